//! The object-level model of the closed chain at the **measured** joint configuration: the
//! paper's (14) for `m` spatial arms with welded grasps (SPEC-spatial S5: "the controller's
//! nominal `𝓜, 𝓒, 𝓖` … are computed at the measured joint configuration, no inverse kinematics
//! needed").
//!
//! $$ \mathcal M \dot V + \mathcal h + F_d = \sum_i G_i^\top w_i,\qquad
//! \mathcal M = M_o(R_{WO}) + \sum_i G_i^\top \Lambda_i G_i,\qquad
//! \mathcal h = h_o(V) + \sum_i G_i^\top \Lambda_i\big(J_i M_i^{-1} b_i - \dot J_i \dot q_i
//!   + \dot G_i V\big). $$
//!
//! # Conventions (SPEC-spatial S1)
//! Twists `[v; ω]`, wrenches `[f; τ]`, world axes. `V = [v_WO; ω_WO]` is the object twist at its
//! centre of mass. `r_i = p_WTi − p_WO` (world axes, m), from the arms' forward kinematics at the
//! encoders and the (estimated) object position. `G_i = [[I, −[r_i]×], [0, I]]` is the rigid
//! transport of the object twist to tool origin `i` (`V_Ti = G_i V`), so
//! `G_iᵀ w = [f; τ + r_i × f]` moves a wrench at the tool origin to the centre of mass.
//! `w_i` is the wrench arm `i` **applies to the object** at its tool origin; the grasp wrench
//! of the plant (the object on the tool) is `F_i`. `F_d` is the environment disturbance with
//! the plant's sign ([`crate::plant::spatial::SpatialInput::f_d`], subtracted on the object;
//! it sits with `𝓖` in the paper's (39)).
//!
//! # Derivation
//! Arm `i` (SPEC-spatial S3–S4, with the plant's joint damping `D_i`):
//! `M_i q̈_i + b_i = τ_i + J_iᵀ F_i`, `b_i = C_i q̇_i + g_i(q_i) + D_i q̇_i`. The joint command
//! is `τ_i = J_iᵀ w_i + N_iᵀ τ0_i` with the dynamically consistent projector
//! `N_iᵀ = I − J_iᵀ Λ_i J_i M_i⁻¹`, `Λ_i = (J_i M_i⁻¹ J_iᵀ)⁻¹` (exists when `J_i` has full row
//! rank 6: 6- and 7-DOF arms away from singularities). Then
//! `J_i M_i⁻¹ N_iᵀ = J_i M_i⁻¹ − Λ_i⁻¹ Λ_i J_i M_i⁻¹ = 0`: the null-space torque does not
//! reach the tool. The tool acceleration is
//!
//! ```text
//! a_Ti = J_i q̈_i + J̇_i q̇_i = Λ_i⁻¹ (w_i + F_i) − J_i M_i⁻¹ b_i + J̇_i q̇_i
//! ⇒ F_i = Λ_i a_Ti + μ_i − w_i,          μ_i = Λ_i (J_i M_i⁻¹ b_i − J̇_i q̇_i).
//! ```
//!
//! The weld (SPEC-spatial S3) at the acceleration level is `a_Ti = G_i V̇ + Ġ_i V` with
//! `Ġ_i V = [ω × (ω × r_i); 0]` (`ṙ_i = ω × r_i`, so `d/dt(v + ω × r) = v̇ + ω̇ × r + ω × (ω × r)`).
//! The object (the plant's [`crate::model::spatial::object`]):
//! `M_o V̇ + h_o(V) + F_d = −Σ_i G_iᵀ F_i`, `M_o = blkdiag(m I, R_WO I_O R_WOᵀ)`,
//! `h_o = [−m g_W; ω × I_W ω] + C_o V`. Substituting `F_i`:
//!
//! ```text
//! M_o V̇ + h_o + F_d = −Σ G_iᵀ (Λ_i (G_i V̇ + Ġ_i V) + μ_i − w_i)
//! ⇒ (M_o + Σ G_iᵀ Λ_i G_i) V̇ + h_o + Σ G_iᵀ (μ_i + Λ_i Ġ_i V) + F_d = Σ G_iᵀ w_i,
//! ```
//!
//! which is the equation at the top. It is exact (no small-angle or static approximation): the
//! test `model_matches_the_closed_chain_plant` holds it against the KKT plant to round-off.
//! It needs no inverse kinematics: every term is evaluated at the measured `q, q̇` and the
//! estimated `X_WO, V`. For a redundant arm, `b_i` and `J̇_i q̇_i` depend on the measured
//! self-motion too; the equation stays exact for the dynamically consistent command.
//!
//! **Gravity part** (bias at zero velocities, `q̇ = 0`, `V = 0`):
//! `𝓖 = [−m g_W; 0] + Σ_i G_iᵀ g_x,i`, `g_x,i = Λ_i J_i M_i⁻¹ g_i(q_i)` (the arm's operational
//! -space gravity). Since `g_i = J_iᵀ g_x,i + N_iᵀ g_i`, a redundant arm's gravity has a
//! null-space part `N_iᵀ g_i` that the object does not see: [`super::distribute::joint_torques`]
//! adds it with the posture task.
//!
//! # How (per arm)
//! `terms` (`M_i`, `C q̇ + g`, `J`, `J̇ q̇` in one pass) and `gravity`; `M_i = L Lᵀ`; one
//! forward substitution with eight right-hand sides `[u_b | u_g | Z] = L⁻¹ [b_i | g_i | J_iᵀ]`;
//! `Λ_i⁻¹ = Zᵀ Z`, `J M⁻¹ b = Zᵀ u_b`, `J M⁻¹ g = Zᵀ u_g`; `Λ_i` by a 6 × 6 Cholesky.
//! `L` and `Z` stay in the workspace for the null-space projector of
//! [`super::distribute::joint_torques`]. `σ_min(J_i)` (from the eigenvalues of `J_i J_iᵀ`, about
//! half the cost again) is computed on demand only ([`ObjectModel::sigma_min`]).
//!
//! # Validation
//! `tests/spatial_control_model.rs` holds the model against the closed-chain KKT plant
//! ([`crate::plant::spatial`], a different algorithm: multipliers of the welds by a Schur
//! complement) at random consistent states with object twists up to 0.3 m/s and 0.8 rad/s,
//! random self-motion on the Frankas, random `w_i`, posture torques and disturbance: object
//! acceleration and grasp wrenches agree to ≤ 7e-12 and ≤ 4.5e-11 relative (dual UR5, dual
//! Franka, three UR5, with and without damping), with Baumgarte off; with `ω_b = 20` the IK's
//! 1e-12 residuals add up to 1.7e-10 on the wrenches.
//!
//! # References
//! 1. The paper's (14) (object-level dynamics of the closed chain) and (3)–(4) (Cartesian arm
//!    dynamics; here the operational-space form of O. Khatib, "A unified approach for motion and
//!    force control of robot manipulators: the operational space formulation", IEEE J. Robot.
//!    Autom. 3(1), 1987, which also defines the dynamically consistent `N_iᵀ`).
#![allow(non_snake_case)]

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3, Vector6};

