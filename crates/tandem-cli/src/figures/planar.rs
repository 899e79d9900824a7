//! The figures of a run (the paper's Figs. 6–16 plus grasp forces, joint torques, switching and
//! margin) and of a comparison, drawn from the library's [`Log`] with the `plot` module.
//!
//! | file | paper | content |
//! |---|---|---|
//! | `xy_path` | Figs. 6, 11 | object centre in the XY plane, desired circle, `k_c` box |
//! | `trajectories` | Figs. 7, 12 | x, y, θ against their desired values, `±k_c` bounds |
//! | `z1` | Figs. 8, 13 | `z1 = x_1 − x_r` per coordinate, whole run and transient |
//! | `z2` | Figs. 9, 14 | `z2 = x_2 − α` (NN) or `ż1` (PD, CTC) |
//! | `wrench` | Figs. 10, 15 | wrench `τ` commanded on the object |
//! | `admittance` | — | reference offset `x_r − x_d` of the admittance generators |
//! | `weights` | Fig. 16 | NN weight norms `‖Ŵ_j‖` (NN only) |
//! | `grasp_forces` | — | `F_i` per arm (the object on end-effector i) |
//! | `joint_torques` | — | joint torques per arm |
//! | `switching` | — | switching value `Q` (NN) and constraint margin |
//!
//! Figures are independent: they are drawn on all cores.

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::Result;
use tandem::sim::Log;

use crate::figures::plot::{self, Panel, Series, Style};

/// What the figures need besides the log.
#[derive(Clone, Debug)]
pub struct FigureInfo {
    /// Title prefix, e.g. `paper — NN (tuned)`.
    pub title: String,
    /// Output bounds `k_c`, (m, m, rad).
    pub k_c: [f64; 3],
    /// Length of the zoomed-in transient panels, s (`None`: no zoom column).
    pub zoom: Option<f64>,
    /// The run used the NN law (weights, Q, α exist).
    pub nn: bool,
    /// The run was a torque replay (no controller internals).
    pub replay: bool,
    /// The admittance generator was on (the reference `x_r` differs from `x_d`).
    pub admittance: bool,
    /// Joints per arm.
    pub joints: Vec<usize>,
}

const AX: [&str; 3] = ["x", "y", "theta"];
const AX_SYM: [&str; 3] = ["x", "y", "θ"];

/// A column, or an empty slice when the log has none.
pub(crate) fn col<'a>(log: &'a Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// One panel per arm of its joint torques `tau_q{k}` (arm `i + 1` has `dofs[i]` joints; the
/// columns are numbered across the arms), for the planar and the spatial `joint_torques`
/// figure. A column that is missing or not of `t`'s length is left out.
pub(crate) fn joint_torque_panels<'a>(
    log: &'a Log,
    t: &'a [f64],
    dofs: &[usize],
) -> Vec<Panel<'a>> {
    let mut off = 0;
    dofs.iter()
        .enumerate()
        .map(|(i, &n)| {
            let mut p = Panel::new(
                format!("arm {}", i + 1),
                "t [s]",
                format!("τ_q (arm {}) [N m]", i + 1),
            );
            for k in 0..n {
                let c = col(log, &format!("tau_q{}", off + k + 1));
                if c.len() == t.len() {
                    p = p.with(Series::new(
                        format!("joint {}", k + 1),
                        t,
                        c,
                        Style::solid(k),
                    ));
                }
            }
            off += n;
            p
        })
        .collect()
}

/// The constraint margin of several runs, `(label, t, margin)`, on one panel with the violation
/// line at zero (the `compare_margin` figure, planar and spatial). A run whose margin is empty
/// or not of its `t`'s length is left out.
pub(crate) fn margin_panel<'a>(
    runs: impl IntoIterator<Item = (&'a str, &'a [f64], &'a [f64])>,
) -> Panel<'a> {
    let mut m = Panel::new(
        "constraint margin 1 − max_j |x_1j|/k_cj",
        "t [s]",
        "margin [1]",
    );
    for (i, (label, t, margin)) in runs.into_iter().enumerate() {
        if margin.len() == t.len() && !t.is_empty() {
            m = m.with(Series::new(label, t, margin, Style::solid(i)));
        }
    }
    m.hline(0.0, "violation")
}

