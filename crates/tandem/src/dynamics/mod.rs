//! Arm dynamics, paper (1)–(4): what one arm's joints do under torques.
//!
//! * [`planar`]: planar serial arms with revolute joints; the general n-link algorithm
//!   ([`planar::general`]), the 2-link closed forms ([`planar::two_link`]), the fixed-size
//!   paths for the plant's hot loop ([`planar::fixed`]) and, on x86-64, two arms in SSE2 lanes.
//! * [`spatial`]: rigid-body algorithms for URDF chains (kinematics, CRBA, RNEA, ABA, ...) on
//!   a preallocated [`spatial::ChainData`], Pinocchio style.

pub mod planar;
pub mod spatial;
