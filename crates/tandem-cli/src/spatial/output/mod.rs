//! What a spatial run writes (issue 9): `timeseries.csv`, `summary.json`, the figures
//! ([`super::figures`]), `viewer.html` and the snapshots, the terminal table, and the files of a
//! comparison ([`write_compare`]).
//!
//! Everything here reads a [`Finished`] run only: the preset or scenario it came from and the law
//! it ran do not matter. Columns a law does not fill (NN weights, `α`, `Q` for PD or computed
//! torque) are left out of the figures and written `null` in the summary, with the reason in its
//! `unavailable` map.
//!
//! The metrics are the library's ([`tandem::report::spatial`]: the summary, and the quantities
//! derived from the kinematics on the **logged rows** — the grasp wrenches in tool axes, the
//! closest approach to a joint limit, the smallest singular value of each arm's tool Jacobian,
//! the true pose in the output chart and against the desired path); this folder turns them into
//! files and tables.
//!
//! The files of this folder: `summary.rs` (`summary.json` from the library's summary), `timeseries.rs` (the CSV columns), `viewer.rs` (`viewer.html` and the
//! snapshots), `table.rs` (the terminal and Markdown tables) and `compare.rs` (the files of a
//! comparison); [`write()`] writes one run's outputs.

mod compare;
mod summary;
mod table;
mod timeseries;
mod viewer;

pub use compare::write_compare;
pub use summary::{summary, summary_json};
pub use table::{markdown, rows, text};
pub use tandem::report::spatial::{
    CLAIM_Z1_P, CLAIM_Z1_ROT, Closest, Derived, TRANSIENT, sigma_min,
};
pub use timeseries::write_timeseries;
pub use viewer::VIEWER_FPS;

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use serde_json::Value;
use tandem::control::spatial::chart::Chart;
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::spatial::path::Se3Path;
use tandem::report::spatial::SpatialRun;
use tandem::sim::Outcome;

use crate::output::write_json_atomic;

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

/// What the library's summary is computed from: the run and the scenario's definitions (the
/// spatial transient window is [`TRANSIENT`]).
impl<'a> From<&'a Finished> for SpatialRun<'a> {
    fn from(f: &'a Finished) -> Self {
        SpatialRun {
            outcome: &f.outcome,
            plant: &f.plant,
            path: &f.path,
            chart: &f.chart,
            k_c: f.k_c,
            transient: TRANSIENT,
        }
    }
}

pub(crate) use crate::figures::col;
pub(crate) use tandem::report::spatial::six;

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
            viewer::write_viewer(dir, scenario, f, &d).map(|_| t.elapsed().as_secs_f64())
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
