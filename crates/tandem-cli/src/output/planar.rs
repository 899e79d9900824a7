//! What a planar run writes: `timeseries.csv`, `summary.json` (the library's summary with the
//! run's name, version, kernel, warnings and timing), `scenario.toml`, the figures and the
//! animation ([`write_run`]).

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use serde_json::{Value, json};
use tandem::sim::Log;

use crate::figures::planar::{self as figures, FigureInfo};
use crate::files;
use crate::run::planar::{Finished, label};
use crate::scenario::ControllerKind;
use crate::scenario::PlanarScenario;
use crate::scenario::planar::GainPreset;
use crate::view::planar::anim::{self, AnimOptions};

/// The content of `summary.json`: the library's summary, the scenario's name and seed, the
/// tandem version, the RBF kernel, warnings, and (in `timing`, excluded from determinism checks) wall times.
pub fn summary_json(f: &Finished, scenario: &str, output_time: Option<f64>) -> Value {
    let mut v = serde_json::to_value(&f.summary).unwrap_or(Value::Null);
    let mut timing = serde_json::Map::new();
    if let Value::Object(m) = &mut v {
        for k in ["wall_time", "real_time_factor"] {
            if let Some(x) = m.remove(k) {
                timing.insert(k.into(), x);
            }
        }
    }
    if let Some(o) = output_time {
        timing.insert("output_time".into(), json!(o));
    }
    let mut head = serde_json::Map::new();
    head.insert("scenario".into(), json!(scenario));
    head.insert("seed".into(), json!(f.sc.run.seed));
    head.insert("tandem_version".into(), json!(env!("CARGO_PKG_VERSION")));
    // The RBF weight-pass kernel in effect (results differ across kernels within the
    // determinism policy's tolerance; `batched-f32` within its own).
    head.insert(
        "rbf_kernel".into(),
        json!(
            tandem::control::rbf::Kernel::from_env()
                .ok()
                .map(|k| k.name())
        ),
    );
    head.insert("label".into(), json!(f.label()));
    head.insert("duration".into(), json!(f.built.sim.duration));
    head.insert(
        "fault_message".into(),
        json!(f.outcome.fault.as_ref().map(|x| x.to_string())),
    );
    head.insert("warnings".into(), json!(f.warnings));
    head.insert("rows".into(), json!(f.outcome.log.len()));
    head.insert("regularised".into(), json!(f.outcome.regularised));
    let gaps = unavailable(f);
    if let Value::Object(mut m) = v {
        for (k, _) in &gaps {
            if let Some(x) = m.get_mut(*k) {
                *x = Value::Null;
            }
        }
        head.extend(m);
    }
    head.insert(
        "torque_rate".into(),
        super::torque_rate_json(&f.summary.torque_rate),
    );
    // Per joint, the ticks each limit of the actuator stage acted on.
    head.insert("joint_limits".into(), json!(f.outcome.joint_limits));
    let mut reasons = serde_json::Map::new();
    if f.outcome.joint_limits.is_none() {
        reasons.insert("joint_limits".into(), json!(super::NO_ACTUATOR));
    }
    for (k, why) in gaps {
        reasons.insert(k.into(), json!(why));
    }
    // Anything else that is null but not optional was a non-finite number.
    for (k, x) in &head {
        let optional = matches!(k.as_str(), "fault" | "fault_message");
        if x.is_null() && !optional && !reasons.contains_key(k) {
            reasons.insert(k.clone(), json!("not a finite number"));
        }
    }
    for (k, x) in &timing {
        if x.is_null() {
            reasons.insert(format!("timing.{k}"), json!("not a finite number"));
        }
    }
    head.insert("unavailable".into(), Value::Object(reasons));
    head.insert("timing".into(), Value::Object(timing));
    Value::Object(head)
}

