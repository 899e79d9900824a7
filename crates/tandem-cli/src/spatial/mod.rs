//! Spatial runs end to end (issue 9): a spatial scenario file ([`scenario`]) is loaded, built
//! and validated ([`prepare`]), run ([`execute`]) and written ([`output`], [`figures`]):
//! `timeseries.csv`, `summary.json`, figures on six outputs, `viewer.html` and the snapshots,
//! into a marker-protected output folder. `tandem compare` runs several laws from one start
//! ([`cmd_compare`]).

pub mod figures;
pub mod output;
pub mod scenario;

pub use output::Finished;

use std::path::PathBuf;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use tandem::plant::spatial::SpatialPlant;

use crate::output::{OutputDir, write_text_atomic};
use crate::scenario::{ScenarioError, Source};
use scenario::{SpatialBuilt, SpatialKind, SpatialReady, SpatialScenario};

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
    /// `--replay-columns`.
    pub replay_columns: Option<Vec<String>>,
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
    if let Some(c) = &o.replay_columns {
        sc.controller.replay_columns = Some(c.clone());
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
    })
}

/// The label of a run's law, for tables, legends and messages: `NN`, `PD`, `PD + gravity`,
/// `CTC`, `per-arm PD`, `replay`. Its [`slug`] names the law in `summary.json` (`controller`),
/// in the default output folder of `tandem run` and in the sub-folders of `tandem compare`.
pub fn label(sc: &SpatialScenario) -> String {
    let c = &sc.controller;
    let l = match c.kind {
        SpatialKind::Nn => "NN",
        SpatialKind::Pd if c.pd.gravity_compensation => "PD + gravity",
        SpatialKind::Pd => "PD",
        SpatialKind::Ctc => "CTC",
        SpatialKind::Replay => "replay",
    };
    if c.scheme == scenario::SchemeConfig::PerArm && c.kind != SpatialKind::Replay {
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
    let e = scenario::EMBEDDED
        .iter()
        .find(|e| e.name == name)
        .with_context(|| format!("no embedded spatial scenario `{name}`"))?;
    let src = crate::scenario::embedded_source(e);
    let o = SpatialOverrides {
        duration: Some(duration),
        ..SpatialOverrides::default()
    };
    let p = prepare(load(&src, &o)?, &src)?;
    execute(p, |_| {})
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
        controller: slug(&label(&p.sc)),
        label: label(&p.sc),
        k_c: p.ready.k_c,
        chart: p.ready.chart,
        warnings: p.ready.warnings.clone(),
    })
}

/// `tandem run SPATIAL-SCENARIO`: run, write the outputs into `out`, print the summary table.
pub fn cmd_run(p: Prepared, out: OutputDir, figures: bool) -> Result<bool> {
    let name = p.name.clone();
    let label = label(&p.sc);
    let duration = p.built.sim.duration;
    for w in &p.ready.warnings {
        eprintln!("warning ({name}, {label}): {w}");
    }
    let toml_text = scenario_toml(&p.sc, &name)?;
    let bar = progress_bar(&label);
    let f = execute(p, |x| bar.set_position((x * 1000.0) as u64))?;
    bar.finish_and_clear();
    let (s, times, problems) = output::write(out.tmp_dir(), &name, &f, figures)?;
    write_text_atomic(&out.tmp_dir().join("scenario.toml"), &toml_text)?;
    let dir = out.commit_with_warnings(&problems)?;
    println!("{name} — {}, {duration} s", f.label);
    print!("{}", output::text(&[(f.label.as_str(), &s)]));
    println!(
        "outputs in {} (simulated in {:.3} s, written in {:.3} s: kinematics {:.3}, CSV {:.3}, \
         viewer {:.3}, figures {:.3}, in parallel)",
        dir.display(),
        f.outcome.wall_time,
        times.total,
        times.derive,
        times.csv,
        times.viewer,
        times.figures
    );
    if let Some(e) = &f.outcome.fault {
        eprintln!("error: the run stopped with a fault: {e}");
    }
    Ok(f.outcome.fault.is_none())
}

