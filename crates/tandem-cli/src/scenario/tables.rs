//! The tables planar and spatial scenarios share, declared once. Where the two kinds differ
//! only in the number of outputs (three: `x, y, θ`; six: `x, y, z, rx, ry, rz`) a table is
//! generic over it.

use serde::{Deserialize, Serialize};

/// Which law drives the joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// iBLF backstepping + adaptive RBF network (SPEC §3.3–3.4).
    Nn,
    /// PD on the object (SPEC §3.5; spatial: `pd.gravity_compensation` adds the model's 𝓖).
    Pd,
    /// Computed torque with a nominal model (SPEC §3.5).
    Ctc,
    /// Joint torques replayed from a CSV file.
    Replay,
}

impl ControllerKind {
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            ControllerKind::Nn => "nn",
            ControllerKind::Pd => "pd",
            ControllerKind::Ctc => "ctc",
            ControllerKind::Replay => "replay",
        }
    }
}

/// `--controller`: a law by name, PD's two forms apart (`pd-gravity` is `kind = "pd"` with
/// `controller.pd.gravity_compensation = true`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ControllerChoice {
    /// iBLF backstepping + adaptive RBF network (SPEC §3.3–3.4).
    Nn,
    /// PD on the object (SPEC §3.5), as the file sets its gravity compensation (default off).
    Pd,
    /// PD on the object plus the model's gravity 𝓖.
    #[value(name = "pd-gravity")]
    PdGravity,
    /// Computed torque with a nominal model (SPEC §3.5).
    Ctc,
    /// Joint torques replayed from a CSV file.
    Replay,
}

impl ControllerChoice {
    /// The names of the laws a scenario's controller can be built with (not `replay`), in the
    /// order of the docs.
    pub const LAWS: [&'static str; 4] = ["nn", "pd", "pd-gravity", "ctc"];

    /// Parse a law's name (as `--controller` takes it); `Err` names the valid ones.
    pub fn parse(s: &str) -> Result<ControllerChoice, String> {
        <ControllerChoice as clap::ValueEnum>::from_str(s, false)
            .ok()
            .filter(|c| *c != ControllerChoice::Replay)
            .ok_or_else(|| {
                format!(
                    "law = {s:?}: must be one of {} (or None: the scenario's)",
                    Self::LAWS.join(", ")
                )
            })
    }

    /// The name (`pd-gravity`, ...).
    pub fn name(self) -> &'static str {
        match self {
            ControllerChoice::Nn => "nn",
            ControllerChoice::Pd => "pd",
            ControllerChoice::PdGravity => "pd-gravity",
            ControllerChoice::Ctc => "ctc",
            ControllerChoice::Replay => "replay",
        }
    }

    /// The choice a scenario makes: its `controller.kind`, PD with `gravity_compensation`
    /// as `pd-gravity`.
    pub fn of(kind: ControllerKind, gravity_compensation: Option<bool>) -> ControllerChoice {
        match kind {
            ControllerKind::Nn => ControllerChoice::Nn,
            ControllerKind::Pd if gravity_compensation == Some(true) => ControllerChoice::PdGravity,
            ControllerKind::Pd => ControllerChoice::Pd,
            ControllerKind::Ctc => ControllerChoice::Ctc,
            ControllerKind::Replay => ControllerChoice::Replay,
        }
    }

    /// The scenario's `controller.kind`.
    pub fn kind(self) -> ControllerKind {
        match self {
            ControllerChoice::Nn => ControllerKind::Nn,
            ControllerChoice::Pd | ControllerChoice::PdGravity => ControllerKind::Pd,
            ControllerChoice::Ctc => ControllerKind::Ctc,
            ControllerChoice::Replay => ControllerKind::Replay,
        }
    }
}

use tandem::model::disturbance::{Disturbance, Push};
use tandem::sim::sensors::{ChannelNoise, SensorParams};

/// `F_d(t) = a ∘ sin(ω t + φ) − Σ pushes` on the object, on its `N` outputs (planar: `(N, N,
/// N m)` in the plane; spatial: `[f; τ]` in world axes); everything defaults to zero.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct DisturbanceConfig<const N: usize> {
    /// Sinusoid amplitudes, (N, N, N m) / (N ×3, N m ×3).
    #[serde(default = "zeros")]
    pub amplitude: [f64; N],
    /// Angular frequencies, rad/s.
    #[serde(default = "zeros")]
    pub frequency: [f64; N],
    /// Phases, rad.
    #[serde(default = "zeros")]
    pub phase: [f64; N],
    /// Timed pushes (`t0`, `duration`, `wrench` on the object).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pushes: Vec<Push<N>>,
}

