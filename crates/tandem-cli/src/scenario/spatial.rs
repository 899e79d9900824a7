//! Spatial scenario files (SPEC-spatial; issue 9): URDF arms, an SE(3) path and the spatial
//! controller, in the TOML style of the planar files.
//!
//! A scenario file is **spatial** when its arms name a robot model: `model = "ur5"` /
//! `"franka"` (embedded) or `urdf = "path.urdf"` (a file, relative to the scenario file). Planar
//! files, whose arms are given by their links, are read as before.
//!
//! | table | maps to |
//! |---|---|
//! | `[[arms]]` | URDF chain (`model` or `urdf`, `base_link`, `tool_link`), base placement `X_WB`, grasp frame `X_OG`, IK start `q_guess` |
//! | `[object]` | box `size`, `mass` (uniform-box inertia unless `inertia` is given), `damping` |
//! | `[plant]` | gravity, Baumgarte, optional compliant grasps |
//! | `[path]` | [`Se3Path`] (`kind` = circle, point_to_point, spline) |
//! | `[controller]` (+ `.nn`, `.pd`, `.ctc`, `.posture`) | [`SpatialControllerParams`] or a torque replay |
//! | `[admittance]` | [`AdmittanceSe3Params`] |
//! | `[sensors]`, `[disturbance]` | [`SensorParams`], [`SpatialDisturbance`] |
//! | `[run]` | [`SimParams`], the start offset from the path, the seed |
//! | `[metrics]` | the transient window of the summary |
//!
//! Orientations are given as one of `rpy = [roll, pitch, yaw]` (URDF's fixed-axis x–y–z
//! convention, rad), `quaternion = [w, x, y, z]` (unit) or `axes = [x, y, z]` (the frame's axes
//! as columns in the parent's axes; orthonormal, right-handed). Every library error is mapped
//! back to the file's field path, line and column; URDF errors also carry the URDF's own line.

use std::path::{Path as FsPath, PathBuf};

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};
use tandem::ModelError;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::SpatialController;
use tandem::control::spatial::chart::Chart;
use tandem::control::spatial::distribute::friction::FrictionStats;
use tandem::control::spatial::params::{SPATIAL_D1, SPATIAL_D2};
use tandem::control::spatial::{PostureParams, SpatialControllerParams};
use tandem::control::{ControlWarning, Scheme};
use tandem::drive::Drive;
use tandem::model::disturbance::SpatialDisturbance;
use tandem::model::spatial::SpatialArm;
use tandem::model::spatial::SpatialObjectParams;
use tandem::model::spatial::urdf;
use tandem::plant::spatial::{ContactLog, SpatialPlant};
use tandem::plant::spatial::{GraspModel, SpatialPlantParams};
use tandem::reference::spatial::admittance::AdmittanceSe3Params;
use tandem::reference::spatial::path::{AxisFrame, CircleParams, Se3Path, Se3Waypoint};
use tandem::sim::sensors::SensorParams;
use tandem::sim::{External, Formulation, Outcome, Replay, SimParams, Simulation, SpatialStart};

use super::planar::{control_warning, load_replay};
use super::source::{MAX_ARMS, MAX_LINKS, ScenarioError, Source, num, num_short, read_limited};
use super::tables::{
    ActuatorConfig, AdmittanceConfig, AxisFrameConfig, ControllerKind, CtcConfig,
    DisturbanceConfig, MetricsConfig, NnConfig, Orientation, PathKind, PdConfig, PlantConfig,
    RunConfig, SensorsConfig,
};

// ---------------------------------------------------------------------------------------------
// The file's structs.

/// A spatial scenario file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialScenario {
    /// Scenario name (outputs, titles); defaults to the file's stem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Free text.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// The arms, in order (arm 1 first); joint order is arm 1's joints base to tool, then arm 2…
    pub arms: Vec<ArmConfig>,
    /// The carried object.
    pub object: ObjectConfig,
    /// Gravity, drift control, grasp model.
    #[serde(default)]
    pub plant: PlantConfig<[f64; 3]>,
    /// The desired object pose over time.
    pub path: PathConfig,
    /// Environment wrench on the object (default: none).
    #[serde(default)]
    pub disturbance: DisturbanceConfig<6>,
    /// Sensor imperfections (default: ideal).
    #[serde(default)]
    pub sensors: SensorsConfig,
    /// The law and its settings (or a torque replay).
    pub controller: ControllerConfig,
    /// The per-arm 6-D admittance generator (default: on, SPEC §3.1 values).
    #[serde(default)]
    pub admittance: AdmittanceConfig<6>,
    /// Timing, start, seed.
    pub run: RunConfig,
    /// Summary metrics.
    #[serde(default = "spatial_metrics")]
    pub metrics: MetricsConfig,
}

fn spatial_metrics() -> MetricsConfig {
    MetricsConfig::spatial()
}

/// An embedded robot model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RobotModel {
    /// `models/ur5.urdf` (UR5-class, 6 DOF): `base_link` → `tool0`.
    Ur5,
    /// `models/franka.urdf` (Franka-class, 7 DOF): `panda_link0` → `panda_link8`.
    Franka,
}

impl RobotModel {
    /// The embedded URDF text.
    pub fn text(self) -> &'static str {
        match self {
            RobotModel::Ur5 => urdf::UR5_URDF,
            RobotModel::Franka => urdf::FRANKA_URDF,
        }
    }
    /// The embedded model's base link.
    pub fn base(self) -> &'static str {
        match self {
            RobotModel::Ur5 => urdf::UR5_BASE,
            RobotModel::Franka => urdf::FRANKA_BASE,
        }
    }
    /// The embedded model's tool link.
    pub fn tool(self) -> &'static str {
        match self {
            RobotModel::Ur5 => urdf::UR5_TOOL,
            RobotModel::Franka => urdf::FRANKA_TOOL,
        }
    }
    /// The maker's published joint torque-rate limit, N m/s: Franka's 1000
    /// ([`urdf::FRANKA_TORQUE_RATE_LIMIT`]); none published for the UR5.
    pub fn rate_limit(self) -> Option<f64> {
        match self {
            RobotModel::Ur5 => None,
            RobotModel::Franka => Some(urdf::FRANKA_TORQUE_RATE_LIMIT),
        }
    }
}

/// The actuator stage's parameters from `[controller.actuator]`, with the embedded robots'
/// published torque-rate limit as the default `rate_limit` when the table gives none (the
/// strictest over the arms: the stage has one rate limit for every joint); `rate_limit = inf`
/// turns it off.
fn actuator_params(
    arms: &[ArmConfig],
    a: &ActuatorConfig,
) -> tandem::control::actuator::ActuatorParams {
    let mut p = a.params();
    if a.rate_limit.is_none() {
        p.rate_limit = arms
            .iter()
            .filter_map(|arm| arm.model.and_then(RobotModel::rate_limit))
            .reduce(f64::min);
    }
    p
}

/// One arm.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmConfig {
    /// An embedded model (`ur5`, `franka`); exactly one of `model` and `urdf`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<RobotModel>,
    /// A URDF file, relative to the scenario file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub urdf: Option<String>,
    /// The chain's base link (default: the embedded model's; required with `urdf`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_link: Option<String>,
    /// The tool link, whose frame is welded to the grasp frame (default: the embedded model's;
    /// required with `urdf`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_link: Option<String>,
    /// Base placement `X_WB` in the world (default: the origin).
    #[serde(default)]
    pub base: Placement,
    /// Grasp frame `X_OG` in the object frame (the tool frame is welded to it).
    pub grasp: Placement,
    /// Joint angles (rad) from which inverse kinematics starts: picks the branch (elbow up,
    /// wrist…). Default: the middle of each joint's limits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_guess: Option<Vec<f64>>,
}

/// A pose: position plus at most one orientation form (none = identity).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    /// Position, m.
    #[serde(default)]
    pub position: [f64; 3],
    /// Roll, pitch, yaw (URDF: `R = R_z(yaw) R_y(pitch) R_x(roll)`), rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rpy: Option<[f64; 3]>,
    /// Unit quaternion `[w, x, y, z]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion: Option<[f64; 4]>,
    /// The frame's x, y and z axes, each in the parent's axes (the rotation matrix's columns).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<[[f64; 3]; 3]>,
}

/// The object: a box (drawn, and its inertia unless `inertia` is given).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectConfig {
    /// Edge lengths along the object's x, y, z axes, m.
    pub size: [f64; 3],
    /// Mass, kg.
    pub mass: f64,
    /// Rotational inertia about the centre of mass, body axes, rows, kg m² (default: the
    /// uniform box `m/12 diag(b² + c², a² + c², a² + b²)`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertia: Option<[[f64; 3]; 3]>,
    /// Viscous damping on `[v; ω]`, (N s/m ×3, N m s/rad ×3).
    #[serde(default)]
    pub damping: [f64; 6],
}

/// The spatial path table: centres `[x, y, z]`, poses [`Placement`]s, [`WaypointConfig`]s.
pub type PathConfig = super::tables::PathConfig<[f64; 3], Placement, WaypointConfig>;

/// A timed pose of a spline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointConfig {
    /// Time, s.
    pub t: f64,
    /// Position, m.
    pub position: [f64; 3],
    /// Roll, pitch, yaw, rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rpy: Option<[f64; 3]>,
    /// Unit quaternion `[w, x, y, z]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion: Option<[f64; 4]>,
    /// Axes as columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<[[f64; 3]; 3]>,
}

/// `object` or `per_arm`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SchemeConfig {
    /// The law acts on the object; the wrench is distributed (all laws).
    #[default]
    Object,
    /// Each arm tracks its own reference tool pose (PD only).
    PerArm,
}

