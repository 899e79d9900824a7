//! The planar closed-chain plant: arms + object + grasps, SPEC §2.4, paper (10)–(14).
//!
//! Two formulations that must agree wherever both apply:
//! * [`constrained`] (the default plant): all joint angles plus the object pose, one holonomic
//!   constraint per grasp, Lagrange multipliers = grasp forces, Baumgarte drift control. Any
//!   number of arms, any number of joints.
//! * [`reduced`]: object coordinates only, paper (14); arms from analytic inverse kinematics
//!   (2-link arms only).
//!
//! State layout (flat, for the integrators): `y = [q (n_q), x_o (3), q̇ (n_q), ẋ_o (3)]`, where
//! `q` stacks the arms' joint angles in arm order.
//!
//! # Fast paths
//! [`Plant::new`] selects the constrained algorithm once ([`Algorithm`]): two or three arms of 2,
//! 3 or 4 links each (all arms the same) run [`Plant::derivative`] entirely in fixed-size types,
//! per arm (2-link arms: 2×2 blocks from the SPEC §2.1 closed forms, closed-form `M⁻¹`; 3- and
//! 4-link arms: the general algorithm in `SMatrix` values with a fixed-size Cholesky), with a
//! 4×4 or 6×6 grasp-space `L D Lᵀ`; any other plant runs the general dynamic-size algorithm
//! ([`Plant::derivative_general`]), which stays public so tests hold the two equal. The reduced
//! plant (2-link arms only) always uses the fixed-size per-arm terms ([`TwoLinkArm`]), with the
//! inverse kinematics as link directions (no transcendental calls).

pub mod constrained;
pub mod reduced;

use nalgebra::{DMatrix, Matrix2, Matrix2x3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::dynamics::planar::{Arm, ArmTerms, Cartesian, FixedLinkArm, IkFailure, TwoLinkArm};
use crate::error::{ModelError, non_negative};
use crate::model::planar::arm::ArmParams;
use crate::model::planar::grasp::Grasp;
use crate::model::planar::object::{Object, ObjectParams};
use crate::plant::Energy;

/// Plant parameters: plain data, validated by [`Plant::new`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantParams {
    /// The arms.
    pub arms: Vec<ArmParams>,
    /// Grasp point `r_i` of each arm in the object frame, m (one per arm).
    pub grasps: Vec<[f64; 2]>,
    /// The object.
    pub object: ObjectParams,
    /// Gravity `g` along −y, m/s².
    pub gravity: f64,
    /// Baumgarte drift-control natural frequency `ω_b` (critically damped), rad/s; 0 disables.
    pub baumgarte: f64,
}

impl PlantParams {
    /// The paper's two-arm set-up (SPEC §4): Table I arms with `l_c = l/2`, bases `(±0.38, 0)`,
    /// mirrored elbows (arm 1 `q2 < 0`, arm 2 `q2 > 0`), `l_o = 0.1 m`, grasps `(∓l_o/2, 0)`,
    /// `M_o = C_o = I`, `G_o = (0, 9.8, 0)`.
    pub fn paper() -> Self {
        use crate::model::planar::arm::Elbow;
        PlantParams {
            arms: vec![
                ArmParams::paper([-0.38, 0.0], Elbow::Negative),
                ArmParams::paper([0.38, 0.0], Elbow::Positive),
            ],
            grasps: vec![[-0.05, 0.0], [0.05, 0.0]],
            object: ObjectParams::paper(),
            gravity: crate::model::planar::arm::GRAVITY,
            baumgarte: 20.0,
        }
    }
}

/// Joint torques and the object disturbance, held constant over a plant step (ZOH).
#[derive(Clone, Debug, PartialEq)]
pub struct PlantInput {
    /// Joint torques of all arms, stacked in arm order, N m (n_q).
    pub tau: Vec<f64>,
    /// Environment disturbance `F_d` on the object (subtracted in (10)), (N, N, N m).
    pub f_d: Vector3<f64>,
}

