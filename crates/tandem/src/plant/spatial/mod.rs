//! The spatial closed chain (SPEC-spatial S3–S4): URDF arms, an object in SE(3), welded (6-D)
//! or compliant grasps.
//!
//! # Coordinates and state
//! Flat state for the integrators, `n_q` = all arms' joints in arm order:
//!
//! ```text
//! y = [ q (n_q) | p_WO (3) | q_WO = (w, x, y, z) (4) | q̇ (n_q) | v_WO (3) | ω_WO (3) ]
//! ```
//!
//! `p_WO` is the object's centre of mass, `q_WO` its unit orientation quaternion, `[v; ω]` its
//! twist in world axes. Dimension `2 n_q + 13`.
//!
//! # Welds
//! Grasp `i` ties tool frame `T_i` to the object frame `G_i` (`X_OGi`): `X_WTi(q_i) = X_WO X_OGi`.
//! With `r_i = R_WO p_OGi` (world vector from the centre of mass to the grasp origin) and
//! `Ad_i = [[I, −[r_i]×], [0, I]]` (the transport of the object twist to the grasp origin):
//!
//! ```text
//! velocity      J_i q̇_i = Ad_i V_o
//! acceleration  J_i q̈_i + J̇_i q̇_i = Ad_i V̇_o + c_i,   c_i = [ω × (ω × r_i); 0]
//! ```
//!
//! The grasp wrench `F_i` (the object on arm `i`'s tool frame, about its origin, world axes) is
//! the multiplier: arm `i` obeys `M_i q̈_i + C_i q̇_i + g_i + D_i q̇_i = τ_i + J_iᵀ F_i` and the
//! object obeys [`object`](crate::model::spatial::object)'s equation with `F_o = −Σ G_iᵀ F_i`, `G_i = Ad_i`.
//!
//! # The KKT solve (Schur complement)
//! With the unconstrained accelerations `q̈⁰_i = M_i⁻¹(τ_i − C_i q̇_i − g_i − D_i q̇_i)` and
//! `V̇⁰_o = M_o⁻¹ b_o`, the multipliers solve the `6m × 6m` system
//!
//! ```text
//! K F = γ − (J_i q̈⁰_i + J̇_i q̇_i − Ad_i V̇⁰_o − c_i)_i,
//! K_ij = δ_ij J_i M_i⁻¹ J_iᵀ + Ad_i M_o⁻¹ Ad_jᵀ,
//! ```
//!
//! then `q̈_i = q̈⁰_i + M_i⁻¹ J_iᵀ F_i` and `V̇_o = V̇⁰_o − M_o⁻¹ Σ Ad_jᵀ F_j`. Baumgarte drift
//! control sets `γ_i = −2 ω_b ė_i − ω_b² e_i` on the pose error of the weld, with the rotation
//! part from the **log map** (not a small-angle approximation):
//! `e_i = [p_WTi − p_WGi; Log(R_WTi R_WGiᵀ)]`, `ė_i = J_i q̇_i − Ad_i V_o`. A `K` that is not
//! positive definite (an arm at a singularity that locks the chain) is regularised as
//! `K + ε tr(K)/(6m) I` with ε = 1e-10 and counted in [`SpatialWorkspace::regularised`].
//!
//! # Compliant grasps
//! [`GraspModel::Compliant`] replaces each weld by a stiff 6-D spring–damper, diagonal in `G_i`
//! axes: with `e_G = [R_WGᵀ(p_WT − p_WG); Log(R_WGᵀ R_WT)]` and the relative twist of the tool
//! against the object point under it, `ė_G`, the wrench on the arm is
//! `F_i = −blkdiag(R_WG, R_WG)(K e_G + D ė_G)`, and `−F_i` acts on the object at the tool origin
//! (so linear and angular momentum balance exactly). No multipliers: the chain is an ODE.
//!
//! # Integration
//! [`SpatialPlant::step`]: classic RK4 ([`Rk4`]) on the flat state with the input held, then the
//! quaternion is renormalised after every step (a projection onto `|q| = 1` whose error is
//! `O(h⁵)`, so the method stays 4th order). An adaptive reference is the Dormand–Prince
//! integrator on the same [`SpatialOde`].
//!
//! No allocation in [`SpatialPlant::derivative`] or [`SpatialPlant::step`]: every buffer is in
//! [`SpatialWorkspace`], sized by [`SpatialPlant::workspace`].

#![allow(non_snake_case)]

pub mod branches;
pub mod contact;
#[allow(non_snake_case)]
mod kkt;
pub mod placement;

pub use contact::{
    ContactEvent, ContactLog, ContactModel, ContactParams, Pad, PadGauge, PadReading, PadStatus,
};

use nalgebra::{
    DVector, Isometry3, Matrix3, Matrix6, Quaternion, Translation3, UnitQuaternion, Vector3,
    Vector6,
};

use crate::dynamics::spatial;
use crate::dynamics::spatial::ChainData;
use crate::error::{ModelError, non_negative};
pub(crate) use crate::geometry::motion::stack as v6;
pub(crate) use crate::geometry::so3::{hat as skew, log_quat};
use crate::math::integrate::{OdeSystem, Rk4};
use crate::model::spatial::SpatialArm;
use crate::model::spatial::object::{RigidObject, SpatialObjectParams};
use crate::plant::Energy;

/// How the grasps hold the object.
#[derive(Clone, Debug, PartialEq)]
pub enum GraspModel {
    /// Rigid welds (6 constraints per grasp, multipliers = grasp wrenches). The default.
    Weld,
    /// A 6-D spring–damper per grasp, diagonal in the grasp frame's axes.
    Compliant {
        /// Stiffness, (N/m ×3, N m/rad ×3), > 0.
        stiffness: Vector6<f64>,
        /// Damping, (N s/m ×3, N m s/rad ×3), ≥ 0.
        damping: Vector6<f64>,
    },
    /// Pads pressing on the box's faces, held by friction ([`contact`]).
    Contact(ContactParams),
}

/// Heaviest object the spatial plant accepts, as a multiple of the arms' total link mass (1e6:
/// physically no arm carries that; numerically the closed chain still solves a 1e7 ratio).
pub const MAX_OBJECT_TO_ARMS_MASS: f64 = 1e6;