fn zeros<const N: usize>() -> [f64; N] {
    [0.0; N]
}

impl<const N: usize> Default for DisturbanceConfig<N> {
    fn default() -> Self {
        DisturbanceConfig {
            amplitude: [0.0; N],
            frequency: [0.0; N],
            phase: [0.0; N],
            pushes: Vec::new(),
        }
    }
}

impl<const N: usize> DisturbanceConfig<N> {
    /// The library's disturbance (validated by the plant).
    pub fn disturbance(&self) -> Disturbance<N> {
        Disturbance {
            amplitude: self.amplitude,
            frequency: self.frequency,
            phase: self.phase,
            pushes: self.pushes.clone(),
        }
    }
}

/// Sensor imperfections per channel group (the seed is `run.seed`). The wrist torque channels
/// are spatial only: a planar arm's force sensor reads the end-effector force in the plane.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorsConfig {
    /// Joint-angle encoders, rad.
    #[serde(default)]
    pub encoder_q: ChannelNoise,
    /// Joint-rate channels, rad/s.
    #[serde(default)]
    pub encoder_qd: ChannelNoise,
    /// End-effector (wrist) force channels, N.
    #[serde(default)]
    pub force: ChannelNoise,
    /// Wrist torque channels, N m (spatial; a spatial scenario always has it, ideal by default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque: Option<ChannelNoise>,
}

impl SensorsConfig {
    /// The library's sensor models with the run's seed (an absent torque group is ideal).
    pub fn params(&self, seed: u64) -> SensorParams {
        SensorParams {
            encoder_q: self.encoder_q,
            encoder_qd: self.encoder_qd,
            force: self.force,
            torque: self.torque.unwrap_or_default(),
            seed,
        }
    }
}

/// PD gains on the `N` outputs (absent = the law's defaults: the paper's, SPEC §3.5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct PdConfig<const N: usize> {
    /// `K_P` diagonal, (N/m, N/m, N m/rad) / (N/m ×3, N m/rad ×3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_p: Option<[f64; N]>,
    /// `K_D` diagonal, (N s/m, N s/m, N m s/rad) / (N s/m ×3, N m s/rad ×3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_d: Option<[f64; N]>,
    /// Add the model's gravity `𝓖` (off in the paper's baseline). A spatial scenario always
    /// says it (`false` by default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_compensation: Option<bool>,
}

impl<const N: usize> Default for PdConfig<N> {
    fn default() -> Self {
        PdConfig {
            k_p: None,
            k_d: None,
            gravity_compensation: None,
        }
    }
}

/// Computed-torque gains on the `N` outputs (absent = the library's defaults: `ω_n = 20`
/// rad/s, `ζ = 1`, exact model).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct CtcConfig<const N: usize> {
    /// `K_P` diagonal, 1/s².
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_p: Option<[f64; N]>,
    /// `K_D` diagonal, 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_d: Option<[f64; N]>,
    /// Relative error of every mass and inertia of the nominal model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_error: Option<f64>,
}

impl<const N: usize> Default for CtcConfig<N> {
    fn default() -> Self {
        CtcConfig {
            k_p: None,
            k_d: None,
            model_error: None,
        }
    }
}

/// Summary metrics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricsConfig {
    /// Start of the "after the transient" window, s (planar default 5 s; spatial 2 s, the
    /// window of SPEC-spatial S5's claims).
    #[serde(default = "MetricsConfig::planar_transient")]
    pub transient: f64,
}

impl MetricsConfig {
    fn planar_transient() -> f64 {
        5.0
    }
    /// The spatial default: SPEC-spatial S5's claims are stated "within 2 s".
    pub fn spatial() -> Self {
        MetricsConfig { transient: 2.0 }
    }
}

impl Default for MetricsConfig {
    fn default() -> Self {
        MetricsConfig {
            transient: MetricsConfig::planar_transient(),
        }
    }
}

/// A value per axis of the admittance, given once for every axis or as an array of `A`
/// (planar: `[x, y]` of the end effector; spatial: `[x, y, z, rx, ry, rz]` of the tool pose).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PerAxis<const A: usize> {
    /// The same value on every axis.
    Both(f64),
    /// One value per axis.
    Each([f64; A]),
}

