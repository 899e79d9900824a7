//! Forward dynamics by CRBA, the RNEA bias and an in-place Cholesky factorisation of `M`
//! (Featherstone 2008, §6.1): `q̈ = M⁻¹ (τ − (C q̇ + g − J_Tᵀ F_T))`.
//!
//! The O(n³) alternative to [`super::aba`], against which it is tested; for n ≤ 7 both cost
//! about the same. It also leaves `d.M` behind.

use nalgebra::{Vector3, Vector6};

use super::crba::crba_pass;
use super::kinematics::placements_and_inertias;
use super::rnea::rnea_passes;
use super::{ChainData, check_len};
use crate::math::linalg::{cholesky_in_place, cholesky_solve_in_place};
use crate::model::spatial::SpatialArm;

/// Forward dynamics by CRBA + RNEA bias + Cholesky of `M`; agrees with [`super::aba`].
///
/// Reads `q`, `q̇`, `τ` (n), `g_W` and `F_T` (as [`super::aba`]); writes `qdd` (n), `d.M`
/// and the poses (not `d.bias`). If `M` is not positive definite
/// (invalid chain only), `M + ε (tr(M)/n + 1) I` with `ε = 1e-12` is factored instead (so a
/// chain of massless bodies gives large but finite accelerations) and the event is counted in
/// [`ChainData::singular_pivots`]; if that fails too, `qdd` is set to zero.
pub fn forward_dynamics(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    g_W: &Vector3<f64>,
    f_T_W: Option<&Vector6<f64>>,
    qdd: &mut [f64],
    d: &mut ChainData,
) {
    check_len(arm, d, "qd", qd);
    check_len(arm, d, "tau", tau);
    check_len(arm, d, "qdd", qdd);
    placements_and_inertias(arm, q, d);
    let n = d.S.len();
    // qdd first holds the bias C q̇ + g − J_Tᵀ F_T, then τ minus it.
    rnea_passes(qd, None, g_W, f_T_W, qdd, d);
    crba_pass(d);
    for (a, t) in qdd[..n].iter_mut().zip(tau) {
        *a = t - *a;
    }
    d.chol.copy_from(&d.M);
    if cholesky_in_place(&mut d.chol, n).is_err() {
        d.singular += 1;
        let tr: f64 = (0..n).map(|k| d.M[(k, k)].abs()).sum();
        let eps = 1e-12 * (tr / n as f64 + 1.0);
        d.chol.copy_from(&d.M);
        for k in 0..n {
            d.chol[(k, k)] += eps;
        }
        if cholesky_in_place(&mut d.chol, n).is_err() {
            qdd[..n].iter_mut().for_each(|x| *x = 0.0);
            return;
        }
    }
    cholesky_solve_in_place(&d.chol, n, &mut qdd[..n]);
}
