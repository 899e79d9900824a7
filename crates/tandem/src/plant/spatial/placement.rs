//! A base-placement scan (issue 22; the method of the base-placement study,
//! `docs/base-placement.md`, for any arms): the bases are moved apart or together, and at each
//! spread every arm follows the path by inverse kinematics with continuation.
//!
//! # The spread
//! With two arms it is the distance between the base origins; both bases move symmetrically
//! along the line joining them, about their midpoint. With more arms it is the mean distance of
//! the base origins from their centroid; every base moves radially about the centroid, all by
//! the same factor. The bases keep their orientations.
//!
//! # Continuation
//! The scan starts at the set-up's own spread with one start solution per arm (e.g. the best
//! branch of [`branches::arm_solutions`]) and walks outward from it on both sides: at each
//! spread an arm's start solution is the IK from its start solution at the previous spread (so
//! that it stays on one branch; a spread where the start does not solve keeps the last good
//! one as the next guess), and from there it follows the path ([`branches::follow_path`]). When
//! that branch cannot follow the whole path, the arm's solutions at that spread are searched
//! anew ([`branches::search`]) and the best of them followed: a spread is **reachable** when
//! every arm follows the whole path inside its limits on some branch.
//!
//! # Between the arms
//! The closest approach of the arms' link centre lines over the path samples every arm solved:
//! each line is the polyline base origin → the origins of the joint frames → the tool origin,
//! without its last segment (the flange or hand, which the grasp fixes). Centre lines, no link
//! radii: the clearance between link surfaces is smaller.

use nalgebra::{Isometry3, Translation3, Vector3};

use super::branches::{self, PathCheck};
use super::{SpatialPlant, SpatialPlantParams, solve_ik};
use crate::dynamics::spatial;
use crate::dynamics::spatial::ChainData;
use crate::error::ModelError;
use crate::model::spatial::SpatialArm;

/// Most spreads of one scan.
pub const MAX_SPREADS: usize = 1001;

/// The spread of the bases of `params` (see the module doc): `None` with fewer than two arms.
pub fn base_spread(params: &SpatialPlantParams) -> Option<f64> {
    let p: Vec<Vector3<f64>> = params
        .arms
        .iter()
        .map(|a| a.base.translation.vector)
        .collect();
    match p.len() {
        0 | 1 => None,
        2 => Some((p[1] - p[0]).norm()),
        m => {
            let c = p.iter().sum::<Vector3<f64>>() / m as f64;
            Some(p.iter().map(|x| (x - c).norm()).sum::<f64>() / m as f64)
        }
    }
}

/// `params` with the bases moved to spread `d` (see the module doc). Errors when the current
/// spread is zero or not defined (fewer than two arms, or every base at one point).
pub fn spread_to(params: &SpatialPlantParams, d: f64) -> Result<SpatialPlantParams, ModelError> {
    let d0 = base_spread(params).ok_or_else(|| {
        ModelError::geometry("arms", "a placement scan moves two or more arms' bases")
    })?;
    if !(d0 > 1e-9) {
        return Err(ModelError::geometry(
            "arms",
            "every base sits at one point: there is no line to move them along",
        ));
    }
    let m = params.arms.len() as f64;
    let c = params
        .arms
        .iter()
        .map(|a| a.base.translation.vector)
        .sum::<Vector3<f64>>()
        / m;
    let mut p = params.clone();
    for a in &mut p.arms {
        let x = a.base.translation.vector;
        a.base = Isometry3::from_parts(Translation3::from(c + (x - c) * (d / d0)), a.base.rotation);
    }
    Ok(p)
}

/// One arm at one spread.
#[derive(Clone, Debug)]
pub struct ArmAtSpread {
    /// The start solution continued from the previous spread, when it solved inside the limits.
    pub start: Option<Vec<f64>>,
    /// The path from the solution used (the continued one, or the best one searched).
    pub path: Option<PathCheck>,
    /// The continued branch could not follow the path and the solutions were searched anew.
    pub searched: bool,
    /// Why the continued branch could not follow the path (when its start solved).
    pub continued_failure: Option<branches::PathFailure>,
    /// `σ_min` at the start of the solution used.
    pub sigma_start: f64,
}

