//! The planar cooperative controller ([`Controller`]): one tick maps (time, encoder readings, force readings) to joint
//! torques plus a record of its internals (SPEC §3).
//!
//! Data flow of a tick (SPEC §3, steps 1–5):
//! 1. `(q, q̇) → (x̂_o, ẋ̂_o)`: forward kinematics of each arm, least-squares fit through the grasps
//!    ([`crate::model::planar::grasp::fit_pose`]); the controller never reads the plant state.
//! 2. `t → x_d, ẋ_d, ẍ_d`: the desired path ([`crate::reference::planar::path`]).
//! 3. `(F_i, x_d) → x_r,i → x_r`: per-arm admittance generators ([`crate::reference::planar::admittance`], SPEC §3.1)
//!    around the desired end-effector points `x_d,i = p_d + R(θ_d)(r_i − δ_i)`, fed with the
//!    unexpected force `LPF(F_i) − F_ref,i`; the object-level reference is their least-squares
//!    fit, with its exact rates ([`crate::model::planar::grasp::GraspSet::fit_pose_rates`]).
//! 4. `(x̂_o, ẋ̂_o, x_r, ẋ_r, ẍ_r) → τ`: the tracking law on the object (iBLF + adaptive NN
//!    ([`crate::control::law::adaptive`]), PD ([`crate::control::law::pd`], optionally plus the
//!    model's gravity `𝓖` of (14)) or computed torque ([`crate::control::law::ctc`])), selected
//!    by [`ControllerParams::law`] ([`Law<3>`](crate::control::law::Law)).
//! 5. `τ → τ_x,i → τ_joint,i = J_e,iᵀ τ_x,i`: wrench distribution with the internal squeeze
//!    ([`crate::model::planar::grasp::GraspSet::distribute`]) plus the internal part of the arms' own gravity
//!    (`P_N Ĝ_x`, so the squeeze is the commanded one); for redundant arms, damping and gravity
//!    compensation in the null space of `J_e`; then actuator limits.
//!
//! A tick allocates nothing and never emits NaN or infinity: a barrier hit saturates and is
//! counted, a non-finite law output is replaced by zero torque and counted.

use nalgebra::{Dim, Matrix, Matrix2, Rotation2, SVector, Storage, U2, Vector, Vector2, Vector3};

use crate::control::actuator::{Actuator, ActuatorParams};
use crate::control::law::Law;
use crate::control::law::adaptive::{AdaptiveNn, FuBound, NnInternals, Smoothing};
use crate::control::law::ctc::{Ctc, nominal_params};
use crate::control::law::pd::Pd;
use crate::drive::{ControlEvents, Drive, Measurements, Record};
use crate::dynamics::planar::{Arm, FixedKinematics, FixedLinkArm, TwoLinkArm};
use crate::error::{ModelError, non_negative, positive};
use crate::math::linalg::finite_slice;
use crate::model::planar::grasp::{Grasp, GraspSet};
use crate::plant::planar::reduced::ObjectSpace;
use crate::plant::planar::{Plant, PlantParams, PlantWorkspace};
use crate::reference::planar::admittance::{Admittance, AdmittanceParams, AdmittanceState};
use crate::reference::planar::path::Path;

use super::{ControlWarning, Scheme};

/// Joint damping of a redundant arm's self-motion (null space of `J_e`), N m s/rad.
pub const NULL_SPACE_DAMPING: f64 = 2.0;

/// Controller parameters (plain data; validated by [`Controller::new`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ControllerParams {
    /// The tracking law on the object's three outputs `(x, y, θ)`.
    pub law: Law<3>,
    /// Where it acts.
    pub scheme: Scheme,
    /// Output bounds `k_c` on `(x, y, θ)` of the object, (m, m, rad): `|x_1j| < k_cj`.
    pub k_c: [f64; 3],
    /// Admittance generator; `None` bypasses it (`x_r = x_d`).
    pub admittance: Option<AdmittanceParams>,
    /// Offset `δ` of each arm's desired point inside its grasp point, m (SPEC §3.1).
    pub delta: f64,
    /// Control period, s.
    pub control_period: f64,
    /// Joint torque limit (symmetric, every joint), N m; `None` = unlimited. The actuator
    /// stage's effort limit when [`ActuatorParams::effort`] is not given.
    pub torque_limit: Option<f64>,
    /// The actuator stage every law's torques go through (effort, rate limit, output filter;
    /// [`crate::control::actuator`]); all off by default.
    pub actuator: ActuatorParams,
    /// Known bound of the disturbance `|F_d,j|` (enters `f^U`, SPEC §3.4), (N, N, N m).
    pub disturbance_bound: [f64; 3],
}

/// Every arm must reach its grasp point along the whole desired path (sampled every 10 ms, at
/// most 20 000 samples) with a Jacobian away from singular (`σ_min ≥ 1e-3 m/rad`); otherwise an
/// error names the arm, the time and the distance.
fn check_path_reach(kin: &Plant, path: &Path, duration: f64) -> Result<(), ModelError> {
    let n = ((duration / 0.01).ceil() as usize).clamp(1, 20_000);
    for k in 0..=n {
        let t = duration * k as f64 / n as f64;
        let x = path.sample(t).p;
        for (i, (arm, g)) in kin.arms().iter().zip(kin.grasps()).enumerate() {
            let p = g.point(&x);
            let d = (p - arm.base()).norm();
            let reach = arm.reach();
            // 2-link arms: the analytic IK must exist and |det J_e| stay away from 0.
            let bad = d > reach
                || arm.two_link().is_some_and(|tl| {
                    tl.ik_pose(p)
                        .map_or(true, |pose| pose.J.determinant().abs() < 1e-6)
                });
            if bad {
                return Err(ModelError::geometry(
                    "path",
                    format!(
                        "at t = {t:.2} s the desired pose ({:.3}, {:.3}, {:.3}) puts arms[{i}]'s grasp point ({:.4}, {:.4}) m at {d:.4} m from its base; the arm reaches at most {reach:.4} m, and a 2-link arm must not be stretched straight (|det J_e| ≥ 1e-6)",
                        x.x, x.y, x.z, p.x, p.y
                    ),
                ));
            }
        }
    }
    Ok(())
}

impl ControllerParams {
    /// The paper scenario's settings with the given law (SPEC §3–4): object scheme, `k_c = 0.35`
    /// on every output, the SPEC §3.1 admittance defaults, `δ = 5 mm`, 1 kHz, no torque limit,
    /// the paper disturbance's bound.
    pub fn paper(law: Law<3>) -> Self {
        ControllerParams {
            law,
            scheme: Scheme::Object,
            k_c: [0.35; 3],
            admittance: Some(AdmittanceParams::default()),
            delta: 0.005,
            control_period: 1e-3,
            torque_limit: None,
            actuator: ActuatorParams::default(),
            disturbance_bound: crate::model::disturbance::Disturbance::paper().bound(),
        }
    }
}

