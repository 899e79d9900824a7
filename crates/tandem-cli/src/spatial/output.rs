//! What a spatial run writes (issue 9): `timeseries.csv`, `summary.json`, the figures
//! ([`super::figures`]), `viewer.html` and the snapshots, the terminal table, and the files of a
//! comparison ([`write_compare`]).
//!
//! Everything here reads a [`Finished`] run only: the preset or scenario it came from and the law
//! it ran do not matter. Columns a law does not fill (NN weights, `α`, `Q` for PD or computed
//! torque) are left out of the figures and written `null` in the summary, with the reason in its
//! `unavailable` map.
//!
//! Metrics derived from the kinematics (the grasp wrenches in tool axes, the closest approach to
//! a joint limit, the smallest singular value of each arm's tool Jacobian, the true pose in the
//! output chart) are computed here on the **logged rows** (every log period, 10 ms for the
//! presets), with `tandem::dynamics::kinematics` on the logged joint positions.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use nalgebra::{DMatrix, Quaternion, UnitQuaternion, Vector3};
use serde_json::{Map, Value, json};
use tandem::control::spatial::{AXES, WRENCH_AXES};
use tandem::dynamics::{ChainData, kinematics};
use tandem::model::JointKind;
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::se3_path::Se3Path;
use tandem::se3::Chart;
use tandem::sim::{Log, Outcome};

use crate::output::{write_json_atomic, write_text_atomic};
use crate::table::num;
use crate::viewer::{ScalarTrack, scene_from_states, write_snapshots, write_viewer_file};

/// The SPEC-spatial S5 claims hold after this time, s (also the end of the zoomed transient in
/// the figures).
pub const TRANSIENT: f64 = 2.0;
/// SPEC-spatial S5: `‖z1_p‖ < 1 mm` after the transient, m.
pub const CLAIM_Z1_P: f64 = 1e-3;
/// SPEC-spatial S5: `|z1_φ| < 1 mrad` after the transient, rad.
pub const CLAIM_Z1_ROT: f64 = 1e-3;

/// What a spatial run measured, and everything its outputs need.
pub struct Finished {
    /// The simulation outcome (log, fault, drift, margins).
    pub outcome: Outcome,
    /// The plant (kinematics of the logged states, the arms' joint limits).
    pub plant: SpatialPlant,
    /// Box edge lengths, m.
    pub box_size: [f64; 3],
    /// The desired path.
    pub path: Se3Path,
    /// Simulated duration asked for, s.
    pub duration: f64,
    /// The law's short name, the [`super::slug`] of its label: `nn`, `pd`, `pd-gravity`, `ctc`,
    /// `per-arm-pd`, `replay`.
    pub controller: String,
    /// A human label for tables and legends, e.g. `NN`.
    pub label: String,
    /// Output bounds `k_c` on `x_1 = (p − c, φ)`, (m ×3, rad ×3).
    pub k_c: [f64; 6],
    /// The output chart (centre `c`, `R_ref`) the controller used.
    pub chart: Chart,
    /// Set-up warnings.
    pub warnings: Vec<String>,
}

impl Finished {
    /// The run used the NN law (weights, `α`, `Q` exist).
    pub fn nn(&self) -> bool {
        self.controller == "nn"
    }
}

