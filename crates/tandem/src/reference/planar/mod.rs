//! Planar reference generation: the desired object path with analytic derivatives ([`path`],
//! SPEC §3 step 2) and the admittance generator (16)–(21) ([`admittance`]).

pub mod admittance;
pub mod path;
