//! The figures of a spatial run (PNG + SVG, the planar style of [`crate::figures::plot`]) and of a
//! spatial comparison.
//!
//! | file | content |
//! |---|---|
//! | `z1` | `z1 = x_1 − x_r` on the six outputs, whole run and the first 2 s |
//! | `z2` | `z2 = x_2 − α` (NN) or `ż1` (PD, CTC) on the six outputs |
//! | `tracking` | true `x_1`, desired `x_d` and reference `x_r` per axis in the output chart, `±k_c` |
//! | `path` | the object centre's path, top view (x–y) and side view (x–z), with the `k_c` box |
//! | `wrench` | the commanded object wrench `F = [f; τ]` (world axes) |
//! | `grasp_wrenches` | the true grasp wrench of each arm, forces and torques (world axes) |
//! | `internal_wrench` | the internal (null-space) part of each arm's commanded wrench |
//! | `joint_torques` | joint torques, one panel per arm |
//! | `joint_limits` | joint positions scaled to their limits, `(q − q_min)/(q_max − q_min)` |
//! | `weights` | switching value `Q` and weight norms `‖Ŵ_j‖` (NN only) |
//! | `margins` | constraint margin, closest joint-limit distance and the tool Jacobians' σ_min |
//! | `contacts` | contact grasps: each pad's cone margin `μ N − |f_t|`, normal force and friction |
//!
//! Figures are drawn in parallel (`crate::figures::planar::run_jobs`); the plot module min/max
//! decimates long series, so a 60 s run is drawn as fast as a short one.

use std::path::Path;

use anyhow::Result;
use tandem::control::spatial::{AXES, WRENCH_AXES};

use crate::figures::planar::col;
use crate::figures::planar::{Job, joint_torque_panels, margin_panel, run_jobs};
use crate::figures::plot::{self, Panel, Series, Style};
use crate::run::spatial::Finished;
use tandem::report::spatial::{Derived, TRANSIENT, six};

/// Axis symbols of the six outputs in titles.
const SYM: [&str; 6] = ["x", "y", "z", "φx", "φy", "φz"];

fn unit(j: usize, lin: &'static str, rot: &'static str) -> &'static str {
    if j < 3 { lin } else { rot }
}

/// Panels of a six-output quantity: rows x, y, z, φx, φy, φz; columns the whole run and (when
/// the run is longer) its first [`TRANSIENT`] s.
fn six_panels<'a>(
    t: &'a [f64],
    sym: &str,
    units: (&'static str, &'static str),
    note: impl Fn(usize) -> String,
    series: impl Fn(usize) -> Vec<Series<'a>>,
) -> (Vec<Panel<'a>>, usize) {
    let t_end = t.last().copied().unwrap_or(0.0);
    let zoom = t_end > TRANSIENT * 1.5;
    let mut panels = Vec::new();
    for j in 0..6 {
        let y = format!("{sym}_{} [{}]", SYM[j], unit(j, units.0, units.1));
        let mut p = Panel::new(format!("{sym}: {}{}", SYM[j], note(j)), "t [s]", y);
        p.series = series(j);
        if zoom {
            let mut q = p.clone();
            q.title = format!("{sym}: {}, first {TRANSIENT} s", SYM[j]);
            panels.push(p);
            panels.push(q.x_range(t.first().copied().unwrap_or(0.0), TRANSIENT));
        } else {
            panels.push(p);
        }
    }
    (panels, if zoom { 2 } else { 1 })
}

/// An arm (1-based) and its six wrench columns.
type ArmWrench<'a> = (usize, [&'a [f64]; 6]);

