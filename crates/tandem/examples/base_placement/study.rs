//! The base-placement study of SPEC-spatial S6 (`docs/base-placement.md`), shared by the
//! `base_placement` example and `tests/base_placement.rs`.
//!
//! For a two-arm set-up the S6 path (`Se3Path::spec_s6()`, one 60 s lap) is followed by inverse
//! kinematics with continuation: at each sample `SpatialPlant::initial_state` is called with the
//! previous sample's joint angles as the guess (Newton–Raphson with damped least squares: it
//! converges to the nearest solution, so it stays on the branch it starts on, and for a 7-DOF arm
//! it fixes the redundancy by the minimum-norm step). Along the lap it measures, per arm: the
//! singular values of the 6 × n tool Jacobian (`[ṗ_T; ω_T]`, m and rad mixed, as SPEC-spatial
//! S6), `|sin q3|` and `|sin q5|`, each joint's travel, the static holding torques
//! (`SpatialPlant::holding_torques`) against the URDF effort limits, the distance to the joint
//! limits; and between the arms the closest approach of their link centre lines, and the lowest
//! moving point above the table.
//!
//! The arms' "link centre lines" are the polyline base origin → joint-frame origins → the last
//! joint frame (the wrist); the last segment to the tool frame (flange, hand) is left out of the
//! separation because the grasp fixes it (the tools are the grasp spacing apart by construction:
//! 0.4 m for the end-face grasps, 0.24 m for the Franka preset's top-face ones). The height is
//! the lowest of the joint-frame origins from the third joint on and the tool origin (the first
//! two sit on the pedestal at a fixed height). No link radii: these are centre-line distances.

#![allow(dead_code)] // each of the example and the test uses a part

use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::math::random::SplitMix64;
use tandem::model::spatial::SpatialArm;
use tandem::nalgebra::{Isometry3, Vector3, Vector6};
use tandem::plant::spatial::{SpatialPlant, SpatialPlantParams};
use tandem::reference::spatial::path::Se3Path;

/// Lap length of the S6 path, s (ω = 2π/60).
pub const LAP: f64 = 60.0;

/// Which UR5 solution branch a configuration is on (SPEC-spatial S6 wants all three `true`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Branch {
    /// The arm reaches toward its tool (shoulder toward the box), not back over itself.
    pub shoulder_forward: bool,
    /// The elbow is above the shoulder–wrist line.
    pub elbow_up: bool,
    /// `sin q5 > 0`.
    pub wrist_positive: bool,
}

impl Branch {
    /// The S6 branch.
    pub const S6: Branch = Branch {
        shoulder_forward: true,
        elbow_up: true,
        wrist_positive: true,
    };
}

/// The branch of a UR5-class arm at `q`, read geometrically from the kinematics (so it does not
/// depend on the joint-angle conventions): the reach direction is where the elbow points with
/// `q2 = 0`; the elbow is up when it lies above the straight line from the shoulder (body 1
/// origin) to the wrist (body 3 origin).
pub fn ur5_branch(arm: &SpatialArm, q: &[f64], d: &mut ChainData) -> Branch {
    let mut q0 = q.to_vec();
    q0[1] = 0.0;
    spatial::kinematics(arm, &q0, None, d);
    let s = d.X_WL[1].translation.vector;
    let reach = d.X_WL[2].translation.vector - s;
    spatial::kinematics(arm, q, None, d);
    let base = arm.base.translation.vector;
    let tool = d.X_WT.translation.vector - base;
    let shoulder_forward = reach.x * tool.x + reach.y * tool.y > 0.0;
    let e = d.X_WL[2].translation.vector;
    let w = d.X_WL[3].translation.vector;
    let sw = w - s;
    let t = (e - s).dot(&sw) / sw.norm_squared();
    let elbow_up = e.z > s.z + t * sw.z;
    Branch {
        shoulder_forward,
        elbow_up,
        wrist_positive: q[4].sin() > 0.0,
    }
}

