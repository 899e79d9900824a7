//! Reference generation in SE(3): desired object poses for the spatial controller
//! (SPEC-spatial S5, S6).
//!
//! * [`path`]: desired poses $X_{WO,d}(t) = (p_d(t), R_d(t))$ with analytic derivatives up
//!   to third order (position) and up to $\ddot\omega$ (orientation, world axes): the S6
//!   circle with a pitch oscillation, rest-to-rest geodesic moves, and C² waypoint splines;
//!   plus the reach of a path in the iBLF output chart $x_1 = (p - c, \mathrm{Log}(R_{ref}^T R))$.
//! * [`admittance`]: the 6-D admittance generator (SPEC-spatial S5), the spatial counterpart of
//!   [`crate::reference::planar::admittance`].
//! * [`fit`](mod@fit): the reference pose that best fits the arms' reference tool poses through
//!   the grasps (least squares in position, a quaternion mean in orientation), with exact twist
//!   and twist rate.
//! * [`sample`]: [`PoseSample`], a pose with its twist and twist rate, which the fit, the
//!   admittance and the controller's output chart ([`crate::control::spatial::chart`]) share.

pub mod admittance;
pub mod fit;
pub mod path;
pub mod sample;

pub use fit::{Fit, candidate, fit, fit_sample, fit_weighted};
pub use path::{
    AxisFrame, CircleParams, Se3Circle, Se3Path, Se3PointToPoint, Se3Sample, Se3Spline,
    Se3Waypoint, chart_rates, chart_x1, left_jacobian_rates,
};
pub use sample::PoseSample;
