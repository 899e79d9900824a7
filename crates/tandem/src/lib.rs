#![doc = include_str!("../../../README.md")]
//!
//! This crate holds the model, the plant, the controllers and the simulation loop; it does no I/O
//! and no plotting (the `tandem-cli` crate does). See [`notation`] for the symbol table. SI units
//! everywhere.
#![warn(missing_docs)]

pub mod error;
pub mod linalg;
pub mod notation;

pub mod dynamics;
pub mod model;
pub mod spatial;

pub mod arm;
pub mod grasp;
pub mod object;
pub mod plant;

pub mod fixtures;

pub mod faults;
pub mod integrate;
pub mod sensors;

pub mod admittance;
pub mod iblf;
pub mod rbf;
pub mod switching;
pub mod trajectory;

pub mod adaptive;
pub mod control;
pub mod ctc;
pub mod disturbance;
pub mod pd;
pub mod report;
pub mod sim;

pub use error::ModelError;
pub use nalgebra;
