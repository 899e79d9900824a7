//! Contact grasps held by friction: pads on the tools pressing on the faces of a box-shaped
//! object, with a compliant normal, Coulomb friction in elliptic cones (tangential and, for a
//! soft finger, torsional), stick, slip and separation.
//!
//! # The model (per pad)
//! A pad is a disc of radius `ρ` at `p_T` on the tool, pressing along `n_T` (tool axes) on the
//! box face it touches at the start pose. The face has outward normal `σ e_k` in the object
//! frame `O`, tangent axes `t₁ = e_{k+1}`, `t₂ = e_{k+2}`. With `x = X_WO⁻¹ X_WT p_T` the pad
//! centre in `O`, `c` its nominal place (the start pose, `X_OG p_T`) and `Δv` the velocity of
//! the pad centre against the object's material point under it (in `O` axes):
//!
//! ```text
//! penetration   δ = σ (c_k − x_k),          δ̇ = −σ Δv_k
//! normal        N = max(0, F_g + k_n δ + d_n δ̇)
//! stretch       s = (x_t₁ − c_t₁ − a₁, x_t₂ − c_t₂ − a₂),   ṡ = (Δv_t₁, Δv_t₂)
//! twist         φ = σ Log(R_OT R_OGᵀ)_k − ψ,                  φ̇ = σ (ω_T − ω_O)_k
//! trial         f = −k_t s − d_t ṡ,   τ = −k_r φ − d_r φ̇
//! cone          (|f|/μ)² + (τ/μ_τ)² ≤ N²   (elliptic, MuJoCo condim 4; condim 3 when μ_τ = 0)
//! ```
//!
//! `F_g` is the grip force (each pad's normal preload: the gripper closed on the object with
//! that force and holds; a push along the jaw axis loads one pad and unloads the other until
//! it separates). `(a₁, a₂, ψ)` is the pad's **anchor**, where it sticks, a state of the plant
//! (three numbers a pad after the joint and object parts of the flat state). The torsional
//! stiffness is the disc's, `k_r = k_t ρ²/2` (uniform shear over the patch), and likewise `d_r`.
//!
//! A trial outside the cone is brought onto it by the **closest point in the contact's
//! compliance metric** (`|f|²/k_t + τ²/k_r`, maximum dissipation): `f ← f/(1 + λ k_t/μ²)`,
//! `τ ← τ/(1 + λ k_r/μ_τ²)` with the `λ ≥ 0` that puts it on the boundary (one monotone
//! equation, Newton from `λ = 0`, safeguarded by bisection). The force on the object is then
//! on the cone and opposes the slip, as Coulomb's law has it.
//!
//! # Stick and slip: the anchor update
//! The anchors are held through each RK4 step (their rate is zero) and updated after it, as the
//! quaternion is renormalised: the elastic trial (`−k_t s`, `−k_r φ`) at the step's end is
//! tested against the cone; inside, the pad sticks (its anchor does not move: the slip distance
//! of a held grasp is exactly 0); outside, the anchor moves so that the elastic force sits on the
//! cone (the return mapping of elasto-plasticity, the spring-anchor friction model of Hayward and
//! Armstrong, 2000). The anchor's displacement is the slip, summed per grasp. A pad whose
//! normal force is 0, or whose centre leaves its face, has separated: its anchor follows it and
//! it sticks again where it touches. No energy is created: the force is the trial scaled into
//! the cone (the dampers only dissipate), and the update only shortens the springs.

use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};

use super::log_quat;
use crate::error::ModelError;

/// One contact pad on a tool.
#[derive(Clone, Debug, PartialEq)]
pub struct Pad {
    /// Centre of the pad's face in the tool frame, m.
    pub position: Vector3<f64>,
    /// The direction the pad presses in, tool axes (into the object; normalised on
    /// validation).
    pub normal: Vector3<f64>,
    /// The pad's radius `ρ`, m (> 0): it must lie inside the face it touches, and it sets the
    /// torsional stiffness `k_t ρ²/2`.
    pub radius: f64,
}

/// Parameters of contact grasps (plain data), validated by the plant.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactParams {
    /// The pads of each grasp (one list per arm; a parallel-jaw gripper has two opposing pads,
    /// a suction cup one).
    pub pads: Vec<Vec<Pad>>,
    /// Grip force per grasp, N (≥ 0): each pad's normal preload.
    pub grip: Vec<f64>,
    /// Coulomb friction coefficient `μ` (> 0).
    pub mu: f64,
    /// Torsional friction coefficient `μ_τ`, m (≥ 0; 0: no torsional friction, MuJoCo condim 3).
    pub torsion: f64,
    /// Normal stiffness `k_n`, N/m (> 0).
    pub normal_stiffness: f64,
    /// Normal damping `d_n`, N s/m (≥ 0).
    pub normal_damping: f64,
    /// Tangential stiffness `k_t`, N/m (> 0).
    pub tangential_stiffness: f64,
    /// Tangential damping `d_t`, N s/m (≥ 0).
    pub tangential_damping: f64,
    /// The object is a box of these half edge lengths along its body axes, m: the pads press on
    /// its faces.
    pub half_extents: Vector3<f64>,
}