/// Parameters of the spatial closed chain (plain data), validated by [`SpatialPlant::new`].
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialPlantParams {
    /// The arms with their base placements.
    pub arms: Vec<SpatialArm>,
    /// `X_OGi`: grasp frame of arm `i` in the object frame (one per arm).
    pub grasps: Vec<Isometry3<f64>>,
    /// The object.
    pub object: SpatialObjectParams,
    /// Gravity acceleration in world axes, m/s² (SPEC-spatial S1: `(0, 0, −9.81)`).
    pub gravity: Vector3<f64>,
    /// Baumgarte natural frequency `ω_b` (critically damped), rad/s; 0 disables.
    pub baumgarte: f64,
    /// Welds, compliant grasps or contact grasps.
    pub grasp_model: GraspModel,
    /// Pads declared on weld or compliant grasps, to gauge the friction each grasp would need
    /// ([`contact::PadGauge`]): the plant keeps its welds or springs and reports, per pad, the
    /// force stuck pads of this stiffness would carry and its cone margins. `None` for contact
    /// grasps (their pads report themselves).
    pub pad_gauge: Option<ContactParams>,
}

/// Joint torques and the environment wrench on the object, held over a step (ZOH).
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialInput {
    /// Joint torques (forces for prismatic joints) of all arms, stacked, N m (n_q).
    pub tau: Vec<f64>,
    /// Environment disturbance `F_d = [f; τ]` on the object about its centre of mass, world
    /// axes (subtracted), (N, N m).
    pub f_d: Vector6<f64>,
    /// Contact grasps: the grip force of each grasp, N (one per arm; empty or shorter: the
    /// model's nominal grip for the rest), each in `[0, MAX_GRIP]` (else
    /// [`SpatialPlant::step`] refuses the step with [`StepFault::BadGrip`]). Ignored by welds
    /// and compliant grasps (and by pads that only gauge them).
    pub grip: Vec<f64>,
}

/// A validated, immutable spatial plant.
#[derive(Clone, Debug)]
pub struct SpatialPlant {
    arms: Vec<SpatialArm>,
    grasps: Vec<Isometry3<f64>>,
    object: RigidObject,
    g_W: Vector3<f64>,
    baumgarte: f64,
    grasp_model: GraspModel,
    /// The validated contact grasps, for [`GraspModel::Contact`].
    contact: Option<ContactModel>,
    /// Pads gauging weld or compliant grasps ([`SpatialPlantParams::pad_gauge`]).
    gauge: Option<PadGauge>,
    offsets: Vec<usize>,
    n_q: usize,
}

/// Scratch and the secondary results of the last evaluation. The public fields are outputs:
/// read them, do not write them (the workspace reuses its state-only part when the same state
/// comes back).
#[derive(Clone, Debug)]
pub struct SpatialWorkspace {
    /// Per-arm kinematics and dynamics of the last evaluation.
    pub data: Vec<ChainData>,
    /// Grasp wrenches `F_i` of the last evaluation (the object on tool `i`, about the tool
    /// origin, world axes), (N, N m).
    pub wrenches: Vec<Vector6<f64>>,
    /// Object acceleration `[v̇; ω̇]` of the last evaluation.
    pub a_o: Vector6<f64>,
    /// Smallest pivot ratio of the last grasp-space Cholesky (conditioning indicator).
    pub kkt_pivot: f64,
    /// Evaluations whose grasp-space matrix needed regularisation.
    pub regularised: u64,
    /// Cholesky factor of each `M_i`, row-major `n_i × n_i`.
    chol: Vec<Vec<f64>>,
    /// Per arm `[u | Z] = L⁻¹ [τ − Cq̇ − g − Dq̇ | Jᵀ]`, row-major `n_i × 7`.
    x: Vec<Vec<f64>>,
    /// Grasp-space matrix `K` and then its factor, row-major `6m × 6m`.
    k: Vec<f64>,
    /// `K` before factorisation (to regularise after a failed factorisation).
    k_copy: Vec<f64>,
    /// Right-hand side, then the multipliers (6m).
    rhs: Vec<f64>,
    /// Per grasp: where `−F_i` acts on the object, from its centre of mass, world axes, m.
    r: Vec<Vector3<f64>>,
    /// Per grasp `[r_i]× I_W⁻¹`.
    a: Vec<Matrix3<f64>>,
    /// Locked-chain events of [`SpatialPlant::step`].
    pub locked: LockedEvents,
    /// The state at the start of the current step (to undo a non-finite step).
    y_prev: Vec<f64>,
    /// The state of the last successful weld evaluation, whose state-only part (terms, `L_i`,
    /// `Z_i`, the factored `K`) the workspace still holds ([`SpatialPlant::derivative`] reuses
    /// it for the same state with another input).
    cache_y: Vec<f64>,
    /// `cache_y` is valid.
    cache_valid: bool,
    /// That evaluation's `K` needed regularisation.
    cache_regularised: bool,
    /// Per arm `u = L⁻¹(τ − b)` scratch (cache hits).
    u: Vec<Vec<f64>>,
    /// Contact grasps: the pads' readings, events, slip totals and margin minima, updated
    /// after every step (empty for other grasp models).
    pub contacts: ContactLog,
}

impl SpatialWorkspace {
    /// Grasp wrench `i` of the last evaluation in tool axes, as arm `i`'s wrist force/torque
    /// sensor reads it: `blkdiag(R_WTᵀ, R_WTᵀ) F_i` (needs the arm's kinematics of the same
    /// evaluation, which [`SpatialPlant::derivative`] leaves in `data`).
    pub fn tool_wrench(&self, i: usize) -> Vector6<f64> {
        let r = &self.data[i].X_WT.rotation;
        let f = &self.wrenches[i];
        v6(
            &r.inverse_transform_vector(&f.fixed_rows::<3>(0).into_owned()),
            &r.inverse_transform_vector(&f.fixed_rows::<3>(3).into_owned()),
        )
    }
}

