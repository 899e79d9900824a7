//! Criterion benches for the admittance generator (`tandem::reference::planar::admittance`) and the desired path
//! (`tandem::reference::planar::path`): the per-tick cost of SPEC §3 steps 2–3 for the paper's two arms.
//!
//! Target: one admittance step for two arms plus one `Path::Circle` sample ≤ 0.2 µs.
//!
//! Performance log (release, criterion 0.8, 2-core dev machine, Rust 1.95):
//! - initial (median): `circle_sample` 35 ns, `admittance_step_2_arms` 10.4 ns,
//!   `tick_circle_plus_2_steps` 50 ns (target 200 ns), `tick_circle_plus_2_steps_and_e_ddot` 65 ns.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector2;
use tandem::reference::planar::admittance::{Admittance, AdmittanceParams, AdmittanceState};
use tandem::reference::planar::path::Path;

fn bench_admittance(c: &mut Criterion) {
    let h = 1e-3;
    let (adm, _) = Admittance::new(&AdmittanceParams::default(), h).unwrap();
    let path = Path::paper();
    let f_ref = [Vector2::new(5.0, 4.9), Vector2::new(-5.0, 4.9)];
    let f_meas = [Vector2::new(5.3, 4.7), Vector2::new(-4.8, 5.2)];

    c.bench_function("circle_sample", |b| {
        let mut t = 0.0;
        b.iter(|| {
            t += h;
            black_box(path.sample(black_box(t)))
        })
    });

    c.bench_function("admittance_step_2_arms", |b| {
        let mut st = f_ref.map(AdmittanceState::with_filter_at);
        b.iter(|| {
            for i in 0..2 {
                adm.step(&mut st[i], black_box(f_meas[i]), black_box(f_ref[i]));
            }
            black_box(&st);
        })
    });

    // The target: one path sample plus both arms' generator steps.
    c.bench_function("tick_circle_plus_2_steps", |b| {
        let mut st = f_ref.map(AdmittanceState::with_filter_at);
        let mut t = 0.0;
        b.iter(|| {
            t += h;
            let xd = path.sample(black_box(t));
            for i in 0..2 {
                adm.step(&mut st[i], black_box(f_meas[i]), black_box(f_ref[i]));
            }
            black_box((xd, st))
        })
    });

    // SPEC §3 steps 2–3 for the paper scenario: x_d(t) and its derivatives, then each arm's
    // generator and its ë for ẍ_r.
    c.bench_function("tick_circle_plus_2_steps_and_e_ddot", |b| {
        let mut st = f_ref.map(AdmittanceState::with_filter_at);
        let mut t = 0.0;
        b.iter(|| {
            t += h;
            let xd = path.sample(black_box(t));
            let mut acc = [Vector2::zeros(); 2];
            for i in 0..2 {
                adm.step(&mut st[i], black_box(f_meas[i]), black_box(f_ref[i]));
                acc[i] = adm.e_ddot(&st[i], f_ref[i]);
            }
            black_box((xd, st, acc))
        })
    });
}

criterion_group!(benches, bench_admittance);
criterion_main!(benches);
