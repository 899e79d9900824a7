//! What the robots and the object *are*: plain, validated descriptions, no algorithms.
//!
//! * [`planar`]: planar arms ([`planar::arm`]), the carried object (10) ([`planar::object`]) and
//!   the grasp maps (11) ([`planar::grasp`]).
//! * [`spatial`]: kinematic chains with rigid bodies ([`spatial::chain`]), their reading from
//!   URDF ([`spatial::urdf`]) and the 6-D rigid object ([`spatial::object`]).
//! * [`disturbance`]: the environment disturbance `F_d` of (10), one model for both (3 or 6
//!   channels).
//!
//! The algorithms on these models live in [`crate::dynamics::spatial`] and [`crate::plant`].

pub mod disturbance;
pub mod planar;
pub mod spatial;