fn unit(j: usize, lin: &str, rot: &str) -> String {
    if j < 2 { lin.into() } else { rot.into() }
}

/// How to draw one figure.
pub(crate) type Draw<'a> = Box<dyn FnOnce() -> Result<()> + Send + 'a>;
/// One logged quantity with three components, drawn per axis.
struct Quantity {
    /// File stem.
    stem: &'static str,
    /// Column group in the log (`z1` for `z1.x`, …).
    group: &'static str,
    /// Symbol in titles and labels.
    sym: &'static str,
    /// Units of the linear and the angular component.
    units: (&'static str, &'static str),
    /// Figure title.
    what: &'static str,
}

/// A figure job: its file stem and how to draw it.
pub(crate) type Job<'a> = (String, Draw<'a>);

/// Run the jobs on up to `available_parallelism` threads; the first error wins.
pub(crate) fn run_jobs(jobs: Vec<Job<'_>>) -> Result<Vec<String>> {
    let names: Vec<String> = jobs.iter().map(|(n, _)| n.clone()).collect();
    let slots: Vec<Mutex<Option<Draw<'_>>>> =
        jobs.into_iter().map(|(_, j)| Mutex::new(Some(j))).collect();
    let next = AtomicUsize::new(0);
    let errors: Mutex<Vec<(usize, anyhow::Error)>> = Mutex::new(Vec::new());
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(slots.len())
        .max(1);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(slot) = slots.get(i) else { break };
                    let job = slot.lock().ok().and_then(|mut g| g.take());
                    if let Some(job) = job
                        && let Err(e) = job()
                        && let Ok(mut v) = errors.lock()
                    {
                        v.push((i, e));
                    }
                }
            });
        }
    });
    let mut errors = errors.into_inner().unwrap_or_default();
    errors.sort_by_key(|(i, _)| *i);
    match errors.into_iter().next() {
        Some((_, e)) => Err(e),
        None => Ok(names),
    }
}

/// Panels of one quantity per coordinate: rows x, y, θ; columns whole run and (if `zoom`) the
/// first `zoom` seconds.
fn per_axis<'a>(
    t: &'a [f64],
    zoom: Option<f64>,
    sym: &str,
    units: (&str, &str),
    series: impl Fn(usize) -> Vec<Series<'a>>,
) -> (Vec<Panel<'a>>, usize) {
    let mut panels = Vec::new();
    let t_end = t.last().copied().unwrap_or(0.0);
    let zoom = zoom.filter(|z| *z < t_end);
    for j in 0..3 {
        let y_label = format!("{sym}_{} [{}]", AX_SYM[j], unit(j, units.0, units.1));
        let mut p = Panel::new(format!("{sym}: {}", AX_SYM[j]), "t [s]", y_label.clone());
        p.series = series(j);
        panels.push(p.clone());
        if let Some(z) = zoom {
            let mut q = p;
            q.title = format!("{sym}: {}, first {z} s", AX_SYM[j]);
            panels.push(q.x_range(t.first().copied().unwrap_or(0.0), z));
        }
    }
    let cols = if zoom.is_some() { 2 } else { 1 };
    (panels, cols)
}

