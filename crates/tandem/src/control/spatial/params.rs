//! Parameters of the spatial cooperative controller (plain data, validated by
//! [`SpatialController::new`](super::SpatialController::new)): the law on six outputs
//! ([`Law<6>`](crate::control::law::Law); the gains are defined once for any number of outputs
//! in [`crate::control::law`], their spatial presets are here), the output bounds, the chart,
//! the admittance, the internal squeeze, the posture task of redundant arms and the actuator
//! limits.
//!
//! Gains are per output, linear first: `[x, y, z, rx, ry, rz]` in the output chart
//! `x_1 = (p_WO − c, φ)` (metres and radians; SPEC-spatial S5). The presets and how they were
//! found are in `docs/spatial-control.md` ("Gains"): SPEC §3.4's linearised loop per axis,
//! `𝓜_j s³ + K2_j s² + (K2_j K1_j + γ_j) s + γ_j K1_j`, `γ_j = Θ_j ‖S_j‖²`, on the object-level
//! inertia of the set-up at its start.

use nalgebra::{UnitQuaternion, Vector3};

use crate::control::Scheme;
use crate::control::law::Law;
use crate::control::law::adaptive::{NnGains, Smoothing};
use crate::control::law::pd::PdGains;
use crate::control::rbf::structured::NetworkStructure;
use crate::reference::spatial::admittance::AdmittanceSe3Params;

/// `‖S_j(0)‖²` of the default per-axis network (two levels ±1 on four inputs, `ϑ² = 50`):
/// `(2 e^{−2/50})⁴ = 13.63`.
fn per_axis_norm2() -> f64 {
    crate::control::rbf::structured::grid_norm2_at_zero(&[-1.0, 1.0], 50.0, 4)
}

/// Switching inner radius `d1` of the spatial design (paper (38), SPEC §3.4's default is 1):
/// `Ω1` must hold the inputs the designed loop reaches from the S6 start, or `Q` drops below 1
/// in the start transient and the robust term switches on (`docs/smooth-nn.md`, "Radii"). The
/// largest input there is `α̇` along gravity, `|α̇_z| ≈ K1 (K1 |z1(0)| + m_o g/(M_z ω_n))` while
/// the network has not yet learned the box's weight: `8 (0.08 + 29.4/(11 · 20)) = 1.71` on the
/// dual-UR5 set-up, 1.67 on the dual-Franka one (measured 1.45 and 1.53 with `Q ≡ 1`);
/// rounded up to 2.
pub const SPATIAL_D1: f64 = 2.0;

/// Switching outer radius `d2` of the spatial design: `1.5 d1`, SPEC §3.4's ratio.
pub const SPATIAL_D2: f64 = 3.0;

/// The spatial presets of the NN law on six outputs (SPEC-spatial S5, S6), designed per axis
/// (module doc).
impl NnGains<6> {
    /// Gains for the dual-UR5 scenario (SPEC-spatial S6), from the linearised loop per axis
    /// (module doc): `K1 = 8` (as planar `tuned`: `α̇ ≈ K1² z1(0)` stays inside `d1` from the 1 cm
    /// start), the adaptive-bias pair `𝓜_j s² + K2_j s + γ_j` at `ω_n = 20` rad/s and `ζ = 0.8`
    /// on the diagonal of the chart-space inertia, rounded up from its largest value along the
    /// path (18.3, 12.3, 11.0 kg; 0.020, 0.65, 0.76 kg m² at the start: the box alone about its
    /// long axis, along which the wrists' last joints turn freely).
    pub fn dual_ur5() -> Self {
        Self::from_design([20.0, 15.0, 12.0, 0.03, 0.8, 0.9], 8.0, 20.0, 0.8)
    }

    /// Gains for the dual-Franka scenario (two 7-DOF arms, grasps from above), designed as
    /// [`NnGains::dual_ur5`] on that set-up's inertia (23.9, 10.3, 11.4 kg; 0.66, 2.08,
    /// 0.16 kg m² at the start).
    pub fn dual_franka() -> Self {
        Self::from_design([26.0, 12.0, 12.0, 0.7, 2.2, 0.2], 8.0, 20.0, 0.8)
    }

