//! Running a sweep (or one shard of it) across cores, and its table.
//!
//! `runs.csv` has one row per run, in index order: `index`, `seed` (the run's `run.seed`), one
//! column per varied field (named by its path; an array value is one quoted cell `[4, 4, 4]`),
//! `status` (`completed`, `fault`, or `invalid` when the scenario loader rejected the run's
//! values), `message` (the fault or the loader's message), then the summary metrics of
//! `summary.json` ([`METRICS`]; arrays get `.x`/`.y`/`.theta` or `.min`/`.max` suffixes; a
//! spatial base has the spatial `summary.json`'s metrics instead, [`SPATIAL_METRICS`]). An
//! empty cell is a metric that does not exist for that run (`null` in `summary.json`). Numbers
//! are in shortest round-trip form, so the table is the same for any thread count or sharding.

use std::path::Path;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value as Json;

use super::{Shard, Sweep, cell, fmt_f64, load_doc};
use crate::output::planar::{self as planar_output, Outputs};
use crate::run::planar as runner;
use crate::scenario::{Kind, Scenario, Source};

/// The metric columns: (column, JSON pointer into `summary.json`).
pub const METRICS: &[(&str, &str)] = &[
    ("t_end", "/t_end"),
    ("rms_z1", "/rms_z1"),
    ("max_z1", "/max_z1"),
    ("rms_z1_after", "/rms_z1_after"),
    ("max_z1_after", "/max_z1_after"),
    ("max_z1_theta_after", "/max_z1_theta_after"),
    ("settling_time_1mm", "/settling_time_1mm"),
    ("min_margin", "/min_margin"),
    ("violations", "/violations"),
    ("rms_wrench", "/rms_wrench"),
    ("peak_wrench", "/peak_wrench"),
    ("wrench_roughness", "/wrench_roughness"),
    ("rms_joint_torque", "/rms_joint_torque"),
    ("peak_joint_torque", "/peak_joint_torque"),
    ("grasp_force_range.min", "/grasp_force_range/0"),
    ("grasp_force_range.max", "/grasp_force_range/1"),
    ("weight_settling_time.x", "/weight_settling_time/0"),
    ("weight_settling_time.y", "/weight_settling_time/1"),
    ("weight_settling_time.theta", "/weight_settling_time/2"),
    ("final_weight_norms.x", "/final_weight_norms/0"),
    ("final_weight_norms.y", "/final_weight_norms/1"),
    ("final_weight_norms.theta", "/final_weight_norms/2"),
    ("barrier_hits", "/events/barrier_hits"),
    ("torque_clips", "/events/torque_clips"),
    ("non_finite", "/events/non_finite"),
    ("degenerate", "/events/degenerate"),
    ("max_drift", "/max_drift"),
    ("regularised", "/regularised"),
    ("rms_path_error_after", "/rms_path_error_after"),
    ("max_path_error_after", "/max_path_error_after"),
    ("max_path_error_theta_after", "/max_path_error_theta_after"),
    ("peak_torque_rate_Nm_per_s", "/torque_rate/peak_Nm_per_s"),
    ("chatter_ticks", "/torque_rate/chatter_ticks"),
];

/// A spatial metric column's value in the spatial `summary.json`.
#[derive(Clone, Copy, Debug)]
pub enum Pick {
    /// The value at a JSON pointer.
    At(&'static str),
    /// The smallest of the numbers at `/{array}/{i}{rest}` over the arms `i`.
    MinOverArms(&'static str, &'static str),
    /// The largest of the same.
    MaxOverArms(&'static str, &'static str),
    /// The first of several pointers that exists (a margin is `margin_rad` or `margin_m`).
    First(&'static [&'static str]),
}

