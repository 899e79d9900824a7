//! The model bound `f^U` of the robust term in six dimensions (SPEC §3.4, the paper's
//! Assumption 5 and (39); SPEC-spatial S5), computed once at set-up.
//!
//! # What is bounded
//! The controller works in the output chart ([`crate::control::spatial::chart`]): with
//! `x_1 = (p_WO − c, φ)`, `x_2 = ẋ_1 = E V`, the object-level dynamics of [`super::model`]
//! become `M_x ẍ_1 + h_x(x_1, x_2) + F_d,x = F_x`, `M_x = E⁻ᵀ 𝓜 E⁻¹`,
//! `h_x = E⁻ᵀ(𝓱 − 𝓜 E⁻¹ Ė V)`, `F_x = E⁻ᵀ F`. At a fixed pose, with the joint rates of the
//! arms the minimum-norm ones of the weld (`q̇_i = J_i⁺ G_i V`, no self-motion), every term of
//! `h_x` is a polynomial in `x_2` of degree ≤ 2:
//!
//! ```text
//! h_x(x_2) = 𝓖_x + D_x x_2 + Q_x(x_2),     Q_x(x_2)_j = x_2ᵀ H_j x_2   (H_j symmetric 6 × 6)
//! ```
//!
//! — `𝓖_x = E⁻ᵀ 𝓖` (gravity), `D_x` linear (the object's `C_o` and the arms' joint damping),
//! `Q_x` quadratic (arm Coriolis and centripetal terms through `J M⁻¹ b − J̇ q̇`, the transport's
//! `ω × (ω × r)`, the object's `ω × I ω`, and the chart's `Ė`). The paper's (39),
//! `F = 𝓖 + 𝓒 α + 𝓜 α̇ + F_d`, takes the velocity terms with the Coriolis matrix applied to `α`;
//! here `𝓒(x_2) α = H(x_2, α) + D_x α` with the **symmetric** bilinear form
//! `H(x, y)_j = xᵀ H_j y` (the unique symmetric `𝓒` with `𝓒(x_2) x_2 = Q_x(x_2) + D_x x_2`;
//! a Christoffel-consistent `𝓒` differs from it by a skew part, so a law that uses that one
//! should check its own bound). Then
//!
//! $$ |F_j| \le a_j + b_j \|x_2\|\|\alpha\| + c_j \|\dot\alpha\| + d_j \|\alpha\|,\quad
//! a_j = \max|𝓖_{x,j}| + \bar F_{d,j},\ b_j = \max\|H_j\|_2,\ c_j = \max\|(M_x)_{j,:}\|,\
//! d_j = \max\|(D_x)_{j,:}\|, $$
//!
//! maxima over the usable poses of the constraint box `|x_1j| ≤ k_cj`, every constant times
//! `safety` (default 1.5, SPEC §3.4).
//!
//! # How
//! * **Polarization** (exact for a quadratic): with `f(x) = h_x(x) − h_x(0)`,
//!   `Q(x) = (f(x) + f(−x))/2`, `D_x x = (f(x) − f(−x))/2`; `H_kk = Q(e_k)`,
//!   `H_kl = (Q(e_k + e_l) − Q(e_k) − Q(e_l))/2` with `Q(e_k + e_l) = f(e_k + e_l) −
//!   D_x (e_k + e_l)`: 28 model evaluations per pose (`x = 0`, `±e_k`, `e_k + e_l` for
//!   `k < l`) at unit rates (1 m/s, 1 rad/s).
//! * **Poses:** the 3-level grid `{−k_cj, 0, k_cj}⁶` (729 poses including the centre: every
//!   vertex of the box, where lever arms and rotations are largest, every face and edge
//!   centre) plus 271 interior points of a Halton sequence (bases 2, 3, 5, 7, 11, 13),
//!   1000 in all. The terms are smooth low-order trigonometric functions of the pose over a
//!   box a few centimetres and a few tenths of a radian wide, so the grid's maxima are close
//!   to the true ones and `safety` covers the rest; `tests/spatial_control_model.rs` checks
//!   the bound at random interior poses and rates.
//! * **Closed-chain IK** per pose ([`closed_chain_ik`]): damped Newton per arm on the weld,
//!   started from the previous pose's solution (continuation; the seed is the solution at
//!   `x_wo0` from `q_guess`), with a null-space pull toward `q_guess` for redundant arms (so
//!   the redundancy resolution is the one of the nominal configuration, independent of the
//!   visiting order). A pose is skipped when an arm does not reach (residual > 1e-10 m or
//!   rad), leaves its joint limits, or has `σ_min(J_i) <` [`SIGMA_MIN`].
//!
//! # Measured (release, the shared 2-core VM at load 4–10, so upper values)
//! With the chart about the SPEC-spatial path centre and `k_c = (0.17, 0.17, 0.05 m; 0.15,
//! 0.3, 0.15 rad)` (`tests/spatial_control_model.rs`, `fu_bound_bounds_the_model`):
//!
//! | set-up | poses usable | time | max `|F_j|/f_jᵁ` at 400 random poses and rates |
//! |---|---|---|---|
//! | dual UR5 | 1000 of 1000 | 190–280 ms | 0.49 (0.73 with safety 1) |
//! | dual Franka | 865 of 1000 | 220–550 ms | 0.37 (0.56 with safety 1) |
//!
//! About 90 % of the time is the 28 model evaluations per pose (≈ 8–15 µs each for two arms),
//! the rest the IK continuation (≈ 20 µs per pose for the UR5s, 70 µs for the Frankas).
//!
//! # References
//! 1. The paper's Assumption 5 and (39); SPEC §3.4 ("constants computed at set-up from the
//!    nominal model over the reachable, well-conditioned part of the constraint box").
#![allow(non_snake_case)]