/// Forces and torques of one six-column group per arm: one row per arm, columns force and torque.
fn wrench_panels<'a>(t: &'a [f64], arms: &[(usize, [&'a [f64]; 6])], sym: &str) -> Vec<Panel<'a>> {
    let mut panels = Vec::new();
    for (i, w) in arms {
        for half in 0..2 {
            let (what, u) = if half == 0 {
                ("force", "N")
            } else {
                ("torque", "N m")
            };
            let mut p = Panel::new(
                format!("arm {i}: {what}"),
                "t [s]",
                format!("{sym}_{i} {what} [{u}]"),
            );
            for k in 0..3 {
                p = p.with(Series::new(
                    WRENCH_AXES[3 * half + k],
                    t,
                    w[3 * half + k],
                    Style::solid(k),
                ));
            }
            panels.push(p);
        }
    }
    panels
}

/// Draw every figure of one run into `dir`; returns the stems written.
pub fn run_figures(dir: &Path, scenario: &str, f: &Finished, d: &Derived) -> Result<Vec<String>> {
    let log = &f.outcome.log;
    let t = d.t.as_slice();
    let title = |what: &str| format!("{scenario} — {} — {what}", f.label);
    let k_c = f.k_c;
    let n_arms = f.plant.arms().len();
    let mut jobs: Vec<Job> = Vec::new();

    // z1 and z2 on the six outputs.
    let nn = f.nn();
    for (stem, group, sym, units, what) in [
        (
            "z1",
            "z1",
            "z1",
            ("m", "rad"),
            "tracking error z1 = x_1 − x_r (bounds: |x_1| < k_c)",
        ),
        (
            "z2",
            "z2",
            "z2",
            ("m/s", "rad/s"),
            if nn {
                "tracking error z2 = x_2 − α"
            } else {
                "velocity error z2 = ż1 = x_2 − ẋ_r"
            },
        ),
    ] {
        let Some(z) = six(log, group, &AXES) else {
            continue;
        };
        let path = dir.join(stem);
        let ttl = title(what);
        jobs.push((
            stem.into(),
            Box::new(move || {
                let note = |j: usize| {
                    if stem == "z1" {
                        format!(" (k_c = {} {})", k_c[j], unit(j, "m", "rad"))
                    } else {
                        String::new()
                    }
                };
                let (panels, cols) = six_panels(t, sym, units, note, |j| {
                    vec![Series::new("", t, z[j], Style::solid(0))]
                });
                plot::panels(&path, &ttl, &panels, cols)
            }),
        ));
    }

    // Tracking in the output chart, with the bounds.
    if let (6, Some(xd), Some(xr)) = (d.x1.len(), six(log, "x_d", &AXES), six(log, "x_r", &AXES)) {
        let path = dir.join("tracking");
        let ttl =
            title("object pose in the output chart x_1 = (p − c, φ): actual, desired, reference");
        let x1 = &d.x1;
        jobs.push((
            "tracking".into(),
            Box::new(move || {
                // Rows x|φx, y|φy, z|φz: position on the left, orientation on the right.
                let panels: Vec<Panel> = [0, 3, 1, 4, 2, 5]
                    .iter()
                    .map(|&j| {
                        Panel::new(
                            format!("{}: actual, desired, reference", SYM[j]),
                            "t [s]",
                            format!("x_1,{} [{}]", SYM[j], unit(j, "m", "rad")),
                        )
                        .with(Series::new("x_1 (actual)", t, &x1[j], Style::solid(0)))
                        .with(Series::new(
                            "x_r (reference)",
                            t,
                            xr[j],
                            Style::solid(2).width(1),
                        ))
                        .with(Series::new("x_d (desired)", t, xd[j], Style::dashed(1)))
                        .bounds(k_c[j], "±k_c")
                    })
                    .collect();
                plot::panels(&path, &ttl, &panels, 2)
            }),
        ));
    }

    // The path: top and side views of the chart position (the k_c box is centred on c).
    if d.x1.len() == 6 {
        let path = dir.join("path");
        let ttl = title("object centre relative to the chart centre c: top and side views");
        let x1 = &d.x1;
        let xd = six(log, "x_d", &AXES);
        jobs.push((
            "path".into(),
            Box::new(move || {
                let empty: &[f64] = &[];
                let des = |j: usize| xd.map_or(empty, |x| x[j]);
                let mut top = plot::xy_panel(
                    "top view (x–y)",
                    (&x1[0], &x1[1]),
                    (des(0), des(1)),
                    Some((k_c[0], k_c[1])),
                    &[],
                );
                top.x_label = "x − c_x [m]".into();
                top.y_label = "y − c_y [m]".into();
                let mut side = plot::xy_panel(
                    "side view (x–z)",
                    (&x1[0], &x1[2]),
                    (des(0), des(2)),
                    Some((k_c[0], k_c[2])),
                    &[],
                );
                side.x_label = "x − c_x [m]".into();
                side.y_label = "z − c_z [m]".into();
                if xd.is_none() {
                    top.series.truncate(1);
                    side.series.truncate(1);
                }
                plot::panels_sized(&path, &ttl, &[top, side], 2, (1200, 660))
            }),
        ));
    }

    // The commanded object wrench.
    if let Some(w) = six(log, "tau", &WRENCH_AXES) {
        let path = dir.join("wrench");
        let ttl = title("commanded object wrench F = [f; τ] (world axes, about the object origin)");
        jobs.push((
            "wrench".into(),
            Box::new(move || {
                let mut panels = wrench_panels(t, &[(1, w)], "F");
                panels[0].title = "force f".into();
                panels[0].y_label = "f [N]".into();
                panels[1].title = "torque τ".into();
                panels[1].y_label = "τ [N m]".into();
                plot::panels(&path, &ttl, &panels, 2)
            }),
        ));
    }

    // Grasp and internal wrenches per arm.
    for (stem, group, sym, what) in [
        (
            "grasp_wrenches",
            "F",
            "F",
            "true grasp wrenches F_i (object on tool i, world axes)",
        ),
        (
            "internal_wrench",
            "w_int",
            "w_int",
            "internal (null-space) part of the commanded arm wrenches (world axes)",
        ),
    ] {
        let arms: Option<Vec<ArmWrench>> = (1..=n_arms)
            .map(|i| six(log, &format!("{group}{i}"), &WRENCH_AXES).map(|w| (i, w)))
            .collect();
        let Some(arms) = arms else { continue };
        let path = dir.join(stem);
        let ttl = title(what);
        jobs.push((
            stem.into(),
            Box::new(move || plot::panels(&path, &ttl, &wrench_panels(t, &arms, sym), 2)),
        ));
    }

    // Joint torques and joint positions against their limits, one panel per arm.
    let dofs: Vec<usize> = f.plant.arms().iter().map(|a| a.chain.dof()).collect();
    {
        let path = dir.join("joint_torques");
        let ttl = title("joint torques");
        let dofs = dofs.clone();
        jobs.push((
            "joint_torques".into(),
            Box::new(move || {
                let panels = joint_torque_panels(log, t, &dofs);
                plot::panels(&path, &ttl, &panels, 1)
            }),
        ));
    }
    if d.q_norm.iter().any(Option::is_some) {
        let path = dir.join("joint_limits");
        let ttl = title("joint positions scaled to their limits, (q − q_min)/(q_max − q_min)");
        let q_norm = &d.q_norm;
        let dofs = dofs.clone();
        jobs.push((
            "joint_limits".into(),
            Box::new(move || {
                let mut off = 0;
                let mut panels = Vec::new();
                for (i, &n) in dofs.iter().enumerate() {
                    let mut p = Panel::new(
                        format!("arm {}", i + 1),
                        "t [s]",
                        "position in its range [1]",
                    )
                    .y_range(-0.05, 1.05)
                    .hline(0.0, "limits")
                    .hline(1.0, "limits");
                    for k in 0..n {
                        if let Some(Some(v)) = q_norm.get(off + k) {
                            p = p.with(Series::new(
                                format!("joint {}", k + 1),
                                t,
                                v,
                                Style::solid(k),
                            ));
                        }
                    }
                    off += n;
                    if !p.series.is_empty() {
                        panels.push(p);
                    }
                }
                plot::panels(&path, &ttl, &panels, 1)
            }),
        ));
    }

    // Q and the weight norms (NN only).
    if nn && let Some(w) = six(log, "w_norm", &AXES) {
        let path = dir.join("weights");
        let ttl = title("switching value Q and NN weight norms ‖Ŵ_j‖");
        jobs.push((
            "weights".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                let q = col(log, "Q");
                if q.len() == t.len() {
                    panels.push(
                        Panel::new("switching value Q = M(Z)", "t [s]", "Q [1]")
                            .with(Series::new("Q", t, q, Style::solid(0)))
                            .y_range(-0.05, 1.05),
                    );
                }
                let mut p = Panel::new("weight norms", "t [s]", "‖Ŵ_j‖ [1]");
                for j in 0..6 {
                    p = p.with(Series::new(
                        format!("‖Ŵ_{}‖", SYM[j]),
                        t,
                        w[j],
                        Style::solid(j),
                    ));
                }
                panels.push(p);
                plot::panels(&path, &ttl, &panels, 1)
            }),
        ));
    }

    // Margins over time.
    {
        let path = dir.join("margins");
        let ttl = title("margins: output bounds, joint limits, singularity");
        let (lm, sg) = (&d.limit_margin, &d.sigma);
        jobs.push((
            "margins".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                let m = col(log, "margin");
                if m.len() == t.len() {
                    panels.push(
                        Panel::new(
                            "constraint margin 1 − max_j |x_1j|/k_cj (estimate)",
                            "t [s]",
                            "margin [1]",
                        )
                        .with(Series::new("margin", t, m, Style::solid(2)))
                        .hline(0.0, "violation"),
                    );
                }
                if lm.iter().any(|v| v.iter().all(|x| x.is_finite())) {
                    let mut p = Panel::new(
                        "closest joint's distance to its limit",
                        "t [s]",
                        "distance [rad]",
                    );
                    for (i, v) in lm.iter().enumerate() {
                        if v.iter().all(|x| x.is_finite()) {
                            p = p.with(Series::new(
                                format!("arm {}", i + 1),
                                t,
                                v,
                                Style::solid(i),
                            ));
                        }
                    }
                    panels.push(p.hline(0.0, "limit"));
                }
                if !sg.is_empty() {
                    let mut p = Panel::new(
                        "smallest singular value of the tool Jacobian",
                        "t [s]",
                        "σ_min(J_i) [m/rad]",
                    );
                    for (i, v) in sg.iter().enumerate() {
                        p = p.with(Series::new(format!("arm {}", i + 1), t, v, Style::solid(i)));
                    }
                    panels.push(p);
                }
                plot::panels(&path, &ttl, &panels, 1)
            }),
        ));
    }
    // Contact grasps: per pad its cone margin, normal force and friction.
    let pads: Vec<String> = log
        .columns
        .iter()
        .filter_map(|c| c.name.strip_suffix(".margin").map(str::to_string))
        .filter(|p| p.starts_with("pad"))
        .collect();
    if !pads.is_empty() {
        let path = dir.join("contacts");
        let ttl = title("contact pads: friction-cone margins, normal forces, friction");
        jobs.push((
            "contacts".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                for (q, name, unit, line) in [
                    (
                        "margin",
                        "cone margin μ N − |f_t| (below 0: slipping)",
                        "N",
                        true,
                    ),
                    ("normal", "normal force N (0: separated)", "N", false),
                    ("friction", "friction |f_t|", "N", false),
                ] {
                    let mut p = Panel::new(name, "t [s]", format!("{q} [{unit}]"));
                    for (k, pad) in pads.iter().enumerate() {
                        let v = col(log, &format!("{pad}.{q}"));
                        if v.len() == t.len() {
                            p = p.with(Series::new(pad.clone(), t, v, Style::solid(k)));
                        }
                    }
                    if line {
                        p = p.hline(0.0, "slip");
                    }
                    panels.push(p);
                }
                plot::panels(&path, &ttl, &panels, 1)
            }),
        ));
    }
    run_jobs(jobs)
}

