//! Running a sweep (or one shard of it) across cores, and its table.
//!
//! `runs.csv` has one row per run, in index order: `index`, `seed` (the run's `run.seed`), one
//! column per varied field (named by its path; an array value is one quoted cell `[4, 4, 4]`),
//! `status` (`completed`, `fault`, or `invalid` when the scenario loader rejected the run's
//! values), `message` (the fault or the loader's message), then the summary metrics of
//! `summary.json` ([`METRICS`]; arrays get `.x`/`.y`/`.theta` or `.min`/`.max` suffixes). An
//! empty cell is a metric that does not exist for that run (`null` in `summary.json`). Numbers
//! are in shortest round-trip form, so the table is the same for any thread count or sharding.

use std::path::Path;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value as Json;

use super::{Shard, Sweep, cell, fmt_f64, load_doc};
use crate::runner::{self, Outputs};
use crate::scenario::Source;

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
];

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
    h.extend(METRICS.iter().map(|(c, _)| c.to_string()));
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
    let invalid = |mut cells: Vec<String>, msg: String| {
        cells.push("invalid".into());
        cells.push(msg);
        cells.extend(METRICS.iter().map(|_| String::new()));
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
        Ok(s) => s,
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
    let summary = runner::summary_json(&fin, &sw.base.name, None);
    if let Some(dir) = keep {
        let d = dir.join(index.to_string());
        let res = std::fs::create_dir_all(&d)
            .map_err(anyhow::Error::from)
            .and_then(|_| runner::write_run(&d, &fin, &sw.base.name, Outputs { figures: false }));
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

/// The run indices of a shard (all runs without one).
pub fn indices(sw: &Sweep, shard: Option<Shard>) -> Vec<u64> {
    (0..sw.total)
        .filter(|i| shard.is_none_or(|s| s.has(*i)))
        .collect()
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
    let bar = ProgressBar::with_draw_target(Some(idx.len() as u64), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix:>10} [{bar:36}] {pos}/{len} runs {elapsed:>4} (ETA {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix("sweep");
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