/// The controller.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerConfig {
    /// `nn`, `pd`, `ctc` or `replay`.
    pub kind: ControllerKind,
    /// `object` (default) or `per_arm`.
    #[serde(default)]
    pub scheme: SchemeConfig,
    /// Output bounds `|x_1j| < k_cj` on `(p − c, φ)`, (m ×3, rad ×3); `k_c,rot < π`.
    pub k_c: [f64; 6],
    /// Chart centre `c`, m (default: the circle's centre, or the centre of the desired
    /// positions' bounding box).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre: Option<[f64; 3]>,
    /// Chart reference orientation `R_ref` (default: the desired orientation at t = 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_ref: Option<Orientation>,
    /// Internal squeeze along the grasp map's null space, N.
    #[serde(default = "default_squeeze")]
    pub squeeze: f64,
    /// Length that makes forces and torques commensurate in the wrench share, m.
    #[serde(default = "default_metric_length")]
    pub metric_length: f64,
    /// Joint torque limit, every joint, N m (default: each joint's URDF effort limit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque_limit: Option<f64>,
    /// The actuator stage: effort, rate limit, output filter (default: off; the effort limits
    /// are `torque_limit` or the URDF's unless given).
    #[serde(default, skip_serializing_if = "ActuatorConfig::is_off")]
    pub actuator: ActuatorConfig,
    /// Known bound of the environment wrench in chart coordinates (enters `f^U`).
    #[serde(default)]
    pub disturbance_bound: [f64; 6],
    /// NN gains.
    #[serde(default)]
    pub nn: NnConfig<6>,
    /// PD gains.
    #[serde(default)]
    pub pd: PdConfig<6>,
    /// Computed-torque gains.
    #[serde(default)]
    pub ctc: CtcConfig<6>,
    /// The null-space posture task of redundant arms.
    #[serde(default)]
    pub posture: PostureConfig,
    /// The torque file of `kind = "replay"`, relative to the scenario file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay: Option<String>,
    /// `hold` (default) or `linear` between the replayed rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay_interpolation: Option<crate::scenario::replay::Interpolation>,
    /// Column map of a replayed log from another tool (as planar: the time column, then one
    /// torque column per joint).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay_columns: Option<Vec<String>>,
    /// The load distribution: `weld` (the minimum-norm share, as if the grasps were welds; the
    /// default) or `friction` (contact grasps: the nearest share that keeps every pad inside its
    /// friction cone by `friction_margin`, docs/friction-grasps.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distribution: Option<DistributionConfig>,
    /// How far inside its cone the friction-aware distribution keeps each pad, N of normal
    /// force (default 2 N).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_margin: Option<f64>,
}

/// `controller.distribution`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DistributionConfig {
    /// The minimum-norm share, as if the grasps were welds.
    Weld,
    /// The friction-aware share (contact grasps).
    Friction,
}

/// Default `controller.friction_margin`, N.
pub const DEFAULT_FRICTION_MARGIN: f64 = 2.0;

fn default_squeeze() -> f64 {
    5.0
}
fn default_metric_length() -> f64 {
    0.2
}

/// The posture task of redundant arms (default `K_p = 20`, `K_d = 4`, rest = the start).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PostureConfig {
    /// Stiffness, N m/rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kp: Option<f64>,
    /// Damping, N m s/rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kd: Option<f64>,
    /// Rest posture, all joints stacked over the arms, rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_rest: Option<Vec<f64>>,
}

// ---------------------------------------------------------------------------------------------
// Parsing.

/// Parse a spatial scenario's text (syntax, fields, strict lengths, the name).
pub fn parse(src: &Source) -> Result<SpatialScenario, ScenarioError> {
    let mut sc: SpatialScenario = crate::scenario::parse_as(src)?;
    // What a spatial scenario always has (the shared tables leave them optional for planar):
    // the wrist torque channels and the PD law's gravity switch, written out in `scenario.toml`.
    sc.sensors.torque.get_or_insert_default();
    sc.controller.pd.gravity_compensation.get_or_insert(false);
    sc.controller.nn.design.get_or_insert_default();
    sc.run
        .complete(super::Kind::Spatial)
        .map_err(|(f, m)| src.error_at(&f, m))?;
    if let Some(n) = &sc.name {
        crate::scenario::check_name(src, n)?;
    }
    if sc.arms.len() > MAX_ARMS {
        return Err(src.error_at(
            "arms",
            format!("{} arms: at most {MAX_ARMS} are supported", sc.arms.len()),
        ));
    }
    Ok(sc)
}

// ---------------------------------------------------------------------------------------------
// Building.

/// A scenario turned into the library's parameter types (validated by the library when the
/// simulation is made).
#[derive(Clone, Debug)]
pub struct SpatialBuilt {
    /// The plant.
    pub plant: SpatialPlantParams,
    /// The desired path.
    pub path: Se3Path,
    /// The controller (for a replay: the PD law's, which gives the chart and the bounds the
    /// outputs are measured in).
    pub controller: SpatialControllerParams,
    /// The torque file of a replay.
    pub replay: Option<PathBuf>,
    /// Sensors (seeded with `run.seed`).
    pub sensors: SensorParams,
    /// Environment wrench.
    pub disturbance: SpatialDisturbance,
    /// Timing.
    pub sim: SimParams,
    /// Start pose and IK guess.
    pub start: SpatialStart,
    /// Box edge lengths, m (drawing).
    pub box_size: [f64; 3],
    /// URDF and set-up warnings, with their field paths.
    pub warnings: Vec<String>,
    /// Files read (the scenario's URDFs and replay): `--force` never replaces a folder that
    /// holds one.
    pub inputs: Vec<PathBuf>,
}

/// Largest URDF file read, bytes (published arm URDFs are 10–100 kB; meshes are not read).
pub const MAX_URDF_BYTES: u64 = 16 << 20;

fn resolve_file(src: &Source, p: &str) -> PathBuf {
    let path = FsPath::new(p);
    if path.is_absolute() {
        path.to_path_buf()
    } else {
        src.dir.join(path)
    }
}

/// The rotation of an orientation given in one of the three forms; `None` when none is given.
/// Errors: `(field path, reason)`.
fn rotation(
    at: &str,
    rpy: &Option<[f64; 3]>,
    quaternion: &Option<[f64; 4]>,
    axes: &Option<[[f64; 3]; 3]>,
) -> Result<Option<UnitQuaternion<f64>>, (String, String)> {
    let given = usize::from(rpy.is_some())
        + usize::from(quaternion.is_some())
        + usize::from(axes.is_some());
    let join = |f: &str| {
        if at.is_empty() {
            f.to_string()
        } else {
            format!("{at}.{f}")
        }
    };
    if given > 1 {
        return Err((
            join(if rpy.is_some() { "rpy" } else { "quaternion" }),
            "give one of `rpy`, `quaternion` and `axes`, not several".into(),
        ));
    }
    if let Some(r) = rpy {
        for (j, v) in r.iter().enumerate() {
            if !v.is_finite() {
                return Err((format!("{}[{j}]", join("rpy")), "must be finite".into()));
            }
        }
        return Ok(Some(UnitQuaternion::from_euler_angles(r[0], r[1], r[2])));
    }
    if let Some(q) = quaternion {
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        // A unit quaternion typed with 6+ digits (0.707107) is within 1e-6; anything further
        // off is a typo, not rounding.
        if !n.is_finite() || (n - 1.0).abs() > 1e-6 {
            return Err((
                join("quaternion"),
                format!(
                    "[w, x, y, z] must be a unit quaternion: its norm is {} (tolerance 1e-6)",
                    num(n)
                ),
            ));
        }
        return Ok(Some(UnitQuaternion::from_quaternion(
            nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]),
        )));
    }
    if let Some(a) = axes {
        // Each entry first: nalgebra's `max` passes over a NaN, so the orthonormality test
        // below would not see one.
        for (i, ax) in a.iter().enumerate() {
            if let Some(j) = ax.iter().position(|v| !v.is_finite()) {
                return Err((
                    format!("{}[{i}][{j}]", join("axes")),
                    "must be finite".into(),
                ));
            }
        }
        let m = Matrix3::from_columns(&[
            Vector3::from(a[0]),
            Vector3::from(a[1]),
            Vector3::from(a[2]),
        ]);
        let err = (m.transpose() * m - Matrix3::identity()).abs().max();
        if !err.is_finite() || err > 1e-6 {
            return Err((
                join("axes"),
                format!(
                    "the axes [x, y, z] must be orthonormal: |RᵀR − I| is {} (tolerance 1e-6)",
                    num(err)
                ),
            ));
        }
        if m.determinant() < 0.0 {
            return Err((
                join("axes"),
                "the axes [x, y, z] must be right-handed (x × y = z)".into(),
            ));
        }
        let r = Rotation3::from_matrix_unchecked(m);
        return Ok(Some(UnitQuaternion::from_rotation_matrix(&r)));
    }
    Ok(None)
}

fn placement(at: &str, p: &Placement) -> Result<Isometry3<f64>, (String, String)> {
    for (j, v) in p.position.iter().enumerate() {
        if !v.is_finite() {
            return Err((format!("{at}.position[{j}]"), "must be finite".into()));
        }
    }
    let r = rotation(at, &p.rpy, &p.quaternion, &p.axes)?.unwrap_or_else(UnitQuaternion::identity);
    Ok(Isometry3::from_parts(
        Translation3::from(Vector3::from(p.position)),
        r,
    ))
}

fn orientation(at: &str, o: &Orientation) -> Result<UnitQuaternion<f64>, (String, String)> {
    Ok(rotation(at, &o.rpy, &o.quaternion, &o.axes)?.unwrap_or_else(UnitQuaternion::identity))
}

