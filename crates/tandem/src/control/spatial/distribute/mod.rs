//! Wrench distribution and joint torques (SPEC-spatial S5 "Distribution"; the planar SPEC §3.2
//! object scheme `τ_x = (Jᵀ)⁺ τ + N λ`, `τ_joint,i = J_e,iᵀ τ_x,i`).
//!
//! `F` (world axes, about the object's centre of mass) → `w_i` (what arm `i` applies to the
//! object at its tool origin, world axes) with
//!
//! $$ \sum_i G_i^\top w_i = F \quad\text{exactly},\qquad
//! w = G^{+}_W F + P_N\, s, $$
//!
//! `G = [G_1ᵀ … G_mᵀ]` (6 × 6m, `G_iᵀ w = [f; τ + r_i × f]`, `r_i = p_WTi − p_WO`), then
//! `τ_i = J_iᵀ w_i (+ N_iᵀ τ0_i)` ([`joint_torques`]).
//!
//! # The metric (why weighted)
//! A minimum-norm share needs a norm on `ℝ^{6m}`, and `|f|² + |τ|²` adds N² to N² m²: its
//! answer changes with the unit of length (mm instead of m reweights torques by 10⁶). tandem
//! minimises the commensurate norm
//!
//! $$ \|w\|_W^2 = \sum_i |f_i|^2 + |\tau_i|^2 / L^2,\qquad W = \mathrm{blkdiag}(I, I/L^2), $$
//!
//! with a characteristic length `L` (m) of the grasp geometry (e.g. half the grasp spacing,
//! 0.2 m for the SPEC-spatial box): a torque `τ` counts like the force couple `τ/L` that would
//! make it over that lever. The solution is unit-independent, and `L` says what to prefer:
//! a large `L` makes torques cheap (each arm takes its share of the object torque at its own
//! wrist), a small `L` makes them expensive (the torque is carried as a couple of opposite
//! forces between the grasps). `L = 1 m` gives the plain norm.
//!
//! Weighted pseudo-inverse (`G` has full row rank 6 for any grasps, since each `G_iᵀ` is
//! unit triangular, so `A` below is SPD):
//!
//! ```text
//! A = G W⁻¹ Gᵀ = Σ_i G_iᵀ W⁻¹ G_i,      G⁺_W = W⁻¹ Gᵀ A⁻¹,      w_i = W⁻¹ G_i A⁻¹ F,
//! P_N = I − G⁺_W G   (the W-orthogonal projector onto the internal wrenches, null(G)).
//! ```
//!
//! Min-norm: `G⁺_W F` is W-orthogonal to every `n ∈ null(G)` (`⟨W⁻¹GᵀA⁻¹F, n⟩_W = (A⁻¹F)ᵀ G n
//! = 0`), so `‖G⁺_W F + n‖_W² = ‖G⁺_W F‖_W² + ‖n‖_W²`.
//!
//! # The squeeze (internal wrench)
//! Each grasp pushes on the object toward the grasps' centroid `r̄ = Σ r_i / m` with force
//! `squeeze` (N; > 0 pushes inward, < 0 pulls): `s_i = [squeeze (r̄ − r_i)/|r̄ − r_i|; 0]`, then
//! `P_N s` so that its net wrench is exactly zero. For two grasps `r̄ − r_1 ∥ r_2 − r_1`: the
//! pushes are equal and opposite along the grasp-to-grasp line, already internal
//! (`Σ G_iᵀ s_i = [0; s (r_1 − r_2) × u] = 0`), and the projection leaves them unchanged (to
//! round-off). A grasp at the centroid (closer than 1e-9 m) does not push.
//!
//! `internal_part(w) = P_N w = w − G⁺_W G w` (for the record, and for the feed-forward of the
//! internal part of the arms' own gravity, as the planar controller does with `P_N Ĝ_x`).
//!
//! # Joint torques and the posture task
//! `τ_i = J_iᵀ w_i`; an arm with more than six joints adds a null-space posture task with
//! damping, projected by the dynamically consistent `N_iᵀ = I − J_iᵀ Λ_i J_i M_i⁻¹`
//! ([`super::model`]: `J_i M_i⁻¹ N_iᵀ = 0`, so it does not reach the tool and the object-level
//! model stays exact):
//!
//! ```text
//! τ0_i = K_p (q_rest − q_i) − K_d q̇_i + g_i(q_i),
//! ```
//!
//! the gravity term being the null-space part `N_iᵀ g_i` of the arm's gravity, which the
//! object-level `𝓖` (that holds only `J_iᵀ g_x,i`) does not carry. Gains: see
//! [`PostureTask::franka`].
#![allow(non_snake_case)]

pub mod friction;

