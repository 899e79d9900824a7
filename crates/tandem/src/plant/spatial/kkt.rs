//! The spatial plant's derivative: per-arm terms, then the weld KKT by Schur complement, or the
//! compliant grasps' spring–damper wrenches (equations in the [parent module](super)).
//!
//! Data flow: `(y, τ, F_d)` → per arm `(X_WT, J, J̇q̇, M, Cq̇ + g)` → `M_i = L Lᵀ`, `q̈⁰_i`,
//! `M_i⁻¹J_iᵀ` → object `V̇⁰_o` → `K`, `rhs` → `F` → `(q̈, V̇_o)` → `dy`.

use nalgebra::{Matrix3, Vector3, Vector6};

use super::{GraspModel, K_REG, SpatialInput, SpatialPlant, SpatialWorkspace, log_quat, skew, v6};
use crate::dynamics;
use crate::linalg::{cholesky_in_place, cholesky_solve_in_place};

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
    let r_wo = o.q.to_rotation_matrix();
    let r_wo = r_wo.matrix();
    let compliant = matches!(p.grasp_model, GraspModel::Compliant { .. });

    // 1. Per arm: terms, Cholesky of M, unconstrained q̈⁰, and (welds) M⁻¹Jᵀ.
    for (i, arm) in p.arms.iter().enumerate() {
        let n = arm.chain.dof();
        let s = p.offsets[i];
        let (qi, qdi) = (&q[s..s + n], &qd[s..s + n]);
        let d = &mut ws.data[i];
        dynamics::terms(arm, qi, qdi, &p.g_W, d);
        let l = &mut ws.chol[i];
        l.copy_from(&d.M);
        if cholesky_in_place(l, n).is_err() {
            return false;
        }
        let qdd0 = &mut ws.qdd0[i];
        for k in 0..n {
            qdd0[k] = input.tau[s + k] - d.bias[k] - arm.chain.joints[k].damping * qdi[k];
        }
        cholesky_solve_in_place(l, n, qdd0.as_mut_slice());
        if !compliant {
            let yj = &mut ws.y_jt[i];
            for c in 0..6 {
                let col = yj.column_mut(c);
                let col = col.data.into_slice_mut();
                for k in 0..n {
                    col[k] = d.J[(c, k)];
                }
                cholesky_solve_in_place(l, n, col);
            }
        }
    }

    // 2. Object: world inertia, bias b_o and unconstrained acceleration V̇⁰_o = M_o⁻¹ b_o.
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

    if compliant {
        return compliant_derivative(p, y, &o, r_wo, &i_w_inv, b_lin, b_ang, ws, dy);
    }

    let inv_m = 1.0 / obj.mass;
    let a0_lin = b_lin * inv_m;
    let a0_ang = i_w_inv * b_ang;

    // 3. Grasp-space system K F = rhs.
    let (wb, wb2) = (2.0 * p.baumgarte, p.baumgarte * p.baumgarte);
    let x_wo = o.pose();
    ws.k.fill(0.0);
    for i in 0..m {
        let n = p.arms[i].chain.dof();
        let s = p.offsets[i];
        let d = &ws.data[i];
        let r = r_wo * p.grasps[i].translation.vector;
        ws.r[i] = r;
        // Λ_i⁻¹ = J M⁻¹ Jᵀ on the diagonal block.
        let yj = &ws.y_jt[i];
        for a in 0..6 {
            for b in a..6 {
                let mut acc = 0.0;
                for k in 0..n {
                    acc += d.J[(a, k)] * yj[(k, b)];
                }
                ws.k[(6 * i + a, 6 * i + b)] = acc;
                ws.k[(6 * i + b, 6 * i + a)] = acc;
            }
        }
        // rhs_i = γ_i − (J q̈⁰ + J̇q̇ − Ad_i V̇⁰ − c_i).
        let mut jq0 = Vector6::zeros();
        let mut vt = Vector6::zeros();
        for k in 0..n {
            let col = d.J.column(k);
            jq0 += col * ws.qdd0[i][k];
            vt += col * qd[s + k];
        }
        let ad_a0 = v6(&(a0_lin + a0_ang.cross(&r)), &a0_ang);
        let ci = v6(&o.w.cross(&o.w.cross(&r)), &Vector3::zeros());
        let e = {
            let x_wg = x_wo * p.grasps[i];
            let dp = d.X_WT.translation.vector - x_wg.translation.vector;
            let dr = log_quat(&(d.X_WT.rotation * x_wg.rotation.inverse()));
            v6(&dp, &dr)
        };
        let vg = v6(&(o.v + o.w.cross(&r)), &o.w);
        let ed = vt - vg;
        let rhs = -wb * ed - wb2 * e - (jq0 + d.jdqd - ad_a0 - ci);
        ws.rhs[6 * i..6 * i + 6].copy_from_slice(rhs.as_slice());
    }
    // Object coupling: K_ij += Ad_i M_o⁻¹ Ad_jᵀ
    //   = [[I/m − [r_i] I⁻¹ [r_j],  −[r_i] I⁻¹], [I⁻¹ [r_j],  I⁻¹]].
    for i in 0..m {
        let si = skew(&ws.r[i]);
        let si_iinv = si * i_w_inv;
        for j in 0..m {
            let sj = skew(&ws.r[j]);
            let tl = Matrix3::identity() * inv_m - si_iinv * sj;
            let tr = -si_iinv;
            let bl = i_w_inv * sj;
            let br = i_w_inv;
            for a in 0..3 {
                for b in 0..3 {
                    ws.k[(6 * i + a, 6 * j + b)] += tl[(a, b)];
                    ws.k[(6 * i + a, 6 * j + 3 + b)] += tr[(a, b)];
                    ws.k[(6 * i + 3 + a, 6 * j + b)] += bl[(a, b)];
                    ws.k[(6 * i + 3 + a, 6 * j + 3 + b)] += br[(a, b)];
                }
            }
        }
    }
    let nk = 6 * m;
    let ok = match cholesky_in_place(&mut ws.k, nk) {
        Ok(piv) => {
            ws.kkt_pivot = piv;
            piv > 1e-14
        }
        Err(_) => false,
    };
    if !ok {
        // Rebuild K (the failed factorisation overwrote part of it) and regularise.
        rebuild_k(p, ws, &i_w_inv, inv_m);
        let mut tr = 0.0;
        for k in 0..nk {
            tr += ws.k[(k, k)];
        }
        let eps = K_REG * tr / nk as f64;
        for k in 0..nk {
            ws.k[(k, k)] += eps;
        }
        ws.regularised += 1;
        match cholesky_in_place(&mut ws.k, nk) {
            Ok(piv) => ws.kkt_pivot = piv,
            Err(_) => return false,
        }
    }
    cholesky_solve_in_place(&ws.k, nk, &mut ws.rhs);

    // 4. Accelerations.
    let mut f_lin_sum = Vector3::zeros();
    let mut f_ang_sum = Vector3::zeros();
    for i in 0..m {
        let f = Vector6::from_column_slice(&ws.rhs[6 * i..6 * i + 6]);
        ws.wrenches[i] = f;
        let fl = f.fixed_rows::<3>(0).into_owned();
        let fa = f.fixed_rows::<3>(3).into_owned();
        f_lin_sum += fl;
        f_ang_sum += fa + ws.r[i].cross(&fl);
    }
    ws.a_o = v6(
        &(a0_lin - f_lin_sum * inv_m),
        &(a0_ang - i_w_inv * f_ang_sum),
    );
    write_dy(p, y, &o, ws, dy, n_q, false);
    true
}