use crate::dynamics::spatial;
use crate::dynamics::spatial::ChainData;
use crate::error::ModelError;
use crate::geometry::motion::{ang, lin, stack};
use crate::geometry::so3::hat;
use crate::math::linalg::{cholesky_rows, forward_rows};
use crate::model::spatial::RigidObject;
use crate::model::spatial::SpatialArm;
use crate::plant::spatial::{SpatialPlant, SpatialPlantParams};

/// Smallest pivot of `Λ_i⁻¹ = J M⁻¹ Jᵀ`'s Cholesky relative to its largest diagonal entry for
/// which [`ObjectModel::dynamics`] still forms `Λ_i` (below it the arm counts as singular).
pub const LAMBDA_PIVOT: f64 = 1e-12;

/// Columns of the per-arm right-hand side `[b | g | Jᵀ]`.
pub(crate) const RHS: usize = 8;

/// The object-level model (constant after [`ObjectModel::new`]): arms, grasps `X_OGi`, the
/// object's mass, inertia and damping, gravity.
#[derive(Clone, Debug)]
pub struct ObjectModel {
    arms: Vec<SpatialArm>,
    grasps: Vec<Isometry3<f64>>,
    object: RigidObject,
    g_W: Vector3<f64>,
    offsets: Vec<usize>,
    n_q: usize,
}

