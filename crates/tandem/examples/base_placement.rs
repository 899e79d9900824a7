//! The base-placement study behind the spatial presets (SPEC-spatial S6, `docs/base-placement.md`):
//! `cargo run --release -p tandem --example base_placement -- [results.csv] [--svg=figure.svg] [--force]`.
//!
//! 1. Dual UR5 (`presets::dual_ur5` grasps and box): bases at `(∓d/2, 0, 0)` facing each other,
//!    `d` from 0.90 to 1.80 m; one lap of the S6 path by inverse kinematics with continuation on
//!    the S6 branch (shoulder toward the box, elbow up, `sin q5 > 0`), every 0.5 s.
//! 2. Dual Franka (`presets::dual_franka`): which grasps have in-limit solutions at all (top
//!    face vs end faces, box height 0.30–0.40 m), laps for the top-face grasp over `d`, and the
//!    redundancy's range (the values of joint 7 with an in-limit solution) along the lap.
//!
//! Prints the tables; with a path, also writes every lap row as CSV, and with `--svg=PATH` the
//! figure of σ_min against d (each whole or not at all; an
//! existing file is replaced only with `--force`).

#[path = "base_placement/study.rs"]
mod study;

use std::fmt::Write as _;

use study::{FrankaGrasp, Lap};
use tandem::nalgebra::{Isometry3, Vector3, Vector6};
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::spatial::path::Se3Path;

