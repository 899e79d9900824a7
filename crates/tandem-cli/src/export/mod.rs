//! `tandem export`: a spatial scenario's set-up for another simulator (issue 23).
//!
//! [`setup`] builds and validates the scenario exactly as `tandem run` does
//! ([`crate::run::spatial::prepare`]: the URDFs parsed into tandem's chains, the bases, the
//! grasps, the box, the start pose with the arms' joints solved on it) and reads what another
//! simulator needs off the built plant, not off the scenario's text. [`mjcf`] writes it as a
//! MuJoCo model, [`json`] as plain facts for any other tool (Drake, Pinocchio, Isaac).
//!
//! A planar scenario is refused: its plant is a model in the plane (x, y, θ) with no URDF and
//! no SE(3) frames, so neither format's facts exist for it.

pub mod json;
pub mod mjcf;

use std::path::PathBuf;

use anyhow::{Context, Result};
use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
use tandem::dynamics::spatial::{ChainData, kinematics};
use tandem::model::spatial::{Chain, SpatialObjectParams};
use tandem::plant::spatial::GraspModel;

use crate::BadInput;
use crate::run::spatial::prepare;
use crate::scenario::spatial::{self as spatial_scenario, SpatialScenario};
use crate::scenario::{Scenario, Source, read_limited};

/// The text every exported file carries near its start (MJCF: the first comment; JSON: the
/// `written_by` field): `--force` replaces only a file that has it ([`WRITTEN_MARKS`]).
pub const WRITTEN_BY: &str = "tandem export";

/// What `--force` looks for in the first bytes of an existing file before replacing it: the
/// MJCF's first comment or the JSON's `written_by` field.
pub const WRITTEN_MARKS: &[&str] = &[
    "<!-- written by tandem export",
    "\"written_by\": \"tandem export",
];

/// The export formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// A MuJoCo model (MJCF XML): arms, box, welds, start keyframe, torque motors.
    Mjcf,
    /// The set-up's facts as JSON, for any other tool.
    Json,
}

impl Format {
    /// The format's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Format::Mjcf => "mjcf",
            Format::Json => "json",
        }
    }

    /// The format a file name's extension implies (`.xml`, `.mjcf` → MJCF; `.json` → JSON).
    pub fn of_path(p: &std::path::Path) -> Option<Format> {
        let ext = p.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "xml" | "mjcf" => Some(Format::Mjcf),
            "json" => Some(Format::Json),
            _ => None,
        }
    }

    /// The format to write: `--format` if given, else the one `--out`'s extension implies,
    /// else MJCF. A `--format` that contradicts the extension is refused (a `scene.json` full
    /// of XML helps nobody).
    pub fn resolve(
        given: Option<Format>,
        out: Option<&std::path::Path>,
    ) -> Result<Format, BadInput> {
        let implied = out.and_then(Format::of_path);
        match (given, implied) {
            (Some(g), Some(i)) if g != i => Err(BadInput::msg(format!(
                "--format {} but --out {} names a .{} file: give the one or rename the other",
                g.name(),
                out.map(|p| p.display().to_string()).unwrap_or_default(),
                if i == Format::Json { "json" } else { "xml" }
            ))),
            (Some(g), _) => Ok(g),
            (None, Some(i)) => Ok(i),
            (None, None) => Ok(Format::Mjcf),
        }
    }
}

/// One arm of the set-up.
#[derive(Clone, Debug)]
pub struct ArmSetup {
    /// The chain as tandem parsed it from the URDF (fixed joints merged): what the plant
    /// simulates.
    pub chain: Chain,
    /// `X_WB`: the base frame in the world.
    pub base: Isometry3<f64>,
    /// `X_OG`: the grasp frame in the object frame (the tool frame is welded onto it).
    pub grasp: Isometry3<f64>,
    /// The embedded model's name (`ur5`, `franka`), `None` for a URDF file.
    pub model: Option<&'static str>,
    /// The URDF file (absolute), `None` for an embedded model.
    pub urdf_path: Option<PathBuf>,
    /// The URDF text.
    pub urdf: String,
    /// The start joint angles (rad, m), base to tool: solved by tandem's IK on the start pose.
    pub q0: Vec<f64>,
    /// `X_WT` at the start (tandem's forward kinematics at `q0`).
    pub tool_pose: Isometry3<f64>,
    /// Joint torques that hold the start at rest (the arms share the object's weight, no
    /// internal wrench), N m.
    pub holding: Vec<f64>,
    /// The grasp wrench those torques balance: the object's wrench on the tool, about the tool
    /// origin, in tool axes, `[f; τ]` (N, N m).
    pub holding_wrench: Vector6<f64>,
}

