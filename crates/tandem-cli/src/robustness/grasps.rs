//! `tandem robustness` on a spatial scenario: the compliant-grasp sweep (issue 24, "hold on
//! compliant grasps"). The scenario's grasps are made compliant springs in the true plant while
//! the laws keep assuming welds, over stiffness × damping × law, without and with the actuator
//! stage's output filter; each run is scored by the spatial `summary.json` (violating ticks,
//! chattering ticks, the S5 claims, a fault's time).
//!
//! - **Stiffness** ([`STIFFNESS`]): a soft pad 1e4 N/m / 1e2 N m/rad, a firm parallel gripper
//!   1e5 / 1e3 (the issue's level, [`FIRM`]), a stiff one 1e6 / 1e4; diagonal in the grasp axes.
//! - **Damping** ([`DAMPING_RATIOS`]): 0.3, 1 and 3 times critical against the lightest body on
//!   the spring, the tool link (`d = ζ 2√(k m_tip)`, `d_rot = ζ 2√(k_rot I_tip)`, with the
//!   smallest tool-link mass and principal inertia over the arms: `scenario::spatial::grasp_tip`).
//! - **Laws** ([`LAWS`]): the defaults, NN, PD with the model's gravity and computed torque,
//!   with the scenario's own gains.
//! - **Filter**: none, and the first-order output filter at [`FILTER_PERIODS`] control periods
//!   (the knob the `validate` warning names for a tool-link mode faster than the loop).
//! - The plant step resolves the stiffest level's tool-link mode (`h ω ≤ 1`, a whole number of
//!   steps per control period); a grasp deflected past the compliant default `max_drift`
//!   (0.05 m or rad) has slipped and stops the run with its fault.
//!
//! The runs go through the sweep machinery (`sweep::run`), so each is exactly what
//! `tandem sweep` or `tandem run` would do with the same fields set.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Result, bail};
use serde_json::{Value as Json, json};
use toml::{Table, Value};

use crate::files;
use crate::scenario::spatial as sp;
use crate::scenario::{Kind, Scenario, Source};
use rayon::prelude::*;

use crate::sweep::run::{header, one, progress};
use crate::sweep::{Sweep, fields};

/// Grasp stiffness levels, (N/m, N m/rad): a soft pad, a firm parallel gripper, a stiff one.
pub const STIFFNESS: [(f64, f64); 3] = [(1e4, 1e2), (1e5, 1e3), (1e6, 1e4)];
/// The firm gripper of the issue, where the default laws must hold without violations.
pub const FIRM: (f64, f64) = (1e5, 1e3);
/// Damping as a multiple of critical against the tool link.
pub const DAMPING_RATIOS: [f64; 3] = [0.3, 1.0, 3.0];
/// The default laws (`controller.kind`; `pd` runs with the model's gravity).
pub const LAWS: [&str; 3] = ["nn", "pd", "ctc"];
/// The output filter's time constant, in control periods: the one `validate` names.
pub const FILTER_PERIODS: f64 = sp::GRASP_FILTER_PERIODS;
/// Simulated time of a run when `--duration` is not given, s (the S5 claims are measured
/// after 2 s).
pub const DEFAULT_DURATION: f64 = 4.0;

/// Which cells to run (the full grid by default; tests run a corner).
#[derive(Clone, Debug)]
pub struct Grid {
    /// Stiffness levels.
    pub stiffness: Vec<(f64, f64)>,
    /// Damping ratios.
    pub ratios: Vec<f64>,
    /// Laws (`controller.kind` values).
    pub laws: Vec<String>,
    /// Without the filter, with it.
    pub filters: Vec<bool>,
}

impl Default for Grid {
    fn default() -> Self {
        Grid {
            stiffness: STIFFNESS.to_vec(),
            ratios: DAMPING_RATIOS.to_vec(),
            laws: LAWS.iter().map(|s| s.to_string()).collect(),
            filters: vec![false, true],
        }
    }
}