    /// These gains with the paper's switching and robust term as SPEC §3.4 gives them
    /// (`smoothing = "paper"`, `d1 = 1`, `d2 = 1.5`): the spatial presets as they were before the
    /// smooth default (`docs/smooth-nn.md`), for comparisons and the issue-24 measurements.
    pub fn with_paper_switching(self) -> Self {
        NnGains {
            smoothing: Smoothing::Paper,
            d1: 1.0,
            d2: 1.5,
            ..self
        }
    }

    /// The per-axis design of the module doc: for inertia `m[j]` (kg or kg m², chart axes),
    /// `K1 = k1`, `γ_j = m_j ω_n²`, `K2_j = 2 ζ m_j ω_n`, `Θ_j = γ_j / ‖S_j(0)‖²` on the default
    /// per-axis network; `K_r = 0.001`, `ϖ = 0.05`, `ϑ² = 50`, levels `±1`, `ω = 1`, `f^U`
    /// safety 1.5 (SPEC §3.4 defaults); the switching radii [`SPATIAL_D1`], [`SPATIAL_D2`]
    /// (`d1 = 2`, `d2 = 3`: Ω1 holds the start transient) and the robust term's sampled-data
    /// boundary layer ([`Smoothing::Sampled`]), the smooth default of `docs/smooth-nn.md`.
    ///
    /// `σ` is the planar `0.001` scaled by `‖S_j(0)‖² / ‖S_grid(0)‖² = 13.6/2535`: at the
    /// σ-modification's equilibrium `Ŵ_j = −Q S z_2j/σ_j`, so the network leaves
    /// `z_2j = −σ_j f̂_j/‖S_j‖²`, and with 186× fewer basis energy the paper's `σ` would leave
    /// 186× the planar error (0.9 mm against a 110 N gravity load on the S6 set-up).
    pub fn from_design(m: [f64; 6], k1: f64, omega_n: f64, zeta: f64) -> Self {
        let s2 = per_axis_norm2();
        let sigma = 0.001 * s2
            / crate::control::rbf::structured::grid_norm2_at_zero(&[-1.0, 1.0], 50.0, 12);
        NnGains {
            k1: [k1; 6],
            k2: std::array::from_fn(|j| 2.0 * zeta * m[j] * omega_n),
            k_r: [0.001; 6],
            theta: std::array::from_fn(|j| m[j] * omega_n * omega_n / s2),
            sigma: [sigma; 6],
            varpi: 0.05,
            fu_safety: 1.5,
            width2: 50.0,
            levels: vec![-1.0, 1.0],
            d1: SPATIAL_D1,
            d2: SPATIAL_D2,
            omega: 1.0,
            network: NetworkStructure::per_axis(),
            smoothing: Smoothing::Sampled,
        }
    }
}

/// The spatial preset of the PD law on six outputs.
impl PdGains<6> {
    /// The paper's translational PD gains (5000 N/m, 450 N s/m) on the position axes, and the
    /// same natural frequency and damping ratio on the rotational axes at the S6 box's lever arm
    /// `ℓ = 0.2` m (`K ℓ²`): 200 N m/rad, 18 N m s/rad; no gravity compensation (SPEC §3.5).
    pub fn paper() -> Self {
        let l2 = 0.04;
        PdGains {
            k_p: [
                5000.0,
                5000.0,
                5000.0,
                5000.0 * l2,
                5000.0 * l2,
                5000.0 * l2,
            ],
            k_d: [450.0, 450.0, 450.0, 450.0 * l2, 450.0 * l2, 450.0 * l2],
            gravity_compensation: false,
        }
    }
}

/// The null-space posture task of a redundant (7-DOF) arm: `τ0 = K_p (q_rest − q) − K_d q̇ +
/// g(q)`, projected into the null space of the tool Jacobian (dynamically consistent), so it
/// never reaches the object. `q_rest` defaults to the start configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct PostureParams {
    /// Stiffness, N m/rad.
    pub kp: f64,
    /// Damping, N m s/rad.
    pub kd: f64,
    /// Rest posture (all joints, stacked over arms; only redundant arms use theirs); `None` =
    /// the measured configuration at [`super::SpatialController`] start.
    pub q_rest: Option<Vec<f64>>,
}