/// Draw every figure of one run into `dir`; returns the stems written.
pub fn run_figures(dir: &Path, log: &Log, info: &FigureInfo) -> Result<Vec<String>> {
    let t = col(log, "t");
    let mut jobs: Vec<Job> = Vec::new();
    let title = |what: &str| format!("{} — {what}", info.title);
    let k_c = info.k_c;

    // Figs. 6/11: XY path.
    {
        let stem = dir.join("xy_path");
        let ttl = title("object centre in the XY plane");
        jobs.push((
            "xy_path".into(),
            Box::new(move || {
                plot::xy_path(
                    &stem,
                    &ttl,
                    (col(log, "x_o.x"), col(log, "x_o.y")),
                    (col(log, "x_d.x"), col(log, "x_d.y")),
                    Some((k_c[0], k_c[1])),
                    &[],
                )
            }),
        ));
    }

    // Figs. 7/12: coordinates against their desired values, with ±k_c.
    {
        let stem = dir.join("trajectories");
        let ttl = title("object trajectory and output bounds");
        jobs.push((
            "trajectories".into(),
            Box::new(move || {
                let panels: Vec<Panel> = (0..3)
                    .map(|j| {
                        let a = AX[j];
                        Panel::new(
                            format!("{}: actual and desired", AX_SYM[j]),
                            "t [s]",
                            format!("{} [{}]", AX_SYM[j], unit(j, "m", "rad")),
                        )
                        .with(Series::new(
                            format!("{}_o", AX_SYM[j]),
                            t,
                            col(log, &format!("x_o.{a}")),
                            Style::solid(0),
                        ))
                        .with(Series::new(
                            format!("{}_d", AX_SYM[j]),
                            t,
                            col(log, &format!("x_d.{a}")),
                            Style::dashed(1),
                        ))
                        .bounds(k_c[j], "±k_c")
                    })
                    .collect();
                plot::panels(&stem, &ttl, &panels, 1)
            }),
        ));
    }

    // Figs. 8/13 and 9/14: z1 and z2 (z2 has no meaning for a replay).
    let mut errs = vec![Quantity {
        stem: "z1",
        group: "z1",
        sym: "z1",
        units: ("m", "rad"),
        what: if info.replay {
            "position error z1 = x_o − x_d"
        } else {
            "position tracking error z1 = x_1 − x_r"
        },
    }];
    if !info.replay {
        errs.push(Quantity {
            stem: "z2",
            group: "z2",
            sym: "z2",
            units: ("m/s", "rad/s"),
            what: if info.nn {
                "tracking error z2 = x_2 − α"
            } else {
                "velocity error z2 = ż1 = x_2 − ẋ_r"
            },
        });
        errs.push(Quantity {
            stem: "wrench",
            group: "tau",
            sym: "τ",
            units: ("N", "N m"),
            what: "control wrench τ on the object",
        });
    }
    for Quantity {
        stem: stem_name,
        group,
        sym,
        units,
        what,
    } in errs
    {
        let stem = dir.join(stem_name);
        let ttl = title(what);
        let zoom = info.zoom;
        jobs.push((
            stem_name.into(),
            Box::new(move || {
                let (panels, cols) = per_axis(t, zoom, sym, units, |j| {
                    vec![Series::new(
                        "",
                        t,
                        col(log, &format!("{group}.{}", AX[j])),
                        Style::solid(0),
                    )]
                });
                plot::panels(&stem, &ttl, &panels, cols)
            }),
        ));
    }

    // The admittance generators' compliance: the object reference against the desired path.
    if info.admittance {
        let stem = dir.join("admittance");
        let ttl = title("admittance reference offset x_r − x_d (compliance to unexpected forces)");
        let zoom = info.zoom;
        jobs.push((
            "admittance".into(),
            Box::new(move || {
                let offsets: Vec<Vec<f64>> = AX
                    .iter()
                    .map(|a| {
                        let (r, d) = (col(log, &format!("x_r.{a}")), col(log, &format!("x_d.{a}")));
                        r.iter().zip(d).map(|(r, d)| r - d).collect()
                    })
                    .collect();
                let (panels, cols) = per_axis(t, zoom, "(x_r − x_d)", ("m", "rad"), |j| {
                    vec![Series::new("", t, &offsets[j], Style::solid(4))]
                });
                plot::panels(&stem, &ttl, &panels, cols)
            }),
        ));
    }

    // Fig. 16: weight norms.
    if info.nn {
        let stem = dir.join("weights");
        let ttl = title("norms of the NN weights ‖Ŵ_j‖");
        let zoom = info.zoom.filter(|z| *z < t.last().copied().unwrap_or(0.0));
        jobs.push((
            "weights".into(),
            Box::new(move || {
                let p = |title: String| {
                    let mut p = Panel::new(title, "t [s]", "‖Ŵ_j‖ [1]");
                    for j in 0..3 {
                        p = p.with(Series::new(
                            format!("‖Ŵ_{}‖", AX_SYM[j]),
                            t,
                            col(log, &format!("w_norm.{}", AX[j])),
                            Style::solid(j),
                        ));
                    }
                    p
                };
                let mut panels = vec![p("weight norms".into())];
                if let Some(z) = zoom {
                    panels.push(
                        p(format!("weight norms, first {z} s"))
                            .x_range(t.first().copied().unwrap_or(0.0), z),
                    );
                }
                let n = panels.len();
                plot::panels(&stem, &ttl, &panels, n)
            }),
        ));
    }

    // Grasp forces and joint torques, one panel per arm.
    {
        let stem = dir.join("grasp_forces");
        let ttl = title("grasp forces F_i (object on end-effector i)");
        let n_arms = info.joints.len();
        jobs.push((
            "grasp_forces".into(),
            Box::new(move || {
                let panels: Vec<Panel> = (0..n_arms)
                    .map(|i| {
                        let a = i + 1;
                        Panel::new(format!("arm {a}"), "t [s]", format!("F_{a} [N]"))
                            .with(Series::new(
                                format!("F_{a},x"),
                                t,
                                col(log, &format!("F{a}.x")),
                                Style::solid(0),
                            ))
                            .with(Series::new(
                                format!("F_{a},y"),
                                t,
                                col(log, &format!("F{a}.y")),
                                Style::solid(1),
                            ))
                    })
                    .collect();
                plot::panels(&stem, &ttl, &panels, n_arms.min(2))
            }),
        ));
    }
    {
        let stem = dir.join("joint_torques");
        let ttl = title("joint torques");
        let joints = info.joints.clone();
        jobs.push((
            "joint_torques".into(),
            Box::new(move || {
                let panels = joint_torque_panels(log, t, &joints);
                plot::panels(&stem, &ttl, &panels, joints.len().min(2))
            }),
        ));
    }

    // Switching value Q (NN) and constraint margin.
    {
        let stem = dir.join("switching");
        let ttl = if info.nn {
            title("switching value Q and constraint margin")
        } else {
            title("constraint margin")
        };
        let nn = info.nn;
        jobs.push((
            "switching".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                if nn {
                    panels.push(
                        Panel::new("switching value Q = M(Z), (37)", "t [s]", "Q [1]")
                            .with(Series::new("Q", t, col(log, "Q"), Style::solid(0)))
                            .y_range(-0.05, 1.05),
                    );
                }
                panels.push(
                    Panel::new(
                        "constraint margin 1 − max_j |x_1j|/k_cj",
                        "t [s]",
                        "margin [1]",
                    )
                    .with(Series::new(
                        "margin",
                        t,
                        col(log, "margin"),
                        Style::solid(2),
                    ))
                    .hline(0.0, "violation"),
                );
                plot::panels(&stem, &ttl, &panels, 1)
            }),
        ));
    }
    run_jobs(jobs)
}

