//! Network-structure ablation (SPEC-spatial S5, `docs/network.md`): the planar paper scenario
//! (90 s, NN `tuned`, constrained plant, admittance, paper disturbance) with the paper's full
//! grid against the structures of `tandem::control::rbf::structured`, with the tuned `Θ` as it is and
//! with `Θ` matched to the full grid's loop gain `Θ‖S(0)‖²`. Writes a Markdown table.
//!
//! `cargo run --release -p tandem --example ablation -- [seconds] [out.md]`
//! (defaults: 90 s, `target/ablation.md`).

use std::time::Instant;

use nalgebra::{SVector, Vector3};
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::planar::ControllerParams;
use tandem::control::rbf::NnUpdate;
use tandem::control::rbf::structured::{NetworkStructure, StructuredNn, matched_theta};
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::report::planar::summarize;
use tandem::sim::SimParams;

/// One row of the ablation.
struct Case {
    name: &'static str,
    network: NetworkStructure,
    levels: Vec<f64>,
    /// Scale Θ to the full grid's loop gain.
    matched: bool,
}

fn unit_update<const M: usize>() -> NnUpdate<M> {
    NnUpdate::new(SVector::repeat(1.0), SVector::repeat(1e-3), 1e-3).expect("valid")
}

/// Weights a structure needs for `M` outputs (for the spatial column).
fn weights_for<const M: usize>(s: &NetworkStructure, levels: &[f64]) -> String {
    match s {
        NetworkStructure::FullGrid => {
            let n = (levels.len() as f64).powi(4 * M as i32) * M as f64;
            format!("{n:.3e}")
        }
        NetworkStructure::PerAxis { inputs } if !inputs.is_empty() && inputs.len() != M => {
            "–".into()
        }
        _ => StructuredNn::<M>::new(s, levels, 50.0, unit_update())
            .map(|n| n.n_weights().to_string())
            .unwrap_or_else(|_| "–".into()),
    }
}

