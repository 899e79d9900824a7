//! Scenario files: what a run simulates, in TOML.
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
//! | `[object]` | [`ObjectParams`] |
//! | `[plant]` | gravity, Baumgarte drift control |
//! | `[path]` | [`Path`] (`kind` = circle, point_to_point, lemniscate, spline) |
//! | `[disturbance]`, `[[disturbance.pushes]]` | [`Disturbance`], [`Push`] |
//! | `[sensors]` | [`SensorParams`] (its seed is `run.seed`) |
//! | `[controller]` (+ `.nn`, `.pd`, `.ctc`) | [`ControllerParams`] or a torque replay |
//! | `[admittance]` | [`AdmittanceParams`] |
//! | `[run]` | [`SimParams`] and the seed |
//! | `[metrics]` | the transient window of the summary |

use std::fmt;
use std::ops::Range;
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
use tandem::model::disturbance::{Disturbance, Push};
use tandem::model::planar::arm::{ArmParams, Elbow, LinkParams};
use tandem::model::planar::object::ObjectParams;
use tandem::plant::planar::PlantParams;
use tandem::reference::planar::admittance::AdmittanceParams;
use tandem::reference::planar::path::Path;
use tandem::sim::sensors::{ChannelNoise, SensorParams};
use tandem::sim::{Driver, Formulation, Replay, SimParams, Simulation};

use crate::suggest;

// ---------------------------------------------------------------------------------------------
// Embedded scenarios.

/// An embedded scenario: name, one-line description, TOML text.
pub struct Embedded {
    /// Name used on the command line (`tandem run paper`).
    pub name: &'static str,
    /// One line for `tandem scenario list`.
    pub summary: &'static str,
    /// The file.
    pub text: &'static str,
}

/// The scenarios compiled into the binary; the first is the default.
pub const EMBEDDED: &[Embedded] = &[
    Embedded {
        name: "paper",
        summary: "the paper's Section V: two 2-link arms carry a box around a 0.2 m circle for 90 s",
        text: include_str!("../scenarios/paper.toml"),
    },
    Embedded {
        name: "push",
        summary: "the paper scenario with a 2 N push on the object at t = 20 s for 2 s (admittance compliance)",
        text: include_str!("../scenarios/push.toml"),
    },
    Embedded {
        name: "lemniscate",
        summary: "the paper's arms carry the box along a figure eight (Gerono lemniscate), noisy sensors",
        text: include_str!("../scenarios/lemniscate.toml"),
    },
];

/// The default scenario's name.
pub const DEFAULT: &str = "paper";

/// Where a scenario's text comes from.
#[derive(Clone, Debug)]
pub struct Source {
    /// Scenario name: the embedded name, or the file's stem.
    pub name: String,
    /// How errors name it: the file path, or `embedded scenario `paper``.
    pub display: String,
    /// The TOML text.
    pub text: String,
    /// Folder that relative paths inside the file (a replay file) are resolved against.
    pub dir: PathBuf,
    /// The scenario file, if it is one (never inside a folder `--force` replaces).
    pub file: Option<PathBuf>,
}

/// Resolve the command line's `SCENARIO`: an existing file, else an embedded name; `None` is the
/// default scenario.
pub fn resolve(arg: Option<&str>) -> Result<Source, crate::BadInput> {
    let arg = arg.unwrap_or(DEFAULT);
    let p = FsPath::new(arg);
    if p.is_file() {
        let text = read_limited(p, MAX_SCENARIO_BYTES).map_err(|e| {
            crate::BadInput::msg(format!("cannot read scenario file {}: {e}", p.display()))
        })?;
        let name = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map(FsPath::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        return Ok(Source {
            name,
            display: p.display().to_string(),
            text,
            dir,
            file: Some(p.to_path_buf()),
        });
    }
    let all = || {
        EMBEDDED
            .iter()
            .chain(crate::spatial::scenario::EMBEDDED.iter())
    };
    if let Some(e) = all().find(|e| e.name == arg) {
        return Ok(embedded_source(e));
    }
    let names: Vec<&str> = all().map(|e| e.name).collect();
    let looks_like_file = arg.ends_with(".toml") || arg.contains('/') || arg.contains('\\');
    let mut msg = if p.exists() {
        format!("scenario {arg} is not a file")
    } else if looks_like_file {
        format!("scenario file {arg} does not exist")
    } else {
        format!("`{arg}` is neither a scenario file nor an embedded scenario")
    };
    if !looks_like_file && let Some(s) = suggest::closest(arg, names.iter().copied()) {
        msg.push_str(&format!(" — did you mean `{s}`?"));
    }
    msg.push_str(&format!(
        " (embedded scenarios: {}; see `tandem scenario list`)",
        names.join(", ")
    ));
    Err(crate::BadInput::msg(msg))
}

/// Largest scenario file read, bytes (16 MiB; the embedded paper scenario is 12 kB).
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;

/// Most arms, and links per arm, a scenario may have (the plant's matrices grow with the
/// square of the joint count).
pub const MAX_ARMS: usize = 16;
/// See [`MAX_ARMS`].
pub const MAX_LINKS: usize = 16;

/// `O_NONBLOCK` of `open(2)` (without the `libc` crate): opening a FIFO for reading with it
/// returns at once instead of waiting for a writer. Zero (no flag) where the value is not
/// known; the file type is checked on the opened handle all the same.
#[cfg(all(
    any(target_os = "linux", target_os = "android"),
    not(any(
        target_arch = "mips",
        target_arch = "mips64",
        target_arch = "sparc",
        target_arch = "sparc64"
    ))
))]
const O_NONBLOCK: i32 = 0o4000;
#[cfg(any(
    target_os = "macos",
    target_os = "ios",
    target_os = "freebsd",
    target_os = "netbsd",
    target_os = "openbsd",
    target_os = "dragonfly"
))]
const O_NONBLOCK: i32 = 0x4;
#[cfg(not(any(
    all(
        any(target_os = "linux", target_os = "android"),
        not(any(
            target_arch = "mips",
            target_arch = "mips64",
            target_arch = "sparc",
            target_arch = "sparc64"
        ))
    ),
    target_os = "macos",
    target_os = "ios",
    target_os = "freebsd",
    target_os = "netbsd",
    target_os = "openbsd",
    target_os = "dragonfly"
)))]
const O_NONBLOCK: i32 = 0;

