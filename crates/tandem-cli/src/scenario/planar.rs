//! Planar scenario files: two-link (or n-link) arms in the plane carrying a box (SPEC), in TOML.
//!
//! A scenario file deserializes into the plain structs below (every struct `deny_unknown_fields`,
//! STYLE §7 "config is not model"); [`build`] turns it into the library's parameter types and
//! [`make_simulation`] into a validated [`Simulation`]. All range checks are the library's: its
//! [`ModelError`] names the parameter path, which is mapped back to the file's field path (and,
//! when the field is in the file, to its line and column).
//!
//! Layout (see `scenarios/paper.toml` for every field with its origin):
//!
//! | table | maps to |
//! |---|---|
//! | `description` | free text |
//! | `[[arms]]`, `[[arms.links]]` | [`ArmParams`], [`LinkParams`], grasp point `r_i` |
//! | `[object]` | [`ObjectParams`] (from a mass, or explicit: [`ObjectConfig`]) |
//! | `[plant]` | gravity, Baumgarte drift control |
//! | `[path]` | [`Path`] (`kind` = circle, point_to_point, lemniscate, spline) |
//! | `[disturbance]`, `[[disturbance.pushes]]` | [`Disturbance`], [`tandem::model::disturbance::Push`] |
//! | `[sensors]` | [`SensorParams`] (its seed is `run.seed`) |
//! | `[controller]` (+ `.nn`, `.pd`, `.ctc`) | [`ControllerParams`] or a torque replay |
//! | `[admittance]` | [`AdmittanceParams`] |
//! | `[run]` | [`SimParams`] and the seed |
//! | `[metrics]` | the transient window of the summary |

use std::path::{Path as FsPath, PathBuf};

use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};
use tandem::ModelError;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::{Controller, ControllerParams};
use tandem::control::{ControlWarning, Scheme};
use tandem::drive::Drive;
use tandem::model::disturbance::Disturbance;
use tandem::model::planar::arm::{ArmParams, Elbow, LinkParams};
use tandem::model::planar::object::ObjectParams;
use tandem::plant::planar::Plant;
use tandem::plant::planar::PlantParams;
use tandem::reference::planar::admittance::AdmittanceParams;
use tandem::reference::planar::path::Path;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Driver, Replay, SimParams, Simulation};

use super::source::*;
use super::tables::{
    ActuatorConfig, AdmittanceConfig, ControllerKind, CtcConfig, DisturbanceConfig, MetricsConfig,
    NnConfig, PathKind, PdConfig, PlantConfig, RunConfig, SensorsConfig,
};
use super::{GRASP_SURFACE_TOL, Overrides};

// ---------------------------------------------------------------------------------------------
// The file's structs.

/// A scenario file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarScenario {
    /// Scenario name (outputs and figure titles); defaults to the file's stem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Free text, shown by `tandem validate` and in the report.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// The arms, in order (arm 1 first).
    pub arms: Vec<ArmConfig>,
    /// The carried object.
    pub object: ObjectConfig,
    /// Plant-wide constants.
    #[serde(default)]
    pub plant: PlantConfig<f64>,
    /// The desired object path.
    pub path: PathConfig,
    /// Environment disturbance on the object (default: none).
    #[serde(default)]
    pub disturbance: DisturbanceConfig<3>,
    /// Sensor imperfections (default: ideal).
    #[serde(default)]
    pub sensors: SensorsConfig,
    /// The controller (or a torque replay).
    pub controller: ControllerConfig,
    /// The admittance reference generator (default: on, SPEC §3.1 values).
    #[serde(default)]
    pub admittance: AdmittanceConfig<2>,
    /// Timing, start pose, formulation, seed.
    pub run: RunConfig,
    /// Summary metrics.
    #[serde(default)]
    pub metrics: MetricsConfig,
    /// Injected faults for robustness studies (default: none).
    #[serde(default, skip_serializing_if = "FaultsConfig::is_off")]
    pub faults: FaultsConfig,
}

/// The carried object, paper (10): `M_o ẍ_o + C_o ẋ_o + G_o = F_o − F_d`. Two forms:
///
/// - with a mass (as spatial objects): `mass` (kg) and `inertia` the rotational inertia about
///   the centre (kg m²); `M_o = diag(m, m, I)` and `G_o = (0, m g, 0)` with `g = plant.gravity`
///   follow from them;
/// - explicit (the paper's matrices, SPEC §4): `inertia = [m, m, I]` and `gravity = [0, m g,
///   0]` (SPEC §1 sign: gravity on the left of (10)).
///
/// Payload faults (`faults.payload_mass`) and sweeps of `object.mass` change the mass and
/// everything that follows from it together ([`ObjectConfig::params`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectConfig {
    /// Mass, kg (the form with a mass).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// The rotational inertia about the centre, kg m² (with `mass`), or the diagonal of `M_o`,
    /// `[m, m, I]` (kg, kg, kg m²; the explicit form).
    pub inertia: ObjectInertia,
    /// Diagonal of the viscous damping `C_o`, (N s/m, N s/m, N m s/rad).
    pub damping: [f64; 3],
    /// Gravity wrench `G_o`, (N, N, N m) (the explicit form; with `mass` it follows from
    /// `plant.gravity`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<[f64; 3]>,
    /// Box size (length along the grasp axis, height), m.
    pub size: [f64; 2],
}

/// `object.inertia`: the rotational inertia alone (with `object.mass`) or `[m, m, I]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    untagged,
    expecting = "a number (the rotational inertia, kg m², with object.mass) or an array [m, m, I] of three numbers"
)]
pub enum ObjectInertia {
    /// The rotational inertia about the centre, kg m².
    Rotational(f64),
    /// The diagonal of `M_o`: (mass, mass, rotational inertia).
    Diagonal([f64; 3]),
}