/// How close (m) a pad must be to a face at the start pose to touch it, and how far (rad) its
/// pressing direction may be from the face's inward normal.
pub const TOUCH_TOLERANCE: f64 = 1e-6;
/// Largest friction or torsion coefficient accepted (μ, and μ_τ in m): far above any real
/// contact (μ ≈ 0.1–2), and the cone's scaling `μ²` keeps its digits below it.
pub const MAX_COEFFICIENT: f64 = 1e6;
/// Largest grip force accepted, N (industrial grippers squeeze with up to ~1e4 N).
pub const MAX_GRIP: f64 = 1e6;

/// Angular tolerance of a pad's pressing direction against the face normal, rad.
pub const NORMAL_TOLERANCE: f64 = 1e-6;

/// A pad's geometry, precomputed in the object frame.
#[derive(Clone, Debug)]
pub(crate) struct PadGeom {
    pub p_t: Vector3<f64>,
    /// Face axis `k` and sign `σ` (outward normal `σ e_k`).
    pub k: usize,
    pub sign: f64,
    /// Nominal centre in `O`.
    pub c: Vector3<f64>,
    /// Tangent axes.
    pub t: [usize; 2],
    /// Face rectangle half extents along `t`.
    pub half_t: [f64; 2],
    pub k_r: f64,
    pub d_r: f64,
}

/// Validated contact grasps.
#[derive(Clone, Debug)]
pub struct ContactModel {
    pub(crate) pads: Vec<PadGeom>,
    /// First pad of each grasp, and one past the last (len = grasps + 1).
    pub(crate) first: Vec<usize>,
    pub(crate) grip: Vec<f64>,
    pub(crate) mu: f64,
    pub(crate) torsion: f64,
    pub(crate) k_n: f64,
    pub(crate) d_n: f64,
    pub(crate) k_t: f64,
    pub(crate) d_t: f64,
}

/// What a pad is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PadStatus {
    /// Inside its cone: the anchor holds.
    Stick,
    /// On its cone's boundary, sliding.
    Slip,
    /// No normal force (or off its face).
    Separated,
}

/// A change of a pad's status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    /// End of the step at which it was seen, s.
    pub t: f64,
    /// The grasp (arm) index.
    pub grasp: usize,
    /// The pad's index within its grasp.
    pub pad: usize,
    /// The status before.
    pub from: PadStatus,
    /// The status after.
    pub to: PadStatus,
}

/// A pad's forces at the end of the last step, in its face's axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PadReading {
    /// Normal force `N`, N.
    pub normal: f64,
    /// Tangential friction force on the pad `(f_t₁, f_t₂)`, N.
    pub tangential: [f64; 2],
    /// Torsional friction moment about the face normal, N m.
    pub torsion: f64,
    /// Margin to the tangential cone, `μ N − |f_t|`, N.
    pub margin: f64,
    /// Margin to the torsional limit alone, `μ_τ N − |τ|`, N m (0 without torsional
    /// friction).
    pub torsion_margin: f64,
    /// Margin to the elliptic cone, `N − √((|f_t|/μ)² + (τ/μ_τ)²)`, N of normal force: 0 on
    /// the cone, whichever of friction and torsion loads it (the two margins above each ignore
    /// the other).
    pub cone_margin: f64,
    /// Stick, slip or separated.
    pub status: PadStatus,
}

/// Most events a run keeps (later ones are counted in [`ContactLog::dropped`]).
pub const MAX_EVENTS: usize = 4096;

/// The contacts' record: readings, events, slip totals and margin minima. Sized once.
#[derive(Clone, Debug)]
pub struct ContactLog {
    /// Per pad (grasps in order, pads in order): its grasp and its index within the grasp.
    pub pads: Vec<(usize, usize)>,
    /// Per pad, the last step's forces.
    pub readings: Vec<PadReading>,
    /// Status changes, in time order (at most [`MAX_EVENTS`]).
    pub events: Vec<ContactEvent>,
    /// Events not kept.
    pub dropped: u64,
    /// Per grasp, the total slip distance of its pads' anchors, m (the sum over pads).
    pub slip_distance: Vec<f64>,
    /// Per grasp, the total torsional slip, rad (the sum over pads).
    pub slip_angle: Vec<f64>,
    /// Per pad, the smallest tangential margin seen and its time.
    pub min_margin: Vec<(f64, f64)>,
    /// Per pad, the smallest torsional margin seen and its time.
    pub min_torsion_margin: Vec<(f64, f64)>,
    /// Per pad, the smallest elliptic-cone margin seen and its time.
    pub min_cone_margin: Vec<(f64, f64)>,
    /// The pads only gauge weld or compliant grasps ([`PadGauge`]): a `Slip` or `Separated`
    /// status says the grasp would need more friction or grip than the pads give, nothing
    /// moved, and the slip totals stay zero.
    pub gauged: bool,
}