/// The constrained-derivative algorithm of a plant, selected once by [`Plant::new`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Algorithm {
    /// Exactly two 2-link arms (the paper's set-up): fixed-size 2×2 arm blocks (SPEC §2.1
    /// closed forms) and a 4×4 grasp-space solve, no dynamic-size buffers.
    TwoArmsTwoLinks,
    /// `arms` arms (2 or 3) of `links` links each (2, 3 or 4), other than two 2-link arms:
    /// fixed-size per-arm kernels ([`FixedArm`](crate::dynamics::planar::FixedArm)) and a `2·arms` square
    /// fixed-size grasp-space solve.
    Fixed {
        /// Number of arms.
        arms: usize,
        /// Links per arm.
        links: usize,
    },
    /// Any number of arms with any number of joints: dynamic-size blocks in the workspace.
    General,
}

/// The per-plant kernel behind [`Algorithm`]: `L{links}A{arms}` holds each arm's fixed-size
/// kernel.
#[derive(Clone, Debug)]
pub(crate) enum Kernel {
    L2A2([TwoLinkArm; 2]),
    L2A3([TwoLinkArm; 3]),
    L3A2([FixedLinkArm<3>; 2]),
    L3A3([FixedLinkArm<3>; 3]),
    L4A2([FixedLinkArm<4>; 2]),
    L4A3([FixedLinkArm<4>; 3]),
    General,
}

impl Kernel {
    /// Select the kernel for `arms` (once, at construction).
    fn select(arms: &[Arm]) -> Kernel {
        fn all<T: Copy, const M: usize>(
            arms: &[Arm],
            f: impl Fn(&Arm) -> Option<T>,
        ) -> Option<[T; M]> {
            if arms.len() != M {
                return None;
            }
            let v: Option<Vec<T>> = arms.iter().map(f).collect();
            v.map(|v| std::array::from_fn(|i| v[i]))
        }
        let two = |a: &Arm| a.two_link().copied();
        if let Some(a) = all(arms, two) {
            return Kernel::L2A2(a);
        }
        if let Some(a) = all(arms, two) {
            return Kernel::L2A3(a);
        }
        if let Some(a) = all(arms, Arm::fixed::<3>) {
            return Kernel::L3A2(a);
        }
        if let Some(a) = all(arms, Arm::fixed::<3>) {
            return Kernel::L3A3(a);
        }
        if let Some(a) = all(arms, Arm::fixed::<4>) {
            return Kernel::L4A2(a);
        }
        if let Some(a) = all(arms, Arm::fixed::<4>) {
            return Kernel::L4A3(a);
        }
        Kernel::General
    }
}

/// A validated, immutable plant model.
#[derive(Clone, Debug)]
pub struct Plant {
    arms: Vec<Arm>,
    grasps: Vec<Grasp>,
    object: Object,
    g: f64,
    baumgarte: f64,
    offsets: Vec<usize>,
    n_q: usize,
    /// The constrained derivative's kernel, selected once ([`Plant::algorithm`]).
    kernel: Kernel,
    /// Diagonal of `M_o⁻¹` ([`Object::new`] builds `M_o` diagonal), (1/kg, 1/kg, 1/(kg m²)).
    m_o_inv: Vector3<f64>,
    /// Diagonal of `C_o` (diagonal by construction), (N s/m, N s/m, N m s/rad).
    c_o: Vector3<f64>,
}