/// The controller's internals at one tick (SPEC §5 columns). `Copy`, fixed size.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TickRecord {
    /// Estimated object pose `x_1 = x̂_o`.
    pub x_o: Vector3<f64>,
    /// Estimated object velocity `x_2`.
    pub xd_o: Vector3<f64>,
    /// Desired pose `x_d`.
    pub x_d: Vector3<f64>,
    /// Reference pose `x_r` from the admittance generators.
    pub x_r: Vector3<f64>,
    /// Reference velocity `ẋ_r`.
    pub xd_r: Vector3<f64>,
    /// `z1 = x_1 − x_r`.
    pub z1: Vector3<f64>,
    /// `z2 = x_2 − α` (NN) or `ż1` (PD, CTC).
    pub z2: Vector3<f64>,
    /// Virtual control `α` (NN; zero otherwise).
    pub alpha: Vector3<f64>,
    /// `α̇` (NN).
    pub alpha_dot: Vector3<f64>,
    /// Wrench `τ` commanded on the object, (N, N, N m).
    pub wrench: Vector3<f64>,
    /// Switching value `Q = M(Z)` (NN; 1 otherwise).
    pub q_switch: f64,
    /// Weight norms `‖Ŵ_j‖` (NN).
    pub w_norm: Vector3<f64>,
    /// Constraint margin `1 − max_j |x_1j|/k_cj` (negative = violated).
    pub margin: f64,
    /// This tick saturated the barrier (|x_1| or |x_r| at the bound).
    pub barrier_hit: bool,
    /// This tick clipped at least one joint torque.
    pub torque_clipped: bool,
    /// This tick replaced a non-finite law output or measurement.
    pub non_finite: bool,
}

impl TickRecord {
    /// Take the NN law's internals (3 outputs) into the record: `z2, α, α̇, ‖Ŵ‖`, `Q` (the
    /// smallest seen this tick) and the event flags (or-ed).
    fn note_nn(&mut self, o: &NnInternals<3>) {
        self.z2 = o.z2;
        self.alpha = o.alpha;
        self.alpha_dot = o.alpha_dot;
        self.w_norm = o.w_norm;
        self.q_switch = self.q_switch.min(o.q);
        self.barrier_hit |= o.barrier_hit;
        self.non_finite |= o.non_finite;
    }
}

/// The law a controller runs, validated, with its state: PD with the workspace of its gravity
/// term when it compensates gravity, computed torque with its nominal model.
enum Active {
    Nn(Box<AdaptiveNn>),
    Pd(Pd, Option<Box<PlantWorkspace>>),
    Ctc(Ctc, Box<Plant>, Box<PlantWorkspace>),
    PerArmPd(Pd),
    PerArmNn(Vec<AdaptiveNn<2>>),
}

/// The object-space terms `(𝓜, 𝓒, 𝓖)` of (14) of a controller's model at the estimated state
/// `(x_1, x_2)`: the nominal model's for computed torque, the controller's model's gravity
/// `𝓖` for PD with gravity compensation. `None`, counted as a degenerate tick, where the
/// reduced model cannot be evaluated (a grasp out of reach, a singular arm).
#[inline]
fn model_terms(
    model: &Plant,
    x1: &Vector3<f64>,
    x2: &Vector3<f64>,
    ws: &mut PlantWorkspace,
    events: &mut ControlEvents,
) -> Option<ObjectSpace> {
    match model.object_space(x1, x2, ws) {
        Ok(os) => Some(os),
        Err(_) => {
            events.degenerate += 1;
            None
        }
    }
}

/// One arm's kinematics kernel for the tick, selected once by [`Controller::new`] from its link
/// count, with what step 1 leaves for step 5: the 2-link closed forms (SPEC §2.1) and `J_e`;
/// the general algorithm in fixed-size types for 3 and 4 links
/// ([`FixedLinkArm::kinematics_gravity`]: `J_e` and `G(q)`, no `M` or `C`); other link counts
/// the dynamic-size [`Arm::kinematics`] and [`Arm::general_dynamics`] into the workspace's
/// [`ArmTerms`](crate::dynamics::planar::ArmTerms).
#[derive(Clone, Copy, Debug)]
enum ArmKernel {
    Two(TwoLinkArm, Matrix2<f64>),
    Three(FixedLinkArm<3>, FixedKinematics<3>),
    Four(FixedLinkArm<4>, FixedKinematics<4>),
    General,
}

/// An arm's part of the tick: its kernel, the index of its first joint in the stacked joint
/// vectors, and its end-effector position and velocity from step 1 (m, m/s).
#[derive(Clone, Copy, Debug)]
struct ArmSlot {
    kernel: ArmKernel,
    off: usize,
    p_ee: Vector2<f64>,
    v_ee: Vector2<f64>,
}

impl ArmSlot {
    fn new(arm: &Arm, off: usize) -> Self {
        let kernel = if let Some(tl) = arm.two_link() {
            ArmKernel::Two(*tl, Matrix2::zeros())
        } else if let Some(k) = arm.fixed::<3>() {
            ArmKernel::Three(k, k.kinematics_gravity([0.0; 3], [0.0; 3], 0.0))
        } else if let Some(k) = arm.fixed::<4>() {
            ArmKernel::Four(k, k.kinematics_gravity([0.0; 4], [0.0; 4], 0.0))
        } else {
            ArmKernel::General
        };
        ArmSlot {
            kernel,
            off,
            p_ee: Vector2::zeros(),
            v_ee: Vector2::zeros(),
        }
    }
}

/// `N` entries of `v` from `off`, as an array (one length check).
#[inline(always)]
fn joints<const N: usize>(v: &[f64], off: usize) -> [f64; N] {
    let s: &[f64; N] = v[off..off + N]
        .try_into()
        .expect("a slice of N entries converts to [f64; N]");
    *s
}

