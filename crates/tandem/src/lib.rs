#![doc = include_str!("../../../README.md")]
//!
//! This crate holds the model, the plant, the controllers and the simulation loop; it does no I/O
//! and no plotting (the `tandem-cli` crate does). See [`notation`] for the symbol table. SI units
//! everywhere.
//!
//! # Architecture
//!
//! The paper's blocks are folders, planar and spatial side by side inside each: who holds an
//! equation number or a textbook algorithm's name finds its file in one step.
//!
//! | paper block (equations) | folder | planar | spatial |
//! |---|---|---|---|
//! | ground floor: linear algebra, `sin`/`cos`, seeded random numbers, RK4 and Dormand–Prince | [`math`] | [`math::linalg`], [`math::trig`], [`math::random`], [`math::integrate`] (both) | same |
//! | rigid-motion algebra: SO(3), SE(3), twists and wrenches, spatial inertia | [`geometry`] | — | [`geometry::so3`], [`geometry::se3`], [`geometry::motion`], [`geometry::inertia`] |
//! | model: arms, object (10), grasps (11), disturbance `F_d` (10) | [`model`] | [`model::planar::arm`], [`model::planar::object`], [`model::planar::grasp`] | [`model::spatial::chain`], [`model::spatial::urdf`], [`model::spatial::object`]; [`model::disturbance`] (both) |
//! | arm dynamics (1)–(4), Cartesian form (3)–(4) | [`dynamics`] | [`dynamics::planar::general`] (n links), [`dynamics::planar::two_link`] (closed forms), [`dynamics::planar::fixed`] (fixed-size hot path), `dynamics/planar/pair.rs` (two arms in SSE2 lanes) | [`dynamics::spatial`]: `kinematics`, `crba`, `rnea`, `aba`, `terms`, `coriolis`, `forward`, `energy` |
//! | closed chain (10)–(14) | [`plant`] ([`plant::ClosedChain`], [`plant::Stepper`]) | [`plant::planar`] ([`plant::planar::constrained`], [`plant::planar::reduced`] (14)) | [`plant::spatial`] (welds, compliant grasps; `kkt.rs`; pads held by friction: [`plant::spatial::contact`]) |
//! | reference generation (15)–(21) | [`reference`](mod@reference) | [`reference::planar::path`], [`reference::planar::admittance`] (16)–(21) | [`reference::spatial::path`], [`reference::spatial::admittance`], [`reference::spatial::fit`](mod@reference::spatial::fit), [`reference::spatial::sample`] |
//! | the loop contract (SPEC §3 step 2) | [`drive`] (`drive.rs`: [`drive::Drive`], [`drive::Measurements`], [`drive::Record`], [`drive::ControlEvents`]) | both | both |
//! | control laws (22)–(44) | [`control`] ([`control::Scheme`], [`control::ControlWarning`]) | [`control::law`]: [`control::law::iblf`] (22)–(35), [`control::law::switching`] (38)–(40), [`control::law::adaptive`] (36)–(44), [`control::law::pd`], [`control::law::ctc`], each law's gains once for `N` outputs and one law enum [`control::law::Law`] (both: `Law<3>`, `Law<6>`); [`control::actuator`] (filter, rate and effort limits; both); [`control::planar`] (the planar controller) | [`control::spatial`]: [`control::spatial::chart`], [`control::spatial::model`], [`control::spatial::bound`], [`control::spatial::distribute`] (with the friction-aware [`control::spatial::distribute::friction`]), [`control::spatial::params`] |
//! | RBF network (36)–(37), weight update (44) | [`control::rbf`] | [`control::rbf::basis`], [`control::rbf::network`], `batched.rs`, `factors.rs`, [`control::rbf::structured`] (24 inputs); [`control::rbf::kernels`] (CPU detection, `avx2.rs`, `avx512.rs`) (both) | same |
//! | simulation (SPEC §2.4, §2.5, §3, §5) | [`sim`] (one loop, [`sim::Simulation`]) | [`sim::driver`] (the CLI's planar [`sim::Driver`]) | the same loop; [`sim::sensors`], [`sim::faults`], [`sim::log`], [`sim::replay`], [`sim::torque_rate`] (torque rate and chattering per tick) (both) |
//! | run metrics (SPEC §5), for any driver; the true pose to the desired path | [`report`] | [`report::planar`] | [`report::spatial`] |
//! | ready-made set-ups | [`presets`] | [`presets::planar`] ([`presets::paper`], ...) | [`presets::spatial`] ([`presets::dual_ur5`], ...) |
//!
//! **Imports go one way.** The layers, bottom to top: [`math`] → [`geometry`] → [`model`] →
//! [`dynamics`] → [`plant`] → [`reference`](mod@reference) → [`drive`] → [`control`] → [`sim`]
//! → [`report`] → [`presets`], with [`error`] and [`notation`] at the root. A module imports
//! from its own level or below (test modules may also use [`presets`]);
//! `shared/tools/import_circles.py crates/tandem/src` checks in CI that there is no circle.
//!
//! **Where the layout deviates from issue 26's sketch, and why.**
//! * [`reference::spatial::sample`] ([`reference::spatial::PoseSample`], was `se3/mod.rs`) is a
//!   fourth spatial reference file: the pose sample is shared by the reference fit and the 6-D
//!   admittance (reference level) and the output chart (control level), so it sits at the
//!   lower of the two.
//! * The spatial object stays a model ([`model::spatial::object`]) and the spatial plant keeps
//!   its grasps inside [`plant::spatial`] (no `plant/spatial/{object, grasp}.rs`): the object's
//!   parameters and mass matrix are plain data like the planar object, and the grasp models
//!   are part of the plant's step.
//! * [`drive`] is one file at the root rather than a folder: it is the contract between
//!   [`control`] and [`sim`] (the event counters [`drive::ControlEvents`] live there because
//!   the loop counts them; [`control`] re-exports them).
//! * The sensor noise streams are in [`math::random`] (crate-internal), the sensor model in
//!   [`sim::sensors`]; the planar [`sim::Driver`] enum wraps a controller or a replay, so it
//!   sits in [`sim`] (`sim/driver.rs`), above [`control`].
//! * [`report`] computes the summary of any run (tandem's laws, the replay, a user's own
//!   [`drive::Drive`]) from the true pose, the desired path, the reference where the law logs
//!   one, and the scenario's bounds; the CLI only turns it into `summary.json` and tables.
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
//!   channels per arm), constraint residual, conditioning and energy. [`plant::planar::Plant`] and
//!   [`plant::spatial::SpatialPlant`] implement it.
//! * [`sim::sensors::Sensors`] is one sensor model for both: encoders plus one wrist sensor per arm
//!   of 2 (planar force) or 6 (spatial force/torque) channels, same channel model, same
//!   seeding.
//! * [`math::integrate`] works on flat slices ([`math::integrate::OdeSystem`]) and serves both.
//! * The loop ([`sim::Simulation`]) is **one loop, generic over the plant and the driver**:
//!   `Simulation<P: ClosedChain, D: Drive<P>>` steps the plant ([`plant::ClosedChain::step_with`],
//!   in the formulation of the plant's [`plant::Stepper`]), evaluates the grasp wrenches of the
//!   state ([`plant::ClosedChain::grasp_wrenches`]), samples the sensors, calls the driver
//!   ([`drive::Drive::tick`]: time and [`drive::Measurements`] → joint torques and a
//!   [`drive::Record`]), checks health and logs; the plant supplies its log columns (object and
//!   joint truth, wrench channels, drift), the driver its record's. A driver is tandem's planar
//!   [`control::planar::Controller`], the torque [`sim::Replay`] (any plant), the CLI's
//!   [`sim::Driver`] enum, or a user's own law (README, "Your own controller"); the spatial
//!   controller (SPEC-spatial S5) plugs in as one more driver, not as a second loop. The
//!   planar reduced formulation (14) lives in the planar plant's stepper, which reads and
//!   writes its 6-state in the object part of the one flat state, so the loop keeps one state.
#![warn(missing_docs)]

// Root: errors and the symbol table.
pub mod error;
pub mod notation;

// The layers, bottom to top (a module imports only from its own level or below); one per
// group so that rustfmt keeps this order.
pub mod math;

pub mod geometry;

pub mod model;

pub mod dynamics;

pub mod plant;

pub mod reference;

pub mod drive;

pub mod control;

pub mod sim;

pub mod report;

pub mod presets;

pub use error::ModelError;
pub use nalgebra;
