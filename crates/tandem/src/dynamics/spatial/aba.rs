//! Forward dynamics by the articulated-body algorithm (Featherstone 2008, Table 7.1 and §7.3,
//! in world axes about the base origin).
//!
//! ```text
//! pass 1 (out):  V_k = V_{k−1} + S_k q̇_k,   c_k = V_k × S_k q̇_k
//!                𝕀ᴬ_k = 𝕀_k,   pᴬ_k = V_k ×* 𝕀_k V_k   (− F_T at the base origin, k = n−1)
//! pass 2 (in):   U_k = 𝕀ᴬ_k S_k,   D_k = S_k · U_k,   u_k = τ_k − S_k · pᴬ_k
//!                𝕀ᵃ = 𝕀ᴬ_k − U_k U_kᵀ / D_k,   pᵃ = pᴬ_k + 𝕀ᵃ c_k + U_k u_k / D_k
//!                𝕀ᴬ_{k−1} += 𝕀ᵃ,   pᴬ_{k−1} += pᵃ
//! pass 3 (out):  a_{−1} = [−g_W; 0],   a' = a_{k−1} + c_k
//!                q̈_k = (u_k − U_k · a') / D_k,   a_k = a' + S_k q̈_k
//! ```
//!
//! In one fixed coordinate system the articulated inertias are summed without the `X* 𝕀ᴬ X⁻¹` change of
//! frame of the body-coordinate version. Cost: the shared stages, then per body a 6 × 6
//! matrix–vector product for `U`, a symmetric rank-1 update and a second 6 × 6 product for
//! `𝕀ᵃ c`: about 200 flops.

use nalgebra::{Vector3, Vector6};

use super::kinematics::placements_and_inertias;
use super::rnea::tool_wrench_at_origin;
use super::{ChainData, check_len};
use crate::geometry::motion::{cross_force, cross_motion, stack};
use crate::model::spatial::SpatialArm;

/// Forward dynamics by the articulated-body algorithm (Featherstone 2008, Table 7.1, world
/// coordinates): `q̈ = M⁻¹(τ + J_Tᵀ F_T − C q̇ − g)` in O(n).
///
/// Reads `q`, `q̇`, `τ` (n each), `g_W` (world axes, m/s²) and the wrench `F_T` applied **to**
/// the tool frame (about its origin, world axes; `None` for zero). Writes `qdd` (n, rad/s² or
/// m/s²) and the poses `d.X_WL`, `d.X_WT`. A pivot `D_k ≤ 0` (invalid chain only) gives
/// `q̈_k`'s articulated solve a zero inverse and is counted in [`ChainData::singular_pivots`].
pub fn aba(
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
    // Pass 1: twists, bias accelerations c_k (in d.a), articulated inertias and bias forces.
    let mut v = Vector6::zeros();
    for k in 0..n {
        let sqd = d.S[k] * qd[k];
        v += sqd;
        d.V[k] = v;
        d.a[k] = cross_motion(&v, &sqd);
        let i = &d.I_W[k];
        d.IA[k] = i.to_matrix();
        d.f[k] = cross_force(&v, &i.apply(&v));
    }
    if let Some(f_t) = f_T_W {
        let w = tool_wrench_at_origin(d, f_t);
        d.f[n - 1] -= w;
    }
    // Pass 2: articulated inertias inward.
    for k in (0..n).rev() {
        let s = d.S[k];
        let u_vec = d.IA[k] * s;
        let dk = s.dot(&u_vec);
        let dinv = if dk > 0.0 && dk.is_finite() {
            1.0 / dk
        } else {
            d.singular += 1;
            0.0
        };
        let uk = tau[k] - s.dot(&d.f[k]);
        d.U[k] = u_vec;
        d.Dinv[k] = dinv;
        d.u[k] = uk;
        if k > 0 {
            let ia = d.IA[k] - (u_vec * dinv) * u_vec.transpose();
            let pa = d.f[k] + ia * d.a[k] + u_vec * (uk * dinv);
            d.IA[k - 1] += ia;
            d.f[k - 1] += pa;
        }
    }
    // Pass 3: accelerations outward from the base's apparent upward acceleration.
    let mut a = stack(&(-g_W), &Vector3::zeros());
    for k in 0..n {
        a += d.a[k];
        let qddk = (d.u[k] - d.U[k].dot(&a)) * d.Dinv[k];
        qdd[k] = qddk;
        a += d.S[k] * qddk;
    }
}