/// The summary metrics that do not exist for this run, with the reason: they are written as
/// `null` (never 0) and the reason goes into `unavailable`.
pub fn unavailable(f: &Finished) -> Vec<(&'static str, String)> {
    let log = &f.outcome.log;
    let s = &f.summary;
    let mut v: Vec<(&'static str, String)> = Vec::new();
    let t = log.get("t").unwrap_or(&[]);
    let from_log = [
        "rms_z1",
        "max_z1",
        "rms_z1_after",
        "max_z1_after",
        "max_z1_theta_after",
        "rms_path_error",
        "max_path_error",
        "rms_path_error_after",
        "max_path_error_after",
        "rms_path_error_theta",
        "max_path_error_theta",
        "rms_path_error_theta_after",
        "max_path_error_theta_after",
        "settling_time_1mm",
        "rms_wrench",
        "peak_wrench",
        "wrench_roughness",
        "rms_joint_torque",
        "peak_joint_torque",
        "grasp_force_range",
        "weight_settling_time",
        "final_weight_norms",
    ];
    let Some(&last) = t.last() else {
        let why = format!(
            "no logged rows: the run stopped at t = {} s, before its first row",
            crate::output::table::num(s.t_end, 4)
        );
        v.extend(from_log.iter().map(|k| (*k, why.clone())));
        if !s.min_margin.is_finite() {
            v.push(("min_margin", why));
        }
        return v;
    };
    if last < s.transient {
        let why = format!(
            "run too short: the log ends at {} s, before the transient window (from {} s)",
            crate::output::table::num(last, 4),
            crate::output::table::num(s.transient, 4)
        );
        for k in [
            "rms_z1_after",
            "max_z1_after",
            "max_z1_theta_after",
            "rms_path_error_after",
            "max_path_error_after",
            "rms_path_error_theta_after",
            "max_path_error_theta_after",
        ] {
            v.push((k, why.clone()));
        }
    }
    let replay = f.sc.controller.kind == ControllerKind::Replay;
    if replay {
        for k in ["rms_wrench", "peak_wrench", "wrench_roughness"] {
            v.push((
                k,
                "a replay has no controller, so no commanded wrench".into(),
            ));
        }
    } else if t.len() < 2 {
        v.push(("wrench_roughness", "needs two logged rows".into()));
    }
    if f.sc.controller.kind != ControllerKind::Nn {
        for k in ["weight_settling_time", "final_weight_norms"] {
            v.push((
                k,
                format!("the {} run has no NN weights", f.sc.controller.kind.name()),
            ));
        }
    } else if s.weight_settling_time.iter().any(Option::is_none) {
        v.push((
            "weight_settling_time.*",
            "null: that weight norm never stays within ±10 % of its final value".into(),
        ));
    }
    if s.settling_time_1mm.is_none() {
        v.push((
            "settling_time_1mm",
            "never: ‖z1_xy‖ is not below 1 mm for the rest of the run".into(),
        ));
    }
    v
}

/// The resolved scenario as TOML, with a header saying what it is.
pub fn scenario_toml(sc: &PlanarScenario, name: &str, replay: Option<&Path>) -> Result<String> {
    let mut resolved = sc.resolved();
    resolved.name = Some(name.to_string());
    if let Some(r) = replay {
        // Relative to the original scenario's folder, which this file does not live in.
        let abs = std::path::absolute(r).unwrap_or_else(|_| r.to_path_buf());
        resolved.controller.replay = Some(abs.display().to_string());
    }
    let body = toml::to_string(&resolved)?;
    Ok(format!(
        "# Resolved scenario `{name}` as run by tandem {} ({}).\n\
         # Every default is written out (NN gains: the preset plus your overrides); run it\n\
         # again with:  tandem run <this file>\n\n{body}{}",
        env!("CARGO_PKG_VERSION"),
        label(sc),
        nn_gains_comment(sc)?,
    ))
}

/// For an NN run, the gains the preset resolves to (with the file's overrides) as a comment at
/// the end of `scenario.toml`: the file keeps the preset's name, so that `--gains` and
/// `compare`'s paper/tuned columns still switch it, and the reader still sees every number.
fn nn_gains_comment(sc: &PlanarScenario) -> Result<String> {
    if sc.controller.kind != ControllerKind::Nn {
        return Ok(String::new());
    }
    let preset = sc.controller.gains.unwrap_or(GainPreset::Tuned).name();
    let mut out = format!(
        "\n# The NN gains `gains = \"{preset}\"` resolves to, with this file's [controller.nn]\n\
         # overrides: for reading (copy a line into [controller.nn] to pin it).\n"
    );
    for line in toml::to_string(&sc.nn_gains())?.lines() {
        out.push_str(if line.is_empty() { "#" } else { "#   " });
        out.push_str(line);
        out.push('\n');
    }
    Ok(out)
}

/// Write the time series of a run.
pub fn write_timeseries(path: &Path, log: &Log) -> Result<()> {
    let header = log.names();
    let cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    files::write_csv(path, &header, &cols)
}

/// Which outputs to write.
#[derive(Clone, Copy, Debug)]
pub struct Outputs {
    /// Figures (PNG + SVG) and the animation.
    pub figures: bool,
}

/// Times spent writing, s.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteTimes {
    /// CSV.
    pub csv: f64,
    /// Figures.
    pub figures: f64,
    /// Animation.
    pub animation: f64,
}