impl<const A: usize> PerAxis<A> {
    /// The value on each axis.
    pub fn array(self) -> [f64; A] {
        match self {
            PerAxis::Both(v) => [v; A],
            PerAxis::Each(a) => a,
        }
    }

    /// What a file may write (the text of the error for anything else).
    fn expecting() -> &'static str {
        match A {
            2 => "a number or an array [x, y] of two numbers",
            6 => "a number or an array [x, y, z, rx, ry, rz] of six numbers",
            _ => "a number or an array with one number per axis",
        }
    }
}

impl<const A: usize> Serialize for PerAxis<A> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        match self {
            PerAxis::Both(v) => s.serialize_f64(*v),
            PerAxis::Each(a) => {
                let mut t = s.serialize_tuple(A)?;
                for v in a {
                    t.serialize_element(v)?;
                }
                t.end()
            }
        }
    }
}

impl<'de, const A: usize> Deserialize<'de> for PerAxis<A> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const A: usize>;
        impl<'de, const A: usize> serde::de::Visitor<'de> for V<A> {
            type Value = PerAxis<A>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(PerAxis::<A>::expecting())
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(PerAxis::Both(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(PerAxis::Both(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
                Ok(PerAxis::Both(v as f64))
            }
            fn visit_seq<S: serde::de::SeqAccess<'de>>(
                self,
                mut seq: S,
            ) -> Result<Self::Value, S::Error> {
                let wrong = || serde::de::Error::custom(PerAxis::<A>::expecting());
                let mut out = [0.0; A];
                for o in out.iter_mut() {
                    *o = seq
                        .next_element::<f64>()
                        .map_err(|_| wrong())?
                        .ok_or_else(wrong)?;
                }
                if seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                    return Err(wrong());
                }
                Ok(PerAxis::Each(out))
            }
        }
        // Anything that is neither a number nor a sequence gets the same one-line message.
        d.deserialize_any(V::<A>).map_err(|e: D::Error| {
            let m = e.to_string();
            if m.starts_with("invalid type") {
                serde::de::Error::custom(PerAxis::<A>::expecting())
            } else {
                e
            }
        })
    }
}

/// The admittance generator (SPEC §3.1), per arm: on the end effector's `[x, y]` (planar,
/// `A = 2`) or on the tool pose's six components (spatial, `A = 6`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdmittanceConfig<const A: usize> {
    /// `false` bypasses the generator (`x_r = x_d`).
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Virtual mass `M_e`, kg (spatial: kg ×3, kg m² ×3; planar 0: the paper's first-order
    /// form, warned).
    #[serde(default = "AdmittanceConfig::<A>::default_m_e")]
    pub m_e: PerAxis<A>,
    /// Virtual damping `C_e`, N s/m (spatial: N s/m ×3, N m s/rad ×3).
    #[serde(default = "AdmittanceConfig::<A>::default_c_e")]
    pub c_e: PerAxis<A>,
    /// Virtual stiffness `K_e`, N/m (spatial: N/m ×3, N m/rad ×3).
    #[serde(default = "AdmittanceConfig::<A>::default_k_e")]
    pub k_e: PerAxis<A>,
    /// Force (wrench) low-pass time constant `τ_f`, s.
    #[serde(default = "AdmittanceConfig::<A>::default_tau_f")]
    pub tau_f: PerAxis<A>,
}

fn yes() -> bool {
    true
}

impl<const A: usize> AdmittanceConfig<A> {
    /// The defaults of SPEC §3.1: on the plane, one value for both axes (`M_e = 200` kg, `C_e =
    /// 626` N s/m, `K_e = 1000` N/m, `τ_f = 0.01` s); in space, the library's per-axis values
    /// ([`tandem::reference::spatial::admittance::AdmittanceSe3Params::default`]).
    fn defaults() -> [PerAxis<A>; 4] {
        if A == 6 {
            let d = tandem::reference::spatial::admittance::AdmittanceSe3Params::default();
            let each = |v: nalgebra::Vector6<f64>| PerAxis::Each(std::array::from_fn(|i| v[i]));
            [each(d.m_e), each(d.c_e), each(d.k_e), each(d.tau_f)]
        } else {
            [
                PerAxis::Both(200.0),
                PerAxis::Both(626.0),
                PerAxis::Both(1000.0),
                PerAxis::Both(0.01),
            ]
        }
    }
    fn default_m_e() -> PerAxis<A> {
        Self::defaults()[0]
    }
    fn default_c_e() -> PerAxis<A> {
        Self::defaults()[1]
    }
    fn default_k_e() -> PerAxis<A> {
        Self::defaults()[2]
    }
    fn default_tau_f() -> PerAxis<A> {
        Self::defaults()[3]
    }
}

