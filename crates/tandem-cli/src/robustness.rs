//! `tandem robustness`: every fault family of `[faults]` at increasing severity, for PD and the
//! NN law (tuned), from one scenario; a report (`robustness.md`), a figure and `results.json`.
//!
//! Each run is classified:
//! - **inside**: completed, the true pose never left the bounds (`violations = 0`), and the
//!   tracking error after the transient stays below [`TRACK_MM`];
//! - **degraded**: completed, but it violated the bounds or tracked worse than that;
//! - **fault**: stopped early with a named fault (drift, singular arm, non-finite value, ...).

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::Result;
use serde_json::json;

use crate::plot::{self, Panel, Series, Style};
use crate::runner::{self, Finished};
use crate::scenario::{ControllerKind, FaultsConfig, GainPreset, Scenario, Source};
use crate::table::num;

/// Largest tracking error after the transient of a run that stays "inside", mm.
pub const TRACK_MM: f64 = 10.0;

/// A fault family: name, unit of its severity, the levels (mildest first) and how a level is
/// set in `[faults]`.
pub struct Family {
    /// Name.
    pub name: &'static str,
    /// What the level is.
    pub what: &'static str,
    /// Severity levels, mildest first.
    pub levels: &'static [f64],
    /// Sets a level.
    pub set: fn(&mut FaultsConfig, f64),
}

/// The studied families.
pub const FAMILIES: &[Family] = &[
    Family {
        name: "sensor dropout bursts",
        what: "burst length, s (1 burst/s, every reading held)",
        levels: &[0.01, 0.03, 0.1, 0.3, 1.0],
        set: |f, v| {
            f.dropout_rate = 1.0;
            f.dropout_length = v;
        },
    },
    Family {
        name: "force-sensor saturation",
        what: "saturation per component, N",
        levels: &[2.0, 1.0, 0.5, 0.2, 0.05],
        set: |f, v| f.force_limit = Some(v),
    },
    Family {
        name: "force-sensor delay",
        what: "delay, s",
        levels: &[0.01, 0.03, 0.1, 0.3, 1.0],
        set: |f, v| f.force_delay = v,
    },
    Family {
        name: "actuator torque limit",
        what: "saturation, N m",
        levels: &[50.0, 20.0, 10.0, 5.0, 2.0],
        set: |f, v| f.torque_limit = Some(v),
    },
    Family {
        name: "actuator rate limit",
        what: "rate limit, N m/s",
        levels: &[10000.0, 3000.0, 1000.0, 300.0, 100.0],
        set: |f, v| f.torque_rate = Some(v),
    },
    Family {
        name: "payload mismatch",
        what: "true mass and inertia / nominal",
        levels: &[1.25, 1.5, 2.0, 3.0, 5.0],
        set: |f, v| {
            f.payload_mass = v;
            f.payload_inertia = v;
        },
    },
    Family {
        name: "encoder quantisation",
        what: "resolution, rad",
        levels: &[1e-4, 3e-4, 1e-3, 3e-3, 1e-2],
        set: |f, v| f.encoder_resolution = v,
    },
];

/// The compared laws: (kind, preset, label).
const LAWS: [(ControllerKind, Option<GainPreset>, &str); 2] = [
    (ControllerKind::Pd, None, "PD"),
    (ControllerKind::Nn, Some(GainPreset::Tuned), "NN (tuned)"),
];

/// One run of the grid.
pub struct Cell {
    /// Family index (`None`: nominal).
    pub family: Option<usize>,
    /// Level index.
    pub level: usize,
    /// Law index.
    pub law: usize,
    /// inside / degraded / fault.
    pub class: &'static str,
    /// Details for the table.
    pub detail: String,
    /// Min margin (NaN if none).
    pub margin: f64,
    /// Max ‖z1_xy‖ after the transient, mm (NaN if none).
    pub track_mm: f64,
}

fn classify(f: &Finished) -> (&'static str, String, f64, f64) {
    let s = &f.summary;
    let margin = if s.min_margin.is_finite() {
        s.min_margin
    } else {
        f64::NAN
    };
    let after = s.t_end > s.transient;
    let track = if after {
        s.max_z1_after * 1e3
    } else {
        f64::NAN
    };
    if let Some(fault) = &f.outcome.fault {
        let kind = serde_json::to_value(&fault.kind)
            .ok()
            .and_then(|v| v["kind"].as_str().map(str::to_string))
            .unwrap_or_default();
        return (
            "fault",
            format!("{kind} at {} s", num(fault.t, 3)),
            margin,
            track,
        );
    }
    let inside = s.violations == 0 && track <= TRACK_MM;
    let detail = format!(
        "margin {}, err {} mm{}",
        num(margin, 2),
        num(track, 3),
        if s.violations > 0 {
            format!(", {} violating ticks", s.violations)
        } else {
            String::new()
        }
    );
    (
        if inside { "inside" } else { "degraded" },
        detail,
        margin,
        track,
    )
}