/// What one lap measured, per arm `[arm 1, arm 2]` where it says so.
#[derive(Clone, Debug)]
pub struct Lap {
    /// `None` when every sample solved (and, for the UR5, stayed on the S6 branch); otherwise
    /// why and when it stopped. The other fields cover the samples before that.
    pub failure: Option<String>,
    /// Samples solved.
    pub samples: usize,
    /// Smallest `σ_min` of the tool Jacobian over the lap.
    pub sigma_min: [f64; 2],
    /// Largest `σ_max / σ_min`.
    pub cond_max: [f64; 2],
    /// Smallest `|sin q3|` and `|sin q5|`.
    pub sin_q3_min: [f64; 2],
    pub sin_q5_min: [f64; 2],
    /// Largest joint travel (max − min over the lap) of any joint, rad, and which joint (0-based).
    pub travel_max: [f64; 2],
    pub travel_joint: [usize; 2],
    /// Largest `|τ_k| / effort_k` of the static holding torques, and which joint (0-based).
    pub torque_ratio_max: [f64; 2],
    pub torque_joint: [usize; 2],
    /// Smallest distance to a joint limit, rad, and which joint (0-based).
    pub limit_margin_min: [f64; 2],
    pub limit_joint: [usize; 2],
    /// Closest approach of the two arms' link centre lines, m.
    pub separation_min: f64,
    /// Lowest moving arm point above the table (z = 0), m.
    pub height_min: f64,
    /// Joint angles at every solved sample (stacked, n_q each).
    pub q: Vec<Vec<f64>>,
}

/// Singular values of the 6 × n tool Jacobian in `d`, sorted descending.
pub fn singular_values(d: &ChainData) -> Vec<f64> {
    let j = tandem::nalgebra::DMatrix::from_column_slice(6, d.J.ncols(), d.J.as_slice());
    let mut s: Vec<f64> = j.singular_values().iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    s
}

// The link centre lines and their closest approach are the library's placement scan's
// (`tandem place`): the polyline base origin → joint-frame origins → tool origin without its
// last segment, and their closest approach by Ericson's segment distance.
pub use tandem::plant::spatial::placement::{polyline, polyline_distance};

/// The desired object pose of the S6 path at `t`.
pub fn s6_pose(path: &Se3Path, t: f64) -> Isometry3<f64> {
    let s = path.sample(t);
    Isometry3::from_parts(s.p.into(), s.r)
}

/// Follow one lap of `path` sampled every `dt` s from the solution at `q_start` (which must
/// already solve the pose at `t = 0`). `ur5_branch_check`: stop when a UR5 arm leaves the S6
/// branch. Measures everything in [`Lap`].
pub fn follow_lap(
    params: &SpatialPlantParams,
    path: &Se3Path,
    q_start: &[f64],
    dt: f64,
    ur5_branch_check: bool,
) -> Lap {
    let plant = SpatialPlant::new(params).expect("valid set-up");
    let n_q = plant.n_q();
    let mut ws = plant.workspace();
    let mut data: Vec<ChainData> = plant.arms().iter().map(ChainData::new).collect();
    let mut tau = vec![0.0; n_q];
    let mut lap = Lap {
        failure: None,
        samples: 0,
        sigma_min: [f64::INFINITY; 2],
        cond_max: [0.0; 2],
        sin_q3_min: [f64::INFINITY; 2],
        sin_q5_min: [f64::INFINITY; 2],
        travel_max: [0.0; 2],
        travel_joint: [0; 2],
        torque_ratio_max: [0.0; 2],
        torque_joint: [0; 2],
        limit_margin_min: [f64::INFINITY; 2],
        limit_joint: [0; 2],
        separation_min: f64::INFINITY,
        height_min: f64::INFINITY,
        q: Vec::new(),
    };
    let steps = (LAP / dt).round() as usize;
    let mut guess = q_start.to_vec();
    for k in 0..=steps {
        let t = k as f64 * dt;
        let x_wo = s6_pose(path, t);
        let y = match plant.initial_state(&x_wo, &Vector6::zeros(), &guess) {
            Ok(y) => y,
            Err(e) => {
                lap.failure = Some(format!("t = {t:.1} s: {e}"));
                break;
            }
        };
        let q = &y[..n_q];
        if ur5_branch_check {
            for i in 0..2 {
                let s = plant.offset(i);
                let b = ur5_branch(&plant.arms()[i], &q[s..s + 6], &mut data[i]);
                if b != Branch::S6 {
                    lap.failure = Some(format!(
                        "t = {t:.1} s: arm {} off the S6 branch ({b:?})",
                        i + 1
                    ));
                }
            }
            if lap.failure.is_some() {
                break;
            }
        }
        plant.holding_torques(&y, &mut ws, &mut tau);
        let mut lines = Vec::new();
        for (i, arm) in plant.arms().iter().enumerate() {
            let n = arm.chain.dof();
            let s = plant.offset(i);
            let qi = &q[s..s + n];
            let d = &mut data[i];
            spatial::kinematics(arm, qi, None, d);
            let sv = singular_values(d);
            let (smax, smin) = (sv[0], sv[5]);
            lap.sigma_min[i] = lap.sigma_min[i].min(smin);
            lap.cond_max[i] = lap.cond_max[i].max(smax / smin);
            lap.sin_q3_min[i] = lap.sin_q3_min[i].min(qi[2].sin().abs());
            lap.sin_q5_min[i] = lap.sin_q5_min[i].min(qi[4].sin().abs());
            for (k, j) in arm.chain.joints.iter().enumerate() {
                let r = (tau[s + k] / j.limits.effort).abs();
                if r > lap.torque_ratio_max[i] {
                    lap.torque_ratio_max[i] = r;
                    lap.torque_joint[i] = k;
                }
                let m = (qi[k] - j.limits.lower).min(j.limits.upper - qi[k]);
                if m < lap.limit_margin_min[i] {
                    lap.limit_margin_min[i] = m;
                    lap.limit_joint[i] = k;
                }
            }
            for x in d.X_WL.iter().skip(2) {
                lap.height_min = lap.height_min.min(x.translation.z);
            }
            lap.height_min = lap.height_min.min(d.X_WT.translation.z);
            lines.push(polyline(arm, d));
        }
        lap.separation_min = lap
            .separation_min
            .min(polyline_distance(&lines[0], &lines[1]));
        lap.q.push(q.to_vec());
        lap.samples += 1;
        guess.copy_from_slice(q);
    }
    for i in 0..2 {
        let s = plant.offset(i);
        let n = plant.arms()[i].chain.dof();
        for k in 0..n {
            let (lo, hi) = lap
                .q
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[s + k]), hi.max(q[s + k]))
                });
            if hi - lo > lap.travel_max[i] {
                lap.travel_max[i] = hi - lo;
                lap.travel_joint[i] = k;
            }
        }
    }
    lap
}