/// Why a file that is not a regular file cannot be read (its type, in words).
fn not_regular(t: &std::fs::FileType) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "it is a named pipe (FIFO), not a regular file".into();
        }
        if t.is_char_device() {
            return "it is a character device, not a regular file".into();
        }
        if t.is_block_device() {
            return "it is a block device, not a regular file".into();
        }
        if t.is_socket() {
            return "it is a socket, not a regular file".into();
        }
    }
    if t.is_dir() {
        "it is a folder, not a file".into()
    } else {
        "it is not a regular file".into()
    }
}

/// Open `p` for reading if it is a regular file; a FIFO, a device (`/dev/zero`), a folder or
/// a socket is refused at once. The file is opened with `O_NONBLOCK` (a FIFO does not wait
/// for a writer) and its type checked on the opened handle (nothing can swap the path between
/// the check and the read). Every file tandem reads is opened here: scenario, URDF, replay,
/// sweep file, a shard's `sweep.json` and `runs.csv`.
pub fn open_regular(p: &FsPath) -> Result<std::fs::File, String> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(O_NONBLOCK);
    }
    let f = o.open(p).map_err(|e| e.to_string())?;
    let m = f.metadata().map_err(|e| e.to_string())?;
    if !m.is_file() {
        return Err(not_regular(&m.file_type()));
    }
    Ok(f)
}

/// A reader that fails (instead of ending) once more than its limit has been read: a file
/// read as a stream (replay, `runs.csv`) is never read past the limit, and never cut short
/// silently.
pub struct Limited<R> {
    inner: R,
    left: u64,
    limit: u64,
}

impl<R: std::io::Read> std::io::Read for Limited<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let max = (buf.len() as u64).min(self.left.saturating_add(1)) as usize;
        let n = self.inner.read(&mut buf[..max])?;
        if n as u64 > self.left {
            return Err(std::io::Error::other(format!(
                "the file is larger than {}",
                size_text(self.limit)
            )));
        }
        self.left -= n as u64;
        Ok(n)
    }
}

/// `limit` bytes in words (`16 MiB`).
fn size_text(limit: u64) -> String {
    if limit >= 1 << 30 && limit.is_multiple_of(1 << 30) {
        format!("{} GiB", limit >> 30)
    } else if limit >= 1 << 20 {
        format!("{} MiB", limit >> 20)
    } else {
        format!("{limit} bytes")
    }
}

/// [`open_regular`], read through a [`Limited`] reader of `limit` bytes.
pub fn open_limited(p: &FsPath, limit: u64) -> Result<Limited<std::fs::File>, String> {
    Ok(Limited {
        inner: open_regular(p)?,
        left: limit,
        limit,
    })
}

/// Read a UTF-8 regular file (see [`open_regular`]) of at most `limit` bytes (a larger one is
/// refused, never read whole). A leading UTF-8 byte-order mark (some editors write one) is
/// dropped: it is not part of the TOML or the URDF. The scenario, sweep, URDF and shard
/// `sweep.json` readers all read through here.
pub fn read_limited(p: &FsPath, limit: u64) -> Result<String, String> {
    use std::io::Read;
    let f = open_regular(p)?;
    let mut buf = Vec::new();
    f.take(limit + 1)
        .read_to_end(&mut buf)
        .map_err(|e| e.to_string())?;
    if buf.len() as u64 > limit {
        return Err(format!(
            "the file is larger than {} (scenario, sweep and URDF files are far smaller)",
            size_text(limit)
        ));
    }
    let bom = if buf.starts_with(b"\xef\xbb\xbf") {
        3
    } else {
        0
    };
    String::from_utf8(buf.split_off(bom)).map_err(|e| {
        let at = bom + e.utf8_error().valid_up_to();
        format!("the file is not UTF-8 text (invalid byte at offset {at})")
    })
}

/// The inputs of a scenario's run, for [`crate::output::check_replaceable`]: the scenario file
/// and every file the scenario names (any string field `urdf` or `replay`: `arms[0].urdf`,
/// `controller.replay`), resolved as the loaders resolve them (relative to the scenario file's
/// folder). `sc` is the scenario as run (with the command line's overrides); when it does not
/// serialize, the file's own text is read instead.
pub fn inputs<T: Serialize>(src: &Source, sc: &T) -> Vec<crate::output::Input> {
    let doc = toml::Table::try_from(sc)
        .ok()
        .or_else(|| toml::from_str::<toml::Table>(&src.text).ok())
        .unwrap_or_default();
    let mut v: Vec<crate::output::Input> = src
        .file
        .iter()
        .map(|f| crate::output::Input::new("the scenario", f))
        .collect();
    v.extend(named_files(src, &doc, ""));
    v
}