/// A column, or an empty slice when the log has none.
pub(crate) fn col<'a>(log: &'a Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// The six columns `group.{axes}`, if all exist with one value per row.
pub(crate) fn six<'a>(log: &'a Log, group: &str, axes: &[&str; 6]) -> Option<[&'a [f64]; 6]> {
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
    /// True orientation error to the desired path, `|Log(R_dᵀ R_o)|`, rad.
    pub angle_to_desired: Vec<f64>,
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
    /// Compute everything from `f`'s log (one forward-kinematics pass per arm and logged row).
    pub fn new(f: &Finished) -> Self {
        let log = &f.outcome.log;
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
        };
        if d.t.len() != n {
            return d;
        }
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
                let x = f.chart.coords(&Vector3::new(p[0][k], p[1][k], p[2][k]), &q);
                for (c, v) in x1.iter_mut().zip(x.iter()) {
                    c.push(*v);
                }
                let s = f.path.sample(d.t[k]);
                d.angle_to_desired
                    .push(tandem::spatial::so3::log_quat(&(s.r.inverse() * q)).norm());
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
        let arms = f.plant.arms();
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

/// `(rms, max)` of `v` over the rows with `t ≥ from` (`None` when there is none).
fn rms_max(t: &[f64], v: &[f64], from: f64) -> Option<(f64, f64)> {
    let (mut ss, mut mx, mut n) = (0.0, 0.0f64, 0usize);
    for (tk, x) in t.iter().zip(v) {
        if *tk >= from {
            ss += x * x;
            mx = mx.max(x.abs());
            n += 1;
        }
    }
    (n > 0).then(|| ((ss / n as f64).sqrt(), mx))
}

/// `(min, max)` of `v` (`None` when empty).
fn range(v: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    v.into_iter().fold(None, |a, x| match a {
        None => Some((x, x)),
        Some((lo, hi)) => Some((lo.min(x), hi.max(x))),
    })
}

/// The first logged time after which `v < limit` for the rest of the run (`None`: never).
fn settling(t: &[f64], v: &[f64], limit: f64) -> Option<f64> {
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

/// Builds the summary object: values go in with [`Sum::put`]; a missing one is written `null`
/// and its reason recorded in `unavailable`.
struct Sum {
    m: Map<String, Value>,
    why: Map<String, Value>,
}

impl Sum {
    fn put(&mut self, key: &str, v: Value) {
        self.m.insert(key.into(), v);
    }
    /// A number, or `null` with `reason` (also when the number is not finite).
    fn num(&mut self, key: &str, v: Option<f64>, reason: &str) {
        match v {
            Some(x) if x.is_finite() => self.put(key, json!(x)),
            Some(_) => self.null(key, "not a finite number"),
            None => self.null(key, reason),
        }
    }
    fn null(&mut self, key: &str, reason: &str) {
        self.m.insert(key.into(), Value::Null);
        self.why.insert(key.into(), json!(reason));
    }
}

/// A JSON number or `null` (non-finite).
fn jn(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// The content of `summary.json` (SPEC §5 on six outputs and SPEC-spatial S5/S7): metrics with
/// their unit in the key (`_m`, `_rad`, `_s`, `_N`, `_Nm`; no suffix: dimensionless or a count),
/// `null` plus a reason in `unavailable` for a metric this run does not have, and the wall
/// times under `timing` (the only part that differs between two runs of the same scenario).
pub fn summary(scenario: &str, f: &Finished, d: &Derived, output_time: Option<f64>) -> Value {
    let log = &f.outcome.log;
    let o = &f.outcome;
    let t = &d.t;
    let n = log.len();
    let mut s = Sum {
        m: Map::new(),
        why: Map::new(),
    };
    let t_end = t.last().copied();
    let no_rows = "no logged rows";
    let short = format!("the run ends before the transient window (from {TRANSIENT} s)");
    let short = short.as_str();
    s.put("scenario", json!(scenario));
    s.put("label", json!(f.label));
    s.put("controller", json!(f.controller));
    s.put("tandem_version", json!(env!("CARGO_PKG_VERSION")));
    s.put("duration_s", jn(f.duration));
    s.put("t_end_s", jn(o.t_end));
    s.put("rows", json!(n));
    s.put(
        "status",
        json!(if o.fault.is_some() {
            "fault"
        } else {
            "completed"
        }),
    );
    s.put("fault", json!(o.fault.as_ref().map(|e| e.to_string())));
    s.put("warnings", json!(f.warnings));
    s.put(
        "events",
        json!({
            "barrier_hits": o.events.barrier_hits,
            "torque_clips": o.events.torque_clips,
            "non_finite": o.events.non_finite,
            "degenerate": o.events.degenerate,
        }),
    );
    s.put("violation_ticks", json!(o.violation_ticks));
    s.put("regularised", json!(o.regularised));
    s.num(
        "min_margin",
        o.min_margin,
        "the controller defines no output bounds",
    );
    s.put(
        "k_c",
        json!({ "x_m": f.k_c[0], "y_m": f.k_c[1], "z_m": f.k_c[2],
        "rx_rad": f.k_c[3], "ry_rad": f.k_c[4], "rz_rad": f.k_c[5] }),
    );
    s.put("max_drift_m", jn(o.max_drift));
    s.put("max_drift_rad", jn(o.max_drift_rot));
    s.put("transient_s", json!(TRANSIENT));

    // Tracking error z1 = x_1 − x_r.
    let after = |v: &[f64]| rms_max(t, v, TRANSIENT);
    let whole = |v: &[f64]| rms_max(t, v, f64::NEG_INFINITY);
    let have_z1 = d.z1_p.len() == n && n > 0;
    let z1_why = if n == 0 {
        no_rows
    } else {
        "the log has no z1 columns"
    };
    let (zp_w, zp_a, zr_a) = if have_z1 {
        (whole(&d.z1_p), after(&d.z1_p), after(&d.z1_rot))
    } else {
        (None, None, None)
    };
    let why_after = if have_z1 { short } else { z1_why };
    s.num("z1_p_rms_m", zp_w.map(|v| v.0), z1_why);
    s.num("z1_p_max_m", zp_w.map(|v| v.1), z1_why);
    s.num("z1_p_rms_after_2s_m", zp_a.map(|v| v.0), why_after);
    s.num("z1_p_max_after_2s_m", zp_a.map(|v| v.1), why_after);
    s.num("z1_rot_rms_after_2s_rad", zr_a.map(|v| v.0), why_after);
    s.num("z1_rot_max_after_2s_rad", zr_a.map(|v| v.1), why_after);
    let mut per_axis = Map::new();
    if let (Some(z), true) = (six(log, "z1", &AXES), zp_a.is_some()) {
        for (j, a) in AXES.iter().enumerate() {
            let u = if j < 3 { "m" } else { "rad" };
            per_axis.insert(
                format!("{a}_{u}"),
                jn(after(z[j]).map_or(f64::NAN, |v| v.1)),
            );
        }
        s.put("z1_max_abs_after_2s", Value::Object(per_axis));
    } else {
        s.null("z1_max_abs_after_2s", why_after);
    }
    if have_z1 {
        s.num(
            "settling_time_1mm_s",
            settling(t, &d.z1_p, 1e-3),
            "never: ‖z1_p‖ is not below 1 mm for the rest of the run",
        );
    } else {
        s.null("settling_time_1mm_s", z1_why);
    }
    // SPEC-spatial S5 claims.
    let claim = |v: Option<(f64, f64)>, lim: f64, unit: &str| match v {
        Some((_, mx)) if mx.is_finite() => json!({
            format!("max_{unit}"): mx, format!("limit_{unit}"): lim, "pass": mx < lim }),
        _ => json!({ format!("max_{unit}"): null, format!("limit_{unit}"): lim, "pass": false }),
    };
    let (cp, cr) = (
        claim(zp_a, CLAIM_Z1_P, "m"),
        claim(zr_a, CLAIM_Z1_ROT, "rad"),
    );
    let pass = cp["pass"] == json!(true)
        && cr["pass"] == json!(true)
        && o.fault.is_none()
        && o.violation_ticks == 0;
    s.put(
        "s5_claims",
        json!({
            "z1_p_after_2s": cp,
            "z1_rot_after_2s": cr,
            "completed_without_violation": o.fault.is_none() && o.violation_ticks == 0,
            "pass": pass,
        }),
    );

    // Orientation error as an angle.
    let ang = col(log, "angle_error");
    match (ang.len() == n && n > 0).then(|| after(ang)).flatten() {
        Some((r, m)) => {
            s.put("orientation_error_rms_after_2s_rad", jn(r));
            s.put("orientation_error_max_after_2s_rad", jn(m));
        }
        None => {
            let why = if ang.len() == n && n > 0 {
                short
            } else {
                "the log has no angle_error column"
            };
            s.null("orientation_error_rms_after_2s_rad", why);
            s.null("orientation_error_max_after_2s_rad", why);
        }
    }
    s.num(
        "orientation_error_to_desired_max_after_2s_rad",
        (d.angle_to_desired.len() == n)
            .then(|| after(&d.angle_to_desired))
            .flatten()
            .map(|v| v.1),
        if n == 0 { no_rows } else { short },
    );

    // The commanded object wrench.
    match six(log, "tau", &WRENCH_AXES).filter(|_| n > 0) {
        Some(w) => {
            let (fv, tv) = norms(&w);
            let (fr, fm) = whole(&fv).unwrap_or((f64::NAN, f64::NAN));
            let (tr, tm) = whole(&tv).unwrap_or((f64::NAN, f64::NAN));
            s.put("wrench_force_rms_N", jn(fr));
            s.put("wrench_force_peak_N", jn(fm));
            s.put("wrench_torque_rms_Nm", jn(tr));
            s.put("wrench_torque_peak_Nm", jn(tm));
        }
        None => {
            for k in [
                "wrench_force_rms_N",
                "wrench_force_peak_N",
                "wrench_torque_rms_Nm",
                "wrench_torque_peak_Nm",
            ] {
                s.null(
                    k,
                    if n == 0 {
                        no_rows
                    } else {
                        "the log has no commanded wrench (tau.*)"
                    },
                );
            }
        }
    }

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
    if cnt > 0 {
        s.put("joint_torque_rms_Nm", jn((sq / cnt as f64).sqrt()));
        s.put("joint_torque_peak_Nm", jn(peak));
        s.put(
            "joint_torque_peak_joint",
            json!(peak_at.map(|k| format!("q{k}"))),
        );
    } else {
        for k in [
            "joint_torque_rms_Nm",
            "joint_torque_peak_Nm",
            "joint_torque_peak_joint",
        ] {
            s.null(k, no_rows);
        }
    }

    // Grasp wrenches (true, world axes) and the internal part of the commands, per arm.
    let arms = f.plant.arms().len();
    for (key, group, what) in [
        ("grasp_wrench", "F", "grasp wrench"),
        ("internal_wrench", "w_int", "internal wrench"),
    ] {
        let mut v = Vec::new();
        for i in 1..=arms {
            let Some(w) = six(log, &format!("{group}{i}"), &WRENCH_AXES).filter(|_| n > 0) else {
                continue;
            };
            let (fv, tv) = norms(&w);
            let fr = range(fv.iter().copied()).unwrap_or((f64::NAN, f64::NAN));
            let tr = range(tv.iter().copied()).unwrap_or((f64::NAN, f64::NAN));
            v.push(json!({ "arm": i, "force_range_N": [jn(fr.0), jn(fr.1)],
                "torque_range_Nm": [jn(tr.0), jn(tr.1)] }));
        }
        if v.len() == arms && arms > 0 {
            s.put(key, json!(v));
        } else {
            s.null(
                key,
                &if n == 0 {
                    no_rows.to_string()
                } else {
                    format!("the log has no {what} columns ({group}*)")
                },
            );
        }
    }

    // NN internals.
    if f.nn() {
        let q = col(log, "Q");
        s.num(
            "q_switch_min",
            (q.len() == n && n > 0).then(|| q.iter().fold(f64::INFINITY, |a, &x| a.min(x))),
            no_rows,
        );
        match six(log, "w_norm", &AXES).filter(|_| n > 0) {
            Some(w) => {
                let mut fin = Map::new();
                let mut st = Map::new();
                let mut never = false;
                for (j, a) in AXES.iter().enumerate() {
                    let last = w[j][n - 1];
                    fin.insert(a.to_string(), jn(last));
                    let band = 0.1 * last.abs();
                    let dev: Vec<f64> = w[j].iter().map(|x| (x - last).abs()).collect();
                    let ts = if last == 0.0 {
                        None
                    } else {
                        settling(t, &dev, band + f64::MIN_POSITIVE)
                    };
                    never |= ts.is_none();
                    st.insert(a.to_string(), json!(ts));
                }
                s.put("weight_norm_final", Value::Object(fin));
                s.put("weight_settling_time_s", Value::Object(st));
                if never {
                    s.why.insert(
                        "weight_settling_time_s.*".into(),
                        json!("null: that weight norm never stays within ±10 % of its final value"),
                    );
                }
            }
            None => {
                s.null("weight_norm_final", no_rows);
                s.null("weight_settling_time_s", no_rows);
            }
        }
    } else {
        let why = format!("the {} run has no NN weights or switching", f.controller);
        for k in [
            "q_switch_min",
            "weight_norm_final",
            "weight_settling_time_s",
        ] {
            s.null(k, &why);
        }
    }

    // Closest approach to a joint limit; the smallest σ of each arm's tool Jacobian.
    match &d.closest {
        Some(c) => s.put(
            "closest_joint_limit",
            json!({
                "arm": c.arm, "joint": c.name, "column": format!("q{}", c.index),
                "side": c.side, format!("margin_{}", c.unit): c.margin, "t_s": c.t,
            }),
        ),
        None => s.null(
            "closest_joint_limit",
            if n == 0 {
                no_rows
            } else {
                "no joint has finite position limits"
            },
        ),
    }
    if d.sigma.len() == arms && n > 0 {
        let v: Vec<Value> = d
            .sigma
            .iter()
            .enumerate()
            .map(|(i, sg)| {
                let k = (0..sg.len()).fold(0, |b, k| if sg[k] < sg[b] { k } else { b });
                json!({ "arm": i + 1, "sigma_min": jn(sg[k]), "t_s": t[k] })
            })
            .collect();
        s.put("jacobian_sigma_min", json!(v));
        s.put(
            "jacobian_sigma_min_note",
            json!(
                "smallest singular value of each arm's 6×n tool Jacobian (world axes; linear \
                   rows in m/rad, angular rows dimensionless), over the logged rows"
            ),
        );
    } else {
        s.null(
            "jacobian_sigma_min",
            if n == 0 {
                no_rows
            } else {
                "the log has no joint positions"
            },
        );
    }
    let _ = t_end;

    let Sum { mut m, why } = s;
    m.insert("unavailable".into(), Value::Object(why));
    let mut timing = Map::new();
    timing.insert("wall_time_s".into(), jn(o.wall_time));
    timing.insert(
        "real_time_factor".into(),
        jn(if o.wall_time > 0.0 {
            o.t_end / o.wall_time
        } else {
            f64::NAN
        }),
    );
    if let Some(w) = output_time {
        timing.insert("output_time_s".into(), jn(w));
    }
    m.insert("timing".into(), Value::Object(timing));
    Value::Object(m)
}

/// The flat plant states of the logged rows `rows` (`[q; X_WO (p, quaternion w x y z); qd;
/// twist]`, the twist left zero: the viewer draws poses only).
fn states(f: &Finished, rows: &[usize]) -> Vec<Vec<f64>> {
    let log = &f.outcome.log;
    let nq = f.plant.n_q();
    let mut names: Vec<String> = (1..=nq).map(|k| format!("q{k}")).collect();
    names.extend(
        ["x", "y", "z", "qw", "qx", "qy", "qz"]
            .iter()
            .map(|a| format!("x_o.{a}")),
    );
    names.extend((1..=nq).map(|k| format!("qd{k}")));
    let cols: Vec<&[f64]> = names.iter().map(|n| col(log, n)).collect();
    rows.iter()
        .map(|&k| {
            let mut y: Vec<f64> = cols
                .iter()
                .map(|c| c.get(k).copied().unwrap_or(0.0))
                .collect();
            y.resize(2 * nq + 13, 0.0);
            y
        })
        .collect()
}

/// `timeseries.csv`: every logged column (`name [unit]`), then the true pose in the output chart
/// `x_1.*` and the true grasp wrenches in tool axes `F_tool{i}.*` (the `F_meas{i}.*` columns are
/// the wrist sensors' readings, with their noise and filter).
pub fn write_timeseries(path: &Path, f: &Finished, d: &Derived) -> Result<()> {
    let log = &f.outcome.log;
    let mut header: Vec<String> = log
        .columns
        .iter()
        .map(|c| {
            if c.unit.is_empty() {
                c.name.clone()
            } else {
                format!("{} [{}]", c.name, c.unit)
            }
        })
        .collect();
    let mut cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    let n = log.len();
    if d.x1.len() == 6 {
        for (j, a) in AXES.iter().enumerate() {
            header.push(format!("x_1.{a} [{}]", if j < 3 { "m" } else { "rad" }));
            cols.push(&d.x1[j]);
        }
    }
    for (i, w) in d.f_tool.iter().enumerate() {
        for (j, a) in WRENCH_AXES.iter().enumerate() {
            header.push(format!(
                "F_tool{}.{a} [{}]",
                i + 1,
                if j < 3 { "N" } else { "N m" }
            ));
            cols.push(&w[j]);
        }
    }
    if let Some((j, c)) = cols.iter().enumerate().find(|(_, c)| c.len() != n) {
        anyhow::bail!(
            "cannot write {}: column '{}' has {} rows, not {n}",
            path.display(),
            header[j],
            c.len()
        );
    }
    // The shared writer: shortest round-trip numbers, no allocation per row or number.
    crate::output::write_csv(path, &header, &cols)
}

/// Times spent writing, s.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteTimes {
    /// Derived quantities (kinematics on the logged rows).
    pub derive: f64,
    /// `timeseries.csv`.
    pub csv: f64,
    /// `viewer.html` and the snapshots.
    pub viewer: f64,
    /// The figures.
    pub figures: f64,
    /// Wall time of the whole write (the three writers run in parallel).
    pub total: f64,
}

/// Writes every output of `f` into `dir` (the temporary folder of an [`crate::output::OutputDir`]):
/// `timeseries.csv`, `viewer.html` and the snapshots, the figures (if `figures`), then
/// `summary.json` (last, with the write time). The three writers run on their own threads. A
/// figure error is returned as a warning, so that a faulted run still writes what it has.
pub fn write(
    dir: &Path,
    scenario: &str,
    f: &Finished,
    figures: bool,
) -> Result<(Value, WriteTimes, Vec<String>)> {
    let t0 = Instant::now();
    let mut times = WriteTimes::default();
    let d = Derived::new(f);
    times.derive = t0.elapsed().as_secs_f64();
    let mut problems = Vec::new();
    // Three named writer threads (the figure jobs' threads inherit the name): their CPU time
    // shows per thread in a profiler.
    let (csv, viewer, figs) = std::thread::scope(|s| -> Result<_> {
        let spawn = |name: &str| std::thread::Builder::new().name(name.into());
        let csv = spawn("tandem-csv").spawn_scoped(s, || {
            let t = Instant::now();
            write_timeseries(&dir.join("timeseries.csv"), f, &d).map(|_| t.elapsed().as_secs_f64())
        })?;
        let viewer = spawn("tandem-viewer").spawn_scoped(s, || {
            let t = Instant::now();
            write_viewer(dir, scenario, f, &d).map(|_| t.elapsed().as_secs_f64())
        })?;
        let figs = spawn("tandem-figures").spawn_scoped(s, || {
            let t = Instant::now();
            if figures && !f.outcome.log.is_empty() {
                super::figures::run_figures(dir, scenario, f, &d).map(|_| t.elapsed().as_secs_f64())
            } else {
                Ok(0.0)
            }
        })?;
        let panicked = |what: &str| anyhow::anyhow!("the {what} writer panicked");
        Ok((
            csv.join().map_err(|_| panicked("CSV"))?,
            viewer.join().map_err(|_| panicked("viewer"))?,
            figs.join().map_err(|_| panicked("figure"))?,
        ))
    })?;
    times.csv = csv?;
    match viewer {
        Ok(v) => times.viewer = v,
        Err(e) => problems.push(format!("viewer: {e:#}")),
    }
    match figs {
        Ok(v) => times.figures = v,
        Err(e) => problems.push(format!("figures: {e:#}")),
    }
    times.total = t0.elapsed().as_secs_f64();
    let s = summary(scenario, f, &d, Some(times.total));
    write_json_atomic(&dir.join("summary.json"), &s)?;
    Ok((s, times, problems))
}

/// At most this many viewer frames per simulated second (the log has 100 for the presets):
/// smooth playback, and a 60 s run's `viewer.html` stays small and fast to write.
pub const VIEWER_FPS: f64 = 25.0;

fn write_viewer(dir: &Path, scenario: &str, f: &Finished, d: &Derived) -> Result<()> {
    let log = &f.outcome.log;
    let n = d.t.len();
    let dt = if n > 1 { d.t[1] - d.t[0] } else { 1.0 };
    let stride = ((1.0 / VIEWER_FPS / dt).round() as usize).max(1);
    // Every `stride`-th row, and the last one.
    let mut idx: Vec<usize> = (0..n).step_by(stride).collect();
    if n > 0 && idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    let pick = |v: &[f64]| -> Vec<f64> { idx.iter().map(|&k| v[k]).collect() };
    let t = pick(&d.t);
    let st = states(f, &idx);
    let mut scene = scene_from_states(scenario, &f.plant, f.box_size, &t, &st);
    let t_end = t.last().copied().unwrap_or(0.0);
    let n_path = ((t_end * 4.0).ceil() as usize).max(1);
    scene.desired_path = (0..=n_path)
        .map(|k| {
            let p = f.path.sample(t_end * k as f64 / n_path as f64).p;
            [p.x, p.y, p.z]
        })
        .collect();
    let n_arms = f.plant.arms().len();
    let fcols: Option<Vec<[&[f64]; 6]>> = (1..=n_arms)
        .map(|i| six(log, &format!("F{i}"), &WRENCH_AXES))
        .collect();
    if let Some(fcols) = fcols {
        scene.wrenches = idx
            .iter()
            .map(|&k| {
                fcols
                    .iter()
                    .map(|c| [c[0][k], c[1][k], c[2][k], c[3][k], c[4][k], c[5][k]])
                    .collect()
            })
            .collect();
    }
    if d.z1_p.len() == n {
        scene
            .scalars
            .push(ScalarTrack::new("error |z1_p|", "m", pick(&d.z1_p)));
    }
    let m = col(log, "margin");
    if m.len() == n {
        scene.scalars.push(ScalarTrack::new("margin", "", pick(m)));
    }
    write_viewer_file(&scene, dir)?;
    write_snapshots(&scene, dir)?;
    Ok(())
}

/// The table rows of one or more runs' summaries: `(metric, one cell per run)`.
pub fn rows(runs: &[(&str, &Value)]) -> Vec<(String, Vec<String>)> {
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    let mut row = |name: &str, f: &dyn Fn(&Value) -> String| {
        out.push((name.to_string(), runs.iter().map(|(_, s)| f(s)).collect()));
    };
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mm = |v: &Value| match v.as_f64() {
        Some(x) => format!("{} mm", num(x * 1e3, 3)),
        None => "—".into(),
    };
    let mrad = |v: &Value| match v.as_f64() {
        Some(x) => format!("{} mrad", num(x * 1e3, 3)),
        None => "—".into(),
    };
    let pass = |v: &Value| {
        let missing = v
            .as_object()
            .is_some_and(|m| m.iter().any(|(k, x)| k.starts_with("max") && x.is_null()));
        if v["pass"] == json!(true) {
            "pass"
        } else if missing {
            "run too short"
        } else {
            "FAIL"
        }
    };
    row("status", &|s| match s["fault"].as_str() {
        None => s["status"].as_str().unwrap_or("?").to_string(),
        Some(m) => format!("FAULT: {}", m.chars().take(60).collect::<String>()),
    });
    row("simulated time", &|s| {
        format!("{} s", num(f(&s["t_end_s"]), 4))
    });
    row("RMS ‖z1_p‖, whole run", &|s| mm(&s["z1_p_rms_m"]));
    row("max ‖z1_p‖ after 2 s (S5: < 1 mm)", &|s| {
        let c = &s["s5_claims"]["z1_p_after_2s"];
        format!("{} ({})", mm(&c["max_m"]), pass(c))
    });
    row("max ‖z1_φ‖ after 2 s (S5: < 1 mrad)", &|s| {
        let c = &s["s5_claims"]["z1_rot_after_2s"];
        format!("{} ({})", mrad(&c["max_rad"]), pass(c))
    });
    row(
        "settling to ‖z1_p‖ < 1 mm",
        &|s| match s["settling_time_1mm_s"].as_f64() {
            Some(x) => format!("{} s", num(x, 3)),
            None => "never".into(),
        },
    );
    row("max orientation error after 2 s (to x_r / to x_d)", &|s| {
        let r = &s["orientation_error_max_after_2s_rad"];
        let d = &s["orientation_error_to_desired_max_after_2s_rad"];
        match (r.as_f64(), d.as_f64()) {
            (Some(r), Some(d)) => format!("{} / {} mrad", num(r * 1e3, 3), num(d * 1e3, 3)),
            _ => "—".into(),
        }
    });
    row("min constraint margin", &|s| num(f(&s["min_margin"]), 3));
    row("bound violations (control ticks)", &|s| {
        s["violation_ticks"].to_string()
    });
    row("constraint drift", &|s| {
        format!(
            "{} m / {} rad",
            num(f(&s["max_drift_m"]), 2),
            num(f(&s["max_drift_rad"]), 2)
        )
    });
    row("RMS / peak object force ‖f‖", &|s| {
        format!(
            "{} / {} N",
            num(f(&s["wrench_force_rms_N"]), 3),
            num(f(&s["wrench_force_peak_N"]), 3)
        )
    });
    row("RMS / peak joint torque", &|s| {
        format!(
            "{} / {} N m",
            num(f(&s["joint_torque_rms_Nm"]), 3),
            num(f(&s["joint_torque_peak_Nm"]), 3)
        )
    });
    let ranges = |key: &'static str| {
        move |s: &Value| match s[key].as_array() {
            Some(a) => {
                a.iter()
                    .map(|w| {
                        format!(
                            "{}…{}",
                            num(f(&w["force_range_N"][0]), 3),
                            num(f(&w["force_range_N"][1]), 3)
                        )
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
                    + " N"
            }
            None => "—".into(),
        }
    };
    row("grasp force ‖f_i‖ range per arm", &ranges("grasp_wrench"));
    row("internal force range per arm", &ranges("internal_wrench"));
    row("closest joint limit", &|s| {
        let c = &s["closest_joint_limit"];
        if c.is_null() {
            return "—".into();
        }
        let (m, u) = match c.get("margin_rad") {
            Some(m) => (f(m), "rad"),
            None => (f(&c["margin_m"]), "m"),
        };
        format!(
            "{} {u} ({}, arm {}, t = {} s)",
            num(m, 3),
            c["joint"].as_str().unwrap_or("?"),
            c["arm"],
            num(f(&c["t_s"]), 3)
        )
    });
    row(
        "min σ of the tool Jacobians",
        &|s| match s["jacobian_sigma_min"].as_array() {
            Some(a) => a
                .iter()
                .map(|v| num(f(&v["sigma_min"]), 3))
                .collect::<Vec<_>>()
                .join(", "),
            None => "—".into(),
        },
    );
    if runs.iter().any(|(_, s)| s["controller"] == "nn") {
        row("min Q / weight-norm settling (last)", &|s| {
            if s["controller"] != "nn" {
                return "—".into();
            }
            let last = s["weight_settling_time_s"]
                .as_object()
                .map(|m| {
                    let v: Vec<Option<f64>> = m.values().map(Value::as_f64).collect();
                    if v.iter().any(Option::is_none) {
                        "never".to_string()
                    } else {
                        let x = v.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
                        format!("{} s", num(x, 3))
                    }
                })
                .unwrap_or_else(|| "—".into());
            format!("{} / {last}", num(f(&s["q_switch_min"]), 3))
        });
    }
    row("barrier hits / torque clips (ticks)", &|s| {
        format!(
            "{} / {}",
            s["events"]["barrier_hits"], s["events"]["torque_clips"]
        )
    });
    row("wall time (real-time factor)", &|s| {
        format!(
            "{} s ({}×)",
            num(f(&s["timing"]["wall_time_s"]), 3),
            num(f(&s["timing"]["real_time_factor"]), 3)
        )
    });
    out
}

/// The table as aligned text (one column per run; a header line when there are several).
pub fn text(runs: &[(&str, &Value)]) -> String {
    let rows = rows(runs);
    let w0 = rows
        .iter()
        .map(|(n, _)| n.chars().count())
        .max()
        .unwrap_or(0);
    let widths: Vec<usize> = (0..runs.len())
        .map(|i| {
            rows.iter()
                .map(|(_, c)| c[i].chars().count())
                .chain(std::iter::once(runs[i].0.chars().count()))
                .max()
                .unwrap_or(0)
        })
        .collect();
    let pad = |s: &str, w: usize| format!("{s}{}", " ".repeat(w.saturating_sub(s.chars().count())));
    let mut out = String::new();
    let mut line = |name: &str, cells: Vec<&str>| {
        let mut l = pad(name, w0);
        for (i, c) in cells.iter().enumerate() {
            l.push_str("  ");
            l.push_str(&pad(c, widths[i]));
        }
        out.push_str(l.trim_end());
        out.push('\n');
    };
    if runs.len() > 1 {
        line("", runs.iter().map(|(n, _)| *n).collect());
    }
    for (name, cells) in &rows {
        line(name, cells.iter().map(String::as_str).collect());
    }
    out
}

/// The table in Markdown.
pub fn markdown(runs: &[(&str, &Value)]) -> String {
    let esc = |s: &str| s.replace('|', "\\|");
    let mut out = String::from("| metric |");
    for (name, _) in runs {
        out.push_str(&format!(" {} |", esc(name)));
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(runs.len()));
    out.push('\n');
    for (name, cells) in rows(runs) {
        out.push_str(&format!("| {} |", esc(&name)));
        for c in cells {
            out.push_str(&format!(" {} |", esc(&c)));
        }
        out.push('\n');
    }
    out
}

/// Writes a spatial comparison into `dir` (a temporary folder): one sub-folder per run with its
/// own outputs ([`write()`]), the overlay figures ([`super::figures::compare_figures`]),
/// `report.md` (side-by-side table, figures) and `summary.json` (the runs' summaries keyed by
/// their label). Returns the summaries and the problems (figure errors) as warnings.
pub fn write_compare(
    dir: &Path,
    name: &str,
    runs: &[(&str, &Finished)],
    figures: bool,
) -> Result<(Vec<Value>, Vec<String>)> {
    let mut problems = Vec::new();
    let mut summaries = Vec::new();
    let mut slugs: Vec<String> = Vec::new();
    for (label, f) in runs {
        let mut s = super::slug(label);
        let base = s.clone();
        let mut k = 2;
        while slugs.contains(&s) {
            s = format!("{base}-{k}");
            k += 1;
        }
        let sub = dir.join(&s);
        std::fs::create_dir_all(&sub).with_context(|| format!("creating {}", sub.display()))?;
        let (v, _, p) = write(&sub, name, f, figures)?;
        problems.extend(p.into_iter().map(|p| format!("{s}: {p}")));
        summaries.push(v);
        slugs.push(s);
    }
    let mut stems = Vec::new();
    if figures {
        match super::figures::compare_figures(dir, name, runs) {
            Ok(s) => stems = s,
            Err(e) => problems.push(format!("comparison figures: {e:#}")),
        }
    }
    let cols: Vec<(&str, &Value)> = runs
        .iter()
        .zip(&summaries)
        .map(|((l, _), s)| (*l, s))
        .collect();
    let mut md = format!(
        "# Controller comparison: spatial scenario `{name}`\n\n\
         Every controller starts from the same state and runs the same path, disturbance and \
         duration. Generated by tandem {}.\n\n## Summary\n\n",
        env!("CARGO_PKG_VERSION")
    );
    md.push_str(&markdown(&cols));
    md.push_str(
        "\n`z1 = x_1 − x_r` is the tracking error on the six outputs (position `z1_p`, \
         orientation `z1_φ`) against the admittance reference; the SPEC-spatial S5 claims are \
         measured after 2 s. The margin is `1 − max_j |x_1j|/k_cj` (negative: a bound is \
         violated). Wall times vary from run to run; everything else is deterministic.\n\n",
    );
    let captions = [
        (
            "compare_z1",
            "Tracking error norms ‖z1_p‖ and ‖z1_φ‖, whole run and after the transient",
        ),
        (
            "compare_wrench",
            "Commanded object wrench ‖f‖ and ‖τ‖ (one column per controller)",
        ),
        (
            "compare_margin",
            "Constraint margin 1 − max_j |x_1j|/k_cj (negative: bound violated)",
        ),
    ];
    if !stems.is_empty() {
        md.push_str("## Figures\n\n");
        for (stem, cap) in captions {
            if stems.iter().any(|s| s == stem) {
                md.push_str(&format!(
                    "### {cap}\n\n![{cap}]({stem}.png)\n\n[SVG]({stem}.svg)\n\n"
                ));
            }
        }
    }
    md.push_str("## Per-controller outputs\n\n");
    for ((label, _), s) in runs.iter().zip(&slugs) {
        md.push_str(&format!(
            "- **{label}**: [`{s}/`]({s}/) — `timeseries.csv`, `summary.json`, `viewer.html`{}\n",
            if figures { ", figures" } else { "" }
        ));
    }
    write_text_atomic(&dir.join("report.md"), &md)?;
    let mut all = Map::new();
    all.insert("scenario".into(), json!(name));
    all.insert("tandem_version".into(), json!(env!("CARGO_PKG_VERSION")));
    let mut by = Map::new();
    for (((label, _), s), v) in runs.iter().zip(&slugs).zip(&summaries) {
        let mut v = v.clone();
        if let Value::Object(m) = &mut v {
            m.insert("folder".into(), json!(s));
        }
        by.insert((*label).to_string(), v);
    }
    all.insert("runs".into(), Value::Object(by));
    write_json_atomic(&dir.join("summary.json"), &Value::Object(all))?;
    Ok((summaries, problems))
}