/// Step 5 for one arm (SPEC §3): `τ_joint = J_eᵀ τ_x`; an arm with more than two joints adds
/// damping and gravity compensation in the null space of `J_e`,
/// `τ_null = (I − J_eᵀ(J_eJ_eᵀ)⁻¹J_e)(−K_N q̇ + Ĝ(q))` (`K_N` = [`NULL_SPACE_DAMPING`]): the
/// commanded torques, before the actuator stage (a NaN is replaced by zero there; an infinite
/// one is clamped to the effort limit, or replaced by zero without one). `j` is 2 × n, `gq` has
/// n entries (read only when n > 2), `qd` and `tau` at least n. Generic over the column
/// dimension, so 2–4 links run with the link count a constant (no bounds checks) and other
/// counts on the dynamic-size terms, with the same operations in the same order.
#[inline(always)]
fn joint_torques<C: Dim, SJ: Storage<f64, U2, C>, SG: Storage<f64, C>>(
    j: &Matrix<f64, U2, C, SJ>,
    gq: &Vector<f64, C, SG>,
    qd: &[f64],
    tau_x: Vector2<f64>,
    tau: &mut [f64],
) {
    let n = j.ncols();
    let (qd, tau) = (&qd[..n], &mut tau[..n]);
    let mut w_null = Vector2::zeros();
    if n > 2 {
        let (mut a, mut b, mut d) = (0.0, 0.0, 0.0);
        let mut ju = Vector2::zeros();
        for k in 0..n {
            let (jx, jy) = (j[(0, k)], j[(1, k)]);
            a += jx * jx;
            b += jx * jy;
            d += jy * jy;
            let u = -NULL_SPACE_DAMPING * qd[k] + gq[k];
            ju += Vector2::new(jx, jy) * u;
        }
        let det = a * d - b * b;
        if det.abs() > 1e-12 {
            w_null = Vector2::new(d * ju.x - b * ju.y, a * ju.y - b * ju.x) / det;
        }
    }
    for k in 0..n {
        let mut v = j[(0, k)] * tau_x.x + j[(1, k)] * tau_x.y;
        if n > 2 {
            let u = -NULL_SPACE_DAMPING * qd[k] + gq[k];
            v += u - (j[(0, k)] * w_null.x + j[(1, k)] * w_null.y);
        }
        tau[k] = v;
    }
}

/// A cooperative controller: validated gains and models, its own state (admittance, weights),
/// and preallocated scratch. Build once, then call [`Controller::tick`] at the control rate.
pub struct Controller {
    kin: Plant,
    /// The actual grasps `r_i` (estimation, distribution).
    set: GraspSet,
    /// The desired points `r_i − δ_i` (reference fit).
    set_d: GraspSet,
    path: Path,
    adm: Option<Admittance>,
    adm_state: Vec<AdmittanceState>,
    squeeze: f64,
    law: Active,
    k_c: Vector3<f64>,
    h: f64,
    /// The actuator stage (effort from `torque_limit` unless given, rate limit, filter).
    actuator: Actuator,
    /// The commanded torques of the last tick, N m (before the actuator stage).
    tau_cmd: Vec<f64>,
    events: ControlEvents,
    theta_hint: f64,
    theta_r_hint: f64,
    /// `(θ_d, R(θ_d))` of the last tick: a path with a constant angle needs no `sin_cos`.
    rot_d: (f64, Rotation2<f64>),
    /// Each arm's kinematics kernel and step-1 results.
    arm_slots: Vec<ArmSlot>,
    // Scratch (`ws.terms[i]`: arms on the dynamic-size route).
    ws: PlantWorkspace,
    pts: Vec<Vector2<f64>>,
    vels: Vec<Vector2<f64>>,
    acc: Vec<Vector2<f64>>,
    tau_x: Vec<Vector2<f64>>,
    f_ref: Vec<Vector2<f64>>,
    ref_p: Vec<Vector2<f64>>,
    ref_v: Vec<Vector2<f64>>,
    ref_a: Vec<Vector2<f64>>,
    /// Each arm's Cartesian gravity `Ĝ_x,i = J_e⁻ᵀ Ĝ(q)` from the model, N (2-link arms).
    g_x: Vec<Vector2<f64>>,
    scratch: Vec<Vector2<f64>>,
}