/// The S6 UR5 set-up ([`tandem::presets::dual_ur5`]) with the bases at `(∓d/2, 0, 0)`.
pub fn dual_ur5_at(d: f64) -> SpatialPlantParams {
    let mut p = tandem::presets::dual_ur5().params;
    p.arms[0] = tandem::presets::ur5_arm(-d / 2.0, 0.0, 0.0);
    p.arms[1] = tandem::presets::ur5_arm(d / 2.0, 0.0, std::f64::consts::PI);
    p
}

/// One row of the UR5 sweep.
pub struct Ur5Row {
    /// Base separation, m.
    pub d: f64,
    /// The lap (its `failure` says whether the S6 branch exists all lap).
    pub lap: Lap,
}

/// The UR5 sweep over base separations `ds` (any order): the start solution at each `d` is
/// continued from the neighbouring `d` toward 1.40 m (where the fixture's S6 angles are the
/// guess), so that every row starts on the same branch as the S6 start; a row whose start is
/// off that branch keeps the last good start as the next row's guess.
pub fn ur5_sweep(ds: &[f64], dt: f64) -> Vec<Ur5Row> {
    let path = Se3Path::spec_s6();
    let x0 = s6_pose(&path, 0.0);
    let d_ref = 1.40;
    let mut sorted: Vec<f64> = ds.to_vec();
    sorted.sort_by(f64::total_cmp);
    let up: Vec<f64> = sorted.iter().copied().filter(|&d| d >= d_ref).collect();
    let down: Vec<f64> = sorted
        .iter()
        .rev()
        .copied()
        .filter(|&d| d < d_ref)
        .collect();
    let mut rows = Vec::new();
    for side in [up, down] {
        let mut guess = tandem::presets::dual_ur5().q_guess;
        for d in side {
            let params = dual_ur5_at(d);
            let plant = SpatialPlant::new(&params).expect("valid set-up");
            let lap = match plant.initial_state(&x0, &Vector6::zeros(), &guess) {
                Ok(y) => {
                    let q0 = y[..plant.n_q()].to_vec();
                    let lap = follow_lap(&params, &path, &q0, dt, true);
                    if lap.samples > 0 {
                        guess = q0;
                    }
                    lap
                }
                Err(e) => Lap {
                    failure: Some(format!("t = 0.0 s: {e}")),
                    ..empty_lap()
                },
            };
            rows.push(Ur5Row { d, lap });
        }
    }
    rows.sort_by(|a, b| a.d.total_cmp(&b.d));
    rows
}

