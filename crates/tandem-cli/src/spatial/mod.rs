//! Spatial presets end to end (issue 9, first part): `tandem run dual-ur5` / `dual-franka` run
//! the SPEC-spatial S6 set-ups (`tandem::fixtures`) with the NN law and write `timeseries.csv`,
//! `summary.json`, `viewer.html` and the snapshots into a marker-protected output folder.

pub mod scenario;

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use nalgebra::Vector3;
use serde_json::json;
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::se3_path::Se3Path;
use tandem::sim::Outcome;

use crate::output::{OutputDir, write_csv, write_json_atomic, write_text_atomic};
use crate::scenario::{ScenarioError, Source};
use crate::viewer::{ScalarTrack, scene_from_states, write_snapshots, write_viewer_file};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use scenario::{SpatialBuilt, SpatialKind, SpatialReady, SpatialScenario};
use std::path::PathBuf;

/// What a spatial run measured.
pub struct Finished {
    /// The simulation outcome (log, fault, drift, margins).
    pub outcome: Outcome,
    /// The plant (for kinematics of the logged states).
    pub plant: SpatialPlant,
    /// Box edge lengths, m.
    pub box_size: [f64; 3],
    /// The desired path.
    pub path: Se3Path,
    /// Simulated duration, s.
    pub duration: f64,
}