impl ContactLog {
    pub(crate) fn new(model: &ContactModel) -> Self {
        let p = model.pads.len();
        let g = model.grip.len();
        ContactLog {
            pads: (0..g)
                .flat_map(|i| model.pads_of(i).enumerate().map(move |(j, _)| (i, j)))
                .collect(),
            readings: vec![
                PadReading {
                    normal: 0.0,
                    tangential: [0.0; 2],
                    torsion: 0.0,
                    margin: 0.0,
                    torsion_margin: 0.0,
                    cone_margin: 0.0,
                    status: PadStatus::Stick,
                };
                p
            ],
            events: Vec::with_capacity(MAX_EVENTS),
            dropped: 0,
            slip_distance: vec![0.0; g],
            slip_angle: vec![0.0; g],
            min_margin: vec![(f64::INFINITY, 0.0); p],
            min_torsion_margin: vec![(f64::INFINITY, 0.0); p],
            min_cone_margin: vec![(f64::INFINITY, 0.0); p],
            gauged: false,
        }
    }

    /// An empty record (no contact grasps).
    pub(crate) fn empty() -> Self {
        ContactLog {
            pads: Vec::new(),
            readings: Vec::new(),
            events: Vec::new(),
            dropped: 0,
            slip_distance: Vec::new(),
            slip_angle: Vec::new(),
            min_margin: Vec::new(),
            min_torsion_margin: Vec::new(),
            min_cone_margin: Vec::new(),
            gauged: false,
        }
    }
}

fn bad(field: String, msg: impl Into<String>) -> ModelError {
    ModelError::geometry(field, msg.into())
}

impl ContactModel {
    /// Validate the parameters against the grasp frames `X_OGi`. Errors name the field:
    /// `grasp_model.mu`, `grasp_model.pads[i][j].radius`, ….
    pub(crate) fn new(p: &ContactParams, grasps: &[Isometry3<f64>]) -> Result<Self, ModelError> {
        use crate::error::{non_negative, positive};
        if !(p.mu.is_finite() && p.mu > 0.0) {
            return Err(ModelError::invalid(
                "grasp_model.mu",
                p.mu,
                "must be positive and finite (a friction coefficient)",
            ));
        }
        if !(p.torsion.is_finite() && p.torsion >= 0.0) {
            return Err(ModelError::invalid(
                "grasp_model.torsion",
                p.torsion,
                "must be ≥ 0 and finite (a length, m)",
            ));
        }
        for (name, v) in [("grasp_model.mu", p.mu), ("grasp_model.torsion", p.torsion)] {
            if v > MAX_COEFFICIENT {
                return Err(ModelError::invalid(
                    name,
                    v,
                    format!(
                        "must be ≤ {MAX_COEFFICIENT:e} (no contact has more friction; beyond it the cone's scaling loses its digits)"
                    ),
                ));
            }
        }
        positive("grasp_model.normal_stiffness", p.normal_stiffness)?;
        positive("grasp_model.tangential_stiffness", p.tangential_stiffness)?;
        non_negative("grasp_model.normal_damping", p.normal_damping)?;
        non_negative("grasp_model.tangential_damping", p.tangential_damping)?;
        for (name, v) in [
            ("grasp_model.normal_stiffness", p.normal_stiffness),
            ("grasp_model.tangential_stiffness", p.tangential_stiffness),
            ("grasp_model.normal_damping", p.normal_damping),
            ("grasp_model.tangential_damping", p.tangential_damping),
        ] {
            if v > 1e12 {
                return Err(ModelError::invalid(
                    name,
                    v,
                    "must be ≤ 1e12 (no usable step resolves a stiffer contact)",
                ));
            }
        }
        for k in 0..3 {
            positive(&format!("grasp_model.half_extents[{k}]"), p.half_extents[k])?;
        }
        if p.pads.len() != grasps.len() {
            return Err(bad(
                "grasp_model.pads".into(),
                format!(
                    "has {} pad lists for {} grasps: one per arm",
                    p.pads.len(),
                    grasps.len()
                ),
            ));
        }
        if p.grip.len() != grasps.len() {
            return Err(bad(
                "grasp_model.grip".into(),
                format!(
                    "has {} grip forces for {} grasps: one per arm",
                    p.grip.len(),
                    grasps.len()
                ),
            ));
        }
        for (i, g) in p.grip.iter().enumerate() {
            if !(g.is_finite() && *g >= 0.0 && *g <= MAX_GRIP) {
                return Err(ModelError::invalid(
                    format!("grasp_model.grip[{i}]"),
                    *g,
                    format!("must be ≥ 0 and ≤ {MAX_GRIP:e} (a force, N)"),
                ));
            }
        }
        let h = p.half_extents;
        let mut pads = Vec::new();
        let mut first = vec![0];
        for (i, list) in p.pads.iter().enumerate() {
            if list.is_empty() {
                return Err(bad(
                    format!("grasp_model.pads[{i}]"),
                    "is empty: a contact grasp needs at least one pad",
                ));
            }
            if list.len() > 16 {
                return Err(bad(
                    format!("grasp_model.pads[{i}]"),
                    format!("has {} pads: at most 16 per grasp", list.len()),
                ));
            }
            for (j, pad) in list.iter().enumerate() {
                let at = format!("grasp_model.pads[{i}][{j}]");
                if !pad.position.iter().all(|v| v.is_finite()) {
                    return Err(bad(format!("{at}.position"), "must be finite"));
                }
                let nn = pad.normal.norm();
                if !(nn.is_finite() && nn > 1e-9) {
                    return Err(bad(
                        format!("{at}.normal"),
                        "must be a finite non-zero vector",
                    ));
                }
                if !(pad.radius.is_finite() && pad.radius > 0.0) {
                    return Err(ModelError::invalid(
                        format!("{at}.radius"),
                        pad.radius,
                        "must be positive and finite, m",
                    ));
                }
                let x_og = &grasps[i];
                let c = x_og * nalgebra::Point3::from(pad.position);
                let c = c.coords;
                let n_o = x_og.rotation * (pad.normal / nn);
                // The face whose inward normal the pad presses along.
                let (k, comp) = (0..3)
                    .map(|k| (k, n_o[k]))
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .unwrap_or((0, 0.0));
                let sign = -comp.signum();
                let tilt = (1.0 - comp.abs().min(1.0)).max(0.0).sqrt() * std::f64::consts::SQRT_2;
                if tilt > NORMAL_TOLERANCE {
                    return Err(bad(
                        format!("{at}.normal"),
                        format!(
                            "presses {:.3e} rad off the normal of the box face it touches: a pad presses square on a face",
                            tilt
                        ),
                    ));
                }
                let gap = c[k] - sign * h[k];
                if gap.abs() > TOUCH_TOLERANCE {
                    return Err(bad(
                        format!("{at}.position"),
                        format!(
                            "does not touch the object's face at the start pose: it is {:.4} mm {} the face {}{} (the box's half extent {} m)",
                            gap.abs() * 1e3,
                            if gap * sign > 0.0 {
                                "outside"
                            } else {
                                "inside"
                            },
                            if sign > 0.0 { "+" } else { "−" },
                            ["x", "y", "z"][k],
                            h[k]
                        ),
                    ));
                }
                let t = [(k + 1) % 3, (k + 2) % 3];
                for &ax in &t {
                    if c[ax].abs() + pad.radius > h[ax] + TOUCH_TOLERANCE {
                        return Err(bad(
                            format!("{at}.position"),
                            format!(
                                "the pad (radius {} m) reaches {:.4} m along the face's {} axis, outside the face (half extent {} m)",
                                pad.radius,
                                c[ax].abs() + pad.radius,
                                ["x", "y", "z"][ax],
                                h[ax]
                            ),
                        ));
                    }
                }
                let rho2 = 0.5 * pad.radius * pad.radius;
                pads.push(PadGeom {
                    p_t: pad.position,
                    k,
                    sign,
                    c,
                    t,
                    half_t: [h[t[0]], h[t[1]]],
                    k_r: p.tangential_stiffness * rho2,
                    d_r: p.tangential_damping * rho2,
                });
            }
            first.push(pads.len());
        }
        Ok(ContactModel {
            pads,
            first,
            grip: p.grip.clone(),
            mu: p.mu,
            torsion: p.torsion,
            k_n: p.normal_stiffness,
            d_n: p.normal_damping,
            k_t: p.tangential_stiffness,
            d_t: p.tangential_damping,
        })
    }