/// A spatial scenario's set-up, built and validated, at its start.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The scenario's name.
    pub name: String,
    /// Its description.
    pub description: String,
    /// The arms, in the scenario's order.
    pub arms: Vec<ArmSetup>,
    /// Box edge lengths along the object axes, m.
    pub size: [f64; 3],
    /// Mass, inertia about the centre (object axes), damping (world axes on `[v; ω]`).
    pub object: SpatialObjectParams,
    /// `X_WO` at the start (the path at t = 0 with the scenario's start offset).
    pub object_pose: Isometry3<f64>,
    /// Gravity, world axes, m/s².
    pub gravity: Vector3<f64>,
    /// The plant's weld drift control (Baumgarte ω, rad/s).
    pub baumgarte: f64,
    /// Welds or compliant grasps.
    pub grasp_model: GraspModel,
    /// Pads that only gauge the welds or springs (`gauge_only = true`): no physics, exported
    /// so that a peer can report the same cone margins.
    pub pad_gauge: Option<tandem::plant::spatial::ContactParams>,
    /// The plant's RK4 step, s.
    pub plant_step: f64,
    /// The control period (torques held over it), s.
    pub control_period: f64,
    /// The log period, s.
    pub log_period: f64,
    /// The run's duration, s.
    pub duration: f64,
    /// The scenario as resolved (sensor models, disturbance, seed are read from it).
    pub scenario: SpatialScenario,
    /// Largest weld residual at the start in tandem: (m, rad).
    pub residual: (f64, f64),
    /// The set-up's warnings (URDF, plausibility, gains).
    pub warnings: Vec<String>,
}

impl Setup {
    /// Joint count of all arms.
    pub fn n_q(&self) -> usize {
        self.arms.iter().map(|a| a.chain.dof()).sum()
    }
}

/// The refusal for a planar scenario, whatever the format.
pub fn planar_refusal(src: &Source, format: Format) -> BadInput {
    BadInput::msg(format!(
        "planar export: {} is a planar scenario; `tandem export --format {}` writes spatial \
         scenarios only (arms from URDF in SE(3): `dual-ur5`, `dual-franka`, or a file whose \
         arms name `model` or `urdf`). A planar plant lives in the plane (x, y, θ) with no URDF \
         and no 3-D frames, so the exported facts (URDF chains, poses, quaternions, welds) do \
         not exist for it",
        src.display,
        format.name()
    ))
}

/// Build, validate and solve the start of a spatial scenario (exactly as `tandem run` does),
/// and read the set-up off the built plant.
pub fn setup(sc: Scenario, src: &Source, format: Format) -> Result<Setup> {
    let sc = match sc {
        Scenario::Planar(_) => return Err(planar_refusal(src, format).into()),
        Scenario::Spatial(sc) => sc,
    };
    let p = prepare(sc, src)?;
    let (plant, y) = p.ready.sim.plant_state();
    let (q, o, _) = plant.split(y);
    let x_wo = o.pose();
    let mut ws = plant.workspace();
    let residual = plant.constraint_residual(y, &mut ws);
    let mut holding = vec![0.0; plant.n_q()];
    plant.holding_torques(y, &mut ws, &mut holding);
    let mut arms = Vec::with_capacity(plant.arms().len());
    for (i, arm) in plant.arms().iter().enumerate() {
        let s = plant.offset(i);
        let n = arm.chain.dof();
        let mut d = ChainData::new(arm);
        kinematics(arm, &q[s..s + n], None, &mut d);
        let cfg = &p.sc.arms[i];
        let (model, urdf_path, urdf) = match (&cfg.model, &cfg.urdf) {
            (Some(m), _) => (
                Some(spatial_scenario::serde_name(m)),
                None,
                m.text().to_string(),
            ),
            (None, Some(f)) => {
                // `prepare` made the path absolute (relative to the scenario's folder).
                let path = PathBuf::from(f);
                let text = read_limited(&path, spatial_scenario::MAX_URDF_BYTES)
                    .map_err(anyhow::Error::msg)
                    .with_context(|| format!("arms[{i}].urdf: cannot read {}", path.display()))?;
                (None, Some(path), text)
            }
            (None, None) => unreachable!("the builder refuses an arm without a model"),
        };
        arms.push(ArmSetup {
            chain: arm.chain.clone(),
            base: arm.base,
            grasp: plant.grasps()[i],
            model,
            urdf_path,
            urdf,
            q0: q[s..s + n].to_vec(),
            tool_pose: d.X_WT,
            holding: holding[s..s + n].to_vec(),
            holding_wrench: ws.tool_wrench(i),
        });
    }
    let b = &p.built;
    Ok(Setup {
        name: p.name.clone(),
        description: p.sc.description.clone(),
        arms,
        size: b.box_size,
        object: b.plant.object.clone(),
        object_pose: x_wo,
        gravity: b.plant.gravity,
        baumgarte: b.plant.baumgarte,
        grasp_model: b.plant.grasp_model.clone(),
        pad_gauge: b.plant.pad_gauge.clone(),
        plant_step: b.sim.plant_step,
        control_period: b.sim.control_period,
        log_period: b.sim.log_period,
        duration: b.sim.duration,
        residual,
        warnings: p.ready.warnings.clone(),
        scenario: p.sc,
    })
}

/// The set-up in `format`.
pub fn render(s: &Setup, format: Format) -> Result<String> {
    match format {
        Format::Mjcf => mjcf::write(s).map_err(|e| anyhow::Error::new(BadInput::msg(e))),
        Format::Json => Ok(json::write(s)),
    }
}

/// `[w, x, y, z]` of a rotation, with `w ≥ 0` (the same rotation; one sign for every reader).
pub fn wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    let c = q.coords; // (x, y, z, w)
    let s = if c.w < 0.0 { -1.0 } else { 1.0 };
    [s * c.w, s * c.x, s * c.y, s * c.z]
}
