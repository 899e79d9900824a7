//! `tandem`: run cooperative-manipulation scenarios, compare controllers, write figures.
//!
//! Exit codes: 0 success, 1 a run fault (a numerical failure during the simulation: the outputs
//! are written with the fault in `summary.json`) or an I/O failure, 2 bad input (command line,
//! scenario file, replay file, or an output folder that exists without `--force`).

// The doc comments below are clap's `--help` text, written for a terminal (`out/<name>`), not HTML.
#![allow(rustdoc::invalid_html_tags)]

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use tandem_cli::figures::planar as figures;
use tandem_cli::files::{self as output, OutputDir};
use tandem_cli::output::planar::{self as planar_output, Outputs};
use tandem_cli::output::spatial as spatial_output;
use tandem_cli::output::table;
use tandem_cli::run::planar::{self as runner, Finished};
use tandem_cli::run::spatial;
use tandem_cli::scenario::planar::GainPreset;
use tandem_cli::scenario::{
    self, ControllerChoice, ControllerKind, Kind, Overrides, PlanarScenario, Scenario,
    ScenarioError, Source, SpatialScenario, replay,
};
use tandem_cli::{BadInput, robustness, suggest, sweep};

#[derive(Parser)]
#[command(
    name = "tandem",
    version,
    about = "Cooperative manipulation: several arms (planar, or 6/7-DOF from URDF) carry one object along a path",
    long_about = "Cooperative manipulation: several arms (planar, or 6/7-DOF from URDF) carry one \
        object along a path.\n\n\
        Scenarios are TOML files (or embedded: see `tandem scenario list`); a scenario whose arms \
        name a robot (`model = \"ur5\"`, `urdf = \"arm.urdf\"`) is spatial. `tandem run` with no \
        arguments runs the paper's scenario with the tuned NN controller and writes the time \
        series, summary, figures and an animation to out/paper-nn-tuned; `tandem run dual-ur5` \
        runs two UR5-class arms carrying a box in SE(3) and writes a 3-D viewer.",
    after_help = "Exit codes: 0 success, 1 a run fault (outputs written, fault in summary.json) \
        or an I/O error, 2 bad input (arguments, scenario, replay file, existing output folder)."
)]
struct Cli {
    /// The NN law's weight-pass kernel: portable, avx2, avx2fma, avx512, batched or
    /// batched-f32 (default: the fastest double-precision kernel this CPU has). The same as
    /// setting TANDEM_KERNEL, which this option overrides; sweep workers inherit it.
    /// `batched-f32` is the fastest and agrees with `portable` to a relative 2e-6 (README,
    /// "Speed and determinism").
    #[arg(long, global = true, value_name = "NAME")]
    kernel: Option<String>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one scenario with one controller and write its outputs.
    ///
    /// Writes into the output folder (atomically: a temporary folder renamed into place):
    /// timeseries.csv (every logged signal, units in the header), summary.json (metrics, seed,
    /// version, fault), scenario.toml (the resolved scenario, re-runnable), the paper's figures
    /// as PNG and SVG (xy_path, trajectories, z1, z2, wrench, weights, plus admittance,
    /// grasp_forces, joint_torques, switching) and animation.svg. A spatial scenario writes the
    /// figures on six outputs (z1, z2, tracking, path, wrench, grasp_wrenches, internal_wrench,
    /// joint_torques, joint_limits, weights, margins), viewer.html (the 3-D view, offline) and
    /// snapshot_{front,side,top}. A run that hits a numerical fault writes what it has and exits
    /// with code 1.
    Run(RunArgs),
    /// Run PD, NN (paper gains), NN (tuned gains) and CTC from one common start; side-by-side
    /// figures and a report. On a spatial scenario: NN, PD, PD + model gravity and CTC.
    ///
    /// Writes report.md (summary table and figure links), summary.json, scenario.toml, the
    /// comparison figures (compare_xy, compare_trajectories, compare_z1, compare_wrench,
    /// compare_margin) and one sub-folder per controller with its own run outputs.
    Compare(CompareArgs),
    /// Check a scenario (parse and every library validation) without running it.
    Validate {
        /// Scenario file or embedded scenario name.
        scenario: String,
        /// Also list every arm's inverse-kinematics branches at the start pose, as `tandem ik`
        /// does with its defaults (spatial scenarios).
        #[arg(long)]
        branches: bool,
    },
    /// List every inverse-kinematics branch of each arm at a spatial scenario's start pose.
    ///
    /// Solves each arm onto its grasp frame from many starts (the scenario's own q_guess, then
    /// seeded draws inside the joint limits), keeps the solutions inside the limits (revolute
    /// angles wrapped by whole turns), and follows each along the path by IK continuation. For
    /// each: σ_min and cond of the tool Jacobian at the start; whether it stays inside the
    /// limits the whole path (else when and why it fails), the path's smallest σ_min and joint
    /// limit margin, and its largest holding torque over the effort limit; the `q_guess = [...]`
    /// line that picks it. The scenario's own branch is marked *. An arm with more than 6 joints
    /// has a continuum of solutions: its list is clustered samples of that continuum, not
    /// discrete branches.
    Ik(IkArgs),
    /// Scan the base separation of a spatial scenario for where the path stays reachable.
    ///
    /// Two arms: both bases move along the line joining them, about their midpoint; more arms:
    /// every base moves radially about the bases' centroid (the scanned value is then their mean
    /// distance from it). Bases keep their orientation. At each separation every arm follows the
    /// path by IK continuation (from its best `tandem ik` branch at the scenario's placement,
    /// continued in the separation; another branch is searched where that one fails). Prints a
    /// table (σ_min per arm, holding torque over effort, joint-limit margin, closest approach of
    /// the arms' centre lines) and the reachable range with its best-conditioned separation.
    Place(PlaceArgs),
    /// Robustness studies: a planar scenario's fault families, a spatial scenario's
    /// compliant-grasp sweep.
    ///
    /// A planar scenario: every fault family of `[faults]` at five severities for PD and the NN
    /// law, then the spatial grasp-slip family (robustness.md, figures, results.json;
    /// docs/robustness.md). A spatial scenario: its compliant-grasp sweep, stiffness × damping ×
    /// law (NN, PD + gravity, CTC), without and with the output filter (robustness.md,
    /// robustness.json, figures/robustness_grasps.svg; docs/robot-ready.md).
    ///
    /// The spatial sweep makes the true grasps springs while every law assumes welds: 1e4, 1e5
    /// and 1e6 N/m (1e2, 1e3, 1e4 N m/rad), 0.3, 1 and 3 times critical damping against the
    /// tool link, 54 runs.
    Robustness(RobustnessArgs),
    /// Run a parameter sweep (grids and random draws over scenario fields) across cores.
    ///
    /// Writes runs.csv (one row per run: index, seed, the varied values, status, the summary
    /// metrics), sweep.json (the resolved sweep and its hash) and figures (a metric against each
    /// varied field, histograms of the random draws); see docs/sweeps.md. A faulted run is a row
    /// with its fault. With --shard I/N (or inside a Slurm job array) only the runs with
    /// index % N == I run; `tandem merge` joins the shard folders.
    Sweep(SweepArgs),
    /// Join the folders of a sharded sweep into one (runs.csv identical to an unsharded run).
    Merge(MergeArgs),
    /// Write a spatial scenario's set-up for another simulator: a MuJoCo model (MJCF) or JSON.
    ///
    /// The scenario is built and validated as `tandem run` builds it, and its start solved (the
    /// arms' joints on the start pose); the file describes that set-up: the arms' bodies,
    /// joints and inertias from tandem's parse of the URDFs, the bases, the box, the grasps
    /// (MJCF: weld equalities held to ~1e-9 m), the start pose with the torques that hold it,
    /// and sites `arm0_tool`, `arm0_grasp`, ... for the tool and grasp frames. JSON adds the
    /// URDF text, the sensor and loop conventions and the time steps, for Drake, Pinocchio,
    /// Isaac or your own code. Without --out the text goes to standard output.
    Export(ExportArgs),
    /// The embedded scenarios.
    Scenario {
        #[command(subcommand)]
        command: ScenarioCommand,
    },
}