use nalgebra::{DVector, Isometry3, Matrix6, MatrixXx6, Vector3, Vector6};

use super::model::{ModelWorkspace, ObjectModel, jjt_sigma_min};
use crate::control::law::adaptive::FuBound;
use crate::control::spatial::chart::Chart;
use crate::dynamics::spatial;
use crate::error::{ModelError, non_negative, positive};
use crate::geometry::motion::{ang, lin, stack};
use crate::geometry::so3::log_quat;

/// Smallest `σ_min(J_i)` (m/rad mixed units) of a pose used for the bound (as the planar
/// [`FuBound::from_model`]).
pub const SIGMA_MIN: f64 = 0.05;

/// Interior Halton points added to the 3⁶ grid.
pub const HALTON_POINTS: usize = 271;

/// Weld residual accepted by [`closed_chain_ik`], m and rad.
pub const IK_TOL: f64 = 1e-10;

/// `f^U` constants over the usable part of the box `|x_1j| ≤ k_cj` about `chart` (module doc),
/// as the planar [`FuBound`] (6 entries each; `poses` = poses used).
///
/// `k_c` (m ×3, rad ×3; > 0, rotations < π), `disturbance` (bounds of `|F_d,x,j|`, ≥ 0),
/// `safety` (> 0), `x_wo0` with `q_guess` (stacked, n_q) a nominal configuration near which
/// the arms' IK branch is taken. Errors name `k_c[j]`, `disturbance[j]`, `safety`, `q_guess`,
/// or `k_c` when no pose of the box is usable.
pub fn fu_bound(
    model: &ObjectModel,
    chart: &Chart,
    k_c: &Vector6<f64>,
    disturbance: &[f64; 6],
    safety: f64,
    x_wo0: &Isometry3<f64>,
    q_guess: &[f64],
) -> Result<FuBound, ModelError> {
    for j in 0..6 {
        positive(&format!("k_c[{j}]"), k_c[j])?;
        if j >= 3 && k_c[j] >= std::f64::consts::PI {
            return Err(ModelError::invalid(
                format!("k_c[{j}]"),
                k_c[j],
                "a rotation bound must be < π (the chart covers |φ| < π)",
            ));
        }
        non_negative(&format!("disturbance[{j}]"), disturbance[j])?;
    }
    positive("safety", safety)?;
    if q_guess.len() != model.n_q() {
        return Err(ModelError::geometry(
            "q_guess",
            format!(
                "has {} entries, the arms have {} joints",
                q_guess.len(),
                model.n_q()
            ),
        ));
    }
    let mut ws = model.workspace();
    // Seed: the IK at the nominal pose from the guess.
    let mut q0 = q_guess.to_vec();
    if !closed_chain_ik(model, x_wo0, &mut q0, q_guess, &mut ws) {
        q0.copy_from_slice(q_guess);
    }
    let mut fu = FuBound {
        a: vec![0.0; 6],
        b: vec![0.0; 6],
        c: vec![0.0; 6],
        d: vec![0.0; 6],
        poses: 0,
    };
    let mut q = q0.clone();
    let mut ev = PoseEval::new(model);
    for x1 in sample_box(k_c) {
        let x_wo = chart.pose(&x1);
        let mut ok = closed_chain_ik(model, &x_wo, &mut q, q_guess, &mut ws);
        if !ok {
            q.copy_from_slice(&q0);
            ok = closed_chain_ik(model, &x_wo, &mut q, q_guess, &mut ws);
        }
        if !ok || !usable(model, &mut q, q_guess, &mut ws) {
            q.copy_from_slice(&q0);
            continue;
        }
        let Some(t) = pose_terms(model, chart, &q, &x_wo, &mut ev, &mut ws) else {
            continue;
        };
        fu.poses += 1;
        for j in 0..6 {
            fu.a[j] = fu.a[j].max(t.g_x[j].abs());
            fu.c[j] = fu.c[j].max(t.m_x.row(j).norm());
            fu.d[j] = fu.d[j].max(t.d_x.row(j).norm());
            let ev = t.h[j].symmetric_eigenvalues();
            fu.b[j] = fu.b[j].max(ev.amax());
        }
    }
    if fu.poses == 0 {
        return Err(ModelError::geometry(
            "k_c",
            "no pose in the constraint box is reachable by every arm within its joint limits with a well-conditioned Jacobian",
        ));
    }
    for j in 0..6 {
        fu.a[j] = safety * (fu.a[j] + disturbance[j]);
        fu.b[j] *= safety;
        fu.c[j] *= safety;
        fu.d[j] *= safety;
    }
    Ok(fu)
}

