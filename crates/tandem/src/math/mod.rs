//! The ground floor: dense linear algebra on small fixed and dynamic matrices ([`linalg`]),
//! fast sine/cosine and planar rotations ([`trig`]), seeded random numbers ([`random`]) and the
//! time integrators ([`integrate`]). Every other module may use it; it uses only [`crate::error`].

pub mod integrate;
pub mod linalg;
pub mod random;
pub mod trig;