/// Per-arm operational-space terms of the last [`ObjectModel::dynamics`] (world axes, at the
/// tool origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmTerms {
    /// `Λ_i = (J_i M_i⁻¹ J_iᵀ)⁻¹`, operational-space inertia, 6 × 6 (kg, kg m, kg m²).
    pub lambda: Matrix6<f64>,
    /// `μ_i = Λ_i (J_i M_i⁻¹ b_i − J̇_i q̇_i)`, `b_i = C q̇ + g + D q̇`: the arm's bias at the tool
    /// (N, N m).
    pub mu: Vector6<f64>,
    /// `g_x,i = Λ_i J_i M_i⁻¹ g_i(q_i)`: operational-space gravity (N, N m).
    pub g_x: Vector6<f64>,
    /// `r_i = p_WTi − p_WO`, world axes, m.
    pub r: Vector3<f64>,
}

impl Default for ArmTerms {
    fn default() -> Self {
        ArmTerms {
            lambda: Matrix6::zeros(),
            mu: Vector6::zeros(),
            g_x: Vector6::zeros(),
            r: Vector3::zeros(),
        }
    }
}

/// The object-level dynamics `𝓜 V̇ + 𝓱 + F_d = Σ G_iᵀ w_i` (module doc, the paper's (14)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectDynamics {
    /// `𝓜 = M_o + Σ G_iᵀ Λ_i G_i` (6 × 6, SPD; kg, kg m, kg m²).
    pub m: Matrix6<f64>,
    /// `𝓱 = h_o(V) + Σ G_iᵀ Λ_i (J_i M_i⁻¹ b_i − J̇_i q̇_i + Ġ_i V)` (N, N m), gravity included.
    pub h: Vector6<f64>,
    /// `𝓖 = [−m g_W; 0] + Σ G_iᵀ g_x,i`: the part of `𝓱` at zero velocities (N, N m).
    pub g: Vector6<f64>,
}

impl ObjectDynamics {
    /// `V̇ = 𝓜⁻¹ (Σ G_iᵀ w_i − F_d − 𝓱)` for the net applied wrench `net = Σ G_iᵀ w_i` (about
    /// the centre of mass, world axes) and the disturbance `f_d` (plant's sign). `None` if `𝓜`
    /// is not positive definite (never for a valid model).
    pub fn acceleration(&self, net: &Vector6<f64>, f_d: &Vector6<f64>) -> Option<Vector6<f64>> {
        self.m.cholesky().map(|c| c.solve(&(net - f_d - self.h)))
    }
}

/// Scratch and outputs of the object-level model, sized once by [`ObjectModel::workspace`].
#[derive(Clone, Debug)]
pub struct ModelWorkspace {
    /// Per-arm kinematics (after [`ObjectModel::kinematics`]) and dynamics (`M`, `bias =
    /// C q̇ + g`, after [`ObjectModel::dynamics`]).
    pub data: Vec<ChainData>,
    /// Per-arm operational-space terms (after [`ObjectModel::dynamics`]).
    pub arms: Vec<ArmTerms>,
    /// Cholesky factor `L_i` of each `M_i`, row-major `n_i × n_i`.
    pub(crate) chol: Vec<Vec<f64>>,
    /// Per arm `[u_b | u_g | Z] = L⁻¹ [b | g | Jᵀ]`, row-major `n_i × 8`.
    pub(crate) x: Vec<Vec<f64>>,
    /// Per arm `g_i(q_i)` (n_i).
    pub(crate) grav: Vec<Vec<f64>>,
    /// Per arm scratch of `n_i` (the null-space projection).
    pub(crate) tmp: Vec<Vec<f64>>,
}