/// The files a scenario document names (see [`inputs`]); `what` prefixes their field paths.
pub fn named_files(src: &Source, doc: &toml::Table, what: &str) -> Vec<crate::output::Input> {
    fn walk(v: &toml::Value, path: &str, out: &mut Vec<(String, String)>) {
        match v {
            toml::Value::Table(t) => {
                for (k, x) in t {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    if let (true, toml::Value::String(f)) = (k == "urdf" || k == "replay", x) {
                        out.push((p.clone(), f.clone()));
                    }
                    walk(x, &p, out);
                }
            }
            toml::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, &format!("{path}[{i}]"), out);
                }
            }
            _ => {}
        }
    }
    let mut found = Vec::new();
    walk(&toml::Value::Table(doc.clone()), "", &mut found);
    found
        .into_iter()
        .map(|(p, f)| crate::output::Input::new(format!("{what}{p}"), resolve_named(src, &f)))
        .collect()
}

/// A file a scenario names, as its loaders resolve it: absolute, or relative to the
/// scenario file's folder.
pub fn resolve_named(src: &Source, f: &str) -> PathBuf {
    let p = FsPath::new(f);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        src.dir.join(p)
    }
}

/// The source of an embedded scenario.
pub fn embedded_source(e: &Embedded) -> Source {
    Source {
        name: e.name.to_string(),
        display: format!("embedded scenario `{}`", e.name),
        text: e.text.to_string(),
        dir: PathBuf::from("."),
        file: None,
    }
}

// ---------------------------------------------------------------------------------------------
// The file's structs.

/// A scenario file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Scenario name (outputs and figure titles); defaults to the file's stem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Free text, shown by `tandem validate` and in the report.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// The arms, in order (arm 1 first).
    pub arms: Vec<ArmConfig>,
    /// The carried object.
    pub object: ObjectParams,
    /// Plant-wide constants.
    #[serde(default)]
    pub plant: PlantConfig,
    /// The desired object path.
    pub path: PathConfig,
    /// Environment disturbance on the object (default: none).
    #[serde(default)]
    pub disturbance: DisturbanceConfig,
    /// Sensor imperfections (default: ideal).
    #[serde(default)]
    pub sensors: SensorsConfig,
    /// The controller (or a torque replay).
    pub controller: ControllerConfig,
    /// The admittance reference generator (default: on, SPEC §3.1 values).
    #[serde(default)]
    pub admittance: AdmittanceConfig,
    /// Timing, start pose, formulation, seed.
    pub run: RunConfig,
    /// Summary metrics.
    #[serde(default)]
    pub metrics: MetricsConfig,
    /// Injected faults for robustness studies (default: none).
    #[serde(default, skip_serializing_if = "FaultsConfig::is_off")]
    pub faults: FaultsConfig,
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

/// Plant-wide constants.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantConfig {
    /// Gravity along −y, m/s².
    #[serde(default = "default_gravity")]
    pub gravity: f64,
    /// Baumgarte drift-control natural frequency, rad/s (0 disables).
    #[serde(default = "default_baumgarte")]
    pub baumgarte: f64,
}

fn default_gravity() -> f64 {
    tandem::model::planar::arm::GRAVITY
}
fn default_baumgarte() -> f64 {
    20.0
}

impl Default for PlantConfig {
    fn default() -> Self {
        PlantConfig {
            gravity: default_gravity(),
            baumgarte: default_baumgarte(),
        }
    }
}

/// Shape of the desired path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PathKind {
    /// [`Path::circle`]: `center`, `radius`, `omega`, `phase`, `theta`.
    Circle,
    /// [`Path::point_to_point`]: `from`, `to`, `t0`, `duration`.
    PointToPoint,
    /// [`Path::lemniscate`]: `center`, `size`, `omega`, `phase`, `theta`.
    Lemniscate,
    /// [`Path::spline`]: `waypoints`.
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
    /// Fields this kind uses (required ones first), for error messages.
    fn fields(self) -> (&'static [&'static str], &'static [&'static str]) {
        match self {
            PathKind::Circle => (&["center", "radius", "omega"], &["phase", "theta"]),
            PathKind::PointToPoint => (&["from", "to", "duration"], &["t0"]),
            PathKind::Lemniscate => (&["center", "size", "omega"], &["phase", "theta"]),
            PathKind::Spline => (&["waypoints"], &[]),
        }
    }
}

/// One spline waypoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Waypoint {
    /// Time, s.
    pub t: f64,
    /// Pose (x, y, θ), (m, m, rad).
    pub pose: [f64; 3],
}

/// The desired path: `kind` plus the fields that kind uses (the others must be absent).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathConfig {
    /// Shape.
    pub kind: PathKind,
    /// Centre (circle, lemniscate), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center: Option<[f64; 2]>,
    /// Radius (circle), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Half-width (lemniscate), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<f64>,
    /// Angular rate (circle, lemniscate), rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
    /// Phase at t = 0 (circle, lemniscate), rad; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase: Option<f64>,
    /// Constant orientation (circle, lemniscate), rad; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
    /// Start pose (point_to_point), (m, m, rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<[f64; 3]>,
    /// End pose (point_to_point), (m, m, rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<[f64; 3]>,
    /// Start time of the motion (point_to_point), s; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t0: Option<f64>,
    /// Duration of the motion (point_to_point), s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub duration: Option<f64>,
    /// Timed waypoints (spline).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waypoints: Option<Vec<Waypoint>>,
}

/// `F_d(t) = a ∘ sin(ω t + φ) − Σ pushes`; everything defaults to zero.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisturbanceConfig {
    /// Sinusoid amplitudes, (N, N, N m).
    #[serde(default)]
    pub amplitude: [f64; 3],
    /// Angular frequencies, rad/s.
    #[serde(default)]
    pub frequency: [f64; 3],
    /// Phases, rad.
    #[serde(default)]
    pub phase: [f64; 3],
    /// Timed pushes (`t0`, `duration`, `wrench` on the object).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pushes: Vec<Push>,
}