impl Default for PostureParams {
    /// `K_p = 20` N m/rad, `K_d = 4` N m s/rad: on the Franka's self-motion inertia
    /// (0.027–0.035 kg m², measured in `tests/spatial_control_model.rs`) a stiff, overdamped
    /// posture loop (`√(K_p/I) ≈ 26` rad/s, `ζ ≈ 2.5`), so that the uncompensated null-space
    /// Coriolis torques move the posture by a few hundredths of a radian at most (measured 0.03
    /// rad along S6, `docs/spatial-control.md`).
    fn default() -> Self {
        PostureParams {
            kp: 20.0,
            kd: 4.0,
            q_rest: None,
        }
    }
}

/// Spatial controller parameters (plain data).
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialControllerParams {
    /// The law.
    pub law: Law<6>,
    /// Object scheme (all laws) or per-arm scheme (PD).
    pub scheme: Scheme,
    /// Output bounds `k_c` on `x_1 = (p − c, φ)`, (m ×3, rad ×3); `k_c,rot < π`.
    pub k_c: [f64; 6],
    /// Chart centre `c`, m; `None` = the circle's centre, or for other paths the centre of the
    /// desired positions' bounding box over the run.
    pub centre: Option<Vector3<f64>>,
    /// Chart reference orientation `R_ref`; `None` = the desired orientation at `t = 0`.
    pub r_ref: Option<UnitQuaternion<f64>>,
    /// 6-D admittance per arm; `None` bypasses it (`x_r = x_d`).
    pub admittance: Option<AdmittanceSe3Params>,
    /// Internal squeeze commanded along the grasp map's null space, N (object scheme).
    pub squeeze: f64,
    /// Length that makes forces and torques commensurate in the minimum-norm share, m.
    pub metric_length: f64,
    /// Control period, s.
    pub control_period: f64,
    /// Joint torque limit (symmetric, every joint), N m; `None` = each joint's URDF effort
    /// limit (unlimited where the URDF gives none).
    pub torque_limit: Option<f64>,
    /// The actuator stage every law's torques go through ([`crate::control::actuator`]); its
    /// effort limits, when not given, are `torque_limit` or the URDF's; all off by default.
    pub actuator: crate::control::actuator::ActuatorParams,
    /// Known bound of `|F_d,j|` in chart coordinates (enters `f^U`), (N ×3, N m ×3).
    pub disturbance_bound: [f64; 6],
    /// Posture task of redundant arms.
    pub posture: PostureParams,
    /// The friction-aware load distribution for grasps held by friction
    /// ([`super::distribute::friction`]); `None`: the weld-assuming one alone.
    pub friction: Option<super::distribute::friction::FrictionParams>,
}

impl SpatialControllerParams {
    /// The SPEC-spatial S6 settings with the given law: object scheme; `k_c` so that the path
    /// uses about 60 % of the box on the axes it moves (0.1 m circle in 0.167 m, 10° pitch in
    /// 0.29 rad) and 0.1 m, 0.29 rad on the others; the chart about the path's centre and its
    /// initial orientation; the default 6-D admittance; a 5 N squeeze; the S6 box's half-length
    /// as the metric length; 1 kHz; URDF effort limits; the S6 disturbance's bound.
    pub fn spec_s6(law: Law<6>) -> Self {
        SpatialControllerParams {
            law,
            scheme: Scheme::Object,
            k_c: [0.167, 0.167, 0.1, 0.29, 0.29, 0.29],
            centre: None,
            r_ref: None,
            admittance: Some(AdmittanceSe3Params::default()),
            squeeze: 5.0,
            metric_length: 0.2,
            control_period: 1e-3,
            torque_limit: None,
            actuator: Default::default(),
            disturbance_bound: [0.5, 0.5, 0.5, 0.05, 0.05, 0.05],
            posture: PostureParams::default(),
            friction: None,
        }
    }

    /// [`SpatialControllerParams::spec_s6`] on Franka arms: the actuator stage's rate limit at
    /// the Franka Control Interface's published 1000 N m/s
    /// ([`crate::model::spatial::urdf::FRANKA_TORQUE_RATE_LIMIT`]), the default of a scenario
    /// with Franka arms (the `dual-franka` preset).
    pub fn spec_s6_franka(law: Law<6>) -> Self {
        let mut p = Self::spec_s6(law);
        p.actuator.rate_limit = Some(crate::model::spatial::urdf::FRANKA_TORQUE_RATE_LIMIT);
        p
    }
}