/// Why a spatial plant step stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepFault {
    /// The state became non-finite in the RK4 step that started at `t` (s); the state was left
    /// at the start of that step.
    NonFinite {
        /// Start of the failed step, s.
        t: f64,
    },
    /// `input.grip[index]` was not a grip force in `[0, MAX_GRIP]` N (or the list was longer
    /// than the grasps); nothing was stepped.
    BadGrip {
        /// When the step would have started, s.
        t: f64,
        /// The entry of `SpatialInput::grip`.
        index: usize,
        /// Its value (`NaN` for an entry past the grasps).
        value: f64,
    },
}

impl std::fmt::Display for StepFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepFault::NonFinite { t } => {
                write!(
                    f,
                    "the spatial plant state became non-finite in the step at t = {t:.4} s"
                )
            }
            StepFault::BadGrip { t, index, value } => {
                write!(
                    f,
                    "input.grip[{index}] = {value} at t = {t:.4} s: a grip is a pressing force \
                     in [0, {}] N, one per grasp",
                    contact::MAX_GRIP
                )
            }
        }
    }
}

/// Steps at a locked configuration (the grasp-space matrix regularised), counted by
/// [`SpatialPlant::step`], with the time and the state at the start of the first one.
#[derive(Clone, Debug, PartialEq)]
pub struct LockedEvents {
    /// Steps that needed regularisation.
    pub steps: u64,
    /// Start time of the first such step, s.
    pub first_t: Option<f64>,
    /// The state at the start of the first such step (all zero until then).
    pub first_state: Vec<f64>,
}

/// The object part of a state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectState {
    /// `p_WO`, m.
    pub p: Vector3<f64>,
    /// `R_WO` as a unit quaternion.
    pub q: UnitQuaternion<f64>,
    /// `v_WO`, m/s.
    pub v: Vector3<f64>,
    /// `ω_WO`, world axes, rad/s.
    pub w: Vector3<f64>,
}

impl ObjectState {
    /// The pose `X_WO`.
    pub fn pose(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.p), self.q)
    }
    /// The twist `[v; ω]`.
    pub fn twist(&self) -> Vector6<f64> {
        Vector6::new(self.v.x, self.v.y, self.v.z, self.w.x, self.w.y, self.w.z)
    }
}

/// Relative regularisation of a singular grasp-space matrix.
const K_REG: f64 = 1e-10;

impl SpatialPlant {
    /// Validate every part and build the plant. Errors name the item: `arms[i]...`,
    /// `grasps[i]`, `object.*`, `gravity`, `baumgarte`, `grasp_model.*`.
    pub fn new(p: &SpatialPlantParams) -> Result<Self, ModelError> {
        if p.arms.is_empty() {
            return Err(ModelError::geometry("arms", "at least one arm is needed"));
        }
        if p.grasps.len() != p.arms.len() {
            return Err(ModelError::geometry(
                "grasps",
                format!(
                    "{} grasps for {} arms: one grasp frame per arm",
                    p.grasps.len(),
                    p.arms.len()
                ),
            ));
        }
        let mut offsets = Vec::with_capacity(p.arms.len());
        let mut n_q = 0;
        for (i, a) in p.arms.iter().enumerate() {
            a.chain
                .validate()
                .map_err(|e| prefix(&format!("arms[{i}]"), e))?;
            let b = &a.base;
            if !(b.translation.vector.iter().all(|v| v.is_finite())
                && b.rotation.coords.iter().all(|v| v.is_finite()))
            {
                return Err(ModelError::geometry(
                    format!("arms[{i}].base"),
                    "must be finite",
                ));
            }
            offsets.push(n_q);
            n_q += a.chain.dof();
        }
        for (i, g) in p.grasps.iter().enumerate() {
            if !(g.translation.vector.iter().all(|v| v.is_finite())
                && g.rotation.coords.iter().all(|v| v.is_finite()))
            {
                return Err(ModelError::geometry(
                    format!("grasps[{i}]"),
                    "must be finite",
                ));
            }
        }
        for i in 0..p.grasps.len() {
            for j in 0..i {
                if (p.grasps[i].translation.vector - p.grasps[j].translation.vector).norm() < 1e-6 {
                    return Err(ModelError::geometry(
                        format!("grasps[{i}]"),
                        format!("coincides with grasps[{j}] (closer than 1 µm)"),
                    ));
                }
            }
        }
        let object = RigidObject::new(&p.object)?;
        // An object a million times heavier than the arms that carry it is no set-up (real arms
        // carry about their own mass at most), and far beyond it the closed chain's solve has
        // no digits left (a 1e300 kg box faults at t = 0): refused here, by its field.
        let arms_mass: f64 = p
            .arms
            .iter()
            .flat_map(|a| a.chain.bodies.iter().map(|b| b.mass))
            .sum();
        if arms_mass > 0.0 && !(p.object.mass <= MAX_OBJECT_TO_ARMS_MASS * arms_mass) {
            return Err(ModelError::invalid(
                "object.mass",
                p.object.mass,
                format!(
                    "must be at most {MAX_OBJECT_TO_ARMS_MASS:e} times the arms' total mass ({} kg): no arm carries it, and the closed chain's solve loses its digits",
                    crate::error::fmt_fixed(arms_mass, 3)
                ),
            ));
        }
        if !p.gravity.iter().all(|v| v.is_finite()) || p.gravity.norm() > 1e3 {
            return Err(ModelError::geometry(
                "gravity",
                "must be finite with |g| ≤ 1000 m/s²",
            ));
        }
        non_negative("baumgarte", p.baumgarte)?;
        if p.baumgarte > 1e4 {
            return Err(ModelError::invalid(
                "baumgarte",
                p.baumgarte,
                "must be ≤ 1e4 rad/s (stiffer drift control is unstable at any usable step)",
            ));
        }
        if let GraspModel::Compliant { stiffness, damping } = &p.grasp_model {
            for k in 0..6 {
                crate::error::positive(&format!("grasp_model.stiffness[{k}]"), stiffness[k])?;
                non_negative(&format!("grasp_model.damping[{k}]"), damping[k])?;
            }
        }
        let contact = match &p.grasp_model {
            GraspModel::Contact(c) => Some(ContactModel::new(c, &p.grasps)?),
            _ => None,
        };
        let gauge = match (&p.pad_gauge, &contact) {
            (None, _) => None,
            (Some(_), Some(_)) => {
                return Err(ModelError::geometry(
                    "pad_gauge",
                    "contact grasps report their own pads: declare pads to gauge only on weld \
                     or compliant grasps",
                ));
            }
            (Some(g), None) => Some(PadGauge::new(g, &p.grasps)?),
        };
        Ok(SpatialPlant {
            arms: p.arms.clone(),
            grasps: p.grasps.clone(),
            object,
            g_W: p.gravity,
            baumgarte: p.baumgarte,
            grasp_model: p.grasp_model.clone(),
            contact,
            gauge,
            offsets,
            n_q,
        })
    }

