//! The plant's fused pass: kinematics (poses, `J`, `J̇ q̇`), `M` (CRBA) and `C q̇ + g` (RNEA at
//! `q̈ = 0`) from one placement stage and one set of world-coordinate inertias.
//!
//! ```text
//! forward:  placements + world inertias → twists V_k, accelerations a_k (q̈ = 0), forces f_k
//! backward: bias_k = S_k · Σ_{b≥k} f_b   and   𝕀ᶜ_k, M_ik = S_i · 𝕀ᶜ_k S_k   in one loop
//! tool:     J from S_k;  J̇ q̇ from a_{n−1} + [g; 0] = Σ V_k × S_k q̇_k
//! ```
//!
//! The same sums as [`super::kinematics`], [`super::rnea`] at `q̈ = 0` and [`super::crba`]
//! (the tests hold them equal), in two loops over the bodies instead of six.

use nalgebra::{Vector3, Vector6};

use super::kinematics::{placements_and_inertias, tool_jacobian, tool_jdqd_from};
use super::{ChainData, check_len};
use crate::geometry::SpatialInertia;
use crate::geometry::motion::{cross_force, cross_motion, stack};
use crate::model::spatial::SpatialArm;

/// The plant's fused pass: [`super::kinematics`] with `qd`, `d.M`, and
/// `d.bias = C q̇ + g` (n, N m or N).
///
/// Reads `q`, `q̇` (n) and `g_W` (world axes, m/s²); writes `d.X_WL`, `d.X_WT`, `d.J`,
/// `d.jdqd`, `d.M`, `d.bias` and the body twists.
pub fn terms(arm: &SpatialArm, q: &[f64], qd: &[f64], g_W: &Vector3<f64>, d: &mut ChainData) {
    check_len(arm, d, "qd", qd);
    placements_and_inertias(arm, q, d);
    let n = d.S.len();
    // Forward: twists, accelerations at q̈ = 0 (gravity as the base's [−g; 0]), body forces.
    let mut v = Vector6::zeros();
    let mut a = stack(&(-g_W), &Vector3::zeros());
    {
        let (s_all, i_all, v_all, f_all) = (&d.S[..n], &d.I_W[..n], &mut d.V[..n], &mut d.f[..n]);
        let qd = &qd[..n];
        for k in 0..n {
            let sqd = s_all[k] * qd[k];
            v += sqd;
            a += cross_motion(&v, &sqd);
            let i = &i_all[k];
            v_all[k] = v;
            f_all[k] = i.apply(&a) + cross_force(&v, &i.apply(&v));
        }
    }
    // Backward, RNEA and CRBA together: τ_k = S_k · Σ_{b≥k} f_b (the bias C q̇ + g) and
    // M_ik = S_i · (𝕀ᶜ_k S_k), upper triangle by columns.
    {
        let (s_all, i_all, f_all) = (&d.S[..n], &d.I_W[..n], &d.f[..n]);
        let bias = &mut d.bias.as_mut_slice()[..n];
        let m = &mut d.M.as_mut_slice()[..n * n];
        let mut f = Vector6::zeros();
        let mut ic = SpatialInertia::zero();
        for k in (0..n).rev() {
            let s = &s_all[k];
            f += f_all[k];
            bias[k] = s.dot(&f);
            ic += i_all[k];
            let fk = ic.apply(s);
            for (mik, si) in m[k * n..k * n + k + 1].iter_mut().zip(s_all) {
                *mik = si.dot(&fk);
            }
        }
        for k in 0..n {
            for i in 0..k {
                m[i * n + k] = m[k * n + i];
            }
        }
    }
    tool_jacobian(d);
    // The last acceleration at q̈ = 0 is Σ V_k × S_k q̇_k plus the base's [−g; 0]: the tool's
    // J̇ q̇ comes from it without a second pass.
    let acc = a + stack(g_W, &Vector3::zeros());
    tool_jdqd_from(&acc, d);
}