/// One spread of a scan.
#[derive(Clone, Debug)]
pub struct SpreadRow {
    /// The spread, m.
    pub d: f64,
    /// Per arm.
    pub arms: Vec<ArmAtSpread>,
    /// Every arm follows the whole path inside its limits (on some branch).
    pub reachable: bool,
    /// The closest approach of the arms' link centre lines over the path, m (`None` when no
    /// sample was solved by every arm).
    pub closest_approach: Option<f64>,
}

/// What the scan does at each spread.
#[derive(Clone, Debug)]
pub struct ScanOptions {
    /// Path sample times, s.
    pub times: Vec<f64>,
    /// `σ_min` below which the path fails (the run's `min_sigma`).
    pub sigma_floor: f64,
    /// Starts of the search at a spread where the continued branch fails.
    pub starts: usize,
    /// Seed of that search.
    pub seed: u64,
}

/// Scan the spreads `ds` (any order, each > 0) of `params`, the object starting at `x_start`
/// and following the path `pose(t)` ([`branches::follow_path`]), from `start[i]` (arm `i`'s start solution at the current spread).
/// Rows in increasing spread.
pub fn scan(
    params: &SpatialPlantParams,
    x_start: &Isometry3<f64>,
    pose: &dyn Fn(f64) -> Isometry3<f64>,
    start: &[Vec<f64>],
    ds: &[f64],
    opts: &ScanOptions,
) -> Result<Vec<SpreadRow>, ModelError> {
    let d0 = base_spread(params).ok_or_else(|| {
        ModelError::geometry("arms", "a placement scan moves two or more arms' bases")
    })?;
    let mut sorted: Vec<f64> = ds.iter().copied().take(MAX_SPREADS).collect();
    sorted.sort_by(f64::total_cmp);
    let up: Vec<f64> = sorted.iter().copied().filter(|&d| d >= d0).collect();
    let down: Vec<f64> = sorted.iter().rev().copied().filter(|&d| d < d0).collect();
    let mut rows = Vec::with_capacity(sorted.len());
    for side in [up, down] {
        let mut guess: Vec<Vec<f64>> = start.to_vec();
        for d in side {
            let p = spread_to(params, d)?;
            let plant = SpatialPlant::new(&p)?;
            let mut arms = Vec::with_capacity(plant.arms().len());
            for (i, arm) in plant.arms().iter().enumerate() {
                let target = plant.grasp_pose(i, x_start);
                let mut data = ChainData::new(arm);
                let continued = continue_start(arm, &target, &guess[i], &mut data);
                let mut used: Option<(PathCheck, f64)> = continued.as_ref().map(|q| {
                    let c =
                        branches::follow_path(&plant, i, pose, q, &opts.times, opts.sigma_floor);
                    (c, sigma_at(arm, q, &mut data))
                });
                let continued_failure = used.as_ref().and_then(|(c, _)| c.failure.clone());
                let mut searched = false;
                if !used.as_ref().is_some_and(|(c, _)| c.feasible()) {
                    searched = true;
                    let (found, _) = branches::search(arm, &target, None, opts.starts, opts.seed);
                    for (q, _) in found {
                        let c = branches::follow_path(
                            &plant,
                            i,
                            pose,
                            &q,
                            &opts.times,
                            opts.sigma_floor,
                        );
                        let s = sigma_at(arm, &q, &mut data);
                        let better = match &used {
                            None => true,
                            Some((u, us)) => better_than(&c, s, u, *us),
                        };
                        if better {
                            used = Some((c, s));
                        }
                    }
                }
                if let Some(q) = &continued {
                    guess[i].clone_from(q);
                }
                let (path_check, sigma_start) = match used {
                    Some((c, s)) => (Some(c), s),
                    None => (None, f64::NAN),
                };
                arms.push(ArmAtSpread {
                    start: continued,
                    path: path_check,
                    searched,
                    continued_failure,
                    sigma_start,
                });
            }
            let reachable = arms
                .iter()
                .all(|a| a.path.as_ref().is_some_and(PathCheck::feasible));
            let closest_approach = closest(&plant, &arms);
            rows.push(SpreadRow {
                d,
                arms,
                reachable,
                closest_approach,
            });
        }
    }
    rows.sort_by(|a, b| a.d.total_cmp(&b.d));
    Ok(rows)
}

