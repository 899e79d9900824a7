//! Contact grasps (issue 25): the spatial plant's RK4 step with pads against welds, and the
//! closed-loop tick of `dual-ur5-grip` (PD + gravity, 0.1 ms plant step: ten steps a tick) with
//! the friction-aware load distribution against the weld-assuming one, and with effort limits
//! the plan must meet by internal force. The distribution's own cost is the difference of the
//! ticks.
use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use nalgebra::Vector6;
use std::hint::black_box;
use tandem::control::law::Law;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::SpatialControllerParams;
use tandem::control::spatial::distribute::friction::FrictionParams;
use tandem::math::integrate::Rk4;
use tandem::plant::spatial::{GraspModel, SpatialPlant};
use tandem::presets;

fn bench(c: &mut Criterion) {
    // Plant steps at 0.1 ms: welds (dual_ur5) and pads (dual_ur5_grip).
    for (name, s) in [
        ("weld", presets::dual_ur5()),
        ("contact", presets::dual_ur5_grip()),
    ] {
        let plant = SpatialPlant::new(&s.params).unwrap();
        let twist = Vector6::new(0.02, -0.01, 0.03, 0.1, -0.05, 0.2);
        let y = plant.initial_state(&s.x_wo, &twist, &s.q_guess).unwrap();
        let mut ws = plant.workspace();
        let mut input = plant.zero_input();
        let mut tau = vec![0.0; plant.n_q()];
        plant.holding_torques(&y, &mut plant.workspace(), &mut tau);
        input.tau = tau;
        let mut rk = Rk4::new(plant.state_dim());
        let mut yy = y.clone();
        c.bench_function(&format!("friction/plant_step_0.1ms/{name}"), |b| {
            b.iter(|| {
                yy.copy_from_slice(&y);
                plant
                    .step(&mut rk, 0.0, black_box(&mut yy), &input, &mut ws, 1e-4, 1)
                    .unwrap();
            })
        });
    }
    // Closed-loop ticks (ten plant steps each) of the contact grasps, 50 ticks a sample.
    let s = presets::dual_ur5_grip();
    let GraspModel::Contact(contact) = &s.params.grasp_model else {
        unreachable!()
    };
    // Shoulder-lift efforts of 34.5 N m (150 in the URDF): the plan needs the limits on these
    // ticks, and the effort-limited ADMM runs (checked before timing).
    let tight = vec![
        150.0, 34.5, 150.0, 28.0, 28.0, 28.0, 150.0, 34.5, 150.0, 28.0, 28.0, 28.0,
    ];
    for (name, friction, effort) in [
        ("weld_distribution", false, None),
        ("friction_distribution", true, None),
        ("friction_distribution_effort_limited", true, Some(tight)),
    ] {
        let mut g = PdGains::<6>::paper();
        g.gravity_compensation = true;
        let mut p = SpatialControllerParams::spec_s6(Law::Pd(g));
        if friction {
            p.friction = Some(FrictionParams::from_contact(contact, 2.0));
        }
        if let Some(e) = effort {
            p.actuator.effort = Some(e);
            let (mut sim, _) =
                presets::spatial_s6_simulation_with(&s.params, &s, &p, 1.0, 1e-4, 0.05).unwrap();
            for k in 0..100 {
                sim.tick(k).unwrap();
            }
            let before = sim.driver().friction_stats().unwrap().torque_limited;
            for k in 100..150 {
                sim.tick(k).unwrap();
            }
            let st = sim.driver().friction_stats().unwrap();
            assert!(
                st.torque_limited >= before + 40 && st.torque_unmet == 0,
                "the limits must act on the timed ticks: {st:?} (from {before})"
            );
        }
        let mut group = c.benchmark_group("friction/closed_loop_50_ticks");
        group.sample_size(10);
        group.bench_function(name, |b| {
            b.iter_batched(
                || {
                    let (mut sim, _) =
                        presets::spatial_s6_simulation_with(&s.params, &s, &p, 1.0, 1e-4, 0.05)
                            .unwrap();
                    for k in 0..100 {
                        sim.tick(k).unwrap();
                    }
                    sim
                },
                |mut sim| {
                    for k in 100..150 {
                        sim.tick(k).unwrap();
                    }
                    sim
                },
                BatchSize::LargeInput,
            )
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