/// Run the grid from `base` (duration overridden by the caller) on `threads` threads.
pub fn run_grid(base: &Scenario, src: &Source, threads: usize) -> Result<Vec<Cell>> {
    let mut jobs: Vec<(Option<usize>, usize, usize, Scenario)> = Vec::new();
    for (l, (kind, gains, _)) in LAWS.iter().enumerate() {
        let mut sc = base.clone();
        sc.controller.kind = *kind;
        sc.controller.gains = *gains;
        sc.faults = FaultsConfig::default();
        jobs.push((None, 0, l, sc.clone()));
        for (fi, fam) in FAMILIES.iter().enumerate() {
            for (li, &v) in fam.levels.iter().enumerate() {
                let mut s = sc.clone();
                (fam.set)(&mut s.faults, v);
                jobs.push((Some(fi), li, l, s));
            }
        }
    }
    // Validate everything first: a bad scenario is bad input, before any run.
    let mut prepared = Vec::new();
    for (f, lv, law, sc) in jobs {
        prepared.push(Mutex::new(Some((f, lv, law, runner::prepare(sc, src)?))));
    }
    let next = AtomicUsize::new(0);
    let cells: Mutex<Vec<Cell>> = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(slot) = prepared.get(i) else { break };
                    let Some((family, level, law, p)) = slot.lock().ok().and_then(|mut g| g.take())
                    else {
                        continue;
                    };
                    let f = runner::execute(p, |_| {});
                    let (class, detail, margin, track_mm) = classify(&f);
                    if let Ok(mut c) = cells.lock() {
                        c.push(Cell {
                            family,
                            level,
                            law,
                            class,
                            detail,
                            margin,
                            track_mm,
                        });
                    }
                }
            });
        }
    });
    let mut cells = cells.into_inner().unwrap_or_default();
    cells.sort_by_key(|c| (c.family.map_or(0, |f| f + 1), c.law, c.level));
    Ok(cells)
}

