//! Inverse-kinematics branches of one arm at the start pose, and whether each one carries the
//! arm along the whole path (issue 22, "IK start that finds the branch"; the method of the
//! base-placement study, `docs/base-placement.md`).
//!
//! # Finding the solutions
//! The arm's tool frame is solved onto its grasp frame at the start pose from many starts: the
//! scenario's own `q_guess` first (solved exactly as the run's start is,
//! [`SpatialPlant::initial_state`]), then `starts − 1` joint vectors drawn uniformly inside the
//! joint limits (a seeded [`SplitMix64`]; a revolute joint without limits in `[−π, π)`). Each
//! drawn start is solved by the run's own Newton–Raphson with damped least squares with every
//! step clamped into the limits (so that it finds solutions inside them); when that does not
//! converge, unclamped from the same start, the result's revolute angles then wrapped by whole
//! turns into the limits ([`ChainJoint::wrap_into_limits`]). A solution counts when the residual
//! is below 1e-12 m and rad (the run's own tolerance) and every joint is inside its limits.
//!
//! # Distinct solutions
//! Two solutions are the same when every joint agrees within [`SAME_TOL`] rad (revolute angles
//! compared modulo 2π; a prismatic joint's value directly). For an arm with 6 joints or fewer
//! they are the discrete branches (8 for a UR-class arm at a generic pose). An arm with more
//! than 6 joints has a continuum of solutions (the self-motion manifold): its solutions are
//! *samples* of that manifold, grouped greedily into clusters of samples within
//! [`CLUSTER_RADIUS`] rad of the cluster's first sample in every joint; each cluster is
//! reported by that first sample. Those are samples, not discrete branches.
//!
//! A solution's revolute angles are reported at the whole turn that lies inside the limits and
//! farthest from them (a UR5 joint limited to ±2π reads in `[−π, π]`), except the scenario's own
//! solution, which is reported as the run starts from it.
//!
//! # Along the path
//! From each solution the arm follows the path, sampled at the given times, by continuation:
//! the solution at the previous sample is the guess for the next (the run's IK; from a nearby
//! guess it converges to the nearest solution, so it stays on its branch; for a redundant arm
//! its minimum-norm steps fix the redundancy). It fails at the first sample where the IK does
//! not converge, a joint leaves its limits (no wrapping: the joint would have to travel there),
//! a joint moves more than [`MAX_JUMP`] rad between two samples (the continuation jumped to
//! another solution: sample more finely), or `σ_min` falls below the floor given (the run's
//! `min_sigma`, where a run stops). Measured over the samples reached: the smallest `σ_min` of
//! the 6 × n tool Jacobian, the smallest distance to a joint limit, and the largest static
//! holding torque over the joint's effort limit ([`SpatialPlant::holding_torques`]: gravity
//! plus the minimum-norm share of the object's weight), and the arm's lowest point (joint-frame
//! and tool origins: no link volumes, no collision check).

use nalgebra::{DMatrix, Isometry3, Vector3};

use super::{ObjectState, SpatialPlant, solve_ik, solve_ik_clamped};
use crate::dynamics::spatial;
use crate::dynamics::spatial::ChainData;
use crate::math::random::SplitMix64;
use crate::model::spatial::{ChainJoint, JointKind, SpatialArm};

/// Two solutions closer than this in every joint (rad or m; revolute modulo 2π) are one.
pub const SAME_TOL: f64 = 1e-6;
/// A redundant arm's samples within this of a cluster's first sample in every joint (rad or m;
/// revolute modulo 2π) belong to that cluster.
pub const CLUSTER_RADIUS: f64 = 0.5;
/// Largest joint motion between two path samples before the continuation counts as a jump to
/// another solution, rad or m.
pub const MAX_JUMP: f64 = 0.5;
/// A joint-limit margin along the path below this (rad or m, about 6°) ranks a solution after
/// those with more room.
pub const MARGIN_OK: f64 = 0.1;
/// Most starts of one search (a bound on the work, not a useful count: a UR5's 8 branches
/// show up within about 100).
pub const MAX_STARTS: usize = 100_000;