/// Sampling step along the lap, s (the path moves 5 mm and turns ≤ 0.18° per step).
const DT: f64 = 0.5;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let force = args.iter().any(|a| a == "--force");
    let mut paths = 0;
    for a in &args {
        if a.starts_with("--") {
            if a != "--force" && !a.starts_with("--svg=") {
                eprintln!("error: unknown option {a} (options: --svg=PATH, --force)");
                std::process::exit(2);
            }
        } else {
            paths += 1;
        }
    }
    if paths > 1 {
        eprintln!("error: more than one CSV path given");
        std::process::exit(2);
    }
    let out = args.iter().find(|a| !a.starts_with("--")).cloned();
    let svg = args
        .iter()
        .find_map(|a| a.strip_prefix("--svg=").map(str::to_string));
    for p in out.iter().chain(svg.iter()) {
        if std::path::Path::new(p).exists() && !force {
            eprintln!("error: {p} exists; pass --force to replace it");
            std::process::exit(2);
        }
    }
    // σ_min (smaller arm) against d, for the figure: UR5, Franka.
    let mut curves: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    let t0 = std::time::Instant::now();
    let mut csv = String::from(
        "arms,grasp,d_m,lap_ok,samples,failure,sigma_min_1,sigma_min_2,cond_max_1,cond_max_2,\
         sin_q3_min_1,sin_q3_min_2,sin_q5_min_1,sin_q5_min_2,travel_max_deg_1,travel_max_deg_2,\
         torque_ratio_max_1,torque_ratio_max_2,limit_margin_min_rad_1,limit_margin_min_rad_2,\
         separation_min_m,height_min_m\n",
    );

    // ---- 1. Dual UR5 -----------------------------------------------------------------------
    println!("# Dual UR5: one S6 lap on the S6 branch, bases at (∓d/2, 0, 0), every {DT} s\n");
    let ds: Vec<f64> = (0..=45).map(|k| 0.90 + 0.02 * k as f64).collect();
    let rows = study::ur5_sweep(&ds, DT);
    println!(
        "| d (m) | S6 branch all lap | σ_min (arm 1 / 2) | max cond | min |sin q3| | min |sin q5| \
         | max travel (°) | max τ/effort | closest approach (m) | lowest point (m) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let l = &r.lap;
        csv_row(&mut csv, "ur5", "end", r.d, l);
        if l.failure.is_none() {
            curves[0].push((r.d, min2(l.sigma_min)));
        }
        if l.samples == 0 {
            let why = l.failure.as_deref().unwrap_or("");
            println!(
                "| {:.2} | no: {} | | | | | | | | |",
                r.d,
                no_solution(r.d, why)
            );
            continue;
        }
        println!(
            "| {:.2} | {} | {:.3} / {:.3} | {:.1} | {:.3} | {:.3} | {:.1} | {:.1} % | {:.3} | {:.3} |",
            r.d,
            l.failure
                .as_deref()
                .map_or("yes".into(), |f| format!("no: {f}")),
            l.sigma_min[0],
            l.sigma_min[1],
            l.cond_max[0].max(l.cond_max[1]),
            l.sin_q3_min[0].min(l.sin_q3_min[1]),
            l.sin_q5_min[0].min(l.sin_q5_min[1]),
            l.travel_max[0].max(l.travel_max[1]).to_degrees(),
            100.0 * l.torque_ratio_max[0].max(l.torque_ratio_max[1]),
            l.separation_min,
            l.height_min,
        );
    }
    // Where the lap stops being solvable, to 1 mm.
    let edge: Vec<f64> = (0..=20).map(|k| 0.980 + 0.001 * k as f64).collect();
    let first = study::ur5_sweep(&edge, DT)
        .into_iter()
        .find(|r| r.lap.failure.is_none())
        .expect("the lap solves at 1.00 m");
    println!(
        "\nsmallest d (1 mm steps) with the S6 branch all lap: {:.3} m (σ_min {:.4}, |sin q5| {:.3}); \
         wrist-centre offset of arm 2 at the start there {:.4} m (d4 = 0.10915 m)",
        first.d,
        min2(first.lap.sigma_min),
        min2(first.lap.sin_q5_min),
        wrist_offset(first.d)
    );
    // Sampling check: the preset's lap every DT and every 0.1 s.
    let figures = |l: &Lap| {
        [
            min2(l.sigma_min),
            max2(l.cond_max),
            min2(l.sin_q3_min),
            min2(l.sin_q5_min),
            max2(l.travel_max).to_degrees(),
            100.0 * max2(l.torque_ratio_max),
            l.separation_min,
            l.height_min,
        ]
    };
    let lap_at = |dt: f64| {
        study::follow_lap(
            &study::dual_ur5_at(1.40),
            &Se3Path::spec_s6(),
            &tandem::presets::dual_ur5().q_guess,
            dt,
            true,
        )
    };
    let (coarse, fine) = (figures(&lap_at(DT)), figures(&lap_at(0.1)));
    let change = coarse
        .iter()
        .zip(&fine)
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max);
    for (dt, f) in [(DT, coarse), (0.1, fine)] {
        println!(
            "d = 1.40 m every {dt} s: σ_min {:.4}, cond {:.3}, |sin q3| {:.4}, |sin q5| {:.4}, \
             travel {:.2}°, τ/effort {:.2} %, closest {:.4} m, lowest {:.4} m",
            f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7]
        );
    }
    println!("largest relative change: {:.3} %", 100.0 * change);
    // The σ_min peak, finer.
    let fine: Vec<f64> = (0..=16).map(|k| 1.38 + 0.005 * k as f64).collect();
    let peak = study::ur5_sweep(&fine, DT)
        .into_iter()
        .filter(|r| r.lap.failure.is_none())
        .max_by(|a, b| {
            let s = |r: &study::Ur5Row| r.lap.sigma_min[0].min(r.lap.sigma_min[1]);
            s(a).total_cmp(&s(b))
        })
        .expect("the S6 set-up solves");
    println!(
        "\nσ_min (smaller arm) peaks at d = {:.3} m: {:.4} (5 mm steps over 1.38–1.46 m)",
        peak.d,
        peak.lap.sigma_min[0].min(peak.lap.sigma_min[1])
    );
    let s6 = rows
        .iter()
        .find(|r| (r.d - 1.40).abs() < 1e-9)
        .expect("1.40 in the sweep");
    println!(
        "preset d = 1.40 m: start (rad) arm 1 {:.6?}\n                            arm 2 {:.6?}",
        &s6.lap.q[0][..6],
        &s6.lap.q[0][6..]
    );
    println!(
        "largest-travel joints (1-based): arm 1 q{}, arm 2 q{}; largest τ/effort: arm 1 q{}, arm 2 q{}",
        s6.lap.travel_joint[0] + 1,
        s6.lap.travel_joint[1] + 1,
        s6.lap.torque_joint[0] + 1,
        s6.lap.torque_joint[1] + 1
    );

    // ---- 2. Dual Franka ----------------------------------------------------------------------
    let path = Se3Path::spec_s6();
    println!(
        "\n# Dual Franka: in-limit solutions at the lap start (box centre (0.1, 0, z), R = I)\n"
    );
    println!("random starts inside the limits, clamped damped least squares, 200 per arm\n");
    println!("| grasp | z (m) | d = 0.90 | d = 1.10 | d = 1.30 |");
    println!("|---|---|---|---|---|");
    let grasps = [
        ("top face", FrankaGrasp::Top),
        ("end faces, tool x down", FrankaGrasp::End { roll: 0.0 }),
        (
            "end faces, tool x sideways",
            FrankaGrasp::End {
                roll: std::f64::consts::FRAC_PI_2,
            },
        ),
        (
            "end faces, tool x up",
            FrankaGrasp::End {
                roll: std::f64::consts::PI,
            },
        ),
    ];
    for (name, g) in grasps {
        for z in [0.30, 0.35, 0.40] {
            let mut line = format!("| {name} | {z:.2} |");
            for d in [0.90, 1.10, 1.30] {
                let params = study::dual_franka_at(d, g);
                let x_wo = Isometry3::translation(0.1, 0.0, z);
                let found: Vec<usize> = (0..2)
                    .map(|i| {
                        let target = study::grasp_target(&params, i, &x_wo);
                        study::ik_search(&params.arms[i], &target, 200, None, 7 + i as u64).len()
                    })
                    .collect();
                let _ = write!(
                    line,
                    " {} |",
                    match (found[0] > 0, found[1] > 0) {
                        (true, true) => "both arms".to_string(),
                        (false, false) => "none".to_string(),
                        (a, _) => format!("arm {} only", if a { 1 } else { 2 }),
                    }
                );
            }
            println!("{line}");
        }
    }

    // Why the end faces fail: solve ignoring the limits and see which limits the solutions break.
    println!(
        "\nEnd faces (tool x down), d = 1.10 m, z = 0.35 m, solved ignoring the joint limits (200 random starts):"
    );
    let params = study::dual_franka_at(1.10, FrankaGrasp::End { roll: 0.0 });
    let x_wo = Isometry3::translation(0.1, 0.0, 0.35);
    for i in 0..2 {
        let target = study::grasp_target(&params, i, &x_wo);
        let v = study::limit_violations(&params.arms[i], &target, 200, 13 + i as u64);
        let mut count = [0usize; 7];
        for s in &v {
            for &k in &s.0 {
                count[k] += 1;
            }
        }
        let within = v.iter().filter(|s| s.0.is_empty()).count();
        let closest = v
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|s| {
                format!(
                    "the closest breaks {} by at most {:.2} rad",
                    s.0.iter()
                        .map(|k| format!("q{}", k + 1))
                        .collect::<Vec<_>>()
                        .join(", "),
                    s.1
                )
            })
            .unwrap_or_default();
        // Which side of q4's range (−3.07 … −0.07 rad) the solutions that break it are on.
        let (folded, straight) =
            v.iter()
                .filter(|s| s.0.contains(&3))
                .fold((0, 0), |(f, st), s| {
                    let q4 = s.2[3].rem_euclid(std::f64::consts::TAU) - std::f64::consts::TAU;
                    // q4 mapped into (−2π, 0]: beyond the fold stop is below −3.07, past straight
                    // is above −0.07 (the elbow bent backwards).
                    if q4 < -3.0718 && q4 > -std::f64::consts::PI - 1.5 {
                        (f + 1, st)
                    } else {
                        (f, st + 1)
                    }
                });
        println!(
            "  arm {}: {} solutions, {} inside all limits; outside the limits of q1..q7: {:?}; {closest}; \
             q4 beyond its fold stop in {folded}, bent backwards in {straight}",
            i + 1,
            v.len(),
            within,
            count
        );
    }

    println!(
        "\n# Dual Franka, top-face grasps: one S6 lap from the preset's guess, every {DT} s\n"
    );
    println!(
        "the start: `initial_state` from the fixture's guess (the \"ready\" pose), as the preset run\n"
    );
    println!(
        "| d (m) | lap | σ_min (arm 1 / 2) | max cond | max travel (°) | max τ/effort \
         | min limit margin (rad) | closest approach (m) | lowest point (m) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let x0 = study::s6_pose(&path, 0.0);
    for k in 0..=12 {
        let d = 0.80 + 0.05 * k as f64;
        let params = study::dual_franka_at(d, FrankaGrasp::Top);
        let plant = SpatialPlant::new(&params).expect("valid");
        let guess = tandem::presets::dual_franka().q_guess;
        let l = match plant.initial_state(&x0, &Vector6::zeros(), &guess) {
            Ok(y) => study::follow_lap(&params, &path, &y[..plant.n_q()], DT, false),
            Err(e) => Lap {
                failure: Some(format!("t = 0.0 s: {e}")),
                ..no_start()
            },
        };
        csv_row(&mut csv, "franka", "top", d, &l);
        if l.failure.is_none() {
            curves[1].push((d, min2(l.sigma_min)));
        }
        if l.samples == 0 {
            println!(
                "| {d:.2} | no: {} | | | | | | | |",
                l.failure.as_deref().unwrap_or("")
            );
            continue;
        }
        println!(
            "| {d:.2} | {} | {:.3} / {:.3} | {:.1} | {:.1} (q{}) | {:.1} % (q{}) | {:.3} (q{}) | {:.3} | {:.3} |",
            l.failure
                .as_deref()
                .map_or("yes".into(), |f| format!("no: {f}")),
            l.sigma_min[0],
            l.sigma_min[1],
            l.cond_max[0].max(l.cond_max[1]),
            max2(l.travel_max).to_degrees(),
            l.travel_joint[arg_max(l.travel_max)] + 1,
            100.0 * max2(l.torque_ratio_max),
            l.torque_joint[arg_max(l.torque_ratio_max)] + 1,
            min2(l.limit_margin_min),
            l.limit_joint[arg_max(l.limit_margin_min.map(|m| -m))] + 1,
            l.separation_min,
            l.height_min,
        );
    }

    // The redundancy at the preset placement: which q7 values admit an in-limit solution, and
    // where the preset's continuation (minimum-norm steps from the ready guess) keeps it.
    println!("\n# Dual Franka preset (d = 1.10 m, top face): the redundancy along the lap\n");
    let params = study::dual_franka_at(1.10, FrankaGrasp::Top);
    let plant = SpatialPlant::new(&params).expect("valid");
    let y0 = plant
        .initial_state(
            &x0,
            &Vector6::zeros(),
            &tandem::presets::dual_franka().q_guess,
        )
        .expect("the preset starts");
    let lap = study::follow_lap(&params, &path, &y0[..14], DT, false);
    println!("| t (s) | arm | q7 with an in-limit solution (rad) | preset q7 | preset q (rad) |");
    println!("|---|---|---|---|---|");
    for t in [0.0, 15.0, 30.0, 45.0] {
        let x = study::s6_pose(&path, t);
        let k = (t / DT).round() as usize;
        for i in 0..2 {
            let vals = study::redundancy_range(&params, i, &x, 6, 58, 20);
            let q = &lap.q[k][7 * i..7 * i + 7];
            println!(
                "| {t:.0} | {} | {} | {:.3} | {:.3?} |",
                i + 1,
                intervals(&vals, 2.0 * 2.8973 / 58.0),
                q[6],
                q
            );
        }
    }

    // Over the whole lap: how far the continuation moves q7 and the joints the redundancy swings.
    for i in 0..2 {
        let range = |k: usize| {
            lap.q
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[7 * i + k]), hi.max(q[7 * i + k]))
                })
        };
        let (a, b) = range(6);
        let swing = [0, 2, 4]
            .iter()
            .map(|&k| {
                let (lo, hi) = range(k);
                lo.abs().max(hi.abs())
            })
            .fold(0.0, f64::max);
        println!(
            "arm {}: over the lap q7 ∈ [{a:.3}, {b:.3}] rad, max |q1|, |q3|, |q5| = {swing:.3} rad",
            i + 1
        );
    }

    if let Some(p) = svg {
        write_whole(&p, &figure(&curves)).unwrap_or_else(|e| {
            eprintln!("error: cannot write {p}: {e}");
            std::process::exit(1);
        });
        println!("\nwrote {p}");
    }
    if let Some(p) = out {
        write_whole(&p, &csv).unwrap_or_else(|e| {
            eprintln!("error: cannot write {p}: {e}");
            std::process::exit(1);
        });
        println!("\nwrote {p}");
    }
    println!("\n({:.1} s)", t0.elapsed().as_secs_f64());
}