/// `K` from scratch (after a failed factorisation), from the per-arm blocks in `ws`.
fn rebuild_k(p: &SpatialPlant, ws: &mut SpatialWorkspace, i_w_inv: &Matrix3<f64>, inv_m: f64) {
    let m = p.arms.len();
    ws.k.fill(0.0);
    for i in 0..m {
        let n = p.arms[i].chain.dof();
        let d = &ws.data[i];
        let yj = &ws.y_jt[i];
        for a in 0..6 {
            for b in 0..6 {
                let mut acc = 0.0;
                for k in 0..n {
                    acc += d.J[(a, k)] * yj[(k, b)];
                }
                ws.k[(6 * i + a, 6 * i + b)] = acc;
            }
        }
    }
    for i in 0..m {
        let si = skew(&ws.r[i]);
        let si_iinv = si * i_w_inv;
        for j in 0..m {
            let sj = skew(&ws.r[j]);
            let tl = Matrix3::identity() * inv_m - si_iinv * sj;
            let tr = -si_iinv;
            let bl = i_w_inv * sj;
            for a in 0..3 {
                for b in 0..3 {
                    ws.k[(6 * i + a, 6 * j + b)] += tl[(a, b)];
                    ws.k[(6 * i + a, 6 * j + 3 + b)] += tr[(a, b)];
                    ws.k[(6 * i + 3 + a, 6 * j + b)] += bl[(a, b)];
                    ws.k[(6 * i + 3 + a, 6 * j + 3 + b)] += i_w_inv[(a, b)];
                }
            }
        }
    }
}