/// What to search and how to follow the path.
#[derive(Clone, Debug)]
pub struct SearchOptions {
    /// Starts in all, the scenario's own guess included (≥ 1).
    pub starts: usize,
    /// Seed of the drawn starts.
    pub seed: u64,
    /// Path sample times, s (increasing; the first is usually 0).
    pub times: Vec<f64>,
    /// `σ_min` below which the path fails (the run's `min_sigma`).
    pub sigma_floor: f64,
}

/// Why and when the path could not be followed.
#[derive(Clone, Debug, PartialEq)]
pub struct PathFailure {
    /// Path time of the first sample that failed, s.
    pub t: f64,
    /// Why, in words (names the joint where one is at fault).
    pub reason: String,
}

/// One solution followed along the path.
#[derive(Clone, Debug, PartialEq)]
pub struct PathCheck {
    /// `None` when every sample solved inside the limits.
    pub failure: Option<PathFailure>,
    /// Samples solved (the whole path when `failure` is `None`).
    pub samples: usize,
    /// Smallest `σ_min` of the tool Jacobian over the samples solved.
    pub sigma_min: f64,
    /// Smallest distance to a joint limit, rad or m (`∞` when no joint has finite limits).
    pub limit_margin: f64,
    /// The joint (0-based) that sets `limit_margin`.
    pub limit_joint: usize,
    /// Largest `|τ_k| / effort_k` of the holding torques (0 when no effort limit is given).
    pub torque_ratio: f64,
    /// The joint (0-based) that sets `torque_ratio`.
    pub torque_joint: usize,
    /// The lowest point of the arm over the samples solved: the smallest world z of its joint
    /// frames' origins and its tool frame's origin, m (for a table at z = 0: below 0 is through
    /// it).
    pub lowest: f64,
    /// The joint angles at every sample solved, in order.
    pub q_path: Vec<Vec<f64>>,
}

impl PathCheck {
    /// Every sample solved inside the limits.
    pub fn feasible(&self) -> bool {
        self.failure.is_none()
    }
}

/// One solution at the start pose: a branch (≤ 6 joints) or a cluster of samples (> 6).
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// Joint angles, inside the limits.
    pub q: Vec<f64>,
    /// How many starts converged to it (or into its cluster).
    pub hits: usize,
    /// `σ_min` of the 6 × n tool Jacobian at the start.
    pub sigma_min: f64,
    /// `σ_max / σ_min` at the start.
    pub cond: f64,
    /// The path from it.
    pub path: PathCheck,
}

/// The solutions of one arm, best first ([`rank`]).
#[derive(Clone, Debug)]
pub struct ArmSolutions {
    /// Arm index.
    pub arm: usize,
    /// More than 6 joints: the solutions are samples of a self-motion manifold, clustered.
    pub redundant: bool,
    /// The solutions.
    pub solutions: Vec<Solution>,
    /// Which of them the scenario's own guess lands on.
    pub own: Option<usize>,
    /// Why the scenario's own guess lands on none (the run's start error), when it does not.
    pub own_error: Option<String>,
    /// Starts tried.
    pub starts: usize,
    /// Starts that converged inside the limits.
    pub converged: usize,
}

/// Singular values of the 6 × n tool Jacobian in `d` (after [`spatial::kinematics`]), as
/// `(σ_min, σ_max)`; `σ_min` is 0 for fewer than 6 joints (the arm cannot move its tool in
/// every direction).
pub fn jacobian_extremes(d: &ChainData) -> (f64, f64) {
    let n = d.J.ncols();
    let j = DMatrix::from_column_slice(6, n, d.J.as_slice());
    let sv = j.singular_values();
    let smax = sv.max();
    let smin = if n < 6 { 0.0 } else { sv.min() };
    (smin, smax)
}

/// Joint `j`'s value `v` compared with `w`: the difference, modulo 2π for a revolute joint.
fn joint_gap(j: &ChainJoint, v: f64, w: f64) -> f64 {
    let d = v - w;
    match j.kind {
        JointKind::Revolute => {
            let tau = std::f64::consts::TAU;
            let r = d.rem_euclid(tau);
            r.min(tau - r)
        }
        JointKind::Prismatic => d.abs(),
    }
}

/// The largest joint gap between two configurations of `arm` (revolute modulo 2π).
pub fn config_gap(arm: &SpatialArm, a: &[f64], b: &[f64]) -> f64 {
    arm.chain
        .joints
        .iter()
        .zip(a.iter().zip(b))
        .map(|(j, (x, y))| joint_gap(j, *x, *y))
        .fold(0.0, f64::max)
}