impl ObjectConfig {
    /// The object's model on a plant with gravity `g` (m/s²), its mass and rotational inertia
    /// scaled by `payload = (mass ratio, inertia ratio)` (a payload fault; `(1, 1)` is the
    /// nominal object). Errors name the field: a form that mixes the two.
    pub fn params(&self, g: f64, payload: (f64, f64)) -> Result<ObjectParams, (String, String)> {
        let (pm, pi) = payload;
        let err = |f: &str, m: &str| Err((f.to_string(), format!("{f}: {m}")));
        let mut p = match (self.mass, self.inertia, self.gravity) {
            (Some(m), ObjectInertia::Rotational(i), None) => {
                let m = m * pm;
                return Ok(ObjectParams {
                    inertia: [m, m, i * pi],
                    damping: self.damping,
                    gravity: [0.0, m * g, 0.0],
                    size: self.size,
                });
            }
            (Some(_), ObjectInertia::Diagonal(_), _) => {
                return err(
                    "object.inertia",
                    "with object.mass give the rotational inertia alone (kg m², e.g. `inertia = 1.0`); \
                     [m, m, I] is the explicit form, without mass",
                );
            }
            (Some(_), _, Some(_)) => {
                return err(
                    "object.gravity",
                    "follows from object.mass and plant.gravity; give object.mass or object.gravity, not both",
                );
            }
            (None, ObjectInertia::Rotational(_), _) => {
                return err(
                    "object.mass",
                    "missing: `inertia = I` is the rotational inertia and needs the mass (`mass = 1.0`), \
                     or give the explicit form `inertia = [m, m, I]` with `gravity`",
                );
            }
            (None, ObjectInertia::Diagonal(_), None) => {
                return err(
                    "object.gravity",
                    "missing: the explicit form `inertia = [m, m, I]` needs `gravity = [0, m g, 0]` \
                     (or give `mass` and the rotational inertia alone)",
                );
            }
            (None, ObjectInertia::Diagonal(d), Some(gr)) => ObjectParams {
                inertia: d,
                damping: self.damping,
                gravity: gr,
                size: self.size,
            },
        };
        if payload != (1.0, 1.0) {
            p.inertia[0] *= pm;
            p.inertia[1] *= pm;
            p.inertia[2] *= pi;
            p.gravity = p.gravity.map(|x| x * pm);
        }
        Ok(p)
    }
}

/// Injected faults (see `tandem::sim::faults`); everything off by default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultsConfig {
    /// Sensor dropout bursts per second (every reading holds during a burst).
    #[serde(default)]
    pub dropout_rate: f64,
    /// Length of one dropout burst, s.
    #[serde(default)]
    pub dropout_length: f64,
    /// Force-sensor saturation per component, N.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_limit: Option<f64>,
    /// Force-sensor delay, s (whole control periods).
    #[serde(default)]
    pub force_delay: f64,
    /// Encoder quantisation step, rad.
    #[serde(default)]
    pub encoder_resolution: f64,
    /// Actuator torque saturation, N m (the controller does not know it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque_limit: Option<f64>,
    /// Actuator torque rate limit, N m/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque_rate: Option<f64>,
    /// Payload mismatch: the true object's mass over the nominal one (`object`), which the
    /// controller keeps.
    #[serde(default = "one")]
    pub payload_mass: f64,
    /// The true object's rotational inertia over the nominal one.
    #[serde(default = "one")]
    pub payload_inertia: f64,
}

fn one() -> f64 {
    1.0
}

impl Default for FaultsConfig {
    fn default() -> Self {
        FaultsConfig {
            dropout_rate: 0.0,
            dropout_length: 0.0,
            force_limit: None,
            force_delay: 0.0,
            encoder_resolution: 0.0,
            torque_limit: None,
            torque_rate: None,
            payload_mass: 1.0,
            payload_inertia: 1.0,
        }
    }
}

impl FaultsConfig {
    fn is_off(&self) -> bool {
        *self == FaultsConfig::default()
    }
    /// The library's injection (the payload is applied to the plant instead).
    pub fn injection(&self, seed: u64) -> tandem::sim::faults::Faults {
        tandem::sim::faults::Faults {
            dropout_rate: self.dropout_rate,
            dropout_length: self.dropout_length,
            force_limit: self.force_limit,
            force_delay: self.force_delay,
            encoder_resolution: self.encoder_resolution,
            torque_limit: self.torque_limit,
            torque_rate: self.torque_rate,
            seed: splitmix(seed),
        }
    }
}

/// A seed for the fault stream distinct from the sensors' (same run seed).
fn splitmix(seed: u64) -> u64 {
    tandem::math::random::splitmix64(seed ^ 0x6661_756c_7473)
}

/// One arm.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmConfig {
    /// Base position in the world, m.
    pub base: [f64; 2],
    /// Base orientation (added to `q_1`), rad.
    #[serde(default)]
    pub base_angle: f64,
    /// Elbow branch of a 2-link arm's inverse kinematics: "positive" (`q_2 > 0`) or "negative".
    #[serde(default = "default_elbow")]
    pub elbow: Elbow,
    /// Grasp point `r_i` in the object frame, m.
    pub grasp: [f64; 2],
    /// Initial joint-angle guess for the numerical inverse kinematics of an arm that does not
    /// have 2 links, rad (one per link).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_guess: Option<Vec<f64>>,
    /// The links, from the base out.
    pub links: Vec<LinkParams>,
}

fn default_elbow() -> Elbow {
    Elbow::Positive
}

/// The planar path table: centres `[x, y]`, poses `[x, y, θ]`, [`Waypoint`]s.
pub type PathConfig = super::tables::PathConfig<[f64; 2], [f64; 3], Waypoint>;

/// One spline waypoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Waypoint {
    /// Time, s.
    pub t: f64,
    /// Pose (x, y, θ), (m, m, rad).
    pub pose: [f64; 3],
}

/// Gain preset of the NN law.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum GainPreset {
    /// The paper's gains (Section V-B-2); they end in a limit cycle (SPEC §3.4).
    Paper,
    /// Gains that make the paper's claims hold (SPEC §3.4).
    Tuned,
}

impl GainPreset {
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            GainPreset::Paper => "paper",
            GainPreset::Tuned => "tuned",
        }
    }
    fn gains(self) -> NnGains<3> {
        match self {
            GainPreset::Paper => NnGains::paper(),
            GainPreset::Tuned => NnGains::tuned(),
        }
    }
}

