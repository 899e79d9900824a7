//! The cooperative controller in SE(3) (SPEC-spatial S5): the tick of SPEC §3 on six outputs.
//!
//! Data flow of a tick (SPEC §3 steps 1–5, in the spatial form):
//! 1. **Estimate** `(q, q̇) → (X̂_WO, V̂)`: forward kinematics of every arm
//!    ([`model::ObjectModel::kinematics`]), each tool pose carried to an object-pose candidate
//!    through its weld and fitted ([`crate::reference::spatial::fit()`]: quaternion mean, grasp-point least
//!    squares); then the output chart ([`crate::control::spatial::chart`]) gives `x_1 = (p − c, φ)` and
//!    `x_2 = ẋ_1 = E V̂`. The controller never reads the plant state, and needs no inverse
//!    kinematics.
//! 2. **Desired** `t → X_d, V_d, V̇_d` ([`crate::reference::spatial::path`]).
//! 3. **Reference** per arm: the 6-D admittance ([`crate::reference::spatial::admittance`]) offsets
//!    the desired tool pose `X_d X_OGi` by `e_i`, fed with the unexpected wrench
//!    `LPF(F_i) − F_ref,i` (wrist readings turned into world axes with the measured tool
//!    orientation); the object reference is the fit of the arms' reference tool poses, with exact
//!    rates, and its chart coordinates give `x_r, ẋ_r, ẍ_r`. As planar, the reference of a tick
//!    uses the generators' state *before* this tick's wrench is taken in (no direct feed-through).
//! 4. **Law** on the chart: iBLF + adaptive RBF network with switching ([`crate::control::law::adaptive`] on six
//!    outputs), PD, or computed torque; its chart-space force `τ_x` is the object wrench
//!    `F = Eᵀ τ_x` (power-conjugate: `τ_x · ẋ_1 = F · V`).
//! 5. **Distribution** ([`distribute`]): the minimum-norm share of `F` plus the commanded squeeze
//!    along the grasp map's null space, plus the internal part of the arms' own gravity (so the
//!    squeeze is the commanded one, as planar with `P_N Ĝ_x`); then `τ_i = J_iᵀ w_i`, and for
//!    redundant arms a damped posture task in the null space of `J_i`; then actuator limits.
//!
//! The per-arm scheme (PD) runs one 6-D PD per tool on its reference tool pose, with the
//! expected wrench and the arm's own gravity fed forward.
//!
//! A tick allocates nothing and never emits NaN or infinity: a barrier hit saturates and is
//! counted, a non-finite law output becomes zero torque and is counted.

pub mod bound;
pub mod chart;
pub mod distribute;
pub mod model;
pub mod params;

pub use params::{PostureParams, SpatialControllerParams};

use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};

use crate::control::actuator::Actuator;
use crate::control::law::Law;
use crate::control::law::adaptive::{AdaptiveNn, FuBound, NnInternals};
use crate::control::law::ctc::CtcGains;
use crate::control::law::pd::PdGains;
use crate::control::spatial::chart::Chart;
use crate::control::{ControlWarning, Scheme};
use crate::drive::ControlEvents;
use crate::drive::{Drive, Measurements, Record};
use crate::error::{ModelError, non_negative, positive};
use crate::geometry::motion::{ang, lin, stack};
use crate::geometry::so3::log_quat;
use crate::math::linalg::finite_slice;
use crate::model::spatial::object::RigidObject;
use crate::plant::spatial::{SpatialPlant, SpatialPlantParams};
use crate::reference::spatial::PoseSample;
use crate::reference::spatial::admittance::{
    AdmittanceSe3, AdmittanceSe3State, pose_sample, tool_from_object, wrench_tool_to_world,
};
use crate::reference::spatial::path::Se3Path;

use distribute::friction::{FrictionDistribution, FrictionStats};
use distribute::{Distribution, PostureTask, joint_torques};
use model::{ModelWorkspace, ObjectModel};

/// Axis names of the six outputs, linear first.
pub const AXES: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];
/// Wrench component names, linear first.
pub const WRENCH_AXES: [&str; 6] = ["fx", "fy", "fz", "tx", "ty", "tz"];

/// The spatial controller's internals at one tick (SPEC §5 columns on six outputs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpatialTickRecord {
    /// Estimated object pose in the chart, `x_1 = (p̂ − c, φ̂)`, (m, rad).
    pub x_hat: Vector6<f64>,
    /// Estimated chart rate `x_2 = ẋ_1`.
    pub xd_hat: Vector6<f64>,
    /// Desired pose in the chart.
    pub x_d: Vector6<f64>,
    /// Reference pose in the chart (admittance output).
    pub x_r: Vector6<f64>,
    /// Reference rate.
    pub xd_r: Vector6<f64>,
    /// `z1 = x_1 − x_r`.
    pub z1: Vector6<f64>,
    /// `z2 = x_2 − α` (NN) or `ż1` (PD, CTC).
    pub z2: Vector6<f64>,
    /// Virtual control `α` (NN).
    pub alpha: Vector6<f64>,
    /// `α̇` (NN).
    pub alpha_dot: Vector6<f64>,
    /// Object wrench `F = [f; τ]` the arms are commanded to apply, world axes, about the
    /// estimated object origin, (N, N m).
    pub wrench: Vector6<f64>,
    /// Weight norms `‖Ŵ_j‖` (NN).
    pub w_norm: Vector6<f64>,
    /// Internal (null-space) part of each arm's commanded wrench `w_i`, world axes at its tool.
    pub internal: Vec<Vector6<f64>>,
    /// Orientation error `|Log(R_rᵀ R̂)|`, rad.
    pub angle_error: f64,
    /// Switching value `Q` (NN; 1 otherwise).
    pub q_switch: f64,
    /// Constraint margin `1 − max_j |x_1j|/k_cj` of the estimate.
    pub margin: f64,
    /// This tick saturated the barrier.
    pub barrier_hit: bool,
    /// This tick clipped a joint torque.
    pub torque_clipped: bool,
    /// This tick replaced a non-finite value.
    pub non_finite: bool,
}

impl SpatialTickRecord {
    /// A record for `n_arms` arms.
    pub fn new(n_arms: usize) -> Self {
        SpatialTickRecord {
            internal: vec![Vector6::zeros(); n_arms],
            q_switch: 1.0,
            ..Default::default()
        }
    }