/// Where a library parameter of the spatial set-up lives in the file (`k_c[3]` →
/// `controller.k_c[3]`, `grasps[1]` → `arms[1].grasp`, `q_guess[8]` → `arms[1].q_guess[2]`).
fn file_path(sc: &SpatialScenario, dofs: &[usize], param: &str) -> String {
    let law = sc.controller.kind.name();
    let (head, rest) = match param.find(['.', '[']) {
        Some(i) => (&param[..i], &param[i..]),
        None => (param, ""),
    };
    match head {
        "k_c" | "disturbance_bound" | "squeeze" | "metric_length" | "torque_limit" | "centre"
        | "scheme" | "posture" | "actuator" => format!("controller.{param}"),
        "gains" => format!("controller.{law}{rest}"),
        "control_period" | "duration" | "plant_step" | "log_period" | "max_drift" | "min_sigma" => {
            format!("run.{param}")
        }
        "gravity" | "baumgarte" => format!("plant.{param}"),
        // The library's grasp model is the file's `plant.compliant_grasps` or
        // `plant.contact_grasps` (whose pads and grip are the same on every arm:
        // `grasp_model.pads[i][j].radius` → `plant.contact_grasps.pads[j].radius`).
        "grasp_model" if sc.plant.contact_grasps.is_some() => {
            if let Some(r) = rest.strip_prefix(".pads[")
                && let Some((_, tail)) = r.split_once("][")
            {
                format!("plant.contact_grasps.pads[{tail}")
            } else if rest.starts_with(".pads[") {
                // `grasp_model.pads[i]` (arm i's list, e.g. empty): the file's one list.
                "plant.contact_grasps.pads".into()
            } else if rest.starts_with(".grip[") {
                "plant.contact_grasps.grip".into()
            } else if rest.starts_with(".half_extents") {
                "object.size".into()
            } else {
                format!("plant.contact_grasps{rest}")
            }
        }
        "grasp_model" => format!("plant.compliant_grasps{rest}"),
        "grasps" => {
            // `grasps[i]...` → `arms[i].grasp...`
            match rest.strip_prefix('[').and_then(|r| r.split_once(']')) {
                Some((i, tail)) => format!("arms[{i}].grasp{tail}"),
                None => "arms".into(),
            }
        }
        "q_guess" => {
            let k: Option<usize> = rest
                .strip_prefix('[')
                .and_then(|r| r.split_once(']'))
                .and_then(|(i, _)| i.parse().ok());
            match k {
                Some(mut k) => {
                    for (i, n) in dofs.iter().enumerate() {
                        if k < *n {
                            return format!("arms[{i}].q_guess[{k}]");
                        }
                        k -= n;
                    }
                    "arms".into()
                }
                None => "arms".into(),
            }
        }
        "arms" | "object" | "path" | "admittance" | "run" | "controller" | "plant" => {
            // `arms[i].joint NAME` → `arms[i].q_guess` (a joint past its limit at the start).
            if let Some(i) = param.find(".joint ") {
                return format!("{}.q_guess", &param[..i]);
            }
            param.to_string()
        }
        "encoder_q" | "encoder_qd" | "force" | "torque" => format!("sensors.{param}"),
        "frequency" | "phase" | "amplitude" | "pushes" | "disturbance" => {
            format!("disturbance.{}", param.trim_start_matches("disturbance."))
        }
        "m_e" | "c_e" | "k_e" | "tau_f" => format!("admittance.{param}"),
        "mass" | "inertia" | "damping" => format!("object.{param}"),
        _ => param.to_string(),
    }
}

/// Largest start guess taken for a joint without position limits (rad or m): beyond it a value
/// is a typo, not an angle or a stroke.
const MAX_GUESS: f64 = 1e3;

/// Why a start guess cannot be a pose of joint `j`, if it cannot: outside the limits (a
/// revolute joint's guess also after wrapping by whole turns), or beyond [`MAX_GUESS`] for a
/// joint without limits. Checked before the inverse kinematics, so that the guess is blamed,
/// not the base the solver then fails to reach from it.
fn guess_outside(j: &tandem::model::spatial::ChainJoint, v: f64) -> Option<String> {
    use std::f64::consts::TAU;
    use tandem::model::spatial::JointKind;
    let (lo, hi) = (j.limits.lower, j.limits.upper);
    let unit = match j.kind {
        JointKind::Revolute => "rad",
        JointKind::Prismatic => "m",
    };
    if v.abs() > MAX_GUESS {
        return Some(format!(
            "a start guess for joint `{}` beyond ±{MAX_GUESS} {unit} is not a pose of it",
            j.name
        ));
    }
    if !(lo.is_finite() && hi.is_finite()) || (lo - 1e-9..=hi + 1e-9).contains(&v) {
        return None;
    }
    if j.kind == JointKind::Revolute {
        let turns = ((lo - v) / TAU).ceil();
        if v + turns * TAU <= hi + 1e-9 {
            return None;
        }
    }
    let wrap = if j.kind == JointKind::Revolute {
        " (also after wrapping by whole turns)"
    } else {
        ""
    };
    Some(format!(
        "outside joint `{}`'s limits [{}, {}] {unit}{wrap}",
        j.name,
        sig3(lo),
        sig3(hi)
    ))
}

/// The fastest mode of compliant grasps `(|λ| rad/s, arm, tool link)`: the tool link (the
/// lightest body on the grasp spring, mass `m`, smallest principal inertia `I_min`) on each
/// axis's spring `(k, d)`: `|λ| = √(k/m)` while underdamped, and the fast root
/// `(d + √(d² − 4 m k)) / 2m` once overdamped (a heavily damped spring on a light wrist is a fast
/// real mode that an explicit step must resolve too). `damping = None`: the springs alone (the
/// oscillation the control loop sees).
pub fn grasp_fastest_mode(
    arms: &[SpatialArm],
    stiffness: &[f64; 6],
    damping: Option<&[f64; 6]>,
) -> Option<(f64, usize, String)> {
    let fastest = |k: f64, d: f64, m: f64| -> f64 {
        if !(m > 0.0) {
            return 0.0;
        }
        let disc = d * d - 4.0 * m * k;
        if disc > 0.0 {
            (d + disc.sqrt()) / (2.0 * m)
        } else {
            (k / m).sqrt()
        }
    };
    let mut worst: Option<(f64, usize, String)> = None;
    for (i, a) in arms.iter().enumerate() {
        let Some(b) = a.chain.bodies.last() else {
            continue;
        };
        let i_min = b.inertia.symmetric_eigenvalues().min();
        let mut w = 0.0f64;
        for j in 0..6 {
            let d = damping.map_or(0.0, |d| d[j]);
            let m = if j < 3 { b.mass } else { i_min };
            w = w.max(fastest(stiffness[j], d, m));
        }
        if w.is_finite() && worst.as_ref().is_none_or(|x| w > x.0) {
            worst = Some((w, i, b.name.clone()));
        }
    }
    worst
}

/// The lightest body on a grasp spring over the arms: the smallest tool-link mass and the
/// smallest principal inertia of a tool link, (kg, kg m²); `None` without arms or with a
/// massless tool link. The critical damping of a grasp spring `(k, k_rot)` against it is
/// `(2√(k m), 2√(k_rot I))`.
pub fn grasp_tip(arms: &[SpatialArm]) -> Option<(f64, f64)> {
    let mut tip: Option<(f64, f64)> = None;
    for b in arms.iter().filter_map(|a| a.chain.bodies.last()) {
        let i_min = b.inertia.symmetric_eigenvalues().min();
        if !(b.mass > 0.0 && i_min > 0.0) {
            return None;
        }
        tip = Some(tip.map_or((b.mass, i_min), |(m, i)| (m.min(b.mass), i.min(i_min))));
    }
    tip
}

/// The output filter's time constant the compliant-grasp warning names, in control periods
/// (`grasp_filter_check`).
pub const GRASP_FILTER_PERIODS: f64 = 20.0;

/// Compliant grasps whose fastest mode the control loop cannot resolve (`ω T_c > 1`) and no
/// output filter: a law that assumes welds feeds the tool link's spring mode back tick to tick,
/// a period-2 oscillation through the light wrist (measured: dual-UR5, PD + gravity, 1e5 N/m and
/// 1e3 N m/rad, `ω T_c` = 3.2: 3800 chattering ticks, effort-clipped wrists from 12 ms, the box
/// rolled 2 rad by 3.81 s). The actuator stage's first-order filter at [`GRASP_FILTER_PERIODS`]
/// control periods attenuates that mode ~63× at the loop's Nyquist frequency: on dual-UR5 every
/// default law then held every grasp of the robustness sweep (1e4–1e6 N/m, 0.3–3 times
/// critical damping) with S5 met; at 5 periods (~16×) PD + gravity still lost the lightly
/// damped grasps (`docs/robot-ready.md`).
fn grasp_filter_check(
    arms: &[SpatialArm],
    c: &super::tables::ComplianceConfig,
    control_period: f64,
    filter: Option<f64>,
) -> Option<String> {
    if filter.is_some()
        || !(c.stiffness.iter().all(|k| k.is_finite() && *k > 0.0)
            && control_period.is_finite()
            && control_period > 0.0)
    {
        return None;
    }
    let (w, i, link) = grasp_fastest_mode(arms, &c.stiffness, None)?;
    let wt = w * control_period;
    (wt > 1.0).then(|| {
        format!(
            "plant.compliant_grasps: the grasps' fastest mode, arms[{i}]'s tool link `{link}` on \
             the grasp spring (ω = {} rad/s), is faster than the control loop resolves (ω × \
             run.control_period = {} > 1); the law assumes welds and can chatter through it (dual-UR5, \
             PD + gravity at 1e5 N/m and 1e3 N m/rad: 3800 chattering ticks and the box rolled \
             off by 3.81 s); set [controller.actuator] filter_time_constant = {} ({} control \
             periods: on dual-UR5 every default law then held every grasp from 1e4 to 1e6 N/m \
             and 0.3 to 3 times critical damping, S5 met)",
            sig3(w),
            sig3(wt),
            sig3(GRASP_FILTER_PERIODS * control_period),
            GRASP_FILTER_PERIODS
        )
    })
}

/// Largest `K2_j T_c / I_j` of the NN law's rotational damping before the `validate` warning
/// (`nn_damping_check`): measured on `dual-franka` (compliant grasps, no filter), `K2_ry` at
/// 0.75 of `I_ry / T_c` (with `K2_rx` capped alike) held every grasp of the sweep with at most 21
/// chattering ticks, all in the first 40 ms; at 1.0 it chattered on 3 895 of 4 000 ticks
/// (`docs/robot-ready.md`).
pub const NN_ROT_DAMPING_RATIO: f64 = 0.75;