/// Sensor imperfections per channel group (the seed is `run.seed`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorsConfig {
    /// Joint-angle encoders, rad.
    #[serde(default)]
    pub encoder_q: ChannelNoise,
    /// Joint-rate channels, rad/s.
    #[serde(default)]
    pub encoder_qd: ChannelNoise,
    /// End-effector force sensors, N.
    #[serde(default)]
    pub force: ChannelNoise,
}

/// Which law drives the joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// iBLF backstepping + adaptive RBF network (SPEC §3.3–3.4).
    Nn,
    /// PD on the object (SPEC §3.5).
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

/// Per-field overrides of the NN preset (absent = the preset's value).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NnOverrides {
    /// `K1` diagonal, 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k1: Option<[f64; 3]>,
    /// `K2` diagonal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k2: Option<[f64; 3]>,
    /// `K_r` diagonal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_r: Option<[f64; 3]>,
    /// Adaptation gains `Θ_j`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<[f64; 3]>,
    /// σ-modification.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<[f64; 3]>,
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
    /// Switching shape.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
}

impl NnOverrides {
    fn is_empty(&self) -> bool {
        *self == NnOverrides::default()
    }
    fn apply(&self, mut g: NnGains<3>) -> NnGains<3> {
        macro_rules! set {
            ($($f:ident),*) => { $( if let Some(v) = &self.$f { g.$f = v.clone(); } )* };
        }
        set!(
            k1, k2, k_r, theta, sigma, varpi, fu_safety, width2, levels, d1, d2, omega
        );
        g
    }
}

/// PD gains (absent = the paper's).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdConfig {
    /// `K_P` diagonal, (N/m, N/m, N m/rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_p: Option<[f64; 3]>,
    /// `K_D` diagonal, (N s/m, N s/m, N m s/rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_d: Option<[f64; 3]>,
}

/// Computed-torque gains (absent = the library's defaults).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CtcConfig {
    /// `K_P` diagonal, 1/s².
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_p: Option<[f64; 3]>,
    /// `K_D` diagonal, 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_d: Option<[f64; 3]>,
    /// Relative error of the nominal model's masses and inertias.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_error: Option<f64>,
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
    /// Known bound of `|F_d,j|` for the NN law's `f^U` (absent: computed from `[disturbance]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disturbance_bound: Option<[f64; 3]>,
    /// Overrides of the NN preset.
    #[serde(default, skip_serializing_if = "NnOverrides::is_empty")]
    pub nn: NnOverrides,
    /// PD gains.
    #[serde(default)]
    pub pd: PdConfig,
    /// Computed-torque gains.
    #[serde(default)]
    pub ctc: CtcConfig,
    /// Torque file of `kind = "replay"` (relative to the scenario file's folder).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay: Option<String>,
    /// How the replayed rows become torques between time stamps: `hold` (default; every row on
    /// the control grid) or `linear` (a log at another rate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay_interpolation: Option<crate::replay::Interpolation>,
    /// Column map of a replayed log from another tool: the time column's name, then one
    /// torque column per joint in the plant's joint order (default: tandem's names, `t` and
    /// `tau_q1…`/`tau1…`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay_columns: Option<Vec<String>>,
}

/// A value given once for both axes, or as `[x, y]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged, expecting = "a number or an array [x, y] of two numbers")]
pub enum PerAxis {
    /// The same value on both axes.
    Both(f64),
    /// `[x, y]`.
    Each([f64; 2]),
}

impl PerAxis {
    fn vector(self) -> Vector2<f64> {
        match self {
            PerAxis::Both(v) => Vector2::repeat(v),
            PerAxis::Each([x, y]) => Vector2::new(x, y),
        }
    }
}

/// The admittance generator (SPEC §3.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdmittanceConfig {
    /// `false` bypasses the generator (`x_r = x_d`).
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Virtual mass `M_e`, kg (0: the paper's first-order form, warned).
    #[serde(default = "default_m_e")]
    pub m_e: PerAxis,
    /// Virtual damping `C_e`, N s/m.
    #[serde(default = "default_c_e")]
    pub c_e: PerAxis,
    /// Virtual stiffness `K_e`, N/m.
    #[serde(default = "default_k_e")]
    pub k_e: PerAxis,
    /// Force low-pass time constant `τ_f`, s.
    #[serde(default = "default_tau_f")]
    pub tau_f: PerAxis,
}

fn yes() -> bool {
    true
}
fn default_m_e() -> PerAxis {
    PerAxis::Both(200.0)
}
fn default_c_e() -> PerAxis {
    PerAxis::Both(626.0)
}
fn default_k_e() -> PerAxis {
    PerAxis::Both(1000.0)
}
fn default_tau_f() -> PerAxis {
    PerAxis::Both(0.01)
}

impl Default for AdmittanceConfig {
    fn default() -> Self {
        AdmittanceConfig {
            enabled: true,
            m_e: default_m_e(),
            c_e: default_c_e(),
            k_e: default_k_e(),
            tau_f: default_tau_f(),
        }
    }
}

/// Timing, start and determinism.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Simulated time, s.
    pub duration: f64,
    /// Plant RK4 step, s.
    pub plant_step: f64,
    /// Control period, s (a whole multiple of `plant_step`).
    pub control_period: f64,
    /// Logging period, s (a whole multiple of `control_period`).
    pub log_period: f64,
    /// Object start pose at rest, (m, m, rad).
    pub start: [f64; 3],
    /// `constrained` (default) or `reduced`.
    #[serde(default)]
    pub formulation: Formulation,
    /// Seed of every random stream (sensor noise and dropout).
    #[serde(default)]
    pub seed: u64,
    /// Largest grasp-constraint drift before the run stops, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_drift: Option<f64>,
    /// Smallest arm-Jacobian singular value before the run stops, m/rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_sigma: Option<f64>,
}