impl<const A: usize> Default for AdmittanceConfig<A> {
    fn default() -> Self {
        let [m_e, c_e, k_e, tau_f] = Self::defaults();
        AdmittanceConfig {
            enabled: true,
            m_e,
            c_e,
            k_e,
            tau_f,
        }
    }
}

/// The plant's gravity as a scenario writes it: along −y in the plane (m/s², `f64`), or a
/// vector in world axes in space (`[f64; 3]`).
pub trait Gravity: Copy {
    /// The default: the paper's 9.8 m/s² along −y (planar), `[0, 0, −9.81]` (spatial).
    fn standard() -> Self;
}

impl Gravity for f64 {
    fn standard() -> f64 {
        tandem::model::planar::arm::GRAVITY
    }
}

impl Gravity for [f64; 3] {
    fn standard() -> [f64; 3] {
        [0.0, 0.0, -9.81]
    }
}

/// Plant-wide constants.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantConfig<G: Gravity> {
    /// Gravity: along −y, m/s² (planar), or in world axes, m/s² (spatial).
    #[serde(default = "G::standard")]
    pub gravity: G,
    /// Baumgarte natural frequency of the grasp-constraint drift control, rad/s (0 disables).
    #[serde(default = "default_baumgarte")]
    pub baumgarte: f64,
    /// Compliant grasps (a 6-D spring–damper per grasp, in grasp axes) instead of welds
    /// (spatial; planar grasps are welds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compliant_grasps: Option<ComplianceConfig>,
    /// Contact grasps held by friction: pads on each tool pressing on the box's faces (spatial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_grasps: Option<ContactConfig>,
}

fn default_baumgarte() -> f64 {
    20.0
}

impl<G: Gravity> Default for PlantConfig<G> {
    fn default() -> Self {
        PlantConfig {
            gravity: G::standard(),
            baumgarte: default_baumgarte(),
            compliant_grasps: None,
            contact_grasps: None,
        }
    }
}

/// A compliant grasp (every grasp the same).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComplianceConfig {
    /// Stiffness, (N/m ×3, N m/rad ×3).
    pub stiffness: [f64; 6],
    /// Damping, (N s/m ×3, N m s/rad ×3).
    pub damping: [f64; 6],
}

/// Contact grasps (every grasp the same pads, in its tool frame): `[plant.contact_grasps]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactConfig {
    /// Coulomb friction coefficient (required; optional here so that a torsion coefficient
    /// without it gets its own message).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu: Option<f64>,
    /// Torsional friction coefficient, m (MuJoCo's condim 4); absent: none (condim 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torsion: Option<f64>,
    /// Grip force: each pad's normal preload, N.
    pub grip: f64,
    /// Pad normal stiffness, N/m.
    #[serde(default = "default_pad_stiffness")]
    pub normal_stiffness: f64,
    /// Pad normal damping, N s/m.
    #[serde(default = "default_pad_damping")]
    pub normal_damping: f64,
    /// Pad tangential stiffness, N/m (default: the normal one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_stiffness: Option<f64>,
    /// Pad tangential damping, N s/m (default: the normal one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_damping: Option<f64>,
    /// The pads, in the tool frame (the same on every arm).
    pub pads: Vec<PadConfig>,
    /// The pads only gauge the grasps: the grasps stay welds (or the springs of
    /// `[plant.compliant_grasps]`), and the run reports the force each pad would carry and its
    /// friction-cone margins.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub gauge_only: bool,
}

/// Default pad stiffness, N/m: a silicone fingertip on an industrial gripper's finger.
pub const DEFAULT_PAD_STIFFNESS: f64 = 1e5;
/// Default pad damping, N s/m (about a fifth of critical against a UR5's 0.2 kg wrist at the
/// default stiffness).
pub const DEFAULT_PAD_DAMPING: f64 = 50.0;

fn default_pad_stiffness() -> f64 {
    DEFAULT_PAD_STIFFNESS
}

fn default_pad_damping() -> f64 {
    DEFAULT_PAD_DAMPING
}

/// One pad: `{ position = [x, y, z], normal = [x, y, z], radius = r }` in the tool frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PadConfig {
    /// Centre of the pad's face, tool frame, m.
    pub position: [f64; 3],
    /// The direction the pad presses in (into the object), tool axes.
    pub normal: [f64; 3],
    /// Pad radius, m.
    pub radius: f64,
}