/// The controller section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerConfig {
    /// `nn`, `pd`, `ctc` or `replay`.
    pub kind: ControllerKind,
    /// NN gain preset (default `tuned`); used by `kind = "nn"` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gains: Option<GainPreset>,
    /// Where the law acts: `object` (the paper's simulation, default) or `per_arm`.
    #[serde(default)]
    pub scheme: Scheme,
    /// Output bounds `|x_1j| < k_cj`, (m, m, rad).
    pub k_c: [f64; 3],
    /// Offset `δ` of each arm's desired point inside its grasp point, m.
    pub delta: f64,
    /// Symmetric joint torque limit, N m (absent: unlimited).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque_limit: Option<f64>,
    /// The actuator stage: effort, rate limit, output filter (default: off; the effort limit
    /// is `torque_limit` unless given).
    #[serde(default, skip_serializing_if = "ActuatorConfig::is_off")]
    pub actuator: ActuatorConfig,
    /// Known bound of `|F_d,j|` for the NN law's `f^U` (absent: computed from `[disturbance]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disturbance_bound: Option<[f64; 3]>,
    /// Overrides of the NN preset.
    #[serde(default, skip_serializing_if = "NnConfig::is_empty")]
    pub nn: NnConfig<3>,
    /// PD gains.
    #[serde(default)]
    pub pd: PdConfig<3>,
    /// Computed-torque gains.
    #[serde(default)]
    pub ctc: CtcConfig<3>,
    /// Torque file of `kind = "replay"` (relative to the scenario file's folder).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay: Option<String>,
    /// How the replayed rows become torques between time stamps: `hold` (default; every row on
    /// the control grid) or `linear` (a log at another rate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay_interpolation: Option<crate::scenario::replay::Interpolation>,
    /// Column map of a replayed log from another tool: the time column's name, then one
    /// torque column per joint in the plant's joint order (default: tandem's names, `t` and
    /// `tau_q1…`/`tau1…`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay_columns: Option<Vec<String>>,
}

/// Parse a scenario's text.
pub fn parse(src: &Source) -> Result<PlanarScenario, ScenarioError> {
    let mut sc: PlanarScenario = parse_as(src)?;
    sc.run
        .complete(super::Kind::Planar)
        .map_err(|(f, m)| src.error_at(&f, m))?;
    if let Some(n) = &sc.name {
        check_name(src, n)?;
    }
    Ok(sc)
}

impl PlanarScenario {
    /// Apply command-line overrides; errors are bad input (exit code 2).
    pub fn apply(&mut self, o: &Overrides) -> Result<(), crate::BadInput> {
        if let Some(k) = o.controller {
            self.controller.kind = k;
        }
        if o.pd_gravity {
            self.controller.pd.gravity_compensation = Some(true);
        }
        if let Some(r) = &o.replay {
            if o.controller.is_none() {
                self.controller.kind = ControllerKind::Replay;
            } else if self.controller.kind != ControllerKind::Replay {
                return Err(crate::BadInput::msg(format!(
                    "--replay is for --controller replay, not --controller {}",
                    self.controller.kind.name()
                )));
            }
            let abs = std::path::absolute(r).unwrap_or_else(|_| r.clone());
            self.controller.replay = Some(abs.display().to_string());
        }
        if let Some(g) = o.gains {
            if self.controller.kind != ControllerKind::Nn {
                return Err(crate::BadInput::msg(format!(
                    "--gains {} selects a preset of the nn controller; this run uses the {} controller",
                    g.name(),
                    self.controller.kind.name()
                )));
            }
            self.controller.gains = Some(g);
        }
        if let Some(d) = o.duration {
            if !(d.is_finite() && d > 0.0) {
                return Err(crate::BadInput::msg(format!(
                    "--duration {d}: must be a positive number of seconds"
                )));
            }
            self.run.duration = d;
        }
        if let Some(s) = o.seed {
            self.run.seed = s;
        }
        if let Some(i) = o.replay_interpolation {
            if self.controller.kind != ControllerKind::Replay {
                return Err(crate::BadInput::msg(format!(
                    "--replay-interpolation is for a replay (--replay FILE), not the {} controller",
                    self.controller.kind.name()
                )));
            }
            self.controller.replay_interpolation = Some(i);
        }
        if let Some(c) = &o.replay_columns {
            if self.controller.kind != ControllerKind::Replay {
                return Err(crate::BadInput::msg(format!(
                    "--replay-columns is for a replay (--replay FILE), not the {} controller",
                    self.controller.kind.name()
                )));
            }
            self.controller.replay_columns = Some(c.clone());
        }
        Ok(())
    }

    /// The NN gains this scenario runs (preset plus overrides).
    pub fn nn_gains(&self) -> NnGains<3> {
        self.controller
            .nn
            .apply(self.controller.gains.unwrap_or(GainPreset::Tuned).gains())
    }

    /// Short label of the gains: `tuned`, `paper+overrides`, `paper` (PD), ...
    pub fn gains_label(&self) -> String {
        let c = &self.controller;
        match c.kind {
            ControllerKind::Nn => {
                let p = c.gains.unwrap_or(GainPreset::Tuned).name();
                if c.nn.is_empty()
                    || self.nn_gains() == c.gains.unwrap_or(GainPreset::Tuned).gains()
                {
                    p.to_string()
                } else {
                    format!("{p}+overrides")
                }
            }
            ControllerKind::Pd => {
                if self.pd_gains() == PdGains::<3>::paper() {
                    "paper".into()
                } else {
                    "custom".into()
                }
            }
            ControllerKind::Ctc => {
                if self.ctc_gains() == CtcGains::default() {
                    "default".into()
                } else {
                    "custom".into()
                }
            }
            ControllerKind::Replay => c
                .replay
                .as_deref()
                .and_then(|r| FsPath::new(r).file_name())
                .map_or_else(String::new, |f| f.to_string_lossy().into_owned()),
        }
    }