    /// Number of pads over all grasps.
    pub fn n_pads(&self) -> usize {
        self.pads.len()
    }

    /// The pads of grasp `i`: a range of pad indices.
    pub fn pads_of(&self, i: usize) -> std::ops::Range<usize> {
        self.first[i]..self.first[i + 1]
    }

    /// The nominal grip force of grasp `i`, N.
    pub fn grip(&self, i: usize) -> f64 {
        self.grip[i]
    }

    /// Friction coefficient `μ`.
    pub fn mu(&self) -> f64 {
        self.mu
    }

    /// Torsional friction coefficient `μ_τ`, m.
    pub fn torsion(&self) -> f64 {
        self.torsion
    }
}

/// The relative kinematics of one grasp: the tool pose and twist against the object's.
pub(crate) struct GraspKin<'a> {
    pub x_wo: &'a Isometry3<f64>,
    /// Object twist `[v at the centre of mass; ω]`, world axes.
    pub v_o: Vector3<f64>,
    pub w_o: Vector3<f64>,
    pub x_wt: &'a Isometry3<f64>,
    /// Tool twist `[v at the tool origin; ω]`, world axes.
    pub v_t: Vector3<f64>,
    pub w_t: Vector3<f64>,
    /// `X_OGi` (the tool's nominal orientation on the object).
    pub r_og: &'a UnitQuaternion<f64>,
}

/// One pad's state in its face's axes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PadKin {
    /// Penetration and its rate.
    pub delta: f64,
    pub delta_dot: f64,
    /// Tangential stretch from the anchor, and its rate.
    pub s: [f64; 2],
    pub s_dot: [f64; 2],
    /// Twist from the anchor, and its rate.
    pub phi: f64,
    pub phi_dot: f64,
    /// The pad centre's tangential coordinates on its face.
    pub x_t: [f64; 2],
    /// Pad centre, world.
    pub p_w: Vector3<f64>,
}