impl Controller {
    /// Build a controller from its parameters, the controller's model of the set-up (`model`:
    /// arm kinematics and grasps are taken as known; dynamics are used only where a law needs a
    /// model — the expected force `F_ref`, the bound `f^U`, computed torque), the desired path
    /// and the run's duration (to check the path against `k_c`).
    pub fn new(
        p: &ControllerParams,
        model: &PlantParams,
        path: Path,
        duration: f64,
    ) -> Result<(Self, Vec<ControlWarning>), ModelError> {
        let kin = Plant::new(model)?;
        let h = positive("control_period", p.control_period)?;
        let delta = non_negative("delta", p.delta)?;
        let mut k_c = Vector3::zeros();
        for j in 0..3 {
            k_c[j] = positive(&format!("k_c[{j}]"), p.k_c[j])?;
            non_negative(&format!("disturbance_bound[{j}]"), p.disturbance_bound[j])?;
        }
        // The arms must reach the path (checked first: an unreachable path is the root cause
        // whatever the bounds), then the path must stay strictly inside the bound (iBLF needs
        // |x_r| < k_c).
        check_path_reach(&kin, &path, duration)?;
        let peak = path.max_abs(duration);
        let unit = ["m", "m", "rad"];
        let short: Vec<String> = (0..3)
            .filter(|&j| !(peak[j] < k_c[j]))
            .map(|j| {
                format!(
                    "k_c[{j}] = {} ≤ max |x_d,{j}| = {:.4} {}",
                    k_c[j], peak[j], unit[j]
                )
            })
            .collect();
        if let Some(j) = (0..3).find(|&j| !(peak[j] < k_c[j])) {
            return Err(ModelError::invalid(
                format!("k_c[{j}]"),
                k_c[j],
                format!(
                    "every bound must lie above the desired path's largest excursion over the run: {}",
                    short.join("; ")
                ),
            ));
        }
        let torque_limit = match p.torque_limit {
            Some(l) => Some(positive("torque_limit", l)?),
            None => None,
        };
        let mut act = p.actuator.clone();
        if act.effort.is_none() {
            act.effort = torque_limit.map(|l| vec![l; kin.n_q()]);
        }
        let n_q = kin.n_q();
        let actuator = Actuator::new(&act, n_q, h)?;
        let grasps: Vec<Grasp> = kin.grasps().to_vec();
        for (i, g) in grasps.iter().enumerate() {
            if g.r.norm() <= delta {
                return Err(ModelError::invalid(
                    "delta",
                    delta,
                    format!(
                        "must be smaller than grasp {i}'s distance from the object centre ({:.4} m)",
                        g.r.norm()
                    ),
                ));
            }
        }
        if grasps.len() < 2 {
            return Err(ModelError::geometry(
                "grasps",
                "the object-level scheme needs at least two grasps",
            ));
        }
        let grasps_d: Vec<Grasp> = grasps
            .iter()
            .map(|g| Grasp {
                r: g.r * (1.0 - delta / g.r.norm()),
            })
            .collect();
        let degenerate = || {
            ModelError::geometry(
                "grasps",
                "the grasp points do not determine the object's motion (they coincide)",
            )
        };
        let set_d = GraspSet::new(grasps_d).ok_or_else(degenerate)?;
        let mut warnings = Vec::new();
        let (adm, squeeze) = match &p.admittance {
            Some(a) => {
                let (adm, w) = Admittance::new(a, h)?;
                warnings.extend(w.into_iter().map(ControlWarning::Admittance));
                // Internal force of about K_e δ (SPEC §3.1), commanded along the null space in the
                // object scheme. In the per-arm scheme the offsets δ_i already squeeze (SPEC
                // §3.2), so nothing is added (it would squeeze twice).
                let s = if p.scheme == Scheme::PerArm {
                    0.0
                } else {
                    a.k_e[0] * delta
                };
                (Some(adm), s)
            }
            None => (None, 0.0),
        };
        let law = match (&p.law, p.scheme) {
            (Law::Pd(g), Scheme::Object) => {
                let pd = Pd::new(g)?;
                let gravity = if g.gravity_compensation {
                    if let Some(i) = kin.arms().iter().position(|a| a.dof() != 2) {
                        return Err(ModelError::geometry(
                            format!("arms[{i}]"),
                            "PD gravity compensation adds 𝓖 of the reduced model (14), which needs 2-link arms",
                        ));
                    }
                    Some(Box::new(kin.workspace()))
                } else {
                    None
                };
                Active::Pd(pd, gravity)
            }
            (Law::Pd(g), Scheme::PerArm) => {
                let pd = Pd::new(g)?;
                if g.gravity_compensation {
                    return Err(ModelError::geometry(
                        "gains.gravity_compensation",
                        "PD gravity compensation is implemented for the object scheme only",
                    ));
                }
                Active::PerArmPd(pd)
            }
            (Law::Ctc(g), Scheme::Object) => {
                let ctc = Ctc::new(g)?;
                let nominal = Plant::new(&nominal_params(model, g.model_error))?;
                if nominal.arms().iter().any(|a| a.dof() != 2) {
                    return Err(ModelError::geometry(
                        "law",
                        "computed torque uses the reduced model (14), which needs 2-link arms",
                    ));
                }
                let ws = nominal.workspace();
                Active::Ctc(ctc, Box::new(nominal), Box::new(ws))
            }
            (Law::Ctc(_), Scheme::PerArm) => {
                return Err(ModelError::geometry(
                    "scheme",
                    "computed torque is implemented for the object scheme only",
                ));
            }
            (Law::Nn(g), Scheme::Object) => {
                if let Some(i) = kin.arms().iter().position(|a| a.dof() != 2) {
                    return Err(ModelError::geometry(
                        format!("arms[{i}]"),
                        "the NN law's bound f^U is built from the object-space model (14), which needs 2-link arms; with other arms use the PD law",
                    ));
                }
                let fu = FuBound::from_model(&kin, k_c, p.disturbance_bound, g.fu_safety)?;
                // SPEC §3.4: with the nearly constant basis the NN is an adaptive bias, and the
                // linearised loop 𝓜s³ + K2 s² + (K2 K1 + γ)s + γK1 needs roughly K2 > 𝓜 K1.
                // c_j/safety bounds the row norm of 𝓜 over the box (≥ 𝓜_jj).
                for j in 0..3 {
                    let m_j = fu.c[j] / g.fu_safety;
                    if g.k2[j] < m_j * g.k1[j] {
                        warnings.push(ControlWarning::Gain {
                            param: format!("gains.k2[{j}]"),
                            reason: format!(
                                "K2 = {} is below 𝓜 K1 ≈ {} (𝓜 up to {} over the constraint box, K1 = {}): the linearised z2 loop needs roughly K2 > 𝓜 K1 (SPEC §3.4); expect a limit cycle (the paper's gains end in one)",
                                g.k2[j],
                                crate::error::fmt_fixed(m_j * g.k1[j], 0),
                                crate::error::fmt_fixed(m_j, 2),
                                g.k1[j]
                            ),
                        });
                    }
                }
                let mut nn = AdaptiveNn::new(g, k_c, fu, h)?;
                // The sampled-data boundary layer of the robust term (`smoothing = "sampled"`,
                // docs/smooth-nn.md) on the lightest effective inertia over the box.
                if g.smoothing == Smoothing::Sampled {
                    nn.set_sampling_inertia(FuBound::lightest_inertia(&kin, k_c));
                }
                // Anti-windup on the 𝓜 bound of each output (the z2 loop's inertia).
                if p.actuator.anti_windup_on() {
                    nn.set_anti_windup_inertia(std::array::from_fn(|j| nn.fu().c[j] / g.fu_safety));
                }
                Active::Nn(Box::new(nn))
            }
            (Law::Nn(g), Scheme::PerArm) => {
                if g.smoothing == Smoothing::Sampled {
                    return Err(ModelError::geometry(
                        "gains.smoothing",
                        "\"sampled\" is implemented for the object scheme only (the per-arm scheme has no lightest-inertia bound yet); use \"paper\"",
                    ));
                }
                let mut nets = Vec::new();
                for (i, arm) in kin.arms().iter().enumerate() {
                    if arm.dof() != 2 {
                        return Err(ModelError::geometry(
                            format!("arms[{i}]"),
                            "the per-arm NN law needs 2-link arms (Cartesian dynamics (3))",
                        ));
                    }
                    let r = grasps[i].r.norm();
                    let kb = Vector2::new(k_c.x + r, k_c.y + r);
                    let fu = FuBound::from_arm(
                        &kin,
                        i,
                        kb,
                        [p.disturbance_bound[0], p.disturbance_bound[1]],
                        g.fu_safety,
                    )?;
                    // The planar gains are validated on all three outputs; the arm runs x, y.
                    g.validate_outputs()?;
                    nets.push(AdaptiveNn::<2>::new(&g.outputs::<2>(), kb, fu, h)?);
                }
                Active::PerArmNn(nets)
            }
        };
        let m = grasps.len();
        let ws = kin.workspace();
        let arm_slots = kin
            .arms()
            .iter()
            .enumerate()
            .map(|(i, a)| ArmSlot::new(a, kin.offset(i)))
            .collect();
        Ok((
            Controller {
                kin,
                set: GraspSet::new(grasps).ok_or_else(degenerate)?,
                set_d,
                path,
                adm,
                adm_state: vec![AdmittanceState::default(); m],
                squeeze,
                law,
                k_c,
                h,
                tau_cmd: vec![0.0; n_q],
                actuator,
                events: ControlEvents::default(),
                theta_hint: 0.0,
                theta_r_hint: 0.0,
                rot_d: (0.0, Rotation2::identity()),
                arm_slots,
                ws,
                pts: vec![Vector2::zeros(); m],
                vels: vec![Vector2::zeros(); m],
                acc: vec![Vector2::zeros(); m],
                tau_x: vec![Vector2::zeros(); m],
                f_ref: vec![Vector2::zeros(); m],
                ref_p: vec![Vector2::zeros(); m],
                ref_v: vec![Vector2::zeros(); m],
                ref_a: vec![Vector2::zeros(); m],
                g_x: vec![Vector2::zeros(); m],
                scratch: vec![Vector2::zeros(); m],
            },
            warnings,
        ))
    }

