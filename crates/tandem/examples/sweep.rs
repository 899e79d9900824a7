//! A Monte Carlo sweep: the paper scenario (NN, tuned gains) with random start offsets, sensor
//! noise seeds and object-mass errors, run in parallel on scoped threads. Each run's seed is
//! derived from its index, so the results do not depend on the thread count.
//!
//! `cargo run --release -p tandem --example sweep -- [runs] [seconds] [threads]`

use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::planar::{Controller, ControllerParams};
use tandem::math::random::splitmix64;
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::reference::planar::path::Path;
use tandem::report::planar::{Summary, summarize};
use tandem::sim::sensors::{ChannelNoise, SensorParams};
use tandem::sim::{Driver, SimParams, Simulation};

fn unit(seed: u64, k: u64) -> f64 {
    (splitmix64(seed ^ splitmix64(k)) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

fn one(run: u64, duration: f64) -> Summary {
    let mut plant = presets::paper();
    // ±20 % object mass and inertia (the controller keeps the nominal model).
    let s = 1.0 + 0.2 * unit(run, 1);
    for k in 0..3 {
        plant.object.inertia[k] *= s;
        plant.object.gravity[k] *= s;
    }
    let cp = ControllerParams::paper(Law::Nn(NnGains::tuned()));
    let (c, _) = Controller::new(&cp, &presets::paper(), Path::paper(), duration).unwrap();
    let noise = ChannelNoise {
        std_dev: 1e-5,
        bias: 0.0,
        tau: 0.0,
        dropout: 0.0,
    };
    let sensors = SensorParams {
        encoder_q: noise,
        encoder_qd: ChannelNoise {
            std_dev: 1e-3,
            ..noise
        },
        force: ChannelNoise {
            std_dev: 0.05,
            ..noise
        },
        seed: splitmix64(run),
        ..Default::default()
    };
    let mut sp = SimParams::paper();
    sp.duration = duration;
    sp.start = [
        0.19 + 0.005 * unit(run, 2),
        0.005 * unit(run, 3),
        0.02 * unit(run, 4),
    ];
    let sim = Simulation::new(
        &plant,
        &sensors,
        Driver::Controller(Box::new(c)),
        Disturbance::paper(),
        sp,
        None,
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    summarize(&out, "nn", "tuned", [0.35; 3], 5.0, duration)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let runs: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(16);
    let duration: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20.0);
    let threads: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(2);
    let mut results: Vec<Option<Summary>> = vec![None; runs as usize];
    std::thread::scope(|sc| {
        for (t, chunk) in results
            .chunks_mut((runs as usize).div_ceil(threads))
            .enumerate()
        {
            let base = t * (runs as usize).div_ceil(threads);
            sc.spawn(move || {
                for (i, slot) in chunk.iter_mut().enumerate() {
                    *slot = Some(one((base + i) as u64, duration));
                }
            });
        }
    });
    println!(
        "| run | completed | settling 1 mm [s] | RMS z1 after 5 s [mm] | min margin | peak wrench [N] |"
    );
    println!("|---|---|---|---|---|---|");
    for (i, s) in results.iter().flatten().enumerate() {
        println!(
            "| {i} | {} | {:.2} | {:.4} | {:.3} | {:.1} |",
            s.completed,
            s.settling_time_1mm.unwrap_or(f64::NAN),
            1e3 * s.rms_z1_after,
            s.min_margin,
            s.peak_wrench
        );
    }
    let ok = results
        .iter()
        .flatten()
        .filter(|s| s.completed && s.violations == 0)
        .count();
    println!("\n{ok}/{runs} runs completed without a constraint violation");
}
