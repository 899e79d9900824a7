//! PD baseline on the object, paper Section V-B-1 with the SPEC §3.5 erratum:
//!
//! $$τ = −K_P z_1 − K_D \dot z_1,\qquad \dot z_1 = x_2 − \dot x_r$$
//!
//! (the paper prints `τ = K_P z_1 + K_D z_2`, positive feedback). No gravity compensation in the
//! paper's baseline; with [`PdGains::gravity_compensation`] the controller adds its model's
//! gravity term `𝓖` of (14) (`τ = −K_P z_1 − K_D ż_1 + 𝓖`). Paper gains:
//! `K_P = diag(5000, 5000, 1000)`, `K_D = diag(450, 450, 350)`.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, positive};

/// PD gains on `N` outputs (plain data), SPEC §3.5: `τ = −K_P z1 − K_D ż1` (planar, `N = 3`, on
/// the object's `(x, y, θ)`; spatial, `N = 6`, on the chart, mapped to the object wrench
/// `F = Eᵀ τ_x`), plus the model's gravity `𝓖` of (14) when
/// [`gravity_compensation`](PdGains::gravity_compensation) is on.
///
/// Serialised form (serde): `k_p`, `k_d`, `gravity_compensation` (default `false`), unknown
/// fields refused; planar gains (`N ≤ 3`, [`crate::control::law::is_planar`]) leave
/// `gravity_compensation` out when it is off, spatial gains always write it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct PdGains<const N: usize> {
    /// `K_P` diagonal: N/m on the linear outputs, N m/rad on the angular ones.
    pub k_p: [f64; N],
    /// `K_D` diagonal: N s/m on the linear outputs, N m s/rad on the angular ones.
    pub k_d: [f64; N],
    /// Add the controller model's gravity `𝓖` (object and arms, at the measured state). Off in
    /// the paper's baseline (SPEC §3.5: no gravity compensation), which then sags by about
    /// `𝓖/K_P` (about 2 cm under the S6 arms' and box's 110 N); on, it is the model-based PD a
    /// practitioner would run, and on a path as slow as S6 it tracks about as well as the NN
    /// law (`docs/spatial-control.md`). Planar: object scheme with 2-link arms (the reduced
    /// model (14)).
    #[serde(default, skip_serializing_if = "gravity_compensation_is_skipped::<N>")]
    pub gravity_compensation: bool,
}

/// Whether [`PdGains::gravity_compensation`] is left out of the serialised gains: planar
/// (`N ≤ 3`) when it is off (the planar form predates the field); spatial never.
pub fn gravity_compensation_is_skipped<const N: usize>(on: &bool) -> bool {
    crate::control::law::is_planar(N) && !*on
}

impl PdGains<3> {
    /// The paper's gains, no gravity compensation.
    pub fn paper() -> Self {
        PdGains {
            k_p: [5000.0, 5000.0, 1000.0],
            k_d: [450.0, 450.0, 350.0],
            gravity_compensation: false,
        }
    }
}

/// A validated PD law on `N` outputs (stateless; the gravity term, when asked for, comes from
/// the controller's model).
#[derive(Clone, Copy, Debug)]
pub struct Pd<const N: usize = 3> {
    k_p: SVector<f64, N>,
    k_d: SVector<f64, N>,
}

impl<const N: usize> Pd<N> {
    /// Validate (all gains > 0; errors name `gains.k_p[j]` / `gains.k_d[j]`).
    pub fn new(g: &PdGains<N>) -> Result<Self, ModelError> {
        for j in 0..N {
            positive(&format!("gains.k_p[{j}]"), g.k_p[j])?;
            positive(&format!("gains.k_d[{j}]"), g.k_d[j])?;
        }
        Ok(Pd {
            k_p: SVector::from(g.k_p),
            k_d: SVector::from(g.k_d),
        })
    }

    /// `(K_P, K_D)` diagonals.
    pub fn gains(&self) -> (SVector<f64, N>, SVector<f64, N>) {
        (self.k_p, self.k_d)
    }

    /// `(z1, ż1) → τ`.
    #[inline]
    pub fn wrench(&self, z1: &SVector<f64, N>, z1_dot: &SVector<f64, N>) -> SVector<f64, N> {
        -self.k_p.component_mul(z1) - self.k_d.component_mul(z1_dot)
    }
}
