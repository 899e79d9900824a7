//! Scenario files: what a run simulates, in TOML, planar or spatial.
//!
//! [`source`] is the foot (where the text comes from, what an error says); [`planar`] and
//! [`spatial`] are the two kinds' documents and their builders; [`replay`] reads a torque file;
//! [`standalone`] builds a scenario's controller alone, to be stepped by a caller (Python).

pub mod planar;
pub mod replay;
pub mod source;
pub mod spatial;
pub mod standalone;
pub mod tables;

pub use source::*;

use std::path::PathBuf;

/// Farthest a grasp frame may sit from the box's surface before a warning, m (a gripper's pads
/// are millimetres thick; a flange frame a gripper's length away is worth saying).
pub const GRASP_SURFACE_TOL: f64 = 0.01;
/// Smallest distance between two arms' bases before a warning, m (two bases closer than a base
/// plate's radius are the same robot twice).
pub const BASE_SEPARATION_MIN: f64 = 0.1;

/// The implausible-set-up warning both loaders give for arms whose bases stand less than
/// [`BASE_SEPARATION_MIN`] apart (base positions in m, planar ones with z = 0), naming the
/// later arm's `base` with its line; `why` ends the message.
pub fn base_overlaps(src: &Source, bases: &[[f64; 3]], why: &str) -> Vec<String> {
    let mut out = Vec::new();
    for i in 0..bases.len() {
        for j in i + 1..bases.len() {
            let d = (0..3)
                .map(|k| (bases[i][k] - bases[j][k]).powi(2))
                .sum::<f64>()
                .sqrt();
            if d < BASE_SEPARATION_MIN {
                let at = format!("arms[{j}].base");
                out.push(src.warning_at(
                    &at,
                    &format!(
                        "{at}: the base stands {} m from arms[{i}]'s: the two arms overlap{why}",
                        num_short(d)
                    ),
                ));
            }
        }
    }
    out
}

pub use planar::PlanarScenario;
pub use spatial::SpatialScenario;
pub use tables::{ControllerChoice, ControllerKind};

/// A parsed scenario of either kind; the one place where planar or spatial is decided
/// ([`load`]). Commands, sweeps, robustness and the Python package take it and match once.
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // parsed once per run
pub enum Scenario {
    /// Arms in the plane (SPEC).
    Planar(PlanarScenario),
    /// 6/7-DOF arms from URDF in SE(3) (SPEC-spatial).
    Spatial(SpatialScenario),
}

impl Scenario {
    /// Planar or spatial.
    pub fn kind(&self) -> Kind {
        match self {
            Scenario::Planar(_) => Kind::Planar,
            Scenario::Spatial(_) => Kind::Spatial,
        }
    }

    /// The name the file gives itself (`name = "..."`), if any and not blank.
    pub fn name(&self) -> Option<&str> {
        let n = match self {
            Scenario::Planar(s) => s.name.as_deref(),
            Scenario::Spatial(s) => s.name.as_deref(),
        };
        n.filter(|n| !n.trim().is_empty())
    }
}

/// The kind of a scenario's text, from its parsed document ([`Kind::of`]); text that is not
/// TOML is planar (whose parser then reports the syntax error with its line).
pub fn kind_of(src: &Source) -> Kind {
    toml::from_str::<toml::Table>(&src.text)
        .map(|doc| Kind::of(&doc))
        .unwrap_or(Kind::Planar)
}

/// Parse a scenario of either kind (syntax, fields, strict lengths, the name); the kind is
/// decided here, once.
pub fn parse(src: &Source) -> Result<Scenario, ScenarioError> {
    Ok(match kind_of(src) {
        Kind::Planar => Scenario::Planar(planar::parse(src)?),
        Kind::Spatial => Scenario::Spatial(spatial::parse(src)?),
    })
}

/// What the command line (or the Python package) changes in a scenario before it is built;
/// the same for both kinds ([`Scenario::apply`]).
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// `--controller`.
    pub controller: Option<ControllerKind>,
    /// `--controller pd-gravity`: PD with the model's gravity.
    pub pd_gravity: bool,
    /// `--gains`.
    pub gains: Option<planar::GainPreset>,
    /// `--duration`.
    pub duration: Option<f64>,
    /// `--replay` (a path relative to the current folder).
    pub replay: Option<PathBuf>,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--replay-interpolation`.
    pub replay_interpolation: Option<replay::Interpolation>,
    /// `--replay-columns`.
    pub replay_columns: Option<Vec<String>>,
}

impl Overrides {
    /// The overrides that choose a law (`--controller`, Python's `law=`).
    pub fn law(choice: ControllerChoice) -> Overrides {
        Overrides {
            controller: Some(choice.kind()),
            pd_gravity: choice == ControllerChoice::PdGravity,
            ..Overrides::default()
        }
    }
}

impl Scenario {
    /// Apply the command line's overrides (errors are bad input, exit code 2).
    pub fn apply(&mut self, o: &Overrides) -> Result<(), crate::BadInput> {
        match self {
            Scenario::Planar(s) => s.apply(o),
            Scenario::Spatial(s) => s.apply(o),
        }
    }
}

/// Resolve the command line's `SCENARIO` ([`resolve`]), parse it ([`parse`], which decides the
/// kind) and apply the overrides; a file that names itself (`name = "..."`, as a run's
/// `scenario.toml` does) renames the source.
pub fn load(arg: Option<&str>, o: &Overrides) -> anyhow::Result<(Source, Scenario)> {
    let src = resolve(arg)?;
    load_source(src, o)
}

/// [`load`] for a source already resolved.
pub fn load_source(mut src: Source, o: &Overrides) -> anyhow::Result<(Source, Scenario)> {
    let mut sc = parse(&src)?;
    if let Some(n) = sc.name() {
        src.name = n.to_string();
    }
    sc.apply(o)?;
    Ok((src, sc))
}