impl ObjectModel {
    /// Validate (as [`SpatialPlant::new`]: one grasp per arm, valid chains, object, gravity;
    /// errors name `arms[i]…`, `grasps`, `object.*`, `gravity`) and build. The grasp model and
    /// the Baumgarte gain of `p` are not used (the model is for welds).
    pub fn new(p: &SpatialPlantParams) -> Result<Self, ModelError> {
        let plant = SpatialPlant::new(p)?;
        let offsets = (0..plant.arms().len()).map(|i| plant.offset(i)).collect();
        Ok(ObjectModel {
            arms: plant.arms().to_vec(),
            grasps: plant.grasps().to_vec(),
            object: plant.object().clone(),
            g_W: plant.gravity(),
            offsets,
            n_q: plant.n_q(),
        })
    }

    /// A workspace sized for this model (the only allocation).
    pub fn workspace(&self) -> ModelWorkspace {
        let nn = |f: &dyn Fn(usize) -> usize| -> Vec<Vec<f64>> {
            self.arms
                .iter()
                .map(|a| vec![0.0; f(a.chain.dof())])
                .collect()
        };
        ModelWorkspace {
            data: self.arms.iter().map(ChainData::new).collect(),
            arms: vec![ArmTerms::default(); self.arms.len()],
            chol: nn(&|n| n * n),
            x: nn(&|n| n * RHS),
            grav: nn(&|n| n),
            tmp: nn(&|n| n),
        }
    }

    /// Number of joints over all arms.
    pub fn n_q(&self) -> usize {
        self.n_q
    }
    /// Index of arm `arm`'s first joint in the stacked joint vector.
    pub fn offset(&self, arm: usize) -> usize {
        self.offsets[arm]
    }
    /// The arms.
    pub fn arms(&self) -> &[SpatialArm] {
        &self.arms
    }
    /// The grasp frames `X_OGi`.
    pub fn grasps(&self) -> &[Isometry3<f64>] {
        &self.grasps
    }
    /// The object (mass, inertia `I_O` in body axes, damping `C_o`).
    pub fn object(&self) -> &RigidObject {
        &self.object
    }
    /// Gravity in world axes, m/s².
    pub fn gravity(&self) -> Vector3<f64> {
        self.g_W
    }

    /// Forward kinematics, tool Jacobian and `J̇ q̇` of every arm at the encoders (into
    /// `ws.data[i]`: `X_WT`, `J`, `jdqd`); cheap, no `M`. `(q, q̇)` stacked (n_q). No
    /// allocation.
    pub fn kinematics(&self, q: &[f64], qd: &[f64], ws: &mut ModelWorkspace) {
        for (i, arm) in self.arms.iter().enumerate() {
            let (s, n) = (self.offsets[i], arm.chain.dof());
            spatial::kinematics(arm, &q[s..s + n], Some(&qd[s..s + n]), &mut ws.data[i]);
        }
    }

    /// Forward kinematics and tool Jacobian of every arm (into `ws.data[i]`: `X_WT`, `J`),
    /// without the velocity pass (`J̇ q̇` is set to zero): what the estimate needs. No
    /// allocation.
    pub fn poses(&self, q: &[f64], ws: &mut ModelWorkspace) {
        for (i, arm) in self.arms.iter().enumerate() {
            let (s, n) = (self.offsets[i], arm.chain.dof());
            spatial::kinematics(arm, &q[s..s + n], None, &mut ws.data[i]);
        }
    }