fn progress_bar(label: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix:>16} [{bar:36}] {percent:>3}% {elapsed:>4} (ETA {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix(label.to_string());
    bar
}

/// The laws `tandem compare` runs on a spatial scenario, from one start: the NN law, the paper's
/// PD, PD with the model's gravity, computed torque (each with the file's gains).
pub fn compare_variants(sc: &SpatialScenario) -> Vec<SpatialScenario> {
    let mut out = Vec::new();
    for (kind, g) in [
        (SpatialKind::Nn, false),
        (SpatialKind::Pd, false),
        (SpatialKind::Pd, true),
        (SpatialKind::Ctc, false),
    ] {
        let mut v = sc.clone();
        v.controller.kind = kind;
        v.controller.scheme = scenario::SchemeConfig::Object;
        v.controller.pd.gravity_compensation = g;
        out.push(v);
    }
    out
}

/// `tandem compare SPATIAL-SCENARIO`: every law of [`compare_variants`] from the same start
/// (run in parallel), their outputs in sub-folders, `report.md`, `summary.json`, the overlays.
pub fn cmd_compare(
    sc: SpatialScenario,
    src: &Source,
    out: OutputDir,
    figures: bool,
) -> Result<bool> {
    use rayon::prelude::*;
    let name = sc.name.clone().unwrap_or_else(|| src.name.clone());
    let mut prepared = Vec::new();
    for v in compare_variants(&sc) {
        let p = prepare(v, src)?;
        for w in &p.ready.warnings {
            eprintln!("warning ({name}, {}): {w}", label(&p.sc));
        }
        prepared.push(p);
    }
    let toml_text = scenario_toml(&sc, &name)?;
    let t0 = std::time::Instant::now();
    let finished: Vec<Result<Finished>> = prepared
        .into_par_iter()
        .map(|p| execute(p, |_| {}))
        .collect();
    let finished: Vec<Finished> = finished.into_iter().collect::<Result<_>>()?;
    let sim_time = t0.elapsed().as_secs_f64();
    let runs: Vec<(&str, &Finished)> = finished.iter().map(|f| (f.label.as_str(), f)).collect();
    let (summaries, problems) = output::write_compare(out.tmp_dir(), &name, &runs, figures)?;
    write_text_atomic(&out.tmp_dir().join("scenario.toml"), &toml_text)?;
    let dir = out.commit_with_warnings(&problems)?;
    println!("{name} — compare, {} s", finished[0].duration);
    let cols: Vec<(&str, &serde_json::Value)> = finished
        .iter()
        .zip(&summaries)
        .map(|(f, s)| (f.label.as_str(), s))
        .collect();
    print!("{}", output::text(&cols));
    println!(
        "outputs in {} (simulated in {sim_time:.3} s, in parallel)",
        dir.display()
    );
    let mut ok = true;
    for f in &finished {
        if let Some(e) = &f.outcome.fault {
            eprintln!("error: {} stopped with a fault: {e}", f.label);
            ok = false;
        }
    }
    Ok(ok)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// One label function names every law; its slug is what `summary.json`, `tandem run`'s
    /// default folder and `tandem compare`'s sub-folders use, so that a run and the same law in
    /// a comparison land in folders of the same name (PD with gravity was `pd-g` in one and
    /// `pd-gravity` in the other).
    #[test]
    fn one_label_and_its_slug_name_every_law() {
        let src = crate::scenario::embedded_source(&scenario::EMBEDDED[0]);
        let base = scenario::parse(&src).expect("embedded spatial scenario");
        let mut got: Vec<(String, String)> = compare_variants(&base)
            .iter()
            .map(|v| (label(v), slug(&label(v))))
            .collect();
        let mut per_arm = base.clone();
        per_arm.controller.kind = SpatialKind::Pd;
        per_arm.controller.scheme = scenario::SchemeConfig::PerArm;
        let mut replay = per_arm.clone();
        replay.controller.kind = SpatialKind::Replay;
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
