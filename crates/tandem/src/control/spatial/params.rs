//! Parameters of the spatial cooperative controller (plain data, validated by
//! [`SpatialController::new`](super::SpatialController::new)): the law and its gains on six
//! outputs, the output bounds, the chart, the admittance, the internal squeeze, the posture task
//! of redundant arms and the actuator limits.
//!
//! Gains are per output, linear first: `[x, y, z, rx, ry, rz]` in the output chart
//! `x_1 = (p_WO − c, φ)` (metres and radians; SPEC-spatial S5). The presets and how they were
//! found are in `docs/spatial-control.md` ("Gains"): SPEC §3.4's linearised loop per axis,
//! `𝓜_j s³ + K2_j s² + (K2_j K1_j + γ_j) s + γ_j K1_j`, `γ_j = Θ_j ‖S_j‖²`, on the object-level
//! inertia of the set-up at its start.

use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::control::Scheme;
use crate::control::law::adaptive::{NnAxes, NnGains};
use crate::control::rbf::structured::NetworkStructure;
use crate::reference::spatial::admittance::AdmittanceSe3Params;

/// Gains of the NN law on six outputs (plain data).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialNnGains {
    /// `K1` diagonal (κ1), 1/s.
    pub k1: [f64; 6],
    /// `K2` diagonal, (N s/m ×3, N m s/rad ×3) in chart coordinates.
    pub k2: [f64; 6],
    /// `K_r` diagonal (sign term), (N ×3, N m ×3).
    pub k_r: [f64; 6],
    /// Adaptation gains `Θ_j`.
    pub theta: [f64; 6],
    /// σ-modification `σ_j`.
    pub sigma: [f64; 6],
    /// Robust-term smoothing `ϖ`.
    pub varpi: f64,
    /// Safety factor on the `f^U` constants.
    pub fu_safety: f64,
    /// RBF width `ϑ²`.
    pub width2: f64,
    /// Centre levels per input.
    pub levels: Vec<f64>,
    /// Switching inner radius `d1`.
    pub d1: f64,
    /// Switching outer radius `d2`.
    pub d2: f64,
    /// Switching shape `ω ≥ 1`.
    pub omega: f64,
    /// Network structure. The paper's full grid has `2^24` nodes on six outputs (800 MB of
    /// weights) and is refused; the default is one grid per output over its own four signals
    /// ([`NetworkStructure::per_axis`], `docs/network.md`).
    #[serde(default = "NetworkStructure::per_axis")]
    pub network: NetworkStructure,
}

/// `‖S_j(0)‖²` of the default per-axis network (two levels ±1 on four inputs, `ϑ² = 50`):
/// `(2 e^{−2/50})⁴ = 13.63`.
fn per_axis_norm2() -> f64 {
    crate::control::rbf::structured::grid_norm2_at_zero(&[-1.0, 1.0], 50.0, 4)
}

impl SpatialNnGains {
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
    /// [`SpatialNnGains::dual_ur5`] on that set-up's inertia (23.9, 10.3, 11.4 kg; 0.66, 2.08,
    /// 0.16 kg m² at the start).
    pub fn dual_franka() -> Self {
        Self::from_design([26.0, 12.0, 12.0, 0.7, 2.2, 0.2], 8.0, 20.0, 0.8)
    }

    /// The per-axis design of the module doc: for inertia `m[j]` (kg or kg m², chart axes),
    /// `K1 = k1`, `γ_j = m_j ω_n²`, `K2_j = 2 ζ m_j ω_n`, `Θ_j = γ_j / ‖S_j(0)‖²` on the default
    /// per-axis network; `K_r = 0.001`, `ϖ = 0.05`, `ϑ² = 50`, levels `±1`, `d1 = 1`,
    /// `d2 = 1.5`, `ω = 1`, `f^U` safety 1.5 (SPEC §3.4 defaults).
    ///
    /// `σ` is the planar `0.001` scaled by `‖S_j(0)‖² / ‖S_grid(0)‖² = 13.6/2535`: at the
    /// σ-modification's equilibrium `Ŵ_j = −Q S z_2j/σ_j`, so the network leaves
    /// `z_2j = −σ_j f̂_j/‖S_j‖²`, and with 186× fewer basis energy the paper's `σ` would leave
    /// 186× the planar error (0.9 mm against a 110 N gravity load on the S6 set-up).
    pub fn from_design(m: [f64; 6], k1: f64, omega_n: f64, zeta: f64) -> Self {
        let s2 = per_axis_norm2();
        let sigma = 0.001 * s2
            / crate::control::rbf::structured::grid_norm2_at_zero(&[-1.0, 1.0], 50.0, 12);
        SpatialNnGains {
            k1: [k1; 6],
            k2: std::array::from_fn(|j| 2.0 * zeta * m[j] * omega_n),
            k_r: [0.001; 6],
            theta: std::array::from_fn(|j| m[j] * omega_n * omega_n / s2),
            sigma: [sigma; 6],
            varpi: 0.05,
            fu_safety: 1.5,
            width2: 50.0,
            levels: vec![-1.0, 1.0],
            d1: 1.0,
            d2: 1.5,
            omega: 1.0,
            network: NetworkStructure::per_axis(),
        }
    }