    /// The arms.
    pub fn arms(&self) -> &[SpatialArm] {
        &self.arms
    }
    /// The grasp frames `X_OGi`.
    pub fn grasps(&self) -> &[Isometry3<f64>] {
        &self.grasps
    }
    /// The object.
    pub fn object(&self) -> &RigidObject {
        &self.object
    }
    /// Gravity in world axes.
    pub fn gravity(&self) -> Vector3<f64> {
        self.g_W
    }
    /// The grasp model.
    pub fn grasp_model(&self) -> &GraspModel {
        &self.grasp_model
    }
    /// Number of joints over all arms.
    pub fn n_q(&self) -> usize {
        self.n_q
    }
    /// Index of arm `i`'s first joint in the stacked joint vector.
    pub fn offset(&self, i: usize) -> usize {
        self.offsets[i]
    }
    /// The validated contact grasps ([`GraspModel::Contact`]).
    pub fn contact(&self) -> Option<&ContactModel> {
        self.contact.as_ref()
    }
    /// The pads the run reports: the contact grasps', or those gauging weld or compliant
    /// grasps ([`SpatialPlantParams::pad_gauge`]).
    pub fn pads(&self) -> Option<&ContactModel> {
        self.contact
            .as_ref()
            .or(self.gauge.as_ref().map(|g| &g.model))
    }
    /// The parameters of the pads the run reports ([`pads`](Self::pads)).
    pub fn pad_params(&self) -> Option<&ContactParams> {
        match (&self.grasp_model, &self.gauge) {
            (GraspModel::Contact(c), _) => Some(c),
            (_, Some(g)) => Some(&g.params),
            _ => None,
        }
    }
    /// Whether the pads only gauge weld or compliant grasps (they hold nothing).
    pub fn pads_gauge_only(&self) -> bool {
        self.gauge.is_some()
    }
    /// Pads gauging weld or compliant grasps: their readings, margins and events at `t` from
    /// the grasp wrenches of the last evaluation (`ws.wrenches`) and the object's orientation
    /// in `y`, into `ws.contacts`. Nothing for other plants. No allocation.
    pub fn gauge_pads(&self, t: f64, y: &[f64], ws: &mut SpatialWorkspace) {
        let Some(g) = &self.gauge else { return };
        let (_, o, _) = self.split(y);
        let q = o.pose().rotation;
        for i in 0..self.arms.len() {
            let w = ws.wrenches[i];
            g.update(i, &w, &q, t, &mut ws.contacts);
        }
    }
    /// Index of the first pad anchor in the flat state (`2 n_q + 13`; three numbers a pad,
    /// contact grasps only).
    pub fn anchor_offset(&self) -> usize {
        2 * self.n_q + 13
    }
    /// Flat state dimension `2 n_q + 13`, plus `3` per pad for contact grasps.
    pub fn state_dim(&self) -> usize {
        2 * self.n_q + 13 + 3 * self.contact.as_ref().map_or(0, |c| c.n_pads())
    }

    /// A workspace sized for this plant (the only allocation).
    pub fn workspace(&self) -> SpatialWorkspace {
        let m = self.arms.len();
        SpatialWorkspace {
            data: self.arms.iter().map(ChainData::new).collect(),
            wrenches: vec![Vector6::zeros(); m],
            a_o: Vector6::zeros(),
            kkt_pivot: 1.0,
            regularised: 0,
            chol: self
                .arms
                .iter()
                .map(|a| vec![0.0; a.chain.dof() * a.chain.dof()])
                .collect(),
            x: self
                .arms
                .iter()
                .map(|a| vec![0.0; a.chain.dof() * 7])
                .collect(),
            k: vec![0.0; 36 * m * m],
            k_copy: vec![0.0; 36 * m * m],
            rhs: vec![0.0; 6 * m],
            r: vec![Vector3::zeros(); m],
            a: vec![Matrix3::zeros(); m],
            locked: LockedEvents {
                steps: 0,
                first_t: None,
                first_state: vec![0.0; self.state_dim()],
            },
            y_prev: vec![0.0; self.state_dim()],
            cache_y: vec![0.0; self.state_dim()],
            cache_valid: false,
            cache_regularised: false,
            u: self.arms.iter().map(|a| vec![0.0; a.chain.dof()]).collect(),
            contacts: match self.pads() {
                Some(c) => ContactLog {
                    gauged: self.gauge.is_some(),
                    ..ContactLog::new(c)
                },
                None => ContactLog::empty(),
            },
        }
    }

    /// A zero input.
    pub fn zero_input(&self) -> SpatialInput {
        SpatialInput {
            tau: vec![0.0; self.n_q],
            f_d: Vector6::zeros(),
            grip: self.contact.as_ref().map_or(Vec::new(), |c| c.grip.clone()),
        }
    }

