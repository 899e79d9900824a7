//! Forward kinematics, the tool Jacobian and `J̇ q̇` (Featherstone 2008, ch. 3–4: velocity
//! propagation; world axes about the base origin). The stages here are shared by every other
//! algorithm.
//!
//! ```text
//! X_WL_k = X_WL_{k−1} X_PJ[k] J_k(q_k)          (X_WL_{−1} = X_WB = arm.base)
//! X_WT   = X_WL_{n−1} X_LT
//! S_k    = [p_k × z_k; z_k] (revolute) or [z_k; 0] (prismatic),  z_k = R_WL_k a_k,  p_k = p_WL_k
//! V_k    = V_{k−1} + S_k q̇_k                    (world axes about the base origin p_WB)
//! J[:,k] = [s_v + s_ω × p_T; s_ω]              (S_k moved to the tool point p_T = p_WT)
//! A_T    = Σ_k (V_k × S_k) q̇_k                 (spatial acceleration at q̈ = 0: Ṡ_k = V_k × S_k)
//! J̇ q̇   = [a_v + a_ω × p_T + ω × ṗ_T; a_ω]     (classical acceleration of the tool point,
//!                                                ṗ_T = v + ω × p_T, (v, ω) = V_{n−1})
//! ```
//!
//! Cost for n joints: one inlined `sin_cos` and about 130 flops per joint (two quaternion
//! products, the quaternion-to-matrix conversion, the world axis and `S_k`; ≈ 370
//! instructions), 12 flops per Jacobian column, 35 per joint for `J̇ q̇`.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3, Vector6};

use super::{ChainData, check_len};
use crate::geometry::SpatialInertia;
use crate::geometry::motion::{ang, cross_motion, lin, stack};
use crate::math::trig::sin_cos;
use crate::model::spatial::{JointKind, SpatialArm};

/// `R` from a unit quaternion (homogeneous form, no normalisation).
#[inline(always)]
pub(super) fn rot(q: &Quaternion<f64>) -> Matrix3<f64> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let (ww, xx, yy, zz) = (w * w, x * x, y * y, z * z);
    let (xy, xz, yz) = (2.0 * x * y, 2.0 * x * z, 2.0 * y * z);
    let (wx, wy, wz) = (2.0 * w * x, 2.0 * w * y, 2.0 * w * z);
    Matrix3::new(
        ww + xx - yy - zz,
        xy - wz,
        xz + wy,
        xy + wz,
        ww - xx + yy - zz,
        yz - wx,
        xz - wy,
        yz + wx,
        ww - xx - yy + zz,
    )
}

/// Hamilton product `a b` written out (16 multiplications).
#[inline(always)]
fn qmul(a: &Quaternion<f64>, b: &Quaternion<f64>) -> Quaternion<f64> {
    Quaternion::new(
        a.w * b.w - a.i * b.i - a.j * b.j - a.k * b.k,
        a.w * b.i + a.i * b.w + a.j * b.k - a.k * b.j,
        a.w * b.j - a.i * b.k + a.j * b.w + a.k * b.i,
        a.w * b.k + a.i * b.j - a.j * b.i + a.k * b.w,
    )
}

/// `R v` for a rotation matrix, written out.
#[inline(always)]
fn mulv(r: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        r[(0, 0)] * v.x + r[(0, 1)] * v.y + r[(0, 2)] * v.z,
        r[(1, 0)] * v.x + r[(1, 1)] * v.y + r[(1, 2)] * v.z,
        r[(2, 0)] * v.x + r[(2, 1)] * v.y + r[(2, 2)] * v.z,
    )
}

/// Stage 1: `q → (X_WL, R_WL, S, X_WT)`. Reads the chain and `arm.base`.
#[inline]
pub(super) fn placements(arm: &SpatialArm, q: &[f64], d: &mut ChainData) {
    check_len(arm, d, "q", q);
    let chain = &arm.chain;
    let mut q_prev: Quaternion<f64> = *arm.base.rotation.quaternion();
    let mut r_prev = rot(&q_prev);
    // Positions relative to the base origin p_WB (world axes): see the module doc of `super`.
    let p_wb = arm.base.translation.vector;
    let mut p_prev = Vector3::zeros();
    // Equal-length slices: the indexing below needs no bounds checks.
    let n = chain.joints.len();
    let (q, x_wl, p_bl, r_wl_out, s_out) = (
        &q[..n],
        &mut d.X_WL[..n],
        &mut d.p_BL[..n],
        &mut d.R_WL[..n],
        &mut d.S[..n],
    );
    for (k, j) in chain.joints.iter().enumerate() {
        let q_pj = j.placement.rotation.quaternion();
        let t_pj = j.placement.translation.vector;
        let a = j.axis.into_inner();
        // Parent-to-joint placement composed first: q_WJ = q_W,parent q_PJ (16 mult).
        let q_wj = qmul(&q_prev, q_pj);
        let p_j = p_prev + mulv(&r_prev, &t_pj);
        let (q_wl, p_wl, r_wl, s) = match j.kind {
            JointKind::Revolute => {
                // J(q) = Rot(a, q) = (cos q/2, sin q/2 a).
                let (sh, ch) = sin_cos(0.5 * q[k]);
                let q_wl = qmul(&q_wj, &Quaternion::new(ch, sh * a.x, sh * a.y, sh * a.z));
                let r = rot(&q_wl);
                let z = mulv(&r, &a);
                (q_wl, p_j, r, stack(&p_j.cross(&z), &z))
            }
            JointKind::Prismatic => {
                let r = rot(&q_wj);
                let z = mulv(&r, &a);
                let p = p_j + z * q[k];
                (q_wj, p, r, stack(&z, &Vector3::zeros()))
            }
        };
        x_wl[k].rotation = UnitQuaternion::new_unchecked(q_wl);
        x_wl[k].translation.vector = p_wb + p_wl;
        p_bl[k] = p_wl;
        r_wl_out[k] = r_wl;
        s_out[k] = s;
        q_prev = q_wl;
        r_prev = r_wl;
        p_prev = p_wl;
    }
    // Tool: X_WT = X_WL_{n−1} X_LT.
    let q_t = q_prev * chain.tool.rotation.quaternion();
    d.X_WT.rotation = UnitQuaternion::new_unchecked(q_t);
    let p_bt = p_prev + r_prev * chain.tool.translation.vector;
    d.p_BT = p_bt;
    d.X_WT.translation.vector = p_wb + p_bt;
}

