//! Reference generation in SE(3): desired object poses for the spatial controller
//! (SPEC-spatial S5, S6).
//!
//! * [`se3_path`]: desired poses $X_{WO,d}(t) = (p_d(t), R_d(t))$ with analytic derivatives up
//!   to third order (position) and up to $\ddot\omega$ (orientation, world axes): the S6
//!   circle with a pitch oscillation, rest-to-rest geodesic moves, and C² waypoint splines;
//!   plus the reach of a path in the iBLF output chart $x_1 = (p - c, \mathrm{Log}(R_{ref}^T R))$.
//!
//! The planar desired paths are in [`crate::trajectory`].

pub mod admittance_se3;
pub mod se3_path;

pub use se3_path::{
    AxisFrame, CircleParams, Se3Circle, Se3Path, Se3PointToPoint, Se3Sample, Se3Spline,
    Se3Waypoint, chart_rates, chart_x1, left_jacobian_rates,
};
