//! The summary of a spatial run (SPEC §5 on six outputs, SPEC-spatial S5/S7), computed from its
//! log, the plant's kinematics, the desired path, the output chart and the bounds — for any
//! driver: tandem's laws, the torque replay, or a user's own [`crate::drive::Drive`].
//!
//! Two stages, both without I/O (the CLI turns the result into `summary.json` and its tables):
//!
//! * [`Derived::new`]: per logged row, `(log, plant, path, chart) → (x_1, ‖z1‖, the distance to
//!   the desired path, grasp wrenches in tool axes, σ_min of the tool Jacobians, joint-limit
//!   margins)`; one forward-kinematics pass per arm and row (`dynamics::spatial::kinematics` on
//!   the logged joint positions).
//! * [`summarize`]: `(run, derived) → SpatialSummary`; a metric the run does not have is `None`
//!   (no `z1` columns for a driver that logs no reference, no NN weights for PD, ...).
//!
//! **Path error.** `z1 = x_1 − x_r` is measured against the reference the law tracks, which the
//! admittance shifts by the measured wrench: a wrong force-sensor convention moves `x_r` and
//! `x_1` together and `z1` does not see it. The path error is the true pose against the
//! **desired** path, `p_o − p_d` (m) and `|Log(R_dᵀ R_o)|` (rad), from the plant's own pose
//! columns; every driver has it.

use nalgebra::{DMatrix, Quaternion, UnitQuaternion, Vector3};

use crate::control::spatial::chart::Chart;
use crate::control::spatial::{AXES, WRENCH_AXES};
use crate::dynamics::spatial::{ChainData, kinematics};
use crate::model::spatial::JointKind;
use crate::plant::spatial::SpatialPlant;
use crate::reference::spatial::path::Se3Path;
use crate::sim::torque_rate::TorqueRate;
use crate::sim::{Log, Outcome};

/// The SPEC-spatial S5 claims hold after this time, s (the CLI's transient window).
pub const TRANSIENT: f64 = 2.0;
/// SPEC-spatial S5: `‖z1_p‖ < 1 mm` after the transient, m.
pub const CLAIM_Z1_P: f64 = 1e-3;
/// SPEC-spatial S5: `|z1_φ| < 1 mrad` after the transient, rad.
pub const CLAIM_Z1_ROT: f64 = 1e-3;

/// What a summary is computed from: the run and the scenario's definitions.
#[derive(Clone, Copy)]
pub struct SpatialRun<'a> {
    /// The simulation outcome (log, fault, drift, margins, events).
    pub outcome: &'a Outcome,
    /// The plant (kinematics of the logged states, the arms' joint limits).
    pub plant: &'a SpatialPlant,
    /// The desired path.
    pub path: &'a Se3Path,
    /// The output chart (centre `c`, `R_ref`) in which `x_1` and the bounds are measured.
    pub chart: &'a Chart,
    /// Output bounds `k_c` on `x_1 = (p − c, φ)`, (m ×3, rad ×3).
    pub k_c: [f64; 6],
    /// Start of the "after the transient" window, s.
    pub transient: f64,
}

/// A column of the log, empty if absent.
fn col<'a>(log: &'a Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// The six columns `group.{axes}`, if all exist with one value per row.
pub fn six<'a>(log: &'a Log, group: &str, axes: &[&str; 6]) -> Option<[&'a [f64]; 6]> {
    let n = log.len();
    let mut out: [&[f64]; 6] = [&[]; 6];
    for (o, a) in out.iter_mut().zip(axes) {
        let c = log.get(&format!("{group}.{a}"))?;
        if c.len() != n {
            return None;
        }
        *o = c;
    }
    Some(out)
}

