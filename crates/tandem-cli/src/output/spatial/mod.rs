//! What a spatial run writes (issue 9): `timeseries.csv`, `summary.json`, the figures
//! ([`crate::figures::spatial`]), `viewer.html` and the snapshots, the terminal table, and the files of a
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

use crate::scenario::SpatialScenario;
use anyhow::{Context, Result};
use serde_json::Value;

use crate::files::write_json_atomic;
pub use crate::run::spatial::Finished;

pub(crate) use crate::figures::planar::col;
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

/// Writes every output of `f` into `dir` (the temporary folder of an [`crate::files::OutputDir`]):
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
                crate::figures::spatial::run_figures(dir, scenario, f, &d)
                    .map(|_| t.elapsed().as_secs_f64())
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

/// The scenario as run, re-runnable: the resolved TOML with a header.
pub fn scenario_toml(sc: &SpatialScenario, name: &str) -> Result<String> {
    let mut sc = sc.clone();
    sc.name = Some(name.to_string());
    let body = toml::to_string(&sc).context("writing scenario.toml")?;
    Ok(format!(
        "# The scenario of this run as tandem read it (defaults and command-line overrides\n# applied). Re-run it with `tandem run scenario.toml`.\n\n{body}"
    ))
}