    /// Split a flat state into `(q, object, q̇)`. The quaternion is normalised on read.
    pub fn split<'a>(&self, y: &'a [f64]) -> (&'a [f64], ObjectState, &'a [f64]) {
        let n = self.n_q;
        let q = &y[..n];
        let o = &y[n..n + 7];
        let qd = &y[n + 7..2 * n + 7];
        let t = &y[2 * n + 7..2 * n + 13];
        let quat = UnitQuaternion::from_quaternion(Quaternion::new(o[3], o[4], o[5], o[6]));
        (
            q,
            ObjectState {
                p: Vector3::new(o[0], o[1], o[2]),
                q: quat,
                v: Vector3::new(t[0], t[1], t[2]),
                w: Vector3::new(t[3], t[4], t[5]),
            },
            qd,
        )
    }

    /// Write the object part of a flat state (quaternion in `w ≥ 0` hemisphere).
    pub fn set_object(&self, y: &mut [f64], o: &ObjectState) {
        let n = self.n_q;
        let mut c = o.q.coords; // (x, y, z, w)
        if c.w < 0.0 {
            c = -c;
        }
        y[n..n + 7].copy_from_slice(&[o.p.x, o.p.y, o.p.z, c.w, c.x, c.y, c.z]);
        y[2 * n + 7..2 * n + 13].copy_from_slice(&[o.v.x, o.v.y, o.v.z, o.w.x, o.w.y, o.w.z]);
    }

    /// Renormalise the quaternion of a flat state (after an integration step).
    #[inline]
    pub fn normalize(&self, y: &mut [f64]) {
        let n = self.n_q;
        let qv = &mut y[n + 3..n + 7];
        let s = (qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2] + qv[3] * qv[3]).sqrt();
        if s > 0.0 && s.is_finite() {
            let inv = 1.0 / s;
            for v in qv.iter_mut() {
                *v *= inv;
            }
        }
    }

    /// `X_WGi` for the object pose `X_WO`.
    pub fn grasp_pose(&self, i: usize, x_wo: &Isometry3<f64>) -> Isometry3<f64> {
        x_wo * self.grasps[i]
    }

    /// Weld residual of arm `i` from `d.X_WT` (kinematics done): `[p_T − p_G; Log(R_T R_Gᵀ)]`.
    fn weld_error(&self, i: usize, x_wo: &Isometry3<f64>, x_wt: &Isometry3<f64>) -> Vector6<f64> {
        let x_wg = self.grasp_pose(i, x_wo);
        let dp = x_wt.translation.vector - x_wg.translation.vector;
        let dr = log_quat(&(x_wt.rotation * x_wg.rotation.inverse()));
        v6(&dp, &dr)
    }

    /// Largest weld residual over the grasps: (position, m; rotation, rad). Runs the
    /// kinematics of every arm into `ws.data`.
    pub fn constraint_residual(&self, y: &[f64], ws: &mut SpatialWorkspace) -> (f64, f64) {
        ws.cache_valid = false;
        let (q, o, _) = self.split(y);
        let x_wo = o.pose();
        let (mut lin, mut ang) = (0.0f64, 0.0f64);
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let qi = &q[self.offsets[i]..self.offsets[i] + n];
            spatial::kinematics(arm, qi, None, &mut ws.data[i]);
            let e = self.weld_error(i, &x_wo, &ws.data[i].X_WT);
            lin = lin.max(e.fixed_rows::<3>(0).norm());
            ang = ang.max(e.fixed_rows::<3>(3).norm());
        }
        (lin, ang)
    }

    /// Velocity-level weld residual `max_i |J_i q̇_i − Ad_i V_o|` (linear, angular).
    pub fn velocity_residual(&self, y: &[f64], ws: &mut SpatialWorkspace) -> (f64, f64) {
        ws.cache_valid = false;
        let (q, o, qd) = self.split(y);
        let (mut lin, mut ang) = (0.0f64, 0.0f64);
        let r_wo = o.q;
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let s = self.offsets[i];
            spatial::kinematics(arm, &q[s..s + n], None, &mut ws.data[i]);
            let vt = kkt::tool_twist(&ws.data[i], &qd[s..s + n]);
            let r = r_wo * self.grasps[i].translation.vector;
            let vg = o.v + o.w.cross(&r);
            lin = lin.max((vt.fixed_rows::<3>(0) - vg).norm());
            ang = ang.max((vt.fixed_rows::<3>(3) - o.w).norm());
        }
        (lin, ang)
    }

    /// Smallest singular value over the arms' tool Jacobians (6 × n, mixed m and rad units),
    /// from the eigenvalues of `J Jᵀ`. Runs the kinematics into `ws.data`.
    pub fn min_singular_value(&self, y: &[f64], ws: &mut SpatialWorkspace) -> f64 {
        ws.cache_valid = false;
        let (q, _, _) = self.split(y);
        let mut s = f64::INFINITY;
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let qi = &q[self.offsets[i]..self.offsets[i] + n];
            spatial::kinematics(arm, qi, None, &mut ws.data[i]);
            s = s.min(sigma_min(&ws.data[i]));
        }
        s
    }

    /// Kinetic and potential energy `(T, V)` of the whole chain (arms + object; plus the grasp
    /// springs' potential for compliant grasps), J. Runs the arms' dynamics into `ws.data`.
    pub fn energy(&self, y: &[f64], ws: &mut SpatialWorkspace) -> Energy {
        ws.cache_valid = false;
        let (q, o, qd) = self.split(y);
        let mut t = 0.0;
        let mut v = 0.0;
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let s = self.offsets[i];
            let d = &mut ws.data[i];
            spatial::terms(arm, &q[s..s + n], &qd[s..s + n], &self.g_W, d);
            let qdi = &qd[s..s + n];
            for a in 0..n {
                for b in 0..n {
                    t += 0.5 * qdi[a] * d.M[(a, b)] * qdi[b];
                }
            }
            for (k, body) in arm.chain.bodies.iter().enumerate() {
                let c = d.X_WL[k] * nalgebra::Point3::from(body.com);
                v -= body.mass * self.g_W.dot(&c.coords);
            }
        }
        let r = o.q.to_rotation_matrix();
        let i_w = r.matrix() * self.object.inertia * r.matrix().transpose();
        t += 0.5 * self.object.mass * o.v.norm_squared() + 0.5 * o.w.dot(&(i_w * o.w));
        v -= self.object.mass * self.g_W.dot(&o.p);
        if let GraspModel::Compliant { stiffness, .. } = &self.grasp_model {
            let x_wo = o.pose();
            for i in 0..self.arms.len() {
                let e = self.compliant_error(i, &x_wo, &ws.data[i].X_WT);
                for k in 0..6 {
                    v += 0.5 * stiffness[k] * e[k] * e[k];
                }
            }
        }
        if let Some(c) = &self.contact {
            let x_wo = o.pose();
            let base = self.anchor_offset();
            for i in 0..self.arms.len() {
                let g = self.grasp_kin(i, &x_wo, &o, qd, ws);
                let r = c.pads_of(i);
                v += c.energy(i, &g, &y[base + 3 * r.start..base + 3 * r.end]);
            }
        }
        Energy {
            kinetic: t,
            potential: v,
        }
    }

    /// Grasp `i`'s relative kinematics for the contact model (the arm's kinematics, with its
    /// Jacobian, must be in `ws.data[i]`).
    pub(crate) fn grasp_kin<'a>(
        &'a self,
        i: usize,
        x_wo: &'a Isometry3<f64>,
        o: &ObjectState,
        qd: &[f64],
        ws: &'a SpatialWorkspace,
    ) -> contact::GraspKin<'a> {
        let n = self.arms[i].chain.dof();
        let s = self.offsets[i];
        let d = &ws.data[i];
        let vt = kkt::tool_twist(d, &qd[s..s + n]);
        contact::GraspKin {
            x_wo,
            v_o: o.v,
            w_o: o.w,
            x_wt: &d.X_WT,
            v_t: vt.fixed_rows::<3>(0).into_owned(),
            w_t: vt.fixed_rows::<3>(3).into_owned(),
            r_og: &self.grasps[i].rotation,
        }
    }

    /// The contact grasps' readings at the start state `y` (`t = 0`, the nominal grip), so
    /// that a log's first row has them: the anchor update of [`step`](Self::step) at `t = 0`
    /// (a start at rest sticks: its anchors do not move). Nothing for other grasp models.
    pub fn prime_contacts(&self, y: &mut [f64], ws: &mut SpatialWorkspace) {
        if self.contact.is_none() {
            return;
        }
        let input = self.zero_input();
        self.contact_update(0.0, y, &input, ws);
    }

    /// After a step to `(t, y)`: the contact grasps' anchor update (stick, slip, separation)
    /// and their record in `ws.contacts`. Runs the arms' kinematics into `ws.data`.
    fn contact_update(
        &self,
        t: f64,
        y: &mut [f64],
        input: &SpatialInput,
        ws: &mut SpatialWorkspace,
    ) {
        let Some(c) = &self.contact else { return };
        ws.cache_valid = false;
        let base = self.anchor_offset();
        let (q_all, rest) = y.split_at_mut(base);
        let (q, o, qd) = self.split(q_all);
        let x_wo = o.pose();
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let s = self.offsets[i];
            spatial::kinematics(arm, &q[s..s + n], None, &mut ws.data[i]);
        }
        let mut log = std::mem::replace(&mut ws.contacts, ContactLog::empty());
        for i in 0..self.arms.len() {
            let g = self.grasp_kin(i, &x_wo, &o, qd, ws);
            let f_g = input.grip.get(i).copied().unwrap_or(c.grip[i]);
            let r = c.pads_of(i);
            c.update(i, &g, f_g, &mut rest[3 * r.start..3 * r.end], t, &mut log);
        }
        ws.contacts = log;
    }

    /// Compliant-grasp error in `G_i` axes: `[R_WGᵀ(p_T − p_G); Log(R_WGᵀ R_WT)]`.
    fn compliant_error(
        &self,
        i: usize,
        x_wo: &Isometry3<f64>,
        x_wt: &Isometry3<f64>,
    ) -> Vector6<f64> {
        let x_wg = self.grasp_pose(i, x_wo);
        let dp = x_wg
            .rotation
            .inverse_transform_vector(&(x_wt.translation.vector - x_wg.translation.vector));
        let dr = log_quat(&(x_wg.rotation.inverse() * x_wt.rotation));
        v6(&dp, &dr)
    }

    /// State derivative: reads `(y, input)`, writes `dy`, the grasp wrenches and diagnostics in
    /// `ws`. Returns `false` if an arm's inertia was not positive definite (never for a
    /// validated model at finite states).
    pub fn derivative(
        &self,
        y: &[f64],
        input: &SpatialInput,
        ws: &mut SpatialWorkspace,
        dy: &mut [f64],
    ) -> bool {
        kkt::derivative(self, y, input, ws, dy)
    }

    /// `n` RK4 steps of size `h` from `(t, y)` with the input held, renormalising the
    /// quaternion after each. After it, `ws` holds the last stage's evaluation.
    ///
    /// A step whose grasp-space matrix needed regularisation (a locked chain: arms singular
    /// in directions the object cannot take up, e.g. over-constrained welds) is a counted event
    /// in [`SpatialWorkspace::locked`], with the time and state of the first one. (A single
    /// singular arm does not lock the chain: the object's own inertia keeps `K` positive
    /// definite; the simulation loop watches the arms' σ_min with
    /// [`SpatialPlant::min_singular_value`].) A step that produces a non-finite state is undone (`y` is left
    /// at the last good state, never NaN) and reported as [`StepFault::NonFinite`] with its
    /// time. No allocation.
    pub fn step(
        &self,
        rk: &mut Rk4,
        t: f64,
        y: &mut [f64],
        input: &SpatialInput,
        ws: &mut SpatialWorkspace,
        h: f64,
        n: usize,
    ) -> Result<(), StepFault> {
        if !input.grip.is_empty() {
            let g = self.arms.len();
            for (index, &value) in input.grip.iter().enumerate() {
                let ok =
                    index < g && value.is_finite() && (0.0..=contact::MAX_GRIP).contains(&value);
                if !ok {
                    let value = if index < g { value } else { f64::NAN };
                    return Err(StepFault::BadGrip { t, index, value });
                }
            }
        }
        for k in 0..n {
            let tk = t + k as f64 * h;
            ws.y_prev.copy_from_slice(y);
            let before = ws.regularised;
            {
                let mut sys = SpatialOde {
                    plant: self,
                    ws: &mut *ws,
                    input,
                };
                rk.step(&mut sys, tk, y, h);
            }
            self.normalize(y);
            if !y.iter().all(|v| v.is_finite()) {
                y.copy_from_slice(&ws.y_prev);
                return Err(StepFault::NonFinite { t: tk });
            }
            self.contact_update(tk + h, y, input, ws);
            if ws.regularised > before {
                let ev = &mut ws.locked;
                ev.steps += 1;
                if ev.first_t.is_none() {
                    ev.first_t = Some(tk);
                    ev.first_state.copy_from_slice(&ws.y_prev);
                }
            }
        }
        Ok(())
    }

    /// The grasp matrix of a state, one block per grasp: `out[i] = G_iᵀ = Ad_iᵀ =
    /// [[I, 0], [[r_i]×, I]]` with `r_i = R_WO p_OGi`, so the arms' wrench on the object (about
    /// its centre of mass, world axes) is `F_o = −Σ G_iᵀ F_i` (SPEC-spatial S3). The internal
    /// wrenches are the null space of `[G_1ᵀ … G_mᵀ]` (dimension `6m − 6`).
    pub fn grasp_map(&self, y: &[f64], out: &mut [Matrix6<f64>]) {
        let (_, o, _) = self.split(y);
        for (i, g) in out.iter_mut().enumerate().take(self.grasps.len()) {
            *g = grasp_block(&(o.q * self.grasps[i].translation.vector));
        }
    }

    /// Joint torques that hold a state at rest in static equilibrium: each arm's gravity
    /// torques minus `J_iᵀ F_i`, with the grasp wrenches `F_i` the minimum-norm solution of
    /// `Σ G_iᵀ F_i = [m g_W; 0]` (the arms carry the object's weight, no internal wrench).
    /// Writes `tau` (n_q) and the wrenches into `ws.wrenches`; runs the kinematics into
    /// `ws.data`. For set-up, not the hot path (it allocates a small scratch).
    pub fn holding_torques(&self, y: &[f64], ws: &mut SpatialWorkspace, tau: &mut [f64]) {
        ws.cache_valid = false;
        let (q, o, _) = self.split(y);
        let m = self.arms.len();
        // G = [Ad_1ᵀ … Ad_mᵀ] (6 × 6m); min-norm F = Gᵀ (G Gᵀ)⁻¹ w.
        let mut ggt = Matrix6::zeros();
        let mut ads = Vec::with_capacity(m);
        for i in 0..m {
            let adt = grasp_block(&(o.q * self.grasps[i].translation.vector));
            ggt += adt * adt.transpose();
            ads.push(adt);
        }
        let w = v6(&(self.object.mass * self.g_W), &Vector3::zeros());
        let lam = ggt
            .cholesky()
            .map(|c| c.solve(&w))
            .unwrap_or_else(Vector6::zeros);
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let s = self.offsets[i];
            let f = ads[i].transpose() * lam;
            ws.wrenches[i] = f;
            let d = &mut ws.data[i];
            spatial::kinematics(arm, &q[s..s + n], None, d);
            spatial::gravity(arm, &q[s..s + n], &self.g_W, &mut tau[s..s + n], d);
            for k in 0..n {
                tau[s + k] -= d.J.column(k).dot(&f);
            }
        }
    }

    /// The state with the object at `x_wo` moving with twist `twist` (world axes), each arm's
    /// joints solved so that its tool frame sits on its grasp frame, starting from
    /// `q_guess` (stacked, n_q), and joint rates from `J_i q̇_i = Ad_i V_o` (minimum norm).
    ///
    /// Errors name the arm when it cannot reach its grasp (Newton–Raphson with damped least
    /// squares, at most 200 iterations, residual ≤ 1e-12 m and rad), when the solution lies
    /// outside a joint's limits, or when the arm is singular there.
    pub fn initial_state(
        &self,
        x_wo: &Isometry3<f64>,
        twist: &Vector6<f64>,
        q_guess: &[f64],
    ) -> Result<Vec<f64>, ModelError> {
        if q_guess.len() != self.n_q {
            return Err(ModelError::geometry(
                "q_guess",
                format!(
                    "has {} entries, the arms have {} joints",
                    q_guess.len(),
                    self.n_q
                ),
            ));
        }
        if let Some(j) = q_guess.iter().position(|v| !v.is_finite()) {
            return Err(ModelError::invalid(
                format!("q_guess[{j}]"),
                q_guess[j],
                "must be finite",
            ));
        }
        let mut y = vec![0.0; self.state_dim()];
        let mut ws = self.workspace();
        for (i, arm) in self.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let s = self.offsets[i];
            let mut q = q_guess[s..s + n].to_vec();
            let x_wg = self.grasp_pose(i, x_wo);
            solve_ik(arm, &x_wg, &mut q, &mut ws.data[i]).map_err(|res| {
                ModelError::geometry(
                    format!("arms[{i}]"),
                    format!(
                        "cannot reach its grasp frame from the start pose (closest: {:.3e} m, {:.3e} rad off after the inverse kinematics)",
                        res.0, res.1
                    ),
                )
            })?;
            for (k, j) in arm.chain.joints.iter().enumerate() {
                // A revolute angle a whole turn outside its range is the same pose inside it.
                if let Some(v) = j.wrap_into_limits(q[k], q_guess[s + k]) {
                    q[k] = v;
                }
                if q[k] < j.limits.lower - 1e-9 || q[k] > j.limits.upper + 1e-9 {
                    return Err(ModelError::geometry(
                        format!("arms[{i}].joint {}", j.name),
                        format!(
                            "the start pose needs q = {:.4} outside its limits [{:.4}, {:.4}]",
                            q[k], j.limits.lower, j.limits.upper
                        ),
                    ));
                }
            }
            // Rates: J q̇ = Ad V_o, minimum norm q̇ = Jᵀ (J Jᵀ)⁻¹ V_T.
            let d = &mut ws.data[i];
            spatial::kinematics(arm, &q, None, d);
            let r = x_wo.rotation * self.grasps[i].translation.vector;
            let w = twist.fixed_rows::<3>(3).into_owned();
            let vt = v6(&(twist.fixed_rows::<3>(0) + w.cross(&r)), &w);
            // Full row rank (n ≥ 6): minimum norm Jᵀ(J Jᵀ)⁻¹ V_T; fewer joints: least squares
            // (Jᵀ J)⁻¹ Jᵀ V_T, which must then reproduce V_T.
            let qd: DVector<f64> = if n >= 6 {
                let sol = jjt(d).cholesky().ok_or_else(|| {
                    ModelError::geometry(
                        format!("arms[{i}]"),
                        "is at a singular configuration at the start pose",
                    )
                })?;
                d.J.transpose() * sol.solve(&vt)
            } else {
                let jtj = d.J.transpose() * &d.J;
                let sol = jtj.cholesky().ok_or_else(|| {
                    ModelError::geometry(
                        format!("arms[{i}]"),
                        "is at a singular configuration at the start pose",
                    )
                })?;
                sol.solve(&(d.J.transpose() * vt))
            };
            let miss = (&d.J * &qd - vt).norm();
            if miss > 1e-9 * (1.0 + vt.norm()) {
                return Err(ModelError::geometry(
                    format!("arms[{i}]"),
                    format!("cannot follow the start twist at its grasp ({miss:.3e} off)"),
                ));
            }
            y[s..s + n].copy_from_slice(&q);
            y[self.n_q + 7 + s..self.n_q + 7 + s + n].copy_from_slice(qd.as_slice());
        }
        let o = ObjectState {
            p: x_wo.translation.vector,
            q: x_wo.rotation,
            v: twist.fixed_rows::<3>(0).into_owned(),
            w: twist.fixed_rows::<3>(3).into_owned(),
        };
        self.set_object(&mut y, &o);
        Ok(y)
    }
}