/// The NN law's damping on the box's rotations against compliant grasps (issue 24): `K2` is
/// designed on the box-plus-arms inertia (`K2 = 2ζ M ω_n`), but through a grasp spring the
/// sampled damping acts tick by tick on what sits on the springs' arm side: about chart axis
/// `e_j`, the tool links' `I_j = Σ_i (I_tip,i + m_tip,i |e_j × r_i|²)` (`r_i` the grasp in the
/// object frame, `I_tip` the tool link's smallest principal inertia). Where `K2_j T_c / I_j`
/// exceeds [`NN_ROT_DAMPING_RATIO`] (measured: `dual-franka`, `ry`, 1.57), the law chattered on
/// nearly every tick (3 800–3 980 of 4 000 at 1e4–1e6 N/m, damping below critical), and the
/// `K2_j` at that ratio removed it at no cost on welds (`z1` within 0.03 %). Warned for an NN
/// run on compliant grasps without an output filter, without the file's own `k2`, and with the
/// tool link's spring mode resolved by the loop (else [`grasp_filter_check`]'s warning names
/// the filter, which cures this too).
fn nn_damping_check(sc: &SpatialScenario, b: &SpatialBuilt, g: &NnGains<6>) -> Option<String> {
    let c = sc.plant.compliant_grasps.as_ref()?;
    let t_c = sc.run.control_period();
    if sc.controller.actuator.filter_time_constant.is_some()
        || sc.controller.nn.k2.is_some()
        || !(t_c.is_finite() && t_c > 0.0)
    {
        return None;
    }
    let arms = &b.plant.arms;
    if grasp_fastest_mode(arms, &c.stiffness, None).is_none_or(|m| m.0 * t_c > 1.0) {
        return None;
    }
    let mut inertia = [0.0f64; 3];
    for (a, x) in arms.iter().zip(&b.plant.grasps) {
        let body = a.chain.bodies.last()?;
        let i_tip = body.inertia.symmetric_eigenvalues().min();
        let r = x.translation.vector;
        for (j, ij) in inertia.iter_mut().enumerate() {
            let e = Vector3::ith(j, 1.0);
            *ij += i_tip + body.mass * e.cross(&r).norm_squared();
        }
    }
    let mut k2 = g.k2;
    let mut worst: Option<(usize, f64)> = None;
    for j in 0..3 {
        let ratio = g.k2[3 + j] * t_c / inertia[j];
        if ratio.is_finite() && ratio > NN_ROT_DAMPING_RATIO {
            k2[3 + j] = NN_ROT_DAMPING_RATIO * inertia[j] / t_c;
            if worst.is_none_or(|w| ratio > w.1) {
                worst = Some((j, ratio));
            }
        }
    }
    let (j, ratio) = worst?;
    let axis = ["rx", "ry", "rz"][j];
    let list = k2.iter().map(|v| sig3(*v)).collect::<Vec<_>>().join(", ");
    Some(format!(
        "controller.nn: on compliant grasps the NN law's damping on the box's rotation {axis} \
         (K2 = {} N m s/rad, designed on the box and arms) acts tick by tick on the tool links on \
         the grasp springs ({} kg m² about {axis}): K2 × run.control_period / I = {} > {}, where \
         the law chattered on nearly every tick (dual-franka, 1e4 to 1e6 N/m: 3800 to 3980 of \
         4000 ticks); set [controller.nn] k2 = [{list}] (the design's, its rotational entries \
         capped at {} I / control_period; measured on dual-franka over 1e4 to 1e6 N/m and 0.3 to 3 \
         times critical damping: every grasp held with S5 met, at most 21 chattering ticks, all \
         in the first 40 ms; no change on welds), or an output filter",
        sig3(g.k2[3 + j]),
        sig3(inertia[j]),
        sig3(ratio),
        NN_ROT_DAMPING_RATIO,
        NN_ROT_DAMPING_RATIO
    ))
}

/// The plant step against the fastest mode of a compliant grasp: the tool link (the lightest
/// body on the grasp spring) on each axis's spring and damper ([`grasp_fastest_mode`]: `ω =
/// √(k/m)` while underdamped, the fast real root `(d + √(d² − 4mk))/2m` once overdamped; `m` the
/// tool link's mass or smallest principal inertia). RK4 is unstable beyond `h ω = 2√2 ≈ 2.83`
/// on an undamped oscillator and beyond `h |λ| ≈ 2.78` on a real root: a longer step is refused
/// by `run.plant_step` (the run would only fault: 2 N m s/rad on a UR5 wrist at 0.25 ms went
/// non-finite at 5 ms); above `h |λ| = 1` the mode is resolved poorly, a warning (`tandem
/// robustness` steps its grasp runs at `h |λ| ≤ 1`).
fn grasp_step_check(
    src: &Source,
    arms: &[SpatialArm],
    c: &super::tables::ComplianceConfig,
    h: f64,
) -> Result<Vec<String>, ScenarioError> {
    // A stiffness that is not a positive number is the library's to refuse, by its field.
    if !(c.stiffness.iter().all(|k| k.is_finite() && *k > 0.0) && h.is_finite() && h > 0.0) {
        return Ok(Vec::new());
    }
    let Some((w, i, link)) = grasp_fastest_mode(arms, &c.stiffness, Some(&c.damping)) else {
        return Ok(Vec::new());
    };
    let hw = h * w;
    // Overdamped on some axis: the fastest root is real, set by the damping.
    let undamped = grasp_fastest_mode(arms, &c.stiffness, None).map_or(0.0, |m| m.0);
    let what = if w > undamped * (1.0 + 1e-9) {
        format!(
            "the compliant grasps' fastest mode (arms[{i}]'s tool link `{link}` on the grasp \
             spring, overdamped: its fast root |λ| = {} 1/s, from plant.compliant_grasps.damping \
             and stiffness)",
            sig3(w)
        )
    } else {
        format!(
            "the compliant grasps' fastest mode (arms[{i}]'s tool link `{link}` on the grasp \
             spring, ω = {} rad/s, from plant.compliant_grasps.stiffness)",
            sig3(w)
        )
    };
    // RK4's stability region reaches 2.83 along the imaginary axis, 2.78 along the real one.
    let limit = if w > undamped * (1.0 + 1e-9) {
        2.78
    } else {
        2.0 * std::f64::consts::SQRT_2
    };
    if hw > limit {
        return Err(src.error_at(
            "run.plant_step",
            format!(
                "run.plant_step = {} s is too long for {what}: RK4 is unstable beyond h |λ| = {} \
                 (here {}); use plant_step ≤ {} s (h |λ| ≤ 1), or softer or less damped grasps",
                sig3(h),
                sig3(limit),
                sig3(hw),
                sig3(1.0 / w)
            ),
        ));
    }
    Ok(if hw > 1.0 {
        vec![format!(
            "run.plant_step = {} s resolves {what} poorly (h |λ| = {}); plant_step ≤ {} s \
             (h |λ| ≤ 1) resolves it",
            sig3(h),
            sig3(hw),
            sig3(1.0 / w)
        )]
    } else {
        Vec::new()
    })
}

/// The library's contact parameters from `[plant.contact_grasps]` (the same pads on every
/// grasp; the box's half extents from `object.size`). The library checks the values by their
/// fields; here only what the file's shape says: a torsion coefficient without `mu`.
fn contact_params(
    src: &Source,
    c: &super::tables::ContactConfig,
    n_grasps: usize,
    size: [f64; 3],
) -> Result<tandem::plant::spatial::ContactParams, ScenarioError> {
    use tandem::plant::spatial::{ContactParams, Pad};
    let Some(mu) = c.mu else {
        let why = if c.torsion.is_some() {
            "plant.contact_grasps.torsion: a torsion coefficient needs a friction coefficient: \
             give `mu` too (torsional friction is μ_τ N on top of Coulomb's μ N)"
        } else {
            "plant.contact_grasps.mu: contact grasps need a friction coefficient `mu` (e.g. 0.3, \
             silicone fingertips on steel)"
        };
        let field = if c.torsion.is_some() {
            "plant.contact_grasps.torsion"
        } else {
            "plant.contact_grasps"
        };
        return Err(src.error_at(field, why));
    };
    let pads: Vec<Pad> = c
        .pads
        .iter()
        .map(|p| Pad {
            position: Vector3::from(p.position),
            normal: Vector3::from(p.normal),
            radius: p.radius,
        })
        .collect();
    Ok(ContactParams {
        pads: vec![pads; n_grasps],
        grip: vec![c.grip; n_grasps],
        mu,
        torsion: c.torsion.unwrap_or(0.0),
        normal_stiffness: c.normal_stiffness,
        normal_damping: c.normal_damping,
        tangential_stiffness: c.tangential_stiffness.unwrap_or(c.normal_stiffness),
        tangential_damping: c.tangential_damping.unwrap_or(c.normal_damping),
        half_extents: Vector3::new(0.5 * size[0], 0.5 * size[1], 0.5 * size[2]),
    })
}

/// The friction-aware distribution's model of the grasps, from the plant's contact grasps,
/// when `controller.distribution = "friction"`.
fn friction_params(
    src: &Source,
    sc: &SpatialScenario,
    plant: &SpatialPlantParams,
) -> Result<Option<tandem::control::spatial::distribute::friction::FrictionParams>, ScenarioError> {
    use tandem::control::spatial::distribute::friction::FrictionParams;
    let c = &sc.controller;
    let on = c.distribution == Some(DistributionConfig::Friction);
    if !on {
        if c.friction_margin.is_some() {
            return Err(src.error_at(
                "controller.friction_margin",
                "controller.friction_margin: the margin is the friction-aware distribution's; \
                 set `distribution = \"friction\"` too",
            ));
        }
        return Ok(None);
    }
    // The pads of contact grasps, or those gauging welds or springs (the plan then keeps
    // the pads the run gauges inside their cones).
    let g = match (&plant.grasp_model, &plant.pad_gauge) {
        (GraspModel::Contact(g), _) | (_, Some(g)) => g,
        _ => {
            return Err(src.error_at(
                "controller.distribution",
                "controller.distribution = \"friction\" keeps contact pads inside their friction \
                 cones: it needs pads ([plant.contact_grasps])",
            ));
        }
    };
    let margin = c.friction_margin.unwrap_or(DEFAULT_FRICTION_MARGIN);
    if !(margin.is_finite() && margin >= 0.0) {
        return Err(src.error_at(
            "controller.friction_margin",
            format!(
                "controller.friction_margin = {}: must be ≥ 0 and finite, N",
                num(margin)
            ),
        ));
    }
    Ok(Some(FrictionParams::from_contact(g, margin)))
}