/// Per-step scratch and the step's secondary results (grasp forces, diagnostics).
#[derive(Clone, Debug)]
pub struct PlantWorkspace {
    /// Per-arm kinematics and dynamics. Written by the functions that say so
    /// ([`Plant::energy`], [`Plant::constraint_residual`], [`Plant::min_singular_value`],
    /// [`Plant::arms_from_object`], [`Plant::object_space`], [`Plant::derivative_general`]); the
    /// fixed-size paths of [`Plant::derivative`] and [`Plant::reduced_derivative`] keep their
    /// per-arm terms on the stack and leave it as it was.
    pub terms: Vec<ArmTerms>,
    /// Grasp forces `F_i` (the object on end-effector `i`) of the last evaluation, N.
    pub forces: Vec<Vector2<f64>>,
    /// Object acceleration of the last evaluation.
    pub xdd_o: Vector3<f64>,
    /// Smallest pivot over the largest diagonal entry of the last grasp-space factorisation
    /// (conditioning indicator; the Cholesky's and the `L D Lᵀ`'s pivots are the same).
    pub kkt_pivot: f64,
    /// Number of evaluations whose grasp-space system needed regularisation (singular chain).
    pub regularised: u64,
    grasp_j: Vec<Matrix2x3<f64>>,
    minv_jt: Vec<DMatrix<f64>>,
    a0: Vec<f64>,
    k: DMatrix<f64>,
    k_copy: DMatrix<f64>,
    rhs: Vec<f64>,
    /// Joint angles from IK in the reduced formulation (n_q).
    pub q_red: Vec<f64>,
    /// Joint velocities in the reduced formulation (n_q).
    pub qd_red: Vec<f64>,
    /// Per-arm Cartesian terms (3)–(4) from the last reduced evaluation.
    pub cartesian: Vec<Cartesian>,
    tau_x: Vec<Vector2<f64>>,
    /// Per-arm `R(θ) r_i` of the last reduced evaluation, m.
    rw: Vec<Vector2<f64>>,
    /// The state part of the last [`Plant::derivative_keep`] (fixed-size kernels only), for
    /// [`Plant::derivative_reusing`] at the same state.
    kept: constrained::Kept,
    /// The state `y` of [`PlantWorkspace::kept`] (state_dim), compared bit for bit.
    kept_y: Vec<f64>,
    /// Whether `kept` holds the state part of `kept_y`.
    kept_valid: bool,
}

/// As the spatial plant ([`crate::plant::spatial::MAX_OBJECT_TO_ARMS_MASS`]): an object a
/// million times heavier than the arms that carry it (`arms_mass`, kg) is no set-up, and far
/// beyond it the constrained solve has no digits left (an inertia of 1e308 validated and
/// faulted at t = 0). The rotational entry is held to the same ratio against the arms' mass
/// times a square metre. Errors name `object.inertia[k]`.
pub fn object_within_arms(o: &ObjectParams, arms_mass: f64) -> Result<(), ModelError> {
    let max = crate::plant::spatial::MAX_OBJECT_TO_ARMS_MASS;
    for k in 0..3 {
        let v = o.inertia[k];
        if arms_mass > 0.0 && !(v <= max * arms_mass) {
            return Err(ModelError::invalid(
                format!("object.inertia[{k}]"),
                v,
                format!(
                    "must be at most {max:e} times the arms' total mass ({} kg{}): no arm carries it, and the constrained solve loses its digits",
                    crate::error::fmt_fixed(arms_mass, 3),
                    if k == 2 { " × 1 m²" } else { "" }
                ),
            ));
        }
    }
    Ok(())
}

impl Plant {
    /// Validate the parameters (each arm, the object, one grasp per arm, `g ≥ 0`, `ω_b ≥ 0`).
    pub fn new(p: &PlantParams) -> Result<Self, ModelError> {
        if p.arms.is_empty() {
            return Err(ModelError::geometry("arms", "at least one arm is needed"));
        }
        if p.grasps.len() != p.arms.len() {
            return Err(ModelError::geometry(
                "grasps",
                format!(
                    "{} grasp points for {} arms: give one per arm",
                    p.grasps.len(),
                    p.arms.len()
                ),
            ));
        }
        let mut arms = Vec::with_capacity(p.arms.len());
        let mut offsets = Vec::with_capacity(p.arms.len());
        let mut n_q = 0;
        for (i, a) in p.arms.iter().enumerate() {
            let arm = Arm::new(&format!("arms[{i}]"), a)?;
            offsets.push(n_q);
            n_q += arm.dof();
            arms.push(arm);
        }
        let mut grasps = Vec::with_capacity(p.grasps.len());
        for (i, r) in p.grasps.iter().enumerate() {
            for (k, v) in r.iter().enumerate() {
                if !v.is_finite() {
                    return Err(ModelError::invalid(
                        format!("grasps[{i}][{k}]"),
                        *v,
                        "must be finite",
                    ));
                }
            }
            grasps.push(Grasp {
                r: Vector2::new(r[0], r[1]),
            });
        }
        let arms_mass: f64 = p
            .arms
            .iter()
            .flat_map(|a| a.links.iter().map(|l| l.mass))
            .sum();
        object_within_arms(&p.object, arms_mass)?;
        let object = Object::new(&p.object)?;
        let g = non_negative("gravity", p.gravity)?;
        let baumgarte = non_negative("baumgarte", p.baumgarte)?;
        let kernel = Kernel::select(&arms);
        let m_o_inv = object.M_o_inv.diagonal();
        let c_o = object.C_o.diagonal();
        Ok(Plant {
            arms,
            grasps,
            object,
            g,
            baumgarte,
            offsets,
            n_q,
            kernel,
            m_o_inv,
            c_o,
        })
    }

