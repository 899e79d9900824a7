//! Spatial runs (issue 9): a spatial scenario ([`crate::scenario::spatial`]) is built and
//! validated ([`prepare`]) and run ([`execute`]) to a [`Finished`] run, which
//! [`crate::output::spatial`] and [`crate::figures::spatial`] write: `timeseries.csv`,
//! `summary.json`, figures on six outputs, `viewer.html` and the snapshots. `tandem compare`
//! runs the laws of [`compare_variants`] from one start.

use anyhow::{Context, Result};
use tandem::control::spatial::chart::Chart;
use tandem::plant::spatial::{ContactLog, SpatialPlant};
use tandem::reference::spatial::path::Se3Path;
use tandem::report::spatial::SpatialRun;
use tandem::sim::{External, ExternalLaw, Outcome};

use crate::scenario::ControllerKind;
use crate::scenario::spatial as scenario;
use crate::scenario::spatial::{SpatialBuilt, SpatialReady, SpatialScenario};
use crate::scenario::{ScenarioError, Source};
use tandem::report::spatial::TRANSIENT;

/// What a spatial run measured, and everything its outputs need.
pub struct Finished {
    /// The simulation outcome (log, fault, drift, margins).
    pub outcome: Outcome,
    /// The plant (kinematics of the logged states, the arms' joint limits).
    pub plant: SpatialPlant,
    /// Box edge lengths, m.
    pub box_size: [f64; 3],
    /// The desired path.
    pub path: Se3Path,
    /// Simulated duration asked for, s.
    pub duration: f64,
    /// The law's short name, the [`slug`] of its label: `nn`, `pd`, `pd-gravity`, `ctc`,
    /// `per-arm-pd`, `replay`.
    pub controller: String,
    /// A human label for tables and legends, e.g. `NN`.
    pub label: String,
    /// Output bounds `k_c` on `x_1 = (p − c, φ)`, (m ×3, rad ×3).
    pub k_c: [f64; 6],
    /// The output chart (centre `c`, `R_ref`) the controller used.
    pub chart: Chart,
    /// Set-up warnings.
    pub warnings: Vec<String>,
    /// Contact grasps: the pads' record (slip, events, cone margins); `None` for welds and
    /// compliant grasps.
    pub contacts: Option<ContactLog>,
    /// What the friction-aware distribution did (`controller.distribution = "friction"`).
    pub friction: Option<tandem::control::spatial::distribute::friction::FrictionStats>,
}

impl Finished {
    /// The run used the NN law (weights, `α`, `Q` exist).
    pub fn nn(&self) -> bool {
        self.controller == "nn"
    }
}

/// What the library's summary is computed from: the run and the scenario's definitions (the
/// spatial transient window is [`TRANSIENT`]).
impl<'a> From<&'a Finished> for SpatialRun<'a> {
    fn from(f: &'a Finished) -> Self {
        SpatialRun {
            outcome: &f.outcome,
            plant: &f.plant,
            path: &f.path,
            chart: &f.chart,
            k_c: f.k_c,
            transient: TRANSIENT,
        }
    }
}

/// A scenario ready to run.
pub struct Prepared {
    /// The scenario as run.
    pub sc: SpatialScenario,
    /// Its library parameters.
    pub built: SpatialBuilt,
    /// The simulation.
    pub ready: SpatialReady,
    /// Scenario name.
    pub name: String,
    /// Driven by a user's law ([`prepare_external`]).
    pub external: bool,
}

/// Build and validate (every set-up check; errors name the field).
pub fn prepare(sc: SpatialScenario, src: &Source) -> Result<Prepared, ScenarioError> {
    prepare_with(sc, src, None)
}

/// [`prepare`] with a user's law driving the loop instead of the scenario's controller (issue
/// 23): the scenario's plant, sensors, path and bounds; the run is scored on the true state,
/// as a torque replay is.
pub fn prepare_external(
    sc: SpatialScenario,
    src: &Source,
    law: Box<dyn ExternalLaw>,
) -> Result<Prepared, ScenarioError> {
    prepare_with(sc, src, Some(External::new(law)))
}

fn prepare_with(
    sc: SpatialScenario,
    src: &Source,
    law: Option<External>,
) -> Result<Prepared, ScenarioError> {
    let built = scenario::build(&sc, src)?;
    let external = law.is_some();
    let ready = match law {
        Some(l) => scenario::make_simulation_external(&sc, &built, src, l)?,
        None => scenario::make_simulation(&sc, &built, src)?,
    };
    // Last: a NaN or infinity the run's own checks did not meet (another law's section).
    crate::scenario::check_finite(src, &sc)?;
    let name = sc.name.clone().unwrap_or_else(|| src.name.clone());
    // The run's `scenario.toml` lives in the output folder: its file references (URDFs, the
    // replay) become absolute so that it runs from there.
    let mut sc = sc;
    let abs = |p: &str| {
        let p = src.dir.join(p);
        std::path::absolute(&p).unwrap_or(p).display().to_string()
    };
    for a in &mut sc.arms {
        if let Some(u) = &a.urdf {
            a.urdf = Some(abs(u));
        }
    }
    if let Some(r) = &sc.controller.replay {
        sc.controller.replay = Some(abs(r));
    }
    Ok(Prepared {
        sc,
        built,
        ready,
        name,
        external,
    })
}

