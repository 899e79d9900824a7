//! The tracking laws, one file per law (the unit of extension): the iBLF backstepping
//! (22)–(35) ([`iblf`]), the switching function `m(z)`, `Q = M(Z)` (38)–(40) ([`switching`]),
//! the iBLF + adaptive RBF law (36)–(44) ([`adaptive`]), the PD baseline ([`pd`]) and computed
//! torque with a nominal model ([`ctc`]).
//!
//! Each law's gains are defined once, generic over the number of outputs `N`
//! ([`adaptive::NnGains`], [`pd::PdGains`], [`ctc::CtcGains`]), and [`Law`] selects one: the
//! planar controller ([`super::planar`]) runs `Law<3>` on the object's `(x, y, θ)`, the spatial
//! one ([`super::spatial`]) `Law<6>` on the chart's `[x, y, z, rx, ry, rz]`.

use serde::{Deserialize, Serialize};

pub mod adaptive;
pub mod ctc;
pub mod iblf;
pub mod pd;
pub mod switching;

use adaptive::NnGains;
use ctc::CtcGains;
use pd::PdGains;

/// Whether gains on `n` outputs are the planar controller's (`n ≤ 3`: the object's
/// `(x, y, θ)`) rather than the spatial one's (six). Where the two serialised forms differ
/// (`NnGains::network`, `PdGains::gravity_compensation`), this decides.
pub const fn is_planar(n: usize) -> bool {
    n <= 3
}

/// Which tracking law, with its gains on `N` outputs (plain data): `Law<3>` for the planar
/// controller ([`super::planar::ControllerParams::law`]), `Law<6>` for the spatial one
/// ([`super::spatial::SpatialControllerParams::law`]).
///
/// Serialised (serde) internally tagged: `kind = "nn" | "pd" | "ctc"` next to the gains' own
/// fields, unknown fields refused.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    tag = "kind",
    rename_all = "lowercase",
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
#[allow(clippy::large_enum_variant)] // plain data, built once per run
pub enum Law<const N: usize> {
    /// iBLF backstepping + adaptive RBF network with switching (SPEC §3.3–3.4; on six outputs
    /// SPEC-spatial S5).
    Nn(NnGains<N>),
    /// PD baseline (SPEC §3.5), optionally with the model's gravity.
    Pd(PdGains<N>),
    /// Computed torque with a nominal model (SPEC §3.5).
    Ctc(CtcGains<N>),
}

impl<const N: usize> Law<N> {
    /// Short name: `nn`, `pd` or `ctc`.
    pub fn name(&self) -> &'static str {
        match self {
            Law::Nn(_) => "nn",
            Law::Pd(_) => "pd",
            Law::Ctc(_) => "ctc",
        }
    }
}
