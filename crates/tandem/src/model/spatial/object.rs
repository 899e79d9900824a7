//! The object as a 6-D rigid body (SPEC-spatial S3), Newton–Euler about its centre of mass in
//! world axes:
//!
//! $$\begin{bmatrix} m I & 0 \\ 0 & I_W \end{bmatrix}
//! \begin{bmatrix}\dot v_{WO} \\ \dot\omega_{WO}\end{bmatrix}
//! + \begin{bmatrix} 0 \\ \omega \times I_W \omega\end{bmatrix}
//! + C_o \begin{bmatrix} v \\ \omega \end{bmatrix}
//! - \begin{bmatrix} m g_W \\ 0 \end{bmatrix} = F_o - F_d$$
//!
//! with `I_W = R_WO I_O R_WOᵀ` (`I_O` about the centre of mass in body axes), `C_o` a diagonal
//! viscous damping on the twist (world axes), `F_o = −Σ G_iᵀ F_i` the wrench the arms put on it
//! and `F_d` the environment disturbance (subtracted, as SPEC §2.2 does in the plane).

use nalgebra::{Matrix3, Vector3, Vector6};

use crate::error::ModelError;

/// Object parameters (plain data).
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialObjectParams {
    /// Mass `m`, kg (> 0).
    pub mass: f64,
    /// Rotational inertia `I_O` about the centre of mass, body axes, kg m² (symmetric positive
    /// definite).
    pub inertia: Matrix3<f64>,
    /// Diagonal viscous damping `C_o` on `[v_WO; ω_WO]`, (N s/m ×3, N m s/rad ×3), ≥ 0.
    pub damping: Vector6<f64>,
}

impl SpatialObjectParams {
    /// A uniform box of edge lengths `size` (m) along the body axes and mass `mass` (kg):
    /// `I = m/12 diag(b² + c², a² + c², a² + b²)`, no damping.
    pub fn uniform_box(size: [f64; 3], mass: f64) -> Self {
        let [a, b, c] = size;
        let k = mass / 12.0;
        SpatialObjectParams {
            mass,
            inertia: Matrix3::from_diagonal(&Vector3::new(
                k * (b * b + c * c),
                k * (a * a + c * c),
                k * (a * a + b * b),
            )),
            damping: Vector6::zeros(),
        }
    }

    /// The SPEC-spatial S6 box: 0.4 × 0.2 × 0.2 m, 3 kg, `I = diag(0.02, 0.05, 0.05)` kg m².
    pub fn spec_box() -> Self {
        Self::uniform_box([0.4, 0.2, 0.2], 3.0)
    }
}

/// A validated object.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidObject {
    /// Mass, kg.
    pub mass: f64,
    /// `I_O`, body axes, kg m².
    pub inertia: Matrix3<f64>,
    /// `I_O⁻¹`, body axes.
    pub inertia_inv: Matrix3<f64>,
    /// Diagonal of `C_o`.
    pub damping: Vector6<f64>,
}

impl RigidObject {
    /// Validate: mass finite and > 0, inertia finite, symmetric, positive definite (triangle
    /// inequality required: an object is a real rigid body), damping finite and ≥ 0. Errors name
    /// `object.mass`, `object.inertia` or `object.damping[k]`.
    pub fn new(p: &SpatialObjectParams) -> Result<Self, ModelError> {
        crate::error::positive("object.mass", p.mass)?;
        let i = &p.inertia;
        if !i.iter().all(|v| v.is_finite()) {
            return Err(ModelError::geometry("object.inertia", "must be finite"));
        }
        if (i - i.transpose()).abs().max() > 1e-12 * i.abs().max() {
            return Err(ModelError::geometry("object.inertia", "must be symmetric"));
        }
        let ev = i.symmetric_eigenvalues();
        if !(ev.min() > 0.0) {
            return Err(ModelError::geometry(
                "object.inertia",
                format!(
                    "must be positive definite (principal moments {:.3e}, {:.3e}, {:.3e} kg m²)",
                    ev[0], ev[1], ev[2]
                ),
            ));
        }
        let s = ev.sum();
        if (0..3).any(|k| 2.0 * ev[k] > s * (1.0 + 1e-9)) {
            return Err(ModelError::geometry(
                "object.inertia",
                format!(
                    "breaks the triangle inequality (principal moments {:.4e}, {:.4e}, {:.4e} kg m²): no rigid body has it",
                    ev[0], ev[1], ev[2]
                ),
            ));
        }
        for k in 0..6 {
            crate::error::non_negative(&format!("object.damping[{k}]"), p.damping[k])?;
        }
        let inertia_inv = i
            .try_inverse()
            .ok_or_else(|| ModelError::geometry("object.inertia", "is singular"))?;
        Ok(RigidObject {
            mass: p.mass,
            inertia: *i,
            inertia_inv,
            damping: p.damping,
        })
    }
}
