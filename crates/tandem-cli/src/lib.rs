//! The `tandem` command-line tool as a library: scenario files (TOML), runs, comparisons,
//! sweeps, figures, the 3-D viewer and the output folders. The `tandem` binary (`main.rs`) is a
//! thin command-line layer over it, and the Python package (`python/`) binds the same code, so
//! that a scenario means the same thing, and gets the same errors, everywhere.
//!
//! The simulation itself (models, plants, control laws, the loop) is the `tandem` library crate,
//! which has no I/O.

pub mod anim;
pub mod figures;
pub mod output;
pub mod plot;
pub mod replay;
pub mod robustness;
pub mod runner;
pub mod scenario;
pub mod scene;
pub mod spatial;
pub mod suggest;
pub mod sweep;
pub mod table;
pub mod viewer;

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