    fn pd_gains(&self) -> PdGains<3> {
        let d = PdGains::<3>::paper();
        PdGains {
            k_p: self.controller.pd.k_p.unwrap_or(d.k_p),
            k_d: self.controller.pd.k_d.unwrap_or(d.k_d),
            gravity_compensation: self.controller.pd.gravity_compensation.unwrap_or(false),
        }
    }

    fn ctc_gains(&self) -> CtcGains<3> {
        let d = CtcGains::default();
        let c = &self.controller.ctc;
        CtcGains {
            k_p: c.k_p.unwrap_or(d.k_p),
            k_d: c.k_d.unwrap_or(d.k_d),
            model_error: c.model_error.unwrap_or(d.model_error),
        }
    }

    /// The same scenario with every default and preset written out (for `scenario.toml`).
    pub fn resolved(&self) -> PlanarScenario {
        let mut s = self.clone();
        let c = &mut s.controller;
        if c.kind == ControllerKind::Nn {
            c.gains = Some(c.gains.unwrap_or(GainPreset::Tuned));
        }
        // The NN gains stay as preset name + the user's own overrides (not the expanded preset
        // values), so `--gains` and `compare`'s paper/tuned columns still switch the preset
        // when this file is run again.
        let pd = self.pd_gains();
        c.pd = PdConfig {
            k_p: Some(pd.k_p),
            k_d: Some(pd.k_d),
            gravity_compensation: c.pd.gravity_compensation,
        };
        let ctc = self.ctc_gains();
        c.ctc = CtcConfig {
            k_p: Some(ctc.k_p),
            k_d: Some(ctc.k_d),
            model_error: Some(ctc.model_error),
        };
        if c.disturbance_bound.is_none() {
            c.disturbance_bound = Some(self.disturbance.disturbance().bound());
        }
        let d = SimParams::paper();
        s.run.max_drift = Some(self.run.max_drift.unwrap_or(d.max_drift));
        s.run.min_sigma = Some(self.run.min_sigma.unwrap_or(d.min_sigma));
        s
    }

    /// The output bounds `k_c`.
    pub fn k_c(&self) -> [f64; 3] {
        self.controller.k_c
    }
}

// ---------------------------------------------------------------------------------------------
// Building the library's parameters.

/// A scenario turned into the library's parameter types (not yet validated by the library
/// beyond what [`build`] checks).
pub struct Built {
    /// The plant (truth); also the controller's model.
    pub plant: PlantParams,
    /// Sensors with the run's seed.
    pub sensors: SensorParams,
    /// `F_d`.
    pub disturbance: Disturbance,
    /// Timing.
    pub sim: SimParams,
    /// The desired path.
    pub path: Path,
    /// Controller parameters (`None` for a replay).
    pub controller: Option<ControllerParams>,
    /// The replay file (for `kind = "replay"`).
    pub replay: Option<PathBuf>,
    /// Stacked joint-angle guess for arms that are not 2-link.
    pub q_guess: Option<Vec<f64>>,
    /// The true plant when it differs from `plant` (the controller's nominal model): a payload
    /// mismatch of `[faults]`.
    pub truth: Option<PlantParams>,
}

/// The object's model ([`ObjectConfig::params`]) with the payload `(mass, inertia)` ratios,
/// validated; with a mass, an error in a derived quantity names the field it comes from
/// (`object.mass` for the masses and gravity of `M_o`, `G_o`; `object.inertia` for `I`).
fn object(
    sc: &PlanarScenario,
    src: &Source,
    payload: (f64, f64),
) -> Result<ObjectParams, ScenarioError> {
    let p = sc
        .object
        .params(sc.plant.gravity, payload)
        .map_err(|(f, m)| src.error_at(&f, m))?;
    if sc.object.mass.is_some() {
        let arms_mass: f64 = sc
            .arms
            .iter()
            .flat_map(|a| a.links.iter().map(|l| l.mass))
            .sum();
        tandem::plant::planar::object_within_arms(&p, arms_mass)
            .and_then(|_| tandem::model::planar::object::Object::new(&p).map(|_| ()))
            .map_err(|e| {
                src.model_error(e, |q| {
                    if q.starts_with("object.gravity")
                        || q == "object.inertia[0]"
                        || q == "object.inertia[1]"
                    {
                        "object.mass".to_string()
                    } else if q == "object.inertia[2]" {
                        "object.inertia".to_string()
                    } else {
                        q.to_string()
                    }
                })
            })?;
    }
    Ok(p)
}

/// Map a library parameter path of the plant to the file's.
fn plant_path(p: &str) -> String {
    if let Some(rest) = p.strip_prefix("grasps[") {
        // grasps[i][k] → arms[i].grasp[k]
        if let Some(end) = rest.find(']') {
            return format!("arms[{}].grasp{}", &rest[..end], &rest[end + 1..]);
        }
    }
    match p {
        "gravity" | "baumgarte" => format!("plant.{p}"),
        "grasps" => "arms".into(),
        _ => p.to_string(),
    }
}

/// Map a library parameter path of the path constructors (`circle.radius`) to `path.radius`.
fn path_path(p: &str) -> String {
    match p.split_once('.') {
        Some((_, rest)) => format!("path.{rest}"),
        None => format!("path.{p}"),
    }
}

/// Map a library parameter path of the run settings to the file's.
fn run_path(p: &str) -> String {
    format!("run.{p}")
}

/// A controller set-up warning with its place in the file: a gain's at the file path `gain_path`
/// maps the library's parameter to, an admittance warning's at the path its sentence starts
/// with (`admittance.m_e[0] …`). Planar and spatial scenarios.
pub(crate) fn control_warning(
    src: &Source,
    w: &ControlWarning,
    gain_path: impl Fn(&str) -> String,
) -> String {
    match w {
        ControlWarning::Gain { param, reason } => src.warning_at(&gain_path(param), reason),
        ControlWarning::Admittance(a) => {
            let t = a.to_string();
            let path = t.split_whitespace().next().unwrap_or("admittance");
            src.warning_at(path, &t)
        }
    }
}