    /// Control period, s.
    pub fn period(&self) -> f64 {
        self.h
    }
    /// Event counters since the start.
    pub fn events(&self) -> ControlEvents {
        self.events
    }
    /// Output bounds `k_c`.
    pub fn k_c(&self) -> Vector3<f64> {
        self.k_c
    }
    /// The internal squeeze force commanded, N.
    pub fn squeeze(&self) -> f64 {
        self.squeeze
    }
    /// The desired path.
    pub fn path(&self) -> &Path {
        &self.path
    }
    /// The adaptive law, when this controller runs one (for inspection and tests).
    pub fn adaptive(&self) -> Option<&AdaptiveNn> {
        match &self.law {
            Active::Nn(nn) => Some(nn),
            _ => None,
        }
    }

    /// The adaptive law, mutable (to switch its anti-windup off for a comparison).
    pub fn adaptive_mut(&mut self) -> Option<&mut AdaptiveNn> {
        match &mut self.law {
            Active::Nn(nn) => Some(nn),
            _ => None,
        }
    }
    /// The actuator stage (its limits and the ticks each acted on).
    pub fn actuator(&self) -> &Actuator {
        &self.actuator
    }
    /// Replace the actuator stage between ticks (to lift a limit mid-run): the new stage starts
    /// from its first command; `p.effort = None` means no effort limit (not `torque_limit`).
    /// Errors name the field as [`ActuatorParams::validate`].
    pub fn set_actuator(&mut self, p: &ActuatorParams) -> Result<(), ModelError> {
        self.actuator = Actuator::new(p, self.tau_cmd.len(), self.h)?;
        Ok(())
    }

    /// Start (or restart) at time `t0`: admittance offsets at rest, each force filter started at
    /// its expected force `F_ref,i(t0)` (SPEC §3.1), the pose estimate's angle branch set from
    /// the measurements. Adaptive weights are kept (call [`Controller::reset_weights`] to zero
    /// them).
    pub fn start(&mut self, t0: f64, meas: &Measurements) {
        let s = self.path.sample(t0);
        self.expected_forces(&crate::math::trig::rotation2(s.p.z), &s.v, &s.a);
        for (st, f) in self.adm_state.iter_mut().zip(&self.f_ref) {
            *st = AdmittanceState::with_filter_at(*f);
        }
        self.theta_hint = s.p.z;
        self.theta_r_hint = s.p.z;
        self.estimate(meas);
        self.actuator.reset();
        self.events = ControlEvents::default();
    }

    /// Zero the adaptive weights (NN law).
    pub fn reset_weights(&mut self) {
        if let Active::Nn(nn) = &mut self.law {
            nn.reset_weights();
        }
    }

    /// `F_ref,i`: minus arm i's share of the nominal wrench `M_o ẍ_d + C_o ẋ_d + G_o` plus the
    /// squeeze reaction (SPEC §3.1), into `self.f_ref`.
    fn expected_forces(
        &mut self,
        rot_d: &Rotation2<f64>,
        xd_d: &Vector3<f64>,
        xdd_d: &Vector3<f64>,
    ) {
        let o = self.kin.object();
        let w = o.M_o * xdd_d + o.C_o * xd_d + o.G_o;
        self.set
            .distribute(rot_d, &w, self.squeeze, &mut self.tau_x);
        for (f, t) in self.f_ref.iter_mut().zip(&self.tau_x) {
            *f = -t;
        }
    }

    /// Object pose and velocity from the encoders (step 1). Returns false if degenerate.
    #[inline]
    fn estimate(
        &mut self,
        meas: &Measurements,
    ) -> Option<(Vector3<f64>, Vector3<f64>, Rotation2<f64>)> {
        let g = self.kin.gravity();
        for (i, a) in self.arm_slots.iter_mut().enumerate() {
            let off = a.off;
            match &mut a.kernel {
                ArmKernel::Two(tl, j) => {
                    // Fast path: one sin_cos per link; J_e kept for step 5.
                    let pose = tl.pose(joints(meas.q, off));
                    let qd = Vector2::from(joints::<2>(meas.qd, off));
                    a.p_ee = tl.end_effector(&pose);
                    a.v_ee = pose.J * qd;
                    // Ĝ_x = J_e⁻ᵀ Ĝ(q) (3)–(4), for the internal-force feed-forward of step 5.
                    let gq = tl.terms(&pose, [0.0, 0.0], g).G;
                    // (nalgebra's LU of J_eᵀ in the same operations, `linalg::lu_solve_2x2`.)
                    self.g_x[i] = crate::math::linalg::lu_solve_2x2(&pose.J.transpose(), &gq)
                        .filter(|v| v.x.is_finite() & v.y.is_finite())
                        .unwrap_or_else(Vector2::zeros);
                    *j = pose.J;
                }
                ArmKernel::Three(arm, k) => {
                    *k = arm.kinematics_gravity(joints(meas.q, off), joints(meas.qd, off), g);
                    (a.p_ee, a.v_ee) = (k.p_ee, k.v_ee);
                }
                ArmKernel::Four(arm, k) => {
                    *k = arm.kinematics_gravity(joints(meas.q, off), joints(meas.qd, off), g);
                    (a.p_ee, a.v_ee) = (k.p_ee, k.v_ee);
                }
                ArmKernel::General => {
                    let arm = &self.kin.arms()[i];
                    let n = arm.dof();
                    let t = &mut self.ws.terms[i];
                    arm.kinematics(&meas.q[off..off + n], &meas.qd[off..off + n], t);
                    (a.p_ee, a.v_ee) = (t.p_ee, t.v_ee);
                }
            }
            self.pts[i] = a.p_ee;
            self.vels[i] = a.v_ee;
        }
        let (x, rot) = self.set.fit_pose(&self.pts, self.theta_hint);
        let v = self.set.fit_velocity(&rot, &self.vels);
        self.theta_hint = x.z;
        Some((x, v, rot))
    }