/// Per-row quantities derived from the log and the plant's kinematics.
pub struct Derived {
    /// Times of the logged rows, s.
    pub t: Vec<f64>,
    /// The true object pose in the output chart, `x_1 = (p − c, φ)` (6 columns; empty if the log
    /// has no object pose).
    pub x1: Vec<Vec<f64>>,
    /// `‖z1_p‖`, m (empty if no `z1` columns).
    pub z1_p: Vec<f64>,
    /// `‖z1_φ‖`, rad.
    pub z1_rot: Vec<f64>,
    /// Per arm, the true grasp wrench in tool axes (6 columns each; empty if not computable).
    pub f_tool: Vec<Vec<Vec<f64>>>,
    /// Per arm, the smallest singular value of the tool Jacobian per row.
    pub sigma: Vec<Vec<f64>>,
    /// Per arm, the smallest distance of a joint to its nearest limit per row (rad or m;
    /// infinite when no joint of the arm has a finite limit).
    pub limit_margin: Vec<Vec<f64>>,
    /// Per joint (all arms), `(q − lower)/(upper − lower)`; `None` for a joint without finite
    /// limits.
    pub q_norm: Vec<Option<Vec<f64>>>,
    /// The closest approach to a joint limit over the logged rows.
    pub closest: Option<Closest>,
    /// True orientation error to the desired path, `|Log(R_dᵀ R_o)|`, rad (empty if the log
    /// has no object pose).
    pub angle_to_desired: Vec<f64>,
    /// True position error to the desired path, `‖p_o − p_d‖`, m (empty if the log has no
    /// object pose).
    pub dist_to_desired: Vec<f64>,
}

/// The closest approach of a joint to one of its limits.
#[derive(Clone, Debug, PartialEq)]
pub struct Closest {
    /// Arm (1-based).
    pub arm: usize,
    /// Global joint index (1-based, as the `q*` columns).
    pub index: usize,
    /// The joint's name in its chain.
    pub name: String,
    /// Distance to the limit (rad, or m for a prismatic joint).
    pub margin: f64,
    /// `rad` or `m`.
    pub unit: &'static str,
    /// `lower` or `upper`.
    pub side: &'static str,
    /// Time of the row, s.
    pub t: f64,
}

/// The smallest singular value of a 6 × n tool Jacobian (`n ≥ 6`: from the eigenvalues of
/// `J Jᵀ`; `n < 6`: of `Jᵀ J`).
pub fn sigma_min(j: &DMatrix<f64>) -> f64 {
    let g = if j.ncols() >= j.nrows() {
        j * j.transpose()
    } else {
        j.transpose() * j
    };
    g.symmetric_eigenvalues()
        .iter()
        .fold(f64::INFINITY, |a, &v| a.min(v))
        .max(0.0)
        .sqrt()
}