/// Why a UR5 row has no lap at all: says whether any inverse-kinematics solution exists (any
/// branch), from 200 random starts.
fn no_solution(d: f64, why: &str) -> String {
    let params = study::dual_ur5_at(d);
    let x0 = study::s6_pose(&Se3Path::spec_s6(), 0.0);
    let none: Vec<String> = (0..2)
        .filter(|&i| {
            let target = study::grasp_target(&params, i, &x0);
            study::ik_search(&params.arms[i], &target, 200, None, 11).is_empty()
        })
        .map(|i| format!("arm {}", i + 1))
        .collect();
    if none.is_empty() {
        format!("off the S6 branch at the start ({why})")
    } else {
        let w = wrist_offset(d);
        format!(
            "{} cannot reach the start on any branch (wrist centre {:.4} m from the shoulder axis < d4 = 0.10915 m)",
            none.join(", "),
            w
        )
    }
}

/// Horizontal distance of arm 2's wrist centre (0.0823 m behind the flange along the tool z) from
/// its base axis at the lap start, m.
fn wrist_offset(d: f64) -> f64 {
    let params = study::dual_ur5_at(d);
    let x0 = study::s6_pose(&Se3Path::spec_s6(), 0.0);
    let g = study::grasp_target(&params, 1, &x0);
    let w = g.translation.vector - g.rotation * Vector3::z() * 0.0823;
    let b = params.arms[1].base.translation.vector;
    ((w.x - b.x).powi(2) + (w.y - b.y).powi(2)).sqrt()
}

