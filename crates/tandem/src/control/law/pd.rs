//! PD baseline on the object, paper Section V-B-1 with the SPEC §3.5 erratum:
//!
//! $$τ = −K_P z_1 − K_D \dot z_1,\qquad \dot z_1 = x_2 − \dot x_r$$
//!
//! (the paper prints `τ = K_P z_1 + K_D z_2`, positive feedback). No gravity compensation.
//! Paper gains: `K_P = diag(5000, 5000, 1000)`, `K_D = diag(450, 450, 350)`.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, positive};

/// PD gains (plain data).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdGains {
    /// `K_P` diagonal, (N/m, N/m, N m/rad).
    pub k_p: [f64; 3],
    /// `K_D` diagonal, (N s/m, N s/m, N m s/rad).
    pub k_d: [f64; 3],
}

impl PdGains {
    /// The paper's gains.
    pub fn paper() -> Self {
        PdGains {
            k_p: [5000.0, 5000.0, 1000.0],
            k_d: [450.0, 450.0, 350.0],
        }
    }
}

/// A validated PD law (stateless).
#[derive(Clone, Copy, Debug)]
pub struct Pd {
    k_p: Vector3<f64>,
    k_d: Vector3<f64>,
}

impl Pd {
    /// Validate (all gains > 0; errors name `gains.k_p[j]` / `gains.k_d[j]`).
    pub fn new(g: &PdGains) -> Result<Self, ModelError> {
        for j in 0..3 {
            positive(&format!("gains.k_p[{j}]"), g.k_p[j])?;
            positive(&format!("gains.k_d[{j}]"), g.k_d[j])?;
        }
        Ok(Pd {
            k_p: Vector3::from(g.k_p),
            k_d: Vector3::from(g.k_d),
        })
    }

    /// `(K_P, K_D)` diagonals.
    pub fn gains(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.k_p, self.k_d)
    }

    /// `(z1, ż1) → τ`.
    #[inline]
    pub fn wrench(&self, z1: &Vector3<f64>, z1_dot: &Vector3<f64>) -> Vector3<f64> {
        -self.k_p.component_mul(z1) - self.k_d.component_mul(z1_dot)
    }
}