/// One run of the sweep.
#[derive(Clone, Debug)]
pub struct GraspCell {
    /// `controller.kind`.
    pub law: String,
    /// (N/m, N m/rad).
    pub stiffness: (f64, f64),
    /// Multiple of critical damping.
    pub ratio: f64,
    /// (N s/m, N m s/rad).
    pub damping: (f64, f64),
    /// Output filter time constant, s.
    pub filter_s: Option<f64>,
    /// Plant step, s.
    pub plant_step: f64,
    /// `completed`, `fault` or `invalid`.
    pub status: String,
    /// The fault or the loader's message.
    pub message: String,
    /// Simulated time reached, s.
    pub t_end_s: Option<f64>,
    /// Ticks outside the output bounds.
    pub violation_ticks: Option<f64>,
    /// Ticks on which a joint chattered (issue 24's count).
    pub chatter_ticks: Option<f64>,
    /// The S5 claims.
    pub s5_pass: Option<bool>,
    /// Largest `‖z1_p‖` after 2 s, m.
    pub z1_p_max_after_2s_m: Option<f64>,
    /// Largest `‖z1_φ‖` after 2 s, rad.
    pub z1_rot_max_after_2s_rad: Option<f64>,
}

impl GraspCell {
    /// Completed, inside the bounds, no chattering and the S5 claims met.
    pub fn clean(&self) -> bool {
        self.held() && self.chatter_ticks == Some(0.0) && self.s5_pass == Some(true)
    }

    /// Completed without a violating tick (the issue's bar: "completed, 0 violations").
    pub fn held(&self) -> bool {
        self.status == "completed" && self.violation_ticks == Some(0.0)
    }

    /// The table cell: `violating / chattering ticks, S5` or the fault's time.
    fn cell(&self) -> String {
        match self.status.as_str() {
            "completed" => format!(
                "{} / {}, {}",
                count(self.violation_ticks),
                count(self.chatter_ticks),
                match self.s5_pass {
                    Some(true) => "S5",
                    Some(false) => "S5 ✗",
                    None => "S5 –",
                }
            ),
            "fault" => match self.t_end_s {
                Some(t) => format!("**fault {t:.2} s**"),
                None => "**fault**".into(),
            },
            _ => "invalid".into(),
        }
    }

    fn json(&self) -> Json {
        json!({
            "law": self.law,
            "stiffness": [self.stiffness.0, self.stiffness.1],
            "damping_ratio": self.ratio,
            "damping": [self.damping.0, self.damping.1],
            "filter_time_constant_s": self.filter_s,
            "plant_step_s": self.plant_step,
            "status": self.status,
            "message": self.message,
            "t_end_s": self.t_end_s,
            "violation_ticks": self.violation_ticks,
            "chatter_ticks": self.chatter_ticks,
            "s5_pass": self.s5_pass,
            "z1_p_max_after_2s_m": self.z1_p_max_after_2s_m,
            "z1_rot_max_after_2s_rad": self.z1_rot_max_after_2s_rad,
            "clean": self.clean(),
        })
    }
}

fn count(v: Option<f64>) -> String {
    v.map_or_else(|| "–".into(), |x| format!("{x:.0}"))
}

/// The finished sweep.
#[derive(Clone, Debug)]
pub struct GraspSweep {
    /// Scenario name.
    pub name: String,
    /// Every run, filter slowest, then law, stiffness and damping.
    pub cells: Vec<GraspCell>,
    /// The tool link the damping is critical against, (kg, kg m²).
    pub tip: (f64, f64),
    /// Control period, s.
    pub control_period: f64,
    /// Simulated time of each run, s.
    pub duration: f64,
    /// What of the base was set aside (contact pads, an earlier compliance, `max_drift`).
    pub set_aside: Vec<String>,
    /// The `validate` warnings the firm level (critically damped, NN, no filter) gets about
    /// the filter and the NN law's damping.
    pub firm_warnings: Vec<String>,
}

impl GraspSweep {
    /// The run of a cell, if it ran.
    pub fn find(
        &self,
        law: &str,
        stiffness: (f64, f64),
        ratio: f64,
        filter: bool,
    ) -> Option<&GraspCell> {
        self.cells.iter().find(|c| {
            c.law == law
                && c.stiffness == stiffness
                && c.ratio == ratio
                && c.filter_s.is_some() == filter
        })
    }
}

/// Remove `path` (dot-separated table keys) from `doc`; true if it was there.
fn remove(doc: &mut Table, path: &str) -> bool {
    let mut keys: Vec<&str> = path.split('.').collect();
    let Some(last) = keys.pop() else {
        return false;
    };
    let mut t = doc;
    for k in keys {
        match t.get_mut(k).and_then(Value::as_table_mut) {
            Some(next) => t = next,
            None => return false,
        }
    }
    t.remove(last).is_some()
}