/// Prefix a model error's path (`link x` → `arms[0]: link x`).
fn prefix(p: &str, e: ModelError) -> ModelError {
    match e {
        ModelError::Invalid {
            param,
            value,
            reason,
        } => ModelError::Invalid {
            param: format!("{p}: {param}"),
            value,
            reason,
        },
        ModelError::Geometry { what, reason } => ModelError::Geometry {
            what: format!("{p}: {what}"),
            reason,
        },
    }
}

/// `G_iᵀ = Ad_iᵀ = [[I, 0], [[r]×, I]]` for the grasp at `r` from the centre of mass.
fn grasp_block(r: &Vector3<f64>) -> Matrix6<f64> {
    let mut g = Matrix6::identity();
    g.fixed_view_mut::<3, 3>(3, 0).copy_from(&skew(r));
    g
}

/// `J Jᵀ` (6 × 6) of the tool Jacobian in `d`.
fn jjt(d: &ChainData) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    let n = d.J.ncols();
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
    m
}

/// Smallest singular value of the tool Jacobian in `d` (`√λ_min(J Jᵀ)`; 0 for `n < 6`).
pub(crate) fn sigma_min(d: &ChainData) -> f64 {
    if d.J.ncols() < 6 {
        return 0.0;
    }
    let ev = jjt(d).symmetric_eigenvalues();
    ev.min().max(0.0).sqrt()
}