/// The poses of the box in chart coordinates: the 3⁶ grid (lexicographic, so successive poses
/// are neighbours for the continuation) then [`HALTON_POINTS`] Halton points.
pub fn sample_box(k_c: &Vector6<f64>) -> Vec<Vector6<f64>> {
    let mut out = Vec::with_capacity(729 + HALTON_POINTS);
    for idx in 0..729usize {
        let mut x = Vector6::zeros();
        let mut t = idx;
        for j in (0..6).rev() {
            x[j] = k_c[j] * ((t % 3) as f64 - 1.0);
            t /= 3;
        }
        out.push(x);
    }
    const BASES: [u64; 6] = [2, 3, 5, 7, 11, 13];
    for i in 1..=HALTON_POINTS as u64 {
        let mut x = Vector6::zeros();
        for j in 0..6 {
            x[j] = k_c[j] * (2.0 * radical_inverse(i, BASES[j]) - 1.0);
        }
        out.push(x);
    }
    out
}

/// Van der Corput radical inverse of `i` in `base`, in `[0, 1)`.
fn radical_inverse(mut i: u64, base: u64) -> f64 {
    let (mut r, mut f) = (0.0, 1.0 / base as f64);
    while i > 0 {
        r += f * (i % base) as f64;
        i /= base;
        f /= base as f64;
    }
    r
}

/// Every arm within its joint limits and `σ_min(J_i) ≥` [`SIGMA_MIN`] at `q` (stacked); runs
/// the kinematics into `ws.data`. A revolute angle a whole turn outside its range is first
/// wrapped into it ([`ChainJoint::wrap_into_limits`](crate::model::spatial::chain::ChainJoint::wrap_into_limits),
/// nearest to `q_near`): the same pose.
pub fn usable(model: &ObjectModel, q: &mut [f64], q_near: &[f64], ws: &mut ModelWorkspace) -> bool {
    for (i, arm) in model.arms().iter().enumerate() {
        let (s, n) = (model.offset(i), arm.chain.dof());
        for (k, j) in arm.chain.joints.iter().enumerate() {
            match j.wrap_into_limits(q[s + k], q_near[s + k]) {
                Some(v) => q[s + k] = v,
                None => return false,
            }
        }
        spatial::kinematics(arm, &q[s..s + n], None, &mut ws.data[i]);
        if !(jjt_sigma_min(&ws.data[i]) >= SIGMA_MIN) {
            return false;
        }
    }
    true
}