fn arr6(a: f64, b: f64) -> Value {
    Value::Array(
        [a, a, a, b, b, b]
            .iter()
            .map(|v| Value::Float(*v))
            .collect(),
    )
}

/// Run the compliant-grasp sweep of the spatial scenario `src` (`duration` s per run, on
/// `threads` threads), with a progress bar.
pub fn run(src: &Source, grid: &Grid, duration: f64, threads: usize) -> Result<GraspSweep> {
    if !(duration.is_finite() && duration > 2.0) {
        bail!(crate::BadInput::msg(format!(
            "--duration {}: the grasp sweep measures the S5 claims after 2 s; give more than 2 s \
             (default {DEFAULT_DURATION})",
            crate::scenario::num(duration)
        )));
    }
    let sc = match crate::scenario::parse(src)? {
        Scenario::Spatial(sc) => sc,
        Scenario::Planar(_) => bail!("the grasp sweep takes a spatial scenario"),
    };
    // The scenario itself must be valid as it stands (errors with its own fields and lines).
    crate::run::spatial::prepare(sc.clone(), src)?;
    let b = sp::build(&sc, src)?;
    let Some(tip) = sp::grasp_tip(&b.plant.arms) else {
        bail!(crate::BadInput::msg(format!(
            "{}: a tool link without mass or inertia: a compliant grasp needs a body on its \
             spring (set tool_link to a link with an <inertial>)",
            src.display
        )));
    };
    let set = |doc: &mut Table, path: &str, v: Value| {
        fields::set(doc, path, v).map_err(|e| anyhow::anyhow!("{path}: {e}"))
    };
    let t_c = b.sim.control_period;
    let base_step = b.sim.plant_step;

    let mut doc: Table = toml::from_str(&src.text)?;
    let mut set_aside = Vec::new();
    for (path, what) in [
        (
            "plant.contact_grasps",
            "the contact pads ([plant.contact_grasps])",
        ),
        (
            "plant.compliant_grasps",
            "the file's own compliance ([plant.compliant_grasps])",
        ),
        (
            "run.max_drift",
            "run.max_drift (the compliant default, 0.05 m or rad, applies)",
        ),
        (
            "controller.replay",
            "controller.replay (the laws are varied)",
        ),
    ] {
        if remove(&mut doc, path) {
            set_aside.push(what.to_string());
        }
    }
    // The friction-aware distribution needs the pads just set aside.
    let friction = doc
        .get("controller")
        .and_then(|c| c.get("distribution"))
        .and_then(Value::as_str)
        == Some("friction");
    if friction && remove(&mut doc, "controller.distribution") {
        remove(&mut doc, "controller.friction_margin");
        set_aside.push(
            "controller.distribution = \"friction\" and its friction_margin (they need the pads; \
             the default distribution applies)"
                .to_string(),
        );
    }
    set(&mut doc, "run.duration", Value::Float(duration))?;
    set(
        &mut doc,
        "controller.pd.gravity_compensation",
        Value::Boolean(true),
    )?;
    let damping =
        |(k, kr): (f64, f64), z: f64| (z * 2.0 * (k * tip.0).sqrt(), z * 2.0 * (kr * tip.1).sqrt());
    // Each grasp's plant step: the base's, or shorter so that the tool link's fastest root on
    // the spring is resolved (h |λ| ≤ 1), a whole number of steps per control period.
    let grasp = |doc: &mut Table, k: (f64, f64), z: f64| -> Result<f64> {
        let d = damping(k, z);
        let (s6, d6) = (
            [k.0, k.0, k.0, k.1, k.1, k.1],
            [d.0, d.0, d.0, d.1, d.1, d.1],
        );
        let w = sp::grasp_fastest_mode(&b.plant.arms, &s6, Some(&d6)).map_or(0.0, |m| m.0);
        let n = (w * t_c).ceil().max((t_c / base_step).round()).max(1.0);
        set(doc, "plant.compliant_grasps.stiffness", arr6(k.0, k.1))?;
        set(doc, "plant.compliant_grasps.damping", arr6(d.0, d.1))?;
        set(doc, "run.plant_step", Value::Float(t_c / n))?;
        Ok(t_c / n)
    };
    // The firm level's validate warnings (critically damped, without a filter), as a user
    // would see them: the filter's and the NN damping's.
    let firm_warnings = {
        let mut d = doc.clone();
        grasp(&mut d, FIRM, 1.0)?;
        remove(&mut d, "controller.actuator.filter_time_constant");
        set(&mut d, "controller.kind", Value::String("nn".into()))?;
        let s = crate::sweep::doc_source(&d, src, &src.display).map_err(anyhow::Error::msg)?;
        match crate::scenario::parse(&s) {
            Ok(Scenario::Spatial(sc)) => crate::run::spatial::prepare(sc, &s)
                .map(|p| {
                    p.ready
                        .warnings
                        .into_iter()
                        .filter(|w| {
                            w.contains("filter_time_constant") || w.contains("controller.nn")
                        })
                        .collect()
                })
                .unwrap_or_default(),
            _ => Vec::new(),
        }
    };

    // Every cell a one-run sweep of its own document (filter slowest, then law, stiffness and
    // damping), each run 0 of a sweep seeded with the scenario's `run.seed`: the same sensor
    // noise in every cell.
    let mut jobs = Vec::new();
    for &filter in &grid.filters {
        let filter_s = filter.then_some(FILTER_PERIODS * t_c);
        for law in &grid.laws {
            for &k in &grid.stiffness {
                for &z in &grid.ratios {
                    let mut d = doc.clone();
                    set(&mut d, "controller.kind", Value::String(law.clone()))?;
                    let h = grasp(&mut d, k, z)?;
                    match filter_s {
                        Some(f) => set(
                            &mut d,
                            "controller.actuator.filter_time_constant",
                            Value::Float(f),
                        )?,
                        None => {
                            remove(&mut d, "controller.actuator.filter_time_constant");
                        }
                    }
                    let sw = Sweep {
                        display: format!("{} (grasp sweep)", src.display),
                        base: src.clone(),
                        doc: d,
                        params: Vec::new(),
                        draws: 1,
                        seed: sc.run.seed,
                        total: 1,
                        base_name: src.name.clone(),
                        kind: Kind::Spatial,
                    };
                    jobs.push((sw, law.clone(), k, z, filter_s, h));
                }
            }
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let bar = progress(jobs.len() as u64, "grasps");
    let cells: Vec<GraspCell> = pool.install(|| {
        jobs.par_iter()
            .map(|(sw, law, k, z, filter_s, h)| {
                let r = one(sw, 0, None);
                bar.inc(1);
                let head = header(sw);
                let get = |name: &str| {
                    head.iter()
                        .position(|c| c == name)
                        .and_then(|c| r.row.cells.get(c))
                        .cloned()
                };
                let num = |name: &str| get(name).and_then(|s| s.parse::<f64>().ok());
                GraspCell {
                    law: law.clone(),
                    stiffness: *k,
                    ratio: *z,
                    damping: damping(*k, *z),
                    filter_s: *filter_s,
                    plant_step: *h,
                    status: get("status").unwrap_or_default(),
                    message: get("message").unwrap_or_default(),
                    t_end_s: num("t_end_s"),
                    violation_ticks: num("violation_ticks"),
                    chatter_ticks: num("chatter_ticks"),
                    s5_pass: get("s5_pass").and_then(|s| s.parse().ok()),
                    z1_p_max_after_2s_m: num("z1_p_max_after_2s_m"),
                    z1_rot_max_after_2s_rad: num("z1_rot_max_after_2s_rad"),
                }
            })
            .collect()
    });
    bar.finish_and_clear();
    // A cell the loader refused is a set-up this sweep could not make of the scenario, not a
    // result: all of them refused is an error with the loader's message.
    if let Some(first) = cells.iter().find(|c| c.status == "invalid")
        && cells.iter().all(|c| c.status == "invalid")
    {
        bail!(crate::BadInput::msg(format!(
            "{}: the grasp sweep could not set up a run of this scenario: {}",
            src.display, first.message
        )));
    }
    Ok(GraspSweep {
        name: src.name.clone(),
        cells,
        tip,
        control_period: t_c,
        duration,
        set_aside,
        firm_warnings,
    })
}

/// `no filter` or `filter 5 ms`.
fn filter_label(filter: bool, control_period: f64) -> String {
    if filter {
        format!(
            "filter {} ms",
            crate::scenario::num(FILTER_PERIODS * control_period * 1e3)
        )
    } else {
        "no filter".into()
    }
}

fn law_name(l: &str) -> &str {
    match l {
        "nn" => "NN",
        "pd" => "PD + gravity",
        "ctc" => "CTC",
        other => other,
    }
}

fn e10(v: f64) -> String {
    format!("1e{}", v.log10().round())
}

/// The report: method, one table per filter setting, the verdict at the firm level.
pub fn markdown(s: &GraspSweep, grid: &Grid, command: &str) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Compliant grasps: `{}`\n\nMade by `{command}` (tandem {}).\n",
        s.name,
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        md,
        "The true grasps are compliant springs (diagonal in the grasp axes) while every law \
         assumes welds. Damping is a multiple ζ of critical against the lightest tool link \
         ({} kg, {} kg m²): `d = ζ 2√(k m)`, `d_rot = ζ 2√(k_rot I)`. Each run is {} s at a \
         plant step that resolves its grasp's fastest root on the tool link (`h |λ| ≤ 1`, a whole \
         number of steps per {} ms control period: {} to {} ms); PD runs with the model's \
         gravity; a grasp deflected past 0.05 m or rad has slipped (a fault). The filter is the \
         actuator stage's first-order output filter at {} control periods \
         (`[controller.actuator] filter_time_constant`).",
        crate::scenario::num(s.tip.0),
        crate::scenario::num(s.tip.1),
        crate::scenario::num(s.duration),
        crate::scenario::num(s.control_period * 1e3),
        sig3(
            s.cells
                .iter()
                .map(|c| c.plant_step)
                .fold(f64::INFINITY, f64::min)
                * 1e3
        ),
        sig3(s.cells.iter().map(|c| c.plant_step).fold(0.0, f64::max) * 1e3),
        crate::scenario::num(FILTER_PERIODS),
    );
    if !s.set_aside.is_empty() {
        let _ = writeln!(
            md,
            "\nSet aside from the scenario: {}.",
            s.set_aside.join("; ")
        );
    }
    for &filter in &grid.filters {
        let what = filter_label(filter, s.control_period);
        let _ = writeln!(
            md,
            "\n## {what}\n\nViolating ticks / chattering ticks, and the S5 claims after 2 s.\n"
        );
        let _ = write!(
            md,
            "| stiffness (N/m, N m/rad) | damping ζ (N s/m, N m s/rad) |"
        );
        for l in &grid.laws {
            let _ = write!(md, " {} |", law_name(l));
        }
        let _ = write!(md, "\n|---|---|");
        for _ in &grid.laws {
            md.push_str("---|");
        }
        md.push('\n');
        for &k in &grid.stiffness {
            for &z in &grid.ratios {
                let first = grid.laws.iter().find_map(|l| s.find(l, k, z, filter));
                let Some(c0) = first else { continue };
                let _ = write!(
                    md,
                    "| {}, {} | {} ({}, {}) |",
                    e10(k.0),
                    e10(k.1),
                    crate::scenario::num(z),
                    sig3(c0.damping.0),
                    sig3(c0.damping.1)
                );
                for l in &grid.laws {
                    let c = s
                        .find(l, k, z, filter)
                        .map_or_else(|| "–".into(), GraspCell::cell);
                    let _ = write!(md, " {c} |");
                }
                md.push('\n');
            }
        }
    }
    let _ = writeln!(
        md,
        "\n## The firm gripper ({} N/m, {} N m/rad, critically damped)\n",
        e10(FIRM.0),
        e10(FIRM.1)
    );
    for &filter in &grid.filters {
        for l in &grid.laws {
            if let Some(c) = s.find(l, FIRM, 1.0, filter) {
                let verdict = if c.clean() {
                    "holds: 0 violations, 0 chattering ticks, S5 met"
                } else if c.held() {
                    "completed without violations, but chatters or misses S5"
                } else {
                    "does **not** hold"
                };
                let _ = writeln!(
                    md,
                    "- {}, {}: {} ({}).",
                    law_name(l),
                    if filter { "filtered" } else { "no filter" },
                    verdict,
                    c.cell()
                );
            }
        }
    }
    if s.firm_warnings.is_empty() {
        let _ = writeln!(
            md,
            "\n`tandem validate` gives neither a filter nor an NN-damping warning at this level \
             (NN, critically damped, no filter)."
        );
    } else {
        let _ = writeln!(
            md,
            "\n`tandem validate` warns at this level (NN, critically damped, no filter):\n"
        );
        for w in &s.firm_warnings {
            let _ = writeln!(md, "> {w}\n");
        }
    }
    md
}