/// Inverse kinematics of one arm onto `x_wg` by Newton–Raphson with damped least squares,
/// from `q` in place. `Err((lin, ang))` with the closest residual when it does not converge.
pub(crate) fn solve_ik(
    arm: &SpatialArm,
    x_wg: &Isometry3<f64>,
    q: &mut [f64],
    d: &mut ChainData,
) -> Result<(), (f64, f64)> {
    solve_ik_clamped(arm, x_wg, q, d, None)
}

/// [`solve_ik`], with each step's result clamped into `clamp[k] = (lower, upper)` when given
/// (a search that should only find solutions inside the joint limits; without it the same
/// arithmetic as [`solve_ik`]). Converged means 1e-12 m and rad, as the run's start.
pub(crate) fn solve_ik_clamped(
    arm: &SpatialArm,
    x_wg: &Isometry3<f64>,
    q: &mut [f64],
    d: &mut ChainData,
    clamp: Option<&[(f64, f64)]>,
) -> Result<(), (f64, f64)> {
    let n = q.len();
    let mut best = (f64::INFINITY, f64::INFINITY);
    for it in 0..200 {
        spatial::kinematics(arm, q, None, d);
        let dp = x_wg.translation.vector - d.X_WT.translation.vector;
        let dr = log_quat(&(x_wg.rotation * d.X_WT.rotation.inverse()));
        let e = v6(&dp, &dr);
        let (el, ea) = (dp.norm(), dr.norm());
        if el + ea < best.0 + best.1 {
            best = (el, ea);
        }
        if el <= 1e-12 && ea <= 1e-12 {
            return Ok(());
        }
        if !e.iter().all(|v| v.is_finite()) {
            return Err(best);
        }
        // Damped least squares: Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e, λ shrinking as the error falls.
        let lambda2 = if it < 100 {
            (1e-2 * (el + ea)).min(1e-2)
        } else {
            1e-12
        };
        let mut a = jjt(d);
        for k in 0..6 {
            a[(k, k)] += lambda2;
        }
        let Some(ch) = a.cholesky() else {
            return Err(best);
        };
        let x = ch.solve(&e);
        let mut step = d.J.transpose() * x;
        let sn = step.norm();
        if sn > 0.5 {
            step *= 0.5 / sn;
        }
        match clamp {
            None => {
                for k in 0..n {
                    q[k] += step[k];
                }
            }
            Some(c) => {
                for k in 0..n {
                    q[k] = (q[k] + step[k]).clamp(c[k].0, c[k].1);
                }
            }
        }
    }
    Err(best)
}

/// The spatial plant as an [`OdeSystem`] with a held input; writes NaN where the derivative
/// does not exist.
pub struct SpatialOde<'a> {
    /// The model.
    pub plant: &'a SpatialPlant,
    /// Scratch; after a step it holds the last stage's grasp wrenches.
    pub ws: &'a mut SpatialWorkspace,
    /// The held input.
    pub input: &'a SpatialInput,
}

impl OdeSystem for SpatialOde<'_> {
    fn dim(&self) -> usize {
        self.plant.state_dim()
    }
    fn deriv(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        if !self.plant.derivative(y, self.input, self.ws, dy) {
            dy.fill(f64::NAN);
        }
    }
}