/// Closed-chain inverse kinematics: every arm's tool frame onto its grasp frame
/// `X_WO X_OGi`, from `q` (stacked, n_q) in place, by damped least squares with a null-space
/// pull toward `q_pull` for redundant arms (`Δq = J⁺_λ e + (I − J⁺J) ½(q_pull − q)`, step at
/// most 0.5 rad). `true` when every weld residual is ≤ [`IK_TOL`] (m and rad). Set-up only
/// (allocates small temporaries).
pub fn closed_chain_ik(
    model: &ObjectModel,
    x_wo: &Isometry3<f64>,
    q: &mut [f64],
    q_pull: &[f64],
    ws: &mut ModelWorkspace,
) -> bool {
    for (i, arm) in model.arms().iter().enumerate() {
        let (s, n) = (model.offset(i), arm.chain.dof());
        let x_wg = x_wo * model.grasps()[i];
        let d = &mut ws.data[i];
        let qi = &mut q[s..s + n];
        let mut converged = false;
        for it in 0..100 {
            spatial::kinematics(arm, qi, None, d);
            let dp = x_wg.translation.vector - d.X_WT.translation.vector;
            let dr = log_quat(&(x_wg.rotation * d.X_WT.rotation.inverse()));
            let (el, ea) = (dp.norm(), dr.norm());
            if !(el.is_finite() && ea.is_finite()) {
                return false;
            }
            let e = stack(&dp, &dr);
            let j = &d.J;
            let jjt: Matrix6<f64> = Matrix6::from_fn(|a, b| j.row(a).dot(&j.row(b)));
            let task_done = el <= 0.1 * IK_TOL && ea <= 0.1 * IK_TOL;
            // Null-space pull (redundant arms only).
            let mut dq = DVector::zeros(n);
            if n > 6 {
                let Some(ch) = jjt.cholesky() else {
                    return false;
                };
                let pull = DVector::from_fn(n, |k, _| 0.5 * (q_pull[s + k] - qi[k]));
                let jp = j * &pull;
                let proj =
                    &pull - j.transpose() * ch.solve(&Vector6::from_column_slice(jp.as_slice()));
                dq += proj;
            }
            if task_done && (n <= 6 || dq.norm() < 1e-9) {
                converged = true;
                break;
            }
            let lambda2 = if it < 50 {
                (1e-2 * (el + ea)).min(1e-2)
            } else {
                0.0
            };
            let mut a = jjt;
            for k in 0..6 {
                a[(k, k)] += lambda2;
            }
            let Some(ch) = a.cholesky() else {
                return false;
            };
            dq += j.transpose() * ch.solve(&e);
            let sn = dq.norm();
            if sn > 0.5 {
                dq *= 0.5 / sn;
            }
            for k in 0..n {
                qi[k] += dq[k];
            }
        }
        if !converged {
            // Accept a converged task with an unfinished null-space pull.
            spatial::kinematics(arm, qi, None, d);
            let dp = x_wg.translation.vector - d.X_WT.translation.vector;
            let dr = log_quat(&(x_wg.rotation * d.X_WT.rotation.inverse()));
            if !(dp.norm() <= IK_TOL && dr.norm() <= IK_TOL) {
                return false;
            }
        }
    }
    true
}

/// Scratch for the per-pose evaluations: minimum-norm weld rates `q̇_i = J_i⁺ G_i V`.
struct PoseEval {
    jpinv: Vec<MatrixXx6<f64>>,
    qd: Vec<f64>,
}

impl PoseEval {
    fn new(model: &ObjectModel) -> Self {
        PoseEval {
            jpinv: model
                .arms()
                .iter()
                .map(|a| MatrixXx6::zeros(a.chain.dof()))
                .collect(),
            qd: vec![0.0; model.n_q()],
        }
    }

    /// `J_i⁺ = J_iᵀ (J_i J_iᵀ)⁻¹` at `q` (kinematics into `ws.data`). `false` if singular.
    fn prepare(&mut self, model: &ObjectModel, q: &[f64], ws: &mut ModelWorkspace) -> bool {
        for (i, arm) in model.arms().iter().enumerate() {
            let (s, n) = (model.offset(i), arm.chain.dof());
            spatial::kinematics(arm, &q[s..s + n], None, &mut ws.data[i]);
            let j = &ws.data[i].J;
            let jjt: Matrix6<f64> = Matrix6::from_fn(|a, b| j.row(a).dot(&j.row(b)));
            let Some(inv) = jjt.try_inverse() else {
                return false;
            };
            self.jpinv[i] = j.transpose() * inv;
        }
        true
    }

