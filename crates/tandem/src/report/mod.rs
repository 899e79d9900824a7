//! Run reports: what a finished run amounts to, computed from its log, no I/O (the CLI writes
//! them). For any driver — tandem's laws, the torque replay, a user's own
//! [`crate::drive::Drive`] — from the true pose the plant logs, the desired path, the reference
//! where the law logs one, and the scenario's bounds and transient:
//!
//! * [`planar`]: the SPEC §5 summary (`summary.json`) of a planar run;
//! * [`spatial`]: the SPEC §5 metrics on six outputs and the SPEC-spatial S5/S7 claims of a
//!   spatial run, with the per-row kinematics they need ([`spatial::Derived`]).
//!
//! Both carry the [`TorqueRate`] of the applied joint torques (peak `|Δτ|/Δt` and
//! chattering per joint), measured by the loop on every control tick
//! ([`crate::sim::torque_rate`]), not from the logged rows.
//!
//! Both give the distance of the true pose to the **desired** path next to `z1` (which is
//! measured against the admittance-shifted reference and so cannot see, for example, a wrong
//! force-sensor convention).

pub mod planar;
pub mod spatial;

pub use crate::sim::torque_rate::{JointTorqueRate, TorqueRate};