#[derive(Subcommand)]
enum ScenarioCommand {
    /// List the embedded scenarios.
    List,
    /// Print an embedded scenario, with comments on where every value comes from.
    Show {
        /// Embedded scenario name (e.g. `paper`).
        name: String,
    },
}

#[derive(Args)]
struct Common {
    /// Output folder (default: out/SCENARIO-CONTROLLER[-GAINS] for run, out/SCENARIO-compare for
    /// compare).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace the output folder if it exists. Without it an existing folder (e.g. from the
    /// previous `tandem run`) is left untouched, nothing is run, and the exact command to re-run
    /// with --force is printed (exit code 2). The old folder is replaced only once the new outputs
    /// are complete.
    #[arg(long)]
    force: bool,
    /// Simulated time in seconds (overrides run.duration).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    duration: Option<f64>,
    /// Seed of the sensor noise (overrides run.seed).
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Write no figures and no animation (time series, summary and scenario only).
    #[arg(long)]
    no_figures: bool,
}

#[derive(Args)]
struct RunArgs {
    /// Scenario file or embedded scenario name [default: paper].
    scenario: Option<String>,
    /// Controller (overrides controller.kind; pd-gravity is PD with the model's gravity).
    #[arg(long, value_enum)]
    controller: Option<ControllerChoice>,
    /// Gain preset of the nn controller (overrides controller.gains).
    #[arg(long, value_enum)]
    gains: Option<GainPreset>,
    /// Joint torques to replay: a run's timeseries.csv or a `t,tau1,tau2,...` table (implies
    /// --controller replay).
    #[arg(long, value_name = "FILE")]
    replay: Option<PathBuf>,
    /// How a replay turns rows into torques: hold (each row until the next; rows on the control
    /// grid, time stamps within 1 % of a tick snapped onto it) or linear (interpolated at every
    /// tick: a log at another rate). Overrides controller.replay_interpolation.
    #[arg(long, value_enum, value_name = "MODE")]
    replay_interpolation: Option<replay::Interpolation>,
    /// Column names of a replayed log from another tool: the time column, then one torque
    /// column per joint in the plant's order (e.g. `stamp,j1_effort,j2_effort,...`). Overrides
    /// controller.replay_columns.
    #[arg(long, value_name = "TIME,TAU1,...", value_delimiter = ',')]
    replay_columns: Option<Vec<String>>,
    #[command(flatten)]
    common: Common,
}

#[derive(Args)]
struct RobustnessArgs {
    /// Scenario file or embedded scenario name [default: paper].
    scenario: Option<String>,
    /// Output folder [default: out/SCENARIO-robustness].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace the output folder if tandem wrote it.
    #[arg(long)]
    force: bool,
    /// Simulated time of each run, s [default: 20 for a planar scenario, 4 for a spatial one].
    #[arg(long, value_name = "S")]
    duration: Option<f64>,
    /// Worker threads [default: every core].
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
}

#[derive(Args)]
struct SweepArgs {
    /// The sweep file (TOML; see docs/sweeps.md).
    file: PathBuf,
    /// Output folder [default: out/<sweep file stem>-sweep, plus -shard-I-of-N for a shard].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Worker threads [default: every core].
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Run only the runs with index % N == I (I from 0). Without it, SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT are used when set.
    #[arg(long, value_name = "I/N", allow_hyphen_values = true)]
    shard: Option<String>,
    /// Also write every run's outputs (time series, summary, scenario) to DIR/runs/<index>/.
    #[arg(long)]
    keep_runs: bool,
    /// Replace the output folder if tandem wrote it.
    #[arg(long)]
    force: bool,
    /// Write no figures.
    #[arg(long)]
    no_figures: bool,
}

#[derive(Args)]
struct MergeArgs {
    /// The shard folders (one per shard, any order).
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Replace the output folder if tandem wrote it.
    #[arg(long)]
    force: bool,
    /// Write no figures.
    #[arg(long)]
    no_figures: bool,
}

