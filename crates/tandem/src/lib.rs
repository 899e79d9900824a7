#![doc = include_str!("../../../README.md")]
//!
//! This crate holds the model, the plant, the controllers and the simulation loop; it does no I/O
//! and no plotting (the `tandem-cli` crate does). See [`notation`] for the symbol table. SI units
//! everywhere.
//!
//! # Architecture
//!
//! The paper's blocks, bottom to top (a module imports only from its own level or below):
//!
//! | block | planar | spatial | shared |
//! |---|---|---|---|
//! | algebra | — | [`geometry`] (SE(3), SO(3) exp/log and Jacobians, spatial inertia) | [`math::linalg`], [`math::trig`] |
//! | model | [`arm`], [`object`], [`grasp`] | [`model`] (chains, URDF), [`plant::spatial::object`] | [`error`] |
//! | arm dynamics (1)–(4) | [`arm`] (closed forms + general n-link) | [`dynamics`] (FK, J, J̇q̇, CRBA, RNEA, ABA) | |
//! | closed chain (10)–(14) | [`plant`] (constrained, reduced) | [`plant::spatial`] (welds, compliant grasps) | [`plant::ClosedChain`] |
//! | reference generation (15)–(21) | [`trajectory`], [`admittance`] | [`reference`](mod@reference) (SE(3) paths), [`se3`] (output chart, reference pose fit) | |
//! | control laws (22)–(44) | [`iblf`], [`rbf`], [`switching`], [`adaptive`], [`pd`], [`ctc`], [`control`] | [`control::spatial`] (iBLF + NN, PD, computed torque on six outputs; object-level model, distribution, `f^U`) | [`rbf_structured`] (network structures that scale to 24 inputs) |
//! | simulation | [`report`], [`sim::Driver`] | [`plant::spatial::SpatialPlant::step`] | [`sim`] (one loop, [`sim::Drive`]), [`math::integrate`], [`sensors`], [`disturbance`], [`faults`] |
//!
//! **How planar and spatial share one loop: one trait, two implementations.** The two plants
//! differ in more than a dimension: the spatial state lives on a manifold (a unit quaternion,
//! renormalised after every step), its grasp wrenches are read in the sensors' rotating tool
//! axes, and its arms come from URDF with any joint layout, while the planar plant keeps its
//! closed-form fast paths (SPEC §2.1, a 4 × 4 grasp-space solve) and its reduced formulation
//! (14). A const-generic task dimension would drag each plant's special structure into the
//! other; a trait lets each keep its fast path. So:
//! * [`plant::ClosedChain`] is what the loop needs from a plant: a flat state for the
//!   integrators, the held input, `advance` (RK4 with the input held, plus the plant's own
//!   projection), the grasp wrenches as the wrist sensors read them (`WRENCH_DIM` = 2 or 6
//!   channels per arm), constraint residual, conditioning and energy. [`plant::Plant`] and
//!   [`plant::spatial::SpatialPlant`] implement it.
//! * [`sensors::Sensors`] is one sensor model for both: encoders plus one wrist sensor per arm
//!   of 2 (planar force) or 6 (spatial force/torque) channels, same channel model, same
//!   seeding.
//! * [`math::integrate`] works on flat slices ([`math::integrate::OdeSystem`]) and serves both.
//! * The loop ([`sim::Simulation`]) is **one loop, generic over the plant and the driver**:
//!   `Simulation<P: ClosedChain, D: Drive<P>>` steps the plant ([`plant::ClosedChain::step_with`],
//!   in the formulation of the plant's [`plant::Stepper`]), evaluates the grasp wrenches of the
//!   state ([`plant::ClosedChain::grasp_wrenches`]), samples the sensors, calls the driver
//!   ([`sim::Drive::tick`]: time and [`sim::Measurements`] → joint torques and a
//!   [`sim::Record`]), checks health and logs; the plant supplies its log columns (object and
//!   joint truth, wrench channels, drift), the driver its record's. A driver is tandem's planar
//!   [`control::Controller`], the torque [`sim::Replay`] (any plant), the CLI's
//!   [`sim::Driver`] enum, or a user's own law (README, "Your own controller"); the spatial
//!   controller (SPEC-spatial S5) plugs in as one more driver, not as a second loop. The
//!   planar reduced formulation (14) lives in the planar plant's stepper, which reads and
//!   writes its 6-state in the object part of the one flat state, so the loop keeps one state.
#![warn(missing_docs)]

pub mod error;
pub mod notation;

pub mod geometry;
pub mod math;

pub mod dynamics;
pub mod model;

pub mod plant;

pub mod reference;

pub mod control;
pub mod drive;
pub mod report;
pub mod sim;

pub mod presets;

pub use error::ModelError;
pub use nalgebra;
