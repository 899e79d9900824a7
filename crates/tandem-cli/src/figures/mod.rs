//! The figures of a run (PNG and SVG): [`plot`] draws panels, [`planar`] and [`spatial`] choose
//! what a run of each kind shows.

pub mod planar;
pub mod plot;
pub mod spatial;
