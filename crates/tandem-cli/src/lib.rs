//! The `tandem` command-line tool as a library: scenario files (TOML), runs, comparisons,
//! sweeps, figures, the 3-D viewer and the output folders. The `tandem` binary (`main.rs`) is a
//! thin command-line layer over it, and the Python package (`python/`) binds the same code, so
//! that a scenario means the same thing, and gets the same errors, everywhere.
//!
//! The simulation itself (models, plants, control laws, the loop) is the `tandem` library crate,
//! which has no I/O.
//!
//! # Architecture
//!
//! The same blocks for planar and spatial scenarios, side by side inside each; imports go one way
//! (bottom to top; `.ci/run` checks there is no circle):
//!
//! | layer | module | planar | spatial |
//! |---|---|---|---|
//! | foot | [`suggest`], [`files`] (output folders that never delete what tandem did not write, atomic writes, CSV numbers) | both | both |
//! | scenario | [`scenario`]: [`scenario::source`] (where a text comes from, what an error says, the catalogue), [`scenario::tables`] (the tables both kinds share, declared once), [`scenario::parse`] and [`scenario::load`] (**the one place** planar or spatial is decided: `enum` [`scenario::Scenario`]), [`scenario::replay`] | [`scenario::planar`] | [`scenario::spatial`] |
//! | run | [`run`]: prepare (every validation) and execute | [`run::planar`] | [`run::spatial`] |
//! | figures | [`figures`]: [`figures::plot`] (panels, PNG + SVG) | [`figures::planar`] | [`figures::spatial`] |
//! | view | [`view`] | [`view::planar`] (the animation) | [`view::spatial`] (the 3-D viewer) |
//! | output | [`output`]: what a run writes ([`output::table`]: terminal and Markdown tables) | [`output::planar`] | [`output::spatial`] |
//! | studies | [`sweep`] (sweeps, shards, merges), [`robustness`] | both | both |
//! | set-up studies | [`ik`] (`tandem ik`, `validate --branches`, `tandem place`: IK branches at the start, base placement) | — | spatial |
//!
//! `main.rs` matches on [`scenario::Scenario`] once per command; the Python package keeps the
//! variant it parsed.

pub mod export;
pub mod figures;
pub mod files;
pub mod ik;
pub mod output;
pub mod robustness;
pub mod run;
pub mod scenario;
pub mod suggest;
pub mod sweep;
pub mod view;

use std::fmt;

/// Bad input: the command line, a scenario, a replay file or an existing output folder. Exit 2.
#[derive(Debug)]
pub struct BadInput(String);

impl BadInput {
    /// From a message.
    pub fn msg(s: impl Into<String>) -> Self {
        BadInput(s.into())
    }
}

impl fmt::Display for BadInput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// Most worker threads a command (`sweep --threads`) or the Python package (`threads=`) starts:
/// 1024, far above any machine's useful parallelism (the runs are CPU-bound) and far below
/// the thread limits that would fail only after the pool has spent seconds starting.
pub const MAX_THREADS: usize = 1024;

/// The worker thread count for `option` (`--threads`, `threads=`): the given count, checked
/// to be from 1 to [`MAX_THREADS`], or every core when not given.
pub fn threads(n: Option<usize>, option: &str) -> Result<usize, BadInput> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // `--threads 5`, `threads=5`.
    let given = |n: usize| {
        if option.ends_with('=') {
            format!("{option}{n}")
        } else {
            format!("{option} {n}")
        }
    };
    match n {
        None => Ok(cores),
        Some(0) => Err(BadInput::msg(format!("{}: give at least 1", given(0)))),
        Some(n) if n > MAX_THREADS => Err(BadInput::msg(format!(
            "{}: at most {MAX_THREADS} threads (this machine has {cores} core{})",
            given(n),
            if cores == 1 { "" } else { "s" }
        ))),
        Some(n) => Ok(n),
    }
}
