//! Running a scenario: [`planar`] and [`spatial`] prepare a parsed scenario (build and validate
//! the library's simulation) and execute it to a finished run.

pub mod planar;
pub mod spatial;