/// Each revolute angle at the whole turn inside the limits farthest from them (unchanged when
/// no turn lands inside, or when the limits are infinite).
fn farthest_turns(arm: &SpatialArm, q: &mut [f64]) {
    for (j, v) in arm.chain.joints.iter().zip(q.iter_mut()) {
        let (lo, hi) = (j.limits.lower, j.limits.upper);
        if j.kind != JointKind::Revolute || !(lo.is_finite() && hi.is_finite()) {
            continue;
        }
        let tau = std::f64::consts::TAU;
        let k = ((0.5 * (lo + hi) - *v) / tau).round();
        let margin = |w: f64| (w - lo).min(hi - w);
        let best = [k - 1.0, k, k + 1.0]
            .into_iter()
            .map(|k| *v + tau * k)
            .filter(|w| *w >= lo && *w <= hi)
            .max_by(|a, b| margin(*a).total_cmp(&margin(*b)));
        if let Some(w) = best {
            *v = w;
        }
    }
}

/// The smallest distance to a joint limit at `q`, and the joint.
pub fn limit_margin(arm: &SpatialArm, q: &[f64]) -> (f64, usize) {
    let mut m = (f64::INFINITY, 0);
    for (k, (j, &v)) in arm.chain.joints.iter().zip(q).enumerate() {
        let g = (v - j.limits.lower).min(j.limits.upper - v);
        if g < m.0 {
            m = (g, k);
        }
    }
    m
}

fn inside(arm: &SpatialArm, q: &[f64]) -> bool {
    arm.chain
        .joints
        .iter()
        .zip(q)
        .all(|(j, &v)| v >= j.limits.lower && v <= j.limits.upper)
}

/// The start of a draw for joint `j`: uniform inside its limits (a revolute joint without
/// finite limits in `[−π, π)`, a prismatic one in `[−1, 1)` m).
fn draw(j: &ChainJoint, rng: &mut SplitMix64) -> f64 {
    let (lo, hi) = (j.limits.lower, j.limits.upper);
    if lo.is_finite() && hi.is_finite() {
        rng.range(lo, hi)
    } else {
        let a = match j.kind {
            JointKind::Revolute => std::f64::consts::PI,
            JointKind::Prismatic => 1.0,
        };
        rng.range(lo.max(-a), hi.min(a))
    }
}

/// The run's start solution of arm `i` from its guess (as [`SpatialPlant::initial_state`]
/// solves it: the IK, then each revolute angle wrapped into its limits nearest the guess).
pub fn own_solution(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    guess: &[f64],
    d: &mut ChainData,
) -> Result<Vec<f64>, String> {
    let mut q = guess.to_vec();
    solve_ik(arm, target, &mut q, d).map_err(|r| {
        format!(
            "the inverse kinematics from q_guess does not reach the grasp frame (closest: {:.3e} m, {:.3e} rad off)",
            r.0, r.1
        )
    })?;
    for (k, j) in arm.chain.joints.iter().enumerate() {
        if let Some(v) = j.wrap_into_limits(q[k], guess[k]) {
            q[k] = v;
        }
        if q[k] < j.limits.lower - 1e-9 || q[k] > j.limits.upper + 1e-9 {
            return Err(format!(
                "from q_guess it lands on q = {:.4} for joint {}, outside its limits [{:.4}, {:.4}]",
                q[k], j.name, j.limits.lower, j.limits.upper
            ));
        }
    }
    Ok(q)
}