fn min2(a: [f64; 2]) -> f64 {
    a[0].min(a[1])
}

fn max2(a: [f64; 2]) -> f64 {
    a[0].max(a[1])
}

/// Which arm (0, 1) has the larger value.
fn arg_max(a: [f64; 2]) -> usize {
    usize::from(a[1] > a[0])
}

/// σ_min against d as a hand-written SVG (no plotting dependency in the library crate): the UR5
/// curve, the Franka curve, the presets marked.
fn figure(curves: &[Vec<(f64, f64)>; 2]) -> String {
    let (w, h, l, r, t, b) = (640.0, 400.0, 60.0, 20.0, 30.0, 50.0);
    let (x0, x1, y0, y1) = (0.8, 1.8, 0.0, 0.22);
    let px = |x: f64| l + (x - x0) / (x1 - x0) * (w - l - r);
    let py = |y: f64| h - b - (y - y0) / (y1 - y0) * (h - t - b);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" \
         font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    for k in 0..=10 {
        let x = x0 + 0.1 * k as f64;
        let _ = writeln!(
            s,
            "<line x1=\"{0:.1}\" y1=\"{1:.1}\" x2=\"{0:.1}\" y2=\"{2:.1}\" stroke=\"#ddd\"/>\
             <text x=\"{0:.1}\" y=\"{3:.1}\" text-anchor=\"middle\">{x:.1}</text>",
            px(x),
            py(y0),
            py(y1),
            h - b + 16.0
        );
    }
    for k in 0..=11 {
        let y = 0.02 * k as f64;
        let _ = writeln!(
            s,
            "<line x1=\"{0:.1}\" y1=\"{1:.1}\" x2=\"{2:.1}\" y2=\"{1:.1}\" stroke=\"#ddd\"/>\
             <text x=\"{3:.1}\" y=\"{4:.1}\" text-anchor=\"end\">{y:.2}</text>",
            px(x0),
            py(y),
            px(x1),
            l - 6.0,
            py(y) + 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">base separation d (m)</text>\
         <text x=\"14\" y=\"{:.1}\" transform=\"rotate(-90 14 {:.1})\" text-anchor=\"middle\">\
         smallest σ_min over an S6 lap</text>",
        (px(x0) + px(x1)) / 2.0,
        h - 12.0,
        (py(y0) + py(y1)) / 2.0,
        (py(y0) + py(y1)) / 2.0
    );
    let colours = ["#1f77b4", "#d62728"];
    let names = ["dual UR5, end faces", "dual Franka, top face"];
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\">dots: the presets</text>",
        px(1.5) + 6.0,
        py(0.05) + 40.0
    );
    let presets = [1.40, 1.10];
    for (i, c) in curves.iter().enumerate() {
        let pts: Vec<String> = c
            .iter()
            .map(|(x, y)| format!("{:.1},{:.1}", px(*x), py(*y)))
            .collect();
        let _ = writeln!(
            s,
            "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"2\" points=\"{}\"/>",
            colours[i],
            pts.join(" ")
        );
        if let Some((x, y)) = c.iter().find(|(x, _)| (x - presets[i]).abs() < 1e-9) {
            let _ = writeln!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"5\" fill=\"{}\"/>",
                px(*x),
                py(*y),
                colours[i]
            );
        }
        let _ = writeln!(
            s,
            "<line x1=\"{0:.1}\" y1=\"{1:.1}\" x2=\"{2:.1}\" y2=\"{1:.1}\" stroke=\"{3}\" stroke-width=\"2\"/>\
             <text x=\"{4:.1}\" y=\"{5:.1}\">{6}</text>",
            px(1.45),
            py(0.05) + 18.0 * i as f64,
            px(1.5),
            colours[i],
            px(1.5) + 6.0,
            py(0.05) + 18.0 * i as f64 + 4.0,
            names[i]
        );
    }
    s.push_str("</svg>\n");
    s
}