/// `dy` from the arms' `q̈⁰` (+ `M⁻¹Jᵀ F` for welds, already folded in for compliant grasps)
/// and `ws.a_o`.
fn write_dy(
    p: &SpatialPlant,
    y: &[f64],
    o: &super::ObjectState,
    ws: &mut SpatialWorkspace,
    dy: &mut [f64],
    n_q: usize,
    compliant: bool,
) {
    // q̇ and the object's pose rates.
    dy[..n_q].copy_from_slice(&y[n_q + 7..2 * n_q + 7]);
    dy[n_q..n_q + 3].copy_from_slice(o.v.as_slice());
    // q̇_WO = ½ (0, ω) ⊗ q_WO, on the stored (unnormalised) quaternion.
    let (w0, x0, y0, z0) = (y[n_q + 3], y[n_q + 4], y[n_q + 5], y[n_q + 6]);
    let (wx, wy, wz) = (o.w.x, o.w.y, o.w.z);
    dy[n_q + 3] = 0.5 * (-wx * x0 - wy * y0 - wz * z0);
    dy[n_q + 4] = 0.5 * (wx * w0 + wy * z0 - wz * y0);
    dy[n_q + 5] = 0.5 * (wy * w0 + wz * x0 - wx * z0);
    dy[n_q + 6] = 0.5 * (wz * w0 + wx * y0 - wy * x0);
    // q̈.
    for i in 0..p.arms.len() {
        let n = p.arms[i].chain.dof();
        let s = p.offsets[i];
        let out = &mut dy[n_q + 7 + s..n_q + 7 + s + n];
        out.copy_from_slice(ws.qdd0[i].as_slice());
        if !compliant {
            let f = &ws.wrenches[i];
            let yj = &ws.y_jt[i];
            for k in 0..n {
                let mut acc = 0.0;
                for c in 0..6 {
                    acc += yj[(k, c)] * f[c];
                }
                out[k] += acc;
            }
        }
    }
    dy[2 * n_q + 7..2 * n_q + 13].copy_from_slice(ws.a_o.as_slice());
}

/// Compliant grasps: spring–damper wrenches, then the arms and the object independently.
#[allow(clippy::too_many_arguments)]
fn compliant_derivative(
    p: &SpatialPlant,
    y: &[f64],
    o: &super::ObjectState,
    r_wo: &Matrix3<f64>,
    i_w_inv: &Matrix3<f64>,
    b_lin: Vector3<f64>,
    b_ang: Vector3<f64>,
    ws: &mut SpatialWorkspace,
    dy: &mut [f64],
) -> bool {
    let GraspModel::Compliant { stiffness, damping } = &p.grasp_model else {
        unreachable!("compliant_derivative on welds")
    };
    let n_q = p.n_q;
    let (_, _, qd) = p.split(y);
    let x_wo = o.pose();
    let mut f_lin_sum = Vector3::zeros();
    let mut f_ang_sum = Vector3::zeros();
    for i in 0..p.arms.len() {
        let n = p.arms[i].chain.dof();
        let s = p.offsets[i];
        let d = &ws.data[i];
        let x_wg = x_wo * p.grasps[i];
        let r_wg = x_wg.rotation;
        let p_t = d.X_WT.translation.vector;
        // Error in G axes.
        let e = {
            let dp = r_wg.inverse_transform_vector(&(p_t - x_wg.translation.vector));
            let dr = log_quat(&(r_wg.inverse() * d.X_WT.rotation));
            v6(&dp, &dr)
        };
        // Relative twist of the tool against the object point under it, in G axes.
        let mut vt = Vector6::zeros();
        for k in 0..n {
            vt += d.J.column(k) * qd[s + k];
        }
        let rp = p_t - o.p;
        let dv = vt.fixed_rows::<3>(0) - (o.v + o.w.cross(&rp));
        let dw = vt.fixed_rows::<3>(3) - o.w;
        let ed = v6(
            &r_wg.inverse_transform_vector(&dv),
            &r_wg.inverse_transform_vector(&dw),
        );
        let mut w_g = Vector6::zeros();
        for k in 0..6 {
            w_g[k] = -(stiffness[k] * e[k] + damping[k] * ed[k]);
        }
        let fl = r_wg.transform_vector(&w_g.fixed_rows::<3>(0).into_owned());
        let fa = r_wg.transform_vector(&w_g.fixed_rows::<3>(3).into_owned());
        ws.wrenches[i] = v6(&fl, &fa);
        f_lin_sum += fl;
        f_ang_sum += fa + rp.cross(&fl);
        // q̈ = q̈⁰ + M⁻¹ Jᵀ F.
        let jtf = &mut ws.tmp[..n];
        for k in 0..n {
            jtf[k] = d.J.column(k).dot(&ws.wrenches[i]);
        }
        cholesky_solve_in_place(&ws.chol[i], n, jtf);
        for k in 0..n {
            ws.qdd0[i][k] += jtf[k];
        }
    }
    let _ = r_wo;
    ws.a_o = v6(
        &((b_lin - f_lin_sum) / p.object.mass),
        &(i_w_inv * (b_ang - f_ang_sum)),
    );
    write_dy(p, y, o, ws, dy, n_q, true);
    true
}