    /// Chart-space `(M_x, h_x)` at `q` (after [`Self::prepare`]), pose `x_wo` and chart rate
    /// `x2`.
    fn eval(
        &mut self,
        model: &ObjectModel,
        chart: &Chart,
        q: &[f64],
        x_wo: &Isometry3<f64>,
        x2: &Vector6<f64>,
        ws: &mut ModelWorkspace,
    ) -> Option<(Matrix6<f64>, Vector6<f64>)> {
        let phi = chart.phi(&x_wo.rotation);
        let jac = chart.jacobian(&phi, &ang(x2));
        let twist = jac.twist_from_chart(x2);
        let (v, w) = (lin(&twist), ang(&twist));
        for (i, arm) in model.arms().iter().enumerate() {
            let (s, n) = (model.offset(i), arm.chain.dof());
            let r: Vector3<f64> = x_wo.rotation * model.grasps()[i].translation.vector;
            let vt = stack(&(v + w.cross(&r)), &w);
            let qd = &self.jpinv[i] * vt;
            self.qd[s..s + n].copy_from_slice(qd.as_slice());
        }
        // g(q) and σ_min are not needed here (h includes gravity through the arms' bias).
        let od = model.dynamics_with(q, &self.qd, x_wo, &twist, ws, false)?;
        Some(jac.dynamics(&od.m, &od.h, &twist))
    }
}

/// The chart-space terms of one pose (module doc).
struct PoseTerms {
    g_x: Vector6<f64>,
    m_x: Matrix6<f64>,
    d_x: Matrix6<f64>,
    h: [Matrix6<f64>; 6],
}

fn pose_terms(
    model: &ObjectModel,
    chart: &Chart,
    q: &[f64],
    x_wo: &Isometry3<f64>,
    ev: &mut PoseEval,
    ws: &mut ModelWorkspace,
) -> Option<PoseTerms> {
    if !ev.prepare(model, q, ws) {
        return None;
    }
    let (m_x, h0) = ev.eval(model, chart, q, x_wo, &Vector6::zeros(), ws)?;
    let e = |k: usize| {
        let mut v = Vector6::zeros();
        v[k] = 1.0;
        v
    };
    // f(±e_k) → Q(e_k) = (f(e_k) + f(−e_k))/2 and D e_k = (f(e_k) − f(−e_k))/2; then
    // Q(e_k + e_l) = f(e_k + e_l) − D (e_k + e_l): 1 + 12 + 15 = 28 evaluations.
    let f = |x: &Vector6<f64>, ev: &mut PoseEval, ws: &mut ModelWorkspace| {
        ev.eval(model, chart, q, x_wo, x, ws).map(|t| t.1 - h0)
    };
    let mut qk = [Vector6::zeros(); 6];
    let mut d_x = Matrix6::zeros();
    for k in 0..6 {
        let fp = f(&e(k), ev, ws)?;
        let fm = f(&(-e(k)), ev, ws)?;
        qk[k] = (fp + fm) * 0.5;
        d_x.set_column(k, &((fp - fm) * 0.5));
    }
    let mut h = [Matrix6::zeros(); 6];
    for k in 0..6 {
        for j in 0..6 {
            h[j][(k, k)] = qk[k][j];
        }
        for l in k + 1..6 {
            let ekl = e(k) + e(l);
            let qkl = f(&ekl, ev, ws)? - d_x * ekl;
            for j in 0..6 {
                let v = 0.5 * (qkl[j] - qk[k][j] - qk[l][j]);
                h[j][(k, l)] = v;
                h[j][(l, k)] = v;
            }
        }
    }
    Some(PoseTerms {
        g_x: h0,
        m_x,
        d_x,
        h,
    })
}

/// Chart-space `(M_x, h_x)` of the model at the closed-chain configuration `q` (stacked, n_q;
/// the arms' welds must hold at `x_wo`) moving with chart rate `x2 = ẋ_1` and the minimum-norm
/// joint rates of the weld (no self-motion), as [`fu_bound`] evaluates it: `M_x ẍ_1 + h_x =
/// F_x`. For checks and studies; allocates.
pub fn chart_dynamics(
    model: &ObjectModel,
    chart: &Chart,
    q: &[f64],
    x_wo: &Isometry3<f64>,
    x2: &Vector6<f64>,
    ws: &mut ModelWorkspace,
) -> Option<(Matrix6<f64>, Vector6<f64>)> {
    let mut ev = PoseEval::new(model);
    if !ev.prepare(model, q, ws) {
        return None;
    }
    ev.eval(model, chart, q, x_wo, x2, ws)
}