/// Sorted grid values as intervals `[a, b]` (neighbours closer than `step` merge).
fn intervals(v: &[f64], step: f64) -> String {
    if v.is_empty() {
        return "none".into();
    }
    let mut out = Vec::new();
    let (mut a, mut b) = (v[0], v[0]);
    for &x in &v[1..] {
        if x - b > 1.5 * step {
            out.push(format!("[{a:.2}, {b:.2}]"));
            a = x;
        }
        b = x;
    }
    out.push(format!("[{a:.2}, {b:.2}]"));
    out.join(" ∪ ")
}

fn no_start() -> Lap {
    Lap {
        failure: Some("no in-limit start".into()),
        samples: 0,
        sigma_min: [f64::NAN; 2],
        cond_max: [f64::NAN; 2],
        sin_q3_min: [f64::NAN; 2],
        sin_q5_min: [f64::NAN; 2],
        travel_max: [f64::NAN; 2],
        travel_joint: [0; 2],
        torque_ratio_max: [f64::NAN; 2],
        torque_joint: [0; 2],
        limit_margin_min: [f64::NAN; 2],
        limit_joint: [0; 2],
        separation_min: f64::NAN,
        height_min: f64::NAN,
        q: Vec::new(),
    }
}

/// One CSV row; a quantity not measured (no sample solved) is an empty field, never NaN.
fn csv_row(csv: &mut String, arms: &str, grasp: &str, d: f64, l: &Lap) {
    let f = |x: f64| {
        if x.is_finite() {
            format!("{x:.6}")
        } else {
            String::new()
        }
    };
    let fail = l
        .failure
        .as_deref()
        .unwrap_or("")
        .replace('"', "'")
        .replace('\n', " ");
    let _ = writeln!(
        csv,
        "{arms},{grasp},{d:.3},{},{},\"{fail}\",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
        l.failure.is_none() && l.samples > 0,
        l.samples,
        f(l.sigma_min[0]),
        f(l.sigma_min[1]),
        f(l.cond_max[0]),
        f(l.cond_max[1]),
        f(l.sin_q3_min[0]),
        f(l.sin_q3_min[1]),
        f(l.sin_q5_min[0]),
        f(l.sin_q5_min[1]),
        f(l.travel_max[0].to_degrees()),
        f(l.travel_max[1].to_degrees()),
        f(l.torque_ratio_max[0]),
        f(l.torque_ratio_max[1]),
        f(l.limit_margin_min[0]),
        f(l.limit_margin_min[1]),
        f(l.separation_min),
        f(l.height_min),
    );
}

/// Write `text` to `path` whole or not at all: a temporary file beside it, then a rename.
fn write_whole(path: &str, text: &str) -> std::io::Result<()> {
    let p = std::path::Path::new(path);
    let mut name = p.file_name().unwrap_or_default().to_os_string();
    name.push(".tandem-partial");
    let tmp = p.with_file_name(name);
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, p).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}