/// Timing, start and determinism. The start is said per kind: a planar object's start pose at
/// rest (`start`, required) or a spatial object's offset from the desired pose at `t = 0`
/// (`start_offset`, default zero); the timing is required in planar files and defaults to a 1 ms
/// step and a 10 ms log in spatial ones ([`RunConfig::complete`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Simulated time, s.
    pub duration: f64,
    /// Plant RK4 step, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plant_step: Option<f64>,
    /// Control period, s (a whole multiple of `plant_step`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control_period: Option<f64>,
    /// Logging period, s (a whole multiple of `control_period`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log_period: Option<f64>,
    /// Planar: the object's start pose at rest, (m, m, rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<[f64; 3]>,
    /// Spatial: the start pose at rest relative to the desired pose at `t = 0`: position offset
    /// (m, world axes) and rotation vector (rad, world axes), `[dx, dy, dz, rx, ry, rz]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_offset: Option<[f64; 6]>,
    /// Planar: `constrained` (default) or `reduced`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formulation: Option<tandem::sim::Formulation>,
    /// Seed of every random stream (sensor noise, dropout).
    #[serde(default)]
    pub seed: u64,
    /// Largest grasp-constraint drift before the run stops, m (and rad); default 1e-6 for
    /// welds (planar and spatial), 0.05 for spatial compliant grasps (a grasp that slipped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_drift: Option<f64>,
    /// Smallest arm-Jacobian singular value before the run stops.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_sigma: Option<f64>,
}

/// The spatial plant step and control period when a file does not give them, s.
pub const SPATIAL_STEP: f64 = 1e-3;
/// The spatial log period when a file does not give it, s.
pub const SPATIAL_LOG_PERIOD: f64 = 0.01;

impl RunConfig {
    /// Check the fields of the other kind are absent and fill the defaults of this one, so
    /// that every field the kind uses is set (and written to `scenario.toml`). `Err((field,
    /// message))` names a field.
    pub fn complete(&mut self, kind: crate::scenario::Kind) -> Result<(), (String, String)> {
        use crate::scenario::Kind;
        let other = |f: &str, m: &str| Err((format!("run.{f}"), format!("run.{f}: {m}")));
        match kind {
            Kind::Planar => {
                if self.start_offset.is_some() {
                    return other(
                        "start_offset",
                        "a planar scenario gives the object's start pose, `run.start = [x, y, θ]`",
                    );
                }
                for (f, v) in [
                    ("plant_step", self.plant_step.is_some()),
                    ("control_period", self.control_period.is_some()),
                    ("log_period", self.log_period.is_some()),
                    ("start", self.start.is_some()),
                ] {
                    if !v {
                        return Err(("run".into(), format!("missing field `{f}` in run")));
                    }
                }
                self.formulation.get_or_insert_default();
            }
            Kind::Spatial => {
                if self.start.is_some() {
                    return other(
                        "start",
                        "a spatial scenario starts at the desired pose plus `run.start_offset = \
                         [dx, dy, dz, rx, ry, rz]`",
                    );
                }
                if self.formulation.is_some() {
                    return other(
                        "formulation",
                        "spatial plants have one formulation (the KKT system of the closed chain)",
                    );
                }
                self.plant_step.get_or_insert(SPATIAL_STEP);
                self.control_period.get_or_insert(SPATIAL_STEP);
                self.log_period.get_or_insert(SPATIAL_LOG_PERIOD);
                self.start_offset.get_or_insert([0.0; 6]);
            }
        }
        Ok(())
    }

    /// The plant step, s (set by [`RunConfig::complete`]).
    pub fn plant_step(&self) -> f64 {
        self.plant_step.unwrap_or(SPATIAL_STEP)
    }
    /// The control period, s.
    pub fn control_period(&self) -> f64 {
        self.control_period.unwrap_or(SPATIAL_STEP)
    }
    /// The log period, s.
    pub fn log_period(&self) -> f64 {
        self.log_period.unwrap_or(SPATIAL_LOG_PERIOD)
    }
    /// The planar start pose (required in a planar file), (m, m, rad).
    pub fn start(&self) -> [f64; 3] {
        self.start.unwrap_or([0.0; 3])
    }
    /// The spatial start offset, `[dx, dy, dz, rx, ry, rz]`.
    pub fn start_offset(&self) -> [f64; 6] {
        self.start_offset.unwrap_or([0.0; 6])
    }
    /// The planar formulation.
    pub fn formulation(&self) -> tandem::sim::Formulation {
        self.formulation.unwrap_or_default()
    }
}