/// The torque replay `file` for `n_q` joints on the run's control period and duration
/// (interpolation `mode`, default linear); an error names `controller.replay (or --replay)`.
/// Planar and spatial scenarios.
pub(crate) fn load_replay(
    src: &Source,
    file: &FsPath,
    n_q: usize,
    sim: &SimParams,
    mode: Option<crate::scenario::replay::Interpolation>,
    columns: Option<&[String]>,
) -> Result<Replay, ScenarioError> {
    let timing = crate::scenario::replay::Timing {
        control_period: sim.control_period,
        duration: sim.duration,
    };
    crate::scenario::replay::load(file, n_q, timing, mode.unwrap_or_default(), columns).map_err(
        |e| {
            let message = format!(
                "controller.replay (or --replay) = {}: {e:#}",
                file.display()
            );
            // The caret on the file's `replay = …` when it sets one (else the path came from
            // --replay alone and there is no line to show).
            match span_of(&src.text, "controller.replay") {
                Some((_, true)) => src.error_at("controller.replay", message),
                _ => ScenarioError {
                    file: src.display.clone(),
                    message,
                    span: None,
                    text: String::new(),
                },
            }
        },
    )
}

/// Map a library parameter path of [`Controller::new`] to the file's.
fn controller_path(kind: ControllerKind) -> impl Fn(&str) -> String {
    move |p: &str| {
        let section = match kind {
            ControllerKind::Nn => "nn",
            ControllerKind::Pd => "pd",
            ControllerKind::Ctc => "ctc",
            ControllerKind::Replay => "replay",
        };
        // The RBF network's own paths (`rbf.levels`, `rbf.centres`) are the NN's `levels`.
        let p = p
            .strip_prefix("gains.")
            .map_or(p, |r| if r.starts_with("rbf.") { r } else { p });
        if p.starts_with("rbf.") {
            return format!("controller.{section}.levels");
        }
        if let Some(rest) = p.strip_prefix("gains.") {
            if rest.starts_with("k_c") {
                return format!("controller.{rest}");
            }
            return format!("controller.{section}.{rest}");
        }
        if p.starts_with("admittance.") {
            return p.to_string();
        }
        if p.starts_with("arms") {
            return p.to_string();
        }
        match p {
            "control_period" | "h" => "run.control_period".into(),
            "grasps" => "arms".into(),
            "law" => "controller.kind".into(),
            "path" => "path".into(),
            "scheme" => "controller.scheme".into(),
            _ => format!("controller.{p}"),
        }
    }
}