impl WriteTimes {
    /// Total.
    pub fn total(&self) -> f64 {
        self.csv + self.figures + self.animation
    }
}

/// Write a run's files into `dir` (a temporary folder): `timeseries.csv`, `scenario.toml`,
/// figures, `animation.svg`, then `summary.json` (last, with the write times). Figure errors are
/// returned as warnings so that a faulted run still writes what it has.
pub fn write_run(
    dir: &Path,
    f: &Finished,
    scenario: &str,
    what: Outputs,
) -> Result<(WriteTimes, Vec<String>)> {
    let mut times = WriteTimes::default();
    let mut problems = Vec::new();
    let t0 = Instant::now();
    write_timeseries(&dir.join("timeseries.csv"), &f.outcome.log)?;
    times.csv = t0.elapsed().as_secs_f64();
    files::write_text_atomic(
        &dir.join("scenario.toml"),
        &scenario_toml(&f.sc, scenario, f.built.replay.as_deref())?,
    )?;
    if what.figures && !f.outcome.log.is_empty() {
        let t1 = Instant::now();
        let info = FigureInfo {
            title: format!("{scenario} — {}", f.label()),
            k_c: f.sc.k_c(),
            zoom: zoom(&f.sc),
            nn: f.sc.controller.kind == ControllerKind::Nn,
            replay: f.sc.controller.kind == ControllerKind::Replay,
            admittance: f.sc.controller.kind != ControllerKind::Replay && f.sc.admittance.enabled,
            joints: f.built.plant.arms.iter().map(|a| a.links.len()).collect(),
        };
        if let Err(e) = figures::run_figures(dir, &f.outcome.log, &info) {
            problems.push(format!("figures: {e:#}"));
        }
        times.figures = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        if let Err(e) = write_animation(dir, f, scenario) {
            problems.push(format!("animation: {e:#}"));
        }
        times.animation = t2.elapsed().as_secs_f64();
    }
    files::write_json_atomic(
        &dir.join("summary.json"),
        &summary_json(f, scenario, Some(times.total())),
    )?;
    Ok((times, problems))
}

/// The zoomed transient window of the figures: the metrics' transient, at least 2 s.
pub fn zoom(sc: &PlanarScenario) -> Option<f64> {
    Some(sc.metrics.transient.max(2.0))
}

fn write_animation(dir: &Path, f: &Finished, scenario: &str) -> Result<()> {
    let frames = crate::view::planar::scene::frames(
        &f.built.plant,
        &f.outcome.log,
        &f.built.path,
        f.sc.k_c(),
        f.built.q_guess.as_deref(),
    )?;
    if frames.frames.len() < 2 {
        return Ok(());
    }
    let t_end = frames.frames.last().map_or(0.0, |fr| fr.t);
    // About 30 s of playback, never slower than real time.
    let speed = (t_end / 30.0).max(1.0);
    anim::animated_svg(
        &dir.join("animation.svg"),
        &frames,
        &AnimOptions {
            speed,
            title: format!(
                "{scenario} — {} ({}× speed)",
                f.label(),
                crate::output::table::num(speed, 3)
            ),
            ..AnimOptions::default()
        },
    )
}
