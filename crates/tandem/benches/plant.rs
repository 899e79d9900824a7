//! Plant derivative and step costs for the paper's two arms (SPEC §2.4).
//!
//! # Performance log
//! Criterion medians on the shared 2-core development VM (other builds running: load ≈ 1.1,
//! ±10 %), baseline and change measured alternately; instructions per call from callgrind
//! (`valgrind --tool=callgrind`, stable). Paper plant, state as below.
//!
//! | date       | change                                             | constrained       | reduced           | RK4 step |
//! |------------|----------------------------------------------------|-------------------|-------------------|----------|
//! | 2026-11-25 | general dynamic-size path (DMatrix, per-link Vecs) | 447–545 ns, 7222 Ir | 562–575 ns, 6031 Ir | 1.90–1.95 µs |
//! | 2026-11-25 | fixed-size 2-link path, 4×4 K, trig-free IK        | 170–180 ns, 1546 Ir | 188–192 ns, 1497 Ir | 0.71–0.73 µs |
//!
//! `plant/constrained_derivative_general` keeps the general algorithm measured on the same plant.
//!
//! `tick/*` (issue 12): one control tick (sensors, the PD law, the plant's RK4 substeps at the
//! paper's 1 kHz control / 0.2 ms plant step) of two 2-link arms (the paper), three 2-link
//! arms ([`presets::three_arms`]), two 3-link arms ([`presets::redundant_pair`]) and two
//! 4-link arms (`tests/support/n_link.rs`), side by side; divide by the arm count for the
//! per-arm cost. The PD law, because the NN law is built
//! for 2-link arms only. With `TANDEM_TICKS=<config>:<n>` in the environment the binary runs
//! `n` ticks of that configuration and exits (for callgrind: the difference of two counts over
//! the difference of `n` is the instructions per tick).
use criterion::{Criterion, criterion_group};
use nalgebra::Vector3;
use std::hint::black_box;
use tandem::control::law::Law;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::{Controller, ControllerParams};
use tandem::math::integrate::Rk4;
use tandem::model::disturbance::Disturbance;
use tandem::plant::planar::{ConstrainedOde, Plant, PlantParams};
use tandem::plant::{ClosedChain, Formulation};
use tandem::presets;
use tandem::reference::planar::path::Path;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Driver, SimParams, Simulation};

#[path = "../tests/support/n_link.rs"]
mod n_link;

/// The tick configurations: name, plant, joint-angle guess, arm count.
fn tick_configs() -> Vec<(&'static str, PlantParams, Option<Vec<f64>>, usize)> {
    let (p3, guess) = presets::redundant_pair();
    let (p4, guess4) = n_link::chain(2, 4);
    vec![
        ("two_2link", presets::paper(), None, 2),
        ("three_2link", presets::three_arms(), None, 3),
        ("two_3link", p3, Some(guess), 2),
        ("two_4link", p4, Some(guess4), 2),
    ]
}

/// A long PD run of `plant` (ticks are taken one by one, never to its end).
fn tick_sim(plant: &PlantParams, guess: Option<&[f64]>) -> Simulation {
    let duration = 1.0e4;
    let (c, _) = Controller::new(
        &ControllerParams::paper(Law::Pd(PdGains::<3>::paper())),
        plant,
        Path::paper(),
        duration,
    )
    .unwrap();
    let sp = SimParams {
        duration,
        ..SimParams::paper()
    };
    Simulation::new(
        plant,
        &SensorParams::default(),
        Driver::Controller(Box::new(c)),
        Disturbance::paper(),
        sp,
        guess,
    )
    .unwrap()
}