/// The plant step against the contact grasps' fastest modes, as [`grasp_step_check`] for
/// compliant grasps: the tool link on its pads, translating (`Σ k` over the pads on its mass)
/// and rotating (`Σ k |p|²` over the pads, `p` each pad's place from the tool origin, on its
/// smallest principal inertia), and the pads' dampers on the same (`h c/m` beyond 2.8 makes RK4
/// unstable as surely as a stiff spring).
fn contact_step_check(
    src: &Source,
    arms: &[SpatialArm],
    c: &super::tables::ContactConfig,
    h: f64,
) -> Result<Vec<String>, ScenarioError> {
    let k = c
        .normal_stiffness
        .max(c.tangential_stiffness.unwrap_or(0.0));
    let d = c.normal_damping.max(c.tangential_damping.unwrap_or(0.0));
    if !(k.is_finite() && k > 0.0 && d.is_finite() && d >= 0.0 && h.is_finite() && h > 0.0) {
        return Ok(Vec::new());
    }
    let n = c.pads.len() as f64;
    let r2: f64 = c
        .pads
        .iter()
        .map(|p| Vector3::from(p.position).norm_squared())
        .sum();
    if !(r2.is_finite() && n > 0.0) {
        return Ok(Vec::new());
    }
    // (h ω, h c/m, arm, link).
    let mut worst: Option<(f64, f64, usize, String)> = None;
    for (i, a) in arms.iter().enumerate() {
        let Some(b) = a.chain.bodies.last() else {
            continue;
        };
        let i_min = b.inertia.symmetric_eigenvalues().min();
        let (mut w, mut rate) = (0.0f64, 0.0f64);
        if b.mass > 0.0 {
            w = w.max((n * k / b.mass).sqrt());
            rate = rate.max(n * d / b.mass);
        }
        if i_min > 0.0 {
            w = w.max((k * r2 / i_min).sqrt());
            rate = rate.max(d * r2 / i_min);
        }
        let score = (h * w).max(h * rate / 2.0);
        if score.is_finite() && worst.as_ref().is_none_or(|x| score > x.0.max(x.1 / 2.0)) {
            worst = Some((h * w, h * rate, i, b.name.clone()));
        }
    }
    let Some((hw, hr, i, link)) = worst else {
        return Ok(Vec::new());
    };
    let what = format!(
        "arms[{i}]'s tool link `{link}` on its pads, the contact grasps' fastest mode (h ω = {}, \
         h c/m = {}; plant.contact_grasps stiffness and damping)",
        sig3(hw),
        sig3(hr)
    );
    if hw > 2.0 * std::f64::consts::SQRT_2 || hr > 2.78 {
        return Err(src.error_at(
            "run.plant_step",
            format!(
                "run.plant_step = {} s is too long: {what}, and RK4 is unstable beyond h ω = 2.83 \
                 or h c/m = 2.78; use plant_step ≤ {} s, or softer or less damped pads",
                sig3(h),
                sig3(h / hw.max(hr))
            ),
        ));
    }
    Ok(if hw > 1.0 || hr > 1.0 {
        vec![format!(
            "run.plant_step = {} s resolves {what} poorly; plant_step ≤ {} s resolves it",
            sig3(h),
            sig3(h / hw.max(hr))
        )]
    } else {
        Vec::new()
    })
}

/// `v` to three significant digits, for a message (`31600`, `3.16e-5`).
fn sig3(v: f64) -> String {
    num(format!("{v:.2e}").parse().unwrap_or(v))
}

/// Map a library error of the spatial set-up to the file.
pub fn model_error(
    src: &Source,
    sc: &SpatialScenario,
    dofs: &[usize],
    e: ModelError,
) -> ScenarioError {
    // "The path leaves arm i's reach or joint limits": the arm's placement (or its grasp) is
    // what the user changes, so the error points at `arms[i].base` and quotes the path check.
    if let ModelError::Geometry { what, reason } = &e
        && what == "path"
        && let Some(i) = reason
            .split("arms[")
            .nth(1)
            .and_then(|r| r.split(']').next())
            .and_then(|i| i.parse::<usize>().ok())
            .filter(|i| *i < sc.arms.len())
    {
        let field = format!("arms[{i}].base");
        return src.error_at(
                    &field,
                    format!(
                        "{field}: with this base placement (and grasp `arms[{i}].grasp`) the path is out of the arm's reach or joint limits: {reason}"
                    ),
                );
    }
    src.model_error(e, |p| file_path(sc, dofs, p))
}

fn at(src: &Source) -> impl Fn((String, String)) -> ScenarioError + '_ {
    move |(path, why)| src.error_at(&path, format!("{path}: {why}"))
}

fn six(v: [f64; 6]) -> Vector6<f64> {
    Vector6::from(v)
}

/// 1.1 × `x` rounded up to two significant digits (the design inertia rule of
/// [`super::tables::DesignConfig::inertia`]).
pub fn round_up_2(x: f64) -> f64 {
    let x = 1.1 * x;
    if !(x > 0.0) || !x.is_finite() {
        return x;
    }
    let e = x.log10().floor() - 1.0;
    let s = 10f64.powf(e);
    (x / s).ceil() * s
}

