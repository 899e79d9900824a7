//! Model descriptions of spatial arms: kinematic chains with rigid bodies ([`chain`]) and their
//! reading from URDF ([`urdf`]). Plain, validated data; the algorithms live in
//! [`crate::dynamics`].

pub mod chain;
pub mod urdf;

pub use chain::{Chain, ChainJoint, JointKind, JointLimits, RigidBody, SpatialArm};
