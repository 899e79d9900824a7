//! The tables planar and spatial scenarios share, declared once. Where the two kinds differ
//! only in the number of outputs (three: `x, y, θ`; six: `x, y, z, rx, ry, rz`) a table is
//! generic over it.

use serde::{Deserialize, Serialize};

/// Which law drives the joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// iBLF backstepping + adaptive RBF network (SPEC §3.3–3.4).
    Nn,
    /// PD on the object (SPEC §3.5; spatial: `pd.gravity_compensation` adds the model's 𝓖).
    Pd,
    /// Computed torque with a nominal model (SPEC §3.5).
    Ctc,
    /// Joint torques replayed from a CSV file.
    Replay,
}

impl ControllerKind {
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            ControllerKind::Nn => "nn",
            ControllerKind::Pd => "pd",
            ControllerKind::Ctc => "ctc",
            ControllerKind::Replay => "replay",
        }
    }
}
