//! Kinetic and potential energy of the arm.
//!
//! ```text
//! T = ½ Σ_k V_kᵀ 𝕀_k V_k = ½ q̇ᵀ M q̇          U = −Σ_k m_k g_W · c_k  (c_k the world COM)
//! ```
//!
//! `U` is zero for every body's centre of mass at the world origin (it uses world positions);
//! `d/dt (T + U) = q̇ᵀ τ` for
//! the torques of [`super::rnea`] without tool wrench.

use nalgebra::Vector3;

use super::kinematics::{placements_and_inertias, velocities};
use super::{ChainData, check_len};
use crate::model::spatial::SpatialArm;

/// Kinetic energy `T = ½ q̇ᵀ M q̇` and gravitational potential energy
/// `U = −Σ_k m_k g_W · c_k` (J), as `(T, U)`. Reads `q`, `q̇` (n) and `g_W`; writes the poses
/// and the body twists.
pub fn energy(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    g_W: &Vector3<f64>,
    d: &mut ChainData,
) -> (f64, f64) {
    check_len(arm, d, "qd", qd);
    placements_and_inertias(arm, q, d);
    velocities(qd, d);
    let mut t = 0.0;
    let mut h = Vector3::zeros();
    let mut m = 0.0;
    for k in 0..d.dof() {
        t += d.I_W[k].kinetic_energy(&d.V[k]);
        h += d.I_W[k].h;
        m += d.I_W[k].mass;
    }
    // h is about the base origin: Σ m c_W = h + m p_WB.
    (t, -g_W.dot(&(h + m * arm.base.translation.vector)))
}
