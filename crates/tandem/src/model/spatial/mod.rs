//! The spatial model: kinematic chains with rigid bodies ([`chain`]), their reading from URDF
//! ([`urdf`]) and the carried 6-D rigid object ([`object`]). Plain, validated data; the
//! algorithms live in [`crate::dynamics::spatial`] and [`crate::plant::spatial`].

pub mod chain;
pub mod object;
pub mod urdf;

pub use chain::{Chain, ChainJoint, JointKind, JointLimits, RigidBody, SpatialArm};
pub use object::{RigidObject, SpatialObjectParams};