    /// One control tick at time `t`: `(t, q, q̇, F) → τ_joint` (written into `tau`, n_q) and the
    /// internals into `rec`. No allocation; never writes NaN or infinity into `tau`.
    pub fn tick(&mut self, t: f64, meas: &Measurements, tau: &mut [f64], rec: &mut TickRecord) {
        *rec = TickRecord {
            q_switch: 1.0,
            ..TickRecord::default()
        };
        // 1. Estimate.
        let Some((x1, x2, rot1)) = self.estimate(meas) else {
            self.events.degenerate += 1;
            tau.fill(0.0);
            return;
        };
        if !(finite_slice(x1.as_slice()) & finite_slice(x2.as_slice())) {
            self.events.non_finite += 1;
            rec.non_finite = true;
            tau.fill(0.0);
            return;
        }
        // 2. Desired path.
        let s = self.path.sample(t);
        // 3. Reference: admittance around x_d,i, fitted back to the object.
        let (x_r, xd_r, xdd_r) = self.reference(&s.p, &s.v, &s.a, meas, rec);
        // 4. Tracking law → wrench on the object.
        let z1 = x1 - x_r;
        let z1_dot = x2 - xd_r;
        let per_arm = matches!(self.law, Active::PerArmPd(_) | Active::PerArmNn(_));
        let mut w = match &mut self.law {
            Active::Pd(pd, gravity) => {
                rec.z2 = z1_dot;
                let w = pd.wrench(&z1, &z1_dot);
                // With gravity compensation, + 𝓖 of the controller's model (14); where that
                // model fails, plain PD (counted as degenerate).
                match gravity {
                    None => w,
                    Some(ws) => match model_terms(&self.kin, &x1, &x2, ws, &mut self.events) {
                        Some(os) => w + os.G,
                        None => w,
                    },
                }
            }
            Active::Ctc(ctc, nominal, ws) => {
                rec.z2 = z1_dot;
                let a = ctc.acceleration(&xdd_r, &z1, &z1_dot);
                match model_terms(nominal, &x1, &x2, ws, &mut self.events) {
                    Some(os) => os.M * a + os.C * x2 + os.G,
                    None => Vector3::zeros(),
                }
            }
            Active::Nn(nn) => {
                let mut o = NnInternals::default();
                let w = nn.wrench(&x1, &x2, &x_r, &xd_r, &xdd_r, &mut o);
                rec.note_nn(&o);
                w
            }
            Active::PerArmPd(_) | Active::PerArmNn(_) => {
                rec.z2 = z1_dot;
                self.per_arm_forces(rec);
                // The wrench the arms' commands put on the object (for the record).
                let mut w = Vector3::zeros();
                for (g, t) in self.set.grasps().iter().zip(&self.tau_x) {
                    w += Grasp::jacobian_from_arm(rot1 * g.r).transpose() * t;
                }
                w
            }
        };
        if !finite_slice(w.as_slice()) {
            rec.non_finite = true;
            w = Vector3::zeros();
        }
        rec.x_o = x1;
        rec.xd_o = x2;
        rec.x_d = s.p;
        rec.x_r = x_r;
        rec.xd_r = xd_r;
        rec.z1 = z1;
        rec.wrench = w;
        // (x1 is finite here and k_c > 0: the smallest of three numbers, no NaN handling.)
        rec.margin = (0..3)
            .map(|j| 1.0 - x1[j].abs() / self.k_c[j])
            .fold(f64::INFINITY, |m, v| if v < m { v } else { m });
        // 5. Distribute (object scheme) and map to joints.
        if !per_arm {
            self.set
                .distribute(&rot1, &w, self.squeeze, &mut self.tau_x);
            // The arms' own gravity has an internal (null-space) part that no object wrench
            // commands: without this feed-forward it adds to the squeeze (2–7 N on the paper's
            // path) and the admittance yields to it. τ_x += P_N Ĝ_x, P_N Ĝ_x = Ĝ_x − (𝐉ᵀ)⁺𝐉ᵀĜ_x.
            let mut jt_g = Vector3::zeros();
            for (g, gx) in self.set.grasps().iter().zip(&self.g_x) {
                jt_g += Grasp::jacobian_from_arm(rot1 * g.r).transpose() * gx;
            }
            self.set.distribute(&rot1, &jt_g, 0.0, &mut self.scratch);
            for ((t, gx), r) in self.tau_x.iter_mut().zip(&self.g_x).zip(&self.scratch) {
                *t += gx - r;
            }
        }
        // The torque map of each arm on the kernel selected at set-up (2–4 links: fixed size).
        let g = self.kin.gravity();
        for (i, a) in self.arm_slots.iter().enumerate() {
            let (off, tx) = (a.off, self.tau_x[i]);
            let (qd, out) = (&meas.qd[off..], &mut tau[off..]);
            match &a.kernel {
                ArmKernel::Two(_, j) => joint_torques(j, &Vector2::zeros(), qd, tx, out),
                ArmKernel::Three(_, k) => joint_torques(&k.j, &k.gravity, qd, tx, out),
                ArmKernel::Four(_, k) => joint_torques(&k.j, &k.gravity, qd, tx, out),
                ArmKernel::General => {
                    let arm = &self.kin.arms()[i];
                    let t = &mut self.ws.terms[i];
                    if arm.dof() > 2 {
                        arm.general_dynamics(g, t);
                    }
                    joint_torques(&t.J, &t.G, qd, tx, out)
                }
            }
        }
        // The actuator stage: the law's torques → the applied ones.
        rec.torque_clipped |= crate::control::actuator::actuate(
            &mut self.actuator,
            tau,
            &mut self.tau_cmd,
            &mut self.events,
        );
        if matches!(self.law, Active::Nn(_)) {
            let d = self.deficit_wrench(&rot1, tau);
            if let Active::Nn(nn) = &mut self.law {
                nn.anti_windup(&d);
            }
        }
        if rec.barrier_hit {
            self.events.barrier_hits += 1;
        }
        if rec.torque_clipped {
            self.events.torque_clips += 1;
        }
        if rec.non_finite {
            self.events.non_finite += 1;
        }
    }

    /// The actuator's deficit `δτ_q = τ_applied − τ_cmd` of this tick as an object wrench,
    /// with the maps of (14) the wrench was distributed with: per arm `δτ_x,i = J_e,i⁻ᵀ δτ_q,i`
    /// (2-link arms, the NN law's), then `δ𝓣 = Σ_i 𝐉_iᵀ δτ_x,i` (the grasp maps at the
    /// estimated angle; the internal part of the deficit puts no wrench on the object). Zero
    /// where nothing was limited.
    fn deficit_wrench(&self, rot1: &Rotation2<f64>, tau: &[f64]) -> Vector3<f64> {
        let mut d = Vector3::zeros();
        for (a, g) in self.arm_slots.iter().zip(self.set.grasps()) {
            let ArmKernel::Two(_, j) = &a.kernel else {
                continue;
            };
            let off = a.off;
            let dq = Vector2::new(
                tau[off] - self.tau_cmd[off],
                tau[off + 1] - self.tau_cmd[off + 1],
            );
            if dq == Vector2::zeros() {
                continue;
            }
            if let Some(dx) = crate::math::linalg::lu_solve_2x2(&j.transpose(), &dq)
                .filter(|v| v.x.is_finite() & v.y.is_finite())
            {
                d += Grasp::jacobian_from_arm(rot1 * g.r).transpose() * dx;
            }
        }
        d
    }

