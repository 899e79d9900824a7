//! The carried rigid object, paper (10):
//!
//! $$M_o \ddot x_o + C_o \dot x_o + G_o = F_o - F_d$$
//!
//! with pose `x_o = (x, y, θ)`, constant inertia `M_o`, constant viscous damping `C_o`, constant
//! gravity wrench `G_o` (SPEC §1 sign convention: `G_o = (0, +m g, 0)` sits on the left), the
//! wrench `F_o = −Jᵀ F_e` the arms put on it and the environment disturbance `F_d`.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, non_negative, positive};

/// Object parameters: plain data, validated by [`Object::new`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectParams {
    /// Diagonal of `M_o`: (mass, mass, rotational inertia), (kg, kg, kg m²), all > 0.
    pub inertia: [f64; 3],
    /// Diagonal of the viscous damping `C_o`, (N s/m, N s/m, N m s/rad), all ≥ 0.
    pub damping: [f64; 3],
    /// Gravity wrench `G_o`, (N, N, N m); SPEC §1 sign: `(0, m g, 0)`.
    pub gravity: [f64; 3],
    /// Box size (length along the grasp axis, height), m; used for drawing and default grasps.
    pub size: [f64; 2],
}

impl ObjectParams {
    /// The paper's object (SPEC §4): `M_o = C_o = I`, `G_o = (0, 9.8, 0)`, `l_o = 0.1 m`.
    pub fn paper() -> Self {
        ObjectParams {
            inertia: [1.0; 3],
            damping: [1.0; 3],
            gravity: [0.0, 9.8, 0.0],
            size: [0.1, 0.05],
        }
    }
}

/// A validated, immutable object model.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct Object {
    /// `M_o`, diagonal.
    pub M_o: Matrix3<f64>,
    /// `M_o⁻¹`.
    pub M_o_inv: Matrix3<f64>,
    /// `C_o`, diagonal.
    pub C_o: Matrix3<f64>,
    /// `G_o`.
    pub G_o: Vector3<f64>,
    /// Box size, m.
    pub size: [f64; 2],
}

impl Object {
    /// Validate the parameters (`object.inertia[k] > 0`, `object.damping[k] ≥ 0`, finite values).
    pub fn new(p: &ObjectParams) -> Result<Self, ModelError> {
        let mut m = [0.0; 3];
        let mut c = [0.0; 3];
        for k in 0..3 {
            m[k] = positive(&format!("object.inertia[{k}]"), p.inertia[k])?;
            c[k] = non_negative(&format!("object.damping[{k}]"), p.damping[k])?;
            if !p.gravity[k].is_finite() {
                return Err(ModelError::invalid(
                    format!("object.gravity[{k}]"),
                    p.gravity[k],
                    "must be finite",
                ));
            }
        }
        for k in 0..2 {
            positive(&format!("object.size[{k}]"), p.size[k])?;
        }
        let mo = Matrix3::from_diagonal(&Vector3::from(m));
        Ok(Object {
            M_o: mo,
            M_o_inv: Matrix3::from_diagonal(&Vector3::new(1.0 / m[0], 1.0 / m[1], 1.0 / m[2])),
            C_o: Matrix3::from_diagonal(&Vector3::from(c)),
            G_o: Vector3::from(p.gravity),
            size: p.size,
        })
    }

    /// Kinetic and potential energy `(½ ẋᵀM_o ẋ, G_oᵀ x)`, J (the potential of a constant wrench).
    pub fn energy(&self, x: &Vector3<f64>, xd: &Vector3<f64>) -> (f64, f64) {
        (0.5 * xd.dot(&(self.M_o * xd)), self.G_o.dot(x))
    }
}