/// The relative rotation of the tool on the object, `Log(R_OT R_OGᵀ)` in object axes.
pub(crate) fn relative_rotation(g: &GraspKin) -> Vector3<f64> {
    let r_ot = g.x_wo.rotation.inverse() * g.x_wt.rotation;
    log_quat(&(r_ot * g.r_og.inverse()))
}

impl ContactModel {
    /// The pad's kinematics from the grasp's and its anchor `(a₁, a₂, ψ)`.
    pub(crate) fn pad_kin(
        &self,
        pad: &PadGeom,
        g: &GraspKin,
        theta: &Vector3<f64>,
        anchor: &[f64],
    ) -> PadKin {
        let p_w = g.x_wt * nalgebra::Point3::from(pad.p_t);
        let p_w = p_w.coords;
        let x = g
            .x_wo
            .inverse_transform_point(&nalgebra::Point3::from(p_w))
            .coords;
        let v_pad = g.v_t + g.w_t.cross(&(p_w - g.x_wt.translation.vector));
        let v_mat = g.v_o + g.w_o.cross(&(p_w - g.x_wo.translation.vector));
        let dv = g.x_wo.rotation.inverse_transform_vector(&(v_pad - v_mat));
        let dw = g.x_wo.rotation.inverse_transform_vector(&(g.w_t - g.w_o));
        let (k, s, [t1, t2]) = (pad.k, pad.sign, pad.t);
        PadKin {
            delta: s * (pad.c[k] - x[k]),
            delta_dot: -s * dv[k],
            s: [x[t1] - pad.c[t1] - anchor[0], x[t2] - pad.c[t2] - anchor[1]],
            s_dot: [dv[t1], dv[t2]],
            phi: s * theta[k] - anchor[2],
            phi_dot: s * dw[k],
            x_t: [x[t1], x[t2]],
            p_w,
        }
    }

    /// Whether the pad's centre is on its face.
    fn on_face(pad: &PadGeom, pk: &PadKin) -> bool {
        pk.x_t[0].abs() <= pad.half_t[0] && pk.x_t[1].abs() <= pad.half_t[1]
    }

    /// The normal force with grip `f_g`, N (0 off the face).
    pub(crate) fn normal_force(&self, pad: &PadGeom, pk: &PadKin, f_g: f64, damped: bool) -> f64 {
        if !Self::on_face(pad, pk) {
            return 0.0;
        }
        let d = if damped { self.d_n * pk.delta_dot } else { 0.0 };
        let n = f_g + self.k_n * pk.delta + d;
        if n > 0.0 { n } else { 0.0 }
    }

    /// The friction `(f₁, f₂, τ)` of a trial brought into the cone of normal force `n`
    /// (closest point in the compliance metric). Returns it and whether the trial was
    /// outside.
    pub(crate) fn project_to_cone(
        &self,
        pad: &PadGeom,
        f: [f64; 2],
        tau: f64,
        n: f64,
    ) -> ([f64; 2], f64, bool) {
        if n <= 0.0 {
            return ([0.0; 2], 0.0, f != [0.0; 2] || tau != 0.0);
        }
        let mu = self.mu;
        let ft2 = f[0] * f[0] + f[1] * f[1];
        if self.torsion == 0.0 {
            let lim = mu * n;
            if ft2 <= lim * lim {
                return (f, 0.0, false);
            }
            let sc = lim / ft2.sqrt();
            return ([f[0] * sc, f[1] * sc], 0.0, true);
        }
        let mt = self.torsion;
        let g0 = ft2 / (mu * mu) + tau * tau / (mt * mt);
        if g0 <= n * n {
            return (f, tau, false);
        }
        // g(λ) = |f|²/(μ²(1+aλ)²) + τ²/(μ_τ²(1+bλ)²) − N², decreasing and convex in λ ≥ 0.
        let a = self.k_t / (mu * mu);
        let b = pad.k_r / (mt * mt);
        let g = |l: f64| {
            let ua = 1.0 / (1.0 + a * l);
            let ub = 1.0 / (1.0 + b * l);
            let v = ft2 / (mu * mu) * ua * ua + tau * tau / (mt * mt) * ub * ub - n * n;
            let dv = -2.0 * a * ft2 / (mu * mu) * ua * ua * ua
                - 2.0 * b * tau * tau / (mt * mt) * ub * ub * ub;
            (v, dv)
        };
        // Bracket: g(hi) ≤ 0 at hi = (√g0/N − 1)/min(a, b).
        let (mut lo, mut hi) = (0.0, (g0.sqrt() / n - 1.0) / a.min(b));
        let mut l = 0.0;
        for _ in 0..100 {
            let (v, dv) = g(l);
            if v > 0.0 {
                lo = l;
            } else {
                hi = l;
            }
            if v.abs() <= 1e-14 * n * n {
                break;
            }
            let next = l - v / dv;
            l = if next > lo && next < hi && dv < 0.0 {
                next
            } else {
                0.5 * (lo + hi)
            };
            if hi - lo <= 1e-15 * hi {
                break;
            }
        }
        let sa = 1.0 / (1.0 + a * l);
        let sb = 1.0 / (1.0 + b * l);
        ([f[0] * sa, f[1] * sa], tau * sb, true)
    }

