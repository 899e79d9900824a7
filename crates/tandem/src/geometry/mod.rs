//! The SE(3) algebra on fixed-size nalgebra types (SPEC-spatial S1), written by hand. (Until
//! issue 26 this was `spatial`, a word that now names only the 3-D plant and controller.)
//!
//! * [`so3`]: `hat`/`vee`, `Exp`/`Log` of SO(3) and the right and left Jacobians with their
//!   inverses, accurate near `θ = 0` (Taylor series) and `θ = π` (antipodal `Log`).
//! * [`se3`]: `Exp`/`Log` of SE(3) on linear-first twists (pose errors by the log map).
//! * [`motion`]: twists `[v; ω]` and wrenches `[f; τ]` (**linear first**), their cross products
//!   and the motion and force adjoints of a rigid transform `X_AB` (nalgebra `Isometry3<f64>`).
//! * [`inertia`]: spatial inertia `(m, h = m c, I_O)` with its application to a twist and its
//!   change of frame.
//!
//! Conventions: `X_AB` is the pose of `B` in `A` (`p_A = X_AB p_B`), `R_AB` maps `B`
//! coordinates to `A`; SI units. The formulas are Featherstone's (*Rigid Body Dynamics
//! Algorithms*, 2008, ch. 2) with the 3-blocks swapped to put the linear part first.

pub mod inertia;
pub mod motion;
pub mod se3;
pub mod so3;

pub use inertia::SpatialInertia;
pub use motion::{
    Twist, Wrench, adjoint_force, adjoint_motion, cross_force, cross_force_matrix, cross_motion,
    cross_motion_matrix, inverse_transform_force, inverse_transform_motion, transform_force,
    transform_motion,
};