/// Which desired path (the shapes of both kinds; [`PathKind::fields`] says which a kind has).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PathKind {
    /// A circle at constant rate: planar `center`, `radius`, `omega`, `phase`, `theta`
    /// ([`tandem::reference::planar::path::Path::circle`]); spatial also an orientation
    /// oscillation about a fixed axis (`plane_x`, `plane_y`, `r0`, `axis`, `axis_frame`,
    /// `amplitude`, `omega_rot`, `phase_rot`; [`tandem::reference::spatial::path::Se3Path::circle`]).
    Circle,
    /// Rest to rest from `from` to `to` (quintic time law; geodesic in orientation): `from`,
    /// `to`, `duration`, `t0`.
    PointToPoint,
    /// A figure eight (Gerono lemniscate, planar only): `center`, `size`, `omega`, `phase`,
    /// `theta`.
    Lemniscate,
    /// A clamped cubic spline through timed poses: `waypoints`.
    Spline,
}

impl PathKind {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            PathKind::Circle => "circle",
            PathKind::PointToPoint => "point_to_point",
            PathKind::Lemniscate => "lemniscate",
            PathKind::Spline => "spline",
        }
    }

    /// The fields this kind of path uses on a `space` scenario: (required, optional); `None`
    /// for a shape that kind of scenario does not have.
    pub fn fields(
        self,
        space: crate::scenario::Kind,
    ) -> Option<(&'static [&'static str], &'static [&'static str])> {
        use crate::scenario::Kind;
        Some(match (self, space) {
            (PathKind::Circle, Kind::Planar) => {
                (&["center", "radius", "omega"], &["phase", "theta"])
            }
            (PathKind::Circle, Kind::Spatial) => (
                &["center", "radius", "omega"],
                &[
                    "phase",
                    "plane_x",
                    "plane_y",
                    "r0",
                    "axis",
                    "axis_frame",
                    "amplitude",
                    "omega_rot",
                    "phase_rot",
                ],
            ),
            (PathKind::PointToPoint, _) => (&["from", "to", "duration"], &["t0"]),
            (PathKind::Lemniscate, Kind::Planar) => {
                (&["center", "size", "omega"], &["phase", "theta"])
            }
            (PathKind::Lemniscate, Kind::Spatial) => return None,
            (PathKind::Spline, _) => (&["waypoints"], &[]),
        })
    }
}

/// `world` or `body`: the axes a spatial path's oscillation `axis` is given in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisFrameConfig {
    /// The axis is fixed in the world.
    World,
    /// The axis is fixed in the object (in `r0`'s axes).
    Body,
}

/// An orientation: at most one of the forms (none = identity).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Orientation {
    /// Roll, pitch, yaw (URDF convention), rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rpy: Option<[f64; 3]>,
    /// Unit quaternion `[w, x, y, z]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion: Option<[f64; 4]>,
    /// The frame's x, y and z axes as columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<[[f64; 3]; 3]>,
}

/// The desired object path: `kind` plus the fields that kind uses on this kind of scenario (the
/// others must be absent: [`PathConfig::check_fields`]). A planar table has points `Pt = [x, y]`,
/// poses `Pose = [x, y, θ]` and waypoints `{ t, pose }`; a spatial one `[x, y, z]`, placements
/// and waypoints `{ t, position, orientation }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "Pt: Serialize, Pose: Serialize, Wp: Serialize",
        deserialize = "Pt: Deserialize<'de>, Pose: Deserialize<'de>, Wp: Deserialize<'de>"
    )
)]
pub struct PathConfig<Pt, Pose, Wp> {
    /// The shape.
    pub kind: PathKind,
    /// Centre (circle, lemniscate), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center: Option<Pt>,
    /// Radius (circle), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Half-width (lemniscate), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<f64>,
    /// Angular rate along the path (circle, lemniscate), rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
    /// Phase at t = 0 (circle, lemniscate), rad; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase: Option<f64>,
    /// Constant orientation (planar circle, lemniscate), rad; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
    /// First in-plane axis (spatial circle; default world x).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane_x: Option<[f64; 3]>,
    /// Second in-plane axis (spatial circle; default world y).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane_y: Option<[f64; 3]>,
    /// Orientation about which the object oscillates (spatial circle; default identity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r0: Option<Orientation>,
    /// Oscillation axis (spatial circle; default y).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// `world` (default) or `body`: the axes `axis` is given in (spatial circle).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis_frame: Option<AxisFrameConfig>,
    /// Oscillation amplitude (spatial circle), rad (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// Oscillation rate (spatial circle), rad/s (default `omega`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega_rot: Option<f64>,
    /// Oscillation phase (spatial circle), rad (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_rot: Option<f64>,
    /// Start pose (point_to_point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<Pose>,
    /// End pose (point_to_point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<Pose>,
    /// Start time of the motion (point_to_point), s; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t0: Option<f64>,
    /// Duration of the motion (point_to_point), s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub duration: Option<f64>,
    /// Timed waypoints (spline).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waypoints: Option<Vec<Wp>>,
}

