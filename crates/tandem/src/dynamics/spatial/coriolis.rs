//! The Christoffel-consistent Coriolis matrix `C(q, q̇)` in O(n²) from composite quantities
//! (Echeandia & Wensing 2021, ref. 2 of [`super`]), world axes about the base origin.
//!
//! With `J_b` the Jacobian of body `b` (columns `S_j`, `j ≤ b`; world axes about the base
//! origin), `J̇_b` its derivative (columns `Ṡ_j = V_j × S_j`) and
//!
//! ```text
//! B_b = ½ (V_b ×* 𝕀_b − 𝕀_b V_b × + X(𝕀_b V_b)),     X(f) V := V ×* f,
//!       X([f; τ]) = −[[0, [f]], [[f], [τ]]]            (skew-symmetric)
//! C   = Σ_b J_bᵀ (𝕀_b J̇_b + B_b J_b)
//! ```
//!
//! `B_b V_b = V_b ×* 𝕀_b V_b`, so `C q̇` is the RNEA's velocity product; with
//! `𝕀̇_b = V_b ×* 𝕀_b − 𝕀_b V_b ×`, `Ṁ − 2C = Σ_b (J̇_bᵀ 𝕀_b J_b − J_bᵀ 𝕀_b J̇_b − J_bᵀ X J_b)`
//! is skew-symmetric (Property 1), and `C(q, u) w = C(q, w) u` (Christoffel symmetry). On a
//! serial chain the body sums collapse into suffix sums `𝕀ᶜ_k = Σ_{b≥k} 𝕀_b`,
//! `Bᶜ_k = Σ_{b≥k} B_b`:
//!
//! ```text
//! C_ij = S_i · (𝕀ᶜ_j Ṡ_j + Bᶜ_j S_j)                  i ≤ j
//! C_ij = (𝕀ᶜ_i S_i) · Ṡ_j + (Bᶜ_iᵀ S_i) · S_j         i > j
//! ```
//!
//! Not in the plant's hot path (the plant uses `C q̇` from [`super::terms`]): the `B_b` are
//! formed as 6 × 6 products, about 1.5 kflop per body.

use nalgebra::{DMatrix, Matrix6, Vector6};

use super::kinematics::{placements_and_inertias, velocities};
use super::{ChainData, check_len};
use crate::geometry::motion::{ang, cross_force_matrix, cross_motion, cross_motion_matrix, lin};
use crate::geometry::so3::hat;
use crate::model::spatial::SpatialArm;

/// `X(f)` with `X(f) V = V ×* f`: `−[[0, [f]], [[f], [τ]]]`.
fn bar_force_matrix(f: &Vector6<f64>) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    let hf = hat(&lin(f));
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-hf));
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-hf));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-hat(&ang(f))));
    m
}

/// The Christoffel-consistent Coriolis matrix `C(q, q̇)` (n × n, kg m²/s for revolute joints):
/// `C q̇ + g` equals the RNEA at `q̈ = 0`, `Ṁ − 2C` is skew-symmetric and
/// `C(q, u) w = C(q, w) u`.
///
/// Reads `q`, `q̇` (n); writes `c` (resized by the caller to n × n: panics otherwise), the
/// poses and the body twists. Allocation-free.
pub fn coriolis_matrix(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    c: &mut DMatrix<f64>,
    d: &mut ChainData,
) {
    check_len(arm, d, "qd", qd);
    let n = d.dof();
    assert!(
        c.nrows() == n && c.ncols() == n,
        "coriolis_matrix: c must be n × n"
    );
    placements_and_inertias(arm, q, d);
    velocities(qd, d);
    // Composite inertias (d.Ic), composite B (d.IA) and Ṡ_k (d.a), tip to base.
    let mut ic = crate::geometry::SpatialInertia::zero();
    let mut bc = Matrix6::zeros();
    for k in (0..n).rev() {
        let i = &d.I_W[k];
        let v = d.V[k];
        let im = i.to_matrix();
        let b = 0.5
            * (cross_force_matrix(&v) * im - im * cross_motion_matrix(&v)
                + bar_force_matrix(&i.apply(&v)));
        ic += *i;
        bc += b;
        d.Ic[k] = ic;
        d.IA[k] = bc;
        d.a[k] = cross_motion(&v, &d.S[k]);
    }
    for j in 0..n {
        // Column j, rows i ≤ j: S_i · F_j with F_j = 𝕀ᶜ_j Ṡ_j + Bᶜ_j S_j.
        let fj = d.Ic[j].apply(&d.a[j]) + d.IA[j] * d.S[j];
        for i in 0..=j {
            c[(i, j)] = d.S[i].dot(&fj);
        }
    }
    for i in 1..n {
        // Row i, columns j < i: (𝕀ᶜ_i S_i) · Ṡ_j + (Bᶜ_iᵀ S_i) · S_j.
        let g = d.Ic[i].apply(&d.S[i]);
        let h: Vector6<f64> = d.IA[i].tr_mul(&d.S[i]);
        for j in 0..i {
            c[(i, j)] = g.dot(&d.a[j]) + h.dot(&d.S[j]);
        }
    }
}
