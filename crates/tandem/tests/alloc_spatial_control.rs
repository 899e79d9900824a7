//! The spatial controller allocates nothing per tick, for every law and scheme, alone and
//! inside the simulation loop (counting allocator, `tests/support/counting.rs`).

use nalgebra::{Isometry3, Translation3, Vector3};
use tandem::control::Scheme;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::{SpatialController, SpatialControllerParams};
use tandem::model::disturbance::{Push, SpatialDisturbance};
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;
use tandem::reference::spatial::path::Se3Path;
use tandem::sim::sensors::{ChannelNoise, SensorParams};
use tandem::sim::{Formulation, SimParams, Simulation, SpatialStart};

#[path = "support/counting.rs"]
mod counting;
use counting::count;

#[global_allocator]
static A: counting::Counting = counting::Counting;

#[test]
fn the_counter_counts() {
    let n = count(|| {
        let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
        drop(v);
    });
    assert_eq!(n, 1);
}

#[test]
fn every_spatial_law_and_scheme_ticks_without_allocating() {
    let noisy = SensorParams {
        force: ChannelNoise {
            std_dev: 0.05,
            ..Default::default()
        },
        torque: ChannelNoise {
            std_dev: 0.005,
            ..Default::default()
        },
        encoder_q: ChannelNoise {
            std_dev: 1e-6,
            ..Default::default()
        },
        seed: 3,
        ..Default::default()
    };
    for (name, franka, law, scheme, torque_limit) in [
        (
            "nn ur5",
            false,
            Law::Nn(NnGains::dual_ur5()),
            Scheme::Object,
            None,
        ),
        (
            "pd ur5",
            false,
            Law::Pd(PdGains::<6>::paper()),
            Scheme::Object,
            Some(20.0),
        ),
        (
            "ctc ur5",
            false,
            Law::Ctc(CtcGains::<6>::default()),
            Scheme::Object,
            None,
        ),
        (
            "pd per-arm ur5",
            false,
            Law::Pd(PdGains::<6>::paper()),
            Scheme::PerArm,
            None,
        ),
        (
            "nn franka",
            true,
            Law::Nn(NnGains::dual_franka()),
            Scheme::Object,
            None,
        ),
        (
            "ctc franka",
            true,
            Law::Ctc(CtcGains::<6>::default()),
            Scheme::Object,
            None,
        ),
    ] {
        let s = if franka {
            presets::dual_franka()
        } else {
            presets::dual_ur5()
        };
        let mut p = SpatialControllerParams::spec_s6(law);
        p.scheme = scheme;
        p.torque_limit = torque_limit;
        // The actuator stage with a rate limit and a filter (and the NN law's anti-windup).
        p.actuator.rate_limit = Some(300.0);
        p.actuator.filter_time_constant = Some(0.002);
        let path = Se3Path::spec_s6();
        let duration = 0.3;
        let (c, _) =
            SpatialController::new(&p, &s.params, path.clone(), duration, &s.q_guess).unwrap();
        let d0 = path.sample(0.0);
        let start = SpatialStart {
            x_wo: Isometry3::from_parts(
                Translation3::from(d0.p - Vector3::new(0.01, 0.0, 0.0)),
                d0.r,
            ),
            q_guess: s.q_guess.clone(),
        };
        let mut dist = SpatialDisturbance::spec_s6();
        dist.pushes = vec![Push {
            t0: 0.1,
            duration: 0.1,
            wrench: [5.0, 0.0, 0.0, 0.0, 0.0, 0.5],
        }];
        let mut sim = Simulation::with_plant(
            SpatialPlant::new(&s.params).unwrap(),
            &start,
            &noisy,
            c,
            dist,
            SimParams {
                duration,
                plant_step: 5e-4,
                control_period: 1e-3,
                log_period: 2e-3,
                start: [0.0; 3],
                formulation: Formulation::Constrained,
                max_drift: 1e-6,
                min_sigma: 1e-3,
            },
        )
        .unwrap();
        for k in 0..5 {
            sim.tick(k).unwrap();
        }
        let n = count(|| {
            for k in 5..300 {
                sim.tick(k).unwrap();
            }
        });
        assert_eq!(n, 0, "{name}: {n} allocations in 295 ticks");
    }
}