/// Draw the overlay figures of a comparison into `dir`; returns the stems written.
pub fn compare_figures(dir: &Path, name: &str, runs: &[(&str, &Finished)]) -> Result<Vec<String>> {
    // Norms per run: ‖z1_p‖, ‖z1_φ‖, ‖f‖, ‖τ‖.
    struct Norms<'a> {
        label: &'a str,
        t: &'a [f64],
        v: [Vec<f64>; 4],
        margin: &'a [f64],
    }
    let data: Vec<Norms> = runs
        .iter()
        .map(|(label, f)| {
            let log = &f.outcome.log;
            let norm = |g: &str, axes: &[&str; 6], half: usize| -> Vec<f64> {
                six(log, g, axes).map_or_else(Vec::new, |c| {
                    (0..log.len())
                        .map(|k| {
                            (0..3)
                                .map(|j| c[3 * half + j][k].powi(2))
                                .sum::<f64>()
                                .sqrt()
                        })
                        .collect()
                })
            };
            Norms {
                label,
                t: col(log, "t"),
                v: [
                    norm("z1", &AXES, 0),
                    norm("z1", &AXES, 1),
                    norm("tau", &WRENCH_AXES, 0),
                    norm("tau", &WRENCH_AXES, 1),
                ],
                margin: col(log, "margin"),
            }
        })
        .collect();
    let data = &data;
    let t_end = data
        .iter()
        .filter_map(|r| r.t.last().copied())
        .fold(0.0f64, f64::max);
    let mut jobs: Vec<Job> = Vec::new();
    {
        let path = dir.join("compare_z1");
        let ttl = format!("{name} — tracking error norms");
        jobs.push((
            "compare_z1".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                for (k, (what, u)) in [("‖z1_p‖", "m"), ("‖z1_φ‖", "rad")].iter().enumerate()
                {
                    let mut p = Panel::new(*what, "t [s]", format!("{what} [{u}]"));
                    for (i, r) in data.iter().enumerate() {
                        if r.v[k].len() == r.t.len() && !r.t.is_empty() {
                            p = p.with(Series::new(r.label, r.t, &r.v[k], Style::solid(i)));
                        }
                    }
                    let mut q = p.clone();
                    panels.push(p);
                    if t_end > TRANSIENT * 1.5 {
                        // After the transient, where the S5 claims hold: zoomed onto the claim's
                        // limit (1 mm, 1 mrad), so that a law far above it (the paper's PD sags
                        // by centimetres) leaves the axes instead of flattening the others.
                        let limit = 1e-3;
                        let top = data
                            .iter()
                            .filter(|r| r.v[k].len() == r.t.len())
                            .flat_map(|r| {
                                r.t.iter()
                                    .zip(&r.v[k])
                                    .filter(|(t, _)| **t >= TRANSIENT)
                                    .map(|(_, v)| *v)
                            })
                            .fold(0.0f64, f64::max);
                        q.title = format!("{what} after {TRANSIENT} s (S5 limit {limit} {u})");
                        q = q.x_range(TRANSIENT, t_end);
                        if top > 1.5 * limit {
                            q.title = format!(
                                "{what} after {TRANSIENT} s, zoomed to the S5 limit ({limit} {u})"
                            );
                            q = q.y_range(0.0, 1.5 * limit);
                        }
                        panels.push(q.hline(limit, "S5 limit"));
                    }
                }
                let cols = if t_end > TRANSIENT * 1.5 { 2 } else { 1 };
                plot::panels(&path, &ttl, &panels, cols)
            }),
        ));
    }
    {
        // Small multiples, each with its own scale: the laws' wrenches differ by orders of
        // magnitude.
        let path = dir.join("compare_wrench");
        let ttl = format!("{name} — commanded object wrench (one column per controller)");
        jobs.push((
            "compare_wrench".into(),
            Box::new(move || {
                let mut panels = Vec::new();
                for (k, (what, u)) in [("‖f‖", "N"), ("‖τ‖", "N m")].iter().enumerate() {
                    for (i, r) in data.iter().enumerate() {
                        if r.v[k + 2].len() == r.t.len() && !r.t.is_empty() {
                            panels.push(
                                Panel::new(
                                    format!("{}: {what}", r.label),
                                    "t [s]",
                                    format!("{what} [{u}]"),
                                )
                                .with(Series::new(
                                    "",
                                    r.t,
                                    &r.v[k + 2],
                                    Style::solid(i),
                                )),
                            );
                        }
                    }
                }
                let cols = data.len().max(1);
                plot::panels(&path, &ttl, &panels, cols)
            }),
        ));
    }
    {
        let path = dir.join("compare_margin");
        let ttl = format!("{name} — constraint margin");
        jobs.push((
            "compare_margin".into(),
            Box::new(move || {
                let m = margin_panel(data.iter().map(|r| (r.label, r.t, r.margin)));
                plot::panels(&path, &ttl, &[m], 1)
            }),
        ));
    }
    run_jobs(jobs)
}