/// The in-limit solutions of one arm onto `target` from `starts − 1` drawn starts (see the
/// module doc), each with how many starts found it; distinct within [`SAME_TOL`] (or, for a
/// redundant arm, clustered within [`CLUSTER_RADIUS`]); the `first` solution, when given, is
/// the first entry. Returns the solutions and the number of starts that converged.
pub fn search(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    first: Option<&[f64]>,
    starts: usize,
    seed: u64,
) -> (Vec<(Vec<f64>, usize)>, usize) {
    let n = arm.chain.dof();
    let tol = if n > 6 { CLUSTER_RADIUS } else { SAME_TOL };
    let mut d = ChainData::new(arm);
    let clamp: Vec<(f64, f64)> = arm
        .chain
        .joints
        .iter()
        .map(|j| (j.limits.lower, j.limits.upper))
        .collect();
    let mut out: Vec<(Vec<f64>, usize)> = Vec::new();
    let mut converged = 0;
    if let Some(q) = first {
        out.push((q.to_vec(), 1));
        converged += 1;
    }
    let mut rng = SplitMix64(seed);
    let mut q = vec![0.0; n];
    let mut q0 = vec![0.0; n];
    for _ in 1..starts.min(MAX_STARTS) {
        for (k, j) in arm.chain.joints.iter().enumerate() {
            q0[k] = draw(j, &mut rng);
        }
        q.copy_from_slice(&q0);
        let mut ok = solve_ik_clamped(arm, target, &mut q, &mut d, Some(&clamp)).is_ok();
        if !ok {
            q.copy_from_slice(&q0);
            ok = solve_ik(arm, target, &mut q, &mut d).is_ok();
            if ok {
                for (k, j) in arm.chain.joints.iter().enumerate() {
                    if let Some(v) = j.wrap_into_limits(q[k], q0[k]) {
                        q[k] = v;
                    }
                }
            }
        }
        if !ok || !inside(arm, &q) {
            continue;
        }
        converged += 1;
        farthest_turns(arm, &mut q);
        match out.iter_mut().find(|(p, _)| config_gap(arm, p, &q) < tol) {
            Some(s) => s.1 += 1,
            None => out.push((q.clone(), 1)),
        }
    }
    (out, converged)
}

/// A flat plant state with the object at `x_wo` (at rest) and arm `i`'s joints at `q` (the
/// other arms' at zero: the holding torques of arm `i` do not depend on them).
fn state_with(plant: &SpatialPlant, x_wo: &Isometry3<f64>, i: usize, q: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; plant.state_dim()];
    let s = plant.offset(i);
    y[s..s + q.len()].copy_from_slice(q);
    plant.set_object(
        &mut y,
        &ObjectState {
            p: x_wo.translation.vector,
            q: x_wo.rotation,
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        },
    );
    y
}

/// Follow the path (`pose(t)`: the object's pose at time `t`, e.g. a [`Se3Path`]'s sample)
/// at `times` with arm `i` from `q_start` (a solution at the start pose) by continuation (see
/// the module doc).
///
/// [`Se3Path`]: crate::reference::spatial::path::Se3Path
pub fn follow_path(
    plant: &SpatialPlant,
    i: usize,
    pose: &dyn Fn(f64) -> Isometry3<f64>,
    q_start: &[f64],
    times: &[f64],
    sigma_floor: f64,
) -> PathCheck {
    let arm = &plant.arms()[i];
    let s = plant.offset(i);
    let mut d = ChainData::new(arm);
    let mut ws = plant.workspace();
    let mut tau = vec![0.0; plant.n_q()];
    let mut check = PathCheck {
        failure: None,
        samples: 0,
        sigma_min: f64::INFINITY,
        limit_margin: f64::INFINITY,
        limit_joint: 0,
        torque_ratio: 0.0,
        torque_joint: 0,
        lowest: f64::INFINITY,
        q_path: Vec::with_capacity(times.len()),
    };
    let mut q = q_start.to_vec();
    let mut prev = q_start.to_vec();
    for &t in times {
        let x_wo = pose(t);
        let target = plant.grasp_pose(i, &x_wo);
        let fail = |reason: String| Some(PathFailure { t, reason });
        if let Err(r) = solve_ik(arm, &target, &mut q, &mut d) {
            check.failure = fail(format!(
                "cannot reach its grasp frame (closest: {:.3e} m, {:.3e} rad off)",
                r.0, r.1
            ));
            break;
        }
        if let Some((k, j)) = arm
            .chain
            .joints
            .iter()
            .enumerate()
            .find(|(k, j)| q[*k] < j.limits.lower || q[*k] > j.limits.upper)
        {
            check.failure = fail(format!(
                "joint {} needs q = {:.4}, outside its limits [{:.4}, {:.4}]",
                j.name, q[k], j.limits.lower, j.limits.upper
            ));
            break;
        }
        if let Some((k, j)) = arm
            .chain
            .joints
            .iter()
            .enumerate()
            .find(|(k, _)| (q[*k] - prev[*k]).abs() > MAX_JUMP)
        {
            check.failure = fail(format!(
                "joint {} jumps {:.3} rad between two samples (the continuation left its \
                 branch near a singularity; sample more finely)",
                j.name,
                (q[k] - prev[k]).abs()
            ));
            break;
        }
        spatial::kinematics(arm, &q, None, &mut d);
        let (smin, _) = jacobian_extremes(&d);
        if smin < sigma_floor {
            check.failure = fail(format!(
                "σ_min = {smin:.2e} falls below the run's min_sigma {sigma_floor:.2e} (near \
                 singular: the run would stop)"
            ));
            break;
        }
        check.sigma_min = check.sigma_min.min(smin);
        for x in d.X_WL.iter().chain([&d.X_WT]) {
            check.lowest = check.lowest.min(x.translation.z);
        }
        let (m, mk) = limit_margin(arm, &q);
        if m < check.limit_margin {
            check.limit_margin = m;
            check.limit_joint = mk;
        }
        let y = state_with(plant, &x_wo, i, &q);
        plant.holding_torques(&y, &mut ws, &mut tau);
        for (k, j) in arm.chain.joints.iter().enumerate() {
            let r = (tau[s + k] / j.limits.effort).abs();
            if r > check.torque_ratio {
                check.torque_ratio = r;
                check.torque_joint = k;
            }
        }
        check.samples += 1;
        check.q_path.push(q.clone());
        prev.copy_from_slice(&q);
    }
    check
}

