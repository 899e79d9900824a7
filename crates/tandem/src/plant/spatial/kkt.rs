//! The spatial plant's derivative: per-arm terms, then the weld KKT by Schur complement, or the
//! compliant grasps' spring–damper wrenches (equations in the [parent module](super)).
//!
//! Data flow: `(y, τ, F_d)` → per arm `(X_WT, J, J̇q̇, M, Cq̇ + g)` → `M_i = L_i L_iᵀ` and one
//! forward substitution with seven right-hand sides, `[u_i | Z_i] = L_i⁻¹ [τ_i − Cq̇ − g − Dq̇ |
//! J_iᵀ]` → `J_i M_i⁻¹ J_iᵀ = Z_iᵀ Z_i`, `J_i q̈⁰_i = Z_iᵀ u_i` → object `V̇⁰_o` → `K F = rhs`
//! (`6m × 6m` Cholesky) → `q̈_i = L_i⁻ᵀ (u_i + Z_i F_i)`, `V̇_o` → `dy`.
//!
//! The compliant grasps take the same per-arm factorisation and the same last step with the
//! spring–damper wrench in place of the multiplier.

use nalgebra::{Matrix3, Vector3, Vector6};

use super::{
    GraspModel, K_REG, ObjectState, SpatialInput, SpatialPlant, SpatialWorkspace, log_quat, skew,
    v6,
};
use crate::dynamics::spatial;
use crate::math::linalg::{backward_rows, cholesky_rows, forward_rows};

/// Columns of the per-arm right-hand side `[τ − b | Jᵀ]`.
const RHS: usize = 7;