/// Check the scenario's own structure and turn it into library parameters.
pub fn build(sc: &PlanarScenario, src: &Source) -> Result<Built, ScenarioError> {
    // Arms and grasps.
    if sc.arms.is_empty() {
        return Err(src.error_at("arms", "at least one arm is needed ([[arms]])"));
    }
    if sc.arms.len() > MAX_ARMS {
        return Err(src.error_at(
            "arms",
            format!("{} arms: at most {MAX_ARMS} are supported", sc.arms.len()),
        ));
    }
    if let Some((i, a)) = sc
        .arms
        .iter()
        .enumerate()
        .find(|(_, a)| a.links.len() > MAX_LINKS)
    {
        return Err(src.error_at(
            &format!("arms[{i}].links"),
            format!(
                "arms[{i}] has {} links: at most {MAX_LINKS} are supported",
                a.links.len()
            ),
        ));
    }
    let mut q_guess = Vec::new();
    let mut need_guess = false;
    for (i, a) in sc.arms.iter().enumerate() {
        match &a.q_guess {
            Some(g) if g.len() != a.links.len() => {
                return Err(src.error_at(
                    &format!("arms[{i}].q_guess"),
                    format!(
                        "arms[{i}].q_guess has {} angles for {} links",
                        g.len(),
                        a.links.len()
                    ),
                ));
            }
            Some(g) => {
                if let Some(k) = g.iter().position(|v| !v.is_finite()) {
                    return Err(src.error_at(
                        &format!("arms[{i}].q_guess[{k}]"),
                        format!("arms[{i}].q_guess[{k}] = {}: must be finite", num(g[k])),
                    ));
                }
                q_guess.extend_from_slice(g)
            }
            None if a.links.len() != 2 => {
                return Err(src.error_at(
                    &format!("arms[{i}]"),
                    format!(
                        "arms[{i}] has {} links: give q_guess (initial joint angles, rad) for its numerical inverse kinematics (analytic IK covers 2-link arms only)",
                        a.links.len()
                    ),
                ));
            }
            None => q_guess.extend(std::iter::repeat_n(0.0, a.links.len())),
        }
        need_guess |= a.links.len() != 2;
    }
    let plant = PlantParams {
        arms: sc
            .arms
            .iter()
            .map(|a| ArmParams {
                base: a.base,
                base_angle: a.base_angle,
                links: a.links.clone(),
                elbow: a.elbow,
            })
            .collect(),
        grasps: sc.arms.iter().map(|a| a.grasp).collect(),
        object: object(sc, src, (1.0, 1.0))?,
        gravity: sc.plant.gravity,
        baumgarte: sc.plant.baumgarte,
    };
    tandem::plant::planar::Plant::new(&plant).map_err(|e| src.model_error(e, plant_path))?;
    // Two arms holding the same point leave the object's rotation about it undetermined.
    for (j, b) in sc.arms.iter().enumerate() {
        for (i, a) in sc.arms.iter().enumerate().take(j) {
            let d = (a.grasp[0] - b.grasp[0]).hypot(a.grasp[1] - b.grasp[1]);
            if !(d > 1e-6) {
                return Err(src.error_at(
                    &format!("arms[{j}].grasp"),
                    format!(
                        "arms[{j}].grasp = ({}, {}) coincides with arms[{i}].grasp: the grasp points must be distinct (at least 1 µm apart) to hold the object",
                        num(b.grasp[0]),
                        num(b.grasp[1])
                    ),
                ));
            }
        }
    }

    // Path.
    let path = build_path(&sc.path, src)?;

    // Disturbance and sensors.
    let disturbance = sc.disturbance.disturbance();
    disturbance
        .validate()
        .map_err(|e| src.model_error(e, |p| p.to_string()))?;
    // The tables shared with spatial scenarios have fields a planar set-up does not.
    if sc.sensors.torque.is_some() {
        return Err(src.error_at(
            "sensors.torque",
            "sensors.torque: a planar arm has no wrist torque channel (its force sensor reads the \
             end effector's force in the plane, `sensors.force`)",
        ));
    }
    if sc.controller.nn.design.is_some() {
        return Err(src.error_at(
            "controller.nn.design",
            "controller.nn.design: the per-axis design from the chart-space inertia is the \
             spatial NN law's; planar NN gains are a preset (`gains = \"tuned\"`, --gains) plus \
             the gains given in [controller.nn]",
        ));
    }
    if sc.plant.compliant_grasps.is_some() {
        return Err(src.error_at(
            "plant.compliant_grasps",
            "plant.compliant_grasps: planar grasps are welds (compliant grasps are a spatial \
             plant's, SPEC-spatial)",
        ));
    }
    if sc.plant.contact_grasps.is_some() {
        return Err(src.error_at(
            "plant.contact_grasps",
            "plant.contact_grasps: planar grasps are welds (contact grasps held by friction are \
             the spatial plant's)",
        ));
    }
    let sensors = sc.sensors.params(sc.run.seed);
    sensors
        .validate()
        .map_err(|e| src.model_error(e, |p| format!("sensors.{p}")))?;

    // Run settings (the library checks the period ratios).
    let d = SimParams::paper();
    let sim = SimParams {
        duration: sc.run.duration,
        plant_step: sc.run.plant_step(),
        control_period: sc.run.control_period(),
        log_period: sc.run.log_period(),
        start: sc.run.start(),
        formulation: sc.run.formulation(),
        max_drift: sc.run.max_drift.unwrap_or(d.max_drift),
        min_sigma: sc.run.min_sigma.unwrap_or(d.min_sigma),
    };
    sim.validate().map_err(|e| src.model_error(e, run_path))?;
    if !(sc.metrics.transient.is_finite() && sc.metrics.transient >= 0.0) {
        return Err(src.error_at(
            "metrics.transient",
            format!(
                "metrics.transient = {}: must be finite and >= 0",
                sc.metrics.transient
            ),
        ));
    }

    // Controller.
    let c = &sc.controller;
    let admittance = c_admittance(&sc.admittance);
    let law = match c.kind {
        ControllerKind::Nn => Some(Law::Nn(sc.nn_gains())),
        ControllerKind::Pd => Some(Law::Pd(sc.pd_gains())),
        ControllerKind::Ctc => Some(Law::Ctc(sc.ctc_gains())),
        ControllerKind::Replay => None,
    };
    let controller = law.map(|law| ControllerParams {
        law,
        scheme: c.scheme,
        k_c: c.k_c,
        admittance,
        delta: c.delta,
        control_period: sc.run.control_period(),
        torque_limit: c.torque_limit,
        actuator: c.actuator.params(),
        disturbance_bound: c.disturbance_bound.unwrap_or(disturbance.bound()),
    });
    let replay = match (c.kind, &c.replay) {
        (ControllerKind::Replay, None) => {
            return Err(src.error_at(
                "controller",
                "controller.kind = \"replay\" needs a torque file: set controller.replay or pass --replay FILE",
            ));
        }
        (ControllerKind::Replay, Some(r)) => {
            let p = FsPath::new(r);
            Some(if p.is_absolute() {
                p.to_path_buf()
            } else {
                src.dir.join(p)
            })
        }
        _ => None,
    };
    // The true plant: the nominal one with the payload mismatch of [faults].
    let fc = &sc.faults;
    for (name, v) in [
        ("faults.payload_mass", fc.payload_mass),
        ("faults.payload_inertia", fc.payload_inertia),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(src.error_at(name, format!("{name} = {}: must be finite and > 0", num(v))));
        }
    }
    let payload = (fc.payload_mass, fc.payload_inertia);
    let truth = if payload != (1.0, 1.0) {
        let mut t = plant.clone();
        t.object = object(sc, src, payload)?;
        Some(t)
    } else {
        None
    };
    if let Some(t) = &truth {
        tandem::plant::planar::Plant::new(t).map_err(|e| {
            src.model_error(e, |p| format!("faults (true plant): {}", plant_path(p)))
        })?;
    }
    Ok(Built {
        plant,
        sensors,
        disturbance,
        sim,
        path,
        controller,
        replay,
        q_guess: need_guess.then_some(q_guess),
        truth,
    })
}

fn c_admittance(a: &AdmittanceConfig<2>) -> Option<AdmittanceParams> {
    let v = |p: super::tables::PerAxis<2>| Vector2::from(p.array());
    a.enabled.then(|| AdmittanceParams {
        m_e: v(a.m_e),
        c_e: v(a.c_e),
        k_e: v(a.k_e),
        tau_f: v(a.tau_f),
    })
}

fn build_path(p: &PathConfig, src: &Source) -> Result<Path, ScenarioError> {
    let kind = p.kind;
    p.check_fields(super::Kind::Planar, src)?;
    let v2 = |a: [f64; 2]| Vector2::new(a[0], a[1]);
    let v3 = Vector3::from;
    let r = match kind {
        PathKind::Circle => Path::circle(
            v2(p.center.unwrap_or_default()),
            p.radius.unwrap_or_default(),
            p.omega.unwrap_or_default(),
            p.phase.unwrap_or(0.0),
            p.theta.unwrap_or(0.0),
        ),
        PathKind::Lemniscate => Path::lemniscate(
            v2(p.center.unwrap_or_default()),
            p.size.unwrap_or_default(),
            p.omega.unwrap_or_default(),
            p.phase.unwrap_or(0.0),
            p.theta.unwrap_or(0.0),
        ),
        PathKind::PointToPoint => Path::point_to_point(
            v3(p.from.unwrap_or_default()),
            v3(p.to.unwrap_or_default()),
            p.t0.unwrap_or(0.0),
            p.duration.unwrap_or_default(),
        ),
        PathKind::Spline => {
            let w: Vec<(f64, Vector3<f64>)> = p
                .waypoints
                .as_deref()
                .unwrap_or_default()
                .iter()
                .map(|w| (w.t, v3(w.pose)))
                .collect();
            Path::spline(&w)
        }
    };
    r.map_err(|e| src.model_error(e, path_path))
}