fn sig3(v: f64) -> String {
    crate::output::table::num(v, 3)
}

/// The figure: one panel per filter setting, rows stiffness × damping, columns the laws; green
/// clean, amber completed inside the bounds but chattering or missing S5, red violations or a
/// fault.
pub fn svg(s: &GraspSweep, grid: &Grid) -> String {
    let (cw, ch, left, top, gap) = (90.0, 22.0, 200.0, 60.0, 30.0);
    let nl = grid.laws.len() as f64;
    let nrow = (grid.stiffness.len() * grid.ratios.len()) as f64;
    let pw = left + cw * nl;
    let ph = top + ch * nrow;
    let np = grid.filters.len().max(1) as f64;
    let (w, h) = (np * pw + (np - 1.0) * gap + 20.0, ph + 60.0);
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="DejaVu Sans, sans-serif" font-size="11">"#
    );
    let _ = writeln!(o, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        o,
        r#"<text x="{}" y="18" text-anchor="middle" font-size="14">{}: compliant grasps under laws that assume welds (green clean; amber chattering or S5 missed; red violations or fault)</text>"#,
        w / 2.0,
        xml(&s.name)
    );
    for (fi, &filter) in grid.filters.iter().enumerate() {
        let x0 = fi as f64 * (pw + gap);
        let y0 = 30.0;
        let what = filter_label(filter, s.control_period);
        let _ = writeln!(
            o,
            r#"<text x="{}" y="{}" font-size="12">{what}</text>"#,
            x0 + left,
            y0 + 20.0
        );
        for (li, l) in grid.laws.iter().enumerate() {
            let _ = writeln!(
                o,
                r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
                x0 + left + cw * li as f64 + cw / 2.0,
                y0 + top - 6.0,
                law_name(l)
            );
        }
        let mut row = 0.0;
        for &k in &grid.stiffness {
            for &z in &grid.ratios {
                let y = y0 + top + ch * row;
                row += 1.0;
                let _ = writeln!(
                    o,
                    r#"<text x="{}" y="{}" text-anchor="end">k {} / {}, ζ {}</text>"#,
                    x0 + left - 6.0,
                    y + 15.0,
                    e10(k.0),
                    e10(k.1),
                    crate::scenario::num(z)
                );
                for (li, l) in grid.laws.iter().enumerate() {
                    let Some(c) = s.find(l, k, z, filter) else {
                        continue;
                    };
                    let colour = if c.clean() {
                        "#2ca02c"
                    } else if c.held() {
                        "#ffbf47"
                    } else {
                        "#d62728"
                    };
                    let label = match c.status.as_str() {
                        "completed" => {
                            format!("{}/{}", count(c.violation_ticks), count(c.chatter_ticks))
                        }
                        "fault" => "fault".into(),
                        _ => "invalid".into(),
                    };
                    let xx = x0 + left + cw * li as f64;
                    let _ = writeln!(
                        o,
                        r#"<rect x="{}" y="{}" width="{}" height="{}" fill="{colour}"/>"#,
                        xx + 1.0,
                        y + 1.0,
                        cw - 2.0,
                        ch - 2.0
                    );
                    let _ = writeln!(
                        o,
                        r#"<text x="{}" y="{}" text-anchor="middle">{label}</text>"#,
                        xx + cw / 2.0,
                        y + 15.0
                    );
                }
            }
        }
    }
    o.push_str("</svg>\n");
    o
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Write `robustness.md`, `robustness.json` and `figures/robustness_grasps.svg` into `dir`.
pub fn write(dir: &Path, s: &GraspSweep, grid: &Grid, command: &str) -> Result<()> {
    files::write_text_atomic(&dir.join("robustness.md"), &markdown(s, grid, command))?;
    let j = json!({
        "tandem_version": env!("CARGO_PKG_VERSION"),
        "scenario": s.name,
        "command": command,
        "family": "compliant grasps (stiffness × damping × law × filter)",
        "tip_mass_kg": s.tip.0,
        "tip_inertia_kg_m2": s.tip.1,
        "control_period_s": s.control_period,
        "duration_s": s.duration,
        "set_aside": s.set_aside,
        "firm_level_validate_warnings": s.firm_warnings,
        "runs": s.cells.iter().map(GraspCell::json).collect::<Vec<_>>(),
    });
    files::write_json_atomic(&dir.join("robustness.json"), &j)?;
    let figs = dir.join("figures");
    std::fs::create_dir_all(&figs)?;
    files::write_text_atomic(&figs.join("robustness_grasps.svg"), &svg(s, grid))?;
    Ok(())
}
