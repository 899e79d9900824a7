//! Ready-made set-ups that the CLI, benches, examples and tests use (Pinocchio's sample models,
//! what `fixtures` was): the top of the layer order, free to use every module below.
//!
//! * Planar ([`planar`]): [`paper`] (the paper's two-arm set-up, SPEC §4) with
//!   [`paper_start`], [`redundant_pair`] (two 3-link arms), [`three_arms`], and the paper
//!   scenario's closed loop [`paper_simulation`].
//! * Spatial ([`spatial`], SPEC-spatial S6): the embedded arms [`ur5_arm`] and [`franka_arm`],
//!   the set-ups [`dual_ur5`], [`three_ur5`] and [`dual_franka`] ([`SpatialSetup`]), and the S6
//!   closed loop [`spatial_s6_simulation`] / [`spatial_s6_simulation_with`].
//!
//! ```
//! let params = tandem::presets::paper();
//! assert_eq!(params.arms.len(), 2);
//! tandem::plant::planar::Plant::new(&params).unwrap();
//! let s6 = tandem::presets::dual_ur5();
//! assert_eq!(s6.params.arms.len(), 2);
//! ```

pub mod planar;
pub mod spatial;

pub use planar::{paper, paper_simulation, paper_start, redundant_pair, three_arms};
pub use spatial::{
    SpatialSetup, dual_franka, dual_ur5, dual_ur5_grip, franka_arm, spatial_s6_simulation,
    spatial_s6_simulation_with, three_ur5, ur5_arm,
};