impl Derived {
    /// Compute everything from the run's log (one forward-kinematics pass per arm and logged
    /// row).
    pub fn new<'a>(run: impl Into<SpatialRun<'a>>) -> Self {
        let run: SpatialRun<'a> = run.into();
        let log = &run.outcome.log;
        let n = log.len();
        let t = col(log, "t").to_vec();
        let mut d = Derived {
            t,
            x1: Vec::new(),
            z1_p: Vec::new(),
            z1_rot: Vec::new(),
            f_tool: Vec::new(),
            sigma: Vec::new(),
            limit_margin: Vec::new(),
            q_norm: Vec::new(),
            closest: None,
            angle_to_desired: Vec::new(),
            dist_to_desired: Vec::new(),
        };
        if d.t.len() != n {
            return d;
        }
        // The true pose: in the chart, and against the desired path.
        let pose: Option<Vec<&[f64]>> = ["x", "y", "z", "qw", "qx", "qy", "qz"]
            .iter()
            .map(|a| log.get(&format!("x_o.{a}")).filter(|c| c.len() == n))
            .collect();
        if let Some(p) = pose {
            let mut x1 = (0..6).map(|_| Vec::with_capacity(n)).collect::<Vec<_>>();
            for k in 0..n {
                let q = UnitQuaternion::from_quaternion(Quaternion::new(
                    p[3][k], p[4][k], p[5][k], p[6][k],
                ));
                let p_wo = Vector3::new(p[0][k], p[1][k], p[2][k]);
                let x = run.chart.coords(&p_wo, &q);
                for (c, v) in x1.iter_mut().zip(x.iter()) {
                    c.push(*v);
                }
                let s = run.path.sample(d.t[k]);
                d.angle_to_desired
                    .push(crate::geometry::so3::log_quat(&(s.r.inverse() * q)).norm());
                d.dist_to_desired.push((p_wo - s.p).norm());
            }
            d.x1 = x1;
        }
        if let Some(z) = six(log, "z1", &AXES) {
            d.z1_p = (0..n)
                .map(|k| Vector3::new(z[0][k], z[1][k], z[2][k]).norm())
                .collect();
            d.z1_rot = (0..n)
                .map(|k| Vector3::new(z[3][k], z[4][k], z[5][k]).norm())
                .collect();
        }
        // Kinematics per arm and row.
        let arms = run.plant.arms();
        let mut off = 0;
        for (i, arm) in arms.iter().enumerate() {
            let dof = arm.chain.dof();
            let qcols: Vec<&[f64]> = (0..dof)
                .map(|k| col(log, &format!("q{}", off + k + 1)))
                .collect();
            let fw = six(log, &format!("F{}", i + 1), &WRENCH_AXES);
            if qcols.iter().any(|c| c.len() != n) {
                off += dof;
                continue;
            }
            let mut data = ChainData::new(arm);
            let mut qi = vec![0.0; dof];
            let mut ft = (0..6).map(|_| Vec::with_capacity(n)).collect::<Vec<_>>();
            let mut sig = Vec::with_capacity(n);
            for k in 0..n {
                for (v, c) in qi.iter_mut().zip(&qcols) {
                    *v = c[k];
                }
                kinematics(arm, &qi, None, &mut data);
                sig.push(sigma_min(&DMatrix::from_iterator(
                    6,
                    dof,
                    data.J.iter().copied(),
                )));
                if let Some(w) = fw {
                    let r = &data.X_WT.rotation;
                    let fl = r.inverse_transform_vector(&Vector3::new(w[0][k], w[1][k], w[2][k]));
                    let tl = r.inverse_transform_vector(&Vector3::new(w[3][k], w[4][k], w[5][k]));
                    for (c, v) in ft.iter_mut().zip(fl.iter().chain(tl.iter())) {
                        c.push(*v);
                    }
                }
            }
            if fw.is_some() {
                d.f_tool.push(ft);
            }
            d.sigma.push(sig);
            let mut lm = vec![f64::INFINITY; n];
            for (k, j) in arm.chain.joints.iter().enumerate() {
                let (lo, hi) = (j.limits.lower, j.limits.upper);
                let q = qcols[k];
                if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                    d.q_norm.push(None);
                    continue;
                }
                d.q_norm
                    .push(Some(q.iter().map(|v| (v - lo) / (hi - lo)).collect()));
                for (r, v) in q.iter().enumerate() {
                    let (m, side) = if v - lo <= hi - v {
                        (v - lo, "lower")
                    } else {
                        (hi - v, "upper")
                    };
                    lm[r] = lm[r].min(m);
                    if d.closest.as_ref().is_none_or(|c| m < c.margin) {
                        d.closest = Some(Closest {
                            arm: i + 1,
                            index: off + k + 1,
                            name: j.name.clone(),
                            margin: m,
                            unit: if j.kind == JointKind::Prismatic {
                                "m"
                            } else {
                                "rad"
                            },
                            side,
                            t: d.t[r],
                        });
                    }
                }
            }
            d.limit_margin.push(lm);
            off += dof;
        }
        d
    }
}

/// RMS and max of `|v|` over a window of rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RmsMax {
    /// Root mean square.
    pub rms: f64,
    /// Largest absolute value.
    pub max: f64,
}