/// Stages 1 and 2: `q → (X_WL, R_WL, S, X_WT, 𝕀_k)`, with the body inertias in
/// world axes about the base origin: `c = p + R c_L`, `I_O = R I_c Rᵀ − m [c]²`, `h = m c`.
#[inline]
pub(super) fn placements_and_inertias(arm: &SpatialArm, q: &[f64], d: &mut ChainData) {
    placements(arm, q, d);
    for (((i, b), r), p) in d
        .I_W
        .iter_mut()
        .zip(&arm.chain.bodies)
        .zip(&d.R_WL)
        .zip(&d.p_BL)
    {
        *i = SpatialInertia::from_com_posed(b.mass, &b.com, &b.inertia, r, p);
    }
}

/// Stage 3: `(S, q̇) → V_k = V_{k−1} + S_k q̇_k` (fixed base: `V_{−1} = 0`).
#[inline]
pub(super) fn velocities(qd: &[f64], d: &mut ChainData) {
    let mut v = Vector6::zeros();
    for ((vk, s), qdk) in d.V.iter_mut().zip(&d.S).zip(qd) {
        v += s * *qdk;
        *vk = v;
    }
}

/// Stage 4a: `(S, p_BT) → J`: each `S_k` moved to the tool point.
#[inline]
pub(super) fn tool_jacobian(d: &mut ChainData) {
    let p_t = d.p_BT;
    for (col, s) in d.J.as_mut_slice().chunks_exact_mut(6).zip(&d.S) {
        let w = ang(s);
        let v = lin(s) + w.cross(&p_t);
        col.copy_from_slice(&[v.x, v.y, v.z, w.x, w.y, w.z]);
    }
}

/// Stage 4b: `(S, V, q̇, p_BT) → J̇ q̇` (classical, tool point).
#[inline]
pub(super) fn tool_jdqd(qd: &[f64], d: &mut ChainData) {
    let mut acc = Vector6::zeros();
    for ((v, s), qdk) in d.V.iter().zip(&d.S).zip(qd) {
        acc += cross_motion(v, s) * *qdk;
    }
    tool_jdqd_from(&acc, d);
}

/// `J̇ q̇` from the last body's spatial acceleration `acc` at `q̈ = 0` without gravity
/// (`Σ_k V_k × S_k q̇_k`) and its twist.
#[inline]
pub(super) fn tool_jdqd_from(acc: &Vector6<f64>, d: &mut ChainData) {
    let p_t = d.p_BT;
    let vt = d.V[d.V.len() - 1];
    let w = ang(&vt);
    let pd_t = lin(&vt) + w.cross(&p_t);
    let alpha = ang(acc);
    d.jdqd = stack(&(lin(acc) + alpha.cross(&p_t) + w.cross(&pd_t)), &alpha);
}

/// Forward kinematics of every body and the tool, the tool Jacobian, and `J̇ q̇` when `qd` is
/// given (Featherstone 2008, ch. 4; world axes).
///
/// Reads `q` (n, rad or m), optionally `q̇` (n); writes `d.X_WL` (n poses), `d.X_WT`,
/// `d.J` (6 × n, `[ṗ_T; ω_T] = J q̇`, world axes, about the tool origin, m/rad and 1) and
/// `d.jdqd` (`[p̈_T; ω̇_T]` at `q̈ = 0`, m/s² and rad/s²; zero when `qd` is `None`). With `qd`,
/// the body twists are left in [`ChainData::body_twists`].
pub fn kinematics(arm: &SpatialArm, q: &[f64], qd: Option<&[f64]>, d: &mut ChainData) {
    placements(arm, q, d);
    tool_jacobian(d);
    match qd {
        Some(qd) => {
            check_len(arm, d, "qd", qd);
            velocities(qd, d);
            tool_jdqd(qd, d);
        }
        None => d.jdqd = Vector6::zeros(),
    }
}