pub(super) fn derivative(
    p: &SpatialPlant,
    y: &[f64],
    input: &SpatialInput,
    ws: &mut SpatialWorkspace,
    dy: &mut [f64],
) -> bool {
    let n_q = p.n_q;
    let m = p.arms.len();
    let (q, o, qd) = p.split(y);
    let r_wo = *o.q.to_rotation_matrix().matrix();
    let weld = matches!(p.grasp_model, GraspModel::Weld);
    // The state-only part (terms, L, Z, the factored K) is reused when the same state comes
    // back with another input: the loop's wrench evaluation at (y_k, u_{k−1}) and the first
    // RK4 stage at (y_k, u_k). Bitwise the same result as a full evaluation.
    let hit = weld && ws.cache_valid && ws.cache_y[..] == *y;
    ws.cache_valid = false;

    // 1. Per arm: terms, M = L Lᵀ, and [u | Z] = L⁻¹ [τ − Cq̇ − g − Dq̇ | Jᵀ]. The common
    //    joint counts get constant loop bounds (unrolled kernels). On a cache hit only u.
    for (i, arm) in p.arms.iter().enumerate() {
        let s = p.offsets[i];
        if hit {
            let n = arm.chain.dof();
            let d = &ws.data[i];
            let u = &mut ws.u[i][..n];
            for k in 0..n {
                u[k] = input.tau[s + k] - d.bias[k] - arm.chain.joints[k].damping * qd[s + k];
            }
            match n {
                6 => forward_rows(&ws.chol[i], 6, u, 1),
                7 => forward_rows(&ws.chol[i], 7, u, 1),
                _ => forward_rows(&ws.chol[i], n, u, 1),
            }
            let x = &mut ws.x[i];
            for k in 0..n {
                x[k * RHS] = u[k];
            }
            continue;
        }
        let d = &mut ws.data[i];
        spatial::terms(
            arm,
            &q[s..s + arm.chain.dof()],
            &qd[s..s + arm.chain.dof()],
            &p.g_W,
            d,
        );
        let ok = match arm.chain.dof() {
            6 => arm_factor(6, arm, s, qd, input, d, &mut ws.chol[i], &mut ws.x[i]),
            7 => arm_factor(7, arm, s, qd, input, d, &mut ws.chol[i], &mut ws.x[i]),
            n => arm_factor(n, arm, s, qd, input, d, &mut ws.chol[i], &mut ws.x[i]),
        };
        if !ok {
            return false;
        }
    }

    // 2. Object: world inertia, bias b_o.
    let obj = &p.object;
    let i_w = r_wo * obj.inertia * r_wo.transpose();
    let i_w_inv = r_wo * obj.inertia_inv * r_wo.transpose();
    let c = &obj.damping;
    let mut b_lin = obj.mass * p.g_W - input.f_d.fixed_rows::<3>(0);
    let mut b_ang = -o.w.cross(&(i_w * o.w)) - input.f_d.fixed_rows::<3>(3);
    for k in 0..3 {
        b_lin[k] -= c[k] * o.v[k];
        b_ang[k] -= c[3 + k] * o.w[k];
    }
    let inv_m = 1.0 / obj.mass;

    match &p.grasp_model {
        GraspModel::Weld => {
            if !weld_wrenches(p, &o, &r_wo, &i_w_inv, inv_m, b_lin, b_ang, qd, ws, !hit) {
                return false;
            }
            ws.cache_y.copy_from_slice(y);
            ws.cache_valid = true;
        }
        GraspModel::Compliant { stiffness, damping } => {
            compliant_wrenches(p, &o, stiffness, damping, qd, ws);
        }
        GraspModel::Contact(_) => {
            contact_wrenches(p, y, &o, qd, input, ws);
        }
    }

    // 4. Accelerations: q̈_i = L⁻ᵀ(u_i + Z_i F_i); the object takes −F_i at the points
    //    `ws.r[i]` (the grasp origins for welds, the tool origins for compliant grasps).
    let mut f_lin_sum = Vector3::zeros();
    let mut f_ang_sum = Vector3::zeros();
    for i in 0..m {
        let n = p.arms[i].chain.dof();
        let s = p.offsets[i];
        let f = ws.wrenches[i];
        let fl = f.fixed_rows::<3>(0).into_owned();
        f_lin_sum += fl;
        f_ang_sum += f.fixed_rows::<3>(3) + ws.r[i].cross(&fl);
        let x = &ws.x[i][..n * RHS];
        let out = &mut dy[n_q + 7 + s..n_q + 7 + s + n];
        for k in 0..n {
            let row = &x[k * RHS..k * RHS + RHS];
            let mut acc = row[0];
            for a in 0..6 {
                acc += row[1 + a] * f[a];
            }
            out[k] = acc;
        }
        match n {
            6 => backward_rows(&ws.chol[i], 6, out),
            7 => backward_rows(&ws.chol[i], 7, out),
            _ => backward_rows(&ws.chol[i], n, out),
        }
    }
    ws.a_o = v6(
        &((b_lin - f_lin_sum) * inv_m),
        &(i_w_inv * (b_ang - f_ang_sum)),
    );

    // q̇ and the object's pose rates; q̇_WO = ½ (0, ω) ⊗ q_WO on the stored quaternion.
    dy[..n_q].copy_from_slice(&y[n_q + 7..2 * n_q + 7]);
    dy[n_q..n_q + 3].copy_from_slice(o.v.as_slice());
    let (w0, x0, y0, z0) = (y[n_q + 3], y[n_q + 4], y[n_q + 5], y[n_q + 6]);
    let (wx, wy, wz) = (o.w.x, o.w.y, o.w.z);
    dy[n_q + 3] = 0.5 * (-wx * x0 - wy * y0 - wz * z0);
    dy[n_q + 4] = 0.5 * (wx * w0 + wy * z0 - wz * y0);
    dy[n_q + 5] = 0.5 * (wy * w0 + wz * x0 - wx * z0);
    dy[n_q + 6] = 0.5 * (wz * w0 + wx * y0 - wy * x0);
    dy[2 * n_q + 7..2 * n_q + 13].copy_from_slice(ws.a_o.as_slice());
    // Contact anchors are held through the step (updated after it).
    dy[2 * n_q + 13..].iter_mut().for_each(|v| *v = 0.0);
    true
}