/// `(rms, max)` of `v` over the rows with `t ≥ from` (`None` when there is none).
pub fn rms_max(t: &[f64], v: &[f64], from: f64) -> Option<RmsMax> {
    let (mut ss, mut mx, mut n) = (0.0, 0.0f64, 0usize);
    for (tk, x) in t.iter().zip(v) {
        if *tk >= from {
            ss += x * x;
            mx = mx.max(x.abs());
            n += 1;
        }
    }
    (n > 0).then(|| RmsMax {
        rms: (ss / n as f64).sqrt(),
        max: mx,
    })
}

/// `(min, max)` of `v` (`None` when empty).
fn range(v: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    v.into_iter().fold(None, |a, x| match a {
        None => Some((x, x)),
        Some((lo, hi)) => Some((lo.min(x), hi.max(x))),
    })
}

/// The first logged time after which `v < limit` for the rest of the run (`None`: never).
pub fn settling(t: &[f64], v: &[f64], limit: f64) -> Option<f64> {
    match v.iter().rposition(|&x| x >= limit) {
        None => t.first().copied(),
        Some(k) if k + 1 < v.len() => Some(t[k + 1]),
        _ => None,
    }
}

/// Norms of the linear and angular halves of six columns, per row.
fn norms(c: &[&[f64]; 6]) -> (Vec<f64>, Vec<f64>) {
    let n = c[0].len();
    (
        (0..n)
            .map(|k| Vector3::new(c[0][k], c[1][k], c[2][k]).norm())
            .collect(),
        (0..n)
            .map(|k| Vector3::new(c[3][k], c[4][k], c[5][k]).norm())
            .collect(),
    )
}

/// One S5 claim: the largest value after the transient against its limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Claim {
    /// The largest value after the transient (`None`: no such rows, or not finite).
    pub max: Option<f64>,
    /// The limit.
    pub limit: f64,
    /// `max < limit`.
    pub pass: bool,
}

impl Claim {
    fn of(v: Option<RmsMax>, limit: f64) -> Self {
        match v {
            Some(RmsMax { max, .. }) if max.is_finite() => Claim {
                max: Some(max),
                limit,
                pass: max < limit,
            },
            _ => Claim {
                max: None,
                limit,
                pass: false,
            },
        }
    }
}

/// The SPEC-spatial S5 claims.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct S5Claims {
    /// `‖z1_p‖ <` [`CLAIM_Z1_P`] after the transient.
    pub z1_p_after: Claim,
    /// `‖z1_φ‖ <` [`CLAIM_Z1_ROT`] after the transient.
    pub z1_rot_after: Claim,
    /// No fault and no control tick on or outside the bound.
    pub completed_without_violation: bool,
    /// All three.
    pub pass: bool,
}

/// Force and torque norms of a wrench over the run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WrenchStats {
    /// RMS of the force norm, N.
    pub force_rms: f64,
    /// Peak of the force norm, N.
    pub force_peak: f64,
    /// RMS of the torque norm, N m.
    pub torque_rms: f64,
    /// Peak of the torque norm, N m.
    pub torque_peak: f64,
}

/// Joint torques over joints and rows.
#[derive(Clone, Debug, PartialEq)]
pub struct JointTorques {
    /// RMS over joints and rows, N m.
    pub rms: f64,
    /// Peak absolute value, N m.
    pub peak: f64,
    /// The column of the peak, e.g. `q3`.
    pub peak_joint: Option<String>,
}

/// The range of one arm's wrench norms over the run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmWrenchRange {
    /// Arm (1-based).
    pub arm: usize,
    /// `[min, max]` of the force norm, N.
    pub force: [f64; 2],
    /// `[min, max]` of the torque norm, N m.
    pub torque: [f64; 2],
}

/// The smallest singular value of one arm's tool Jacobian over the logged rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmaMin {
    /// Arm (1-based).
    pub arm: usize,
    /// The smallest σ (linear rows m/rad, angular rows dimensionless).
    pub sigma_min: f64,
    /// Time of the row, s.
    pub t: f64,
}

