//! The cooperative controllers, paper (22)–(44): one tick maps (time, encoder readings, wrist
//! readings) to joint torques plus a record of its internals (SPEC §3).
//!
//! * [`law`]: the tracking laws, one file each: the iBLF backstepping (22)–(35)
//!   ([`law::iblf`]), the switching function (38)–(40) ([`law::switching`]), the adaptive RBF
//!   law (36)–(44) ([`law::adaptive`]), and the PD and computed-torque baselines
//!   ([`law::pd`], [`law::ctc`]).
//! * [`rbf`]: the RBF basis and network (36)–(37), (44), the structured networks that scale to
//!   24 inputs ([`rbf::structured`]) and the weight-pass kernels ([`rbf::kernels`]).
//! * [`planar`]: the planar [`Controller`](planar::Controller) (SPEC §3) and its record.
//! * [`spatial`]: the controller in SE(3) (SPEC-spatial S5): output chart, object-level model,
//!   `f^U` bound, wrench distribution.
//! * [`actuator`]: the actuator stage after the law and before the plant (output filter,
//!   torque-rate and effort limits, with counts), the same for planar and spatial arms. It is
//!   control-level, not a simulation fault ([`crate::sim::faults`]), because the law must know
//!   what was applied (issue 24); not wired into the controllers yet.
//!
//! Shared by both: [`Scheme`], [`ControlWarning`] and the event counters [`ControlEvents`]
//! (defined with the loop contract in [`crate::drive`], re-exported here).

use serde::{Deserialize, Serialize};

use crate::reference::planar::admittance::AdmittanceWarning;

pub mod actuator;
pub mod law;
pub mod planar;
pub mod rbf;
pub mod spatial;

pub use crate::drive::ControlEvents;

/// Where the tracking law acts (SPEC §3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scheme {
    /// On the object dynamics (14), tracking `x_r`; the wrench is distributed to the arms
    /// (the paper's Section IV and simulation).
    #[default]
    Object,
    /// Each arm on its own Cartesian dynamics (3), tracking `x_r,i`, with the measured grasp force
    /// fed forward; internal force comes from the offsets `δ_i` (the paper's "controller for each
    /// manipulator"). PD and NN laws; the NN uses the `x`, `y` entries of its gains, bounds
    /// `k_c,xy + |r_i|` on the end-effector, and `2^8` nodes per arm with the paper's 2-level grid.
    PerArm,
}

/// Set-up warnings (allowed but risky choices).
#[derive(Clone, Debug, PartialEq)]
pub enum ControlWarning {
    /// From the admittance generator (the paper's first-order form).
    Admittance(AdmittanceWarning),
    /// An NN gain allowed by the theory but below what the sampled loop needs.
    Gain {
        /// Parameter path, e.g. `gains.k2[1]`.
        param: String,
        /// Why it is risky.
        reason: String,
    },
}

impl std::fmt::Display for ControlWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ControlWarning::Admittance(w) => write!(f, "{w}"),
            ControlWarning::Gain { param, reason } => write!(f, "{param}: {reason}"),
        }
    }
}
