//! The planar model (SPEC §1): arm parameters ([`arm`]), the object (10) ([`object`]) and the
//! grasp maps (11) ([`grasp`]).

pub mod arm;
pub mod grasp;
pub mod object;