/// The summary of a spatial run. `None`: the run does not have that metric (the CLI writes it
/// `null` with a reason).
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialSummary {
    /// Logged rows.
    pub rows: usize,
    /// Start of the "after the transient" window, s.
    pub transient: f64,
    /// The log has `z1` columns (the law logs a reference).
    pub has_z1: bool,
    /// `‖z1_p‖` over the whole run, m.
    pub z1_p: Option<RmsMax>,
    /// `‖z1_p‖` after the transient, m.
    pub z1_p_after: Option<RmsMax>,
    /// `‖z1_φ‖` after the transient, rad.
    pub z1_rot_after: Option<RmsMax>,
    /// Per axis, `max |z1_j|` after the transient (m ×3, rad ×3).
    pub z1_max_abs_after: Option<[f64; 6]>,
    /// First logged time after which `‖z1_p‖ < 1 mm` for the rest of the run, s.
    pub settling_time_1mm: Option<f64>,
    /// The S5 claims.
    pub s5: S5Claims,
    /// The log has an `angle_error` column (the law's orientation error to its reference).
    pub has_angle_error: bool,
    /// The law's `angle_error` after the transient, rad.
    pub orientation_error_after: Option<RmsMax>,
    /// Max of `|Log(R_dᵀ R_o)|` after the transient, rad (as [`Self::path_error_rot_after`]).
    pub orientation_error_to_desired_max_after: Option<f64>,
    /// `‖p_o − p_d‖`, the true position to the desired path, whole run, m.
    pub path_error_p: Option<RmsMax>,
    /// `‖p_o − p_d‖` after the transient, m.
    pub path_error_p_after: Option<RmsMax>,
    /// `|Log(R_dᵀ R_o)|`, the true orientation to the desired path, whole run, rad.
    pub path_error_rot: Option<RmsMax>,
    /// `|Log(R_dᵀ R_o)|` after the transient, rad.
    pub path_error_rot_after: Option<RmsMax>,
    /// Smallest constraint margin `1 − max_j |x_1j|/k_cj`: from every control tick when the law
    /// defines bounds ([`Outcome::min_margin`]), else from the true pose on the logged rows
    /// against the scenario's `k_c`.
    pub min_margin: Option<f64>,
    /// Ticks (or, without the law's bounds, logged rows) on or outside the bound.
    pub violations: u64,
    /// `min_margin` and `violations` come from the logged rows, not the control ticks.
    pub margin_from_rows: bool,
    /// The commanded object wrench `τ`.
    pub wrench: Option<WrenchStats>,
    /// The joint torques.
    pub joint_torque: Option<JointTorques>,
    /// Per arm, the true grasp wrench norms (world axes).
    pub grasp_wrench: Option<Vec<ArmWrenchRange>>,
    /// Per arm, the internal part of the commands.
    pub internal_wrench: Option<Vec<ArmWrenchRange>>,
    /// Smallest switching function `Q` (NN laws).
    pub q_switch_min: Option<f64>,
    /// Final weight norms `‖Ŵ_j‖` (NN laws).
    pub weight_norm_final: Option<[f64; 6]>,
    /// Per output, first time after which `‖Ŵ_j‖` stays within ±10 % of its final value, s.
    pub weight_settling_time: Option<[Option<f64>; 6]>,
    /// The closest approach to a joint limit.
    pub closest_joint_limit: Option<Closest>,
    /// Per arm, the smallest σ of the tool Jacobian.
    pub jacobian_sigma_min: Option<Vec<SigmaMin>>,
    /// Torque rate and chattering of the applied joint torques, from every control tick
    /// ([`Outcome::torque_rate`]).
    pub torque_rate: TorqueRate,
}