    /// The object-level model at the measured `(q, q̇)` (stacked, n_q) and the estimated object
    /// pose `x_wo` and twist `twist` (world axes): per arm `M_i`, `b_i`, `Λ_i`, `μ_i`, `g_x,i`,
    /// `r_i` into `ws` (`σ_min(J_i)` on demand: [`Self::sigma_min`]), and `𝓜, 𝓱, 𝓖` returned (module doc).
    ///
    /// Recomputes the kinematics (the fused `terms` pass), so calling [`Self::kinematics`]
    /// first is not required for correctness. `None` if some `M_i` or `Λ_i⁻¹` is not positive
    /// definite, or `Λ_i⁻¹`'s smallest Cholesky pivot is below [`LAMBDA_PIVOT`] times its
    /// largest diagonal entry (an arm at a singularity: `Λ_i` does not exist). No allocation.
    pub fn dynamics(
        &self,
        q: &[f64],
        qd: &[f64],
        x_wo: &Isometry3<f64>,
        twist: &Vector6<f64>,
        ws: &mut ModelWorkspace,
    ) -> Option<ObjectDynamics> {
        self.dynamics_with(q, qd, x_wo, twist, ws, true)
    }

    /// [`Self::dynamics`]; `extras = false` skips `g_i(q)` (so `g_x,i` and `𝓖` are left
    /// stale), for the bound's repeated evaluations at one configuration.
    pub(crate) fn dynamics_with(
        &self,
        q: &[f64],
        qd: &[f64],
        x_wo: &Isometry3<f64>,
        twist: &Vector6<f64>,
        ws: &mut ModelWorkspace,
        extras: bool,
    ) -> Option<ObjectDynamics> {
        let r_wo = *x_wo.rotation.to_rotation_matrix().matrix();
        let p_wo = x_wo.translation.vector;
        let (v, w) = (lin(twist), ang(twist));
        let o = &self.object;
        // Object: M_o, h_o, and its gravity part.
        let i_w = r_wo * o.inertia * r_wo.transpose();
        let mut m_cal = Matrix6::zeros();
        m_cal
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&Matrix3::from_diagonal_element(o.mass));
        m_cal.fixed_view_mut::<3, 3>(3, 3).copy_from(&i_w);
        let g_o = stack(&(-o.mass * self.g_W), &Vector3::zeros());
        let mut h_lin = -o.mass * self.g_W;
        let mut h_ang = w.cross(&(i_w * w));
        for k in 0..3 {
            h_lin[k] += o.damping[k] * v[k];
            h_ang[k] += o.damping[3 + k] * w[k];
        }
        let mut h = stack(&h_lin, &h_ang);
        let mut g = g_o;
        for (i, arm) in self.arms.iter().enumerate() {
            let (s, n) = (self.offsets[i], arm.chain.dof());
            let (qi, qdi) = (&q[s..s + n], &qd[s..s + n]);
            let ok = match n {
                6 => arm_terms(6, arm, qi, qdi, &self.g_W, ws, i, extras),
                7 => arm_terms(7, arm, qi, qdi, &self.g_W, ws, i, extras),
                _ => arm_terms(n, arm, qi, qdi, &self.g_W, ws, i, extras),
            };
            if !ok {
                return None;
            }
            let t = &mut ws.arms[i];
            let r = ws.data[i].X_WT.translation.vector - p_wo;
            t.r = r;
            // G_iᵀ Λ G_i and G_iᵀ (μ + Λ Ġ V), G_iᵀ g_x.
            let gt = transport_t(&r);
            let lg = t.lambda * gt.transpose();
            m_cal += gt * lg;
            let gdv = stack(&w.cross(&w.cross(&r)), &Vector3::zeros());
            h += gt * (t.mu + t.lambda * gdv);
            g += gt * t.g_x;
        }
        Some(ObjectDynamics { m: m_cal, h, g })
    }

    /// The grasp wrench the model predicts for arm `i` (the object on tool `i`, about the tool
    /// origin, world axes): `F_i = Λ_i (G_i V̇ + Ġ_i V) + μ_i − w_i` for the object acceleration
    /// `v_dot` and twist `twist` (module doc). Needs `ws.arms[i]` from [`Self::dynamics`].
    pub fn grasp_wrench(
        &self,
        ws: &ModelWorkspace,
        i: usize,
        w_i: &Vector6<f64>,
        v_dot: &Vector6<f64>,
        twist: &Vector6<f64>,
    ) -> Vector6<f64> {
        let t = &ws.arms[i];
        let w = ang(twist);
        let a_t = stack(
            &(lin(v_dot) + ang(v_dot).cross(&t.r) + w.cross(&w.cross(&t.r))),
            &ang(v_dot),
        );
        t.lambda * a_t + t.mu - w_i
    }
}