use nalgebra::{Vector3, Vector6};

use super::model::{ModelWorkspace, ObjectModel, RHS};
use crate::error::{ModelError, positive};
use crate::geometry::motion::{ang, lin, stack};
use crate::math::linalg::{Cholesky6, forward_rows};

/// The distribution of an object wrench over `m` grasps (constant metric, no scratch that
/// grows).
#[derive(Clone, Debug)]
pub struct Distribution {
    m: usize,
    /// `L`, m.
    metric_length: f64,
    /// `L²`.
    l2: f64,
    /// The lever arms of the last factorisation and its factor: a tick distributes several
    /// wrenches over the same grasps, and `A` depends on `r` only.
    last_r: Vec<Vector3<f64>>,
    last: Cholesky6,
    /// `last` holds the factor of `A(last_r)`.
    last_ok: bool,
    /// `last_r` and `last` are set (the first call factors).
    primed: bool,
}

impl Distribution {
    /// `m ≥ 1` grasps, characteristic length `metric_length` (m, > 0; module doc). Errors name
    /// `m` or `metric_length`.
    pub fn new(m: usize, metric_length: f64) -> Result<Self, ModelError> {
        if m == 0 {
            return Err(ModelError::geometry("m", "at least one grasp is needed"));
        }
        positive("metric_length", metric_length)?;
        Ok(Distribution {
            m,
            metric_length,
            l2: metric_length * metric_length,
            last_r: vec![Vector3::zeros(); m],
            last: Cholesky6::new(&std::array::from_fn(|i| {
                std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 })
            }))
            .expect("the identity is SPD"),
            last_ok: false,
            primed: false,
        })
    }

    /// Number of grasps.
    pub fn m(&self) -> usize {
        self.m
    }

    /// `L`, m.
    pub fn metric_length(&self) -> f64 {
        self.metric_length
    }

    /// `W⁻¹ G_i λ = [λ_f − r_i × λ_τ; L² λ_τ]` (`G_i = [[I, −[r_i]×], [0, I]]`).
    #[inline]
    fn share(&self, r: &Vector3<f64>, lam: &Vector6<f64>) -> Vector6<f64> {
        let (lf, lt) = (lin(lam), ang(lam));
        stack(&(lf - r.cross(&lt)), &(lt * self.l2))
    }

    /// `A = Σ G_iᵀ W⁻¹ G_i` factored, or `None` if non-finite; reused while `r` is bitwise the
    /// same as at the last call.
    fn factor(&mut self, r: &[Vector3<f64>]) -> Option<&Cholesky6> {
        if !(self.primed && r[..self.m] == self.last_r[..]) {
            self.last_ok = self.factor_new(r);
            self.last_r.copy_from_slice(&r[..self.m]);
            self.primed = true;
        }
        self.last_ok.then_some(&self.last)
    }

    /// `A` in closed form: with `G_iᵀ = [[I, 0], [[r_i]×, I]]`,
    /// `G_iᵀ W⁻¹ G_i = [[I, −[r_i]×], [[r_i]×, L² I − [r_i]×²]]` and `−[r]×² = |r|² I − r rᵀ`, so
    /// `A = [[m I, −[Σr]×], [[Σr]×, m L² I + Σ(|r_i|² I − r_i r_iᵀ)]]`.
    /// Only the lower triangle is assembled (the factorisation reads no more), on fixed arrays;
    /// factored into `self.last`, `false` if `A` is not finite or not positive definite.
    fn factor_new(&mut self, r: &[Vector3<f64>]) -> bool {
        let m = self.m as f64;
        let mut sum = Vector3::zeros();
        let mut lower = nalgebra::Matrix3::from_diagonal_element(m * self.l2);
        for ri in &r[..self.m] {
            sum += ri;
            lower +=
                nalgebra::Matrix3::from_diagonal_element(ri.norm_squared()) - ri * ri.transpose();
        }
        // Lower triangle of A: [[m I, ·], [[Σr]×, lower]].
        let c = crate::geometry::so3::hat(&sum);
        let mut a = [[0.0; 6]; 6];
        for i in 0..3 {
            a[i][i] = m;
            for j in 0..3 {
                a[3 + i][j] = c[(i, j)];
                a[3 + i][3 + j] = lower[(i, j)];
            }
        }
        if !crate::math::linalg::finite_slice(a.as_flattened()) {
            return false;
        }
        self.last.refactor(&a)
    }

    /// `w = G⁺_W F + P_N s(squeeze)` (module doc): `r[i] = p_WTi − p_WO` (m entries, world
    /// axes, m), `f` the object wrench about the centre of mass (N, N m), `squeeze` N (> 0
    /// pushes inward). Writes `w` (m entries, the wrench each arm applies to the object at its
    /// tool origin). Returns `false` (and writes zeros) if the grasp map is degenerate (a
    /// non-finite input). `r` and `w` need at least `m` entries (shorter slices panic: a
    /// programming error). No allocation.
    pub fn distribute(
        &mut self,
        r: &[Vector3<f64>],
        f: &Vector6<f64>,
        squeeze: f64,
        w: &mut [Vector6<f64>],
    ) -> bool {
        let m = self.m;
        if self.factor(r).is_none() {
            w[..m].fill(Vector6::zeros());
            return false;
        }
        // Squeeze pushes toward the centroid, and their net wrench.
        let mut c = Vector3::zeros();
        for ri in &r[..m] {
            c += ri;
        }
        c /= m as f64;
        let mut net_s = Vector6::zeros();
        for i in 0..m {
            let d = c - r[i];
            let dn = d.norm();
            let s = if squeeze != 0.0 && dn > 1e-9 {
                stack(&(d * (squeeze / dn)), &Vector3::zeros())
            } else {
                Vector6::zeros()
            };
            w[i] = s;
            net_s += stack(&lin(&s), &(ang(&s) + r[i].cross(&lin(&s))));
        }
        // w_i = s_i + W⁻¹ G_i A⁻¹ (F − G s): min-norm share plus the projected squeeze.
        let ch = &self.last;
        let lam = Vector6::from(ch.solve(&(f - net_s).into()));
        for i in 0..m {
            w[i] += self.share(&r[i], &lam);
        }
        w[..m].iter().all(|x| x.iter().all(|v| v.is_finite()))
    }

    /// `out = P_N w = w − G⁺_W G w`: the internal part of the grasp wrenches `w` (m entries,
    /// at the tool origins, world axes). `false` (and zeros) if the grasp map is degenerate.
    /// No allocation.
    pub fn internal_part(
        &mut self,
        r: &[Vector3<f64>],
        w: &[Vector6<f64>],
        out: &mut [Vector6<f64>],
    ) -> bool {
        let m = self.m;
        if self.factor(r).is_none() {
            out[..m].fill(Vector6::zeros());
            return false;
        }
        let ch = &self.last;
        let lam = Vector6::from(ch.solve(&Self::net(&r[..m], &w[..m]).into()));
        for i in 0..m {
            out[i] = w[i] - self.share(&r[i], &lam);
        }
        true
    }

    /// `Σ G_iᵀ w_i = Σ [f_i; τ_i + r_i × f_i]` (about the centre of mass, world axes).
    pub fn net(r: &[Vector3<f64>], w: &[Vector6<f64>]) -> Vector6<f64> {
        let mut s = Vector6::zeros();
        for (ri, wi) in r.iter().zip(w) {
            let f = lin(wi);
            s += stack(&f, &(ang(wi) + ri.cross(&f)));
        }
        s
    }

    /// The metric norm `‖w‖_W² = Σ |f_i|² + |τ_i|²/L²`.
    pub fn metric_norm2(&self, w: &[Vector6<f64>]) -> f64 {
        w.iter()
            .map(|x| lin(x).norm_squared() + ang(x).norm_squared() / self.l2)
            .sum()
    }
}

