//! Reference generation, paper (15)–(21): the desired object path and the admittance-shifted
//! reference the controller tracks.
//!
//! * [`planar`]: desired paths `x_d(t) = (x, y, θ)` ([`planar::path`]) and the per-axis
//!   admittance generator (16)–(21) ([`planar::admittance`]).
//! * [`spatial`]: desired poses in SE(3) ([`spatial::path`]), the 6-D admittance
//!   ([`spatial::admittance`]) and the object-level reference pose fitted to the arms'
//!   reference tool poses ([`spatial::fit`](mod@spatial::fit)), on a [`spatial::PoseSample`].

pub mod planar;
pub mod spatial;