    /// Reset to the start-of-tick values, keeping the buffers.
    fn clear(&mut self) {
        let z = Vector6::zeros();
        for v in [
            &mut self.x_hat,
            &mut self.xd_hat,
            &mut self.x_d,
            &mut self.x_r,
            &mut self.xd_r,
            &mut self.z1,
            &mut self.z2,
            &mut self.alpha,
            &mut self.alpha_dot,
            &mut self.wrench,
            &mut self.w_norm,
        ] {
            *v = z;
        }
        for w in &mut self.internal {
            *w = z;
        }
        self.angle_error = 0.0;
        self.q_switch = 1.0;
        self.margin = 0.0;
        self.barrier_hit = false;
        self.torque_clipped = false;
        self.non_finite = false;
    }

    fn groups(&self) -> [(&'static str, &Vector6<f64>, [&'static str; 2]); 11] {
        [
            ("x_hat", &self.x_hat, ["m", "rad"]),
            ("xd_hat", &self.xd_hat, ["m/s", "rad/s"]),
            ("x_d", &self.x_d, ["m", "rad"]),
            ("x_r", &self.x_r, ["m", "rad"]),
            ("xd_r", &self.xd_r, ["m/s", "rad/s"]),
            ("z1", &self.z1, ["m", "rad"]),
            ("z2", &self.z2, ["m/s", "rad/s"]),
            ("alpha", &self.alpha, ["m/s", "rad/s"]),
            ("alpha_dot", &self.alpha_dot, ["m/s^2", "rad/s^2"]),
            ("tau", &self.wrench, ["N", "N m"]),
            ("w_norm", &self.w_norm, ["1", "1"]),
        ]
    }
}