    /// The per-output gains.
    pub fn axes(&self) -> NnAxes<6> {
        NnAxes {
            k1: self.k1,
            k2: self.k2,
            k_r: self.k_r,
            theta: self.theta,
            sigma: self.sigma,
        }
    }

    /// The shared settings as planar gains (their per-output arrays are the first three of
    /// these; [`crate::control::law::adaptive::AdaptiveNn::with_axes`] ignores them).
    pub fn shared(&self) -> NnGains {
        NnGains {
            k1: [self.k1[0], self.k1[1], self.k1[2]],
            k2: [self.k2[0], self.k2[1], self.k2[2]],
            k_r: [self.k_r[0], self.k_r[1], self.k_r[2]],
            theta: [self.theta[0], self.theta[1], self.theta[2]],
            sigma: [self.sigma[0], self.sigma[1], self.sigma[2]],
            varpi: self.varpi,
            fu_safety: self.fu_safety,
            width2: self.width2,
            levels: self.levels.clone(),
            d1: self.d1,
            d2: self.d2,
            omega: self.omega,
            network: self.network.clone(),
        }
    }
}

/// PD gains on six outputs (plain data). SPEC §3.5 on the chart: `τ_x = −K_P z1 − K_D ż1`,
/// mapped to the object wrench `F = Eᵀ τ_x`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialPdGains {
    /// `K_P` diagonal, (N/m ×3, N m/rad ×3).
    pub k_p: [f64; 6],
    /// `K_D` diagonal, (N s/m ×3, N m s/rad ×3).
    pub k_d: [f64; 6],
    /// Add the model's gravity `𝓖` (object and arms, at the measured joints). Off in the
    /// paper's baseline (SPEC §3.5: no gravity compensation), which then sags by
    /// `𝓖/K_P` (about 2 cm under the S6 arms' and box's 110 N); on, it is the model-based PD
    /// a practitioner would run, and on a path as slow as S6 it tracks about as well as the NN
    /// law (`docs/spatial-control.md`).
    #[serde(default)]
    pub gravity_compensation: bool,
}

impl SpatialPdGains {
    /// The paper's translational PD gains (5000 N/m, 450 N s/m) on the position axes, and the
    /// same natural frequency and damping ratio on the rotational axes at the S6 box's lever arm
    /// `ℓ = 0.2` m (`K ℓ²`): 200 N m/rad, 18 N m s/rad; no gravity compensation (SPEC §3.5).
    pub fn paper() -> Self {
        let l2 = 0.04;
        SpatialPdGains {
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

/// Computed-torque gains on six outputs: `a = ẍ_r − K_D ż1 − K_P z1` in the chart,
/// `F = 𝓜 E⁻¹(a − Ė V) + 𝓱` with the nominal model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialCtcGains {
    /// `K_P` diagonal, 1/s².
    pub k_p: [f64; 6],
    /// `K_D` diagonal, 1/s.
    pub k_d: [f64; 6],
    /// Relative error of every mass and inertia of the nominal model (0 = exact).
    pub model_error: f64,
}

impl Default for SpatialCtcGains {
    /// `ω_n = 20` rad/s, `ζ = 1` on every axis; exact model.
    fn default() -> Self {
        SpatialCtcGains {
            k_p: [400.0; 6],
            k_d: [40.0; 6],
            model_error: 0.0,
        }
    }
}

/// Which law, with its gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
#[allow(clippy::large_enum_variant)] // plain data, built once per run
pub enum SpatialLaw {
    /// iBLF backstepping + adaptive RBF network with switching on six outputs (SPEC-spatial S5).
    Nn(SpatialNnGains),
    /// PD on six outputs.
    Pd(SpatialPdGains),
    /// Computed torque with the nominal model.
    Ctc(SpatialCtcGains),
}

impl SpatialLaw {
    /// `nn`, `pd` or `ctc`.
    pub fn name(&self) -> &'static str {
        match self {
            SpatialLaw::Nn(_) => "nn",
            SpatialLaw::Pd(_) => "pd",
            SpatialLaw::Ctc(_) => "ctc",
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
    pub law: SpatialLaw,
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
    /// Known bound of `|F_d,j|` in chart coordinates (enters `f^U`), (N ×3, N m ×3).
    pub disturbance_bound: [f64; 6],
    /// Posture task of redundant arms.
    pub posture: PostureParams,
}

impl SpatialControllerParams {
    /// The SPEC-spatial S6 settings with the given law: object scheme; `k_c` so that the path
    /// uses about 60 % of the box on the axes it moves (0.1 m circle in 0.167 m, 10° pitch in
    /// 0.29 rad) and 0.1 m, 0.29 rad on the others; the chart about the path's centre and its
    /// initial orientation; the default 6-D admittance; a 5 N squeeze; the S6 box's half-length
    /// as the metric length; 1 kHz; URDF effort limits; the S6 disturbance's bound.
    pub fn spec_s6(law: SpatialLaw) -> Self {
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
            disturbance_bound: [0.5, 0.5, 0.5, 0.05, 0.05, 0.05],
            posture: PostureParams::default(),
        }
    }
}
