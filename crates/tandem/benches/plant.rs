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
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use std::hint::black_box;
use tandem::fixtures;
use tandem::integrate::Rk4;
use tandem::plant::{ConstrainedOde, Plant};

fn bench(c: &mut Criterion) {
    let plant = Plant::new(&fixtures::paper()).unwrap();
    let y = plant
        .initial_state(fixtures::paper_start(), Vector3::new(0.01, 0.02, 0.0), None)
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
}

criterion_group!(benches, bench);
criterion_main!(benches);