/// `G_iᵀ = [[I, 0], [[r]×, I]]` (6 × 6): a wrench at the tool origin moved to the centre of
/// mass, `G_iᵀ w = [f; τ + r × f]`.
pub fn transport_t(r: &Vector3<f64>) -> Matrix6<f64> {
    let mut g = Matrix6::identity();
    g.fixed_view_mut::<3, 3>(3, 0).copy_from(&hat(r));
    g
}

/// One arm's `terms`, gravity, Cholesky, `[u_b | u_g | Z]` and `Λ, μ, g_x` (inlined so a
/// constant `n` unrolls). `false` if `M` or `Λ⁻¹` is not positive definite.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn arm_terms(
    n: usize,
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    g_W: &Vector3<f64>,
    ws: &mut ModelWorkspace,
    i: usize,
    extras: bool,
) -> bool {
    let d = &mut ws.data[i];
    let grav = &mut ws.grav[i][..n];
    if extras {
        spatial::gravity(arm, q, g_W, grav, d);
    }
    spatial::terms(arm, q, qd, g_W, d);
    let l = &mut ws.chol[i][..n * n];
    // M is symmetric: column-major storage = row-major storage.
    l.copy_from_slice(&d.M.as_slice()[..n * n]);
    if cholesky_rows(l, n).is_err() {
        return false;
    }
    let x = &mut ws.x[i][..n * RHS];
    let jt = &d.J.as_slice()[..6 * n];
    for k in 0..n {
        let row = &mut x[k * RHS..k * RHS + RHS];
        row[0] = d.bias[k] + arm.chain.joints[k].damping * qd[k];
        row[1] = grav[k];
        row[2..].copy_from_slice(&jt[6 * k..6 * k + 6]);
    }
    forward_rows(l, n, x, RHS);
    let mut lam_inv = Matrix6::zeros();
    let mut jmb = Vector6::zeros();
    let mut jmg = Vector6::zeros();
    for k in 0..n {
        let row = &x[k * RHS..k * RHS + RHS];
        for a in 0..6 {
            let za = row[2 + a];
            jmb[a] += za * row[0];
            jmg[a] += za * row[1];
            for b in 0..6 {
                lam_inv[(a, b)] += za * row[2 + b];
            }
        }
    }
    let Some(ch) = lam_inv.cholesky() else {
        return false;
    };
    // A rank-deficient J (a singular arm) leaves a round-off pivot: treat a pivot ratio below
    // LAMBDA_PIVOT (condition of Λ⁻¹ above 1e12) as "Λ does not exist".
    let l = ch.l_dirty();
    let (mut pmin, mut dmax) = (f64::INFINITY, 0.0f64);
    for k in 0..6 {
        pmin = pmin.min(l[(k, k)] * l[(k, k)]);
        dmax = dmax.max(lam_inv[(k, k)]);
    }
    if !(pmin > LAMBDA_PIVOT * dmax) {
        return false;
    }
    let lambda = ch.inverse();
    let t = &mut ws.arms[i];
    t.lambda = lambda;
    t.mu = lambda * (jmb - d.jdqd);
    t.g_x = lambda * jmg;
    true
}