/// `L = chol(M)` and `[u | Z] = L⁻¹ [τ − Cq̇ − g − Dq̇ | Jᵀ]` for one arm of `n` joints
/// (inlined so that a constant `n` unrolls the kernels). `false` if `M` is not positive
/// definite.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn arm_factor(
    n: usize,
    arm: &crate::model::spatial::SpatialArm,
    s: usize,
    qd: &[f64],
    input: &SpatialInput,
    d: &spatial::ChainData,
    l: &mut [f64],
    x: &mut [f64],
) -> bool {
    let l = &mut l[..n * n];
    // M is symmetric: its column-major storage is its row-major storage.
    l.copy_from_slice(&d.M.as_slice()[..n * n]);
    if cholesky_rows(l, n).is_err() {
        return false;
    }
    let x = &mut x[..n * RHS];
    let jt = &d.J.as_slice()[..6 * n]; // column-major 6 × n: jt[6k + c] = J[c, k]
    let (tau, qd) = (&input.tau[s..s + n], &qd[s..s + n]);
    for k in 0..n {
        let row = &mut x[k * RHS..k * RHS + RHS];
        row[0] = tau[k] - d.bias[k] - arm.chain.joints[k].damping * qd[k];
        row[1..].copy_from_slice(&jt[6 * k..6 * k + 6]);
    }
    forward_rows(l, n, x, RHS);
    true
}