/// A joint-space posture task for a redundant arm's self-motion (module doc), applied through
/// the dynamically consistent null-space projector.
#[derive(Clone, Debug, PartialEq)]
pub struct PostureTask {
    /// `K_p`, N m/rad (> 0).
    pub kp: f64,
    /// `K_d`, N m s/rad (> 0).
    pub kd: f64,
    /// `q_rest` of this arm (n_i), rad.
    pub q_rest: Vec<f64>,
}

impl PostureTask {
    /// Validated task; errors name `posture.kp`, `posture.kd` or `posture.q_rest[k]`.
    pub fn new(kp: f64, kd: f64, q_rest: Vec<f64>) -> Result<Self, ModelError> {
        positive("posture.kp", kp)?;
        positive("posture.kd", kd)?;
        if let Some(k) = q_rest.iter().position(|v| !v.is_finite()) {
            return Err(ModelError::invalid(
                format!("posture.q_rest[{k}]"),
                q_rest[k],
                "must be finite",
            ));
        }
        Ok(PostureTask { kp, kd, q_rest })
    }

    /// Check the task against arm `arm` of `model`: `q_rest` has one entry per joint and lies
    /// within the joint limits. Errors name `posture.q_rest` or `posture.q_rest[k]`.
    pub fn check(&self, model: &ObjectModel, arm: usize) -> Result<(), ModelError> {
        let a = model.arms().get(arm).ok_or_else(|| {
            ModelError::geometry("arm", format!("no arm {arm} ({} arms)", model.arms().len()))
        })?;
        let n = a.chain.dof();
        if self.q_rest.len() != n {
            return Err(ModelError::geometry(
                "posture.q_rest",
                format!(
                    "has {} entries, arm {arm} has {n} joints",
                    self.q_rest.len()
                ),
            ));
        }
        for (k, j) in a.chain.joints.iter().enumerate() {
            let v = self.q_rest[k];
            if !(v >= j.limits.lower && v <= j.limits.upper) {
                return Err(ModelError::invalid(
                    format!("posture.q_rest[{k}]"),
                    v,
                    format!(
                        "outside joint {}'s limits [{:.4}, {:.4}]",
                        j.name, j.limits.lower, j.limits.upper
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Defaults for a Franka-class 7-DOF arm holding the SPEC-spatial box: `K_p = 1 N m/rad`,
    /// `K_d = 0.4 N m s/rad`. The self-motion's effective inertia is
    /// `I_ns = (nᵀ M⁻¹ n)⁻¹ = 0.027–0.035 kg m²` near the dual-Franka grasp (`n` the unit null
    /// vector of `J`, mostly the forearm and wrist; measured by
    /// `null_space_torques_do_not_move_the_tool` in `tests/spatial_control_model.rs`), so
    /// `ω_n = √(K_p/I_ns) = 5.3–6.1 rad/s` (a posture time constant `1/ω_n ≈ 0.17 s`, slower
    /// than the object loop's `1/K_1 = 0.125 s`, though the two are decoupled anyway by the
    /// dynamically consistent projector) and `ζ = K_d/(2√(K_p I_ns)) = 1.07–1.22` (no
    /// overshoot of the self-motion; a stiffer `K_p` would only hold the elbow harder against
    /// the uncompensated null-space Coriolis torques, which are small at these speeds).
    pub fn franka(q_rest: Vec<f64>) -> Self {
        PostureTask {
            kp: 1.0,
            kd: 0.4,
            q_rest,
        }
    }
}

/// Joint torques of arm `arm`: `τ_i = J_iᵀ w_i`, plus `N_iᵀ τ0_i` (module doc) if the arm has
/// more than six joints and `posture` is `Some`. `w` is what the arm applies to the object at
/// its tool origin (world axes); `q`, `qd` and `tau` are **stacked** over all arms (n_q), and
/// only arm `arm`'s entries of `tau` are written. Needs `ws` from [`ObjectModel::dynamics`] at
/// the same `q, q̇` (`J`, the factor of `M`, `Λ`, `g`). The posture task should pass
/// [`PostureTask::check`] for this arm (a shorter `q_rest` panics). No allocation.
#[allow(clippy::too_many_arguments)]
pub fn joint_torques(
    model: &ObjectModel,
    ws: &mut ModelWorkspace,
    arm: usize,
    w: &Vector6<f64>,
    q: &[f64],
    qd: &[f64],
    posture: Option<&PostureTask>,
    tau: &mut [f64],
) {
    let n = model.arms()[arm].chain.dof();
    let s = model.offset(arm);
    let d = &ws.data[arm];
    let jt = &d.J.as_slice()[..6 * n];
    let out = &mut tau[s..s + n];
    for k in 0..n {
        let col = &jt[6 * k..6 * k + 6];
        let mut acc = 0.0;
        for a in 0..6 {
            acc += col[a] * w[a];
        }
        out[k] = acc;
    }
    let Some(p) = posture else { return };
    if n <= 6 {
        return;
    }
    // τ0 = K_p (q_rest − q) − K_d q̇ + g(q).
    let tmp = &mut ws.tmp[arm][..n];
    let grav = &ws.grav[arm][..n];
    for k in 0..n {
        tmp[k] = p.kp * (p.q_rest[k] - q[s + k]) - p.kd * qd[s + k] + grav[k];
    }
    // Nᵀ τ0 = τ0 − Jᵀ Λ (J M⁻¹ τ0), J M⁻¹ τ0 = Zᵀ L⁻¹ τ0 with Z = L⁻¹ Jᵀ.
    for k in 0..n {
        out[k] += tmp[k];
    }
    forward_rows(&ws.chol[arm], n, tmp, 1);
    let x = &ws.x[arm][..n * RHS];
    let mut y = Vector6::zeros();
    for k in 0..n {
        let row = &x[k * RHS..k * RHS + RHS];
        for a in 0..6 {
            y[a] += row[2 + a] * tmp[k];
        }
    }
    let z = ws.arms[arm].lambda * y;
    for k in 0..n {
        let col = &jt[6 * k..6 * k + 6];
        let mut acc = 0.0;
        for a in 0..6 {
            acc += col[a] * z[a];
        }
        out[k] -= acc;
    }
}
