//! The spatial controller (SPEC-spatial S5) on the S6 scenario: one controller tick per law
//! (at a state of a running loop), and one closed-loop tick (the plant's RK4 step, the wrench
//! evaluation, the sensors, the controller and the log) for the NN law on two UR5 and two
//! Franka arms. A run's real-time factor is 1 ms over the closed-loop tick.
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Translation3, Vector3};
use std::hint::black_box;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::{SpatialController, SpatialControllerParams, SpatialTickRecord};
use tandem::drive::Measurements;
use tandem::model::disturbance::SpatialDisturbance;
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;
use tandem::reference::spatial::path::Se3Path;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Formulation, SimParams, Simulation, SpatialStart};

fn sim(franka: bool, law: Law<6>, duration: f64) -> Simulation<SpatialPlant, SpatialController> {
    let s = if franka {
        presets::dual_franka()
    } else {
        presets::dual_ur5()
    };
    let p = SpatialControllerParams::spec_s6(law);
    let path = Se3Path::spec_s6();
    let (c, _) = SpatialController::new(&p, &s.params, path.clone(), duration, &s.q_guess).unwrap();
    let d0 = path.sample(0.0);
    let start = SpatialStart {
        x_wo: Isometry3::from_parts(
            Translation3::from(d0.p - Vector3::new(0.01, 0.0, 0.0)),
            d0.r,
        ),
        q_guess: s.q_guess.clone(),
    };
    Simulation::with_plant(
        SpatialPlant::new(&s.params).unwrap(),
        &start,
        &SensorParams::default(),
        c,
        SpatialDisturbance::spec_s6(),
        SimParams {
            duration,
            plant_step: 1e-3,
            control_period: 1e-3,
            log_period: 0.01,
            start: [0.0; 3],
            formulation: Formulation::Constrained,
            max_drift: 1e-6,
            min_sigma: 1e-3,
        },
    )
    .unwrap()
}

fn bench(c: &mut Criterion) {
    // Controller ticks alone, replaying the measurements of 2 s of the closed loop (so the
    // controller sees a consistent trajectory; one jump back per 2000 ticks).
    for (name, franka, law) in [
        ("nn_dual_ur5", false, Law::Nn(NnGains::dual_ur5())),
        ("pd_dual_ur5", false, Law::Pd(PdGains::<6>::paper())),
        ("ctc_dual_ur5", false, Law::Ctc(CtcGains::<6>::default())),
        ("nn_dual_franka", true, Law::Nn(NnGains::dual_franka())),
    ] {
        let law2 = law.clone();
        let mut s = sim(franka, law, 3.0);
        let n = s.plant().n_q();
        let ticks = 2000;
        let mut rec_q = Vec::with_capacity(ticks);
        let mut rec_w = Vec::with_capacity(ticks);
        for k in 0..ticks {
            s.tick(k).unwrap();
            let y = s.state();
            rec_q.push((y[..n].to_vec(), y[n + 7..2 * n + 7].to_vec()));
            rec_w.push(s.last_readings().to_vec());
        }
        let s2 = if franka {
            presets::dual_franka()
        } else {
            presets::dual_ur5()
        };
        let (mut controller, _) = SpatialController::new(
            &SpatialControllerParams::spec_s6(law2),
            &s2.params,
            Se3Path::spec_s6(),
            3.0,
            &s2.q_guess,
        )
        .unwrap();
        controller.start(
            0.0,
            &Measurements {
                q: &rec_q[0].0,
                qd: &rec_q[0].1,
                wrenches: &rec_w[0],
            },
        );
        let mut tau = vec![0.0; n];
        let mut rec = SpatialTickRecord::new(2);
        let mut k = 0;
        c.bench_function(&format!("spatial_control/{name}/tick"), |b| {
            b.iter(|| {
                let i = k % ticks;
                let meas = Measurements {
                    q: &rec_q[i].0,
                    qd: &rec_q[i].1,
                    wrenches: &rec_w[i],
                };
                controller.tick(i as f64 * 1e-3, black_box(&meas), &mut tau, &mut rec);
                k += 1;
            })
        });
    }
    // Closed-loop ticks (the real-time factor of a run).
    for (name, franka, law) in [
        ("nn_dual_ur5", false, Law::Nn(NnGains::dual_ur5())),
        ("nn_dual_franka", true, Law::Nn(NnGains::dual_franka())),
    ] {
        let mut s = sim(franka, law, 120.0);
        let mut k = 0;
        c.bench_function(&format!("spatial_control/{name}/closed_loop_tick"), |b| {
            b.iter(|| {
                s.tick(k).unwrap();
                k += 1;
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