/// Build the library's parameters from a parsed spatial scenario: reads the URDF files (errors
/// name `arms[i].urdf` and carry the URDF's line), checks the poses, builds the path.
pub fn build(sc: &SpatialScenario, src: &Source) -> Result<SpatialBuilt, ScenarioError> {
    let mut warnings = Vec::new();
    let mut inputs: Vec<PathBuf> = Vec::new();
    if sc.arms.is_empty() {
        return Err(src.error_at("arms", "arms: give at least one arm"));
    }
    // Arms.
    let mut arms = Vec::with_capacity(sc.arms.len());
    let mut grasps = Vec::with_capacity(sc.arms.len());
    let mut q_guess = Vec::new();
    for (i, a) in sc.arms.iter().enumerate() {
        let here = format!("arms[{i}]");
        let (text, base_default, tool_default, origin): (
            String,
            Option<&str>,
            Option<&str>,
            String,
        ) = match (&a.model, &a.urdf) {
            (Some(_), Some(_)) => {
                return Err(src.error_at(
                    &format!("{here}.urdf"),
                    format!("{here}.urdf: give `model` (embedded) or `urdf` (a file), not both"),
                ));
            }
            (None, None) => {
                return Err(src.error_at(
                    &here,
                    format!(
                        "{here}: give `model = \"ur5\"` / `\"franka\"` or `urdf = \"file.urdf\"`"
                    ),
                ));
            }
            (Some(m), None) => (
                m.text().to_string(),
                Some(m.base()),
                Some(m.tool()),
                format!("embedded model `{}`", serde_name(m)),
            ),
            (None, Some(f)) => {
                let p = resolve_file(src, f);
                let text = read_limited(&p, MAX_URDF_BYTES).map_err(|e| {
                    src.error_at(
                        &format!("{here}.urdf"),
                        format!("{here}.urdf: cannot read {}: {e}", p.display()),
                    )
                })?;
                inputs.push(p.clone());
                (text, None, None, p.display().to_string())
            }
        };
        let base_link = a.base_link.as_deref().or(base_default).ok_or_else(|| {
            src.error_at(
                &format!("{here}.base_link"),
                format!("{here}.base_link: a URDF arm names its base link (e.g. \"base_link\")"),
            )
        })?;
        let tool_link = a.tool_link.as_deref().or(tool_default).ok_or_else(|| {
            src.error_at(
                &format!("{here}.tool_link"),
                format!("{here}.tool_link: a URDF arm names its tool link (e.g. \"tool0\")"),
            )
        })?;
        let (chain, w) = urdf::load_chain(&text, base_link, tool_link).map_err(|e| {
            let field = match &e {
                e if e.to_string().contains(&format!("`{tool_link}`")) && a.tool_link.is_some() => {
                    format!("{here}.tool_link")
                }
                e if e.to_string().contains(&format!("`{base_link}`")) && a.base_link.is_some() => {
                    format!("{here}.base_link")
                }
                _ if a.urdf.is_some() => format!("{here}.urdf"),
                _ => format!("{here}.model"),
            };
            src.error_at(&field, format!("{field}: {origin}: {e}"))
        })?;
        // The plant's matrices grow with the square of the joint count: a chain longer than any
        // arm (a URDF of a whole robot cell, a generated file) is refused before they exist.
        if chain.joints.len() > MAX_LINKS {
            let field = if a.urdf.is_some() {
                format!("{here}.urdf")
            } else {
                format!("{here}.model")
            };
            return Err(src.error_at(
                &field,
                format!(
                    "{field}: the chain {base_link} → {tool_link} has {} moving joints; at most {MAX_LINKS} per arm are supported",
                    chain.joints.len()
                ),
            ));
        }
        for w in w {
            warnings.push(format!("{here} ({origin}): {w}"));
        }
        let base = placement(&format!("{here}.base"), &a.base).map_err(at(src))?;
        let grasp = placement(&format!("{here}.grasp"), &a.grasp).map_err(at(src))?;
        let n = chain.joints.len();
        match &a.q_guess {
            Some(g) => {
                if g.len() != n {
                    return Err(src.error_at(
                        &format!("{here}.q_guess"),
                        format!(
                            "{here}.q_guess has {} entries; the chain {base_link} → {tool_link} has {n} joints",
                            g.len()
                        ),
                    ));
                }
                for (k, v) in g.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(src.error_at(
                            &format!("{here}.q_guess[{k}]"),
                            format!("{here}.q_guess[{k}]: must be finite"),
                        ));
                    }
                    if let Some(msg) = guess_outside(&chain.joints[k], *v) {
                        return Err(src.error_at(
                            &format!("{here}.q_guess[{k}]"),
                            format!("{here}.q_guess[{k}] = {}: {msg}", sig3(*v)),
                        ));
                    }
                }
                q_guess.extend_from_slice(g);
            }
            None => {
                for j in &chain.joints {
                    let (lo, hi) = (j.limits.lower, j.limits.upper);
                    q_guess.push(if lo.is_finite() && hi.is_finite() {
                        0.5 * (lo + hi)
                    } else {
                        0.0
                    });
                }
            }
        }
        arms.push(SpatialArm { chain, base });
        grasps.push(grasp);
    }

    // Object.
    let o = &sc.object;
    let mut object = SpatialObjectParams::uniform_box(o.size, o.mass);
    for (j, s) in o.size.iter().enumerate() {
        if !(*s > 0.0) || !s.is_finite() {
            return Err(src.error_at(
                &format!("object.size[{j}]"),
                format!(
                    "object.size[{j}] = {}: must be positive and finite",
                    num(*s)
                ),
            ));
        }
    }
    if let Some(i) = o.inertia {
        object.inertia = Matrix3::from_row_slice(&[
            i[0][0], i[0][1], i[0][2], i[1][0], i[1][1], i[1][2], i[2][0], i[2][1], i[2][2],
        ]);
    }
    object.damping = six(o.damping);

    warnings.extend(plausibility(src, &arms, &grasps, o.size));

    // The pads hold the object (contact grasps), or only gauge welds or springs.
    let gauge = sc.plant.contact_grasps.as_ref().filter(|c| c.gauge_only);
    let held = sc.plant.contact_grasps.as_ref().filter(|c| !c.gauge_only);
    let grasp_model = match (&sc.plant.compliant_grasps, held) {
        (Some(_), Some(_)) => {
            return Err(src.error_at(
                "plant.contact_grasps",
                "plant.contact_grasps: the grasps are either compliant ([plant.compliant_grasps]) \
                 or held by friction ([plant.contact_grasps]), not both (`gauge_only = true` \
                 keeps the springs and gauges the friction they would need)",
            ));
        }
        (None, None) => GraspModel::Weld,
        (Some(c), None) => GraspModel::Compliant {
            stiffness: six(c.stiffness),
            damping: six(c.damping),
        },
        (None, Some(c)) => {
            let g = contact_params(src, c, grasps.len(), o.size)?;
            warnings.extend(contact_step_check(src, &arms, c, sc.run.plant_step())?);
            GraspModel::Contact(g)
        }
    };
    let pad_gauge = match gauge {
        Some(c) => Some(contact_params(src, c, grasps.len(), o.size)?),
        None => None,
    };
    if held.is_some()
        && let Some(d) = sc.run.max_drift.filter(|d| *d < 1e-3)
    {
        warnings.push(format!(
            "run.max_drift = {} stops the run when a pad deflects or slips that far, but contact \
             grasps deflect by design; leave it out (0.05 m and rad: a grasp that slipped off) or \
             raise it",
            num(d)
        ));
    }
    if let Some(c) = &sc.plant.compliant_grasps {
        warnings.extend(grasp_step_check(src, &arms, c, sc.run.plant_step())?);
        warnings.extend(grasp_filter_check(
            &arms,
            c,
            sc.run.control_period(),
            sc.controller.actuator.filter_time_constant,
        ));
        if let Some(d) = sc.run.max_drift.filter(|d| *d < 1e-3) {
            warnings.push(format!(
                "run.max_drift = {} stops the run when a grasp deflects that far, but compliant \
                 grasps deflect by design; leave it out (0.05 m and rad: a grasp that slipped) \
                 or raise it",
                num(d)
            ));
        }
    }
    let plant = SpatialPlantParams {
        arms,
        grasps,
        object,
        gravity: Vector3::from(sc.plant.gravity),
        baumgarte: sc.plant.baumgarte,
        grasp_model,
        pad_gauge,
    };

    let path = build_path(&sc.path, src)?;

    // Controller.
    let c = &sc.controller;
    // The NN design's inputs (SPEC §3.4's per-axis design): checked here, by their own names,
    // before the gains designed from them are (a NaN `k1` would otherwise surface as the
    // designed `controller.nn.k1[0]`, a field the file does not set).
    if c.kind == ControllerKind::Nn {
        let d = c.nn.design();
        let mut fields: Vec<(String, f64)> = vec![
            ("controller.nn.design.k1".into(), d.k1),
            ("controller.nn.design.omega_n".into(), d.omega_n),
            ("controller.nn.design.zeta".into(), d.zeta),
        ];
        for (j, m) in d.inertia.iter().flatten().enumerate() {
            fields.push((format!("controller.nn.design.inertia[{j}]"), *m));
        }
        for (name, v) in fields {
            if !(v.is_finite() && v > 0.0) {
                return Err(src.error_at(
                    &name,
                    format!("{name} = {}: must be finite and > 0", num(v)),
                ));
            }
        }
    }
    let controller = {
        let law = match c.kind {
            ControllerKind::Nn => Law::Nn(nn_gains(sc, None)),
            ControllerKind::Pd | ControllerKind::Replay => {
                let mut g = PdGains::<6>::paper();
                if let Some(v) = c.pd.k_p {
                    g.k_p = v;
                }
                if let Some(v) = c.pd.k_d {
                    g.k_d = v;
                }
                g.gravity_compensation = c.pd.gravity_compensation.unwrap_or(false);
                Law::Pd(g)
            }
            ControllerKind::Ctc => {
                let mut g = CtcGains::<6>::default();
                if let Some(v) = c.ctc.k_p {
                    g.k_p = v;
                }
                if let Some(v) = c.ctc.k_d {
                    g.k_d = v;
                }
                if let Some(v) = c.ctc.model_error {
                    g.model_error = v;
                }
                Law::Ctc(g)
            }
        };
        let scheme = match c.scheme {
            SchemeConfig::Object => Scheme::Object,
            SchemeConfig::PerArm => Scheme::PerArm,
        };
        let r_ref = match &c.r_ref {
            Some(o) => Some(orientation("controller.r_ref", o).map_err(at(src))?),
            None => None,
        };
        let mut posture = PostureParams::default();
        if let Some(v) = c.posture.kp {
            posture.kp = v;
        }
        if let Some(v) = c.posture.kd {
            posture.kd = v;
        }
        posture.q_rest = c.posture.q_rest.clone();
        let a = &sc.admittance;
        SpatialControllerParams {
            law,
            scheme,
            k_c: c.k_c,
            centre: c.centre.map(Vector3::from),
            r_ref,
            admittance: a.enabled.then(|| AdmittanceSe3Params {
                m_e: six(a.m_e.array()),
                c_e: six(a.c_e.array()),
                k_e: six(a.k_e.array()),
                tau_f: six(a.tau_f.array()),
            }),
            squeeze: c.squeeze,
            metric_length: c.metric_length,
            control_period: sc.run.control_period(),
            torque_limit: c.torque_limit,
            actuator: actuator_params(&sc.arms, &c.actuator),
            disturbance_bound: c.disturbance_bound,
            posture,
            friction: friction_params(src, sc, &plant)?,
        }
    };
    let replay = if c.kind == ControllerKind::Replay {
        match &c.replay {
            None => {
                return Err(src.error_at(
                    "controller.replay",
                    "controller.replay: kind = \"replay\" needs the torque file (`replay = \"torques.csv\"`, or --replay FILE)",
                ));
            }
            Some(f) => {
                let p = resolve_file(src, f);
                inputs.push(p.clone());
                Some(p)
            }
        }
    } else {
        None
    };

    let sensors = sc.sensors.params(sc.run.seed);
    let disturbance = sc.disturbance.disturbance();
    let r = &sc.run;
    let sim = SimParams {
        duration: r.duration,
        plant_step: r.plant_step(),
        control_period: r.control_period(),
        log_period: r.log_period(),
        start: [0.0; 3],
        formulation: Formulation::Constrained,
        // Welds hold to 1e-6 (m and rad) or the run has lost its constraint; a compliant grasp
        // deflects by design, and has slipped at 0.05 m or 0.05 rad (`tandem robustness`'s
        // grasp-slip family uses the same).
        max_drift: r.max_drift.unwrap_or(
            if sc.plant.compliant_grasps.is_some() || sc.plant.contact_grasps.is_some() {
                0.05
            } else {
                1e-6
            },
        ),
        min_sigma: r.min_sigma.unwrap_or(1e-3),
    };
    // Start: the desired pose at t = 0, offset (world axes).
    let start_offset = r.start_offset();
    for (j, v) in start_offset.iter().enumerate() {
        if !v.is_finite() {
            return Err(src.error_at(
                &format!("run.start_offset[{j}]"),
                format!("run.start_offset[{j}]: must be finite"),
            ));
        }
    }
    // The summary's transient window: as the planar loader checks it.
    if !(sc.metrics.transient.is_finite() && sc.metrics.transient >= 0.0) {
        return Err(src.error_at(
            "metrics.transient",
            format!(
                "metrics.transient = {}: must be finite and >= 0",
                num(sc.metrics.transient)
            ),
        ));
    }
    let d0 = path.sample(0.0);
    let dp = Vector3::new(start_offset[0], start_offset[1], start_offset[2]);
    let dr = Vector3::new(start_offset[3], start_offset[4], start_offset[5]);
    let start = SpatialStart {
        x_wo: Isometry3::from_parts(
            Translation3::from(d0.p + dp),
            UnitQuaternion::from_scaled_axis(dr) * d0.r,
        ),
        q_guess,
    };
    Ok(SpatialBuilt {
        plant,
        path,
        controller,
        replay,
        sensors,
        disturbance,
        sim,
        start,
        box_size: o.size,
        warnings,
        inputs,
    })
}

pub use super::{BASE_SEPARATION_MIN, GRASP_SURFACE_TOL};

/// What validation warns about (issue 22, "refuse the impossible, warn about the
/// implausible"): a grasp frame more than [`GRASP_SURFACE_TOL`] off the box's surface (with the
/// distance, in or out), a tool whose approach axis (its z axis, the flange normal of URDF
/// convention) does not point into the box at the face it holds (naming the tool axis that
/// does), and two arms whose bases are less than [`BASE_SEPARATION_MIN`] apart.
fn plausibility(
    src: &Source,
    arms: &[SpatialArm],
    grasps: &[Isometry3<f64>],
    size: [f64; 3],
) -> Vec<String> {
    let mut out = Vec::new();
    let h = Vector3::new(0.5 * size[0], 0.5 * size[1], 0.5 * size[2]);
    for (i, g) in grasps.iter().enumerate() {
        let p = g.translation.vector;
        let ex = p.abs() - h; // per axis: how far past the face (> 0) or inside it (< 0)
        let face = ex.imax();
        let outside = ex.map(|e| e.max(0.0)).norm();
        let (dist, side) = if outside > 0.0 {
            (outside, "outside")
        } else {
            (-ex[face], "inside")
        };
        let at = format!("arms[{i}].grasp");
        if dist > GRASP_SURFACE_TOL {
            out.push(src.warning_at(
                &at,
                &format!(
                    "{at}: the tool frame sits {} m {side} the box ({} × {} × {} m), off its surface: if the tool link is the flange, that distance is the gripper (then set tool_link to the fingertip frame); otherwise check {at}.position",
                    num_short(dist),
                    num_short(size[0]),
                    num_short(size[1]),
                    num_short(size[2])
                ),
            ));
        }
        // Inward normal of the face held (the nearest face; the +face when the point is central).
        let mut n_in = Vector3::zeros();
        n_in[face] = if p[face] < 0.0 { 1.0 } else { -1.0 };
        let r = g.rotation.to_rotation_matrix();
        let z = r.matrix().column(2).dot(&n_in);
        if z < (30f64).to_radians().cos() {
            let (mut best, mut best_c) = (0, 0.0f64);
            for a in 0..3 {
                let c = r.matrix().column(a).dot(&n_in);
                if c.abs() > best_c.abs() {
                    (best, best_c) = (a, c);
                }
            }
            let axis = format!(
                "{}{}",
                if best_c < 0.0 { "−" } else { "+" },
                ["x", "y", "z"][best]
            );
            let face_name = format!(
                "{}{}",
                if n_in[face] > 0.0 { "−" } else { "+" },
                ["x", "y", "z"][face]
            );
            out.push(src.warning_at(
                &at,
                &format!(
                    "{at}: the tool's approach axis (+z) is {}° from the box's inward normal at its {face_name} face; the tool axis that points into the box is {axis} (check {at}'s orientation)",
                    num_short(z.clamp(-1.0, 1.0).acos().to_degrees())
                ),
            ));
        }
    }
    let bases: Vec<[f64; 3]> = arms
        .iter()
        .map(|a| a.base.translation.vector.into())
        .collect();
    out.extend(super::base_overlaps(src, &bases, ""));
    out
}