impl Record for SpatialTickRecord {
    fn head_columns(&self) -> Vec<(String, String)> {
        let mut c = Vec::new();
        for (g, _, [lu, ru]) in self.groups() {
            let names = if g == "tau" { WRENCH_AXES } else { AXES };
            for (j, a) in names.iter().enumerate() {
                c.push((format!("{g}.{a}"), if j < 3 { lu } else { ru }.to_string()));
            }
        }
        for i in 0..self.internal.len() {
            for (j, a) in WRENCH_AXES.iter().enumerate() {
                c.push((
                    format!("w_int{}.{a}", i + 1),
                    if j < 3 { "N" } else { "N m" }.to_string(),
                ));
            }
        }
        c.push(("angle_error".into(), "rad".into()));
        c
    }
    fn tail_columns(&self) -> Vec<(String, String)> {
        vec![("Q".into(), "1".into()), ("margin".into(), "1".into())]
    }
    fn write_head(&self, out: &mut [f64]) {
        let mut k = 0;
        for (_, v, _) in self.groups() {
            out[k..k + 6].copy_from_slice(v.as_slice());
            k += 6;
        }
        for w in &self.internal {
            out[k..k + 6].copy_from_slice(w.as_slice());
            k += 6;
        }
        out[k] = self.angle_error;
    }
    fn write_tail(&self, out: &mut [f64]) {
        out[0] = self.q_switch;
        out[1] = self.margin;
    }
    fn non_finite(&self) -> Option<String> {
        for (g, v, _) in self.groups() {
            if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                let names = if g == "tau" { WRENCH_AXES } else { AXES };
                return Some(format!("{g}.{}", names[j]));
            }
        }
        for (i, w) in self.internal.iter().enumerate() {
            if let Some(j) = w.iter().position(|x| !x.is_finite()) {
                return Some(format!("w_int{}.{}", i + 1, WRENCH_AXES[j]));
            }
        }
        if !self.angle_error.is_finite() {
            return Some("angle_error".into());
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

/// The law a controller runs, validated, with its state.
enum Active {
    Nn(Box<AdaptiveNn<6>>),
    Pd(PdGains<6>),
    Ctc(CtcGains<6>, Box<ObjectModel>, Box<ModelWorkspace>),
    PerArmPd(PdGains<6>),
}

/// A spatial cooperative controller: validated gains and models, its state (admittance offsets,
/// network weights) and preallocated scratch. Build once with [`SpatialController::new`], then
/// call [`SpatialController::tick`] at the control rate (or let [`crate::sim::Simulation`]
/// drive it).
pub struct SpatialController {
    model: ObjectModel,
    ws: ModelWorkspace,
    dist: Distribution,
    /// The friction-aware distribution (contact grasps), after the weld-assuming one.
    friction: Option<Box<FrictionDistribution>>,
    chart: Chart,
    path: Se3Path,
    object: RigidObject,
    gravity: Vector3<f64>,
    x_og: Vec<Isometry3<f64>>,
    adm: Option<Vec<AdmittanceSe3>>,
    adm_state: Vec<AdmittanceSe3State>,
    law: Active,
    k_c: Vector6<f64>,
    h: f64,
    squeeze: f64,
    /// The actuator stage (effort from `torque_limit` or the URDF unless given).
    actuator: Actuator,
    /// The commanded torques of the last tick, N m (before the actuator stage).
    tau_cmd: Vec<f64>,
    posture: PostureTask,
    posture_rest_given: bool,
    path_inertia: Vector6<f64>,
    events: ControlEvents,
    hint_hat: UnitQuaternion<f64>,
    hint_r: UnitQuaternion<f64>,
    // Scratch (sized once).
    tools: Vec<PoseSample>,
    ref_tools: Vec<PoseSample>,
    f_meas: Vec<Vector6<f64>>,
    f_ref: Vec<Vector6<f64>>,
    w: Vec<Vector6<f64>>,
    w2: Vec<Vector6<f64>>,
    gx: Vec<Vector6<f64>>,
    r: Vec<Vector3<f64>>,
    r_d: Vec<Vector3<f64>>,
    rot: Vec<UnitQuaternion<f64>>,
    /// The object-level dynamics of the tick (when the full model runs).
    last_dyn: Option<model::ObjectDynamics>,
}

/// Sampling step of the set-up checks along the path, s (at most [`MAX_PATH_SAMPLES`]).
const PATH_CHECK_STEP: f64 = 0.05;
/// Most path samples the set-up checks take.
const MAX_PATH_SAMPLES: usize = 4000;
/// Smallest singular value of an arm's Jacobian tolerated along the path at set-up, m/rad.
const MIN_PATH_SIGMA: f64 = 0.02;

impl SpatialController {
    /// Build a controller from its parameters, the controller's model of the set-up (`model`:
    /// kinematics and grasps are taken as known; dynamics are used where a law needs them — the
    /// expected wrenches, `f^U`, computed torque, the arms' gravity feed-forward), the desired
    /// path, the run's duration and a joint configuration near the start (`q_guess`, for the
    /// set-up's inverse kinematics along the path and over the constraint box).
    ///
    /// Checks (each error names its parameter): gains, `k_c` (positive, rotational `< π`, a
    /// warning above `π/2`), the path inside the bounds over the run, the path inside every arm's
    /// reach and joint limits with a well-conditioned Jacobian (sampled every 50 ms), the posture.
    pub fn new(
        p: &SpatialControllerParams,
        model: &SpatialPlantParams,
        path: Se3Path,
        duration: f64,
        q_guess: &[f64],
    ) -> Result<(Self, Vec<ControlWarning>), ModelError> {
        let h = positive("control_period", p.control_period)?;
        let duration = non_negative("duration", duration)?;
        let squeeze = non_negative("squeeze", p.squeeze)?;
        let mut warnings = Vec::new();
        let mut k_c = Vector6::zeros();
        for j in 0..6 {
            k_c[j] = positive(&format!("k_c[{j}]"), p.k_c[j])?;
            non_negative(&format!("disturbance_bound[{j}]"), p.disturbance_bound[j])?;
        }
        for j in 3..6 {
            if !(k_c[j] < std::f64::consts::PI) {
                return Err(ModelError::invalid(
                    format!("k_c[{j}]"),
                    k_c[j],
                    "a rotational bound must be below π rad: the chart φ = Log(R_refᵀ R) covers |φ| < π only",
                ));
            }
            if k_c[j] > std::f64::consts::FRAC_PI_2 {
                warnings.push(ControlWarning::Gain {
                    param: format!("k_c[{j}]"),
                    reason: format!(
                        "{:.3} rad is above π/2: the chart's Jacobian J_l(φ)⁻¹ grows towards the bound (|φ| = π is its edge), so the barrier acts on a strongly distorted angle",
                        k_c[j]
                    ),
                });
            }
        }
        let plant = SpatialPlant::new(model)?;
        let m = plant.arms().len();
        if m < 2 {
            return Err(ModelError::geometry(
                "arms",
                "the cooperative controller needs at least two arms",
            ));
        }
        if q_guess.len() != plant.n_q() {
            return Err(ModelError::geometry(
                "q_guess",
                format!(
                    "has {} entries, the arms have {} joints",
                    q_guess.len(),
                    plant.n_q()
                ),
            ));
        }
        // The chart: about the centre of the path's bounding box, R_ref = R_d(0).
        let s0 = path.sample(0.0);
        let r_ref = p.r_ref.unwrap_or(s0.r);
        let centre = match p.centre {
            Some(c) => c,
            None => path_centre(&path, duration),
        };
        if !centre.iter().all(|v| v.is_finite()) {
            return Err(ModelError::geometry("centre", "must be finite"));
        }
        let chart = Chart::new(centre, r_ref);
        // The path inside the bounds over the run.
        let peak = path.max_abs(&centre, &r_ref, duration);
        if let Some(j) = (0..6).find(|&j| !(peak[j] < k_c[j])) {
            let unit = if j < 3 { "m" } else { "rad" };
            return Err(ModelError::invalid(
                format!("k_c[{j}]"),
                k_c[j],
                format!(
                    "must lie above the desired path's largest excursion over the run, max |x_d,{}| = {:.4} {unit} (chart centre ({:.3}, {:.3}, {:.3}) m)",
                    AXES[j], peak[j], centre.x, centre.y, centre.z
                ),
            ));
        }
        // The path inside every arm's reach and limits (IK by continuation), and the chart-space
        // inertia along it (for the gain check).
        let obj_model = ObjectModel::new(model)?;
        let (q_start, path_inertia, light_inertia) =
            check_path_reach(&plant, &obj_model, &chart, &path, duration, q_guess)?;
        // Posture of redundant arms.
        let q_rest = match &p.posture.q_rest {
            Some(q) => {
                check_posture(&plant, q)?;
                q.clone()
            }
            None => q_start.clone(),
        };
        positive("posture.kp", p.posture.kp)?;
        positive("posture.kd", p.posture.kd)?;
        let posture = PostureTask {
            kp: p.posture.kp,
            kd: p.posture.kd,
            q_rest,
        };
        let torque_limit: Vec<f64> = match p.torque_limit {
            Some(l) => vec![positive("torque_limit", l)?; plant.n_q()],
            None => plant
                .arms()
                .iter()
                .flat_map(|a| a.chain.joints.iter().map(|j| j.limits.effort))
                .map(|e| if e > 0.0 { e } else { f64::INFINITY })
                .collect(),
        };
        let mut act = p.actuator.clone();
        if act.effort.is_none() {
            act.effort = Some(torque_limit.clone());
        }
        let actuator = Actuator::new(&act, plant.n_q(), h)?;
        let ws = obj_model.workspace();
        let dist = Distribution::new(m, p.metric_length).map_err(|e| rename(e, "metric_length"))?;
        let friction = match &p.friction {
            Some(f) => {
                if f.pads.len() != m {
                    return Err(ModelError::geometry(
                        "friction.pads",
                        format!("{} pad lists for {m} grasps", f.pads.len()),
                    ));
                }
                let mut fd = FrictionDistribution::new(f, p.metric_length)?;
                // The arms' effort limits (the actuator stage's) as constraints of the plan.
                let e = actuator.effort();
                if e.iter().any(|v| v.is_finite()) {
                    let per_arm: Vec<Vec<f64>> = (0..m)
                        .map(|i| {
                            let s = obj_model.offset(i);
                            e[s..s + obj_model.arms()[i].chain.dof()].to_vec()
                        })
                        .collect();
                    fd.set_effort(&per_arm)
                        .map_err(|e| rename(e, "controller.actuator.effort"))?;
                }
                Some(Box::new(fd))
            }
            None => None,
        };
        let adm = match &p.admittance {
            Some(a) => {
                let (g, w) = AdmittanceSe3::new(a, h)?;
                warnings.extend(w.into_iter().map(|w| ControlWarning::Gain {
                    param: "admittance".into(),
                    reason: w.to_string(),
                }));
                Some(vec![g; m])
            }
            None => None,
        };
        if p.scheme == Scheme::PerArm && !matches!(p.law, Law::Pd(_)) {
            return Err(ModelError::geometry(
                "scheme",
                "the per-arm scheme is implemented for the PD law; use the object scheme with the NN and computed-torque laws",
            ));
        }
        let x_wo0 = Isometry3::from_parts(s0.p.into(), s0.r);
        let law = match &p.law {
            Law::Pd(g) => {
                for j in 0..6 {
                    positive(&format!("gains.k_p[{j}]"), g.k_p[j])?;
                    positive(&format!("gains.k_d[{j}]"), g.k_d[j])?;
                }
                if p.scheme == Scheme::PerArm {
                    Active::PerArmPd(*g)
                } else {
                    Active::Pd(*g)
                }
            }
            Law::Ctc(g) => {
                for j in 0..6 {
                    positive(&format!("gains.k_p[{j}]"), g.k_p[j])?;
                    positive(&format!("gains.k_d[{j}]"), g.k_d[j])?;
                }
                if !(g.model_error > -1.0 && g.model_error < 10.0) {
                    return Err(ModelError::invalid(
                        "gains.model_error",
                        g.model_error,
                        "must lie in (−1, 10): the nominal masses are (1 + model_error) times the true ones",
                    ));
                }
                let nominal = ObjectModel::new(&model::nominal_params(model, g.model_error))?;
                let nws = nominal.workspace();
                Active::Ctc(*g, Box::new(nominal), Box::new(nws))
            }
            Law::Nn(g) => {
                if g.network.is_full_grid() {
                    return Err(ModelError::geometry(
                        "gains.network",
                        "the paper's full grid on six outputs has 2^24 ≈ 1.7e7 nodes (800 MB of weights); choose `per_axis` (the default) or `quasi_random`",
                    ));
                }
                let fu: FuBound = bound::fu_bound(
                    &obj_model,
                    &chart,
                    &k_c,
                    &p.disturbance_bound,
                    g.fu_safety,
                    &x_wo0,
                    &q_start,
                )?;
                // SPEC §3.4: the linearised loop needs roughly K2 > 𝓜 K1 per axis, with 𝓜 the
                // diagonal of the chart-space inertia at the heaviest pose on the path.
                for j in 0..6 {
                    let m_j = path_inertia[j];
                    if g.k2[j] < m_j * g.k1[j] {
                        warnings.push(ControlWarning::Gain {
                            param: format!("gains.k2[{j}]"),
                            reason: format!(
                                "K2 = {} is below 𝓜 K1 ≈ {} (𝓜_jj up to {} along the path, K1 = {}): the linearised z2 loop needs roughly K2 > 𝓜 K1 (SPEC §3.4); expect a limit cycle",
                                g.k2[j],
                                crate::error::fmt_fixed(m_j * g.k1[j], 3),
                                crate::error::fmt_fixed(m_j, 3),
                                g.k1[j]
                            ),
                        });
                    }
                }
                let mut nn = AdaptiveNn::<6>::new(g, k_c, fu, h)?;
                // The sampled-data boundary layer of the robust term on the lightest effective
                // chart-space inertia along the path (`docs/smooth-nn.md`).
                nn.set_sampling_inertia(std::array::from_fn(|j| light_inertia[j]));
                // Anti-windup on the chart-space inertia along the path (the z2 loop's).
                if p.actuator.anti_windup_on() {
                    nn.set_anti_windup_inertia(std::array::from_fn(|j| path_inertia[j]));
                }
                Active::Nn(Box::new(nn))
            }
        };
        let object = RigidObject::new(&model.object)?;
        let z6 = Vector6::zeros();
        let rest = PoseSample::at_rest(Vector3::zeros(), UnitQuaternion::identity());
        Ok((
            SpatialController {
                model: obj_model,
                ws,
                dist,
                friction,
                chart,
                path,
                object,
                gravity: model.gravity,
                x_og: model.grasps.clone(),
                adm,
                adm_state: vec![AdmittanceSe3State::default(); m],
                law,
                k_c,
                h,
                squeeze,
                tau_cmd: vec![0.0; torque_limit.len()],
                actuator,
                posture,
                posture_rest_given: p.posture.q_rest.is_some(),
                path_inertia,
                events: ControlEvents::default(),
                hint_hat: s0.r,
                hint_r: s0.r,
                tools: vec![rest; m],
                ref_tools: vec![rest; m],
                f_meas: vec![z6; m],
                f_ref: vec![z6; m],
                w: vec![z6; m],
                w2: vec![z6; m],
                gx: vec![z6; m],
                r: vec![Vector3::zeros(); m],
                r_d: vec![Vector3::zeros(); m],
                rot: vec![UnitQuaternion::identity(); m],
                last_dyn: None,
            },
            warnings,
        ))
    }

    /// Control period, s.
    pub fn period(&self) -> f64 {
        self.h
    }
    /// What the friction-aware distribution did (`None` without one).
    pub fn friction_stats(&self) -> Option<FrictionStats> {
        self.friction.as_ref().map(|f| f.stats)
    }
    /// Event counters since the start.
    pub fn events(&self) -> ControlEvents {
        self.events
    }
    /// Output bounds `k_c`.
    pub fn k_c(&self) -> Vector6<f64> {
        self.k_c
    }
    /// The output chart (centre and reference orientation).
    pub fn chart(&self) -> &Chart {
        &self.chart
    }
    /// The desired path.
    pub fn path(&self) -> &Se3Path {
        &self.path
    }
    /// The largest diagonal entries of the chart-space inertia `M_x = E⁻ᵀ 𝓜 E⁻¹` along the
    /// desired path (kg ×3, kg m² ×3): the `𝓜_j` of the per-axis gain design.
    pub fn path_inertia(&self) -> Vector6<f64> {
        self.path_inertia
    }
    /// The commanded squeeze, N.
    pub fn squeeze(&self) -> f64 {
        self.squeeze
    }
    /// The adaptive law, when this controller runs one.
    pub fn adaptive(&self) -> Option<&AdaptiveNn<6>> {
        match &self.law {
            Active::Nn(nn) => Some(nn),
            _ => None,
        }
    }
    /// Expected grasp wrenches `F_ref,i` of the last tick (the object on tool `i`, world axes).
    pub fn expected(&self) -> &[Vector6<f64>] {
        &self.f_ref
    }
    /// Admittance offsets `e_i` of every arm (m, rad; world axes).
    pub fn admittance_offsets(&self) -> impl Iterator<Item = Vector6<f64>> + '_ {
        self.adm_state.iter().map(|s| s.e)
    }
    /// The last tick's commanded wrenches `w_i` (arm `i` on the object at its tool origin,
    /// world axes).
    pub fn arm_wrenches(&self) -> &[Vector6<f64>] {
        &self.w
    }
    /// The tool origins relative to the estimated object origin, world axes, of the last tick.
    pub fn lever_arms(&self) -> &[Vector3<f64>] {
        &self.r
    }
    /// The object-level model at the last tick's measurements (after [`SpatialController::tick`]).
    pub fn model(&self) -> (&ObjectModel, &ModelWorkspace) {
        (&self.model, &self.ws)
    }

    /// Start (or restart) at `t0`: admittance offsets at rest with each wrench filter started at
    /// its expected wrench `F_ref,i(t0)` (SPEC §3.1), the quaternion hints from the desired
    /// orientation, the posture (unless given) at the measured configuration. Adaptive weights
    /// are kept ([`SpatialController::reset_weights`]).
    pub fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        let s = self.path.sample(t0);
        let des = pose_sample(&s);
        self.hint_hat = s.r;
        self.hint_r = s.r;
        self.expected_wrenches(&des);
        for (st, f) in self.adm_state.iter_mut().zip(&self.f_ref) {
            *st = AdmittanceSe3State::with_filter_at(*f);
        }
        if !self.posture_rest_given && meas.q.len() == self.posture.q_rest.len() {
            self.posture.q_rest.copy_from_slice(meas.q);
        }
        if self.estimate(meas).is_some() {
            // hint_hat now follows the measured pose.
        }
        self.actuator.reset();
        self.events = ControlEvents::default();
    }