    /// The constrained-derivative algorithm selected at construction.
    pub fn algorithm(&self) -> Algorithm {
        let fixed = |arms, links| Algorithm::Fixed { arms, links };
        match self.kernel {
            Kernel::L2A2(_) => Algorithm::TwoArmsTwoLinks,
            Kernel::L2A3(_) => fixed(3, 2),
            Kernel::L3A2(_) => fixed(2, 3),
            Kernel::L3A3(_) => fixed(3, 3),
            Kernel::L4A2(_) => fixed(2, 4),
            Kernel::L4A3(_) => fixed(3, 4),
            Kernel::General => Algorithm::General,
        }
    }
    /// The arms.
    pub fn arms(&self) -> &[Arm] {
        &self.arms
    }
    /// The grasps, one per arm.
    pub fn grasps(&self) -> &[Grasp] {
        &self.grasps
    }
    /// The object.
    pub fn object(&self) -> &Object {
        &self.object
    }
    /// Gravity, m/s².
    pub fn gravity(&self) -> f64 {
        self.g
    }
    /// Total number of joints `n_q`.
    pub fn n_q(&self) -> usize {
        self.n_q
    }
    /// Offset of arm `i`'s joints in the stacked `q`.
    pub fn offset(&self, i: usize) -> usize {
        self.offsets[i]
    }
    /// Length of the flat state `y`.
    pub fn state_dim(&self) -> usize {
        2 * (self.n_q + 3)
    }
    /// `(q, x_o, q̇, ẋ_o)` views of a flat state.
    pub fn split<'a>(&self, y: &'a [f64]) -> (&'a [f64], Vector3<f64>, &'a [f64], Vector3<f64>) {
        let n = self.n_q;
        (
            &y[..n],
            Vector3::new(y[n], y[n + 1], y[n + 2]),
            &y[n + 3..2 * n + 3],
            Vector3::new(y[2 * n + 3], y[2 * n + 4], y[2 * n + 5]),
        )
    }
    /// An all-zero input of the right size.
    pub fn zero_input(&self) -> PlantInput {
        PlantInput {
            tau: vec![0.0; self.n_q],
            f_d: Vector3::zeros(),
        }
    }

    /// Allocate the workspace (once).
    pub fn workspace(&self) -> PlantWorkspace {
        let m = self.arms.len();
        PlantWorkspace {
            terms: self.arms.iter().map(|a| a.terms()).collect(),
            forces: vec![Vector2::zeros(); m],
            xdd_o: Vector3::zeros(),
            kkt_pivot: 1.0,
            regularised: 0,
            grasp_j: vec![Matrix2x3::zeros(); m],
            minv_jt: self
                .arms
                .iter()
                .map(|a| DMatrix::zeros(a.dof(), 2))
                .collect(),
            a0: vec![0.0; self.n_q],
            k: DMatrix::zeros(2 * m, 2 * m),
            k_copy: DMatrix::zeros(2 * m, 2 * m),
            rhs: vec![0.0; 2 * m],
            q_red: vec![0.0; self.n_q],
            qd_red: vec![0.0; self.n_q],
            cartesian: vec![
                Cartesian {
                    M_x: Matrix2::identity(),
                    C_x: Matrix2::zeros(),
                    G_x: Vector2::zeros(),
                    J_inv: Matrix2::identity()
                };
                m
            ],
            tau_x: vec![Vector2::zeros(); m],
            rw: vec![Vector2::zeros(); m],
            kept: constrained::Kept::for_kernel(&self.kernel),
            kept_y: vec![0.0; self.state_dim()],
            kept_valid: false,
        }
    }

    /// A consistent state with the object at `x_o` moving at `ẋ_o`: 2-link arms by analytic IK
    /// on their elbow branch, other arms by damped Gauss–Newton from `q_guess` (stacked n_q; the
    /// 2-link entries are ignored). Joint velocities are the minimum-norm solution of
    /// `J_e q̇ = J_i ẋ_o`. Fails, naming the arm, if a grasp point is out of reach.
    pub fn initial_state(
        &self,
        x_o: Vector3<f64>,
        xd_o: Vector3<f64>,
        q_guess: Option<&[f64]>,
    ) -> Result<Vec<f64>, ModelError> {
        let n = self.n_q;
        let mut y = vec![0.0; self.state_dim()];
        let mut ws = self.workspace();
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let target = self.grasps[i].point(&x_o);
            let dof = arm.dof();
            if dof == 2 {
                let q = arm
                    .inverse_kinematics(target)
                    .map_err(|e| ik_error(arm, i, target, e))?;
                y[off..off + 2].copy_from_slice(&q);
            } else {
                let q = &mut y[off..off + dof];
                if let Some(g) = q_guess {
                    q.copy_from_slice(&g[off..off + dof]);
                }
                solve_ik_numeric(arm, target, q, &mut ws.terms[i]).map_err(|d| {
                    ModelError::geometry(
                        format!("arms[{i}]"),
                        format!("cannot reach its grasp point ({:.4}, {:.4}) m from the given initial joint angles (residual {d:.3e} m)", target.x, target.y),
                    )
                })?;
            }
            // Velocities: minimum-norm q̇ with J_e q̇ = J_i ẋ_o.
            let zeros = vec![0.0; dof];
            arm.kinematics(&y[off..off + dof], &zeros, &mut ws.terms[i]);
            let v = self.grasps[i].jacobian(x_o.z) * xd_o;
            let j = &ws.terms[i].J;
            let jjt = j * j.transpose();
            let w = jjt.try_inverse().ok_or_else(|| {
                ModelError::geometry(
                    format!("arms[{i}]"),
                    "starts in a singular configuration (J_e Jᵀ_e not invertible)",
                )
            })? * v;
            let qd = j.transpose() * w;
            y[n + 3 + off..n + 3 + off + dof].copy_from_slice(qd.as_slice());
        }
        y[n..n + 3].copy_from_slice(x_o.as_slice());
        y[2 * n + 3..].copy_from_slice(xd_o.as_slice());
        self.check_state(&y, 1e-9)?;
        Ok(y)
    }

    /// Check that a state satisfies every grasp to within `tol` (position, m, and velocity,
    /// m/s); otherwise an error naming the arm and the violation.
    pub fn check_state(&self, y: &[f64], tol: f64) -> Result<(), ModelError> {
        if y.len() != self.state_dim() {
            return Err(ModelError::geometry(
                "state",
                format!(
                    "has {} entries, the plant needs {}",
                    y.len(),
                    self.state_dim()
                ),
            ));
        }
        if let Some(k) = y.iter().position(|v| !v.is_finite()) {
            return Err(ModelError::invalid(
                format!("state[{k}]"),
                y[k],
                "must be finite",
            ));
        }
        let mut ws = self.workspace();
        let (q, x_o, qd, xd_o) = self.split(y);
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let dof = arm.dof();
            arm.kinematics(&q[off..off + dof], &qd[off..off + dof], &mut ws.terms[i]);
            let t = &ws.terms[i];
            let dp = (t.p_ee - self.grasps[i].point(&x_o)).norm();
            let dv = (t.v_ee - self.grasps[i].jacobian(x_o.z) * xd_o).norm();
            if dp > tol || dv > tol {
                return Err(ModelError::geometry(
                    format!("arms[{i}]"),
                    format!(
                        "the starting pose violates the grasp: end-effector {dp:.3e} m and {dv:.3e} m/s away from its grasp point"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Largest grasp-constraint violation `(position m, velocity m/s)` of a state.
    pub fn constraint_residual(&self, y: &[f64], ws: &mut PlantWorkspace) -> (f64, f64) {
        self.residual_and_sigma::<false>(y, ws).0
    }

    /// Mechanical energy of a state (arms + object; the object's potential is `G_oᵀ x_o`).
    pub fn energy(&self, y: &[f64], ws: &mut PlantWorkspace) -> Energy {
        let (q, x_o, qd, xd_o) = self.split(y);
        let mut e = Energy::default();
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let dof = arm.dof();
            arm.dynamics(
                &q[off..off + dof],
                &qd[off..off + dof],
                self.g,
                &mut ws.terms[i],
            );
            let (k, p) = arm.energy(&qd[off..off + dof], self.g, &ws.terms[i]);
            e.kinetic += k;
            e.potential += p;
        }
        let (k, p) = self.object.energy(&x_o, &xd_o);
        e.kinetic += k;
        e.potential += p;
        e
    }

    /// Power flowing in: `τᵀq̇ − F_dᵀẋ_o − ẋ_oᵀ C_o ẋ_o` (the energy balance's right side), W.
    pub fn power_in(&self, y: &[f64], input: &PlantInput) -> f64 {
        let (_, _, qd, xd_o) = self.split(y);
        let tq: f64 = input.tau.iter().zip(qd).map(|(a, b)| a * b).sum();
        tq - input.f_d.dot(&xd_o) - xd_o.dot(&(self.object.C_o * xd_o))
    }

    /// Smallest singular value of any arm's end-effector Jacobian in state `y`, m/rad.
    pub fn min_singular_value(&self, y: &[f64], ws: &mut PlantWorkspace) -> f64 {
        let (q, _, qd, _) = self.split(y);
        let mut s = f64::INFINITY;
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let dof = arm.dof();
            arm.kinematics(&q[off..off + dof], &qd[off..off + dof], &mut ws.terms[i]);
            s = s.min(arm.min_singular_value(&ws.terms[i]));
        }
        s
    }

    /// [`Plant::constraint_residual`] and [`Plant::min_singular_value`] of one state from one
    /// [`Arm::kinematics`] per arm (the two would compute the same kinematics twice): the same
    /// values, bit for bit. Writes `ws.terms`.
    pub fn residual_and_min_singular_value(
        &self,
        y: &[f64],
        ws: &mut PlantWorkspace,
    ) -> ((f64, f64), f64) {
        self.residual_and_sigma::<true>(y, ws)
    }

    /// The loop of [`Plant::constraint_residual`], and `σ_min` too if `SIGMA` (else `+∞`).
    fn residual_and_sigma<const SIGMA: bool>(
        &self,
        y: &[f64],
        ws: &mut PlantWorkspace,
    ) -> ((f64, f64), f64) {
        let (q, x_o, qd, xd_o) = self.split(y);
        let (mut ep, mut ev) = (0.0f64, 0.0f64);
        let mut s = f64::INFINITY;
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let dof = arm.dof();
            arm.kinematics(&q[off..off + dof], &qd[off..off + dof], &mut ws.terms[i]);
            let t = &ws.terms[i];
            ep = ep.max((t.p_ee - self.grasps[i].point(&x_o)).norm());
            ev = ev.max((t.v_ee - self.grasps[i].jacobian(x_o.z) * xd_o).norm());
            if SIGMA {
                s = s.min(arm.min_singular_value(t));
            }
        }
        ((ep, ev), s)
    }
}

fn ik_error(arm: &Arm, i: usize, target: Vector2<f64>, e: IkFailure) -> ModelError {
    match e {
        IkFailure::OutOfReach { distance, min, max } => ModelError::geometry(
            format!("arms[{i}]"),
            format!(
                "grasp point ({:.4}, {:.4}) m is {distance:.4} m from the base ({:.3}, {:.3}); the arm reaches {min:.4}..{max:.4} m",
                target.x,
                target.y,
                arm.base().x,
                arm.base().y
            ),
        ),
        IkFailure::NotTwoLink => {
            ModelError::geometry(format!("arms[{i}]"), "analytic IK needs a 2-link arm")
        }
    }
}

/// Damped Gauss–Newton position IK for an n-link arm from the angles in `q`; returns the final
/// residual on failure.
fn solve_ik_numeric(
    arm: &Arm,
    target: Vector2<f64>,
    q: &mut [f64],
    t: &mut ArmTerms,
) -> Result<(), f64> {
    let zeros = vec![0.0; q.len()];
    let mut res = f64::INFINITY;
    for _ in 0..200 {
        arm.kinematics(q, &zeros, t);
        let e = target - t.p_ee;
        res = e.norm();
        if res < 1e-13 {
            return Ok(());
        }
        let j = &t.J;
        let lambda2 = 1e-6;
        let a = j * j.transpose() + nalgebra::Matrix2::identity() * lambda2;
        let w = a.try_inverse().ok_or(res)? * e;
        let dq = j.transpose() * w;
        for (qi, d) in q.iter_mut().zip(dq.iter()) {
            *qi += d;
        }
    }
    if res < 1e-11 { Ok(()) } else { Err(res) }
}

/// The constrained plant as an [`OdeSystem`](crate::math::integrate::OdeSystem) with a held input
/// (zero-order hold). If the derivative cannot be evaluated (never for a validated model) it
/// writes NaN, which the caller's non-finite check catches.
pub struct ConstrainedOde<'a> {
    /// The model.
    pub plant: &'a Plant,
    /// Scratch; after a step it holds the last stage's grasp forces.
    pub ws: &'a mut PlantWorkspace,
    /// The held input.
    pub input: &'a PlantInput,
}