/// The name a scenario file gives an embedded model (`ur5`, `franka`).
pub fn serde_name(m: &RobotModel) -> &'static str {
    match m {
        RobotModel::Ur5 => "ur5",
        RobotModel::Franka => "franka",
    }
}

/// NN gains from the design (with `inertia` when the file gives none) and the overrides.
pub fn nn_gains(sc: &SpatialScenario, path_inertia: Option<[f64; 6]>) -> NnGains<6> {
    let n = &sc.controller.nn;
    let d = n.design();
    let m = d
        .inertia
        .or(path_inertia.map(|m| m.map(round_up_2)))
        // Placeholder until the path inertia is known (the controller is then rebuilt).
        .unwrap_or([1.0; 6]);
    let mut g = NnGains::from_design(m, d.k1, d.omega_n, d.zeta);
    (g.d1, g.d2) = switching_radii(sc, m[2], d.k1, d.omega_n);
    n.apply(g)
}

/// The NN design's switching radii for this scenario (`docs/smooth-nn.md`, rule 2): the
/// nominal loop should stay inside `Ω1 = {|Z_k| ≤ d1}` through the start, whose largest input
/// is `α̇` along gravity while the network has not learned the box's weight,
/// `|α̇_z| ≈ K1 (K1 |z1(0)| + m_o g / (M_z ω_n))` (`z1(0)` the start offset's translation,
/// `M_z` the design inertia along z). `d1` is that with a 15 % margin (the measured peak is
/// 0.85–0.92 of the estimate on the presets), rounded up to a half, and never below
/// [`SPATIAL_D1`]; `d2 = 1.5 d1` (SPEC §3.4's ratio). Both presets get `SPATIAL_D1`,
/// `SPATIAL_D2` (estimate 1.62 on both: 3 kg, `M_z` 12 kg, 1 cm); a 15 kg box on dual-UR5 gets 6.5 and 9.75, which keeps
/// `Q ≡ 1` (with 2 and 3 it fell to 0.88 and the start's peak torque rate rose from 1 264 to
/// 4 729 N m/s). A file's own `d1`, `d2` win.
pub fn switching_radii(sc: &SpatialScenario, m_z: f64, k1: f64, omega_n: f64) -> (f64, f64) {
    let o = sc.run.start_offset();
    let z1 = Vector3::new(o[0], o[1], o[2]).norm();
    let g = Vector3::from(sc.plant.gravity).norm();
    let est = k1 * (k1 * z1 + sc.object.mass * g / (m_z * omega_n));
    let d1 = (1.15 * est * 2.0).ceil() / 2.0;
    if d1.is_finite() && d1 > SPATIAL_D1 {
        (d1, 1.5 * d1)
    } else {
        (SPATIAL_D1, SPATIAL_D2)
    }
}

fn need<T: Copy>(src: &Source, v: Option<T>, field: &str, kind: &str) -> Result<T, ScenarioError> {
    v.ok_or_else(|| {
        src.error_at(
            &format!("path.{field}"),
            format!("path.{field}: a `{kind}` path needs `{field}`"),
        )
    })
}