impl ObjectModel {
    /// The arms' operational-space gravity `g_x,i` alone, for arms with exactly six joints:
    /// `g_x,i = Λ_i J_i M_i⁻¹ g_i = J_i⁻ᵀ g_i` (square `J_i`), by the gravity pass and one 6 × 6
    /// LU solve, without `M_i` (a fifth of [`Self::dynamics`]). Needs the placements and
    /// `ws.data[i].J` from [`Self::kinematics`] or [`Self::poses`] at the same `q`; writes
    /// `ws.arms[i].g_x`. `false` (nothing
    /// usable written) if an arm has other than six joints or a singular Jacobian. No
    /// allocation.
    pub fn operational_gravity(&self, ws: &mut ModelWorkspace) -> bool {
        for (i, arm) in self.arms.iter().enumerate() {
            if arm.chain.dof() != 6 {
                return false;
            }
            let d = &ws.data[i];
            let grav = &mut ws.grav[i][..6];
            spatial::gravity_at_placements(arm, &self.g_W, grav, d);
            // Row k of Jᵀ is column k of J (contiguous: J is column-major, 6 rows).
            let js = &d.J.as_slice()[..36];
            let mut jt = [[0.0; 6]; 6];
            for (row, col) in jt.iter_mut().zip(js.chunks_exact(6)) {
                row.copy_from_slice(col);
            }
            let mut x = [0.0; 6];
            x.copy_from_slice(grav);
            if !crate::math::linalg::lu_solve6_in_place(&mut jt, &mut x) {
                return false;
            }
            if !crate::math::linalg::finite_slice(&x) {
                return false;
            }
            ws.arms[i].g_x = Vector6::from(x);
        }
        true
    }

    /// `σ_min(J_i)` of arm `i`'s tool Jacobian in `ws` (after [`Self::kinematics`] or
    /// [`Self::dynamics`]), mixed m and rad units, from the eigenvalues of `J_i J_iᵀ`. Not part of
    /// the per-tick [`Self::dynamics`] (a 6 × 6 symmetric eigenproblem costs a third of it).
    pub fn sigma_min(&self, ws: &ModelWorkspace, i: usize) -> f64 {
        jjt_sigma_min(&ws.data[i])
    }
}

/// `σ_min(J)` of the 6 × n tool Jacobian in `d` (0 for `n < 6`), from the eigenvalues of `J Jᵀ`.
pub(crate) fn jjt_sigma_min(d: &ChainData) -> f64 {
    let n = d.J.ncols();
    if n < 6 {
        return 0.0;
    }
    let mut m = Matrix6::zeros();
    for a in 0..6 {
        for b in a..6 {
            let mut s = 0.0;
            for k in 0..n {
                s += d.J[(a, k)] * d.J[(b, k)];
            }
            m[(a, b)] = s;
            m[(b, a)] = s;
        }
    }
    m.symmetric_eigenvalues().min().max(0.0).sqrt()
}

/// The computed-torque baseline's nominal model (SPEC §3.5, spatial): every mass and inertia —
/// each link body of each arm and the object — scaled by `1 + model_error` (centres of mass,
/// kinematics, damping and gravity unchanged), as the planar [`crate::control::law::ctc::nominal_params`].
pub fn nominal_params(truth: &SpatialPlantParams, model_error: f64) -> SpatialPlantParams {
    let s = 1.0 + model_error;
    let mut p = truth.clone();
    for a in &mut p.arms {
        for b in &mut a.chain.bodies {
            b.mass *= s;
            b.inertia *= s;
        }
    }
    p.object.mass *= s;
    p.object.inertia *= s;
    p
}
