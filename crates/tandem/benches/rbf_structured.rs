//! Structured RBF network benches (`tandem::control::rbf::structured`, SPEC-spatial S5): one full tick
//! (`S_j(Z)`, outputs with the old weights, exact update (44), norms) per structure, planar
//! (3 outputs, 12 inputs) and spatial (6 outputs, 24 inputs). The paper's full grid is
//! `rbf/nn_tick_fused_4096x3` in `benches/rbf.rs`; it is repeated here through the same API.
//!
//! Performance log (release, AMD EPYC Zen 4 VM, 2 cores shared, AVX2 path): see
//! `docs/network.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::SVector;
use tandem::control::rbf::NnUpdate;
use tandem::control::rbf::structured::{NetworkStructure, StructuredNn};

fn bench_m<const M: usize>(
    c: &mut Criterion,
    label: &str,
    cases: &[(&str, NetworkStructure, Vec<f64>)],
) {
    let upd = NnUpdate::<M>::new(SVector::repeat(1.5), SVector::repeat(1e-3), 1e-3).unwrap();
    let z: Vec<f64> = (0..4 * M).map(|i| 0.02 * (i as f64 - 6.0)).collect();
    let z2 = SVector::<f64, M>::from_fn(|j, _| 0.01 * (j as f64 - 1.0));
    for (name, s, levels) in cases {
        let mut net = StructuredNn::<M>::new(s, levels, 50.0, upd).unwrap();
        let id = format!("rbf_structured/{label}/{name}_{}w", net.n_weights());
        c.bench_function(&id, |b| {
            b.iter(|| black_box(net.tick(black_box(&z), black_box(1.0), &z2)))
        });
    }
}

fn bench(c: &mut Criterion) {
    let two = vec![-1.0, 1.0];
    let three = vec![-1.0, 0.0, 1.0];
    let qr = |n| NetworkStructure::QuasiRandom { n, seed: 0 };
    bench_m::<3>(
        c,
        "planar",
        &[
            ("full_grid", NetworkStructure::FullGrid, two.clone()),
            ("per_axis2", NetworkStructure::per_axis(), two.clone()),
            ("per_axis3", NetworkStructure::per_axis(), three.clone()),
            ("quasi_random512", qr(512), two.clone()),
            ("quasi_random4096", qr(4096), two.clone()),
        ],
    );
    bench_m::<6>(
        c,
        "spatial",
        &[
            ("per_axis2", NetworkStructure::per_axis(), two.clone()),
            ("per_axis3", NetworkStructure::per_axis(), three.clone()),
            ("quasi_random512", qr(512), two.clone()),
            ("quasi_random4096", qr(4096), two.clone()),
        ],
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