/// Summary metrics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricsConfig {
    /// Start of the "after the transient" window, s.
    #[serde(default = "default_transient")]
    pub transient: f64,
}

fn default_transient() -> f64 {
    5.0
}

impl Default for MetricsConfig {
    fn default() -> Self {
        MetricsConfig {
            transient: default_transient(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Errors.

/// A problem with a scenario: where (file, field path, line and column) and why.
#[derive(Debug, Clone)]
pub struct ScenarioError {
    /// The file (or `embedded scenario `name``).
    pub file: String,
    /// The message, including the field path.
    pub message: String,
    /// Byte range in the text, if known.
    pub span: Option<Range<usize>>,
    /// The text (for line, column and the source excerpt).
    pub text: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // A message may quote the input (a value, a key): never more than a line of it.
        write!(f, "{}: {}", self.file, clip_middle(&self.message, 300, 100))?;
        if let Some(span) = &self.span
            && let Some(snippet) = excerpt(&self.text, span.clone())
        {
            write!(f, "\n{snippet}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ScenarioError {}

/// A number for a message: shortest round-trip form, with an exponent outside
/// [1e-4, 1e6) (`1e9`, `1.7e96`, `-2.5e-7`), never hundreds of digits.
pub fn num(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 || (1e-4..1e6).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// 1-based (line, column) of a byte offset (column in characters).
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..floor_char(text, offset)];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

fn floor_char(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// ` (line L, column C)` for a span.
fn at_line(text: &str, span: &Option<Range<usize>>) -> String {
    match span {
        Some(s) => {
            let (l, c) = line_col(text, s.start);
            format!(" (line {l}, column {c})")
        }
        None => String::new(),
    }
}

/// Characters of a source line shown before and after the error's column.
const CONTEXT_BEFORE: usize = 40;
/// See [`CONTEXT_BEFORE`].
const CONTEXT_AFTER: usize = 60;

/// The source line of `span` with carets under it, rustc style; a long line is cut to
/// [`CONTEXT_BEFORE`] + [`CONTEXT_AFTER`] characters around the span (`…` marks the cuts).
fn excerpt(text: &str, span: Range<usize>) -> Option<String> {
    if text.is_empty() {
        return None;
    }
    let start = floor_char(text, span.start.min(text.len()));
    let (line, _) = line_col(text, start);
    // The line's bounds by search from the span (never a scan of the whole text's lines).
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let src = text[line_start..line_end].trim_end_matches('\r');
    let col = text[line_start..start].chars().count();
    let width = text[start..floor_char(text, span.end.clamp(start, line_end))]
        .chars()
        .count()
        .clamp(1, CONTEXT_AFTER);
    // The window [from, from + shown) of the line's characters.
    let from = col.saturating_sub(CONTEXT_BEFORE);
    let shown: String = src
        .chars()
        .skip(from)
        .take(CONTEXT_BEFORE + CONTEXT_AFTER)
        .collect();
    let cut_left = from > 0;
    let cut_right = src.chars().count() > from + CONTEXT_BEFORE + CONTEXT_AFTER;
    let n = line.to_string();
    let pad = " ".repeat(n.len());
    Some(format!(
        "{pad} |\n{n} | {}{shown}{}\n{pad} | {}{}",
        if cut_left { "…" } else { "" },
        if cut_right { "…" } else { "" },
        " ".repeat(col - from + usize::from(cut_left)),
        "^".repeat(width)
    ))
}

/// `s` cut to its first `head` and last `tail` characters (with `…` between) when longer: a
/// message that quotes a huge value keeps its start and its place (`(line L, column C)`).
pub fn clip_middle(s: &str, head: usize, tail: usize) -> String {
    let n = s.chars().count();
    if n <= head + tail + 1 {
        return s.to_string();
    }
    let a: String = s.chars().take(head).collect();
    let b: String = s.chars().skip(n - tail).collect();
    format!("{a}…{b}")
}

/// A value echoed in a message: whole up to 200 characters, else its first 200 and its length
/// (`xxxx… (10000000 chars)`), so that a message about a huge value is not itself huge.
pub fn echo(s: &str) -> String {
    let n = s.chars().count();
    if n <= 200 {
        s.to_string()
    } else {
        let head: String = s.chars().take(200).collect();
        format!("{head}… ({n} chars)")
    }
}

/// `s` cut to at most `n` characters (with `…`), for messages that echo the input.
pub fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut c: String = s.chars().take(n).collect();
        c.push('…');
        c
    }
}

impl Source {
    /// An error at a field path (its span looked up in the text when the field is there).
    pub fn error_at(&self, path: &str, message: impl Into<String>) -> ScenarioError {
        let (span, exact) = match span_of(&self.text, path) {
            Some((s, e)) => (Some(s), e),
            None => (None, false),
        };
        let mut message = message.into();
        if !exact && !path.is_empty() {
            message.push_str(" (not set in the file: a default or preset value)");
        }
        let message = format!("{message}{}", at_line(&self.text, &span));
        ScenarioError {
            file: self.display.clone(),
            message,
            span,
            text: self.text.clone(),
        }
    }

    /// A warning about the field at `path`: `path: text (line L)`, or `(preset or default
    /// value, not set in the file)` when the file does not set it.
    pub fn warning_at(&self, path: &str, text: &str) -> String {
        let body = text
            .strip_prefix(path)
            .map_or(text, |r| r.trim_start_matches([':', ' ']));
        let body = if text.starts_with(path) && !text[path.len()..].starts_with(':') {
            // `admittance.m_e[0] = 0 selects ...`: keep the sentence whole.
            text
        } else {
            body
        };
        let place = match span_of(&self.text, path) {
            Some((s, true)) => {
                let (l, _) = line_col(&self.text, s.start);
                format!(" ({}, line {l})", self.display)
            }
            _ => " (preset or default value, not set in the file)".to_string(),
        };
        if body.starts_with(path) {
            format!("{body}{place}")
        } else {
            format!("{path}: {body}{place}")
        }
    }

    /// A library validation error, its parameter path mapped to the file's by `map`.
    pub fn model_error(&self, e: ModelError, map: impl Fn(&str) -> String) -> ScenarioError {
        match e {
            ModelError::Invalid {
                param,
                value,
                reason,
            } => {
                let path = map(&param);
                self.error_at(&path, format!("{path} = {}: {reason}", num(value)))
            }
            // The kernel comes from the environment, not from the file: no field, no line.
            ModelError::Geometry { what, reason } if what == tandem::control::rbf::KERNEL_ENV => {
                self.error_at("", format!("environment variable {what}: {reason}"))
            }
            ModelError::Geometry { what, reason } => {
                let path = map(&what);
                self.error_at(&path, format!("{path}: {reason}"))
            }
            other => self.error_at("", other.to_string()),
        }
    }
}

/// Path segments of `a.b[1].c`.
fn segments(path: &str) -> Vec<Result<String, usize>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|s| !s.is_empty()) {
        let mut rest = part;
        if let Some(i) = rest.find('[') {
            if i > 0 {
                out.push(Ok(rest[..i].to_string()));
            }
            rest = &rest[i..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let Some(end) = stripped.find(']') else { break };
                if let Ok(k) = stripped[..end].parse() {
                    out.push(Err(k));
                }
                rest = &stripped[end + 1..];
            }
        } else {
            out.push(Ok(rest.to_string()));
        }
    }
    out
}

/// The span of the value at `path` (or of its nearest ancestor present in the file, with
/// `false`).
pub fn span_of(text: &str, path: &str) -> Option<(Range<usize>, bool)> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let segs = segments(path);
    let mut best: Option<Range<usize>> = None;
    let mut table: Option<&DeTable> = Some(root.get_ref());
    let mut value: Option<&DeValue> = None;
    for (i, seg) in segs.iter().enumerate() {
        // A scalar given for a per-axis value (`m_e = 200` for `m_e[1]`) is the value itself.
        if let (Err(_), Some(v)) = (seg, value)
            && !v.is_array()
            && segs[i..].iter().all(|s| s.is_err())
        {
            return best.map(|b| (b, true));
        }
        let next = match (seg, value, table) {
            (Ok(key), _, Some(t)) => t
                .iter()
                .find(|(k, _)| k.get_ref().as_ref() == key.as_str())
                .map(|(_, v)| v),
            (Err(k), Some(v), _) => v.as_array().and_then(|a| a.get(*k)),
            _ => None,
        };
        match next {
            Some(v) => {
                best = Some(v.span());
                value = Some(v.get_ref());
                table = v.get_ref().as_table();
            }
            None => return best.map(|b| (b, false)),
        }
    }
    best.map(|b| (b, true))
}

/// Parse a scenario's text.
pub fn parse(src: &Source) -> Result<Scenario, ScenarioError> {
    let sc: Scenario = parse_as(src)?;
    if let Some(n) = &sc.name {
        check_name(src, n)?;
    }
    Ok(sc)
}

/// Parse a TOML text into `T` (planar or spatial scenario): syntax errors and serde errors with
/// the file, line, column, field path and a suggestion for a misspelt field, then the strict
/// array lengths of `check_lengths`.
pub fn parse_as<T: serde::de::DeserializeOwned + Serialize>(
    src: &Source,
) -> Result<T, ScenarioError> {
    let err = |message: String, span: Option<Range<usize>>| ScenarioError {
        file: src.display.clone(),
        message,
        span,
        text: src.text.clone(),
    };
    let de = toml::Deserializer::parse(&src.text).map_err(|e| {
        let span = e.span();
        err(
            format!(
                "TOML syntax error: {}{}",
                e.message().trim_end(),
                at_line(&src.text, &span)
            ),
            span,
        )
    })?;
    let sc = serde_path_to_error::deserialize::<_, T>(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.inner();
        let span = inner.span();
        let msg = inner.message().trim_end().to_string();
        err(describe(&path, &msg, &src.text, &span), span)
    })?;
    check_lengths(src, &sc)?;
    Ok(sc)
}

/// A scenario `name` becomes part of the default output folder `out/<name>-...`: it must be a
/// plain name (no path separators, not `.` or `..`, no leading dot, no control characters, at
/// most 100 characters), so the folder stays inside `out/`.
pub fn check_name(src: &Source, n: &str) -> Result<(), ScenarioError> {
    let why = if n.trim().is_empty() {
        None
    } else if n.contains('/') || n.contains('\\') {
        Some("must not contain a path separator (it names the output folder out/<name>-...)")
    } else if n.starts_with('.') {
        Some("must not start with a dot (it names the output folder out/<name>-...)")
    } else if n.chars().any(char::is_control) {
        Some("must not contain control characters")
    } else if n.chars().count() > 100 {
        Some("must be at most 100 characters")
    } else {
        None
    };
    match why {
        None => Ok(()),
        Some(w) => Err(src.error_at("name", format!("name = {:?}: {w}", clip(n, 60)))),
    }
}

/// Every array in the file has exactly the length of the field it fills: serde reads the first
/// N entries of a fixed-size array and ignores the rest (`base = [-0.38, 0.0, 99.0, "x"]` was
/// read as `[-0.38, 0.0]`). The parsed scenario is written back and every array of the file
/// compared with the one at the same path, whatever struct (the CLI's or the library's) it
/// filled.
fn check_lengths<T: Serialize>(src: &Source, sc: &T) -> Result<(), ScenarioError> {
    use toml::de::DeValue;
    first_in_file(src, sc, &mut |path, v, back| match (v.get_ref(), back) {
        (DeValue::Array(a), toml::Value::Array(b)) if a.len() != b.len() => Some(format!(
            "{path} has {} entries; it takes exactly {}",
            a.len(),
            b.len()
        )),
        _ => None,
    })
}

/// A number that is not finite (`nan`, `inf`) anywhere in the file's known fields, also in a
/// section the run does not use (the gains of another law, which `tandem compare` would use),
/// is an error naming the field. Run after the field-specific checks, whose messages say more.
pub(crate) fn check_finite<T: Serialize>(src: &Source, sc: &T) -> Result<(), ScenarioError> {
    first_in_file(src, sc, &mut |path, _, back| match back {
        toml::Value::Float(x) if !x.is_finite() => {
            Some(format!("{path} = {}: must be a finite number", num(*x)))
        }
        _ => None,
    })
}

/// What [`first_in_file`] asks of each field: `(path, the value in the file, the value as read)`
/// → an error message, or `None` to go on.
type Visit<'v> =
    dyn FnMut(&str, &toml::Spanned<toml::de::DeValue<'_>>, &toml::Value) -> Option<String> + 'v;

/// Walks the fields the file sets together with their values as read (`sc` serialized back),
/// depth first in the file's order, and returns the first for which `visit(path, in the file,
/// as read)` gives a message as an error at that field.
fn first_in_file<T: Serialize>(
    src: &Source,
    sc: &T,
    visit: &mut Visit<'_>,
) -> Result<(), ScenarioError> {
    use toml::de::{DeTable, DeValue};
    let Ok(back) = toml::Value::try_from(sc) else {
        return Ok(());
    };
    let Ok(root) = DeTable::parse(&src.text) else {
        return Ok(());
    };
    fn walk(
        path: &str,
        v: &toml::Spanned<DeValue<'_>>,
        back: &toml::Value,
        visit: &mut Visit<'_>,
    ) -> Option<(String, Range<usize>)> {
        if let Some(m) = visit(path, v, back) {
            return Some((m, v.span()));
        }
        match (v.get_ref(), back) {
            (DeValue::Array(a), toml::Value::Array(b)) => a
                .iter()
                .zip(b.iter())
                .enumerate()
                .find_map(|(i, (x, y))| walk(&format!("{path}[{i}]"), x, y, visit)),
            (DeValue::Table(t), toml::Value::Table(b)) => t.iter().find_map(|(k, x)| {
                let key = k.get_ref().as_ref();
                let y = b.get(key)?;
                let p = if path.is_empty() {
                    key.to_string()
                } else {
                    format!("{path}.{key}")
                };
                walk(&p, x, y, visit)
            }),
            _ => None,
        }
    }
    let toml::Value::Table(b) = &back else {
        return Ok(());
    };
    let found = root.get_ref().iter().find_map(|(k, x)| {
        let key = k.get_ref().as_ref();
        walk(key, x, b.get(key)?, visit)
    });
    match found {
        None => Ok(()),
        Some((message, span)) => Err(ScenarioError {
            file: src.display.clone(),
            message: format!("{message}{}", at_line(&src.text, &Some(span.clone()))),
            span: Some(span),
            text: src.text.clone(),
        }),
    }
}

/// Turn serde's message and path into a sentence with the place and a suggestion.
fn describe(path: &str, msg: &str, text: &str, span: &Option<Range<usize>>) -> String {
    let place = at_line(text, span);
    let parent = |p: &str| -> String {
        // The path of an unknown field ends with the field itself.
        let cut = p.rfind('.').unwrap_or(0);
        let parent = &p[..cut];
        if parent.is_empty() || parent == "." {
            "the top level".to_string()
        } else {
            parent.to_string()
        }
    };
    let ticks: Vec<&str> = msg.split('`').skip(1).step_by(2).collect();
    if msg.starts_with("unknown field ") {
        let name = ticks.first().copied().unwrap_or("");
        let expected: Vec<&str> = ticks.iter().skip(1).copied().collect();
        let mut s = format!("unknown field `{name}` at {}{place}", parent(path));
        match suggest::closest(name, expected.iter().copied()) {
            Some(c) => s.push_str(&format!(" — did you mean `{c}`?")),
            None if !expected.is_empty() => s.push_str(&format!(
                "; expected one of {}",
                expected
                    .iter()
                    .map(|e| format!("`{e}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            None => s.push_str("; this table takes no fields"),
        }
        return s;
    }
    if msg.starts_with("unknown variant ") {
        let name = ticks.first().copied().unwrap_or("");
        let expected: Vec<&str> = ticks.iter().skip(1).copied().collect();
        let mut s = format!("unknown value \"{name}\" for {path}{place}");
        if let Some(c) = suggest::closest(name, expected.iter().copied()) {
            s.push_str(&format!(" — did you mean \"{c}\"?"));
        } else {
            s.push_str(&format!(
                "; expected one of {}",
                expected
                    .iter()
                    .map(|e| format!("\"{e}\""))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        return s;
    }
    if msg.starts_with("missing field ") {
        let name = ticks.first().copied().unwrap_or("");
        let at = if path.is_empty() || path == "." {
            "the top level".to_string()
        } else {
            path.to_string()
        };
        return format!("missing field `{name}` in {at}{place}");
    }
    let at = if path.is_empty() || path == "." {
        String::new()
    } else {
        format!(" at {path}")
    };
    format!("{msg}{at}{place}")
}

// ---------------------------------------------------------------------------------------------
// Command-line overrides.

/// What the command line changes in a scenario before it is built.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// `--controller`.
    pub controller: Option<ControllerKind>,
    /// `--gains`.
    pub gains: Option<GainPreset>,
    /// `--duration`.
    pub duration: Option<f64>,
    /// `--replay` (a path relative to the current folder).
    pub replay: Option<PathBuf>,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--replay-interpolation`.
    pub replay_interpolation: Option<crate::replay::Interpolation>,
    /// `--replay-columns`.
    pub replay_columns: Option<Vec<String>>,
}

impl Scenario {
    /// Apply command-line overrides; errors are bad input (exit code 2).
    pub fn apply(&mut self, o: &Overrides) -> Result<(), crate::BadInput> {
        if let Some(k) = o.controller {
            self.controller.kind = k;
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
            ..d
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
    pub fn resolved(&self) -> Scenario {
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
        };
        let ctc = self.ctc_gains();
        c.ctc = CtcConfig {
            k_p: Some(ctc.k_p),
            k_d: Some(ctc.k_d),
            model_error: Some(ctc.model_error),
        };
        if c.disturbance_bound.is_none() {
            c.disturbance_bound = Some(disturbance(&self.disturbance).bound());
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

fn disturbance(d: &DisturbanceConfig) -> Disturbance {
    Disturbance {
        amplitude: d.amplitude,
        frequency: d.frequency,
        phase: d.phase,
        pushes: d.pushes.clone(),
    }
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
    mode: Option<crate::replay::Interpolation>,
    columns: Option<&[String]>,
) -> Result<Replay, ScenarioError> {
    let timing = crate::replay::Timing {
        control_period: sim.control_period,
        duration: sim.duration,
    };
    crate::replay::load(file, n_q, timing, mode.unwrap_or_default(), columns).map_err(|e| {
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
    })
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
pub fn build(sc: &Scenario, src: &Source) -> Result<Built, ScenarioError> {
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
        object: sc.object.clone(),
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
    let disturbance = disturbance(&sc.disturbance);
    disturbance
        .validate()
        .map_err(|e| src.model_error(e, |p| p.to_string()))?;
    let sensors = SensorParams {
        encoder_q: sc.sensors.encoder_q,
        encoder_qd: sc.sensors.encoder_qd,
        force: sc.sensors.force,
        torque: Default::default(),
        seed: sc.run.seed,
    };
    sensors
        .validate()
        .map_err(|e| src.model_error(e, |p| format!("sensors.{p}")))?;

    // Run settings (the library checks the period ratios).
    let d = SimParams::paper();
    let sim = SimParams {
        duration: sc.run.duration,
        plant_step: sc.run.plant_step,
        control_period: sc.run.control_period,
        log_period: sc.run.log_period,
        start: sc.run.start,
        formulation: sc.run.formulation,
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
        control_period: sc.run.control_period,
        torque_limit: c.torque_limit,
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
    let truth = (fc.payload_mass != 1.0 || fc.payload_inertia != 1.0).then(|| {
        let mut t = plant.clone();
        t.object.inertia[0] *= fc.payload_mass;
        t.object.inertia[1] *= fc.payload_mass;
        t.object.inertia[2] *= fc.payload_inertia;
        t.object.gravity = t.object.gravity.map(|g| g * fc.payload_mass);
        t
    });
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

fn c_admittance(a: &AdmittanceConfig) -> Option<AdmittanceParams> {
    a.enabled.then(|| AdmittanceParams {
        m_e: a.m_e.vector(),
        c_e: a.c_e.vector(),
        k_e: a.k_e.vector(),
        tau_f: a.tau_f.vector(),
    })
}

fn build_path(p: &PathConfig, src: &Source) -> Result<Path, ScenarioError> {
    let kind = p.kind;
    let (required, optional) = kind.fields();
    let present: Vec<(&str, bool)> = vec![
        ("center", p.center.is_some()),
        ("radius", p.radius.is_some()),
        ("size", p.size.is_some()),
        ("omega", p.omega.is_some()),
        ("phase", p.phase.is_some()),
        ("theta", p.theta.is_some()),
        ("from", p.from.is_some()),
        ("to", p.to.is_some()),
        ("t0", p.t0.is_some()),
        ("duration", p.duration.is_some()),
        ("waypoints", p.waypoints.is_some()),
    ];
    for (name, set) in &present {
        let used = required.contains(name) || optional.contains(name);
        if *set && !used {
            return Err(src.error_at(
                &format!("path.{name}"),
                format!(
                    "path.{name} is not used by kind = \"{}\" (it takes {})",
                    kind.name(),
                    required
                        .iter()
                        .chain(optional.iter())
                        .map(|f| format!("`{f}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        if !*set && required.contains(name) {
            return Err(src.error_at(
                "path",
                format!(
                    "missing field `{name}` in path: kind = \"{}\" needs {}",
                    kind.name(),
                    required
                        .iter()
                        .map(|f| format!("`{f}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
    }
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

/// Build the driver (controller or replay) and the simulation: every library validation.
pub fn make_simulation(sc: &Scenario, b: &Built, src: &Source) -> Result<Ready, ScenarioError> {
    let mut warnings = Vec::new();
    let driver = match &b.controller {
        Some(cp) => {
            let (c, w) = Controller::new(cp, &b.plant, b.path.clone(), b.sim.duration)
                .map_err(|e| src.model_error(e, controller_path(sc.controller.kind)))?;
            let map = controller_path(sc.controller.kind);
            warnings.extend(w.iter().map(|w| control_warning(src, w, &map)));
            // The start must be inside the output bounds the controller keeps (iBLF: |x_1j| < k_cj).
            if sc.controller.kind != ControllerKind::Replay {
                let unit = ["m", "m", "rad"];
                for j in 0..3 {
                    let (x, k) = (sc.run.start[j], sc.controller.k_c[j]);
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
    Ok(Ready { sim, warnings })
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
        for e in EMBEDDED {
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