    /// The friction `(f₁, f₂, τ)` the pad transmits: the damped trial `(−k_t s − d_t ṡ,
    /// −k_r φ − d_r φ̇)` brought into the cone of normal force `n`.
    fn friction(&self, pad: &PadGeom, pk: &PadKin, n: f64) -> ([f64; 2], f64) {
        let trial = [
            -self.k_t * pk.s[0] - self.d_t * pk.s_dot[0],
            -self.k_t * pk.s[1] - self.d_t * pk.s_dot[1],
        ];
        let tau_trial = if self.torsion > 0.0 {
            -pad.k_r * pk.phi - pad.d_r * pk.phi_dot
        } else {
            0.0
        };
        let (f, tau, _) = self.project_to_cone(pad, trial, tau_trial, n);
        (f, tau)
    }

    /// The wrench of grasp `i`'s pads on the tool (about the tool origin, world axes), with grip
    /// `f_g`, anchors `anchors` (3 per pad of this grasp, in order).
    pub(crate) fn grasp_wrench(
        &self,
        i: usize,
        g: &GraspKin,
        f_g: f64,
        anchors: &[f64],
    ) -> Vector6<f64> {
        let theta = relative_rotation(g);
        let mut force = Vector3::zeros();
        let mut moment = Vector3::zeros();
        let r_wo = g.x_wo.rotation;
        for (jj, pi) in self.pads_of(i).enumerate() {
            let pad = &self.pads[pi];
            let pk = self.pad_kin(pad, g, &theta, &anchors[3 * jj..3 * jj + 3]);
            let n = self.normal_force(pad, &pk, f_g, true);
            let (f, tau) = self.friction(pad, &pk, n);
            let mut fo = Vector3::zeros();
            fo[pad.k] = pad.sign * n;
            fo[pad.t[0]] = f[0];
            fo[pad.t[1]] = f[1];
            let mut mo = Vector3::zeros();
            mo[pad.k] = pad.sign * tau;
            let fw = r_wo * fo;
            force += fw;
            moment += r_wo * mo + (pk.p_w - g.x_wt.translation.vector).cross(&fw);
        }
        Vector6::new(force.x, force.y, force.z, moment.x, moment.y, moment.z)
    }

