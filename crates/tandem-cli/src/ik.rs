//! `tandem ik`, `tandem validate --branches` and `tandem place` (issue 22, "the first hour with
//! your own arm"): the inverse-kinematics branches of every arm at a spatial scenario's start
//! pose, each followed along the path, with the `q_guess` line that picks it; and a scan of the
//! base separation that keeps the path reachable. The method is the library's
//! ([`tandem::plant::spatial::branches`], [`tandem::plant::spatial::placement`]); this module
//! loads the scenario, checks the options, and writes the table and the JSON.

use std::path::Path;

use anyhow::Result;
use nalgebra::Isometry3;
use serde_json::{Value, json};
use tandem::plant::spatial::SpatialPlant;
use tandem::plant::spatial::branches::{self, ArmSolutions, PathCheck, SearchOptions};
use tandem::plant::spatial::placement::{self, ScanOptions, SpreadRow};

use crate::BadInput;
use crate::files::{self, Input};
use crate::scenario::spatial::{self as spatial_scenario, SpatialBuilt, SpatialScenario};
use crate::scenario::{self, Overrides, Scenario, Source};

/// Default starts per arm (the scenario's own `q_guess` and 199 drawn inside the limits).
pub const DEFAULT_STARTS: usize = 200;
/// Most starts per arm `--starts` accepts.
pub const MAX_STARTS: usize = 10_000;
/// Default path sampling step, s (the base-placement study's).
pub const DEFAULT_EVERY: f64 = 0.5;
/// Most path samples (`duration / --every`).
pub const MAX_SAMPLES: usize = 20_000;
/// Most separations of `tandem place`.
pub const MAX_SEPARATIONS: usize = 201;
/// Starts of `tandem place`'s search at a separation where the continued branch fails.
pub const PLACE_STARTS: usize = 100;

/// What `--force` looks for in the first bytes of an existing `--json` file.
pub const WRITTEN_MARKS: &[&str] = &[
    "\"written_by\": \"tandem ik",
    "\"written_by\": \"tandem place",
];

/// The search's options from the command line.
#[derive(Clone, Debug)]
pub struct IkOptions {
    /// Only this arm (0-based).
    pub arm: Option<usize>,
    /// Starts per arm.
    pub starts: usize,
    /// Seed of the drawn starts.
    pub seed: u64,
    /// Path sampling step, s.
    pub every: f64,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            arm: None,
            starts: DEFAULT_STARTS,
            seed: 0,
            every: DEFAULT_EVERY,
        }
    }
}

/// A spatial scenario loaded for `command` (a planar one is refused with the reason).
pub fn load(arg: &str, command: &str) -> Result<(Source, SpatialScenario)> {
    match scenario::load(Some(arg), &Overrides::default())? {
        (src, Scenario::Spatial(sc)) => Ok((src, sc)),
        (src, Scenario::Planar(_)) => Err(BadInput::msg(format!(
            "{command} takes a spatial scenario (arms that name a robot model); {} is planar: \
             a 2-link arm has two elbow branches, picked by `arms[i].elbow = \"positive\"` or \
             `\"negative\"` (q_2 > 0 or < 0), not searched",
            src.display
        ))
        .into()),
    }
}

/// The path sample times `0, every, 2 every, …` up to and including `duration`.
pub fn times(duration: f64, every: f64, option: &str) -> Result<Vec<f64>> {
    if !(every.is_finite() && every > 0.0) {
        return Err(BadInput::msg(format!("{option} {every}: give a step > 0 s")).into());
    }
    let n = (duration / every).floor();
    if !(n < MAX_SAMPLES as f64) {
        return Err(BadInput::msg(format!(
            "{option} {every}: {duration} s in steps of {every} s is more than {MAX_SAMPLES} samples; give a larger step"
        ))
        .into());
    }
    let n = n as usize;
    let mut t: Vec<f64> = (0..=n).map(|k| k as f64 * every).collect();
    if duration - t[n] > 1e-9 * duration.max(1.0) {
        t.push(duration);
    }
    Ok(t)
}