fn empty_lap() -> Lap {
    Lap {
        failure: None,
        samples: 0,
        sigma_min: [f64::NAN; 2],
        cond_max: [f64::NAN; 2],
        sin_q3_min: [f64::NAN; 2],
        sin_q5_min: [f64::NAN; 2],
        travel_max: [f64::NAN; 2],
        travel_joint: [0; 2],
        torque_ratio_max: [f64::NAN; 2],
        torque_joint: [0; 2],
        limit_margin_min: [f64::NAN; 2],
        limit_joint: [0; 2],
        separation_min: f64::NAN,
        height_min: f64::NAN,
        q: Vec::new(),
    }
}

// ---------------------------------------------------------------------------------------------
// Franka: grasps, in-limit IK search, the redundancy.

/// How the Franka pair holds the box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrankaGrasp {
    /// The preset's: on the top face at `(∓0.12, 0, 0.1)`, tool z down (`presets::dual_franka`).
    Top,
    /// The UR5's end-face grasps at `(∓0.2, 0, 0)` (tool z into the box), turned about the tool
    /// z axis by `roll` rad (0 = tool x down, as the UR5).
    End { roll: f64 },
}

/// The Franka pair with bases at `(∓d/2, 0, 0)` and the given grasp.
pub fn dual_franka_at(d: f64, grasp: FrankaGrasp) -> SpatialPlantParams {
    let mut p = tandem::presets::dual_franka().params;
    p.arms[0] = tandem::presets::franka_arm(-d / 2.0, 0.0, 0.0);
    p.arms[1] = tandem::presets::franka_arm(d / 2.0, 0.0, std::f64::consts::PI);
    if let FrankaGrasp::End { roll } = grasp {
        let ur = tandem::presets::dual_ur5().params.grasps;
        let turn = Isometry3::rotation(Vector3::z() * roll);
        p.grasps = vec![ur[0] * turn, ur[1] * turn];
    }
    p
}

/// Damped least-squares inverse kinematics of one arm onto `target` from `q` in place, each
/// step clamped into the joint limits (so it only finds solutions inside them), with joint
/// `locked` (if any) held at its value. `true` when the residual falls below 1e-10 m and rad.
pub fn ik_in_limits(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    q: &mut [f64],
    locked: Option<usize>,
    d: &mut ChainData,
) -> bool {
    ik_clamped(arm, target, q, locked, d, true)
}

/// [`ik_in_limits`], or with `limits == false` clamped to `±2π` only (any solution, to see which
/// limits the solutions break).
fn ik_clamped(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    q: &mut [f64],
    locked: Option<usize>,
    d: &mut ChainData,
    limits: bool,
) -> bool {
    let n = q.len();
    let tau = std::f64::consts::TAU;
    let lim: Vec<(f64, f64)> = arm
        .chain
        .joints
        .iter()
        .map(|j| {
            if limits {
                (j.limits.lower, j.limits.upper)
            } else {
                (-tau, tau)
            }
        })
        .collect();
    for _ in 0..300 {
        spatial::kinematics(arm, q, None, d);
        let dp = target.translation.vector - d.X_WT.translation.vector;
        let dr = (target.rotation * d.X_WT.rotation.inverse()).scaled_axis();
        if dp.norm() < 1e-10 && dr.norm() < 1e-10 {
            return true;
        }
        let e = Vector6::new(dp.x, dp.y, dp.z, dr.x, dr.y, dr.z);
        let mut j = d.J.clone();
        if let Some(l) = locked {
            j.column_mut(l).fill(0.0);
        }
        let lambda2 = (1e-2 * e.norm()).clamp(1e-12, 1e-2);
        let mut a = &j * j.transpose();
        for k in 0..6 {
            a[(k, k)] += lambda2;
        }
        let Some(ch) = a.cholesky() else {
            return false;
        };
        let mut step = j.transpose() * ch.solve(&e);
        let sn = step.norm();
        if sn > 0.3 {
            step *= 0.3 / sn;
        }
        for k in 0..n {
            q[k] = (q[k] + step[k]).clamp(lim[k].0, lim[k].1);
        }
    }
    false
}