/// One run of a comparison.
pub struct CompareRun<'a> {
    /// Legend label, e.g. `NN (tuned)`.
    pub label: String,
    /// Its log.
    pub log: &'a Log,
}

/// Draw the side-by-side figures of a comparison into `dir`; returns the stems written.
pub fn compare_figures(
    dir: &Path,
    runs: &[CompareRun],
    title: &str,
    k_c: [f64; 3],
    zoom: Option<f64>,
) -> Result<Vec<String>> {
    let mut jobs: Vec<Job> = Vec::new();
    let Some(first) = runs.first() else {
        return Ok(vec![]);
    };

    // XY paths side by side.
    {
        let stem = dir.join("compare_xy");
        let ttl = format!("{title} — object centre in the XY plane");
        jobs.push((
            "compare_xy".into(),
            Box::new(move || {
                let panels: Vec<Panel> = runs
                    .iter()
                    .map(|r| {
                        plot::xy_panel(
                            &r.label,
                            (col(r.log, "x_o.x"), col(r.log, "x_o.y")),
                            (col(r.log, "x_d.x"), col(r.log, "x_d.y")),
                            Some((k_c[0], k_c[1])),
                            &[],
                        )
                    })
                    .collect();
                // Side by side, each panel about square.
                let n = panels.len() as u32;
                plot::panels_sized(&stem, &ttl, &panels, n as usize, (520 * n, 620))
            }),
        ));
    }

    // Overlaid tracking errors.
    {
        let (group, sym, units) = ("z1", "z1", ("m", "rad"));
        let stem = dir.join("compare_z1");
        let ttl = format!("{title} — position tracking error z1");
        jobs.push((
            "compare_z1".into(),
            Box::new(move || {
                let t0 = col(first.log, "t");
                let (panels, cols) = per_axis(t0, zoom, sym, units, |j| {
                    runs.iter()
                        .enumerate()
                        .map(|(i, r)| {
                            Series::new(
                                r.label.clone(),
                                col(r.log, "t"),
                                col(r.log, &format!("{group}.{}", AX[j])),
                                Style::solid(i),
                            )
                        })
                        .collect()
                });
                plot::panels(&stem, &ttl, &panels, cols)
            }),
        ));
    }
    // The wrench differs by orders of magnitude between controllers (the paper's NN gains
    // chatter at hundreds of newtons): small multiples, one column per controller, each with
    // its own scale.
    {
        let stem = dir.join("compare_wrench");
        let ttl = format!("{title} — control wrench τ on the object (one column per controller)");
        jobs.push((
            "compare_wrench".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                for j in 0..3 {
                    for (i, r) in runs.iter().enumerate() {
                        panels.push(
                            Panel::new(
                                format!("{}: τ_{}", r.label, AX_SYM[j]),
                                "t [s]",
                                format!("τ_{} [{}]", AX_SYM[j], unit(j, "N", "N m")),
                            )
                            .with(Series::new(
                                "",
                                col(r.log, "t"),
                                col(r.log, &format!("tau.{}", AX[j])),
                                Style::solid(i),
                            )),
                        );
                    }
                }
                let n = runs.len();
                plot::panels(&stem, &ttl, &panels, n)
            }),
        ));
    }
    {
        let stem = dir.join("compare_trajectories");
        let ttl = format!("{title} — object trajectory and output bounds");
        jobs.push((
            "compare_trajectories".into(),
            Box::new(move || {
                let panels: Vec<Panel> = (0..3)
                    .map(|j| {
                        let a = AX[j];
                        let mut p = Panel::new(
                            format!("{}: actual and desired", AX_SYM[j]),
                            "t [s]",
                            format!("{} [{}]", AX_SYM[j], unit(j, "m", "rad")),
                        );
                        for (i, r) in runs.iter().enumerate() {
                            p = p.with(Series::new(
                                r.label.clone(),
                                col(r.log, "t"),
                                col(r.log, &format!("x_o.{a}")),
                                Style::solid(i),
                            ));
                        }
                        p.with(Series::new(
                            "desired",
                            col(first.log, "t"),
                            col(first.log, &format!("x_d.{a}")),
                            Style::dashed(7),
                        ))
                        .bounds(k_c[j], "±k_c")
                    })
                    .collect();
                plot::panels(&stem, &ttl, &panels, 1)
            }),
        ));
    }
    {
        let stem = dir.join("compare_margin");
        let ttl = format!("{title} — constraint margin");
        jobs.push((
            "compare_margin".into(),
            Box::new(move || {
                let m = margin_panel(
                    runs.iter()
                        .map(|r| (r.label.as_str(), col(r.log, "t"), col(r.log, "margin"))),
                );
                plot::panels(&stem, &ttl, &[m], 1)
            }),
        ));
    }
    run_jobs(jobs)
}