/// The metric columns of a spatial base: (column, where in the spatial `summary.json`,
/// [`crate::output::spatial::summary`]). Units are in the names as in `summary.json`; the
/// per-arm metrics are reduced over the arms (any number of arms gives the same columns).
pub const SPATIAL_METRICS: &[(&str, Pick)] = &[
    ("t_end_s", Pick::At("/t_end_s")),
    ("s5_pass", Pick::At("/s5_claims/pass")),
    ("s5_z1_p_pass", Pick::At("/s5_claims/z1_p_after_2s/pass")),
    (
        "s5_z1_rot_pass",
        Pick::At("/s5_claims/z1_rot_after_2s/pass"),
    ),
    ("z1_p_rms_m", Pick::At("/z1_p_rms_m")),
    ("z1_p_max_m", Pick::At("/z1_p_max_m")),
    ("z1_p_rms_after_2s_m", Pick::At("/z1_p_rms_after_2s_m")),
    ("z1_p_max_after_2s_m", Pick::At("/z1_p_max_after_2s_m")),
    (
        "z1_rot_rms_after_2s_rad",
        Pick::At("/z1_rot_rms_after_2s_rad"),
    ),
    (
        "z1_rot_max_after_2s_rad",
        Pick::At("/z1_rot_max_after_2s_rad"),
    ),
    ("settling_time_1mm_s", Pick::At("/settling_time_1mm_s")),
    (
        "orientation_error_rms_after_2s_rad",
        Pick::At("/orientation_error_rms_after_2s_rad"),
    ),
    (
        "orientation_error_max_after_2s_rad",
        Pick::At("/orientation_error_max_after_2s_rad"),
    ),
    (
        "orientation_error_to_desired_max_after_2s_rad",
        Pick::At("/orientation_error_to_desired_max_after_2s_rad"),
    ),
    ("min_margin", Pick::At("/min_margin")),
    ("violation_ticks", Pick::At("/violation_ticks")),
    ("wrench_force_rms_N", Pick::At("/wrench_force_rms_N")),
    ("wrench_force_peak_N", Pick::At("/wrench_force_peak_N")),
    ("wrench_torque_rms_Nm", Pick::At("/wrench_torque_rms_Nm")),
    ("wrench_torque_peak_Nm", Pick::At("/wrench_torque_peak_Nm")),
    ("joint_torque_rms_Nm", Pick::At("/joint_torque_rms_Nm")),
    ("joint_torque_peak_Nm", Pick::At("/joint_torque_peak_Nm")),
    (
        "grasp_force_min_N",
        Pick::MinOverArms("/grasp_wrench", "/force_range_N/0"),
    ),
    (
        "grasp_force_max_N",
        Pick::MaxOverArms("/grasp_wrench", "/force_range_N/1"),
    ),
    (
        "grasp_torque_max_Nm",
        Pick::MaxOverArms("/grasp_wrench", "/torque_range_Nm/1"),
    ),
    (
        "jacobian_sigma_min",
        Pick::MinOverArms("/jacobian_sigma_min", "/sigma_min"),
    ),
    (
        "joint_limit_margin",
        Pick::First(&[
            "/closest_joint_limit/margin_rad",
            "/closest_joint_limit/margin_m",
        ]),
    ),
    ("q_switch_min", Pick::At("/q_switch_min")),
    ("weight_norm_final.x", Pick::At("/weight_norm_final/x")),
    ("weight_norm_final.y", Pick::At("/weight_norm_final/y")),
    ("weight_norm_final.z", Pick::At("/weight_norm_final/z")),
    ("weight_norm_final.rx", Pick::At("/weight_norm_final/rx")),
    ("weight_norm_final.ry", Pick::At("/weight_norm_final/ry")),
    ("weight_norm_final.rz", Pick::At("/weight_norm_final/rz")),
    ("barrier_hits", Pick::At("/events/barrier_hits")),
    ("torque_clips", Pick::At("/events/torque_clips")),
    ("non_finite", Pick::At("/events/non_finite")),
    ("degenerate", Pick::At("/events/degenerate")),
    ("max_drift_m", Pick::At("/max_drift_m")),
    ("max_drift_rad", Pick::At("/max_drift_rad")),
    ("regularised", Pick::At("/regularised")),
    (
        "path_error_p_rms_after_2s_m",
        Pick::At("/path_error_p_rms_after_2s_m"),
    ),
    (
        "path_error_p_max_after_2s_m",
        Pick::At("/path_error_p_max_after_2s_m"),
    ),
    (
        "path_error_rot_max_after_2s_rad",
        Pick::At("/path_error_rot_max_after_2s_rad"),
    ),
    (
        "peak_torque_rate_Nm_per_s",
        Pick::At("/torque_rate/peak_Nm_per_s"),
    ),
    ("chatter_ticks", Pick::At("/torque_rate/chatter_ticks")),
];