/// Every solution of arm `i` at the start pose `x_start`, each followed along the path
/// `pose(t)` (see the module doc and [`follow_path`]); `guess` is the scenario's own guess for
/// this arm.
pub fn arm_solutions(
    plant: &SpatialPlant,
    i: usize,
    x_start: &Isometry3<f64>,
    pose: &dyn Fn(f64) -> Isometry3<f64>,
    guess: &[f64],
    opts: &SearchOptions,
) -> ArmSolutions {
    let arm = &plant.arms()[i];
    let n = arm.chain.dof();
    let target = plant.grasp_pose(i, x_start);
    let mut d = ChainData::new(arm);
    let own = own_solution(arm, &target, guess, &mut d);
    let (found, converged) = search(
        arm,
        &target,
        own.as_ref().ok().map(Vec::as_slice),
        opts.starts,
        opts.seed,
    );
    let mut solutions: Vec<(bool, Solution)> = found
        .into_iter()
        .enumerate()
        .map(|(k, (q, hits))| {
            spatial::kinematics(arm, &q, None, &mut d);
            let (smin, smax) = jacobian_extremes(&d);
            let path = follow_path(plant, i, pose, &q, &opts.times, opts.sigma_floor);
            (
                k == 0 && own.is_ok(),
                Solution {
                    q,
                    hits,
                    sigma_min: smin,
                    cond: smax / smin,
                    path,
                },
            )
        })
        .collect();
    solutions.sort_by(|(_, a), (_, b)| rank(a, b));
    let own_idx = solutions.iter().position(|(o, _)| *o);
    ArmSolutions {
        arm: i,
        redundant: n > 6,
        own: own_idx,
        own_error: own.err(),
        solutions: solutions.into_iter().map(|(_, s)| s).collect(),
        starts: opts.starts,
        converged,
    }
}

/// The order of [`ArmSolutions::solutions`]: those that follow the whole path first; of
/// those, the ones at least [`MARGIN_OK`] from every joint limit along the path first, then by
/// the path's smallest `σ_min` (to the 4 decimals printed), then by the larger limit margin; of those that fail,
/// the farther reaching first, then by `σ_min` at the start.
pub fn rank(a: &Solution, b: &Solution) -> std::cmp::Ordering {
    let fa = a.path.feasible();
    let fb = b.path.feasible();
    let key = |x: f64| (x * 1e4).round() as i64;
    fb.cmp(&fa)
        .then_with(|| {
            if fa {
                let ma = a.path.limit_margin >= MARGIN_OK;
                let mb = b.path.limit_margin >= MARGIN_OK;
                mb.cmp(&ma)
                    .then_with(|| key(b.path.sigma_min).cmp(&key(a.path.sigma_min)))
                    .then_with(|| b.path.limit_margin.total_cmp(&a.path.limit_margin))
            } else {
                b.path.samples.cmp(&a.path.samples)
            }
        })
        .then_with(|| b.sigma_min.total_cmp(&a.sigma_min))
}