/// The validated pieces of a run, ready to simulate.
pub struct Ready {
    /// The simulation (driver inside).
    pub sim: Simulation,
    /// Set-up warnings (e.g. the paper's first-order admittance).
    pub warnings: Vec<String>,
}

/// Build the controller of a scenario's law as [`make_simulation`] does (every check of
/// [`Controller::new`] with its file path, the start inside the output bounds), with its set-up
/// warnings appended to `warnings`. The controller is not started.
pub fn make_controller(
    sc: &PlanarScenario,
    b: &Built,
    cp: &ControllerParams,
    src: &Source,
    warnings: &mut Vec<String>,
) -> Result<Controller, ScenarioError> {
    let (c, w) = Controller::new(cp, &b.plant, b.path.clone(), b.sim.duration)
        .map_err(|e| src.model_error(e, controller_path(sc.controller.kind)))?;
    let map = controller_path(sc.controller.kind);
    warnings.extend(w.iter().map(|w| control_warning(src, w, &map)));
    // The start must be inside the output bounds the controller keeps (iBLF: |x_1j| < k_cj).
    if sc.controller.kind != ControllerKind::Replay {
        let unit = ["m", "m", "rad"];
        for j in 0..3 {
            let (x, k) = (sc.run.start()[j], sc.controller.k_c[j]);
            if k > 0.0 && !(x.abs() < k) {
                return Err(src.error_at(
                    &format!("run.start[{j}]"),
                    format!(
                        "run.start[{j}] = {} {} is outside the output bound |x_{j}| < controller.k_c[{j}] = {} {}: the run would start in violation",
                        num(x),
                        unit[j],
                        num(k),
                        unit[j]
                    ),
                ));
            }
        }
    }
    Ok(c)
}

/// Build the driver (controller or replay) and the simulation: every library validation.
pub fn make_simulation(
    sc: &PlanarScenario,
    b: &Built,
    src: &Source,
) -> Result<Ready, ScenarioError> {
    let mut warnings = Vec::new();
    let driver = match &b.controller {
        Some(cp) => {
            let c = make_controller(sc, b, cp, src, &mut warnings)?;
            Driver::Controller(Box::new(c))
        }
        None => {
            let file = b.replay.as_deref().unwrap_or(FsPath::new(""));
            let n_q: usize = b.plant.arms.iter().map(|a| a.links.len()).sum();
            let mode = sc.controller.replay_interpolation;
            let columns = sc.controller.replay_columns.as_deref();
            let replay = load_replay(src, file, n_q, &b.sim, mode, columns)?;
            Driver::Replay(replay)
        }
    };
    let sim = simulation_of(sc, b, src, driver, &mut warnings)?;
    Ok(Ready { sim, warnings })
}

/// The simulation of `driver` on the scenario's plant, sensors, disturbance, injected faults
/// and timing (what [`make_simulation`] builds around the scenario's own driver; a user's law,
/// [`tandem::sim::External`], or torques from outside, [`tandem::sim::Held`]), with the
/// set-up warnings of the start appended to `warnings`.
pub fn simulation_of<D: Drive<Plant>>(
    sc: &PlanarScenario,
    b: &Built,
    src: &Source,
    driver: D,
    warnings: &mut Vec<String>,
) -> Result<Simulation<Plant, D>, ScenarioError> {
    let sim = Simulation::new(
        b.truth.as_ref().unwrap_or(&b.plant),
        &b.sensors,
        driver,
        b.disturbance.clone(),
        b.sim.clone(),
        b.q_guess.as_deref(),
    )
    .map_err(|e| {
        // What remains to check here is the start pose (reach, singularity) and the formulation.
        let [x, y, th] = b.sim.start.map(num);
        let text = e.to_string();
        match &e {
            ModelError::Invalid { param, .. } if param == "start" => src.error_at(
                "run.start",
                format!(
                    "run.start = ({x}, {y}, {th}): {}",
                    text.trim_start_matches("start = ")
                ),
            ),
            ModelError::Geometry { what, .. } if what.starts_with("arms") => src.error_at(
                "run.start",
                format!("run.start = ({x}, {y}, {th}) cannot be reached: {text}"),
            ),
            _ => src.model_error(e, |p| {
                if p.starts_with("arms") {
                    p.to_string()
                } else if p == "gravity" {
                    "plant.gravity".into()
                } else if p.starts_with("encoder") || p.starts_with("force") {
                    format!("sensors.{p}")
                } else {
                    run_path(p)
                }
            }),
        }
    })?;
    let sim = sim
        .with_faults(&sc.faults.injection(sc.run.seed))
        .map_err(|e| src.model_error(e, |p| p.to_string()))?;
    warnings.extend(plausibility(src, &b.plant));
    // A start far from the path's first pose means a large initial error: every law answers it
    // with a large transient wrench (SPEC §4 starts 1 cm off).
    let x0 = b.path.sample(0.0).p;
    let gap = ((b.sim.start[0] - x0.x).powi(2) + (b.sim.start[1] - x0.y).powi(2)).sqrt();
    if gap > 0.02 {
        warnings.push(src.warning_at(
            "run.start",
            &format!(
                "({:.3}, {:.3}) is {:.0} mm from the path's start ({:.3}, {:.3}): expect a large initial error and wrench",
                b.sim.start[0], b.sim.start[1], 1e3 * gap, x0.x, x0.y
            ),
        ));
    }
    Ok(sim)
}

