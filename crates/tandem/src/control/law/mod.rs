//! The tracking laws, one file per law (the unit of extension): the iBLF backstepping
//! (22)–(35) ([`iblf`]), the switching function `m(z)`, `Q = M(Z)` (38)–(40) ([`switching`]),
//! the iBLF + adaptive RBF law (36)–(44) ([`adaptive`]), the PD baseline ([`pd`]) and computed
//! torque with a nominal model ([`ctc`]). Each controller kind ([`super::planar`],
//! [`super::spatial`]) selects one by its `Law`.

pub mod adaptive;
pub mod ctc;
pub mod iblf;
pub mod pd;
pub mod switching;