    /// After a step ending at `t`: the anchor update of grasp `i`'s pads (stick, slip or
    /// separation), their readings, events, slip totals and margin minima into `log`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn update(
        &self,
        i: usize,
        g: &GraspKin,
        f_g: f64,
        anchors: &mut [f64],
        t: f64,
        log: &mut ContactLog,
    ) {
        let theta = relative_rotation(g);
        for (jj, pi) in self.pads_of(i).enumerate() {
            let pad = &self.pads[pi];
            let an = &mut anchors[3 * jj..3 * jj + 3];
            let pk = self.pad_kin(pad, g, &theta, an);
            let n_damped = self.normal_force(pad, &pk, f_g, true);
            let n_el = self.normal_force(pad, &pk, f_g, false);
            let status;
            let (mut d_lin, mut d_ang) = (0.0, 0.0);
            if n_el <= 0.0 || !Self::on_face(pad, &pk) {
                // Separated: the anchor follows the pad.
                let new = [pk.x_t[0] - pad.c[pad.t[0]], pk.x_t[1] - pad.c[pad.t[1]]];
                let psi = pk.phi + an[2];
                // (Separation is not slip: the pad moves freely.)
                an[0] = new[0];
                an[1] = new[1];
                an[2] = psi;
                status = PadStatus::Separated;
            } else {
                let fe = [-self.k_t * pk.s[0], -self.k_t * pk.s[1]];
                let te = if self.torsion > 0.0 {
                    -pad.k_r * pk.phi
                } else {
                    0.0
                };
                let (f, tau, outside) = self.project_to_cone(pad, fe, te, n_el);
                if self.torsion == 0.0 && pk.phi != 0.0 {
                    // No torsional friction: the twist anchor follows the pad.
                    an[2] += pk.phi;
                }
                if outside {
                    let s_new = [-f[0] / self.k_t, -f[1] / self.k_t];
                    let da = [pk.s[0] - s_new[0], pk.s[1] - s_new[1]];
                    an[0] += da[0];
                    an[1] += da[1];
                    d_lin = (da[0] * da[0] + da[1] * da[1]).sqrt();
                    if self.torsion > 0.0 {
                        let phi_new = -tau / pad.k_r;
                        let dpsi = pk.phi - phi_new;
                        an[2] += dpsi;
                        d_ang = dpsi.abs();
                    }
                    status = PadStatus::Slip;
                } else {
                    status = PadStatus::Stick;
                }
            }
            log.slip_distance[i] += d_lin;
            log.slip_angle[i] += d_ang;
            // The reading: the force the pad transmits now (damped normal, clamped friction).
            let pk = self.pad_kin(pad, g, &theta, an);
            let (f, tau) = self.friction(pad, &pk, n_damped);
            self.record(log, pi, (i, jj), t, n_damped, f, tau, status);
        }
    }

    /// Pad `pi` (`jj` of grasp `i`) at `t`: its reading (normal force `n`, friction `f`,
    /// torsion `tau` on the tool, and `status`), the margins to its cone, their minima and a
    /// status change as an event, into `log`.
    #[allow(clippy::too_many_arguments)]
    fn record(
        &self,
        log: &mut ContactLog,
        pi: usize,
        (i, jj): (usize, usize),
        t: f64,
        n: f64,
        f: [f64; 2],
        tau: f64,
        status: PadStatus,
    ) {
        let margin = self.mu * n - (f[0] * f[0] + f[1] * f[1]).sqrt();
        let torsion_margin = self.torsion * n - tau.abs();
        let ft2 = (f[0] * f[0] + f[1] * f[1]) / (self.mu * self.mu);
        let tt2 = if self.torsion > 0.0 {
            tau * tau / (self.torsion * self.torsion)
        } else {
            0.0
        };
        let cone_margin = n - (ft2 + tt2).sqrt();
        let r = &mut log.readings[pi];
        let before = r.status;
        *r = PadReading {
            normal: n,
            tangential: f,
            torsion: tau,
            margin,
            torsion_margin,
            cone_margin,
            status,
        };
        if margin < log.min_margin[pi].0 {
            log.min_margin[pi] = (margin, t);
        }
        if cone_margin < log.min_cone_margin[pi].0 {
            log.min_cone_margin[pi] = (cone_margin, t);
        }
        if self.torsion > 0.0 && torsion_margin < log.min_torsion_margin[pi].0 {
            log.min_torsion_margin[pi] = (torsion_margin, t);
        }
        if before != status {
            if log.events.len() < MAX_EVENTS {
                log.events.push(ContactEvent {
                    t,
                    grasp: i,
                    pad: jj,
                    from: before,
                    to: status,
                });
            } else {
                log.dropped += 1;
            }
        }
    }

    /// The contacts' stored energy for grasp `i` (normal preload springs, tangential and
    /// torsional springs), J.
    pub(crate) fn energy(&self, i: usize, g: &GraspKin, anchors: &[f64]) -> f64 {
        let theta = relative_rotation(g);
        let f_g = self.grip[i];
        let mut e = 0.0;
        for (jj, pi) in self.pads_of(i).enumerate() {
            let pad = &self.pads[pi];
            let pk = self.pad_kin(pad, g, &theta, &anchors[3 * jj..3 * jj + 3]);
            // ∫ max(0, F_g + k_n δ) dδ from 0.
            let d0 = -f_g / self.k_n;
            let d = pk.delta.max(d0);
            e += f_g * d + 0.5 * self.k_n * d * d;
            if Self::on_face(pad, &pk) && f_g + self.k_n * pk.delta > 0.0 {
                e += 0.5 * self.k_t * (pk.s[0] * pk.s[0] + pk.s[1] * pk.s[1]);
                if self.torsion > 0.0 {
                    e += 0.5 * pad.k_r * pk.phi * pk.phi;
                }
            }
        }
        e
    }
}

/// Pads declared on weld or compliant grasps: **the friction a grasp would need**. The plant
/// keeps its welds (or springs); each tick the grasp wrench it carries is shared among the pads
/// as stuck pads of the given stiffness share it, and each pad's force is gauged against its
/// cone. So every grasp model reports cone margins, and a weld's result says whether a
/// gripper of that μ and grip would have held it.
///
/// # The share (object axes, about the tool origin `g`)
/// A small displacement `δ = (u, θ)` of the tool against the object moves pad `j`'s centre by
/// `d_j = u + θ × ρ_j` (`ρ_j = c_j − g`), and the stuck contact model answers with the force
/// on the tool `σ e_k F_g − K d_j` (`K = k_n` along the face normal `e_k`, `k_t` across) and
/// the moment `−k_r θ_k e_k`: the grasp's wrench is `W_pre − S δ`, with `W_pre` the pads'
/// preload (zero for opposing pads) and `S = Σ_j Aᵀ diag(K, k_r e_k e_kᵀ) A`, `A = [I, −[ρ]×]`.
/// The weld's wrench `W` gives `δ = S⁻¹ (W_pre − W)`, and so each pad's normal force, friction
/// and torsion, exactly those of the contact model stuck at `δ` (its limit as the pads stiffen,
/// [`crate::plant::spatial::GraspModel::Contact`]). A pad whose normal force would be ≤ 0 is
/// reported separated, one outside its cone slipping: what the contact grasp would do.
#[derive(Clone, Debug)]
pub struct PadGauge {
    pub(crate) model: ContactModel,
    /// The parameters it was made from.
    pub(crate) params: ContactParams,
    /// Per grasp, the tool origin in `O` (the grasp frame's, `X_OG`).
    origin: Vec<Vector3<f64>>,
    /// Per grasp, `S⁻¹` (object axes).
    s_inv: Vec<nalgebra::Matrix6<f64>>,
}