/// Welds: build `K` and the right-hand side, solve for the multipliers `F` (into
/// `ws.wrenches`) and set `ws.r[i]` to the grasp origins. `false` if `K` cannot be factored
/// even regularised.
#[allow(clippy::too_many_arguments)]
fn weld_wrenches(
    p: &SpatialPlant,
    o: &ObjectState,
    r_wo: &Matrix3<f64>,
    i_w_inv: &Matrix3<f64>,
    inv_m: f64,
    b_lin: Vector3<f64>,
    b_ang: Vector3<f64>,
    qd: &[f64],
    ws: &mut SpatialWorkspace,
    factor: bool,
) -> bool {
    let m = p.arms.len();
    let nk = 6 * m;
    let a0_lin = b_lin * inv_m;
    let a0_ang = i_w_inv * b_ang;
    let (wb, wb2) = (2.0 * p.baumgarte, p.baumgarte * p.baumgarte);
    let x_wo = o.pose();
    let k = &mut ws.k[..nk * nk];
    for i in 0..m {
        let n = p.arms[i].chain.dof();
        let s = p.offsets[i];
        let d = &ws.data[i];
        let r = r_wo * p.grasps[i].translation.vector;
        ws.r[i] = r;
        // Diagonal block Λ_i⁻¹ = J M⁻¹ Jᵀ = Zᵀ Z, and J q̈⁰ = Zᵀ u.
        let x = &ws.x[i][..n * RHS];
        let mut jq0 = Vector6::zeros();
        if factor {
            let mut lam = [[0.0f64; 6]; 6];
            for kk in 0..n {
                let row: &[f64; RHS] = x[kk * RHS..kk * RHS + RHS].try_into().expect("RHS columns");
                let u = row[0];
                // Full 6 × 6 rank-one update per joint: six 6-wide AXPYs vectorise better than
                // the 21-entry triangle.
                for a in 0..6 {
                    let za = row[1 + a];
                    jq0[a] += za * u;
                    let dst = &mut lam[a];
                    for b in 0..6 {
                        dst[b] += za * row[1 + b];
                    }
                }
            }
            for a in 0..6 {
                let dst = &mut k[(6 * i + a) * nk + 6 * i..(6 * i + a) * nk + 6 * i + 6];
                dst.copy_from_slice(&lam[a]);
            }
        } else {
            for kk in 0..n {
                let row: &[f64; RHS] = x[kk * RHS..kk * RHS + RHS].try_into().expect("RHS columns");
                for a in 0..6 {
                    jq0[a] += row[1 + a] * row[0];
                }
            }
        }
        // rhs_i = γ_i − (J q̈⁰ + J̇q̇ − Ad_i V̇⁰ − c_i), γ_i = −2ω_b ė − ω_b² e.
        let vt = tool_twist(d, &qd[s..s + n]);
        let ad_a0 = v6(&(a0_lin + a0_ang.cross(&r)), &a0_ang);
        let ci = v6(&o.w.cross(&o.w.cross(&r)), &Vector3::zeros());
        let x_wg = x_wo * p.grasps[i];
        let e = v6(
            &(d.X_WT.translation.vector - x_wg.translation.vector),
            &log_quat(&(d.X_WT.rotation * x_wg.rotation.inverse())),
        );
        let ed = vt - v6(&(o.v + o.w.cross(&r)), &o.w);
        let rhs = -wb * ed - wb2 * e - (jq0 + d.jdqd - ad_a0 - ci);
        ws.rhs[6 * i..6 * i + 6].copy_from_slice(rhs.as_slice());
    }
    if !factor {
        // The factor of K (and its regularisation) from the cached evaluation of this state.
        if ws.cache_regularised {
            ws.regularised += 1;
        }
    } else {
        ws.cache_regularised = false;
        // Object coupling: K_ij += Ad_i M_o⁻¹ Ad_jᵀ
        //   = [[I/m − A_i [r_j],  −A_i], [−A_jᵀ,  I⁻¹]],   A_i = [r_i] I⁻¹ (so I⁻¹[r_j] = −A_jᵀ).
        for i in 0..m {
            ws.a[i] = skew(&ws.r[i]) * i_w_inv;
        }
        for i in 0..m {
            let ai = ws.a[i];
            for j in 0..m {
                let tl = Matrix3::from_diagonal_element(inv_m) - ai * skew(&ws.r[j]);
                let bl = -ws.a[j].transpose();
                let diag = i == j;
                for a in 0..3 {
                    let top = &mut k[(6 * i + a) * nk + 6 * j..(6 * i + a) * nk + 6 * j + 6];
                    for b in 0..3 {
                        let (t, r) = (tl[(a, b)], -ai[(a, b)]);
                        if diag {
                            top[b] += t;
                            top[3 + b] += r;
                        } else {
                            top[b] = t;
                            top[3 + b] = r;
                        }
                    }
                    let bot =
                        &mut k[(6 * i + 3 + a) * nk + 6 * j..(6 * i + 3 + a) * nk + 6 * j + 6];
                    for b in 0..3 {
                        let (t, r) = (bl[(a, b)], i_w_inv[(a, b)]);
                        if diag {
                            bot[b] += t;
                            bot[3 + b] += r;
                        } else {
                            bot[b] = t;
                            bot[3 + b] = r;
                        }
                    }
                }
            }
        }
        ws.k_copy[..nk * nk].copy_from_slice(k);
        let factored = match nk {
            12 => cholesky_rows(k, 12),
            18 => cholesky_rows(k, 18),
            _ => cholesky_rows(k, nk),
        };
        match factored {
            Ok(piv) if piv > 1e-14 => ws.kkt_pivot = piv,
            _ => {
                // Singular chain: K + ε tr(K)/(6m) I from the saved copy, counted.
                k.copy_from_slice(&ws.k_copy[..nk * nk]);
                let tr: f64 = (0..nk).map(|a| k[a * nk + a]).sum();
                let eps = K_REG * tr / nk as f64;
                for a in 0..nk {
                    k[a * nk + a] += eps;
                }
                ws.regularised += 1;
                ws.cache_regularised = true;
                match cholesky_rows(k, nk) {
                    Ok(piv) => ws.kkt_pivot = piv,
                    Err(_) => return false,
                }
            }
        }
    }
    match nk {
        12 => {
            forward_rows(k, 12, &mut ws.rhs, 1);
            backward_rows(k, 12, &mut ws.rhs);
        }
        _ => {
            forward_rows(k, nk, &mut ws.rhs, 1);
            backward_rows(k, nk, &mut ws.rhs);
        }
    }
    for i in 0..m {
        ws.wrenches[i] = Vector6::from_column_slice(&ws.rhs[6 * i..6 * i + 6]);
    }
    true
}