    /// The adaptive law, mutable (to switch its anti-windup off for a comparison).
    pub fn adaptive_mut(&mut self) -> Option<&mut AdaptiveNn<6>> {
        match &mut self.law {
            Active::Nn(nn) => Some(nn),
            _ => None,
        }
    }
    /// The actuator stage (its limits and the ticks each acted on).
    pub fn actuator(&self) -> &Actuator {
        &self.actuator
    }

    /// Zero the adaptive weights.
    pub fn reset_weights(&mut self) {
        if let Active::Nn(nn) = &mut self.law {
            nn.reset_weights();
        }
    }

    /// `F_ref,i`: minus arm `i`'s share of the nominal object wrench at the desired sample,
    /// `M_o V̇_d + h_o(V_d)` (object only: inertia, gyroscopic, damping, weight), plus the
    /// squeeze's reaction (SPEC §3.1 in six dimensions). Into `self.f_ref`.
    fn expected_wrenches(&mut self, des: &PoseSample) {
        let rot = des.q.to_rotation_matrix().into_inner();
        let i_w = rot * self.object.inertia * rot.transpose();
        let (w, wd) = (des.w(), des.w_dot());
        let m = self.object.mass;
        let f = m * (des.v_dot() - self.gravity)
            + self
                .object
                .damping
                .fixed_rows::<3>(0)
                .component_mul(&des.v());
        let tq = i_w * wd
            + w.cross(&(i_w * w))
            + self.object.damping.fixed_rows::<3>(3).component_mul(&w);
        let nominal = stack(&f, &tq);
        for (rd, g) in self.r_d.iter_mut().zip(&self.x_og) {
            *rd = des.q * g.translation.vector;
        }
        if !self
            .dist
            .distribute(&self.r_d, &nominal, self.squeeze, &mut self.w2)
        {
            self.w2.iter_mut().for_each(|v| *v = Vector6::zeros());
        }
        for (fr, w) in self.f_ref.iter_mut().zip(&self.w2) {
            *fr = -w;
        }
    }