#[derive(Args)]
struct ExportArgs {
    /// Scenario file or embedded scenario name (spatial: e.g. `dual-ur5`, `dual-franka`).
    scenario: String,
    /// mjcf (a MuJoCo model) or json [default: the one --out's extension names (.xml, .mjcf,
    /// .json), else mjcf].
    #[arg(long, value_enum)]
    format: Option<tandem_cli::export::Format>,
    /// The file to write (atomically) [default: standard output; `-` is standard output too].
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Replace --out if it exists and tandem export wrote it (never another file, nor an
    /// input of the scenario).
    #[arg(long)]
    force: bool,
}

#[derive(Args)]
struct IkArgs {
    /// Scenario file or embedded scenario name (spatial: e.g. `dual-ur5`, `dual-franka`).
    scenario: String,
    /// Only this arm (0-based, as in `arms[I]`).
    #[arg(long, value_name = "I")]
    arm: Option<usize>,
    /// Starts per arm, the scenario's own q_guess included (1 to 10000).
    #[arg(long, value_name = "N", default_value_t = tandem_cli::ik::DEFAULT_STARTS)]
    starts: usize,
    /// Seed of the starts drawn inside the joint limits.
    #[arg(long, value_name = "N", default_value_t = 0)]
    seed: u64,
    /// Path sampling step for the continuation, s.
    #[arg(long, value_name = "S", default_value_t = tandem_cli::ik::DEFAULT_EVERY, allow_negative_numbers = true)]
    every: f64,
    /// Also write the results as JSON to FILE (whole or not at all).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Replace --json FILE if it exists and tandem ik or place wrote it (never another file,
    /// nor an input of the scenario).
    #[arg(long)]
    force: bool,
}

#[derive(Args)]
struct PlaceArgs {
    /// Scenario file or embedded scenario name (spatial, two or more arms).
    scenario: String,
    /// Smallest separation, m [default: 0.6 × the scenario's].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    from: Option<f64>,
    /// Largest separation, m [default: 1.4 × the scenario's].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    to: Option<f64>,
    /// Separation step, m [default: 0.05 × the scenario's; at most 201 separations].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    step: Option<f64>,
    /// Path sampling step for the continuation, s [default: 0.5].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    every: Option<f64>,
    /// Starts per arm of the branch search at the scenario's placement (1 to 10000) [default: 200].
    #[arg(long, value_name = "N")]
    starts: Option<usize>,
    /// Seed of the searches.
    #[arg(long, value_name = "N", default_value_t = 0)]
    seed: u64,
    /// Also write the results as JSON to FILE (whole or not at all).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Replace --json FILE if it exists and tandem ik or place wrote it (never another file,
    /// nor an input of the scenario).
    #[arg(long)]
    force: bool,
}

#[derive(Args)]
struct CompareArgs {
    /// Scenario file or embedded scenario name [default: paper].
    scenario: Option<String>,
    #[command(flatten)]
    common: Common,
}

/// A closed pipe (`tandem scenario show paper | head`) ends the process quietly, as for any
/// Unix tool, instead of a panic in `println!` (Rust ignores SIGPIPE by default).
#[cfg(unix)]
fn default_sigpipe() {
    unsafe extern "C" {
        fn signal(sig: i32, handler: usize) -> usize;
    }
    const SIGPIPE: i32 = 13;
    const SIG_DFL: usize = 0;
    // SAFETY: restoring the default disposition of one signal before any thread starts.
    unsafe {
        signal(SIGPIPE, SIG_DFL);
    }
}

#[cfg(not(unix))]
fn default_sigpipe() {}

fn main() -> ExitCode {
    default_sigpipe();
    let cli = Cli::parse();
    if let Some(k) = &cli.kernel {
        // Checked at once (an unknown name, or one this CPU lacks, lists the valid ones), then
        // handed to the library, and to sweep workers, through the environment.
        if let Err(e) = tandem::control::rbf::Kernel::parse(k) {
            eprintln!(
                "error: --kernel: {}",
                e.to_string().replace("TANDEM_KERNEL: ", "")
            );
            return ExitCode::from(2);
        }
        // SAFETY: no other thread exists yet (nothing has been spawned), so nothing reads the
        // environment concurrently.
        unsafe { std::env::set_var(tandem::control::rbf::KERNEL_ENV, k.trim()) };
    }
    // `TANDEM_KERNEL` is read from the environment, not from a scenario: refuse a bad value
    // here, before any file is read or written, also for runs that never build a network (a
    // PD run would otherwise ignore it). The library path reports it the same way
    // (`Source::model_error`).
    if let Err(e) = tandem::control::rbf::Kernel::from_env() {
        eprintln!("error: environment variable {e}");
        return ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Run(a) => cmd_run(a),
        Command::Compare(a) => cmd_compare(a),
        Command::Robustness(a) => cmd_robustness(a),
        Command::Validate { scenario, branches } => cmd_validate(&scenario, branches),
        Command::Ik(a) => cmd_ik(a),
        Command::Place(a) => cmd_place(a),
        Command::Sweep(a) => cmd_sweep(a),
        Command::Merge(a) => cmd_merge(a),
        Command::Scenario { command } => cmd_scenario(command),
        Command::Export(a) => cmd_export(a),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            let bad = e.downcast_ref::<BadInput>().is_some()
                || e.downcast_ref::<ScenarioError>().is_some()
                || e.downcast_ref::<output::Refused>().is_some();
            ExitCode::from(if bad { 2 } else { 1 })
        }
    }
}

/// Refuse an existing output folder without --force, with the command that would overwrite it;
/// with --force, refuse anything tandem did not write (see [`output::check_replaceable`]).
fn check_out(dir: &Path, force: bool, protected: &[output::Input]) -> Result<()> {
    if std::fs::symlink_metadata(dir).is_err() {
        return Ok(());
    }
    if force {
        return output::check_replaceable(dir, protected);
    }
    let mut cmd = vec!["tandem".to_string()];
    cmd.extend(std::env::args().skip(1).map(|a| shell_quote(&a)));
    cmd.push("--force".into());
    Err(BadInput::msg(format!(
        "output folder {} exists (nothing was run). To overwrite it, run:\n    {}\nor choose another folder with --out DIR",
        dir.display(),
        cmd.join(" ")
    ))
    .into())
}