impl PadGauge {
    /// Validate the pads as contact grasps are (errors name `grasp_model.*`), and
    /// refuse pads that cannot carry a six-axis wrench (a single pad carries no moment across
    /// its normal).
    pub fn new(p: &ContactParams, grasps: &[Isometry3<f64>]) -> Result<Self, ModelError> {
        let model = ContactModel::new(p, grasps)?;
        let mut origin = Vec::with_capacity(grasps.len());
        let mut s_inv = Vec::with_capacity(grasps.len());
        for (i, x_og) in grasps.iter().enumerate() {
            let g = x_og.translation.vector;
            let mut s = nalgebra::Matrix6::<f64>::zeros();
            for pi in model.pads_of(i) {
                let pad = &model.pads[pi];
                let mut k = nalgebra::Matrix3::from_diagonal_element(model.k_t);
                k[(pad.k, pad.k)] = model.k_n;
                let rx = (pad.c - g).cross_matrix();
                // A = [I, −[ρ]×]: S += Aᵀ K A, and the torsion k_r along e_k.
                let a = nalgebra::Matrix3x6::from_columns(&[
                    Vector3::x(),
                    Vector3::y(),
                    Vector3::z(),
                    -rx.column(0),
                    -rx.column(1),
                    -rx.column(2),
                ]);
                s += a.transpose() * k * a;
                s[(3 + pad.k, 3 + pad.k)] += pad.k_r;
            }
            let sv = s.singular_values();
            let (lo, hi) = (sv.min(), sv.max());
            match s.try_inverse() {
                Some(inv) if lo > 1e-9 * hi && inv.iter().all(|v| v.is_finite()) => {
                    s_inv.push(inv);
                }
                _ => {
                    return Err(ModelError::geometry(
                        format!("grasp_model.pads[{i}]"),
                        "these pads cannot carry every component of a grasp's wrench (one pad \
                         carries no moment across its normal): give at least two pads apart, \
                         e.g. a parallel-jaw gripper's two opposing pads",
                    ));
                }
            }
            origin.push(g);
        }
        Ok(PadGauge {
            model,
            params: p.clone(),
            origin,
            s_inv,
        })
    }

    /// An empty record for these pads ([`ContactLog::gauged`] set).
    pub fn log(&self) -> ContactLog {
        ContactLog {
            gauged: true,
            ..ContactLog::new(&self.model)
        }
    }

    /// The parameters the gauge was made from.
    pub fn params(&self) -> &ContactParams {
        &self.params
    }

    /// Grasp `i` at `t`: `w` is the wrench the object puts on the tool (about the tool origin,
    /// world axes), `r_wo` the object's orientation. Writes the pads' readings, margins,
    /// minima and events into `log` (from [`log`](Self::log)). No allocation.
    ///
    /// Outside a simulation this gauges measured wrenches: a wrist F/T sensor's reading
    /// (object on tool, moved to the tool origin) tells how close a parallel-jaw grasp of
    /// these pads is to slipping. A non-finite wrench reads as separated pads.
    ///
    /// # Panics
    /// If `i` is not one of the gauge's grasps, or `log` is not this gauge's
    /// ([`log`](Self::log)).
    pub fn update(
        &self,
        i: usize,
        w: &Vector6<f64>,
        r_wo: &UnitQuaternion<f64>,
        t: f64,
        log: &mut ContactLog,
    ) {
        let m = &self.model;
        let g = self.origin[i];
        let f_g = m.grip[i];
        // The wrench in object axes, and the preload.
        let f_o = r_wo.inverse_transform_vector(&Vector3::new(w[0], w[1], w[2]));
        let t_o = r_wo.inverse_transform_vector(&Vector3::new(w[3], w[4], w[5]));
        let mut pre = Vector6::zeros();
        for pi in m.pads_of(i) {
            let pad = &m.pads[pi];
            let mut f = Vector3::zeros();
            f[pad.k] = pad.sign * f_g;
            let mo = (pad.c - g).cross(&f);
            pre += Vector6::new(f.x, f.y, f.z, mo.x, mo.y, mo.z);
        }
        let delta = self.s_inv[i] * (pre - Vector6::new(f_o.x, f_o.y, f_o.z, t_o.x, t_o.y, t_o.z));
        let (u, th) = (
            Vector3::new(delta[0], delta[1], delta[2]),
            Vector3::new(delta[3], delta[4], delta[5]),
        );
        for (jj, pi) in m.pads_of(i).enumerate() {
            let pad = &m.pads[pi];
            let d = u + th.cross(&(pad.c - g));
            let n = f_g - m.k_n * pad.sign * d[pad.k];
            let f = [-m.k_t * d[pad.t[0]], -m.k_t * d[pad.t[1]]];
            let tau = if m.torsion > 0.0 {
                -pad.k_r * pad.sign * th[pad.k]
            } else {
                0.0
            };
            let ft2 = (f[0] * f[0] + f[1] * f[1]) / (m.mu * m.mu);
            let tt2 = if m.torsion > 0.0 {
                tau * tau / (m.torsion * m.torsion)
            } else {
                0.0
            };
            let status = if !(n > 0.0) {
                PadStatus::Separated
            } else if (ft2 + tt2).sqrt() > n {
                PadStatus::Slip
            } else {
                PadStatus::Stick
            };
            m.record(log, pi, (i, jj), t, n, f, tau, status);
        }
    }
}