    /// Step 1: the object's pose and twist from the encoders; `None` if degenerate.
    fn estimate(&mut self, meas: &Measurements<'_>) -> Option<PoseSample> {
        self.model.poses(meas.q, &mut self.ws);
        for i in 0..self.tools.len() {
            let d = &self.ws.data[i];
            let off = self.model.offset(i);
            let n = d.dof();
            let mut tw = Vector6::zeros();
            for k in 0..n {
                tw += d.J.column(k) * meas.qd[off + k];
            }
            self.tools[i] = PoseSample {
                p: d.X_WT.translation.vector,
                q: d.X_WT.rotation,
                twist: tw,
                twist_dot: Vector6::zeros(),
            };
        }
        let fit = crate::reference::spatial::fit_sample(&self.x_og, &self.tools, &self.hint_hat)?;
        self.hint_hat = fit.q;
        for (r, t) in self.r.iter_mut().zip(&self.tools) {
            *r = t.p - fit.p;
        }
        Some(fit)
    }

    /// Step 3: the reference pose sample (object level) at this tick; advances the generators.
    fn reference(
        &mut self,
        des: &PoseSample,
        meas: &Measurements<'_>,
        rec: &mut SpatialTickRecord,
    ) -> PoseSample {
        self.expected_wrenches(des);
        let Some(adm) = &self.adm else {
            return *des;
        };
        for i in 0..self.tools.len() {
            let tool_d = tool_from_object(des, &self.x_og[i]);
            // The reference from the state before this tick's wrench (no feed-through).
            let r = adm[i].reference(&self.adm_state[i], &tool_d);
            self.ref_tools[i] = if finite_sample(&r) { r } else { tool_d };
            self.f_meas[i] = wrench_tool_to_world(&self.tools[i].q, &meas.wrench(i));
            let flags = adm[i].step(&mut self.adm_state[i], &self.f_meas[i], &self.f_ref[i]);
            if !flags.is_clean() {
                rec.non_finite |= flags.state_held != 0;
            }
        }
        let Some(fit) =
            crate::reference::spatial::fit_sample(&self.x_og, &self.ref_tools, &self.hint_r)
        else {
            return *des;
        };
        if !finite_sample(&fit) {
            return *des;
        }
        self.hint_r = fit.q;
        fit
    }