    /// Per-arm scheme, step 4: each arm's law on its end-effector tracks `x_r,i`, with the
    /// *expected* grasp force fed forward (`τ_x,i = law − F_ref,i`, cancelling the nominal `F_i`
    /// in (3)). Feeding the *measured* force forward closes an algebraic loop through the rigid
    /// grasp (the internal force responds one-to-one to the commands: per-tick gain ≈ 1); it
    /// diverged within 1 ms in tandem's runs, so it is not offered. Writes `τ_x,i`.
    fn per_arm_forces(&mut self, rec: &mut TickRecord) {
        let mut sub = NnInternals::<2>::default();
        let mut wn = Vector3::zeros();
        for i in 0..self.tau_x.len() {
            let a = &self.arm_slots[i];
            let (x1, x2) = (a.p_ee, a.v_ee);
            let (xr, xdr, xddr) = (self.ref_p[i], self.ref_v[i], self.ref_a[i]);
            let law = match &mut self.law {
                Active::PerArmPd(pd) => {
                    let (kp, kd) = pd.gains();
                    -Vector2::new(kp.x, kp.y).component_mul(&(x1 - xr))
                        - Vector2::new(kd.x, kd.y).component_mul(&(x2 - xdr))
                }
                Active::PerArmNn(nets) => {
                    let v = |a: Vector2<f64>| SVector::<f64, 2>::new(a.x, a.y);
                    let f = nets[i].wrench(&v(x1), &v(x2), &v(xr), &v(xdr), &v(xddr), &mut sub);
                    for j in 0..2 {
                        wn[j] += sub.w_norm[j] * sub.w_norm[j];
                    }
                    rec.barrier_hit |= sub.barrier_hit;
                    rec.non_finite |= sub.non_finite;
                    rec.q_switch = rec.q_switch.min(sub.q);
                    Vector2::new(f[0], f[1])
                }
                _ => Vector2::zeros(),
            };
            self.tau_x[i] = law - self.f_ref[i];
        }
        rec.w_norm = wn.map(f64::sqrt);
    }

    /// Step 3: the reference `(x_r, ẋ_r, ẍ_r)` at this tick. Uses the generators' state
    /// before the update (no direct feed-through of this tick's force), then advances them.
    fn reference(
        &mut self,
        x_d: &Vector3<f64>,
        xd_d: &Vector3<f64>,
        xdd_d: &Vector3<f64>,
        meas: &Measurements,
        rec: &mut TickRecord,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        if self.rot_d.0 != x_d.z {
            self.rot_d = (x_d.z, crate::math::trig::rotation2(x_d.z));
        }
        let rot = self.rot_d.1;
        self.expected_forces(&rot, xd_d, xdd_d);
        let p_d = Vector2::new(x_d.x, x_d.y);
        for (i, g) in self.set_d.grasps().iter().enumerate() {
            let rw = rot * g.r;
            let j = Grasp::jacobian_from_arm(rw);
            // x_d,i and its derivatives: ẍ_d,i = J ẍ_d + J̇ ẋ_d, J̇ ẋ = −R r θ̇².
            let mut p = p_d + rw;
            let mut v = j * xd_d;
            let mut a = j * xdd_d - rw * (xd_d.z * xd_d.z);
            if let Some(adm) = &self.adm {
                let st = &mut self.adm_state[i];
                a += adm.e_ddot(st, self.f_ref[i]);
                p += st.e;
                v += st.e_dot;
                if !adm.step(st, meas.force(i), self.f_ref[i]) {
                    rec.non_finite = true;
                }
            }
            self.pts[i] = p;
            self.vels[i] = v;
            self.acc[i] = a;
            self.ref_p[i] = p;
            self.ref_v[i] = v;
            self.ref_a[i] = a;
        }
        if self.adm.is_none() {
            return (*x_d, *xd_d, *xdd_d);
        }
        // The object-level reference and its exact rates (SPEC §3.3 needs α̇ exact: ẋ_r, ẍ_r
        // must be the derivatives of x_r, also while the reference points deform).
        let (x_r, xd_r, xdd_r, _) =
            self.set_d
                .fit_pose_rates(&self.pts, &self.vels, &self.acc, self.theta_r_hint);
        self.theta_r_hint = x_r.z;
        (x_r, xd_r, xdd_r)
    }

    /// Expected grasp forces `F_ref,i` of the last tick (N), for logging.
    pub fn expected(&self) -> &[Vector2<f64>] {
        &self.f_ref
    }
    /// Admittance offsets `e_i` of every arm (m), for logging.
    pub fn admittance_offsets(&self) -> impl Iterator<Item = Vector2<f64>> + '_ {
        self.adm_state.iter().map(|s| s.e)
    }
}

const AX: [&str; 3] = ["x", "y", "theta"];

/// The planar record groups in log order (SPEC §5): name, units of `(x, y)` and `θ`.
const HEAD: [(&str, &str, &str); 9] = [
    ("x_hat", "m", "rad"),
    ("x_d", "m", "rad"),
    ("x_r", "m", "rad"),
    ("z1", "m", "rad"),
    ("z2", "m/s", "rad/s"),
    ("alpha", "m/s", "rad/s"),
    ("alpha_dot", "m/s^2", "rad/s^2"),
    ("tau", "N", "N m"),
    ("w_norm", "1", "1"),
];

impl TickRecord {
    fn groups(&self) -> [&nalgebra::Vector3<f64>; 9] {
        [
            &self.x_o,
            &self.x_d,
            &self.x_r,
            &self.z1,
            &self.z2,
            &self.alpha,
            &self.alpha_dot,
            &self.wrench,
            &self.w_norm,
        ]
    }
}

