//! The `tandem` command-line tool as a library: scenario files (TOML), runs, comparisons,
//! sweeps, figures, the 3-D viewer and the output folders. The `tandem` binary (`main.rs`) is a
//! thin command-line layer over it, and the Python package (`python/`) binds the same code, so
//! that a scenario means the same thing, and gets the same errors, everywhere.
//!
//! The simulation itself (models, plants, control laws, the loop) is the `tandem` library crate,
//! which has no I/O.

pub mod export;
pub mod figures;
pub mod files;
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
