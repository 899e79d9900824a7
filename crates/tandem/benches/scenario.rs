//! The whole 90 s paper scenario (SPEC §4), outputs excluded: NN (tuned) at 1 kHz control on the
//! constrained plant (the default) and on the reduced plant, and PD for comparison.
use criterion::{Criterion, criterion_group, criterion_main};
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::ControllerParams;
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::sim::{Formulation, SimParams, Simulation};

fn build(law: Law<3>, formulation: Formulation) -> Simulation {
    let sp = SimParams {
        formulation,
        ..SimParams::paper()
    };
    presets::paper_simulation(&ControllerParams::paper(law), sp, Disturbance::paper())
        .unwrap()
        .0
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("scenario_90s");
    g.sample_size(10);
    for (name, law, f) in [
        (
            "nn_tuned_constrained",
            Law::Nn(NnGains::tuned()),
            Formulation::Constrained,
        ),
        (
            "nn_tuned_reduced",
            Law::Nn(NnGains::tuned()),
            Formulation::Reduced,
        ),
        (
            "pd_constrained",
            Law::Pd(PdGains::<3>::paper()),
            Formulation::Constrained,
        ),
    ] {
        g.bench_function(name, |b| {
            b.iter_batched(
                || build(law.clone(), f),
                |sim| sim.run(|_| {}).0.t_end,
                criterion::BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