/// The label of a run's law, for tables, legends and messages: `NN`, `PD`, `PD + gravity`,
/// `CTC`, `per-arm PD`, `replay`. Its [`slug`] names the law in `summary.json` (`controller`),
/// in the default output folder of `tandem run` and in the sub-folders of `tandem compare`.
pub fn label(sc: &SpatialScenario) -> String {
    let c = &sc.controller;
    let l = match c.kind {
        ControllerKind::Nn => "NN",
        ControllerKind::Pd if c.pd.gravity_compensation == Some(true) => "PD + gravity",
        ControllerKind::Pd => "PD",
        ControllerKind::Ctc => "CTC",
        ControllerKind::Replay => "replay",
    };
    if c.scheme == scenario::SchemeConfig::PerArm && c.kind != ControllerKind::Replay {
        format!("per-arm {l}")
    } else {
        l.to_string()
    }
}

/// A folder name for a run label: lowercase letters, digits and `-` (`PD + gravity` →
/// `pd-gravity`; `run` when nothing is left).
pub fn slug(label: &str) -> String {
    let mut s: String = label
        .to_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    while s.contains("--") {
        s = s.replace("--", "-");
    }
    let s = s.trim_matches('-').to_string();
    if s.is_empty() { "run".into() } else { s }
}

/// Run the embedded spatial scenario `name` (`dual-ur5`, `dual-franka`) for `duration` s with
/// the file's law (tests, examples).
pub fn run(name: &str, duration: f64) -> Result<Finished> {
    let e = crate::scenario::EMBEDDED
        .iter()
        .find(|e| e.name == name && e.kind == crate::scenario::Kind::Spatial)
        .with_context(|| format!("no embedded spatial scenario `{name}`"))?;
    let src = crate::scenario::embedded_source(e);
    let mut sc = scenario::parse(&src)?;
    sc.run.duration = duration;
    let p = prepare(sc, &src)?;
    execute(p, |_| {})
}

/// Run a prepared scenario, reporting progress in [0, 1].
pub fn execute(p: Prepared, progress: impl FnMut(f64)) -> Result<Finished> {
    let label = label_of(&p);
    let (outcome, contacts, friction) = p.ready.sim.run(progress);
    Ok(Finished {
        outcome,
        contacts,
        friction,
        plant: SpatialPlant::new(&p.built.plant).context("spatial plant")?,
        box_size: p.built.box_size,
        path: p.built.path.clone(),
        duration: p.built.sim.duration,
        controller: slug(&label),
        label,
        k_c: p.ready.k_c,
        chart: p.ready.chart,
        warnings: p.ready.warnings.clone(),
    })
}

/// The label of a prepared run: the scenario's law, or `external` for a user's law.
pub fn label_of(p: &Prepared) -> String {
    if p.external {
        crate::run::planar::EXTERNAL.into()
    } else {
        label(&p.sc)
    }
}

/// The laws `tandem compare` runs on a spatial scenario, from one start: the NN law, the paper's
/// PD, PD with the model's gravity, computed torque (each with the file's gains).
pub fn compare_variants(sc: &SpatialScenario) -> Vec<SpatialScenario> {
    let mut out = Vec::new();
    for (kind, g) in [
        (ControllerKind::Nn, false),
        (ControllerKind::Pd, false),
        (ControllerKind::Pd, true),
        (ControllerKind::Ctc, false),
    ] {
        let mut v = sc.clone();
        v.controller.kind = kind;
        v.controller.scheme = scenario::SchemeConfig::Object;
        v.controller.pd.gravity_compensation = Some(g);
        out.push(v);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One label function names every law; its slug is what `summary.json`, `tandem run`'s
    /// default folder and `tandem compare`'s sub-folders use, so that a run and the same law in
    /// a comparison land in folders of the same name (PD with gravity was `pd-g` in one and
    /// `pd-gravity` in the other).
    #[test]
    fn one_label_and_its_slug_name_every_law() {
        let src = crate::scenario::embedded_source(&crate::scenario::EMBEDDED[3]);
        let base = scenario::parse(&src).expect("embedded spatial scenario");
        let mut got: Vec<(String, String)> = compare_variants(&base)
            .iter()
            .map(|v| (label(v), slug(&label(v))))
            .collect();
        let mut per_arm = base.clone();
        per_arm.controller.kind = ControllerKind::Pd;
        per_arm.controller.scheme = scenario::SchemeConfig::PerArm;
        let mut replay = per_arm.clone();
        replay.controller.kind = ControllerKind::Replay;
        for v in [&per_arm, &replay] {
            got.push((label(v), slug(&label(v))));
        }
        let want = [
            ("NN", "nn"),
            ("PD", "pd"),
            ("PD + gravity", "pd-gravity"),
            ("CTC", "ctc"),
            ("per-arm PD", "per-arm-pd"),
            ("replay", "replay"),
        ];
        let want: Vec<(String, String)> = want
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        assert_eq!(got, want);
        assert_eq!(slug(" +/ "), "run");
    }
}