/// The summary of a spatial run from its log and the per-row quantities `d` (see
/// [`Derived::new`]).
pub fn summarize<'a>(run: impl Into<SpatialRun<'a>>, d: &Derived) -> SpatialSummary {
    let run: SpatialRun<'a> = run.into();
    let o = run.outcome;
    let log = &o.log;
    let t = &d.t;
    let n = log.len();
    let transient = run.transient;
    let after = |v: &[f64]| rms_max(t, v, transient);
    let whole = |v: &[f64]| rms_max(t, v, f64::NEG_INFINITY);

    // Tracking error z1 = x_1 − x_r.
    let has_z1 = d.z1_p.len() == n && n > 0;
    let (z1_p, z1_p_after, z1_rot_after) = if has_z1 {
        (whole(&d.z1_p), after(&d.z1_p), after(&d.z1_rot))
    } else {
        (None, None, None)
    };
    let z1_max_abs_after = match (six(log, "z1", &AXES), z1_p_after.is_some()) {
        (Some(z), true) => {
            let mut m = [f64::NAN; 6];
            for (j, v) in m.iter_mut().enumerate() {
                *v = after(z[j]).map_or(f64::NAN, |v| v.max);
            }
            Some(m)
        }
        _ => None,
    };
    let settling_time_1mm = if has_z1 {
        settling(t, &d.z1_p, 1e-3)
    } else {
        None
    };
    let (cp, cr) = (
        Claim::of(z1_p_after, CLAIM_Z1_P),
        Claim::of(z1_rot_after, CLAIM_Z1_ROT),
    );
    let clean = o.fault.is_none() && o.violation_ticks == 0;
    let s5 = S5Claims {
        z1_p_after: cp,
        z1_rot_after: cr,
        completed_without_violation: clean,
        pass: cp.pass && cr.pass && clean,
    };

    // The law's orientation error, and the true pose against the desired path.
    let ang = col(log, "angle_error");
    let has_angle_error = ang.len() == n && n > 0;
    let orientation_error_after = if has_angle_error { after(ang) } else { None };
    let orientation_error_to_desired_max_after = (d.angle_to_desired.len() == n)
        .then(|| after(&d.angle_to_desired))
        .flatten()
        .map(|v| v.max);
    let have_pose = d.dist_to_desired.len() == n && n > 0;
    let (path_error_p, path_error_p_after, path_error_rot, path_error_rot_after) = if have_pose {
        (
            whole(&d.dist_to_desired),
            after(&d.dist_to_desired),
            whole(&d.angle_to_desired),
            after(&d.angle_to_desired),
        )
    } else {
        (None, None, None, None)
    };

    // Constraint margin: the law's, else the true pose's on the logged rows.
    let (min_margin, violations, margin_from_rows) = match o.min_margin {
        Some(m) => (Some(m), o.violation_ticks, false),
        None if d.x1.len() == 6 && n > 0 => {
            let (mut mm, mut v) = (f64::INFINITY, 0u64);
            for k in 0..n {
                let m = (0..6).fold(f64::INFINITY, |a, j| {
                    a.min(1.0 - (d.x1[j][k] / run.k_c[j]).abs())
                });
                if m <= 0.0 {
                    v += 1;
                }
                mm = mm.min(m);
            }
            (Some(mm), v, true)
        }
        None => (None, o.violation_ticks, false),
    };

    // The commanded object wrench.
    let wrench = six(log, "tau", &WRENCH_AXES).filter(|_| n > 0).map(|w| {
        let (fv, tv) = norms(&w);
        let (fr, fm) = whole(&fv).map_or((f64::NAN, f64::NAN), |v| (v.rms, v.max));
        let (tr, tm) = whole(&tv).map_or((f64::NAN, f64::NAN), |v| (v.rms, v.max));
        WrenchStats {
            force_rms: fr,
            force_peak: fm,
            torque_rms: tr,
            torque_peak: tm,
        }
    });

    // Joint torques.
    let (mut sq, mut cnt, mut peak, mut peak_at) = (0.0, 0usize, 0.0f64, None);
    for c in &log.columns {
        if let Some(k) = c.name.strip_prefix("tau_q") {
            for v in &c.data {
                sq += v * v;
                cnt += 1;
                if v.abs() > peak || peak_at.is_none() {
                    peak = peak.max(v.abs());
                    peak_at = Some(k.to_string());
                }
            }
        }
    }
    let joint_torque = (cnt > 0).then(|| JointTorques {
        rms: (sq / cnt as f64).sqrt(),
        peak,
        peak_joint: peak_at.map(|k| format!("q{k}")),
    });

    // Grasp wrenches (true, world axes) and the internal part of the commands, per arm.
    let arms = run.plant.arms().len();
    let per_arm = |group: &str| {
        let mut v = Vec::new();
        for i in 1..=arms {
            let Some(w) = six(log, &format!("{group}{i}"), &WRENCH_AXES).filter(|_| n > 0) else {
                continue;
            };
            let (fv, tv) = norms(&w);
            let fr = range(fv.iter().copied()).unwrap_or((f64::NAN, f64::NAN));
            let tr = range(tv.iter().copied()).unwrap_or((f64::NAN, f64::NAN));
            v.push(ArmWrenchRange {
                arm: i,
                force: [fr.0, fr.1],
                torque: [tr.0, tr.1],
            });
        }
        (v.len() == arms && arms > 0).then_some(v)
    };
    let grasp_wrench = per_arm("F");
    let internal_wrench = per_arm("w_int");

    // NN internals (where the law logs them).
    let q = col(log, "Q");
    let q_switch_min =
        (q.len() == n && n > 0).then(|| q.iter().fold(f64::INFINITY, |a, &x| a.min(x)));
    let (weight_norm_final, weight_settling_time) =
        match six(log, "w_norm", &AXES).filter(|_| n > 0) {
            Some(w) => {
                let mut fin = [0.0; 6];
                let mut st = [None; 6];
                for j in 0..6 {
                    let last = w[j][n - 1];
                    fin[j] = last;
                    let band = 0.1 * last.abs();
                    let dev: Vec<f64> = w[j].iter().map(|x| (x - last).abs()).collect();
                    st[j] = if last == 0.0 {
                        None
                    } else {
                        settling(t, &dev, band + f64::MIN_POSITIVE)
                    };
                }
                (Some(fin), Some(st))
            }
            None => (None, None),
        };

    // The smallest σ of each arm's tool Jacobian.
    let jacobian_sigma_min = (d.sigma.len() == arms && n > 0).then(|| {
        d.sigma
            .iter()
            .enumerate()
            .map(|(i, sg)| {
                let k = (0..sg.len()).fold(0, |b, k| if sg[k] < sg[b] { k } else { b });
                SigmaMin {
                    arm: i + 1,
                    sigma_min: sg[k],
                    t: t[k],
                }
            })
            .collect()
    });

    SpatialSummary {
        rows: n,
        transient,
        has_z1,
        z1_p,
        z1_p_after,
        z1_rot_after,
        z1_max_abs_after,
        settling_time_1mm,
        s5,
        has_angle_error,
        orientation_error_after,
        orientation_error_to_desired_max_after,
        path_error_p,
        path_error_p_after,
        path_error_rot,
        path_error_rot_after,
        min_margin,
        violations,
        margin_from_rows,
        wrench,
        joint_torque,
        grasp_wrench,
        internal_wrench,
        q_switch_min,
        weight_norm_final,
        weight_settling_time,
        closest_joint_limit: d.closest.clone(),
        jacobian_sigma_min,
        torque_rate: o.torque_rate.clone(),
    }
}

/// The summary of `run`, with its per-row quantities (computed here).
pub fn summarize_run(run: SpatialRun<'_>) -> (SpatialSummary, Derived) {
    let d = Derived::new(run);
    (summarize(run, &d), d)
}