/// `--starts N` checked.
pub fn check_starts(n: usize) -> Result<usize> {
    if n == 0 {
        return Err(BadInput::msg(
            "--starts 0: give at least 1 (the first start is the scenario's own q_guess)",
        )
        .into());
    }
    if n > MAX_STARTS {
        return Err(BadInput::msg(format!(
            "--starts {n}: at most {MAX_STARTS} (a UR5's 8 branches show up within the default {DEFAULT_STARTS})"
        ))
        .into());
    }
    Ok(n)
}

/// The branches of every arm (or `--arm`'s) of a built scenario.
pub struct IkReport {
    /// Scenario name.
    pub name: String,
    /// The start pose of the object.
    pub x_start: Isometry3<f64>,
    /// Path duration, s.
    pub duration: f64,
    /// Path sample times, s.
    pub times: Vec<f64>,
    /// The run's `min_sigma`.
    pub sigma_floor: f64,
    /// The options.
    pub opts: IkOptions,
    /// Per arm: its joints' names, its chain's name, and its solutions.
    pub arms: Vec<(Vec<String>, String, ArmSolutions)>,
    /// The scenario's set-up warnings (URDF, plausibility).
    pub warnings: Vec<String>,
}

/// The object's pose on the scenario's path at `t`.
fn path_pose(b: &SpatialBuilt) -> impl Fn(f64) -> Isometry3<f64> + '_ {
    move |t| {
        let s = b.path.sample(t);
        Isometry3::from_parts(s.p.into(), s.r)
    }
}

/// Build a scenario's plant (its errors mapped to the file).
fn build(src: &Source, sc: &SpatialScenario) -> Result<(SpatialBuilt, SpatialPlant)> {
    let b = spatial_scenario::build(sc, src)?;
    let dofs = spatial_scenario::dofs(&b);
    let plant = SpatialPlant::new(&b.plant)
        .map_err(|e| spatial_scenario::model_error(src, sc, &dofs, e))?;
    Ok((b, plant))
}

/// `tandem ik`: every arm's solutions at the start pose, each followed along the path.
pub fn ik(src: &Source, sc: &SpatialScenario, opts: &IkOptions) -> Result<IkReport> {
    check_starts(opts.starts)?;
    if let Some(i) = opts.arm
        && i >= sc.arms.len()
    {
        return Err(BadInput::msg(format!(
            "--arm {i}: the scenario has {} arm{} (0{})",
            sc.arms.len(),
            if sc.arms.len() == 1 { "" } else { "s" },
            if sc.arms.len() > 1 {
                format!(" to {}", sc.arms.len() - 1)
            } else {
                String::new()
            }
        ))
        .into());
    }
    let (b, plant) = build(src, sc)?;
    let times = times(b.sim.duration, opts.every, "--every")?;
    let search = SearchOptions {
        starts: opts.starts,
        seed: opts.seed,
        times: times.clone(),
        sigma_floor: b.sim.min_sigma,
    };
    let mut arms = Vec::new();
    for (i, arm) in plant.arms().iter().enumerate() {
        if opts.arm.is_some_and(|a| a != i) {
            continue;
        }
        let s = plant.offset(i);
        let n = arm.chain.dof();
        let guess = &b.start.q_guess[s..s + n];
        let sol = branches::arm_solutions(&plant, i, &b.start.x_wo, &path_pose(&b), guess, &search);
        let names = arm.chain.joints.iter().map(|j| j.name.clone()).collect();
        arms.push((names, arm.chain.name.clone(), sol));
    }
    Ok(IkReport {
        name: sc.name.clone().unwrap_or_else(|| src.name.clone()),
        x_start: b.start.x_wo,
        duration: b.sim.duration,
        times,
        sigma_floor: b.sim.min_sigma,
        opts: opts.clone(),
        arms,
        warnings: b.warnings.clone(),
    })
}