/// What validation warns about in a planar set-up (issue 22, "warn about the implausible"; the
/// spatial loader's twin): a grasp point more than [`GRASP_SURFACE_TOL`] off the outline of the
/// box (`object.size`, length × height), with the distance in or out, and two arms whose bases
/// are less than [`BASE_SEPARATION_MIN`] apart (planar arms share one plane: they would overlap).
fn plausibility(src: &Source, p: &PlantParams) -> Vec<String> {
    let mut out = Vec::new();
    let [l, h] = p.object.size;
    let half = [0.5 * l, 0.5 * h];
    for (i, r) in p.grasps.iter().enumerate() {
        let ex = [r[0].abs() - half[0], r[1].abs() - half[1]];
        let outside = ex[0].max(0.0).hypot(ex[1].max(0.0));
        let (dist, side) = if outside > 0.0 {
            (outside, "outside")
        } else {
            (-ex[0].max(ex[1]), "inside")
        };
        if dist > GRASP_SURFACE_TOL {
            let at = format!("arms[{i}].grasp");
            out.push(src.warning_at(
                &at,
                &format!(
                    "{at} = ({}, {}): the grasp point sits {} m {side} the box ({} × {} m, object.size), off its outline: the arm would hold the object where it has no surface; check {at} and object.size",
                    num(r[0]),
                    num(r[1]),
                    num_short(dist),
                    num_short(l),
                    num_short(h)
                ),
            ));
        }
    }
    let bases: Vec<[f64; 3]> = p.arms.iter().map(|a| [a.base[0], a.base[1], 0.0]).collect();
    out.extend(super::base_overlaps(
        src,
        &bases,
        " (planar arms move in one plane)",
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limited_reads_fail_past_their_limit_never_cut_short() {
        use std::io::Read;
        let d = std::env::temp_dir().join(format!("tandem-limited-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("mkdir");
        let f = d.join("x.csv");
        std::fs::write(&f, "0123456789abcdefghij").expect("write");
        let mut s = String::new();
        let e = open_limited(&f, 10)
            .expect("open")
            .read_to_string(&mut s)
            .expect_err("past the limit");
        assert!(e.to_string().contains("larger than 10 bytes"), "{e}");
        s.clear();
        open_limited(&f, 20)
            .expect("open")
            .read_to_string(&mut s)
            .expect("at the limit");
        assert_eq!(s, "0123456789abcdefghij");
        // Not a regular file: refused at open, naming the type.
        assert_eq!(
            open_regular(&d).map(|_| ()),
            Err("it is a folder, not a file".to_string())
        );
        assert!(
            read_limited(FsPath::new("/dev/zero"), 1 << 20)
                .expect_err("a device")
                .contains("character device")
        );
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn read_limited_drops_a_byte_order_mark_and_counts_offsets_in_the_file() {
        let d = std::env::temp_dir().join(format!("tandem-read-limited-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch folder");
        let f = d.join("bom.toml");
        std::fs::write(&f, "\u{feff}name = \"x\"\n").expect("write");
        assert_eq!(read_limited(&f, 1 << 20).as_deref(), Ok("name = \"x\"\n"));
        // Without a mark nothing is dropped (a mark inside the text stays).
        std::fs::write(&f, "a\u{feff}").expect("write");
        assert_eq!(read_limited(&f, 1 << 20).as_deref(), Ok("a\u{feff}"));
        // A bad byte's offset is the file's, the mark counted.
        std::fs::write(&f, b"\xef\xbb\xbfab\xff").expect("write");
        let e = read_limited(&f, 1 << 20).expect_err("not UTF-8");
        assert!(e.contains("offset 5"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    /// A bad `TANDEM_KERNEL` reaching a scenario's build (the library path the Python package
    /// takes) names the environment variable, not a field or a line of the file.
    #[test]
    fn a_kernel_error_names_the_environment_variable_not_a_field() {
        let src = embedded_source(&EMBEDDED[0]);
        let e = tandem::control::rbf::Kernel::parse("sse9").expect_err("unknown kernel");
        let msg = src
            .model_error(e, |p| format!("controller.{p}"))
            .to_string();
        assert!(
            msg.contains("environment variable TANDEM_KERNEL: unknown kernel `sse9`")
                && !msg.contains("controller.")
                && !msg.contains("line ")
                && !msg.contains("not set in the file"),
            "{msg}"
        );
    }

    #[test]
    fn every_embedded_scenario_parses_and_builds() {
        for e in embedded(Kind::Planar) {
            let src = embedded_source(e);
            let sc = parse(&src).unwrap_or_else(|e| panic!("{e}"));
            build(&sc, &src).unwrap_or_else(|e| panic!("{e}"));
        }
    }

    #[test]
    fn segments_split_indices() {
        let s = segments("arms[0].links[1].mass");
        assert_eq!(
            s,
            vec![
                Ok("arms".into()),
                Err(0),
                Ok("links".into()),
                Err(1),
                Ok("mass".into())
            ]
        );
    }

    #[test]
    fn span_finds_nested_values() {
        let text = "[[arms]]\nbase = [1.0, 2.0]\n[[arms.links]]\nmass = 1.0\n[[arms.links]]\nmass = -2.0\n";
        let (s, exact) = span_of(text, "arms[0].links[1].mass").expect("found");
        assert!(exact);
        assert_eq!(&text[s], "-2.0");
        let (s, exact) = span_of(text, "arms[0].base[1]").expect("found");
        assert!(exact);
        assert_eq!(&text[s], "2.0");
        let (_, exact) = span_of(text, "arms[0].links[1].inertia").expect("parent");
        assert!(!exact);
    }

    #[test]
    fn plant_paths_map_grasps() {
        assert_eq!(plant_path("grasps[1][0]"), "arms[1].grasp[0]");
        assert_eq!(plant_path("arms[0].links[1].mass"), "arms[0].links[1].mass");
        assert_eq!(path_path("circle.radius"), "path.radius");
        assert_eq!(path_path("spline.waypoints[2].t"), "path.waypoints[2].t");
        let c = controller_path(ControllerKind::Nn);
        assert_eq!(c("gains.k2[1]"), "controller.nn.k2[1]");
        assert_eq!(c("gains.k_c[1]"), "controller.k_c[1]");
        assert_eq!(c("delta"), "controller.delta");
        assert_eq!(c("admittance.m_e[0]"), "admittance.m_e[0]");
    }
}