/// The IK from `guess`, wrapped into the limits near it; `None` when it does not solve inside.
fn continue_start(
    arm: &SpatialArm,
    target: &Isometry3<f64>,
    guess: &[f64],
    d: &mut ChainData,
) -> Option<Vec<f64>> {
    let mut q = guess.to_vec();
    solve_ik(arm, target, &mut q, d).ok()?;
    for (k, j) in arm.chain.joints.iter().enumerate() {
        q[k] = j.wrap_into_limits(q[k], guess[k])?;
    }
    Some(q)
}

fn sigma_at(arm: &SpatialArm, q: &[f64], d: &mut ChainData) -> f64 {
    spatial::kinematics(arm, q, None, d);
    branches::jacobian_extremes(d).0
}

/// The order of [`branches::rank`] on path checks: feasible first, then the path's `σ_min`; of
/// failing ones the farther reaching, then `σ_min` at the start.
fn better_than(a: &PathCheck, sa: f64, b: &PathCheck, sb: f64) -> bool {
    match (a.feasible(), b.feasible()) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => a.sigma_min > b.sigma_min,
        (false, false) => a.samples > b.samples || (a.samples == b.samples && sa > sb),
    }
}

/// The link centre-line polyline of an arm at the kinematics in `d` (see the module doc).
pub fn polyline(arm: &SpatialArm, d: &ChainData) -> Vec<Vector3<f64>> {
    let mut p = vec![arm.base.translation.vector];
    for x in d
        .X_WL
        .iter()
        .map(|x| x.translation.vector)
        .chain([d.X_WT.translation.vector])
    {
        if (x - p[p.len() - 1]).norm() > 1e-9 {
            p.push(x);
        }
    }
    p.pop();
    p
}

/// Distance between segments `[p1, q1]` and `[p2, q2]` (Ericson, *Real-Time Collision
/// Detection*, 2005, §5.1.9).
pub fn segment_distance(
    p1: &Vector3<f64>,
    q1: &Vector3<f64>,
    p2: &Vector3<f64>,
    q2: &Vector3<f64>,
) -> f64 {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.dot(&d1);
    let e = d2.dot(&d2);
    let f = d2.dot(&r);
    let eps = 1e-15;
    if a <= eps && e <= eps {
        return r.norm();
    }
    let (s, t);
    if a <= eps {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(&r);
        if e <= eps {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > eps {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    ((p1 + d1 * s) - (p2 + d2 * t)).norm()
}

/// Closest approach between two polylines.
pub fn polyline_distance(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    let mut m = f64::INFINITY;
    for sa in a.windows(2) {
        for sb in b.windows(2) {
            m = m.min(segment_distance(&sa[0], &sa[1], &sb[0], &sb[1]));
        }
    }
    m
}

/// The closest approach of every pair of arms over the samples all of them solved.
fn closest(plant: &SpatialPlant, arms: &[ArmAtSpread]) -> Option<f64> {
    let paths: Vec<&PathCheck> = arms.iter().filter_map(|a| a.path.as_ref()).collect();
    if paths.len() != arms.len() || arms.len() < 2 {
        return None;
    }
    let k_max = paths.iter().map(|p| p.q_path.len()).min().unwrap_or(0);
    if k_max == 0 {
        return None;
    }
    let mut data: Vec<ChainData> = plant.arms().iter().map(ChainData::new).collect();
    let mut m = f64::INFINITY;
    for k in 0..k_max {
        let lines: Vec<Vec<Vector3<f64>>> = plant
            .arms()
            .iter()
            .enumerate()
            .map(|(i, arm)| {
                spatial::kinematics(arm, &paths[i].q_path[k], None, &mut data[i]);
                polyline(arm, &data[i])
            })
            .collect();
        for a in 0..lines.len() {
            for b in a + 1..lines.len() {
                m = m.min(polyline_distance(&lines[a], &lines[b]));
            }
        }
    }
    Some(m)
}
