//! One planar run: prepare (every validation), simulate, post-process and summarize; what it
//! writes is [`crate::output::planar`]'s.

use anyhow::Result;
use tandem::report;
use tandem::report::planar::Summary;
use tandem::sim::{Driver, External, ExternalLaw, Log, Outcome};

use crate::scenario::ControllerKind;
use crate::scenario::planar::{Built, Ready};
use crate::scenario::{self, PlanarScenario, ScenarioError, Source};

/// A scenario that passed every validation, ready to run.
pub struct Prepared {
    /// The scenario (command-line overrides applied).
    pub sc: PlanarScenario,
    /// Its library parameters.
    pub built: Built,
    /// The simulation and its set-up warnings.
    pub ready: Ready,
    /// Driven by a user's law ([`prepare_external`]), not the scenario's controller.
    pub external: bool,
}

/// Build and validate everything a run needs (nothing is simulated).
pub fn prepare(sc: PlanarScenario, src: &Source) -> Result<Prepared, ScenarioError> {
    let built = scenario::planar::build(&sc, src)?;
    let ready = scenario::planar::make_simulation(&sc, &built, src)?;
    // Last: a NaN or infinity the run's own checks did not meet (another law's section).
    scenario::check_finite(src, &sc)?;
    Ok(Prepared {
        sc,
        built,
        ready,
        external: false,
    })
}

/// [`prepare`] with a user's law driving the loop instead of the scenario's controller (issue
/// 23): the scenario's plant, sensors, faults, path and bounds; the run is scored as a torque
/// replay is, on the true state.
pub fn prepare_external(
    sc: PlanarScenario,
    src: &Source,
    law: Box<dyn ExternalLaw>,
) -> Result<Prepared, ScenarioError> {
    let built = scenario::planar::build(&sc, src)?;
    let mut warnings = Vec::new();
    let driver = Driver::External(External::new(law));
    let sim = scenario::planar::simulation_of(&sc, &built, src, driver, &mut warnings)?;
    scenario::check_finite(src, &sc)?;
    Ok(Prepared {
        sc,
        built,
        ready: Ready { sim, warnings },
        external: true,
    })
}

/// A finished run.
pub struct Finished {
    /// The scenario that ran.
    pub sc: PlanarScenario,
    /// Its library parameters.
    pub built: Built,
    /// The log and how the run ended.
    pub outcome: Outcome,
    /// The metrics.
    pub summary: Summary,
    /// Set-up warnings.
    pub warnings: Vec<String>,
    /// Driven by a user's law.
    pub external: bool,
}

/// The label and `summary.json` name of a run driven by a user's law.
pub const EXTERNAL: &str = "external";

impl Finished {
    /// A human label, e.g. `NN (tuned)`; `external` for a user's law.
    pub fn label(&self) -> String {
        if self.external {
            EXTERNAL.into()
        } else {
            label(&self.sc)
        }
    }
}

/// A human label of a scenario's controller, e.g. `NN (tuned)`, `PD`.
pub fn label(sc: &PlanarScenario) -> String {
    match sc.controller.kind {
        ControllerKind::Nn => format!("NN ({})", sc.gains_label()),
        ControllerKind::Pd if sc.controller.pd.gravity_compensation == Some(true) => {
            "PD + gravity".into()
        }
        ControllerKind::Pd => "PD".into(),
        ControllerKind::Ctc => "CTC".into(),
        ControllerKind::Replay => format!("replay ({})", sc.gains_label()),
    }
}

/// Simulate; `progress(fraction)` is called about 200 times.
pub fn execute(p: Prepared, progress: impl FnMut(f64)) -> Finished {
    let Prepared {
        sc,
        built,
        ready,
        external,
    } = p;
    let (mut outcome, _sim) = ready.sim.run(progress);
    if external || sc.controller.kind == ControllerKind::Replay {
        fill_replay_columns(&mut outcome.log, &built, sc.k_c());
    }
    let name = if external {
        EXTERNAL
    } else {
        sc.controller.kind.name()
    };
    let summary = report::planar::summarize_with_path(
        &outcome,
        &built.path,
        name,
        &if external {
            EXTERNAL.to_string()
        } else {
            sc.gains_label()
        },
        sc.k_c(),
        sc.metrics.transient,
        built.sim.duration,
    );
    Finished {
        sc,
        built,
        outcome,
        summary,
        warnings: ready.warnings,
        external,
    }
}

/// A replay has no controller, so the library logs zeros for its internals. Fill in what the
/// scenario defines: `x_d` (and `x_r = x_d`, no admittance) from the path, `z1 = x_o − x_d`,
/// and the constraint margin from the true pose.
fn fill_replay_columns(log: &mut Log, built: &Built, k_c: [f64; 3]) {
    let t: Vec<f64> = log.get("t").unwrap_or(&[]).to_vec();
    let x_o: Vec<Vec<f64>> = ["x_o.x", "x_o.y", "x_o.theta"]
        .iter()
        .map(|n| log.get(n).unwrap_or(&[]).to_vec())
        .collect();
    let samples: Vec<_> = t.iter().map(|&t| built.path.sample(t)).collect();
    for c in &mut log.columns {
        let axis = |s: &str| match s {
            "x" => Some(0),
            "y" => Some(1),
            "theta" => Some(2),
            _ => None,
        };
        let Some((group, a)) = c.name.split_once('.') else {
            if c.name == "margin" {
                for (k, v) in c.data.iter_mut().enumerate() {
                    *v = (0..3)
                        .map(|j| 1.0 - x_o[j][k].abs() / k_c[j])
                        .fold(f64::INFINITY, f64::min);
                }
            }
            continue;
        };
        let Some(j) = axis(a) else { continue };
        match group {
            "x_d" | "x_r" => {
                for (v, s) in c.data.iter_mut().zip(&samples) {
                    *v = s.p[j];
                }
            }
            "z1" => {
                for (k, v) in c.data.iter_mut().enumerate() {
                    *v = x_o[j][k] - samples[k].p[j];
                }
            }
            _ => {}
        }
    }
}