/// Command-line overrides of a spatial scenario.
#[derive(Clone, Debug, Default)]
pub struct SpatialOverrides {
    /// `--controller`.
    pub controller: Option<SpatialKind>,
    /// `--duration`.
    pub duration: Option<f64>,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--replay FILE` (relative to the working folder).
    pub replay: Option<PathBuf>,
    /// `--replay-interpolation`.
    pub replay_interpolation: Option<crate::replay::Interpolation>,
}

/// Parse a spatial scenario and apply the command line's overrides.
pub fn load(src: &Source, o: &SpatialOverrides) -> Result<SpatialScenario, ScenarioError> {
    let mut sc = scenario::parse(src)?;
    if let Some(d) = o.duration {
        sc.run.duration = d;
    }
    if let Some(s) = o.seed {
        sc.run.seed = s;
    }
    if let Some(k) = o.controller {
        sc.controller.kind = k;
    }
    if let Some(r) = &o.replay {
        sc.controller.kind = SpatialKind::Replay;
        // The command line's path is relative to the working folder, the file's to the file.
        let abs = std::path::absolute(r).unwrap_or_else(|_| r.clone());
        sc.controller.replay = Some(abs.display().to_string());
    }
    if let Some(m) = o.replay_interpolation {
        sc.controller.replay_interpolation = Some(m);
    }
    Ok(sc)
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
}

/// Build and validate (every set-up check; errors name the field).
pub fn prepare(sc: SpatialScenario, src: &Source) -> Result<Prepared, ScenarioError> {
    let built = scenario::build(&sc, src)?;
    let ready = scenario::make_simulation(&sc, &built, src)?;
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
    })
}

/// The label of a run's law (`nn`, `pd`, `pd+g`, `ctc`, `per-arm pd`, `replay`).
pub fn label(sc: &SpatialScenario) -> String {
    let c = &sc.controller;
    let mut l = c.kind.name().to_string();
    if c.kind == SpatialKind::Pd && c.pd.gravity_compensation {
        l.push_str("+g");
    }
    if c.scheme == scenario::SchemeConfig::PerArm && c.kind != SpatialKind::Replay {
        l = format!("per-arm {l}");
    }
    l
}

/// Run a prepared scenario, reporting progress in [0, 1].
pub fn execute(p: Prepared, progress: impl FnMut(f64)) -> Result<Finished> {
    let outcome = p.ready.sim.run(progress);
    Ok(Finished {
        outcome,
        plant: SpatialPlant::new(&p.built.plant).context("spatial plant")?,
        box_size: p.built.box_size,
        path: p.built.path.clone(),
        duration: p.built.sim.duration,
    })
}

fn col<'a>(log: &'a tandem::sim::Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// The summary of a spatial run (SPEC-spatial S5 claims measured after 2 s).
pub fn summary(name: &str, f: &Finished) -> serde_json::Value {
    let log = &f.outcome.log;
    let t = col(log, "t");
    let g = |a: &str| col(log, &format!("z1.{a}"));
    let (x, y, z, rx, ry, rz) = (g("x"), g("y"), g("z"), g("rx"), g("ry"), g("rz"));
    let (mut zp_max, mut zr_max, mut zp_ss, mut n) = (0.0f64, 0.0f64, 0.0, 0usize);
    for k in 0..t.len().min(x.len()).min(rz.len()) {
        if t[k] >= 2.0 {
            let p = Vector3::new(x[k], y[k], z[k]).norm();
            let r = Vector3::new(rx[k], ry[k], rz[k]).norm();
            zp_max = zp_max.max(p);
            zr_max = zr_max.max(r);
            zp_ss += p * p;
            n += 1;
        }
    }
    let o = &f.outcome;
    let status = if o.fault.is_some() {
        "fault"
    } else {
        "completed"
    };
    json!({
        "scenario": name,
        "controller": "nn",
        "duration": f.duration,
        "status": status,
        "fault": o.fault.as_ref().map(|e| format!("{e:?}")),
        "events": format!("{:?}", o.events),
        "violation_ticks": o.violation_ticks,
        "min_margin": o.min_margin,
        "max_drift_m": o.max_drift,
        "max_drift_rad": o.max_drift_rot,
        "z1_p_max_after_2s_m": zp_max,
        "z1_rot_max_after_2s_rad": zr_max,
        "z1_p_rms_after_2s_m": if n > 0 { (zp_ss / n as f64).sqrt() } else { f64::NAN },
    })
}

/// The flat plant states of the log (`[q; X_WO (p, quaternion w x y z); qd; twist]`, the twist
/// left zero: the viewer draws poses only).
fn states(f: &Finished) -> Vec<Vec<f64>> {
    let log = &f.outcome.log;
    let nq = f.plant.n_q();
    let mut names: Vec<String> = (1..=nq).map(|k| format!("q{k}")).collect();
    names.extend(
        ["x", "y", "z", "qw", "qx", "qy", "qz"]
            .iter()
            .map(|a| format!("x_o.{a}")),
    );
    names.extend((1..=nq).map(|k| format!("qd{k}")));
    let cols: Vec<&[f64]> = names.iter().map(|n| col(log, n)).collect();
    (0..log.len())
        .map(|k| {
            let mut y: Vec<f64> = cols
                .iter()
                .map(|c| c.get(k).copied().unwrap_or(f64::NAN))
                .collect();
            y.resize(2 * nq + 13, 0.0);
            y
        })
        .collect()
}

/// Writes every output of `f` into `dir` (the temporary folder of an [`OutputDir`]).
pub fn write(dir: &Path, name: &str, f: &Finished) -> Result<serde_json::Value> {
    let log = &f.outcome.log;
    let header: Vec<String> = log
        .columns
        .iter()
        .map(|c| {
            if c.unit.is_empty() {
                c.name.clone()
            } else {
                format!("{} [{}]", c.name, c.unit)
            }
        })
        .collect();
    let cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    write_csv(&dir.join("timeseries.csv"), &header, &cols)?;

    let t = col(log, "t").to_vec();
    let mut scene = scene_from_states(name, &f.plant, f.box_size, &t, &states(f));
    let t_end = t.last().copied().unwrap_or(0.0);
    let n_path = ((t_end * 4.0).ceil() as usize).max(1);
    scene.desired_path = (0..=n_path)
        .map(|k| {
            let p = f.path.sample(t_end * k as f64 / n_path as f64).p;
            [p.x, p.y, p.z]
        })
        .collect();
    let n_arms = f.plant.arms().len();
    let axes = ["fx", "fy", "fz", "tx", "ty", "tz"];
    let fcols: Vec<Vec<&[f64]>> = (1..=n_arms)
        .map(|i| {
            axes.iter()
                .map(|a| col(log, &format!("F{i}.{a}")))
                .collect()
        })
        .collect();
    if fcols.iter().flatten().all(|c| c.len() == t.len()) {
        scene.wrenches = (0..t.len())
            .map(|k| {
                fcols
                    .iter()
                    .map(|c| [c[0][k], c[1][k], c[2][k], c[3][k], c[4][k], c[5][k]])
                    .collect()
            })
            .collect();
    }
    let g = |a: &str| col(log, &format!("z1.{a}"));
    let (x, y, z) = (g("x"), g("y"), g("z"));
    if x.len() == t.len() {
        let e = (0..t.len())
            .map(|k| Vector3::new(x[k], y[k], z[k]).norm())
            .collect();
        scene.scalars.push(ScalarTrack::new("error |z1_p|", "m", e));
    }
    let m = col(log, "margin");
    if m.len() == t.len() {
        scene
            .scalars
            .push(ScalarTrack::new("margin", "", m.to_vec()));
    }
    write_viewer_file(&scene, dir)?;
    write_snapshots(&scene, dir)?;
    let s = summary(name, f);
    write_json_atomic(&dir.join("summary.json"), &s)?;
    Ok(s)
}

/// `tandem run SPATIAL-SCENARIO`: run, write the outputs into `out`, print the summary.
pub fn cmd_run(p: Prepared, out: OutputDir) -> Result<bool> {
    let name = p.name.clone();
    let label = label(&p.sc);
    let duration = p.built.sim.duration;
    for w in &p.ready.warnings {
        eprintln!("warning ({name}, {label}): {w}");
    }
    let toml_text = scenario_toml(&p.sc, &name)?;
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix:>16} [{bar:36}] {percent:>3}% {elapsed:>4} (ETA {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix(label.clone());
    let f = execute(p, |x| bar.set_position((x * 1000.0) as u64))?;
    bar.finish_and_clear();
    let t0 = Instant::now();
    let s = write(out.tmp_dir(), &name, &f)?;
    write_text_atomic(&out.tmp_dir().join("scenario.toml"), &toml_text)?;
    let w = t0.elapsed().as_secs_f64();
    let dir = out.commit()?;
    println!(
        "{name} — {label}, {duration} s: simulated in {:.3} s, outputs in {} (written in {w:.3} s)",
        f.outcome.wall_time,
        dir.display()
    );
    println!("{}", serde_json::to_string_pretty(&s)?);
    if let Some(e) = &f.outcome.fault {
        eprintln!("error: the run stopped with a fault: {e}");
    }
    Ok(f.outcome.fault.is_none())
}

/// The scenario as run, re-runnable: the resolved TOML with a header.
pub fn scenario_toml(sc: &SpatialScenario, name: &str) -> Result<String> {
    let mut sc = sc.clone();
    sc.name = Some(name.to_string());
    let body = toml::to_string(&sc).context("writing scenario.toml")?;
    Ok(format!(
        "# The scenario of this run as tandem read it (defaults and command-line overrides\n# applied). Re-run it with `tandem run scenario.toml`.\n\n{body}"
    ))
}
