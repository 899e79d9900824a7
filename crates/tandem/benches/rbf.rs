//! RBF basis and adaptive network benches (SPEC §3.4): the paper grid, 12 inputs × {−1, 1}
//! = 4096 nodes, ϑ² = 50, 3 outputs, weights 4096 × 3 f64 = 96 KB.
//!
//! - `s_kronecker_4096`: `S(Z)` alone, Kronecker form (24 `exp`, one multiply per node);
//! - `nn_tick_fused_4096x3`: the full NN tick, `S(Z)` + outputs + exact weight update + norms
//!   in one pass (`RbfNetwork::tick_at`);
//! - `nn_tick_given_s_4096x3`: the same with `S` given (`RbfNetwork::tick`);
//! - `nn_unfused_output_then_update_4096x3`: output pass, then update pass;
//! - `nn_tick_outputs_4096x3/<kernel>`: the controller's RBF pass (`tick_at_outputs`: `S(Z)`,
//!   outputs and exact update, no norms, `S` not stored) with every kernel this CPU can run,
//!   side by side in one process (the others use the default kernel or `TANDEM_KERNEL`);
//! - `nn_flush_tick_4096x3/<kernel>`: the batched kernels' flushing tick alone (every 16th:
//!   its output pass fused with the flush of the 16 held updates), timed after 15 untimed
//!   ticks;
//! - `s_naive_general_4096`: the direct sum of (8) over explicit centres (4096 `exp`).
//!
//! Performance log (release, AMD EPYC Zen 4 VM, 2 cores, AVX2 path, minimum over runs):
//!
//! | date       | S kron | tick fused | tick given S | unfused | naive S |
//! |------------|--------|------------|--------------|---------|---------|
//! | 2026-11-25 | 0.59 µs | 2.7 µs    | 2.05 µs      | 2.7 µs  | 40 µs   |
//!
//! (An unfused, node-major scalar prototype measured 5.2 µs for the tick; the portable,
//! non-AVX2 kernels take about 8 µs.)

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use tandem::control::rbf::{BATCH_DEPTH, Kernel, NnUpdate, Rbf, RbfNetwork};

/// A plausible NN input `Z = [x1, x2, α, α̇]` near the start of the paper run.
const Z: [f64; 12] = [
    0.19, 0.0, 0.0, 0.01, -0.02, 0.0, 0.02, 0.015, 0.0, -0.3, 0.2, 0.05,
];

fn bench(c: &mut Criterion) {
    let rbf = Rbf::paper();
    let general = rbf.to_general();
    let mut ws = rbf.workspace();
    let mut s_naive = vec![0.0; rbf.n_nodes()];
    let theta = Vector3::new(120.0, 150.0, 120.0);
    let sigma = Vector3::repeat(0.001);
    let upd = NnUpdate::new(theta, sigma, 1e-3).unwrap();
    let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
    let z2 = Vector3::new(0.01, -0.02, 0.005);

    c.bench_function("rbf/s_kronecker_4096", |b| {
        b.iter(|| {
            rbf.eval_into(black_box(&Z), &mut ws);
            black_box(ws.s()[17]);
        })
    });
    c.bench_function("rbf/nn_tick_fused_4096x3", |b| {
        b.iter(|| black_box(net.tick_at(&rbf, black_box(&Z), &mut ws, black_box(1.0), &z2, &upd)))
    });
    for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
        let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        net.set_kernel(kernel).unwrap();
        c.bench_function(&format!("rbf/nn_tick_outputs_4096x3/{kernel}"), |b| {
            b.iter(|| {
                black_box(net.tick_at_outputs(
                    &rbf,
                    black_box(&Z),
                    &mut ws,
                    black_box(1.0),
                    &z2,
                    &upd,
                ))
            })
        });
    }
    // The flushing tick of the batched kernels alone: 15 ticks untimed, then the 16th, whose
    // output pass is fused with the flush of the 16 held updates.
    for kernel in [Kernel::Batched, Kernel::BatchedF32] {
        if !kernel.is_available() {
            continue;
        }
        let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        net.set_kernel(kernel).unwrap();
        c.bench_function(&format!("rbf/nn_flush_tick_4096x3/{kernel}"), |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    while net.pending() < BATCH_DEPTH {
                        black_box(net.tick_at_outputs(&rbf, &Z, &mut ws, 1.0, &z2, &upd));
                    }
                    let t0 = Instant::now();
                    black_box(net.tick_at_outputs(
                        &rbf,
                        black_box(&Z),
                        &mut ws,
                        black_box(1.0),
                        &z2,
                        &upd,
                    ));
                    total += t0.elapsed();
                }
                total
            })
        });
    }
    rbf.eval_into(&Z, &mut ws);
    let s = ws.s().to_vec();
    c.bench_function("rbf/nn_tick_given_s_4096x3", |b| {
        b.iter(|| black_box(net.tick(black_box(&s), black_box(1.0), &z2, &upd)))
    });
    c.bench_function("rbf/nn_unfused_output_then_update_4096x3", |b| {
        b.iter(|| {
            let f = net.output(black_box(&s));
            let n = net.update(&s, black_box(1.0), &z2, &upd);
            black_box((f, n))
        })
    });
    c.bench_function("rbf/s_naive_general_4096", |b| {
        b.iter(|| {
            general.eval_naive_into(black_box(&Z), &mut s_naive);
            black_box(s_naive[17]);
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