impl crate::math::integrate::OdeSystem for ConstrainedOde<'_> {
    fn dim(&self) -> usize {
        self.plant.state_dim()
    }
    fn deriv(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        if !self.plant.derivative(y, self.input, self.ws, dy) {
            dy.fill(f64::NAN);
        }
    }
}

/// [`ConstrainedOde`] whose first evaluation is [`Plant::derivative_reusing`]: the first RK4
/// stage of a control tick is at the state where the loop evaluated the grasp forces
/// ([`Plant::derivative_keep`], the previous input held), so only its torque part is redone.
/// The same values, bit for bit, as [`ConstrainedOde`].
pub(crate) struct ReusingOde<'a> {
    pub(crate) plant: &'a Plant,
    pub(crate) ws: &'a mut PlantWorkspace,
    pub(crate) input: &'a PlantInput,
    /// Whether the next evaluation is the first.
    pub(crate) first: bool,
}

impl crate::math::integrate::OdeSystem for ReusingOde<'_> {
    fn dim(&self) -> usize {
        self.plant.state_dim()
    }
    fn deriv(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let ok = if self.first {
            self.first = false;
            self.plant.derivative_reusing(y, self.input, self.ws, dy)
        } else {
            self.plant.derivative(y, self.input, self.ws, dy)
        };
        if !ok {
            dy.fill(f64::NAN);
        }
    }
}

/// The reduced plant (14) on `(x_o, ẋ_o)` as an [`OdeSystem`](crate::math::integrate::OdeSystem)
/// with a held input; writes NaN where the reduced form does not exist (IK out of reach,
/// singular arm).
pub struct ReducedOde<'a> {
    /// The model.
    pub plant: &'a Plant,
    /// Scratch.
    pub ws: &'a mut PlantWorkspace,
    /// The held input.
    pub input: &'a PlantInput,
}

impl crate::math::integrate::OdeSystem for ReducedOde<'_> {
    fn dim(&self) -> usize {
        6
    }
    fn deriv(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        if self
            .plant
            .reduced_derivative(y, self.input, self.ws, dy)
            .is_err()
        {
            dy.fill(f64::NAN);
        }
    }
}