impl<Pt, Pose, Wp> PathConfig<Pt, Pose, Wp> {
    /// The fields `kind` needs are present and no other is: errors name the field (`path.omega
    /// is missing`, then `path.size is not used by kind = "circle"`) with its line.
    pub fn check_fields(
        &self,
        space: crate::scenario::Kind,
        src: &crate::scenario::Source,
    ) -> Result<(), crate::scenario::ScenarioError> {
        let kind = self.kind;
        let Some((required, optional)) = kind.fields(space) else {
            return Err(src.error_at(
                "path.kind",
                format!(
                    "path.kind = \"{}\" is not a {} path",
                    kind.name(),
                    space.name()
                ),
            ));
        };
        let present: [(&str, bool); 19] = [
            ("center", self.center.is_some()),
            ("radius", self.radius.is_some()),
            ("size", self.size.is_some()),
            ("omega", self.omega.is_some()),
            ("phase", self.phase.is_some()),
            ("theta", self.theta.is_some()),
            ("plane_x", self.plane_x.is_some()),
            ("plane_y", self.plane_y.is_some()),
            ("r0", self.r0.is_some()),
            ("axis", self.axis.is_some()),
            ("axis_frame", self.axis_frame.is_some()),
            ("amplitude", self.amplitude.is_some()),
            ("omega_rot", self.omega_rot.is_some()),
            ("phase_rot", self.phase_rot.is_some()),
            ("from", self.from.is_some()),
            ("to", self.to.is_some()),
            ("t0", self.t0.is_some()),
            ("duration", self.duration.is_some()),
            ("waypoints", self.waypoints.is_some()),
        ];
        let list = |f: &[&str]| {
            f.iter()
                .map(|f| format!("`{f}`"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        // What the kind needs first (a user who changed `kind` learns what to add), then
        // what it does not use.
        for (name, set) in present {
            if !set && required.contains(&name) {
                return Err(src.error_at(
                    "path",
                    format!(
                        "path.{name} is missing: kind = \"{}\" needs {}",
                        kind.name(),
                        list(required)
                    ),
                ));
            }
        }
        for (name, set) in present {
            if set && !(required.contains(&name) || optional.contains(&name)) {
                let all: Vec<&str> = required.iter().chain(optional.iter()).copied().collect();
                return Err(src.error_at(
                    &format!("path.{name}"),
                    format!(
                        "path.{name} is not used by kind = \"{}\" (it takes {})",
                        kind.name(),
                        list(&all)
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// `[controller.actuator]`: the actuator stage every law's torques go through (issue 24;
/// [`tandem::control::actuator`]): per-joint effort limits, a torque-rate limit and a
/// first-order output filter, all off by default (no change to any result). The library
/// validates the values; its errors name `controller.actuator.<field>`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorConfig {
    /// Effort limit per joint, N m, all arms in joint order (`inf` for a joint without one;
    /// absent: `controller.torque_limit`, or on spatial arms each joint's URDF `effort`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effort: Option<Vec<f64>>,
    /// Torque-rate limit, every joint, N m/s (absent: none, or on spatial arms the embedded
    /// robot's published limit: Franka 1000 N m/s; `inf`: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_limit: Option<f64>,
    /// Time constant of the first-order output filter, s, at least the control period (absent:
    /// none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter_time_constant: Option<f64>,
    /// Anti-windup of the NN update against the stage (default: on when a field of this table
    /// sets a limit; `torque_limit` or a URDF's `effort` alone keep the update as before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anti_windup: Option<bool>,
}

impl ActuatorConfig {
    /// Nothing set (the table is left out of a written scenario).
    pub fn is_off(&self) -> bool {
        *self == ActuatorConfig::default()
    }
    /// The library's parameters.
    pub fn params(&self) -> tandem::control::actuator::ActuatorParams {
        tandem::control::actuator::ActuatorParams {
            effort: self.effort.clone(),
            // `inf` is "no limit" (it turns an embedded robot's default off).
            rate_limit: self.rate_limit.filter(|r| *r != f64::INFINITY),
            filter_time_constant: self.filter_time_constant,
            anti_windup: self.anti_windup,
        }
    }
}

/// The NN law's gains, every field optional over a base: the planar preset (`gains = "paper"`
/// or `"tuned"`) or, on spatial arms, the per-axis design from the chart-space inertia
/// (`design`, SPEC §3.4's linearised loop; see `NnGains::<6>::from_design`); any gain given
/// here replaces the base's ([`NnConfig::apply`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct NnConfig<const N: usize> {
    /// The per-axis design (spatial; a spatial scenario always has it, defaults written out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design: Option<DesignConfig>,
    /// `K1` diagonal, 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k1: Option<[f64; N]>,
    /// `K2` diagonal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k2: Option<[f64; N]>,
    /// `K_r` diagonal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_r: Option<[f64; N]>,
    /// Adaptation gains `Θ_j`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<[f64; N]>,
    /// σ-modification.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<[f64; N]>,
    /// Robust-term smoothing `ϖ`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub varpi: Option<f64>,
    /// Safety factor on `f^U`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fu_safety: Option<f64>,
    /// RBF width `ϑ²`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width2: Option<f64>,
    /// Centre levels per input.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<Vec<f64>>,
    /// Switching inner radius.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub d1: Option<f64>,
    /// Switching outer radius.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub d2: Option<f64>,
    /// Switching shape `ω ≥ 1`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
    /// Network structure (`{ kind = "per_axis" }`, `quasi_random` with `n`, `seed`, or the
    /// full grid; default: the base's: planar full grid, spatial per axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network: Option<tandem::control::rbf::structured::NetworkStructure>,
    /// Smoothing of the robust term (`"paper"`: the paper's constant `ϖ`; `"sampled"`: the
    /// boundary layer widened to what the control period resolves, `docs/smooth-nn.md`;
    /// default: planar `paper`, spatial `sampled`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub smoothing: Option<tandem::control::law::adaptive::Smoothing>,
}

impl<const N: usize> Default for NnConfig<N> {
    fn default() -> Self {
        NnConfig {
            design: None,
            k1: None,
            k2: None,
            k_r: None,
            theta: None,
            sigma: None,
            varpi: None,
            fu_safety: None,
            width2: None,
            levels: None,
            d1: None,
            d2: None,
            omega: None,
            network: None,
            smoothing: None,
        }
    }
}

impl<const N: usize> NnConfig<N> {
    /// Nothing set.
    pub fn is_empty(&self) -> bool {
        *self == NnConfig::default()
    }

    /// The design (its defaults where the file gives none).
    pub fn design(&self) -> DesignConfig {
        self.design.clone().unwrap_or_default()
    }

    /// `g` with every gain this table gives.
    pub fn apply(
        &self,
        mut g: tandem::control::law::adaptive::NnGains<N>,
    ) -> tandem::control::law::adaptive::NnGains<N> {
        macro_rules! set {
            ($($f:ident),*) => { $( if let Some(v) = &self.$f { g.$f = v.clone(); } )* };
        }
        set!(
            k1, k2, k_r, theta, sigma, varpi, fu_safety, width2, levels, d1, d2, omega, network,
            smoothing
        );
        g
    }
}

/// The per-axis gain design.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignConfig {
    /// Chart-space inertia per axis (kg ×3, kg m² ×3). Default: 1.1 × the largest diagonal of
    /// the chart-space inertia along the path (computed at set-up), rounded up to two
    /// significant digits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertia: Option<[f64; 6]>,
    /// `K1`, 1/s.
    #[serde(default = "default_k1")]
    pub k1: f64,
    /// Natural frequency of the adaptive-bias pair, rad/s.
    #[serde(default = "default_omega_n")]
    pub omega_n: f64,
    /// Its damping ratio.
    #[serde(default = "default_zeta")]
    pub zeta: f64,
}

fn default_k1() -> f64 {
    8.0
}
fn default_omega_n() -> f64 {
    20.0
}
fn default_zeta() -> f64 {
    0.8
}

impl Default for DesignConfig {
    fn default() -> Self {
        DesignConfig {
            inertia: None,
            k1: default_k1(),
            omega_n: default_omega_n(),
            zeta: default_zeta(),
        }
    }
}