/// In-limit IK solutions of one arm onto `target` from `tries` random starts inside the limits
/// (seeded), joint `locked` held at `q_locked`. Returns the solutions found (possibly repeated).
pub fn ik_search(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    tries: usize,
    locked: Option<(usize, f64)>,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut rng = SplitMix64(seed);
    let mut d = ChainData::new(arm);
    let mut found = Vec::new();
    for _ in 0..tries {
        let mut q: Vec<f64> = arm
            .chain
            .joints
            .iter()
            .map(|j| rng.range(j.limits.lower, j.limits.upper))
            .collect();
        if let Some((l, v)) = locked {
            q[l] = v;
        }
        if ik_in_limits(arm, target, &mut q, locked.map(|l| l.0), &mut d) {
            found.push(q);
        }
    }
    found
}

/// Solutions of one arm onto `target` ignoring the joint limits (angles within ±2π), from
/// `tries` random starts inside the limits: for each, the joints (0-based) outside their limits,
/// the largest excess over a limit, rad, and the solution.
pub fn limit_violations(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    tries: usize,
    seed: u64,
) -> Vec<(Vec<usize>, f64, Vec<f64>)> {
    let mut rng = SplitMix64(seed);
    let mut d = ChainData::new(arm);
    let mut out = Vec::new();
    for _ in 0..tries {
        let mut q: Vec<f64> = arm
            .chain
            .joints
            .iter()
            .map(|j| rng.range(j.limits.lower, j.limits.upper))
            .collect();
        if ik_clamped(arm, target, &mut q, None, &mut d, false) {
            let tau = std::f64::consts::TAU;
            let mut bad = Vec::new();
            let mut worst = 0.0f64;
            for (k, j) in arm.chain.joints.iter().enumerate() {
                // The excess of the 2π-equivalent of the angle closest to the limits.
                let excess = [-tau, 0.0, tau]
                    .iter()
                    .map(|s| {
                        let v = q[k] + s;
                        (j.limits.lower - v).max(v - j.limits.upper).max(0.0)
                    })
                    .fold(f64::INFINITY, f64::min);
                if excess > 0.0 {
                    bad.push(k);
                    worst = worst.max(excess);
                }
            }
            out.push((bad, worst, q));
        }
    }
    out
}

/// The grasp frame pose of arm `i` for the object at `x_wo`.
pub fn grasp_target(
    params: &SpatialPlantParams,
    i: usize,
    x_wo: &Isometry3<f64>,
) -> Isometry3<f64> {
    x_wo * params.grasps[i]
}

/// The smallest singular value of an arm's tool Jacobian at `q`.
pub fn sigma_min_at(arm: &SpatialArm, q: &[f64]) -> f64 {
    let mut d = ChainData::new(arm);
    spatial::kinematics(arm, q, None, &mut d);
    singular_values(&d)[5]
}

/// The smallest distance to a joint limit of an arm at `q`, rad.
pub fn limit_margin(arm: &SpatialArm, q: &[f64]) -> f64 {
    arm.chain
        .joints
        .iter()
        .zip(q)
        .map(|(j, &v)| (v - j.limits.lower).min(j.limits.upper - v))
        .fold(f64::INFINITY, f64::min)
}

/// The values of joint `joint` (a grid of `n` over its limits) at which arm `i` has an in-limit
/// solution at `x_wo` (`tries` random starts per value): the redundancy's reach in that joint.
pub fn redundancy_range(
    params: &SpatialPlantParams,
    i: usize,
    x_wo: &Isometry3<f64>,
    joint: usize,
    n: usize,
    tries: usize,
) -> Vec<f64> {
    let arm = &params.arms[i];
    let lim = arm.chain.joints[joint].limits;
    let target = grasp_target(params, i, x_wo);
    (0..n)
        .map(|k| lim.lower + (lim.upper - lim.lower) * (k as f64 + 0.5) / n as f64)
        .filter(|&v| {
            !ik_search(arm, &target, tries, Some((joint, v)), 0xfeed + k_hash(v)).is_empty()
        })
        .collect()
}

fn k_hash(v: f64) -> u64 {
    v.to_bits()
}
