//! One controller tick (estimation, path, admittance reference, law, distribution, joint
//! torques) for each law on the paper set-up, and the NN law's parts.
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use tandem::control::Scheme;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::{Controller, ControllerParams, TickRecord};
use tandem::control::rbf::{NnUpdate, Rbf, RbfNetwork};
use tandem::drive::Measurements;
use tandem::nalgebra::Vector3;
use tandem::plant::planar::Plant;
use tandem::presets;
use tandem::reference::planar::path::Path;

fn bench(c: &mut Criterion) {
    let plant = Plant::new(&presets::paper()).unwrap();
    let y = plant
        .initial_state(presets::paper_start(), Vector3::new(0.001, 0.02, 0.0), None)
        .unwrap();
    let (q, _, qd, _) = plant.split(&y);
    let forces = [1.3, -1.2, -1.5, -7.4];
    let meas = Measurements {
        q,
        qd,
        wrenches: &forces,
    };
    for (name, law, scheme) in [
        (
            "control/tick_pd",
            Law::Pd(PdGains::<3>::paper()),
            Scheme::Object,
        ),
        (
            "control/tick_ctc",
            Law::Ctc(Default::default()),
            Scheme::Object,
        ),
        (
            "control/tick_nn_tuned",
            Law::Nn(NnGains::tuned()),
            Scheme::Object,
        ),
        (
            "control/tick_nn_per_arm",
            Law::Nn(NnGains::tuned()),
            Scheme::PerArm,
        ),
    ] {
        let p = ControllerParams {
            scheme,
            ..ControllerParams::paper(law)
        };
        let (mut ctl, _) = Controller::new(&p, &presets::paper(), Path::paper(), 90.0).unwrap();
        ctl.start(0.0, &meas);
        let mut tau = [0.0; 4];
        let mut rec = TickRecord::default();
        let mut k = 0u64;
        c.bench_function(name, |b| {
            b.iter(|| {
                k += 1;
                ctl.tick(
                    black_box(1e-3 * (k % 1000) as f64),
                    &meas,
                    &mut tau,
                    &mut rec,
                );
                black_box(tau[0])
            })
        });
    }
    // The NN network alone without the norm pass (what the law calls).
    let rbf = Rbf::paper();
    let mut ws = rbf.workspace();
    let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
    let upd = NnUpdate::new(Vector3::new(1.6, 1.5, 0.5), Vector3::repeat(0.001), 1e-3).unwrap();
    let z = [
        0.19, 0.0, 0.0, 0.01, -0.02, 0.0, 0.02, 0.015, 0.0, -0.3, 0.2, 0.05,
    ];
    let z2 = Vector3::new(1e-3, -2e-3, 5e-4);
    c.bench_function("rbf/nn_tick_outputs_only_4096x3", |b| {
        b.iter(|| black_box(net.tick_at_outputs(&rbf, black_box(&z), &mut ws, 1.0, &z2, &upd)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