fn build_path(p: &PathConfig, src: &Source) -> Result<Se3Path, ScenarioError> {
    let lib = |e: ModelError| src.model_error(e, |s| s.to_string());
    p.check_fields(super::Kind::Spatial, src)?;
    match p.kind {
        PathKind::Lemniscate => Err(src.error_at(
            "path.kind",
            "path.kind = \"lemniscate\" is a planar path (spatial: circle, point_to_point, spline)",
        )),
        PathKind::Circle => {
            let omega = need(src, p.omega, "omega", "circle")?;
            let d = CircleParams::spec_s6();
            let params = CircleParams {
                center: Vector3::from(need(src, p.center, "center", "circle")?),
                radius: need(src, p.radius, "radius", "circle")?,
                omega,
                phase: p.phase.unwrap_or(0.0),
                plane_x: p.plane_x.map(Vector3::from).unwrap_or(d.plane_x),
                plane_y: p.plane_y.map(Vector3::from).unwrap_or(d.plane_y),
                r0: match &p.r0 {
                    Some(o) => orientation("path.r0", o).map_err(at(src))?,
                    None => UnitQuaternion::identity(),
                },
                axis: p.axis.map(Vector3::from).unwrap_or(d.axis),
                axis_frame: match p.axis_frame {
                    Some(AxisFrameConfig::Body) => AxisFrame::Body,
                    _ => AxisFrame::World,
                },
                amplitude: p.amplitude.unwrap_or(0.0),
                omega_rot: p.omega_rot.unwrap_or(omega),
                phase_rot: p.phase_rot.unwrap_or(0.0),
            };
            Se3Path::circle(&params).map_err(lib)
        }
        PathKind::PointToPoint => {
            let from = p.from.as_ref().ok_or_else(|| {
                src.error_at(
                    "path.from",
                    "path.from: a `point_to_point` path needs `from`",
                )
            })?;
            let to = p.to.as_ref().ok_or_else(|| {
                src.error_at("path.to", "path.to: a `point_to_point` path needs `to`")
            })?;
            let a = placement("path.from", from).map_err(at(src))?;
            let b = placement("path.to", to).map_err(at(src))?;
            let duration = need(src, p.duration, "duration", "point_to_point")?;
            Se3Path::point_to_point(
                a.translation.vector,
                a.rotation,
                b.translation.vector,
                b.rotation,
                p.t0.unwrap_or(0.0),
                duration,
            )
            .map_err(lib)
        }
        PathKind::Spline => {
            let w = p.waypoints.as_ref().ok_or_else(|| {
                src.error_at(
                    "path.waypoints",
                    "path.waypoints: a `spline` path needs `[[path.waypoints]]` (t, position, orientation)",
                )
            })?;
            if w.len() > 100_000 {
                return Err(src.error_at(
                    "path.waypoints",
                    format!("path.waypoints: {} waypoints; at most 100000", w.len()),
                ));
            }
            let mut pts = Vec::with_capacity(w.len());
            for (k, wp) in w.iter().enumerate() {
                let here = format!("path.waypoints[{k}]");
                let r = rotation(&here, &wp.rpy, &wp.quaternion, &wp.axes)
                    .map_err(at(src))?
                    .unwrap_or_else(UnitQuaternion::identity);
                pts.push(Se3Waypoint {
                    t: wp.t,
                    p: Vector3::from(wp.position),
                    r,
                });
            }
            // The library names `path.waypoints[k].p[j]`; the file calls it `position`.
            Se3Path::spline(&pts).map_err(|e| {
                src.model_error(e, |s| {
                    s.replace("].p[", "].position[")
                        .replace("].r", "].quaternion")
                })
            })
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The simulation.

/// A ready spatial simulation: a controller or a torque replay drives the plant.
pub enum SpatialSim {
    /// tandem's spatial controller.
    Control(Box<Simulation<SpatialPlant, SpatialController>>),
    /// Joint torques from a file.
    Replay(Box<Simulation<SpatialPlant, Replay>>),
    /// A user's law (issue 23).
    External(Box<Simulation<SpatialPlant, External>>),
}

impl SpatialSim {
    /// Run to the end (or a fault), reporting progress in [0, 1].
    /// Returns the outcome and, for contact grasps, the pads' record (slip, events, margins)
    /// and what the friction-aware distribution did.
    pub fn run(
        self,
        progress: impl FnMut(f64),
    ) -> (Outcome, Option<ContactLog>, Option<FrictionStats>) {
        fn contacts(ws: &tandem::plant::spatial::SpatialWorkspace) -> Option<ContactLog> {
            (!ws.contacts.readings.is_empty()).then(|| ws.contacts.clone())
        }
        match self {
            SpatialSim::Control(s) => {
                let (o, s) = s.run(progress);
                (o, contacts(s.workspace()), s.driver().friction_stats())
            }
            SpatialSim::Replay(s) => {
                let (o, s) = s.run(progress);
                (o, contacts(s.workspace()), None)
            }
            SpatialSim::External(s) => {
                let (o, s) = s.run(progress);
                (o, contacts(s.workspace()), None)
            }
        }
    }

    /// The plant and its flat state (at the start until [`SpatialSim::run`]: the arms' joints
    /// solved on the start pose, at rest).
    pub fn plant_state(&self) -> (&SpatialPlant, &[f64]) {
        match self {
            SpatialSim::Control(s) => (s.plant(), s.state()),
            SpatialSim::Replay(s) => (s.plant(), s.state()),
            SpatialSim::External(s) => (s.plant(), s.state()),
        }
    }
}

/// A built, validated simulation and what the outputs need.
pub struct SpatialReady {
    /// The simulation.
    pub sim: SpatialSim,
    /// The set-up warnings (URDF, gains), each with its field path and line.
    pub warnings: Vec<String>,
    /// The controller's parameters as resolved (design inertia filled in), `None` for a replay.
    pub controller: Option<SpatialControllerParams>,
    /// The chart-space inertia along the path, per axis (kg ×3, kg m² ×3), `None` for a replay.
    pub path_inertia: Option<[f64; 6]>,
    /// The output bounds `k_c` (m ×3, rad ×3).
    pub k_c: [f64; 6],
    /// The output chart (centre `c`, `R_ref`) the outputs are measured in.
    pub chart: Chart,
}

/// The joint count of each arm.
pub fn dofs(b: &SpatialBuilt) -> Vec<usize> {
    b.plant.arms.iter().map(|a| a.chain.joints.len()).collect()
}

/// The simulation of `driver` (the controller or a torque replay) on the built plant, start,
/// sensors, disturbance and timing.
fn simulation<D: Drive<SpatialPlant>>(
    plant: SpatialPlant,
    b: &SpatialBuilt,
    driver: D,
) -> Result<Box<Simulation<SpatialPlant, D>>, ModelError> {
    Simulation::with_plant(
        plant,
        &b.start,
        &b.sensors,
        driver,
        b.disturbance.clone(),
        b.sim.clone(),
    )
    .map(Box::new)
}

/// A scenario's spatial controller as [`make_simulation`] builds it, not started.
pub struct Designed {
    /// The controller.
    pub controller: SpatialController,
    /// Its set-up warnings (the library's, not yet mapped to file paths).
    pub warnings: Vec<ControlWarning>,
    /// Its parameters as resolved (design inertia filled in).
    pub params: SpatialControllerParams,
    /// The chart-space path inertia the PD probe measured, when the NN law was designed on it.
    pub probed_inertia: Option<[f64; 6]>,
}

/// Build the controller of a scenario as [`make_simulation`] does: the set-up checks of
/// [`SpatialController::new`] (gains, bounds, the path inside the bounds, the arms' reach and
/// joint limits, the posture); an NN law whose file gives no design inertia is designed on the
/// path's chart-space inertia, which a first set-up with the PD law measures.
pub fn make_controller(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
) -> Result<Designed, ScenarioError> {
    let dofs = dofs(b);
    let lib = |e: ModelError| model_error(src, sc, &dofs, e);
    let mut cp = b.controller.clone();
    let mut probed_inertia = None;
    if let (ControllerKind::Nn, None) = (sc.controller.kind, sc.controller.nn.design().inertia) {
        let mut probe = cp.clone();
        probe.law = Law::Pd(PdGains::<6>::paper());
        let (c, _) = SpatialController::new(
            &probe,
            &b.plant,
            b.path.clone(),
            b.sim.duration,
            &b.start.q_guess,
        )
        .map_err(lib)?;
        let m: [f64; 6] = c.path_inertia().into();
        probed_inertia = Some(m);
        cp.law = Law::Nn(nn_gains(sc, Some(m)));
    }
    let (c, w) = SpatialController::new(
        &cp,
        &b.plant,
        b.path.clone(),
        b.sim.duration,
        &b.start.q_guess,
    )
    .map_err(lib)?;
    Ok(Designed {
        controller: c,
        warnings: w,
        params: cp,
        probed_inertia,
    })
}

/// Build the controller (the set-up checks of [`SpatialController::new`]: gains, bounds, the
/// path inside the bounds and the arms' reach and joint limits, the posture) and the simulation.
/// An NN law whose file gives no design inertia is designed on the path's chart-space inertia
/// (a first set-up with the PD law measures it).
pub fn make_simulation(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
) -> Result<SpatialReady, ScenarioError> {
    make(sc, b, src, None)
}

/// [`make_simulation`] with a user's law driving the loop instead of the scenario's controller
/// or replay (issue 23): the scenario's controller is still designed, for the output chart and
/// bounds the run is scored in.
pub fn make_simulation_external(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
    law: External,
) -> Result<SpatialReady, ScenarioError> {
    make(sc, b, src, Some(law))
}

/// The simulation of `driver` (torques set from outside, [`tandem::sim::Held`], a user's law)
/// on the scenario's plant, start, sensors, disturbance and timing, with every set-up check
/// of a run; errors name the file's fields.
pub fn simulation_of<D: Drive<SpatialPlant>>(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
    driver: D,
) -> Result<Box<Simulation<SpatialPlant, D>>, ScenarioError> {
    let dofs = dofs(b);
    let plant = SpatialPlant::new(&b.plant).map_err(|e| model_error(src, sc, &dofs, e))?;
    simulation(plant, b, driver).map_err(|e| start_error(sc, b, src, e))
}

/// A set-up error of the simulation, named as the file's field: an arm that cannot hold the
/// start pose names `run.start_offset` when the file gives one (else the arm).
fn start_error(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
    e: ModelError,
) -> ScenarioError {
    let dofs = dofs(b);
    let o = sc.run.start_offset();
    match &e {
        ModelError::Geometry { what, .. } if what.starts_with("arms") => {
            let offset = format!("[{}]", o.map(num).join(", "));
            if o.iter().any(|v| *v != 0.0) {
                src.error_at(
                    "run.start_offset",
                    format!(
                        "run.start_offset = {offset}: the start pose (the path at t = 0 offset by it) cannot be held: {e}"
                    ),
                )
            } else {
                let field = file_path(sc, &dofs, what);
                src.error_at(
                    &field,
                    format!("{field}: the start pose (the path at t = 0) cannot be held: {e}"),
                )
            }
        }
        _ => model_error(src, sc, &dofs, e),
    }
}

fn make(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
    external: Option<External>,
) -> Result<SpatialReady, ScenarioError> {
    let dofs = dofs(b);
    let lib = |e: ModelError| model_error(src, sc, &dofs, e);
    let mut warnings = b.warnings.clone();
    let plant = SpatialPlant::new(&b.plant).map_err(lib)?;
    // The controller's set-up has checked that every arm reaches the path, so an arm that
    // cannot hold the start pose fails on the file's start offset when it gives one.
    let start_error = |e: ModelError| start_error(sc, b, src, e);
    let Designed {
        controller: c,
        warnings: w,
        params: cp,
        probed_inertia,
    } = make_controller(sc, b, src)?;
    let mut path_inertia = probed_inertia;
    let k_c: [f64; 6] = c.k_c().into();
    let chart = *c.chart();
    let (sim, controller) = match (&b.replay, external) {
        (_, Some(law)) => {
            path_inertia = None;
            let sim = simulation(plant, b, law).map_err(start_error)?;
            (SpatialSim::External(sim), None)
        }
        (None, None) => {
            if path_inertia.is_none() {
                path_inertia = Some(c.path_inertia().into());
            }
            warnings.extend(
                w.iter()
                    .map(|w| control_warning(src, w, |p| file_path(sc, &dofs, p))),
            );
            if let Law::Nn(g) = &cp.law {
                warnings.extend(
                    nn_damping_check(sc, b, g).map(|w| src.warning_at("controller.nn", &w)),
                );
            }
            let effort = c.actuator().effort().to_vec();
            let sim = simulation(plant, b, c).map_err(start_error)?;
            start_hold_check(sc, b, src, sim.plant(), sim.state(), &effort)?;
            (SpatialSim::Control(sim), Some(cp))
        }
        (Some(file), None) => {
            let n_q: usize = dofs.iter().sum();
            let mode = sc.controller.replay_interpolation;
            let columns = sc.controller.replay_columns.as_deref();
            let replay = load_replay(src, file, n_q, &b.sim, mode, columns)?;
            path_inertia = None;
            let sim = simulation(plant, b, replay).map_err(start_error)?;
            (SpatialSim::Replay(sim), None)
        }
    };
    Ok(SpatialReady {
        sim,
        warnings,
        controller,
        path_inertia,
        k_c,
        chart,
    })
}

/// Bad input (issue 24): an effort limit below the torque a joint needs to hold the start pose
/// at rest ([`SpatialPlant::holding_torques`]: the arm's gravity and its equal share of the
/// object's weight, no internal wrench) is refused, naming the limit's field
/// (`controller.actuator.effort[k]`, `controller.torque_limit`, or the arm's URDF `effort`
/// through `arms[i].model` / `arms[i].urdf`), the joint (arm and URDF name) and both torques.
/// `effort` is the actuator stage's, one per joint (`+∞` where there is none).
fn start_hold_check(
    sc: &SpatialScenario,
    b: &SpatialBuilt,
    src: &Source,
    plant: &SpatialPlant,
    y: &[f64],
    effort: &[f64],
) -> Result<(), ScenarioError> {
    let mut tau = vec![0.0; plant.n_q()];
    let mut ws = plant.workspace();
    plant.holding_torques(y, &mut ws, &mut tau);
    let mut k = 0;
    for (i, arm) in b.plant.arms.iter().enumerate() {
        for joint in &arm.chain.joints {
            let (t, e) = (tau[k], effort[k]);
            if t.is_finite() && t.abs() > e {
                let field = if sc.controller.actuator.effort.is_some() {
                    format!("controller.actuator.effort[{k}]")
                } else if sc.controller.torque_limit.is_some() {
                    "controller.torque_limit".to_string()
                } else if sc.arms[i].urdf.is_some() {
                    format!("arms[{i}].urdf")
                } else {
                    format!("arms[{i}].model")
                };
                let whose = if field.starts_with("arms[") {
                    format!("{field}: the URDF `effort` of joint `{}`", joint.name)
                } else {
                    format!("{field} = {}", num(e))
                };
                return Err(src.error_at(
                    &field,
                    format!(
                        "{whose}: arms[{i}] joint `{}` (joint {k}) needs {} N m to hold the start \
                         pose at rest (its arm's gravity and its share of the object's weight), \
                         more than its effort limit {} N m; raise the limit, or start where the \
                         arms can hold the object",
                        joint.name,
                        num_short(t.abs()),
                        num_short(e)
                    ),
                ));
            }
            k += 1;
        }
    }
    Ok(())
}

impl SpatialScenario {
    /// Apply the command line's overrides (`--gains` names planar presets only).
    pub fn apply(&mut self, o: &super::Overrides) -> Result<(), crate::BadInput> {
        if o.gains.is_some() {
            return Err(crate::BadInput::msg(
                "--gains selects the planar NN presets (paper, tuned); a spatial scenario designs its \
                 NN gains in [controller.nn] (design = { inertia, k1, omega_n, zeta }, or explicit gains)",
            ));
        }
        if let Some(d) = o.duration {
            self.run.duration = d;
        }
        if let Some(s) = o.seed {
            self.run.seed = s;
        }
        if let Some(k) = o.controller {
            self.controller.kind = k;
        }
        if o.pd_gravity {
            self.controller.pd.gravity_compensation = Some(true);
        }
        if let Some(r) = &o.replay {
            self.controller.kind = ControllerKind::Replay;
            // The command line's path is relative to the working folder, the file's to the file.
            let abs = std::path::absolute(r).unwrap_or_else(|_| r.clone());
            self.controller.replay = Some(abs.display().to_string());
        }
        if let Some(m) = o.replay_interpolation {
            self.controller.replay_interpolation = Some(m);
        }
        if let Some(c) = &o.replay_columns {
            self.controller.replay_columns = Some(c.clone());
        }
        Ok(())
    }
}