/// The tool twist `J q̇` (world axes) from the arm's Jacobian in `d`.
#[inline]
pub(super) fn tool_twist(d: &spatial::ChainData, qd: &[f64]) -> Vector6<f64> {
    let jt = &d.J.as_slice()[..6 * qd.len()];
    let mut vt = Vector6::zeros();
    for (kk, q) in qd.iter().enumerate() {
        let col = &jt[6 * kk..6 * kk + 6];
        for a in 0..6 {
            vt[a] += col[a] * q;
        }
    }
    vt
}

/// Compliant grasps: the spring–damper wrench of each grasp into `ws.wrenches`, and `ws.r[i]`
/// set to the tool origins (where `−F_i` acts on the object).
fn compliant_wrenches(
    p: &SpatialPlant,
    o: &ObjectState,
    stiffness: &Vector6<f64>,
    damping: &Vector6<f64>,
    qd: &[f64],
    ws: &mut SpatialWorkspace,
) {
    let x_wo = o.pose();
    for i in 0..p.arms.len() {
        let n = p.arms[i].chain.dof();
        let s = p.offsets[i];
        let d = &ws.data[i];
        let x_wg = x_wo * p.grasps[i];
        let r_wg = x_wg.rotation;
        let p_t = d.X_WT.translation.vector;
        // Error in G axes.
        let e = v6(
            &r_wg.inverse_transform_vector(&(p_t - x_wg.translation.vector)),
            &log_quat(&(r_wg.inverse() * d.X_WT.rotation)),
        );
        // Relative twist of the tool against the object point under it, in G axes.
        let vt = tool_twist(d, &qd[s..s + n]);
        let rp = p_t - o.p;
        let dv = vt.fixed_rows::<3>(0) - (o.v + o.w.cross(&rp));
        let dw = vt.fixed_rows::<3>(3) - o.w;
        let ed = v6(
            &r_wg.inverse_transform_vector(&dv),
            &r_wg.inverse_transform_vector(&dw),
        );
        let mut w_g = Vector6::zeros();
        for kk in 0..6 {
            w_g[kk] = -(stiffness[kk] * e[kk] + damping[kk] * ed[kk]);
        }
        ws.wrenches[i] = v6(
            &r_wg.transform_vector(&w_g.fixed_rows::<3>(0).into_owned()),
            &r_wg.transform_vector(&w_g.fixed_rows::<3>(3).into_owned()),
        );
        ws.r[i] = rp;
    }
}

/// Contact grasps: the pads' wrench on each tool into `ws.wrenches`, and `ws.r[i]` set to the
/// tool origins (where `−F_i` acts on the object).
fn contact_wrenches(
    p: &SpatialPlant,
    y: &[f64],
    o: &ObjectState,
    qd: &[f64],
    input: &SpatialInput,
    ws: &mut SpatialWorkspace,
) {
    let Some(c) = p.contact() else { return };
    let x_wo = o.pose();
    let base = p.anchor_offset();
    for i in 0..p.arms.len() {
        let g = p.grasp_kin(i, &x_wo, o, qd, ws);
        let f_g = input.grip.get(i).copied().unwrap_or(c.grip(i));
        let r = c.pads_of(i);
        let w = c.grasp_wrench(i, &g, f_g, &y[base + 3 * r.start..base + 3 * r.end]);
        let rp = ws.data[i].X_WT.translation.vector - o.p;
        ws.wrenches[i] = w;
        ws.r[i] = rp;
    }
}