/// A `q_guess = [...]` line (12 decimals: the run's start from it lands within 1e-11 of it).
pub fn q_guess_line(q: &[f64]) -> String {
    let v: Vec<String> = q.iter().map(|x| format!("{x:.12}")).collect();
    format!("q_guess = [{}]", v.join(", "))
}

fn pct(r: f64) -> String {
    format!("{:.1} %", 100.0 * r)
}

fn margin_text(c: &PathCheck, names: &[String]) -> String {
    if c.samples == 0 {
        return "–".into();
    }
    if c.limit_margin.is_finite() {
        format!("{:.3} ({})", c.limit_margin, names[c.limit_joint])
    } else {
        "no limits".into()
    }
}

fn torque_text(c: &PathCheck, names: &[String]) -> String {
    if c.samples == 0 {
        "–".into()
    } else if c.torque_ratio == 0.0 {
        "no effort limits".into()
    } else {
        format!("{} ({})", pct(c.torque_ratio), names[c.torque_joint])
    }
}

fn path_text(c: &PathCheck) -> String {
    match &c.failure {
        None => "whole path".into(),
        Some(f) => format!("fails at t = {} s: {}", short(f.t), f.reason),
    }
}

/// A number without trailing zeros (`0.5`, `12`, `1.25`).
fn short(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// Pad `cells` into aligned columns (two spaces between them).
fn columns(rows: &[Vec<String>]) -> String {
    let w: Vec<usize> = (0..rows[0].len())
        .map(|c| {
            rows.iter()
                .map(|r| r.get(c).map_or(0, |s| s.chars().count()))
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for r in rows {
        let mut line = String::from("  ");
        for (c, s) in r.iter().enumerate() {
            line.push_str(s);
            if c + 1 < r.len() {
                line.push_str(&" ".repeat(w[c] - s.chars().count() + 2));
            }
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// The terminal text of `tandem ik`.
pub fn ik_text(r: &IkReport) -> String {
    let p = r.x_start.translation.vector;
    let mut s = format!(
        "{}: inverse-kinematics solutions at the start pose (object at ({}, {}, {}) m), each \
         followed along the path every {} s over {} s ({} samples); {} starts per arm, seed {}\n",
        r.name,
        short(p.x),
        short(p.y),
        short(p.z),
        short(r.opts.every),
        short(r.duration),
        r.times.len(),
        r.opts.starts,
        r.opts.seed
    );
    for (names, chain, a) in &r.arms {
        let n = names.len();
        let feasible = a.solutions.iter().filter(|x| x.path.feasible()).count();
        s.push('\n');
        if a.redundant {
            s.push_str(&format!(
                "arm {} ({chain}, {n} joints): {} clusters of solutions from {} of {} starts; {} follow the whole path.\n  \
                 {n} joints > 6: the solutions form a continuum (the self-motion manifold); these are \
                 samples of it, grouped within {} rad per joint, not discrete branches.\n",
                a.arm,
                a.solutions.len(),
                a.converged,
                a.starts,
                feasible,
                branches::CLUSTER_RADIUS
            ));
        } else {
            s.push_str(&format!(
                "arm {} ({chain}, {n} joints): {} branch{} inside the joint limits from {} of {} starts; {} follow{} the whole path.\n",
                a.arm,
                a.solutions.len(),
                if a.solutions.len() == 1 { "" } else { "es" },
                a.converged,
                a.starts,
                feasible,
                if feasible == 1 { "s" } else { "" }
            ));
        }
        match (&a.own, &a.own_error) {
            (Some(k), _) => s.push_str(&format!(
                "  the scenario's own q_guess lands on #{} (marked *)\n",
                k + 1
            )),
            (None, Some(e)) => s.push_str(&format!(
                "  the scenario's own q_guess lands on none: {e}\n"
            )),
            (None, None) => {}
        }
        if a.solutions.is_empty() {
            s.push_str("  no solution inside the joint limits: the start pose is out of this arm's reach (move its base or the grasp)\n");
            continue;
        }
        let mut rows = vec![vec![
            "#".to_string(),
            "hits".to_string(),
            "σ_min".into(),
            "cond".into(),
            "path min σ_min".into(),
            "min limit margin (rad)".into(),
            "max |τ|/effort".into(),
            "lowest (m)".into(),
            "path".into(),
        ]];
        for (k, x) in a.solutions.iter().enumerate() {
            rows.push(vec![
                format!("{}{}", k + 1, if a.own == Some(k) { "*" } else { "" }),
                x.hits.to_string(),
                format!("{:.4}", x.sigma_min),
                format!("{:.1}", x.cond),
                if x.path.samples > 0 {
                    format!("{:.4}", x.path.sigma_min)
                } else {
                    "–".into()
                },
                margin_text(&x.path, names),
                torque_text(&x.path, names),
                if x.path.samples > 0 {
                    format!("{:.3}", x.path.lowest)
                } else {
                    "–".into()
                },
                path_text(&x.path),
            ]);
        }
        s.push_str(&columns(&rows));
        s.push_str(&format!(
            "  to pick one, put its line in the scenario's [[arms]] table number {} (arms[{}]):\n",
            a.arm + 1,
            a.arm
        ));
        for (k, x) in a.solutions.iter().enumerate() {
            s.push_str(&format!("  #{:<3} {}\n", k + 1, q_guess_line(&x.q)));
        }
    }
    s.push_str(&format!(
        "\nσ_min, cond: the 6 × n tool Jacobian at the start (m and rad mixed); along the path: \
         IK continuation from the previous sample, failing where it does not converge, a joint \
         leaves its limits, jumps more than {} rad between samples, or σ_min falls below the run's \
         min_sigma {}; torques: static holding torques (gravity and the object's weight) over the \
         URDF effort limits; lowest: the lowest joint-frame or tool origin (world z; no link \
         volumes, no collision check). Order: whole path first, then at least {} rad from every \
         limit, then by the path's σ_min.\n",
        branches::MAX_JUMP,
        r.sigma_floor,
        branches::MARGIN_OK
    ));
    s
}

fn path_json(c: &PathCheck, names: &[String]) -> Value {
    let some = c.samples > 0;
    json!({
        "whole_path": c.feasible(),
        "failure": c.failure.as_ref().map(|f| json!({"t": f.t, "reason": f.reason})),
        "samples": c.samples,
        "sigma_min": if some { json!(c.sigma_min) } else { Value::Null },
        "limit_margin": if some && c.limit_margin.is_finite() { json!(c.limit_margin) } else { Value::Null },
        "limit_joint": if some { json!(names[c.limit_joint]) } else { Value::Null },
        "torque_ratio": if some { json!(c.torque_ratio) } else { Value::Null },
        "torque_joint": if some { json!(names[c.torque_joint]) } else { Value::Null },
        "lowest_point": if some { json!(c.lowest) } else { Value::Null },
    })
}

/// The JSON of `tandem ik` (`written_by` first: `--force` looks for it).
pub fn ik_json(r: &IkReport) -> Value {
    let p = r.x_start.translation.vector;
    let q = r.x_start.rotation;
    let arms: Vec<Value> = r
        .arms
        .iter()
        .map(|(names, chain, a)| {
            let sols: Vec<Value> = a
                .solutions
                .iter()
                .enumerate()
                .map(|(k, x)| {
                    json!({
                        "rank": k + 1,
                        "own": a.own == Some(k),
                        "q": x.q,
                        "hits": x.hits,
                        "sigma_min": x.sigma_min,
                        "cond": x.cond,
                        "path": path_json(&x.path, names),
                        "q_guess": q_guess_line(&x.q),
                    })
                })
                .collect();
            json!({
                "arm": a.arm,
                "chain": chain,
                "joints": names,
                "kind": if a.redundant { "samples of a self-motion manifold (clustered), not discrete branches" } else { "branches" },
                "starts": a.starts,
                "converged": a.converged,
                "own_rank": a.own.map(|k| k + 1),
                "own_error": a.own_error,
                "solutions": sols,
            })
        })
        .collect();
    json!({
        "written_by": format!("tandem ik {}", env!("CARGO_PKG_VERSION")),
        "scenario": r.name,
        "start_pose": {"position": [p.x, p.y, p.z], "quaternion": [q.w, q.i, q.j, q.k]},
        "duration": r.duration,
        "every": r.opts.every,
        "samples": r.times.len(),
        "starts": r.opts.starts,
        "seed": r.opts.seed,
        "min_sigma": r.sigma_floor,
        "arms": arms,
    })
}

// ---------------------------------------------------------------------------------------------
// tandem place

/// `tandem place`'s range.
#[derive(Clone, Debug, Default)]
pub struct PlaceOptions {
    /// Smallest separation, m.
    pub from: Option<f64>,
    /// Largest separation, m.
    pub to: Option<f64>,
    /// Step, m.
    pub step: Option<f64>,
    /// Path sampling step, s.
    pub every: Option<f64>,
    /// Seed of the searches.
    pub seed: u64,
    /// Starts per arm of the branch search at the current separation.
    pub starts: Option<usize>,
}

/// A finished scan.
pub struct PlaceReport {
    /// Scenario name.
    pub name: String,
    /// Two arms: the base separation; more: the mean base distance from the centroid.
    pub two_arms: bool,
    /// The scenario's own separation, m.
    pub current: f64,
    /// Path duration and step, s.
    pub duration: f64,
    /// Path sampling step, s.
    pub every: f64,
    /// The start branch of each arm at the current separation (its first-ranked `tandem ik`
    /// solution).
    pub start: Vec<Vec<f64>>,
    /// The rows.
    pub rows: Vec<SpreadRow>,
    /// The joint names per arm.
    pub names: Vec<Vec<String>>,
}

fn check_len(v: Option<f64>, option: &str) -> Result<Option<f64>> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => {
            Err(BadInput::msg(format!("{option} {x}: give a separation > 0 m")).into())
        }
        v => Ok(v),
    }
}

/// The separations of a scan: `from, from + step, …, ≤ to`; by default 17 around `current`
/// (0.6 to 1.4 times it in steps of 0.05 times it).
pub fn separations(current: f64, o: &PlaceOptions) -> Result<Vec<f64>> {
    let from = check_len(o.from, "--from")?;
    let to = check_len(o.to, "--to")?;
    let step = check_len(o.step, "--step")?;
    if o.from.is_none() && o.to.is_none() && o.step.is_none() {
        return Ok((0..=16)
            .map(|k| current + (k as f64 - 8.0) * 0.05 * current)
            .collect());
    }
    let from = from.unwrap_or(0.6 * current);
    let to = to.unwrap_or(1.4 * current);
    if to < from {
        return Err(BadInput::msg(format!(
            "--to {to}: smaller than --from {from}{}",
            if o.from.is_none() {
                " (the default: 0.6 × the scenario's separation)"
            } else {
                ""
            }
        ))
        .into());
    }
    let step = step.unwrap_or(0.05 * current);
    let n = ((to - from) / step + 1e-9).floor();
    if !(n < MAX_SEPARATIONS as f64) {
        return Err(BadInput::msg(format!(
            "--step {step}: {from} to {to} m in steps of {step} m is more than {MAX_SEPARATIONS} separations; give a larger step"
        ))
        .into());
    }
    Ok((0..=n as usize).map(|k| from + k as f64 * step).collect())
}

/// `tandem place`: the scan over separations.
pub fn place(src: &Source, sc: &SpatialScenario, o: &PlaceOptions) -> Result<PlaceReport> {
    if sc.arms.len() < 2 {
        return Err(BadInput::msg(format!(
            "tandem place moves the arms' bases apart; {} has {} arm",
            src.display,
            sc.arms.len()
        ))
        .into());
    }
    let starts = check_starts(o.starts.unwrap_or(DEFAULT_STARTS))?;
    let (b, plant) = build(src, sc)?;
    let every = o.every.unwrap_or(DEFAULT_EVERY);
    let times = times(b.sim.duration, every, "--every")?;
    let current = placement::base_spread(&b.plant).unwrap_or(0.0);
    if !(current > 1e-9) {
        return Err(BadInput::msg(format!(
            "tandem place moves the bases along the line joining them; in {} they sit at one point",
            src.display
        ))
        .into());
    }
    let ds = separations(current, o)?;
    // The best branch of each arm at the current separation.
    let search = SearchOptions {
        starts,
        seed: o.seed,
        times: times.clone(),
        sigma_floor: b.sim.min_sigma,
    };
    let mut start = Vec::new();
    let mut names = Vec::new();
    for (i, arm) in plant.arms().iter().enumerate() {
        let s = plant.offset(i);
        let n = arm.chain.dof();
        let sol = branches::arm_solutions(
            &plant,
            i,
            &b.start.x_wo,
            &path_pose(&b),
            &b.start.q_guess[s..s + n],
            &search,
        );
        let Some(best) = sol.solutions.first() else {
            return Err(BadInput::msg(format!(
                "arms[{i}]: no inverse-kinematics solution inside the joint limits at the start pose at the scenario's own placement ({} starts); `tandem ik` lists the search",
                starts
            ))
            .into());
        };
        start.push(best.q.clone());
        names.push(arm.chain.joints.iter().map(|j| j.name.clone()).collect());
    }
    let rows = placement::scan(
        &b.plant,
        &b.start.x_wo,
        &path_pose(&b),
        &start,
        &ds,
        &ScanOptions {
            times,
            sigma_floor: b.sim.min_sigma,
            starts: PLACE_STARTS,
            seed: o.seed,
        },
    )
    .map_err(|e| BadInput::msg(e.to_string()))?;
    Ok(PlaceReport {
        name: sc.name.clone().unwrap_or_else(|| src.name.clone()),
        two_arms: sc.arms.len() == 2,
        current,
        duration: b.sim.duration,
        every,
        start,
        rows,
        names,
    })
}

/// The reachable separations as closed intervals of consecutive reachable rows.
pub fn reachable_ranges(rows: &[SpreadRow]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut open: Option<(f64, f64)> = None;
    for r in rows {
        if r.reachable {
            open = Some(match open {
                None => (r.d, r.d),
                Some((a, _)) => (a, r.d),
            });
        } else if let Some(x) = open.take() {
            out.push(x);
        }
    }
    out.extend(open);
    out
}

fn row_sigma(r: &SpreadRow) -> f64 {
    r.arms
        .iter()
        .map(|a| a.path.as_ref().map_or(f64::NAN, |c| c.sigma_min))
        .fold(f64::INFINITY, f64::min)
}

/// The reachable row with the largest smallest-arm `σ_min` along the path.
pub fn best_row(rows: &[SpreadRow]) -> Option<&SpreadRow> {
    rows.iter()
        .filter(|r| r.reachable)
        .max_by(|a, b| row_sigma(a).total_cmp(&row_sigma(b)))
}

fn why_not(r: &SpreadRow) -> String {
    let mut why = Vec::new();
    for (i, a) in r.arms.iter().enumerate() {
        match &a.path {
            None => why.push(format!("arm {i}: no solution at the start on any branch")),
            Some(c) => {
                if let Some(f) = &c.failure {
                    why.push(format!("arm {i}: at t = {} s {}", short(f.t), f.reason));
                }
            }
        }
    }
    why.join("; ")
}

/// The terminal text of `tandem place`.
pub fn place_text(r: &PlaceReport) -> String {
    let what = if r.two_arms {
        "base separation"
    } else {
        "mean base distance from their centroid"
    };
    let mut s = format!(
        "{}: placement scan of the {what} (now {:.3} m); path every {} s over {} s; each arm starts on its best branch of `tandem ik` and is continued in the separation (another branch searched where that one fails)\n\n",
        r.name,
        r.current,
        short(r.every),
        short(r.duration)
    );
    let m = r.start.len();
    let mut head = vec!["d (m)".to_string(), "reachable".into()];
    head.push(format!(
        "path min σ_min ({})",
        (0..m)
            .map(|i| format!("arm {i}"))
            .collect::<Vec<_>>()
            .join(" / ")
    ));
    head.push("max |τ|/effort".into());
    head.push("min limit margin (rad)".into());
    head.push("lowest (m)".into());
    head.push("closest approach (m)".into());
    head.push("note".into());
    let mut rows = vec![head];
    for row in &r.rows {
        let mut note = String::new();
        if !row.reachable {
            note = why_not(row);
        } else if row.arms.iter().any(|a| a.searched) {
            let who: Vec<String> = row
                .arms
                .iter()
                .enumerate()
                .filter(|(_, a)| a.searched)
                .map(|(i, a)| match (&a.start, &a.continued_failure) {
                    (None, _) => format!("arm {i} on another branch (its own has no start here)"),
                    (Some(_), Some(f)) => format!(
                        "arm {i} on another branch (its own at t = {} s: {})",
                        short(f.t),
                        f.reason
                    ),
                    (Some(_), None) => format!("arm {i} on another branch"),
                })
                .collect();
            note = who.join("; ");
        }
        let sig: Vec<String> = row
            .arms
            .iter()
            .map(|a| {
                a.path
                    .as_ref()
                    .filter(|c| c.samples > 0)
                    .map_or("–".into(), |c| format!("{:.3}", c.sigma_min))
            })
            .collect();
        let tau = row
            .arms
            .iter()
            .filter_map(|a| a.path.as_ref().filter(|c| c.samples > 0))
            .map(|c| c.torque_ratio)
            .fold(f64::NAN, f64::max);
        let margin = row
            .arms
            .iter()
            .filter_map(|a| a.path.as_ref().filter(|c| c.samples > 0))
            .map(|c| c.limit_margin)
            .fold(f64::NAN, f64::min);
        let lowest = row
            .arms
            .iter()
            .filter_map(|a| a.path.as_ref().filter(|c| c.samples > 0))
            .map(|c| c.lowest)
            .fold(f64::NAN, f64::min);
        let here = (row.d - r.current).abs() < 1e-9 * r.current;
        rows.push(vec![
            format!("{:.3}{}", row.d, if here { " (now)" } else { "" }),
            if row.reachable { "yes" } else { "no" }.into(),
            sig.join(" / "),
            if tau.is_nan() { "–".into() } else { pct(tau) },
            if margin.is_nan() {
                "–".into()
            } else if margin.is_finite() {
                format!("{margin:.3}")
            } else {
                "no limits".into()
            },
            if lowest.is_nan() {
                "–".into()
            } else {
                format!("{lowest:.3}")
            },
            row.closest_approach
                .map_or("–".into(), |c| format!("{c:.3}")),
            note,
        ]);
    }
    s.push_str(&columns(&rows));
    s.push('\n');
    s.push_str(&suggestion(r));
    s
}

fn suggestion(r: &PlaceReport) -> String {
    let ranges = reachable_ranges(&r.rows);
    if ranges.is_empty() {
        return "no separation scanned keeps the whole path reachable: widen the range (--from, --to), or change the grasps or the path\n".into();
    }
    let list: Vec<String> = ranges
        .iter()
        .map(|(a, b)| {
            if a == b {
                format!("{a:.3} m")
            } else {
                format!("{a:.3}–{b:.3} m")
            }
        })
        .collect();
    let inside = ranges
        .iter()
        .any(|(a, b)| r.current >= a - 1e-9 && r.current <= b + 1e-9);
    let (lo, hi) = (
        r.rows.first().map_or(f64::NAN, |x| x.d),
        r.rows.last().map_or(f64::NAN, |x| x.d),
    );
    let scanned = r.current >= lo - 1e-9 && r.current <= hi + 1e-9;
    let mut s = format!(
        "reachable (the whole path inside the limits on some branch, for every arm): {}\n",
        list.join(", ")
    );
    if let Some(b) = best_row(&r.rows) {
        s.push_str(&format!(
            "best conditioned: {:.3} m (smallest σ_min along the path over the arms {:.4})\n",
            b.d,
            row_sigma(b)
        ));
    }
    if scanned {
        s.push_str(&format!(
            "the scenario's current {:.3} m is {} the reachable range{}\n",
            r.current,
            if inside { "inside" } else { "outside" },
            if ranges.len() > 1 { "s" } else { "" }
        ));
    } else {
        s.push_str(&format!(
            "the scenario's current {:.3} m is outside the scanned {lo:.3}–{hi:.3} m\n",
            r.current
        ));
    }
    s
}

/// The JSON of `tandem place` (`written_by` first).
pub fn place_json(r: &PlaceReport) -> Value {
    let rows: Vec<Value> = r
        .rows
        .iter()
        .map(|row| {
            json!({
                "d": row.d,
                "reachable": row.reachable,
                "closest_approach": row.closest_approach,
                "arms": row.arms.iter().enumerate().map(|(i, a)| json!({
                    "start": a.start,
                    "searched_another_branch": a.searched,
                    "continued_failure": a.continued_failure.as_ref().map(|f| json!({"t": f.t, "reason": f.reason})),
                    "sigma_min_start": if a.sigma_start.is_finite() { json!(a.sigma_start) } else { Value::Null },
                    "path": a.path.as_ref().map(|c| path_json(c, &r.names[i])),
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    let best = best_row(&r.rows).map(|b| json!({"d": b.d, "sigma_min": row_sigma(b)}));
    json!({
        "written_by": format!("tandem place {}", env!("CARGO_PKG_VERSION")),
        "scenario": r.name,
        "separation": if r.two_arms { "base separation, m" } else { "mean base distance from the centroid, m" },
        "current": r.current,
        "duration": r.duration,
        "every": r.every,
        "start_branches": r.start,
        "reachable": reachable_ranges(&r.rows).iter().map(|(a, b)| json!([a, b])).collect::<Vec<_>>(),
        "best": best,
        "rows": rows,
    })
}

/// Check `--json FILE` before any work (and again before writing): a folder is refused; an
/// existing file only with `force`, and then only one tandem ik/place wrote, never an input.
pub fn check_json_out(p: &Path, force: bool, protected: &[Input], command: &str) -> Result<()> {
    if std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir()) {
        return Err(BadInput::msg(format!(
            "--json {}: is a folder; give the file to write",
            p.display()
        ))
        .into());
    }
    if std::fs::symlink_metadata(p).is_err() {
        return Ok(());
    }
    if force {
        return files::check_file_replaceable(p, protected, WRITTEN_MARKS);
    }
    Err(BadInput::msg(format!(
        "--json {}: exists (nothing was written); add --force to replace it (only a file {command} wrote), or choose another file",
        p.display()
    ))
    .into())
}

/// Write `value` to `--json FILE` whole or not at all (checked again just before).
pub fn write_json(
    p: &Path,
    value: &Value,
    force: bool,
    protected: &[Input],
    command: &str,
) -> Result<()> {
    check_json_out(p, force, protected, command)?;
    if let Some(parent) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| {
            anyhow::anyhow!(
                "cannot create the folder {} for --json: {e}",
                parent.display()
            )
        })?;
    }
    files::write_json_atomic(p, value)
}

/// The scenario's inputs (never replaced by `--json --force`).
pub fn protected(src: &Source, sc: &SpatialScenario) -> Vec<Input> {
    scenario::inputs(src, sc)
}