fn ticks(c: &mut Criterion) {
    let mut g = c.benchmark_group("tick");
    for (name, p, guess, _) in tick_configs() {
        let mut sim = tick_sim(&p, guess.as_deref());
        let mut k = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                sim.tick(k).unwrap();
                k += 1;
            })
        });
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    let plant = Plant::new(&presets::paper()).unwrap();
    let y = plant
        .initial_state(presets::paper_start(), Vector3::new(0.01, 0.02, 0.0), None)
        .unwrap();
    let mut ws = plant.workspace();
    let mut input = plant.zero_input();
    input.tau.copy_from_slice(&[5.0, 1.5, -1.0, -0.2]);
    let mut dy = vec![0.0; plant.state_dim()];
    c.bench_function("plant/constrained_derivative", |b| {
        b.iter(|| plant.derivative(black_box(&y), &input, &mut ws, &mut dy))
    });
    c.bench_function("plant/constrained_derivative_general", |b| {
        b.iter(|| plant.derivative_general(black_box(&y), &input, &mut ws, &mut dy))
    });
    let yr = [0.19, 0.0, 0.0, 0.01, 0.02, 0.0];
    let mut dyr = [0.0; 6];
    c.bench_function("plant/reduced_derivative", |b| {
        b.iter(|| {
            plant
                .reduced_derivative(black_box(&yr), &input, &mut ws, &mut dyr)
                .unwrap()
        })
    });
    let (xo, xdo) = (Vector3::new(0.19, 0.0, 0.0), Vector3::new(0.01, 0.02, 0.0));
    c.bench_function("plant/object_space", |b| {
        b.iter(|| plant.object_space(black_box(&xo), &xdo, &mut ws).unwrap())
    });
    let arm = &plant.arms()[0];
    let mut t = arm.terms();
    c.bench_function("arm/dynamics_2link", |b| {
        b.iter(|| arm.dynamics(black_box(&[0.5, -1.0]), &[0.1, 0.2], 9.8, &mut t))
    });
    c.bench_function("arm/kinematics_2link", |b| {
        b.iter(|| arm.kinematics(black_box(&[0.5, -1.0]), &[0.1, 0.2], &mut t))
    });
    let k = arm.two_link().unwrap();
    c.bench_function("arm/two_link_terms", |b| {
        b.iter(|| k.terms(&k.pose(black_box([0.5, -1.0])), [0.1, 0.2], 9.8))
    });
    let mut rk = Rk4::new(plant.state_dim());
    let mut yy = y.clone();
    c.bench_function("plant/constrained_rk4_step", |b| {
        b.iter(|| {
            yy.copy_from_slice(&y);
            let mut sys = ConstrainedOde {
                plant: &plant,
                ws: &mut ws,
                input: &input,
            };
            rk.step(&mut sys, 0.0, &mut yy, 1e-3);
        })
    });
    // The loop's plant work of one control tick (issue 12): the grasp forces at (y, u_{k−1})
    // (`grasp_wrenches`), then one RK4 step at 1 ms with u_k held (`step_with`).
    let mut st = plant.stepper(Formulation::Constrained).unwrap();
    let mut u_prev = input.clone();
    u_prev.tau.copy_from_slice(&[4.9, 1.4, -1.1, -0.3]);
    let mut out = [0.0; 4];
    c.bench_function("plant/tick_forces_and_step", |b| {
        b.iter(|| {
            yy.copy_from_slice(&y);
            plant
                .grasp_wrenches(&mut st, black_box(&yy), &u_prev, &mut ws, &mut out)
                .unwrap();
            plant
                .step_with(&mut st, 0.0, &mut yy, &input, &mut ws, 1e-3, 1)
                .unwrap();
        })
    });
}

criterion_group!(benches, bench, ticks);

fn main() {
    if let Ok(spec) = std::env::var("TANDEM_TICKS") {
        let (name, n) = spec.split_once(':').expect("TANDEM_TICKS=<config>:<n>");
        let n: usize = n.parse().expect("tick count");
        let (_, p, guess, _) = tick_configs()
            .into_iter()
            .find(|c| c.0 == name)
            .expect("config: two_2link, three_2link or two_3link");
        let mut sim = tick_sim(&p, guess.as_deref());
        for k in 0..n {
            sim.tick(k).unwrap();
        }
        black_box(sim.state());
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