/// The planar controller's record: head `x_hat … w_norm` (SPEC §5), tail `Q`, `margin`.
impl Record for TickRecord {
    fn head_columns(&self) -> Vec<(String, String)> {
        let mut l = Vec::with_capacity(27);
        for (g, m, r) in HEAD {
            for (j, a) in AX.iter().enumerate() {
                l.push((format!("{g}.{a}"), if j < 2 { m } else { r }.to_string()));
            }
        }
        l
    }
    fn tail_columns(&self) -> Vec<(String, String)> {
        vec![("Q".into(), "1".into()), ("margin".into(), "1".into())]
    }
    fn write_head(&self, out: &mut [f64]) {
        for (g, v) in self.groups().iter().enumerate() {
            out[3 * g..3 * g + 3].copy_from_slice(v.as_slice());
        }
    }
    fn write_tail(&self, out: &mut [f64]) {
        out[0] = self.q_switch;
        out[1] = self.margin;
    }
    fn non_finite(&self) -> Option<String> {
        // One pass without early exit over every value (the common case: all finite): a sum
        // of `0 · x` is ±0 unless some `x` is NaN or infinite.
        let mut z = 0.0 * self.q_switch + 0.0 * self.margin;
        for v in self.groups() {
            z += 0.0 * v.x + 0.0 * v.y + 0.0 * v.z;
        }
        if z == 0.0 && !self.non_finite {
            return None;
        }
        for ((name, _, _), v) in HEAD.iter().zip(self.groups()) {
            if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                return Some(format!("{name}.{}", AX[j]));
            }
        }
        if !self.q_switch.is_finite() {
            return Some("Q".into());
        }
        if !self.margin.is_finite() {
            return Some("margin".into());
        }
        if self.non_finite {
            return Some("a controller input or output (replaced by the controller)".into());
        }
        None
    }
}

/// The margin `1 − max_j |x_o,j|/k_cj` of a planar state's true pose.
pub(crate) fn planar_margin(plant: &Plant, y: &[f64], k_c: &nalgebra::Vector3<f64>) -> f64 {
    let n = plant.n_q();
    (0..3)
        .map(|j| 1.0 - y[n + j].abs() / k_c[j])
        .fold(f64::INFINITY, f64::min)
}

/// tandem's planar cooperative controller (SPEC §3) as a driver.
impl Drive<Plant> for Controller {
    type Record = TickRecord;
    fn new_record(&self) -> TickRecord {
        TickRecord::default()
    }
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        Controller::start(self, t0, meas);
    }
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut TickRecord) {
        Controller::tick(self, t, meas, tau, rec);
    }
    fn events(&self) -> ControlEvents {
        Controller::events(self)
    }
    fn joint_limit_counts(&self) -> Option<(&[u64], &[u64])> {
        let c = self.actuator.counts();
        Some((&c.rate_per_joint, &c.effort_per_joint))
    }
    fn truth_margin(&self, plant: &Plant, y: &[f64]) -> Option<f64> {
        Some(planar_margin(plant, y, &self.k_c()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::law::pd::PdGains;
    use crate::math::random::SplitMix64;
    use crate::model::planar::arm::{ArmParams, Elbow, LinkParams};
    use crate::presets;

    /// Two 4-link arms (0.15 m links) on the paper's box, and an IK guess at the start pose.
    fn four_link_pair() -> (PlantParams, Vec<f64>) {
        let arm = |x: f64, elbow| ArmParams {
            base: [x, 0.0],
            base_angle: 0.0,
            links: [(1.5, 0.02), (1.0, 0.01), (0.7, 0.007), (0.5, 0.005)]
                .iter()
                .map(|&(mass, inertia)| LinkParams {
                    mass,
                    length: 0.15,
                    com: 0.075,
                    inertia,
                })
                .collect(),
            elbow,
        };
        let mut p = PlantParams::paper();
        p.arms = vec![arm(-0.38, Elbow::Negative), arm(0.38, Elbow::Positive)];
        let guess = vec![0.748, -1.495, 0.748, 0.0, -1.008, 2.017, 2.133, 0.0];
        (p, guess)
    }

    #[test]
    fn fixed_size_arm_kernels_tick_bit_for_bit_as_the_dynamic_route() {
        // The tick with each arm on its fixed-size kernel (3 and 4 links) against the same
        // controller forced onto the dynamic-size route (`ArmTerms`, the fallback for other
        // link counts): the same operations in the same order, so every torque and every
        // recorded value must be the same bits. PD on the object and per arm, with a torque
        // limit so the clamp runs (it clips at least one torque in 25–85 % of the ticks); 200
        // ticks at joint angles within ±2e-4 rad of the start pose, rates within ±0.01 rad/s
        // and grasp forces within ±3 N, drawn afresh each tick.
        let (p3, g3) = presets::redundant_pair();
        let (p4, g4) = four_link_pair();
        for (name, model, guess, links) in [("3-link", p3, g3, 3), ("4-link", p4, g4, 4)] {
            for scheme in [Scheme::Object, Scheme::PerArm] {
                let mut cp = ControllerParams::paper(Law::Pd(PdGains::<3>::paper()));
                cp.scheme = scheme;
                cp.torque_limit = Some(20.0);
                let build = || Controller::new(&cp, &model, Path::paper(), 1.0).unwrap().0;
                let (mut fixed, mut dynamic) = (build(), build());
                for a in dynamic.arm_slots.iter_mut() {
                    let selected = match a.kernel {
                        ArmKernel::Three(..) => 3,
                        ArmKernel::Four(..) => 4,
                        _ => 0,
                    };
                    assert_eq!(selected, links, "{name}: kernel selected at set-up");
                    a.kernel = ArmKernel::General;
                }
                let plant = Plant::new(&model).unwrap();
                let y = plant
                    .initial_state(presets::paper_start(), Vector3::zeros(), Some(&guess))
                    .unwrap();
                let nq = plant.n_q();
                let mut rng = SplitMix64(7);
                let (mut q, mut qd) = (y[..nq].to_vec(), vec![0.0; nq]);
                let mut forces = [0.0; 4];
                let (mut tau_a, mut tau_b) = (vec![0.0; nq], vec![0.0; nq]);
                let (mut rec_a, mut rec_b) = (TickRecord::default(), TickRecord::default());
                let mut clipped = 0;
                for k in 0..200 {
                    for (v, v0) in q.iter_mut().zip(&y[..nq]) {
                        *v = v0 + rng.range(-2e-4, 2e-4);
                    }
                    qd.iter_mut().for_each(|v| *v = rng.range(-0.01, 0.01));
                    forces.iter_mut().for_each(|v| *v = rng.range(-3.0, 3.0));
                    let meas = Measurements {
                        q: &q,
                        qd: &qd,
                        wrenches: &forces,
                    };
                    if k == 0 {
                        fixed.start(0.0, &meas);
                        dynamic.start(0.0, &meas);
                    }
                    let t = k as f64 * 1e-3;
                    fixed.tick(t, &meas, &mut tau_a, &mut rec_a);
                    dynamic.tick(t, &meas, &mut tau_b, &mut rec_b);
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&tau_a), bits(&tau_b), "{name} {scheme:?} tick {k}");
                    assert_eq!(rec_a, rec_b, "{name} {scheme:?} tick {k}");
                    assert!(tau_a.iter().any(|v| *v != 0.0));
                    clipped += usize::from(rec_a.torque_clipped);
                }
                assert_eq!(fixed.events(), dynamic.events(), "{name} {scheme:?}");
                println!("{name} {scheme:?}: 200 ticks identical, {clipped} with a clipped torque");
            }
        }
    }
}