/// A spatial metric's cell.
fn pick_cell(summary: &Json, p: Pick) -> String {
    let over_arms = |array: &str, rest: &str, min: bool| -> String {
        let Some(a) = summary.pointer(array).and_then(Json::as_array) else {
            return String::new();
        };
        let v: Option<Vec<f64>> = (0..a.len())
            .map(|i| {
                summary
                    .pointer(&format!("{array}/{i}{rest}"))
                    .and_then(Json::as_f64)
            })
            .collect();
        match v.filter(|v| !v.is_empty()) {
            Some(v) => fmt_f64(if min {
                v.iter().copied().fold(f64::INFINITY, f64::min)
            } else {
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            }),
            None => String::new(),
        }
    };
    match p {
        Pick::At(ptr) => json_cell(summary.pointer(ptr)),
        Pick::MinOverArms(a, r) => over_arms(a, r, true),
        Pick::MaxOverArms(a, r) => over_arms(a, r, false),
        Pick::First(ptrs) => json_cell(ptrs.iter().find_map(|q| summary.pointer(q))),
    }
}

/// The metric column names of a base kind.
pub fn metric_columns(kind: Kind) -> Vec<&'static str> {
    match kind {
        Kind::Planar => METRICS.iter().map(|(c, _)| *c).collect(),
        Kind::Spatial => SPATIAL_METRICS.iter().map(|(c, _)| *c).collect(),
    }
}

/// One finished run: its table cells.
#[derive(Clone, Debug)]
pub struct Row {
    /// Run index.
    pub index: u64,
    /// Every cell, in header order.
    pub cells: Vec<String>,
}

/// The table header of a sweep.
pub fn header(sw: &Sweep) -> Vec<String> {
    let mut h = vec!["index".to_string(), "seed".to_string()];
    h.extend(sw.params.iter().map(|p| p.path.clone()));
    h.push("status".into());
    h.push("message".into());
    h.extend(metric_columns(sw.kind).iter().map(|c| c.to_string()));
    h
}

fn json_cell(v: Option<&Json>) -> String {
    match v {
        Some(Json::Number(n)) => match n.as_u64() {
            Some(u) => u.to_string(),
            None => match n.as_i64() {
                Some(i) => i.to_string(),
                None => n.as_f64().map(fmt_f64).unwrap_or_default(),
            },
        },
        Some(Json::Bool(b)) => b.to_string(),
        Some(Json::String(s)) => s.clone(),
        _ => String::new(),
    }
}

/// What one run produced.
pub struct RunResult {
    /// The table row.
    pub row: Row,
}

/// Run one sweep run; `keep` writes its outputs (no figures) into `keep/<index>/`.
pub fn one(sw: &Sweep, index: u64, keep: Option<&Path>) -> RunResult {
    let values = sw.values(index);
    let mut cells = vec![index.to_string(), sw.scenario_seed(index).to_string()];
    cells.extend(values.iter().map(cell));
    let n_metrics = metric_columns(sw.kind).len();
    let invalid = |mut cells: Vec<String>, msg: String| {
        cells.push("invalid".into());
        cells.push(msg);
        cells.extend((0..n_metrics).map(|_| String::new()));
        RunResult {
            row: Row { index, cells },
        }
    };
    let label = format!("{} run {index}", sw.display);
    let doc = match sw.run_doc(index, &values) {
        Ok(d) => d,
        Err(e) => return invalid(cells, e),
    };
    let sc = match load_doc(&doc, &sw.base, &label) {
        Ok(Scenario::Planar(s)) => s,
        Ok(Scenario::Spatial(sc)) => {
            return match one_spatial(sw, index, keep, sc, &doc, &label) {
                Ok(metrics) => {
                    cells.extend(metrics);
                    RunResult {
                        row: Row { index, cells },
                    }
                }
                Err(e) => invalid(cells, e),
            };
        }
        Err(e) => return invalid(cells, e),
    };
    let src = Source {
        name: sw.base.name.clone(),
        display: label.clone(),
        text: toml::to_string(&doc).unwrap_or_default(),
        dir: sw.base.dir.clone(),
        file: None,
    };
    let prepared = match runner::prepare(sc, &src) {
        Ok(p) => p,
        Err(e) => return invalid(cells, super::loader_message(&e)),
    };
    let fin = runner::execute(prepared, |_| {});
    let summary = planar_output::summary_json(&fin, &sw.base.name, None);
    if let Some(dir) = keep {
        let d = dir.join(index.to_string());
        let res = std::fs::create_dir_all(&d)
            .map_err(anyhow::Error::from)
            .and_then(|_| {
                planar_output::write_run(&d, &fin, &sw.base.name, Outputs { figures: false })
            });
        if let Err(e) = res {
            eprintln!("warning: run {index}: its outputs were not written: {e:#}");
        }
    }
    let status = if fin.outcome.fault.is_some() {
        "fault"
    } else {
        "completed"
    };
    cells.push(status.into());
    cells.push(
        fin.outcome
            .fault
            .as_ref()
            .map(|f| f.to_string())
            .unwrap_or_default(),
    );
    for (_, ptr) in METRICS {
        cells.push(json_cell(summary.pointer(ptr)));
    }
    RunResult {
        row: Row { index, cells },
    }
}