/// Median wall time of one network tick (µs) at a plausible input, over 7 batches.
fn tick_time(s: &NetworkStructure, levels: &[f64]) -> f64 {
    let mut net = StructuredNn::<3>::new(s, levels, 50.0, unit_update()).expect("valid");
    let z = [
        0.19, 0.0, 0.0, 0.01, -0.02, 0.0, 0.02, 0.015, 0.0, -0.3, 0.2, 0.05,
    ];
    let z2 = Vector3::new(0.01, -0.02, 0.005);
    let reps = 20_000;
    let mut times: Vec<f64> = (0..7)
        .map(|_| {
            let t0 = Instant::now();
            for _ in 0..reps {
                std::hint::black_box(net.tick(std::hint::black_box(&z), 1.0, &z2));
            }
            t0.elapsed().as_secs_f64() / reps as f64 * 1e6
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[3]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let duration: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(90.0);
    let out_path = args
        .get(2)
        .cloned()
        .unwrap_or_else(|| "target/ablation.md".into());
    let two = vec![-1.0, 1.0];
    let three = vec![-1.0, 0.0, 1.0];
    // Output j also sees every axis's α (cross terms: 6 inputs, 64 nodes).
    let cross = NetworkStructure::PerAxis {
        inputs: (0..3).map(|j| vec![j, 3 + j, 6, 7, 8, 9 + j]).collect(),
    };
    // Output j also sees every axis's x_1 (cross terms on the pose: 6 inputs, 64 nodes).
    let cross_x1 = NetworkStructure::PerAxis {
        inputs: (0..3).map(|j| vec![0, 1, 2, 3 + j, 6 + j, 9 + j]).collect(),
    };
    let cases = vec![
        Case {
            name: "full grid 2^12 (paper)",
            network: NetworkStructure::FullGrid,
            levels: two.clone(),
            matched: false,
        },
        Case {
            name: "per-axis 2^4, Θ tuned",
            network: NetworkStructure::per_axis(),
            levels: two.clone(),
            matched: false,
        },
        Case {
            name: "per-axis 2^4, Θ matched",
            network: NetworkStructure::per_axis(),
            levels: two.clone(),
            matched: true,
        },
        Case {
            name: "per-axis 3^4, Θ matched",
            network: NetworkStructure::per_axis(),
            levels: three.clone(),
            matched: true,
        },
        Case {
            name: "per-axis + all α 2^6, Θ matched",
            network: cross,
            levels: two.clone(),
            matched: true,
        },
        Case {
            name: "per-axis + all x_1 2^6, Θ matched",
            network: cross_x1,
            levels: two.clone(),
            matched: true,
        },
        Case {
            name: "quasi-random 512, Θ tuned",
            network: NetworkStructure::QuasiRandom { n: 512, seed: 0 },
            levels: two.clone(),
            matched: false,
        },
        Case {
            name: "quasi-random 512, Θ matched",
            network: NetworkStructure::QuasiRandom { n: 512, seed: 0 },
            levels: two.clone(),
            matched: true,
        },
        Case {
            name: "quasi-random 4096, Θ matched",
            network: NetworkStructure::QuasiRandom { n: 4096, seed: 0 },
            levels: two.clone(),
            matched: true,
        },
    ];
    let mut md = String::new();
    md.push_str(&format!(
        "Planar paper scenario, {duration} s, NN `tuned` gains (K1, K2, K_r, σ, ϑ² = 50, switching unchanged), constrained plant, admittance on, paper disturbance.\n\n"
    ));
    md.push_str("| structure | weights planar (spatial) | Θ | settling 1 mm [s] | RMS z1 > 2 s [mm] | RMS z1 > 5 s [mm] | max z1 > 5 s [mm] | peak wrench [N] | roughness [N] | violations / barrier hits | min margin | ‖Ŵ_y‖/|τ_y| dev. > 2 s | NN tick [µs] | run RTF |\n");
    md.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for c in &cases {
        let mut g = NnGains::tuned();
        g.levels = c.levels.clone();
        g.network = c.network.clone();
        if c.matched {
            let n2 = StructuredNn::<3>::new(&c.network, &c.levels, g.width2, unit_update())
                .expect("valid")
                .norm2_at_zero();
            // Matched to the paper grid (2 levels on 12 inputs).
            g.theta = matched_theta(&g.theta, &[-1.0, 1.0], g.width2, &n2);
        }
        let theta = g.theta;
        let cp = ControllerParams::paper(Law::Nn(g));
        let sp = SimParams {
            duration,
            ..SimParams::paper()
        };
        let (sim, _) = presets::paper_simulation(&cp, sp, Disturbance::paper()).expect("builds");
        let (out, _) = sim.run(|_| {});
        let s2 = summarize(&out, "nn", c.name, [0.35; 3], 2.0, duration);
        let s5 = summarize(&out, "nn", c.name, [0.35; 3], 5.0, duration);
        let tick = tick_time(&c.network, &c.levels);
        // Fig. 16 check of tests/paper.rs: after 2 s, ‖Ŵ_y‖/|τ_y| stays near its median.
        let track = {
            let (t, w, tau) = (
                out.log.get("t").unwrap_or(&[]),
                out.log.get("w_norm.y").unwrap_or(&[]),
                out.log.get("tau.y").unwrap_or(&[]),
            );
            let k2 = t.iter().position(|&x| x >= 2.0).unwrap_or(t.len());
            let r: Vec<f64> = (k2..t.len()).map(|k| w[k] / tau[k].abs()).collect();
            let mut sorted = r.clone();
            sorted.sort_by(f64::total_cmp);
            let med = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
            r.iter().map(|x| (x - med).abs() / med).fold(0.0, f64::max)
        };
        let row = format!(
            "| {} | {} ({}) | ({:.3}, {:.3}, {:.3}) | {} | {:.4} | {:.4} | {:.4} | {:.1} | {:.3} | {} / {} | {:.3} | {:.1} % | {:.2} | {:.0} |\n",
            c.name,
            weights_for::<3>(&c.network, &c.levels),
            weights_for::<6>(&c.network, &c.levels),
            theta[0],
            theta[1],
            theta[2],
            s5.settling_time_1mm
                .map_or("never".into(), |t| format!("{t:.2}")),
            1e3 * s2.rms_z1_after,
            1e3 * s5.rms_z1_after,
            1e3 * s5.max_z1_after,
            s5.peak_wrench,
            s5.wrench_roughness,
            s5.violations,
            s5.events.barrier_hits,
            s5.min_margin,
            100.0 * track,
            tick,
            s5.real_time_factor,
        );
        eprint!("{row}");
        if !s5.completed {
            eprintln!("  run stopped: {:?}", s5.fault);
        }
        md.push_str(&row);
    }
    print!("{md}");
    if let Some(dir) = std::path::Path::new(&out_path).parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    std::fs::write(&out_path, &md).expect("write the table");
    eprintln!("wrote {out_path}");
}