    /// One control tick at time `t`: `(t, q, q̇, wrist wrenches) → τ_joint` into `tau` (n_q)
    /// and the internals into `rec` (sized by [`SpatialTickRecord::new`]). No allocation; never
    /// writes NaN or infinity into `tau`.
    pub fn tick(
        &mut self,
        t: f64,
        meas: &Measurements<'_>,
        tau: &mut [f64],
        rec: &mut SpatialTickRecord,
    ) {
        rec.clear();
        // 1. Estimate.
        let Some(obj) = self.estimate(meas) else {
            self.events.degenerate += 1;
            tau.fill(0.0);
            return;
        };
        let cs = self.chart.sample(&obj);
        let (x1, x2) = (cs.x1, cs.x1_dot);
        if !(finite_slice(x1.as_slice()) && finite_slice(x2.as_slice())) {
            self.events.non_finite += 1;
            rec.non_finite = true;
            tau.fill(0.0);
            return;
        }
        // 2. Desired.
        let s = self.path.sample(t);
        let des = pose_sample(&s);
        // 3. Reference.
        let refs = self.reference(&des, meas, rec);
        let (x_r, xd_r, xdd_r) = self.chart.coordinates(&refs);
        let z1 = x1 - x_r;
        let z1_dot = x2 - xd_r;
        // Object-level model at the measurements: the full one where a law or the null space
        // needs it (computed torque, redundant arms), otherwise only the arms' operational-space
        // gravity (the feed-forward of step 5 and PD's gravity term), five times cheaper.
        let full = self.needs_full_model();
        if full {
            self.last_dyn =
                self.model
                    .dynamics(meas.q, meas.qd, &obj.pose(), &obj.twist, &mut self.ws);
            if self.last_dyn.is_none() {
                self.events.degenerate += 1;
                tau.fill(0.0);
                return;
            }
        } else if !self.model.operational_gravity(&mut self.ws) {
            self.events.degenerate += 1;
            tau.fill(0.0);
            return;
        }
        // 4. Law → object wrench F (world axes, about the estimated object origin).
        let mut f = match &mut self.law {
            Active::Nn(nn) => {
                let mut o = NnInternals::<6>::default();
                let tx = nn.wrench(&x1, &x2, &x_r, &xd_r, &xdd_r, &mut o);
                rec.z2 = o.z2;
                rec.alpha = o.alpha;
                rec.alpha_dot = o.alpha_dot;
                rec.w_norm = o.w_norm;
                rec.q_switch = o.q;
                rec.barrier_hit = o.barrier_hit;
                rec.non_finite |= o.non_finite;
                cs.jac.wrench_from_chart(&tx)
            }
            Active::Pd(g) => {
                rec.z2 = z1_dot;
                let tx = -Vector6::from(g.k_p).component_mul(&z1)
                    - Vector6::from(g.k_d).component_mul(&z1_dot);
                let mut f = cs.jac.wrench_from_chart(&tx);
                if g.gravity_compensation {
                    f += self.gravity_wrench();
                }
                f
            }
            Active::Ctc(g, nominal, nws) => {
                rec.z2 = z1_dot;
                let a = xdd_r
                    - Vector6::from(g.k_d).component_mul(&z1_dot)
                    - Vector6::from(g.k_p).component_mul(&z1);
                let vdot = cs.jac.twist_rate_from_chart(&a, &obj.twist);
                nominal.kinematics(meas.q, meas.qd, nws);
                match nominal.dynamics(meas.q, meas.qd, &obj.pose(), &obj.twist, nws) {
                    Some(nd) => nd.m * vdot + nd.h,
                    None => {
                        self.events.degenerate += 1;
                        Vector6::zeros()
                    }
                }
            }
            Active::PerArmPd(g) => {
                rec.z2 = z1_dot;
                let g = *g;
                self.per_arm_pd(&g, &des);
                Distribution::net(&self.r, &self.w)
            }
        };
        if !finite_slice(f.as_slice()) {
            rec.non_finite = true;
            f = Vector6::zeros();
        }
        rec.x_hat = x1;
        rec.xd_hat = x2;
        rec.x_d = self.chart.coords(&des.p, &des.q);
        rec.x_r = x_r;
        rec.xd_r = xd_r;
        rec.z1 = z1;
        rec.wrench = f;
        rec.angle_error = log_quat(&(refs.q.inverse() * obj.q)).norm();
        rec.margin = (0..6)
            .map(|j| 1.0 - x1[j].abs() / self.k_c[j])
            .fold(f64::INFINITY, f64::min);
        // 5. Distribute (object scheme): min-norm share + squeeze, plus the internal part of
        // the arms' own gravity (no object wrench commands it; without it, it adds to the
        // squeeze and the admittance yields to it).
        if !matches!(self.law, Active::PerArmPd(_)) {
            if !self.dist.distribute(&self.r, &f, self.squeeze, &mut self.w) {
                self.events.degenerate += 1;
                tau.fill(0.0);
                return;
            }
            for (g, a) in self.gx.iter_mut().zip(&self.ws.arms) {
                *g = a.g_x;
            }
            if self.dist.internal_part(&self.r, &self.gx, &mut self.w2) {
                for (wi, gi) in self.w.iter_mut().zip(&self.w2) {
                    *wi += gi;
                }
            }
            // Contact grasps: the nearest wrenches that keep every pad inside its cone
            // (unchanged, and counted, when none exists). The pads carry what the arm puts on
            // the object, `w_i − g_x,i` (the rest holds the arm's own weight).
            if let (Some(fd), Some(nd)) = (&mut self.friction, &self.last_dyn) {
                for (q, tool) in self.rot.iter_mut().zip(&self.tools) {
                    *q = tool.q;
                }
                // The object's acceleration under these wrenches (the model's (14)), then what
                // each arm's own dynamics take of its wrench, `Λ_i (G_i V̇ + Ġ_i V) + μ_i`: the
                // rest, `w_i` less that, is what its pads carry to the object.
                let net = Distribution::net(&self.r, &self.w);
                let vdot = nd
                    .acceleration(&net, &Vector6::zeros())
                    .unwrap_or_else(Vector6::zeros);
                let w_o = ang(&obj.twist);
                for i in 0..self.w.len() {
                    let r = self.r[i];
                    let a = stack(
                        &(lin(&vdot) + ang(&vdot).cross(&r) + w_o.cross(&w_o.cross(&r))),
                        &ang(&vdot),
                    );
                    let arm = &self.ws.arms[i];
                    self.gx[i] = arm.lambda * a + arm.mu;
                    self.w2[i] = self.w[i] - self.gx[i];
                    // The arm's Jacobian and its torques besides the pads' share (its own
                    // share and posture task), for the effort limits.
                    if fd.arm_rows(i).is_some() {
                        joint_torques(
                            &self.model,
                            &mut self.ws,
                            i,
                            &self.gx[i],
                            meas.q,
                            meas.qd,
                            Some(&self.posture),
                            tau,
                        );
                        let n = self.model.arms()[i].chain.dof();
                        let s = self.model.offset(i);
                        if let Some((jac, tau0)) = fd.arm_rows(i) {
                            jac.copy_from_slice(&self.ws.data[i].J.as_slice()[..6 * n]);
                            tau0.copy_from_slice(&tau[s..s + n]);
                        }
                    }
                }
                if fd.solve(t, &self.r, &self.rot, &mut self.w2) {
                    for ((wi, t2), own) in self.w.iter_mut().zip(&self.w2).zip(&self.gx) {
                        *wi = t2 + own;
                    }
                }
            }
        }
        // Record the internal part of the commands.
        if !self.dist.internal_part(&self.r, &self.w, &mut rec.internal) {
            rec.internal.iter_mut().for_each(|v| *v = Vector6::zeros());
        }
        // Joint torques: J_iᵀ w_i (+ the posture task in the null space of redundant arms).
        for i in 0..self.w.len() {
            joint_torques(
                &self.model,
                &mut self.ws,
                i,
                &self.w[i],
                meas.q,
                meas.qd,
                Some(&self.posture),
                tau,
            );
        }
        // The actuator stage: the law's torques → the applied ones.
        rec.torque_clipped |= crate::control::actuator::actuate(
            &mut self.actuator,
            tau,
            &mut self.tau_cmd,
            &mut self.events,
        );
        if matches!(self.law, Active::Nn(_)) {
            let d = cs.jac.wrench_to_chart(&self.deficit_wrench(tau));
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
    /// with the maps the wrench was distributed with: per arm the wrist wrench that `J_iᵀ`
    /// maps onto the deficit in least squares, `δw_i = (J_i J_iᵀ)⁻¹ J_i δτ_q,i` (`J_i⁻ᵀ δτ_q,i`
    /// on a 6-joint arm; the null-space part of a redundant arm's deficit reaches no wrist),
    /// then the grasp map `δF = Σ_i G_iᵀ δw_i`. Zero where nothing was limited. Uses `w2` as
    /// scratch.
    fn deficit_wrench(&mut self, tau: &[f64]) -> Vector6<f64> {
        let mut any = false;
        for i in 0..self.w2.len() {
            let n = self.model.arms()[i].chain.dof();
            let s = self.model.offset(i);
            let nz = (s..s + n).any(|k| tau[k] != self.tau_cmd[k]);
            self.w2[i] = Vector6::zeros();
            if !nz {
                continue;
            }
            any = true;
            let jt = &self.ws.data[i].J.as_slice()[..6 * n];
            let mut b = Vector6::zeros();
            let mut a = nalgebra::Matrix6::<f64>::zeros();
            for k in 0..n {
                let col = Vector6::from_column_slice(&jt[6 * k..6 * k + 6]);
                a += col * col.transpose();
                b += col * (tau[s + k] - self.tau_cmd[s + k]);
            }
            if let Some(c) = a.cholesky() {
                let w = c.solve(&b);
                if finite_slice(w.as_slice()) {
                    self.w2[i] = w;
                }
            }
        }
        if !any {
            return Vector6::zeros();
        }
        Distribution::net(&self.r, &self.w2)
    }

    /// Whether the tick needs the full object-level model ([`ObjectModel::dynamics`]): computed
    /// torque, or an arm that is not square (its null-space projector needs `M_i` and `Λ_i`).
    fn needs_full_model(&self) -> bool {
        matches!(self.law, Active::Ctc(..))
            || self.friction.is_some()
            || self.model.arms().iter().any(|a| a.chain.dof() != 6)
    }

    /// `𝓖 = [−m g; 0] + Σ G_iᵀ g_x,i`: the object's and the arms' weight as an object wrench, at
    /// the estimated grasp lever arms (after the model step of the tick).
    fn gravity_wrench(&self) -> Vector6<f64> {
        let mut g = stack(&(-self.object.mass * self.gravity), &Vector3::zeros());
        for (r, a) in self.r.iter().zip(&self.ws.arms) {
            g += model::transport_t(r) * a.g_x;
        }
        g
    }

    /// Per-arm scheme, step 4: a 6-D PD per tool on its reference tool pose (the desired one
    /// without admittance), `w_i = −K_P e_i − K_D ė_i − F_ref,i (+ g_x,i)` with
    /// `e_i = (p_T − p_r, Log(R_T R_rᵀ))` (world axes) and `ė_i = V_T − V_r`: the expected wrench
    /// and the arm's own operational-space gravity fed forward. Writes `w_i`.
    fn per_arm_pd(&mut self, g: &PdGains<6>, des: &PoseSample) {
        let (kp, kd) = (Vector6::from(g.k_p), Vector6::from(g.k_d));
        for i in 0..self.tools.len() {
            let rf = if self.adm.is_some() {
                self.ref_tools[i]
            } else {
                tool_from_object(des, &self.x_og[i])
            };
            let tl = &self.tools[i];
            let e = stack(&(tl.p - rf.p), &log_quat(&(tl.q * rf.q.inverse())));
            let ed = tl.twist - rf.twist;
            let mut w = -kp.component_mul(&e) - kd.component_mul(&ed) - self.f_ref[i];
            if g.gravity_compensation {
                w += self.ws.arms[i].g_x;
            }
            self.w[i] = w;
        }
    }
}

impl Drive<SpatialPlant> for SpatialController {
    type Record = SpatialTickRecord;
    fn new_record(&self) -> SpatialTickRecord {
        SpatialTickRecord::new(self.tools.len())
    }
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        SpatialController::start(self, t0, meas);
    }
    fn tick(
        &mut self,
        t: f64,
        meas: &Measurements<'_>,
        tau: &mut [f64],
        rec: &mut SpatialTickRecord,
    ) {
        SpatialController::tick(self, t, meas, tau, rec);
    }
    fn events(&self) -> ControlEvents {
        self.events
    }
    fn joint_limit_counts(&self) -> Option<(&[u64], &[u64])> {
        let c = self.actuator.counts();
        Some((&c.rate_per_joint, &c.effort_per_joint))
    }
    fn truth_margin(&self, plant: &SpatialPlant, y: &[f64]) -> Option<f64> {
        let (_, o, _) = plant.split(y);
        let x = self.chart.coords(&o.p, &o.q);
        Some(
            (0..6)
                .map(|j| 1.0 - x[j].abs() / self.k_c[j])
                .fold(f64::INFINITY, f64::min),
        )
    }
}

/// Every component of a pose sample is finite.
fn finite_sample(s: &PoseSample) -> bool {
    finite_slice(s.p.as_slice())
        && finite_slice(s.q.coords.as_slice())
        && finite_slice(s.twist.as_slice())
        && finite_slice(s.twist_dot.as_slice())
}

/// A sub-module's error re-labelled with the controller's parameter name.
fn rename(e: ModelError, to: &str) -> ModelError {
    match e {
        ModelError::Invalid { value, reason, .. } => ModelError::Invalid {
            param: to.to_string(),
            value,
            reason,
        },
        other => other,
    }
}

/// The default chart centre: a circle's centre; for other paths the centre of the desired
/// positions' bounding box over `[0, duration]` (sampled every 50 ms, at most 4000 samples).
fn path_centre(path: &Se3Path, duration: f64) -> Vector3<f64> {
    if let Se3Path::Circle(c) = path {
        return c.center();
    }
    let n = ((duration / PATH_CHECK_STEP).ceil() as usize).clamp(1, MAX_PATH_SAMPLES);
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for k in 0..=n {
        let p = path.sample(duration * k as f64 / n as f64).p;
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    (lo + hi) / 2.0
}

/// The arms reach the desired path within their joint limits and away from singularities:
/// inverse kinematics of the closed chain by continuation along the path (every 50 ms, at most
/// 4000 samples), from `q_guess` at `t = 0`. Returns the configuration at `t = 0`, the
/// largest diagonal entries of the chart-space inertia `M_x` along the path, and the smallest
/// effective inertias `1/(M_x⁻¹)_jj` along it (the lightest each output can be when the others
/// move freely; `docs/smooth-nn.md`).
fn check_path_reach(
    plant: &SpatialPlant,
    model: &ObjectModel,
    chart: &Chart,
    path: &Se3Path,
    duration: f64,
    q_guess: &[f64],
) -> Result<PathReach, ModelError> {
    let n = ((duration / PATH_CHECK_STEP).ceil() as usize).clamp(1, MAX_PATH_SAMPLES);
    let mut q = q_guess.to_vec();
    let zero = vec![0.0; q.len()];
    let mut ws = plant.workspace();
    let mut mws = model.workspace();
    let mut q0 = None;
    let mut inertia = Vector6::zeros();
    let mut light = Vector6::repeat(f64::INFINITY);
    for k in 0..=n {
        let t = duration * k as f64 / n as f64;
        let s = path.sample(t);
        let x = Isometry3::from_parts(s.p.into(), s.r);
        let y = plant
            .initial_state(&x, &Vector6::zeros(), &q)
            .map_err(|e| {
                ModelError::geometry(
                    "path",
                    format!(
                        "at t = {t:.2} s the desired pose p = ({:.3}, {:.3}, {:.3}) m is out of the arms' reach or joint limits: {e}",
                        s.p.x, s.p.y, s.p.z
                    ),
                )
            })?;
        q.copy_from_slice(&y[..plant.n_q()]);
        let sigma = plant.min_singular_value(&y, &mut ws);
        if sigma < MIN_PATH_SIGMA {
            return Err(ModelError::geometry(
                "path",
                format!(
                    "at t = {t:.2} s the desired pose puts an arm near a singular configuration (σ_min = {sigma:.4} m/rad < {MIN_PATH_SIGMA})"
                ),
            ));
        }
        model.kinematics(&q, &zero, &mut mws);
        if let Some(d) = model.dynamics(&q, &zero, &x, &Vector6::zeros(), &mut mws) {
            let ei = chart.sample(&PoseSample::at_rest(s.p, s.r)).jac.e_inv();
            let mx = ei.transpose() * d.m * ei;
            inertia = inertia.sup(&mx.diagonal());
            if let Some(inv) = mx.try_inverse() {
                light = light.inf(&inv.diagonal().map(|d| 1.0 / d));
            }
        }
        if q0.is_none() {
            q0 = Some(q.clone());
        }
    }
    Ok((q0.unwrap_or_else(|| q_guess.to_vec()), inertia, light))
}

/// What [`check_path_reach`] returns: the configuration at `t = 0`, the largest diagonal of
/// the chart-space inertia along the path, and the smallest effective inertias `1/(M_x⁻¹)_jj`.
type PathReach = (Vec<f64>, Vector6<f64>, Vector6<f64>);

/// A posture must be finite and inside every joint's limits.
fn check_posture(plant: &SpatialPlant, q: &[f64]) -> Result<(), ModelError> {
    if q.len() != plant.n_q() {
        return Err(ModelError::geometry(
            "posture.q_rest",
            format!(
                "has {} entries, the arms have {} joints",
                q.len(),
                plant.n_q()
            ),
        ));
    }
    let mut k = 0;
    for (i, arm) in plant.arms().iter().enumerate() {
        for j in &arm.chain.joints {
            let v = q[k];
            if !(v >= j.limits.lower && v <= j.limits.upper) {
                return Err(ModelError::invalid(
                    format!("posture.q_rest[{k}]"),
                    v,
                    format!(
                        "is outside the limits [{:.4}, {:.4}] rad of arms[{i}] joint `{}`: the posture is unreachable",
                        j.limits.lower, j.limits.upper, j.name
                    ),
                ));
            }
            k += 1;
        }
    }
    Ok(())
}