/// A spatial run of a sweep: its status, message and metric cells, or why the loader rejected
/// it. `keep` writes the run's outputs (no figures) and its `scenario.toml` into
/// `keep/<index>/`.
fn one_spatial(
    sw: &Sweep,
    index: u64,
    keep: Option<&Path>,
    sc: crate::scenario::SpatialScenario,
    doc: &toml::Table,
    label: &str,
) -> Result<Vec<String>, String> {
    use crate::run::spatial;
    let src = super::doc_source(doc, &sw.base, label)?;
    let prepared = spatial::prepare(sc, &src).map_err(|e| super::loader_message(&e))?;
    let toml_text = crate::output::spatial::scenario_toml(&prepared.sc, &sw.base.name);
    let fin = spatial::execute(prepared, |_| {}).map_err(|e| format!("{e:#}"))?;
    let derived = crate::output::spatial::Derived::new(&fin);
    let summary = crate::output::spatial::summary(&sw.base.name, &fin, &derived, None);
    if let Some(dir) = keep {
        let d = dir.join(index.to_string());
        let res = std::fs::create_dir_all(&d)
            .map_err(anyhow::Error::from)
            .and_then(|_| crate::output::spatial::write(&d, &sw.base.name, &fin, false))
            .and(toml_text)
            .and_then(|t| crate::files::write_text_atomic(&d.join("scenario.toml"), &t));
        if let Err(e) = res {
            eprintln!("warning: run {index}: its outputs were not written: {e:#}");
        }
    }
    let mut cells = vec![
        if fin.outcome.fault.is_some() {
            "fault"
        } else {
            "completed"
        }
        .to_string(),
        fin.outcome
            .fault
            .as_ref()
            .map(|f| f.to_string())
            .unwrap_or_default(),
    ];
    cells.extend(SPATIAL_METRICS.iter().map(|(_, p)| pick_cell(&summary, *p)));
    Ok(cells)
}

/// The run indices of a shard (all runs without one).
pub fn indices(sw: &Sweep, shard: Option<Shard>) -> Vec<u64> {
    (0..sw.total)
        .filter(|i| shard.is_none_or(|s| s.has(*i)))
        .collect()
}

/// The progress bar of a batch of `len` runs on standard error, labelled `prefix`.
pub fn progress(len: u64, prefix: &'static str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix:>10} [{bar:36}] {pos}/{len} runs {elapsed:>4} (ETA {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix(prefix);
    bar
}

/// Run the given indices on `threads` threads (0: every core), with a progress bar; rows come
/// back in index order.
pub fn run_all(
    sw: &Sweep,
    idx: &[u64],
    threads: usize,
    keep: Option<&Path>,
) -> Result<Vec<RunResult>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let bar = progress(idx.len() as u64, "sweep");
    let mut out: Vec<RunResult> = pool.install(|| {
        idx.par_iter()
            .map(|&i| {
                let r = one(sw, i, keep);
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    out.sort_by_key(|r| r.row.index);
    Ok(out)
}

/// The CSV text of a table (header then rows in the given order).
pub fn csv_text(header: &[String], rows: &[Row]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(header)?;
    for r in rows {
        w.write_record(&r.cells)?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(String::from_utf8(bytes)?)
}