/// The report, the figure and `results.json` into `dir`.
pub fn write(dir: &std::path::Path, cells: &[Cell], base: &Scenario, cmd: &str) -> Result<()> {
    let find = |f: Option<usize>, lv: usize, law: usize| {
        cells
            .iter()
            .find(|c| c.family == f && c.level == lv && c.law == law)
    };
    let mut md = String::from("# Robustness to injected faults\n\n");
    md.push_str(&format!(
        "Generated by `{cmd}` (tandem {}): the paper scenario, {} s per run, seed {}, for PD and \
         the NN law (tuned gains). Each fault family of the scenario's `[faults]` section runs at \
         five increasing severities; everything else is nominal. A run is **inside** when it \
         completes, the true pose never leaves the bounds `|x_1j| < k_cj`, and `‖z1_xy‖` stays \
         below {TRACK_MM} mm after the {} s transient; **degraded** when it completes but \
         violates the bounds or tracks worse; **fault** when it stops with a named fault. Every \
         run either completes or stops with a named fault.\n\n",
        env!("CARGO_PKG_VERSION"),
        num(base.run.duration, 4),
        base.run.seed,
        num(base.metrics.transient, 3),
    ));
    md.push_str(
        "Reproduce this page (about 15 s):\n\n```sh\ncargo run --release -p tandem-cli -- robustness \
         --out out/robustness --force && cp out/robustness/robustness.md docs/ && \
         cp out/robustness/figures/robustness*.png docs/figures/\n```\n\n\
         The knobs are the scenario's `[faults]` section (see `crates/tandem-cli/README.md`); \
         `results.json` next to the report holds every run.\n\n",
    );
    md.push_str("## Nominal\n\n| law | result |\n|---|---|\n");
    for (l, (_, _, name)) in LAWS.iter().enumerate() {
        if let Some(c) = find(None, 0, l) {
            md.push_str(&format!("| {name} | **{}** ({}) |\n", c.class, c.detail));
        }
    }
    md.push_str(
        "\n![Minimum constraint margin per family](figures/robustness.png)\n\n\
         ![Tracking error per family](figures/robustness_error.png)\n\n\
         The figures plot, per family and severity level (1 = mildest), the minimum constraint \
         margin `1 − max_j |x_1j|/k_cj` over the run (below 0: the bound was violated) and the \
         largest `‖z1_xy‖` after the transient (clipped at the top of the axis); a run that \
         faulted ends its law's line. The tables below give every run.\n\n",
    );
    for (fi, fam) in FAMILIES.iter().enumerate() {
        md.push_str(&format!("## {} ({})\n\n| level |", fam.name, fam.what));
        for (_, _, name) in LAWS {
            md.push_str(&format!(" {name} |"));
        }
        md.push_str("\n|---|");
        for _ in LAWS {
            md.push_str("---|");
        }
        md.push('\n');
        for (li, v) in fam.levels.iter().enumerate() {
            md.push_str(&format!("| {} |", num(*v, 3)));
            for l in 0..LAWS.len() {
                match find(Some(fi), li, l) {
                    Some(c) => md.push_str(&format!(" **{}** ({}) |", c.class, c.detail)),
                    None => md.push_str(" — |"),
                }
            }
            md.push('\n');
        }
        md.push('\n');
    }
    md.push_str(
        "Not studied yet: a grasp that slips (a compliant grasp with low stiffness). The \
         compliant grasp exists in the spatial plant (`plant::spatial::GraspModel::Compliant`), \
         but PD and the NN law run on the planar plant here; the family joins this report with \
         the spatial controller and scenarios.\n",
    );
    crate::output::write_text_atomic(&dir.join("robustness.md"), &md)?;

    // Figures: one panel per family, the metric against the level, one series per law; a
    // faulted run ends its law's line.
    std::fs::create_dir_all(dir.join("figures"))?;
    let xs: Vec<f64> = (1..=5).map(f64::from).collect();
    type Metric = fn(&Cell) -> f64;
    /// (file stem, title, y label, metric, y range, reference line and its label).
    type Fig<'a> = (&'a str, &'a str, &'a str, Metric, (f64, f64), f64, &'a str);
    let figs: [Fig; 2] = [
        (
            "robustness",
            "Robustness: minimum constraint margin per fault family and severity",
            "min margin",
            |c| c.margin,
            (-0.5, 1.0),
            0.0,
            "bound",
        ),
        (
            "robustness_error",
            "Robustness: max tracking error ‖z1_xy‖ after the transient",
            "max ‖z1_xy‖ after transient [mm]",
            |c| c.track_mm,
            (0.0, 2.0 * TRACK_MM),
            TRACK_MM,
            "inside limit",
        ),
    ];
    for (stem, title, y_label, metric, (lo, hi), line, line_label) in figs {
        let ys: Vec<Vec<Vec<f64>>> = (0..FAMILIES.len())
            .map(|fi| {
                (0..LAWS.len())
                    .map(|l| {
                        (0..FAMILIES[fi].levels.len())
                            .map_while(|lv| {
                                find(Some(fi), lv, l)
                                    .filter(|c| c.class != "fault" && metric(c).is_finite())
                                    .map(|c| metric(c).clamp(lo, hi))
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let mut panels = Vec::new();
        for (fi, fam) in FAMILIES.iter().enumerate() {
            let mut p = Panel::new(fam.name, format!("level (1..5: {})", fam.what), y_label)
                .hline(line, line_label)
                .x_range(0.5, 5.5)
                .y_range(lo, hi);
            for (l, (_, _, name)) in LAWS.iter().enumerate() {
                let y = &ys[fi][l];
                p = p.with(Series::new(*name, &xs[..y.len()], y, Style::solid(l)));
            }
            panels.push(p);
        }
        plot::panels(&dir.join("figures").join(stem), title, &panels, 2)?;
    }
    let rows: Vec<serde_json::Value> = cells
        .iter()
        .map(|c| {
            json!({
                "family": c.family.map(|f| FAMILIES[f].name),
                "level": c.family.map(|f| FAMILIES[f].levels[c.level]),
                "law": LAWS[c.law].2,
                "class": c.class,
                "detail": c.detail,
                "min_margin": c.margin.is_finite().then_some(c.margin),
                "max_z1_after_mm": c.track_mm.is_finite().then_some(c.track_mm),
            })
        })
        .collect();
    crate::output::write_json_atomic(&dir.join("results.json"), &json!({ "runs": rows }))?;
    Ok(())
}
