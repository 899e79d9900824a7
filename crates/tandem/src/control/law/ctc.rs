//! Computed-torque baseline on the object (SPEC §3.5): with a nominal model `(𝓜̂, 𝓒̂, 𝓖̂)` of
//! (14),
//!
//! $$τ = 𝓜̂(\ddot x_r − K_D \dot z_1 − K_P z_1) + 𝓒̂ x_2 + 𝓖̂$$
//!
//! It shows what model knowledge buys; the nominal model's masses and inertias are the true
//! ones times `1 + model_error` (arms and object alike), which makes its sensitivity visible.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, positive};
use crate::plant::planar::PlantParams;

/// Computed-torque gains on `N` outputs (plain data), SPEC §3.5: the commanded acceleration
/// `a = ẍ_r − K_D ż1 − K_P z1`, then planar (`N = 3`) `τ = 𝓜̂ a + 𝓒̂ x_2 + 𝓖̂` with the nominal
/// model of (14), spatial (`N = 6`, in the chart) `F = 𝓜 E⁻¹(a − Ė V) + 𝓱` with the nominal
/// object-level model.
///
/// Serialised form (serde): `k_p`, `k_d`, `model_error`, all required, unknown fields refused
/// (the same for every `N`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct CtcGains<const N: usize> {
    /// `K_P` diagonal, 1/s².
    pub k_p: [f64; N],
    /// `K_D` diagonal, 1/s.
    pub k_d: [f64; N],
    /// Relative error of every mass and inertia of the nominal model (0 = exact model).
    pub model_error: f64,
}

impl<const N: usize> Default for CtcGains<N> {
    /// Critically damped at `ω_n = 20` rad/s on every axis (`K_P = 400`, `K_D = 40`), exact
    /// model.
    fn default() -> Self {
        CtcGains {
            k_p: [400.0; N],
            k_d: [40.0; N],
            model_error: 0.0,
        }
    }
}

/// A validated computed-torque law on `N` outputs (stateless; the nominal model lives in the
/// controller).
#[derive(Clone, Copy, Debug)]
pub struct Ctc<const N: usize = 3> {
    k_p: SVector<f64, N>,
    k_d: SVector<f64, N>,
}

impl<const N: usize> Ctc<N> {
    /// Validate (gains > 0, `model_error > −1`).
    pub fn new(g: &CtcGains<N>) -> Result<Self, ModelError> {
        for j in 0..N {
            positive(&format!("gains.k_p[{j}]"), g.k_p[j])?;
            positive(&format!("gains.k_d[{j}]"), g.k_d[j])?;
        }
        if !(g.model_error > -1.0) || !g.model_error.is_finite() {
            return Err(ModelError::invalid(
                "gains.model_error",
                g.model_error,
                "must be finite and > −1",
            ));
        }
        Ok(Ctc {
            k_p: SVector::from(g.k_p),
            k_d: SVector::from(g.k_d),
        })
    }

    /// Commanded acceleration `ẍ_r − K_D ż1 − K_P z1`.
    #[inline]
    pub fn acceleration(
        &self,
        xdd_r: &SVector<f64, N>,
        z1: &SVector<f64, N>,
        z1_dot: &SVector<f64, N>,
    ) -> SVector<f64, N> {
        xdd_r - self.k_d.component_mul(z1_dot) - self.k_p.component_mul(z1)
    }
}

/// The nominal model a computed-torque controller believes: masses and inertias of arms and
/// object scaled by `1 + model_error` (gravity wrench of the object too).
pub fn nominal_params(truth: &PlantParams, model_error: f64) -> PlantParams {
    let s = 1.0 + model_error;
    let mut p = truth.clone();
    for a in &mut p.arms {
        for l in &mut a.links {
            l.mass *= s;
            l.inertia *= s;
        }
    }
    for k in 0..3 {
        p.object.inertia[k] *= s;
        p.object.gravity[k] *= s;
    }
    p
}