fn shell_quote(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

fn bar_style() -> ProgressStyle {
    ProgressStyle::with_template("{prefix:>16} [{bar:36}] {percent:>3}% {elapsed:>4} (ETA {eta})")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

fn print_warnings(label: &str, w: &[String]) {
    for w in w {
        eprintln!("warning ({label}): {w}");
    }
}

fn cmd_run(a: RunArgs) -> Result<ExitCode> {
    let o = Overrides {
        controller: a.controller.map(ControllerChoice::kind),
        pd_gravity: a.controller == Some(ControllerChoice::PdGravity),
        gains: a.gains,
        duration: a.common.duration,
        replay: a.replay.clone(),
        seed: a.common.seed,
        replay_interpolation: a.replay_interpolation,
        replay_columns: a.replay_columns.clone(),
    };
    match scenario::load(a.scenario.as_deref(), &o)? {
        (src, Scenario::Planar(sc)) => cmd_run_planar(a, src, sc),
        (src, Scenario::Spatial(sc)) => cmd_run_spatial(a, src, sc),
    }
}

/// `tandem run` on a planar scenario.
fn cmd_run_planar(a: RunArgs, src: Source, sc: PlanarScenario) -> Result<ExitCode> {
    let kind = sc.controller.kind;
    let out_dir = a.common.out.clone().unwrap_or_else(|| {
        let mut name = format!("{}-{}", src.name, kind.name());
        if kind == ControllerKind::Pd && sc.controller.pd.gravity_compensation == Some(true) {
            name.push_str("-gravity");
        }
        if kind == ControllerKind::Nn {
            name.push('-');
            name.push_str(sc.controller.gains.unwrap_or(GainPreset::Tuned).name());
        }
        PathBuf::from("out").join(name)
    });
    let protected = scenario::inputs(&src, &sc);
    check_out(&out_dir, a.common.force, &protected)?;
    let label = runner::label(&sc);
    let prepared = runner::prepare(sc, &src)?;
    print_warnings(&label, &prepared.ready.warnings);
    let out = OutputDir::create(&out_dir, a.common.force, &protected)?;

    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    bar.set_style(bar_style());
    bar.set_prefix(label.clone());
    let fin = runner::execute(prepared, |f| bar.set_position((f * 1000.0) as u64));
    bar.finish_and_clear();

    let (times, problems) = planar_output::write_run(
        out.tmp_dir(),
        &fin,
        &src.name,
        Outputs {
            figures: !a.common.no_figures,
        },
    )?;
    let dir = out.commit_with_warnings(&problems)?;
    println!(
        "{} — {}, {} s{}",
        src.name,
        label,
        table::num(fin.built.sim.duration, 4),
        if fin.sc.run.seed != 0 {
            format!(", seed {}", fin.sc.run.seed)
        } else {
            String::new()
        }
    );
    print!("{}", table::text(&[(label.as_str(), &fin.summary)]));
    println!(
        "outputs in {} (written in {} s: CSV {} s, figures {} s, animation {} s)",
        dir.display(),
        table::num(times.total(), 3),
        table::num(times.csv, 3),
        table::num(times.figures, 3),
        table::num(times.animation, 3),
    );
    Ok(fault_exit(&[&fin]))
}

/// `tandem run` on a spatial scenario.
fn cmd_run_spatial(a: RunArgs, src: Source, sc: SpatialScenario) -> Result<ExitCode> {
    let slug = spatial::slug(&spatial::label(&sc));
    let out_dir = a
        .common
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-{slug}", src.name)));
    let protected = scenario::inputs(&src, &sc);
    check_out(&out_dir, a.common.force, &protected)?;
    let prepared = spatial::prepare(sc, &src)?;
    let out = OutputDir::create(&out_dir, a.common.force, &protected)?;
    let ok = spatial_run(prepared, out, !a.common.no_figures)?;
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// `tandem run SPATIAL-SCENARIO`: run, write the outputs into `out`, print the summary table.
fn spatial_run(p: spatial::Prepared, out: OutputDir, figures: bool) -> Result<bool> {
    let name = p.name.clone();
    let label = spatial::label(&p.sc);
    let duration = p.built.sim.duration;
    for w in &p.ready.warnings {
        eprintln!("warning ({name}, {label}): {w}");
    }
    let toml_text = spatial_output::scenario_toml(&p.sc, &name)?;
    let bar = spatial_progress_bar(&label);
    let f = spatial::execute(p, |x| bar.set_position((x * 1000.0) as u64))?;
    bar.finish_and_clear();
    let (s, times, problems) = spatial_output::write(out.tmp_dir(), &name, &f, figures)?;
    output::write_text_atomic(&out.tmp_dir().join("scenario.toml"), &toml_text)?;
    let dir = out.commit_with_warnings(&problems)?;
    println!("{name} — {}, {duration} s", f.label);
    print!("{}", spatial_output::text(&[(f.label.as_str(), &s)]));
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

/// `tandem compare SPATIAL-SCENARIO`: every law of [`compare_variants`] from the same start
/// (run in parallel), their outputs in sub-folders, `report.md`, `summary.json`, the overlays.
fn spatial_compare(
    sc: SpatialScenario,
    src: &Source,
    out: OutputDir,
    figures: bool,
) -> Result<bool> {
    use rayon::prelude::*;
    let name = sc.name.clone().unwrap_or_else(|| src.name.clone());
    let mut prepared = Vec::new();
    for v in spatial::compare_variants(&sc) {
        let p = spatial::prepare(v, src)?;
        for w in &p.ready.warnings {
            eprintln!("warning ({name}, {}): {w}", spatial::label(&p.sc));
        }
        prepared.push(p);
    }
    let toml_text = spatial_output::scenario_toml(&sc, &name)?;
    let t0 = std::time::Instant::now();
    let finished: Vec<Result<spatial::Finished>> = prepared
        .into_par_iter()
        .map(|p| spatial::execute(p, |_| {}))
        .collect();
    let finished: Vec<spatial::Finished> = finished.into_iter().collect::<Result<_>>()?;
    let sim_time = t0.elapsed().as_secs_f64();
    let runs: Vec<(&str, &spatial::Finished)> =
        finished.iter().map(|f| (f.label.as_str(), f)).collect();
    let (summaries, problems) =
        spatial_output::write_compare(out.tmp_dir(), &name, &runs, figures)?;
    output::write_text_atomic(&out.tmp_dir().join("scenario.toml"), &toml_text)?;
    let dir = out.commit_with_warnings(&problems)?;
    println!("{name} — compare, {} s", finished[0].duration);
    let cols: Vec<(&str, &serde_json::Value)> = finished
        .iter()
        .zip(&summaries)
        .map(|(f, s)| (f.label.as_str(), s))
        .collect();
    print!("{}", spatial_output::text(&cols));
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

fn spatial_progress_bar(label: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    bar.set_style(bar_style());
    bar.set_prefix(label.to_string());
    bar
}

/// Exit code 1 (with a message) when a run faulted.
fn fault_exit(runs: &[&Finished]) -> ExitCode {
    let mut code = ExitCode::SUCCESS;
    for f in runs {
        if let Some(fault) = &f.outcome.fault {
            eprintln!(
                "error: the {} run stopped: {fault} (outputs up to the fault are written; see summary.json)",
                f.label()
            );
            code = ExitCode::from(1);
        }
    }
    code
}

/// The compared controllers: (kind, preset, sub-folder).
const COMPARED: [(ControllerKind, Option<GainPreset>, &str); 4] = [
    (ControllerKind::Pd, None, "pd"),
    (ControllerKind::Nn, Some(GainPreset::Paper), "nn-paper"),
    (ControllerKind::Nn, Some(GainPreset::Tuned), "nn-tuned"),
    (ControllerKind::Ctc, None, "ctc"),
];

fn cmd_compare(a: CompareArgs) -> Result<ExitCode> {
    let o = Overrides {
        duration: a.common.duration,
        seed: a.common.seed,
        ..Overrides::default()
    };
    let (src, base) = match scenario::load(a.scenario.as_deref(), &o)? {
        (src, Scenario::Planar(sc)) => (src, sc),
        (src, Scenario::Spatial(sc)) => {
            let out_dir = a
                .common
                .out
                .clone()
                .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-compare", src.name)));
            let protected = scenario::inputs(&src, &sc);
            check_out(&out_dir, a.common.force, &protected)?;
            let out = OutputDir::create(&out_dir, a.common.force, &protected)?;
            let ok = spatial_compare(sc, &src, out, !a.common.no_figures)?;
            return Ok(if ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            });
        }
    };
    let out_dir = a
        .common
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-compare", src.name)));
    let protected = scenario::inputs(&src, &base);
    check_out(&out_dir, a.common.force, &protected)?;
    let mut prepared = Vec::new();
    for (kind, gains, slug) in COMPARED {
        let mut sc = base.clone();
        sc.controller.kind = kind;
        sc.controller.gains = gains.or(sc.controller.gains);
        if kind == ControllerKind::Ctc && sc.controller.scheme == tandem::control::Scheme::PerArm {
            // Computed torque exists for the object scheme only: compare it there.
            sc.controller.scheme = tandem::control::Scheme::Object;
        }
        let label = runner::label(&sc);
        let p = runner::prepare(sc, &src)?;
        print_warnings(&label, &p.ready.warnings);
        prepared.push((slug, label, p));
    }
    let out = OutputDir::create(&out_dir, a.common.force, &protected)?;

    // All runs at once, one progress bar each.
    let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
    let t0 = Instant::now();
    let finished: Vec<(&str, Finished)> = std::thread::scope(|s| {
        let handles: Vec<_> = prepared
            .into_iter()
            .map(|(slug, label, p)| {
                let bar = multi.add(ProgressBar::new(1000));
                bar.set_style(bar_style());
                bar.set_prefix(label);
                s.spawn(move || {
                    let f = runner::execute(p, |x| bar.set_position((x * 1000.0) as u64));
                    bar.finish();
                    (slug, f)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a simulation thread panicked"))
            .collect()
    });
    let _ = multi.clear();
    let sim_time = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let dir = out.tmp_dir().to_path_buf();
    let mut problems = Vec::new();
    for (slug, f) in &finished {
        let sub = dir.join(slug);
        std::fs::create_dir_all(&sub)?;
        let (_, p) = planar_output::write_run(
            &sub,
            f,
            &src.name,
            Outputs {
                figures: !a.common.no_figures,
            },
        )?;
        problems.extend(p.into_iter().map(|p| format!("{slug}: {p}")));
    }
    let mut figure_stems = Vec::new();
    if !a.common.no_figures {
        let runs: Vec<figures::CompareRun> = finished
            .iter()
            .map(|(_, f)| figures::CompareRun {
                label: f.label(),
                log: &f.outcome.log,
            })
            .collect();
        match figures::compare_figures(
            &dir,
            &runs,
            &src.name,
            base.k_c(),
            planar_output::zoom(&base),
        ) {
            Ok(s) => figure_stems = s,
            Err(e) => problems.push(format!("comparison figures: {e:#}")),
        }
    }
    let labels: Vec<String> = finished.iter().map(|(_, f)| f.label()).collect();
    let cols: Vec<(&str, &tandem::report::planar::Summary)> = finished
        .iter()
        .zip(&labels)
        .map(|((_, f), l)| (l.as_str(), &f.summary))
        .collect();
    output::write_text_atomic(
        &dir.join("report.md"),
        &report_md(&src, &base, &finished, &cols, &figure_stems),
    )?;
    let mut all = serde_json::Map::new();
    all.insert("scenario".into(), serde_json::json!(src.name));
    all.insert(
        "tandem_version".into(),
        serde_json::json!(env!("CARGO_PKG_VERSION")),
    );
    let mut runs = serde_json::Map::new();
    for (slug, f) in &finished {
        runs.insert(
            slug.to_string(),
            planar_output::summary_json(f, &src.name, None),
        );
    }
    all.insert("runs".into(), serde_json::Value::Object(runs));
    output::write_json_atomic(&dir.join("summary.json"), &serde_json::Value::Object(all))?;
    output::write_text_atomic(
        &dir.join("scenario.toml"),
        &planar_output::scenario_toml(&base, &src.name, None)?,
    )?;
    let final_dir = out.commit_with_warnings(&problems)?;
    println!(
        "{} — comparison, {} s, common start ({}, {}, {})",
        src.name,
        table::num(base.run.duration, 4),
        base.run.start()[0],
        base.run.start()[1],
        base.run.start()[2]
    );
    print!("{}", table::text(&cols));
    println!(
        "outputs in {} (simulated in {} s, written in {} s); report: {}",
        final_dir.display(),
        table::num(sim_time, 3),
        table::num(t1.elapsed().as_secs_f64(), 3),
        final_dir.join("report.md").display()
    );
    let refs: Vec<&Finished> = finished.iter().map(|(_, f)| f).collect();
    Ok(fault_exit(&refs))
}

fn report_md(
    src: &Source,
    base: &PlanarScenario,
    finished: &[(&str, Finished)],
    cols: &[(&str, &tandem::report::planar::Summary)],
    figures: &[String],
) -> String {
    let mut s = format!(
        "# Controller comparison: scenario `{}`\n\n{}\n\n",
        src.name,
        if base.description.is_empty() {
            String::new()
        } else {
            format!("{}.", base.description.trim_end_matches('.'))
        }
    );
    s.push_str(&format!(
        "Every controller starts at rest from the same pose x_o = ({}, {}, {}) (SPEC §4) and runs \
         {} s with seed {}. Generated by tandem {}.\n\n",
        base.run.start()[0],
        base.run.start()[1],
        base.run.start()[2],
        table::num(base.run.duration, 4),
        base.run.seed,
        env!("CARGO_PKG_VERSION")
    ));
    s.push_str("## Summary\n\n");
    s.push_str(&table::markdown(cols));
    s.push_str(
        "\n`z1 = x_1 − x_r` is the tracking error against the admittance reference; ‖z1_xy‖ is \
         its position part. The margin is `1 − max_j |x_1j|/k_cj` (negative: the output bound \
         is violated). Wall times vary from run to run; everything else is deterministic.\n\n",
    );
    let captions = [
        (
            "compare_xy",
            "Object centre in the XY plane (paper Figs. 6 and 11)",
        ),
        (
            "compare_trajectories",
            "Object coordinates against the desired path, with the bounds ±k_c (Figs. 7 and 12)",
        ),
        (
            "compare_z1",
            "Position tracking error z1, whole run and transient (Figs. 8 and 13)",
        ),
        (
            "compare_wrench",
            "Control wrench τ on the object (Figs. 10 and 15)",
        ),
        (
            "compare_margin",
            "Constraint margin 1 − max_j |x_1j|/k_cj (negative: bound violated)",
        ),
    ];
    if !figures.is_empty() {
        s.push_str("## Figures\n\n");
        for (stem, cap) in captions {
            if figures.iter().any(|f| f == stem) {
                s.push_str(&format!(
                    "### {cap}\n\n![{cap}]({stem}.png)\n\n[SVG]({stem}.svg)\n\n"
                ));
            }
        }
    }
    s.push_str("## Per-controller outputs\n\n");
    for (slug, f) in finished {
        s.push_str(&format!(
            "- **{}**: [`{slug}/`]({slug}/) — `timeseries.csv`, `summary.json`, `scenario.toml`{}\n",
            f.label(),
            if figures.is_empty() {
                ""
            } else {
                ", the paper's figures, `animation.svg`"
            }
        ));
    }
    s.push_str(
        "\n## Reading the results\n\n\
         - **NN (paper)** keeps the paper's gains. SPEC §3.4 explains why they do not converge: \
         with ϑ² = 50 and centres at ±1 the basis is nearly constant, the network acts as an \
         adaptive bias with a very high gain, and K2 is far below what the loop needs, so z2 \
         chatters in a limit cycle and the weight norms never settle.\n\
         - **NN (tuned)** is SPEC §3.4's preset that makes the paper's claims hold.\n\
         - **PD** is the paper's baseline (Section V-B-1, sign erratum of SPEC §3.5); **CTC** is \
         computed torque with the nominal model (SPEC §3.5), an extra baseline.\n\
         - For PD and CTC, `z2` is the velocity error ż1; for NN it is x_2 − α.\n",
    );
    s
}

fn cmd_robustness(a: RobustnessArgs) -> Result<ExitCode> {
    let threads = tandem_cli::threads(a.threads, "--threads")?;
    let src = scenario::resolve(a.scenario.as_deref())?;
    if let Scenario::Spatial(sc) = scenario::parse(&src)? {
        return cmd_robustness_spatial(&a, src, sc, threads);
    }
    let o = Overrides {
        duration: Some(a.duration.unwrap_or(20.0)),
        ..Overrides::default()
    };
    let (src, base) = match scenario::load_source(src, &o)? {
        (src, Scenario::Planar(sc)) => (src, sc),
        (src, Scenario::Spatial(_)) => {
            return Err(BadInput::msg(format!("{} is spatial", src.display)).into());
        }
    };
    let out_dir = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-robustness", src.name)));
    let protected = scenario::inputs(&src, &base);
    check_out(&out_dir, a.force, &protected)?;
    let t0 = Instant::now();
    let cells = robustness::run_grid(&base, &src, threads)?;
    let out = OutputDir::create(&out_dir, a.force, &protected)?;
    let mut cmd = vec!["tandem".to_string()];
    cmd.extend(std::env::args().skip(1).map(|a| shell_quote(&a)));
    robustness::write(out.tmp_dir(), &cells, &base, &cmd.join(" "))?;
    let dir = out.commit()?;
    let count = |c: &str| cells.iter().filter(|x| x.class == c).count();
    println!(
        "{} runs in {} s: {} inside, {} degraded, {} outside the bounds, {} faulted; report {}",
        cells.len(),
        table::num(t0.elapsed().as_secs_f64(), 3),
        count("inside"),
        count("degraded"),
        count("outside"),
        count("fault"),
        dir.join("robustness.md").display()
    );
    Ok(ExitCode::SUCCESS)
}

/// `tandem robustness` on a spatial scenario: its compliant-grasp sweep
/// (`robustness::grasps`).
fn cmd_robustness_spatial(
    a: &RobustnessArgs,
    src: Source,
    sc: SpatialScenario,
    threads: usize,
) -> Result<ExitCode> {
    use robustness::grasps;
    let out_dir = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-robustness", src.name)));
    let protected = scenario::inputs(&src, &sc);
    check_out(&out_dir, a.force, &protected)?;
    let grid = grasps::Grid::default();
    let t0 = Instant::now();
    let s = grasps::run(
        &src,
        &grid,
        a.duration.unwrap_or(grasps::DEFAULT_DURATION),
        threads,
    )?;
    let out = OutputDir::create(&out_dir, a.force, &protected)?;
    let mut cmd = vec!["tandem".to_string()];
    cmd.extend(std::env::args().skip(1).map(|a| shell_quote(&a)));
    grasps::write(out.tmp_dir(), &s, &grid, &cmd.join(" "))?;
    let dir = out.commit()?;
    let clean = s.cells.iter().filter(|c| c.clean()).count();
    let held = s.cells.iter().filter(|c| c.held()).count();
    let invalid: Vec<_> = s.cells.iter().filter(|c| c.status == "invalid").collect();
    if let Some(c) = invalid.first() {
        eprintln!(
            "warning: {} of {} runs could not be set up (marked invalid in the report); the first: {}",
            invalid.len(),
            s.cells.len(),
            c.message
        );
    }
    println!(
        "{} runs in {} s: {clean} clean, {} held but chattering or missing S5, {} violated or \
         faulted; report {}",
        s.cells.len(),
        table::num(t0.elapsed().as_secs_f64(), 3),
        held - clean,
        s.cells.len() - held - invalid.len(),
        dir.join("robustness.md").display()
    );
    Ok(ExitCode::SUCCESS)
}

fn cmd_sweep(a: SweepArgs) -> Result<ExitCode> {
    let threads = tandem_cli::threads(a.threads, "--threads")?;
    let sw = sweep::Sweep::load(&a.file)?;
    let shard = match &a.shard {
        Some(s) => Some(sweep::Shard::parse(s, "--shard")?),
        None => sweep::Shard::from_env()?,
    };
    let out_dir = a.out.clone().unwrap_or_else(|| {
        let stem = a
            .file
            .file_stem()
            .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned());
        let mut name = format!("{stem}-sweep");
        if let Some(s) = shard {
            name.push_str(&format!("-shard-{}-of-{}", s.index, s.count));
        }
        PathBuf::from("out").join(name)
    });
    let protected = sw.inputs(Some(&a.file));
    check_out(&out_dir, a.force, &protected)?;
    let out = OutputDir::create(&out_dir, a.force, &protected)?;
    let keep = a.keep_runs.then(|| out.tmp_dir().join("runs"));
    let idx = sweep::run::indices(&sw, shard);
    let t0 = Instant::now();
    let results = sweep::run::run_all(&sw, &idx, threads, keep.as_deref())?;
    let elapsed = t0.elapsed().as_secs_f64();
    let header = sweep::run::header(&sw);
    let status = 2 + sw.params.len();
    let count = |s: &str| results.iter().filter(|r| r.row.cells[status] == s).count();
    let (ok, faulted, invalid) = (count("completed"), count("fault"), count("invalid"));
    let rows: Vec<sweep::run::Row> = results.into_iter().map(|r| r.row).collect();
    // The kernel the runs used (checked at start-up, so present), recorded in sweep.json.
    let kernels: Vec<String> = tandem::control::rbf::Kernel::from_env()
        .map(|k| vec![k.name().to_string()])
        .unwrap_or_default();
    let problems = sweep::merge::write_folder(
        out.tmp_dir(),
        &sw.resolved_json(),
        &sw.hash(),
        shard,
        &header,
        &rows,
        &kernels,
        !a.no_figures,
    )?;
    let dir = out.commit_with_warnings(&problems)?;
    println!(
        "{} runs{} in {} s on {threads} thread{}: {ok} completed, {faulted} faulted, {invalid} invalid; table {}",
        rows.len(),
        shard.map_or_else(String::new, |s| format!(
            " (shard {}/{} of {} runs)",
            s.index, s.count, sw.total
        )),
        table::num(elapsed, 3),
        if threads == 1 { "" } else { "s" },
        dir.join("runs.csv").display()
    );
    Ok(ExitCode::SUCCESS)
}

fn cmd_merge(a: MergeArgs) -> Result<ExitCode> {
    let protected: Vec<output::Input> = a
        .dirs
        .iter()
        .map(|d| output::Input::new("a shard folder given to merge", d))
        .collect();
    check_out(&a.out, a.force, &protected)?;
    let m = sweep::merge::merge(&a.dirs)?;
    let out = OutputDir::create(&a.out, a.force, &protected)?;
    let mut problems = sweep::merge::write_folder(
        out.tmp_dir(),
        &m.resolved,
        &m.hash,
        None,
        &m.header,
        &m.rows,
        &m.kernels,
        !a.no_figures,
    )?;
    if m.kernels.len() > 1 {
        problems.push(format!(
            "the shards ran different RBF kernels ({}): their results agree within the \
             kernels' stated tolerance, not bit for bit (README, \"Speed and determinism\")",
            m.kernels.join(", ")
        ));
    }
    let dir = out.commit_with_warnings(&problems)?;
    println!(
        "merged {} folders, {} runs: table {}",
        a.dirs.len(),
        m.rows.len(),
        dir.join("runs.csv").display()
    );
    Ok(ExitCode::SUCCESS)
}

fn cmd_validate(arg: &str, branches: bool) -> Result<ExitCode> {
    let (src, sc) = match scenario::load(Some(arg), &Overrides::default())? {
        (src, Scenario::Planar(sc)) => {
            if branches {
                // The same refusal as `tandem ik`'s.
                tandem_cli::ik::load(arg, "tandem validate --branches")?;
            }
            (src, sc)
        }
        (src, Scenario::Spatial(sc)) => {
            let ik_sc = sc.clone();
            let label = spatial::label(&sc);
            let p = spatial::prepare(sc, &src)?;
            let b = &p.built;
            let dofs = scenario::spatial::dofs(b);
            let ticks = (b.sim.duration / b.sim.control_period).round() as u64;
            let per_log = (b.sim.log_period / b.sim.control_period).round().max(1.0) as u64;
            println!("ok: {}", src.display);
            if !p.sc.description.is_empty() {
                println!("  {}", p.sc.description);
            }
            let arms: Vec<String> = b
                .plant
                .arms
                .iter()
                .map(|a| {
                    format!(
                        "{} ({} → {}, {} joints)",
                        a.chain.name,
                        a.chain.base_link,
                        a.chain.tool_link,
                        a.chain.joints.len()
                    )
                })
                .collect();
            println!("  spatial: {} arms: {}", dofs.len(), arms.join(", "));
            println!(
                "  path {:?}, controller {label}{}",
                p.sc.path.kind,
                if p.sc.admittance.enabled && p.built.replay.is_none() {
                    ", admittance on"
                } else {
                    ""
                }
            );
            if let Some(m) = p.ready.path_inertia {
                println!(
                    "  chart-space inertia along the path (largest): {} kg, {} kg m²",
                    m[..3]
                        .iter()
                        .map(|v| table::num(*v, 3))
                        .collect::<Vec<_>>()
                        .join(", "),
                    m[3..]
                        .iter()
                        .map(|v| table::num(*v, 3))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
            println!(
                "  {} s: {} control ticks, {} log rows",
                table::num(b.sim.duration, 6),
                ticks,
                ticks.div_ceil(per_log)
            );
            print_warnings(&label, &p.ready.warnings);
            if branches {
                let r = tandem_cli::ik::ik(&src, &ik_sc, &tandem_cli::ik::IkOptions::default())?;
                println!();
                print!("{}", tandem_cli::ik::ik_text(&r));
            }
            return Ok(ExitCode::SUCCESS);
        }
    };
    let label = runner::label(&sc);
    let p = runner::prepare(sc, &src)?;
    let b = &p.built;
    let n_q: usize = b.plant.arms.iter().map(|a| a.links.len()).sum();
    let ticks = (b.sim.duration / b.sim.control_period).round() as u64;
    let per_log = (b.sim.log_period / b.sim.control_period).round().max(1.0) as u64;
    let rows = ticks.div_ceil(per_log);
    println!("ok: {}", src.display);
    if !p.sc.description.is_empty() {
        println!("  {}", p.sc.description);
    }
    println!(
        "  {} arms ({n_q} joints), path {}, controller {label}{}",
        b.plant.arms.len(),
        p.sc.path.kind.name(),
        if p.built
            .controller
            .as_ref()
            .and_then(|c| c.admittance.as_ref())
            .is_some()
        {
            ", admittance on"
        } else {
            ""
        }
    );
    println!(
        "  {} s: {} control ticks, {} log rows",
        table::num(b.sim.duration, 6),
        ticks,
        rows
    );
    print_warnings(&label, &p.ready.warnings);
    Ok(ExitCode::SUCCESS)
}

fn cmd_ik(a: IkArgs) -> Result<ExitCode> {
    use tandem_cli::ik;
    let (src, sc) = ik::load(&a.scenario, "tandem ik")?;
    let protected = ik::protected(&src, &sc);
    if let Some(p) = &a.json {
        ik::check_json_out(p, a.force, &protected, "tandem ik")?;
    }
    let opts = ik::IkOptions {
        arm: a.arm,
        starts: a.starts,
        seed: a.seed,
        every: a.every,
    };
    let r = ik::ik(&src, &sc, &opts)?;
    print_warnings(&r.name, &r.warnings);
    print!("{}", ik::ik_text(&r));
    if let Some(p) = &a.json {
        ik::write_json(p, &ik::ik_json(&r), a.force, &protected, "tandem ik")?;
        eprintln!("{}: branches written to {}", r.name, p.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_place(a: PlaceArgs) -> Result<ExitCode> {
    use tandem_cli::ik;
    let (src, sc) = ik::load(&a.scenario, "tandem place")?;
    let protected = ik::protected(&src, &sc);
    if let Some(p) = &a.json {
        ik::check_json_out(p, a.force, &protected, "tandem place")?;
    }
    let opts = ik::PlaceOptions {
        from: a.from,
        to: a.to,
        step: a.step,
        every: a.every,
        seed: a.seed,
        starts: a.starts,
    };
    let r = ik::place(&src, &sc, &opts)?;
    print!("{}", ik::place_text(&r));
    if let Some(p) = &a.json {
        ik::write_json(p, &ik::place_json(&r), a.force, &protected, "tandem place")?;
        eprintln!("{}: placement scan written to {}", r.name, p.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_export(a: ExportArgs) -> Result<ExitCode> {
    use std::io::Write;
    use tandem_cli::export::{self, Format};
    let out = a.out.filter(|p| p.as_os_str() != "-");
    let format = Format::resolve(a.format, out.as_deref())?;
    let (src, sc) = scenario::load(Some(&a.scenario), &Overrides::default())?;
    let Scenario::Spatial(spatial_sc) = &sc else {
        return Err(export::planar_refusal(&src, format).into());
    };
    // The output is checked before any work, and again just before it is written.
    let protected = scenario::inputs(&src, spatial_sc);
    let check = |p: &Path| -> Result<()> {
        if std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir()) {
            return Err(BadInput::msg(format!(
                "--out {}: is a folder; give the file to write (e.g. {})",
                p.display(),
                p.join(format!(
                    "{}.{}",
                    src.name,
                    if format == Format::Json {
                        "json"
                    } else {
                        "xml"
                    }
                ))
                .display()
            ))
            .into());
        }
        if std::fs::symlink_metadata(p).is_err() {
            return Ok(());
        }
        if a.force {
            return output::check_file_replaceable(p, &protected, export::WRITTEN_MARKS);
        }
        let mut cmd = vec!["tandem".to_string()];
        cmd.extend(std::env::args().skip(1).map(|a| shell_quote(&a)));
        cmd.push("--force".into());
        Err(BadInput::msg(format!(
            "{} exists (nothing was written). To overwrite it, run:\n    {}\nor choose another file with --out FILE",
            p.display(),
            cmd.join(" ")
        ))
        .into())
    };
    if let Some(p) = &out {
        check(p)?;
    }
    let setup = export::setup(sc, &src, format)?;
    print_warnings(&setup.name, &setup.warnings);
    let text = export::render(&setup, format)?;
    match &out {
        None => {
            let mut so = std::io::stdout().lock();
            so.write_all(text.as_bytes())?;
            so.flush()?;
        }
        Some(p) => {
            check(p)?;
            if let Some(parent) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(parent).map_err(|e| {
                    anyhow::anyhow!(
                        "cannot create the folder {} for --out: {e}",
                        parent.display()
                    )
                })?;
            }
            output::write_text_atomic(p, &text)?;
            eprintln!(
                "{}: {} ({} arms, {} joints) written to {}",
                setup.name,
                format.name(),
                setup.arms.len(),
                setup.n_q(),
                p.display()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_scenario(c: ScenarioCommand) -> Result<ExitCode> {
    match c {
        ScenarioCommand::List => {
            let w = scenario::EMBEDDED
                .iter()
                .map(|e| e.name.len())
                .max()
                .unwrap_or(0);
            for e in scenario::EMBEDDED.iter().filter(|e| e.kind == Kind::Planar) {
                println!(
                    "{:w$}  {}{}",
                    e.name,
                    e.summary,
                    if e.name == scenario::DEFAULT {
                        " (default)"
                    } else {
                        ""
                    }
                );
            }
            for e in scenario::EMBEDDED
                .iter()
                .filter(|e| e.kind == Kind::Spatial)
            {
                println!("{:w$}  {} (spatial)", e.name, e.summary);
            }
            println!("\nShow one with `tandem scenario show NAME`; copy it to start your own.");
        }
        ScenarioCommand::Show { name } => {
            let all = || scenario::EMBEDDED.iter();
            let Some(e) = all().find(|e| e.name == name) else {
                let names: Vec<&str> = all().map(|e| e.name).collect();
                let mut msg = format!("no embedded scenario `{name}`");
                if let Some(s) = suggest::closest(&name, names.iter().copied()) {
                    msg.push_str(&format!(" — did you mean `{s}`?"));
                }
                msg.push_str(&format!(" (embedded: {})", names.join(", ")));
                return Err(BadInput::msg(msg).into());
            };
            print!("{}", e.text);
        }
    }
    Ok(ExitCode::SUCCESS)
}
