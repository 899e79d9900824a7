//! Inverse dynamics by the recursive Newton–Euler algorithm (Featherstone 2008, Table 5.1 and
//! §5.3, in world axes about the base origin), and the gravity torques `g(q)`.
//!
//! ```text
//! forward:   a_{−1} = [−g_W; 0]                              (gravity as a base acceleration)
//!            V_k = V_{k−1} + S_k q̇_k
//!            a_k = a_{k−1} + S_k q̈_k + V_k × S_k q̇_k
//!            f_k = 𝕀_k a_k + V_k ×* 𝕀_k V_k   (− F_T moved to the base origin, for k = n−1)
//! backward:  τ_k = S_k · f_k,   f_{k−1} += f_k
//! ```
//!
//! so `τ = M q̈ + C q̇ + g − J_Tᵀ F_T`. Cost: the shared placement and inertia stages
//! ([`super::kinematics`]), then about 110 flops per body (two inertia applications, two cross
//! products) and 12 per body backward.

use nalgebra::{Vector3, Vector6};

use super::kinematics::{placements, placements_and_inertias};
use super::{ChainData, check_len};
use crate::geometry::motion::{ang, cross_force, cross_motion, lin, stack};
use crate::model::spatial::SpatialArm;

/// `F_T` (about the tool origin `p_T`, world axes) moved to the base origin:
/// `[f; τ + p_T × f]`.
#[inline]
pub(super) fn tool_wrench_at_origin(d: &ChainData, f_t: &Vector6<f64>) -> Vector6<f64> {
    let p = d.p_BT;
    let f = lin(f_t);
    stack(&f, &(ang(f_t) + p.cross(&f)))
}

/// The RNEA passes on placed bodies (after `placements` and `inertias`): writes `tau` and
/// leaves the twists in `d.V`. `qdd = None` means `q̈ = 0`. Returns the last body's spatial
/// acceleration (gravity included as the base's `[−g_W; 0]`).
#[inline]
pub(super) fn rnea_passes(
    qd: &[f64],
    qdd: Option<&[f64]>,
    g_W: &Vector3<f64>,
    f_T_W: Option<&Vector6<f64>>,
    tau: &mut [f64],
    d: &mut ChainData,
) -> Vector6<f64> {
    let n = d.S.len();
    let mut v = Vector6::zeros();
    let mut a = stack(&(-g_W), &Vector3::zeros());
    // Equal-length slices: no bounds checks in the loops.
    let (s_all, i_all, v_all, f_all) = (&d.S[..n], &d.I_W[..n], &mut d.V[..n], &mut d.f[..n]);
    let (qd, tau) = (&qd[..n], &mut tau[..n]);
    for k in 0..n {
        let s = s_all[k];
        let sqd = s * qd[k];
        v += sqd;
        a += cross_motion(&v, &sqd);
        if let Some(qdd) = qdd {
            a += s * qdd[k];
        }
        let i = &i_all[k];
        v_all[k] = v;
        f_all[k] = i.apply(&a) + cross_force(&v, &i.apply(&v));
    }
    if let Some(f_t) = f_T_W {
        let w = tool_wrench_at_origin(d, f_t);
        d.f[n - 1] -= w;
    }
    let mut f = Vector6::zeros();
    for ((t, s), fk) in tau.iter_mut().zip(&d.S).zip(&d.f).rev() {
        f += fk;
        *t = s.dot(&f);
    }
    a
}

/// Inverse dynamics by recursive Newton–Euler (Featherstone 2008, Table 5.1, world
/// coordinates): `τ = M q̈ + C q̇ + g − J_Tᵀ F_T`.
///
/// Reads `q`, `q̇`, `q̈` (n each), the gravity vector `g_W` (world axes, m/s²) and the wrench
/// `F_T = [f; τ]` applied **to** the tool frame, about its origin, in world axes (N, N m;
/// `None` for zero). Writes `tau` (n, N m or N) and the poses `d.X_WL`, `d.X_WT`; does not
/// touch `d.J`, `d.M`, `d.bias`.
pub fn rnea(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    g_W: &Vector3<f64>,
    f_T_W: Option<&Vector6<f64>>,
    tau: &mut [f64],
    d: &mut ChainData,
) {
    check_len(arm, d, "qd", qd);
    check_len(arm, d, "qdd", qdd);
    check_len(arm, d, "tau", tau);
    placements_and_inertias(arm, q, d);
    rnea_passes(qd, Some(qdd), g_W, f_T_W, tau, d);
}

/// Gravity torques `g(q) = −Σ_b J_bᵀ [m_b g_W; c_b × m_b g_W]` (N m or N): the RNEA at
/// `q̇ = q̈ = 0`, computed from the composite masses and first moments only,
/// `g_k = −S_k · [M_k g_W; H_k × g_W]` with `M_k = Σ_{b≥k} m_b`, `H_k = Σ_{b≥k} m_b c_b`.
///
/// Reads `q` (n) and `g_W`; writes `out` (n) and the poses `d.X_WL`, `d.X_WT`.
pub fn gravity(
    arm: &SpatialArm,
    q: &[f64],
    g_W: &Vector3<f64>,
    out: &mut [f64],
    d: &mut ChainData,
) {
    check_len(arm, d, "out", out);
    placements(arm, q, d);
    gravity_at_placements(arm, g_W, out, d);
}

/// [`gravity`] at the placements already in `d` (from [`super::kinematics`] or any algorithm
/// at the same `q`): the composite pass only, no forward kinematics.
pub fn gravity_at_placements(arm: &SpatialArm, g_W: &Vector3<f64>, out: &mut [f64], d: &ChainData) {
    check_len(arm, d, "out", out);
    let n = d.S.len();
    let (mut m, mut h) = (0.0, Vector3::zeros());
    for k in (0..n).rev() {
        let b = &arm.chain.bodies[k];
        m += b.mass;
        h += b.mass * (d.p_BL[k] + d.R_WL[k] * b.com);
        let w = stack(&(m * g_W), &h.cross(g_W));
        out[k] = -d.S[k].dot(&w);
    }
}
