//! A counting global allocator proves that plant steps, controller ticks and simulation ticks
//! allocate nothing once built (STYLE habit 5; Drake's LimitMalloc, Pinocchio's test_crba_malloc).

use nalgebra::Vector3;
use tandem::control::Scheme;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::{Controller, ControllerParams, TickRecord};
use tandem::drive::Measurements;
use tandem::math::integrate::Rk4;
use tandem::model::disturbance::Disturbance;
use tandem::plant::planar::{ConstrainedOde, Plant, ReducedOde};
use tandem::presets;
use tandem::reference::planar::path::Path;
use tandem::sim::sensors::{ChannelNoise, SensorParams};
use tandem::sim::{Driver, SimParams, Simulation};

#[path = "support/counting.rs"]
mod counting;
#[path = "support/n_link.rs"]
mod n_link;
use counting::count;

#[global_allocator]
static A: counting::Counting = counting::Counting;

#[test]
fn the_counter_counts() {
    // Guards the other tests against a counter that never counts.
    let n = count(|| {
        let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
        drop(v);
    });
    assert_eq!(n, 1);
}

fn params(law: Law<3>) -> ControllerParams {
    // With a torque limit, a rate limit and the output filter, so the actuator stage and the
    // NN law's anti-windup run too.
    ControllerParams {
        torque_limit: Some(50.0),
        actuator: tandem::control::actuator::ActuatorParams {
            rate_limit: Some(200.0),
            filter_time_constant: Some(0.002),
            ..Default::default()
        },
        ..ControllerParams::paper(law)
    }
}

#[test]
fn n_link_constrained_steps_allocate_nothing() {
    // The fixed-size kernel of two 3-link arms (and the general path on the same plant).
    let (p, guess) = presets::redundant_pair();
    let plant = Plant::new(&p).unwrap();
    let mut y = plant
        .initial_state(
            presets::paper_start(),
            Vector3::new(0.01, 0.0, 0.1),
            Some(&guess),
        )
        .unwrap();
    let mut ws = plant.workspace();
    let input = plant.zero_input();
    let mut rk = Rk4::new(plant.state_dim());
    let mut dy = vec![0.0; plant.state_dim()];
    let n = count(|| {
        for k in 0..100 {
            let mut sys = ConstrainedOde {
                plant: &plant,
                ws: &mut ws,
                input: &input,
            };
            rk.step(&mut sys, k as f64 * 1e-3, &mut y, 1e-3);
            assert!(plant.derivative_general(&y, &input, &mut ws, &mut dy));
        }
    });
    assert_eq!(n, 0, "3-link plant steps allocated {n} times");
}

#[test]
fn plant_steps_allocate_nothing() {
    for p in [presets::paper(), presets::three_arms()] {
        let plant = Plant::new(&p).unwrap();
        let mut y = plant
            .initial_state(presets::paper_start(), Vector3::new(0.01, 0.0, 0.1), None)
            .unwrap();
        let mut yr = [0.19, 0.0, 0.0, 0.01, 0.0, 0.1];
        let mut rkr = Rk4::new(6);
        let n = constrained_step_allocations(&plant, &mut y);
        assert_eq!(n, 0, "constrained plant steps allocated {n} times");
        if plant.arms().len() == 2 {
            let (mut ws, input) = (plant.workspace(), plant.zero_input());
            let n = count(|| {
                for k in 0..100 {
                    let mut sys = ReducedOde {
                        plant: &plant,
                        ws: &mut ws,
                        input: &input,
                    };
                    rkr.step(&mut sys, k as f64 * 1e-3, &mut yr, 1e-3);
                }
            });
            assert_eq!(n, 0, "reduced plant steps allocated {n} times");
        }
    }
}

#[test]
fn controller_ticks_allocate_nothing() {
    let plant = Plant::new(&presets::paper()).unwrap();
    let y = plant
        .initial_state(presets::paper_start(), Vector3::zeros(), None)
        .unwrap();
    let (q, _, qd, _) = plant.split(&y);
    let forces = [1.0, -5.0, -1.0, -5.0];
    for law in [
        Law::Nn(NnGains::tuned()),
        Law::Pd(PdGains::<3>::paper()),
        // PD with the model's gravity 𝓖 of (14) (object scheme only).
        Law::Pd(PdGains {
            gravity_compensation: true,
            ..PdGains::<3>::paper()
        }),
        Law::Ctc(Default::default()),
    ] {
        let name = law.name();
        let (mut c, _) =
            Controller::new(&params(law), &presets::paper(), Path::paper(), 10.0).unwrap();
        let meas = Measurements {
            q,
            qd,
            wrenches: &forces,
        };
        c.start(0.0, &meas);
        let mut tau = vec![0.0; plant.n_q()];
        let mut rec = TickRecord::default();
        c.tick(0.0, &meas, &mut tau, &mut rec);
        let n = count(|| {
            for k in 1..200 {
                c.tick(k as f64 * 1e-3, &meas, &mut tau, &mut rec);
            }
        });
        assert_eq!(n, 0, "{name} controller ticks allocated {n} times");
        // The per-arm scheme (PD and NN).
        if name != "ctc" {
            let mut p = params(match name {
                "nn" => Law::Nn(NnGains::tuned()),
                _ => Law::Pd(PdGains::<3>::paper()),
            });
            p.scheme = tandem::control::Scheme::PerArm;
            let (mut c, _) = Controller::new(&p, &presets::paper(), Path::paper(), 10.0).unwrap();
            c.start(0.0, &meas);
            c.tick(0.0, &meas, &mut tau, &mut rec);
            let n = count(|| {
                for k in 1..200 {
                    c.tick(k as f64 * 1e-3, &meas, &mut tau, &mut rec);
                }
            });
            assert_eq!(n, 0, "per-arm {name} controller ticks allocated {n} times");
        }
        assert!(tau.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn n_link_controller_ticks_and_plant_steps_allocate_nothing() {
    // The controller's fixed-size arm kernels (3 and 4 links, two and three arms) and its
    // dynamic-size route (5 links), PD on the object and per arm; and the plant's fixed-size
    // kernels for three 3-link arms and 4-link arms (two 3-link arms: above).
    for (arms, links) in [(2, 3), (3, 3), (2, 4), (3, 4), (2, 5)] {
        let (p, guess) = n_link::chain(arms, links);
        let plant = Plant::new(&p).unwrap();
        let mut y = plant
            .initial_state(
                presets::paper_start(),
                Vector3::new(0.01, 0.0, 0.1),
                Some(&guess),
            )
            .unwrap();
        let forces = vec![1.0; 2 * arms];
        let mut tau = vec![0.0; plant.n_q()];
        let mut rec = TickRecord::default();
        for scheme in [Scheme::Object, Scheme::PerArm] {
            let mut cp = params(Law::Pd(PdGains::<3>::paper()));
            cp.scheme = scheme;
            let (mut c, _) = Controller::new(&cp, &p, Path::paper(), 10.0).unwrap();
            let (q, _, qd, _) = plant.split(&y);
            let meas = Measurements {
                q,
                qd,
                wrenches: &forces,
            };
            c.start(0.0, &meas);
            c.tick(0.0, &meas, &mut tau, &mut rec);
            let n = count(|| {
                for k in 1..200 {
                    c.tick(k as f64 * 1e-3, &meas, &mut tau, &mut rec);
                }
            });
            assert_eq!(
                n, 0,
                "{arms} {links}-link arms, {scheme:?}: ticks allocated {n} times"
            );
            assert!(tau.iter().all(|v| v.is_finite()) && tau.iter().any(|v| *v != 0.0));
        }
        let n = constrained_step_allocations(&plant, &mut y);
        assert_eq!(n, 0, "{arms} {links}-link plant steps allocated {n} times");
    }
}

#[test]
fn simulation_ticks_allocate_nothing() {
    let plant = presets::paper();
    let (c, _) = Controller::new(
        &params(Law::Nn(NnGains::tuned())),
        &plant,
        Path::paper(),
        1.0,
    )
    .unwrap();
    let noisy = ChannelNoise {
        std_dev: 1e-4,
        bias: 0.0,
        tau: 0.002,
        dropout: 0.01,
    };
    let sensors = SensorParams {
        encoder_q: noisy,
        encoder_qd: noisy,
        force: noisy,
        seed: 7,
        ..Default::default()
    };
    let mut sp = SimParams::paper();
    sp.duration = 1.0;
    let mut sim = Simulation::new(
        &plant,
        &sensors,
        Driver::Controller(Box::new(c)),
        Disturbance::paper(),
        sp,
        None,
    )
    .unwrap();
    sim.tick(0).unwrap();
    // Logging rows included (every 30 ticks): the log's capacity is reserved at start.
    let n = count(|| {
        for k in 1..300 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(n, 0, "simulation ticks allocated {n} times");
}

#[test]
fn spatial_plant_steps_allocate_nothing() {
    use tandem::plant::spatial::{GraspModel, SpatialPlant};
    for s in [
        presets::dual_ur5(),
        presets::dual_franka(),
        presets::three_ur5(),
    ] {
        for model in ["weld", "compliant", "contact"] {
            let compliant = model;
            let mut p = s.params.clone();
            if model == "compliant" {
                p.grasp_model = GraspModel::Compliant {
                    stiffness: nalgebra::Vector6::new(1e5, 1e5, 1e5, 100.0, 100.0, 100.0),
                    damping: nalgebra::Vector6::new(280.0, 280.0, 280.0, 0.2, 0.2, 0.2),
                };
            }
            if model == "contact" {
                // Two pads per grasp on the box's ±z faces, 3 cm in from the grasp's end.
                let pads = p
                    .grasps
                    .iter()
                    .map(|g| {
                        let x = g.translation.vector.x - 0.03 * g.translation.vector.x.signum();
                        [-1.0, 1.0]
                            .iter()
                            .map(|&side| tandem::plant::spatial::Pad {
                                position: (g.inverse() * nalgebra::Point3::new(x, 0.0, side * 0.1))
                                    .coords,
                                normal: g.rotation.inverse()
                                    * nalgebra::Vector3::new(0.0, 0.0, -side),
                                radius: 0.01,
                            })
                            .collect()
                    })
                    .collect();
                p.grasp_model = GraspModel::Contact(tandem::plant::spatial::ContactParams {
                    pads,
                    grip: vec![60.0; p.grasps.len()],
                    mu: 0.3,
                    torsion: 0.002,
                    normal_stiffness: 1e5,
                    normal_damping: 30.0,
                    tangential_stiffness: 1e5,
                    tangential_damping: 30.0,
                    half_extents: nalgebra::Vector3::new(0.2, 0.1, 0.1),
                });
            }
            let plant = SpatialPlant::new(&p).unwrap();
            let y0 = plant
                .initial_state(&s.x_wo, &nalgebra::Vector6::zeros(), &s.q_guess)
                .unwrap();
            let mut y = y0.clone();
            let mut ws = plant.workspace();
            let mut rk = Rk4::new(plant.state_dim());
            let input = plant.zero_input();
            let mut dy = vec![0.0; plant.state_dim()];
            plant
                .step(&mut rk, 0.0, &mut y, &input, &mut ws, 1e-4, 2)
                .unwrap();
            let n = count(|| {
                for k in 0..20 {
                    plant
                        .step(&mut rk, k as f64 * 1e-4, &mut y, &input, &mut ws, 1e-4, 1)
                        .unwrap();
                    assert!(plant.derivative(&y, &input, &mut ws, &mut dy));
                }
            });
            assert_eq!(n, 0, "spatial plant step allocated ({compliant} grasps)");
        }
    }
}

/// A minimal user driver for the generic-loop test: the start's holding torques plus a joint PD.
struct HoldPd {
    q0: Vec<f64>,
    hold: Vec<f64>,
}

impl<P: tandem::plant::ClosedChain> tandem::drive::Drive<P> for HoldPd {
    type Record = tandem::drive::NoRecord;
    fn new_record(&self) -> Self::Record {
        tandem::drive::NoRecord
    }
    fn start(&mut self, _t0: f64, meas: &Measurements<'_>) {
        self.q0.copy_from_slice(meas.q);
    }
    fn tick(&mut self, _t: f64, meas: &Measurements<'_>, tau: &mut [f64], _rec: &mut Self::Record) {
        for k in 0..tau.len() {
            tau[k] = self.hold[k] + 400.0 * (self.q0[k] - meas.q[k]) - 20.0 * meas.qd[k];
        }
        // Read the wrist channels too (spatial: 6 per arm).
        std::hint::black_box(meas.wrench(0));
    }
}

fn faults() -> tandem::sim::faults::Faults {
    tandem::sim::faults::Faults {
        dropout_rate: 5.0,
        dropout_length: 0.01,
        force_limit: Some(30.0),
        force_delay: 0.003,
        encoder_resolution: 1e-4,
        torque_limit: Some(100.0),
        torque_rate: Some(1e5),
        seed: 3,
    }
}

#[test]
fn generic_loop_ticks_allocate_nothing() {
    use tandem::plant::SpatialStart;
    use tandem::plant::spatial::SpatialPlant;
    use tandem::sim::Replay;
    let plant = presets::paper();
    let sensors = SensorParams {
        seed: 7,
        ..Default::default()
    };
    let mut sp = SimParams::paper();
    sp.duration = 1.0;
    // The planar controller as the driver itself (not through the Driver enum), with faults.
    let (c, _) = Controller::new(
        &params(Law::Pd(PdGains::<3>::paper())),
        &plant,
        Path::paper(),
        1.0,
    )
    .unwrap();
    let mut sim = Simulation::new(&plant, &sensors, c, Disturbance::paper(), sp.clone(), None)
        .unwrap()
        .with_faults(&faults())
        .unwrap();
    sim.tick(0).unwrap();
    let n = count(|| {
        for k in 1..300 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(
        n, 0,
        "planar controller (generic) ticks allocated {n} times"
    );
    // The replay, through the Driver enum (planar record) and on its own, linear.
    let times: Vec<f64> = (0..100).map(|k| k as f64 * 0.01).collect();
    let rows = vec![vec![0.0; 4]; 100];
    for linear in [false, true] {
        let mut r = Replay::new(times.clone(), rows.clone(), 4).unwrap();
        if linear {
            r = r.linear();
        }
        let mut a = Simulation::new(
            &plant,
            &sensors,
            Driver::Replay(r.clone()),
            Disturbance::paper(),
            sp.clone(),
            None,
        )
        .unwrap();
        let mut b =
            Simulation::new(&plant, &sensors, r, Disturbance::paper(), sp.clone(), None).unwrap();
        a.tick(0).unwrap();
        b.tick(0).unwrap();
        let n = count(|| {
            for k in 1..100 {
                a.tick(k).unwrap();
                b.tick(k).unwrap();
            }
        });
        assert_eq!(n, 0, "replay ticks allocated {n} times (linear: {linear})");
    }
    // The spatial plant with a user driver, with faults, and a spatial replay.
    let s = presets::dual_ur5();
    let sp_plant = SpatialPlant::new(&s.params).unwrap();
    let y0 = sp_plant
        .initial_state(&s.x_wo, &nalgebra::Vector6::zeros(), &s.q_guess)
        .unwrap();
    let mut hold = vec![0.0; sp_plant.n_q()];
    sp_plant.holding_torques(&y0, &mut sp_plant.workspace(), &mut hold);
    let start = SpatialStart {
        x_wo: s.x_wo,
        q_guess: s.q_guess.clone(),
    };
    let mut ssp = sp.clone();
    ssp.plant_step = 5e-4;
    let drv = HoldPd {
        q0: vec![0.0; hold.len()],
        hold: hold.clone(),
    };
    let mut sim = Simulation::with_plant(
        sp_plant.clone(),
        &start,
        &sensors,
        drv,
        tandem::model::disturbance::SpatialDisturbance::zero(),
        ssp.clone(),
    )
    .unwrap()
    .with_faults(&faults())
    .unwrap();
    sim.tick(0).unwrap();
    let n = count(|| {
        for k in 1..100 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(n, 0, "spatial user-driver ticks allocated {n} times");
    let r = Replay::new(vec![0.0], vec![hold.clone()], hold.len()).unwrap();
    let mut sim = Simulation::with_plant(
        sp_plant,
        &start,
        &sensors,
        r,
        tandem::model::disturbance::SpatialDisturbance::zero(),
        ssp,
    )
    .unwrap();
    sim.tick(0).unwrap();
    let n = count(|| {
        for k in 1..100 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(n, 0, "spatial replay ticks allocated {n} times");
}

/// The planar fault-injection path as `tandem robustness` runs it (the NN law through the
/// [`Driver`] enum), with every `[faults]` knob set hard enough to act in the counted ticks:
/// dropout bursts (0.05 per tick: about 15 bursts in 300 ticks), force saturation at 0.5 N, a
/// 20 ms force delay (its ring wraps 15 times), 1 mrad encoder quantisation, 2 N m torque
/// saturation and a 300 N m/s rate limit. No tick allocates, and the faults did act (the state
/// differs from the same ticks without them).
#[test]
fn fault_injected_driver_ticks_allocate_nothing() {
    let plant = presets::paper();
    let build = |f: Option<tandem::sim::faults::Faults>| {
        let (c, _) = Controller::new(
            &ControllerParams::paper(Law::Nn(NnGains::tuned())),
            &plant,
            Path::paper(),
            1.0,
        )
        .unwrap();
        let mut sp = SimParams::paper();
        sp.duration = 1.0;
        let sim = Simulation::new(
            &plant,
            &SensorParams::default(),
            Driver::Controller(Box::new(c)),
            Disturbance::paper(),
            sp,
            None,
        )
        .unwrap();
        match f {
            Some(f) => sim.with_faults(&f).unwrap(),
            None => sim,
        }
    };
    let faults = tandem::sim::faults::Faults {
        dropout_rate: 50.0,
        dropout_length: 0.005,
        force_limit: Some(0.5),
        force_delay: 0.02,
        encoder_resolution: 1e-3,
        torque_limit: Some(2.0),
        torque_rate: Some(300.0),
        seed: 11,
    };
    let mut sim = build(Some(faults));
    let mut clean = build(None);
    sim.tick(0).unwrap();
    clean.tick(0).unwrap();
    let n = count(|| {
        for k in 1..300 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(n, 0, "fault-injected ticks allocated {n} times");
    for k in 1..300 {
        clean.tick(k).unwrap();
    }
    let d = sim
        .state()
        .iter()
        .zip(clean.state())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // 2 N m against the paper's tens of N m moves the state by far more than round-off.
    assert!(d > 1e-6, "the faults did not act: state difference {d:e}");
}

/// Allocations during 100 RK4 steps of the constrained plant from `y` (workspace, input and
/// integrator made before counting).
fn constrained_step_allocations(plant: &Plant, y: &mut [f64]) -> usize {
    let mut ws = plant.workspace();
    let input = plant.zero_input();
    let mut rk = Rk4::new(plant.state_dim());
    count(|| {
        for k in 0..100 {
            let mut sys = ConstrainedOde {
                plant,
                ws: &mut ws,
                input: &input,
            };
            rk.step(&mut sys, k as f64 * 1e-3, y, 1e-3);
        }
    })
}

/// Every weight-pass kernel this CPU has, the held-update ones included (their flushes, the
/// `f32` store's load and widening, and the norms refresh), ticks without allocating.
#[test]
fn rbf_ticks_allocate_nothing_with_every_kernel() {
    use tandem::control::rbf::{BATCH_DEPTH, Kernel, NnUpdate, Rbf, RbfNetwork};
    let rbf = Rbf::paper();
    let upd = NnUpdate::new(
        Vector3::new(1.6, 1.5, 0.5),
        Vector3::new(1e-3, 1e-3, 1e-3),
        1e-3,
    )
    .unwrap();
    for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
        let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        net.set_kernel(kernel).unwrap();
        let mut ws = rbf.workspace();
        let z2 = Vector3::new(0.01, -0.02, 0.03);
        let mut z = [0.1; 12];
        net.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
        let n = count(|| {
            for k in 0..3 * BATCH_DEPTH + 5 {
                z[k % 12] = 0.01 * k as f64;
                net.tick_at_outputs(&rbf, &z, &mut ws, 0.5, &z2, &upd);
                if k == 2 * BATCH_DEPTH {
                    net.flush();
                    let _ = net.norms();
                }
            }
        });
        assert_eq!(n, 0, "{kernel}: {n} allocations");
    }
}

/// A user's law behind [`tandem::sim::ExternalLaw`] (issue 23: how a Python law drives the
/// loop) and a plant stepped from outside ([`tandem::sim::Stepped`]): neither allocates per
/// tick.
#[test]
fn external_law_ticks_and_stepped_plant_steps_allocate_nothing() {
    use tandem::plant::SpatialStart;
    use tandem::plant::spatial::SpatialPlant;
    use tandem::sim::{External, ExternalLaw, Held, Stepped};
    struct Hold(Vec<f64>);
    impl ExternalLaw for Hold {
        fn start(&mut self, _t0: f64, _m: &Measurements<'_>) -> Result<(), String> {
            Ok(())
        }
        fn tick(&mut self, _t: f64, m: &Measurements<'_>, tau: &mut [f64]) -> Result<(), String> {
            for (k, t) in tau.iter_mut().enumerate() {
                *t = self.0[k] - 20.0 * m.qd[k];
            }
            Ok(())
        }
    }
    let s = presets::dual_ur5();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y0 = plant
        .initial_state(&s.x_wo, &nalgebra::Vector6::zeros(), &s.q_guess)
        .unwrap();
    let mut hold = vec![0.0; plant.n_q()];
    plant.holding_torques(&y0, &mut plant.workspace(), &mut hold);
    let start = SpatialStart {
        x_wo: s.x_wo,
        q_guess: s.q_guess.clone(),
    };
    let mut sp = SimParams::paper();
    sp.duration = 1.0;
    sp.plant_step = 5e-4;
    let sensors = SensorParams::default();
    let zero = tandem::model::disturbance::SpatialDisturbance::zero;
    let law = External::new(Box::new(Hold(hold.clone())));
    let mut sim =
        Simulation::with_plant(plant.clone(), &start, &sensors, law, zero(), sp.clone()).unwrap();
    sim.tick(0).unwrap();
    let n = count(|| {
        for k in 1..100 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(n, 0, "external-law ticks allocated {n} times");
    let held = Held::new(hold.len());
    let sim = Simulation::with_plant(plant, &start, &sensors, held, zero(), sp).unwrap();
    let mut st = Stepped::new(sim).unwrap();
    st.step(&hold, 1).unwrap();
    let n = count(|| {
        for _ in 0..50 {
            st.step(&hold, 2).unwrap();
        }
    });
    assert_eq!(n, 0, "stepped plant allocated {n} times");
    assert!((st.time() - 0.101).abs() < 1e-12);
}

/// Contact grasps with the friction-aware distribution: the simulation's ticks (controller with
/// the cone program, plant with the pads) allocate nothing.
#[test]
fn contact_grasp_ticks_with_the_friction_distribution_allocate_nothing() {
    use tandem::control::law::pd::PdGains;
    use tandem::control::spatial::SpatialControllerParams;
    use tandem::control::spatial::distribute::friction::FrictionParams;
    use tandem::plant::spatial::GraspModel;
    let s = presets::dual_ur5_grip();
    let GraspModel::Contact(c) = &s.params.grasp_model else {
        panic!("contact grasps")
    };
    let mut g = PdGains::<6>::paper();
    g.gravity_compensation = true;
    let mut p = SpatialControllerParams::spec_s6(Law::Pd(g));
    p.friction = Some(FrictionParams::from_contact(c, 2.0));
    let (mut sim, _) =
        presets::spatial_s6_simulation_with(&s.params, &s, &p, 1.0, 1e-4, 0.05).unwrap();
    for k in 0..5 {
        sim.tick(k).unwrap();
    }
    let n = count(|| {
        for k in 5..200 {
            sim.tick(k).unwrap();
        }
    });
    assert_eq!(n, 0, "contact-grasp ticks allocated {n} times");
    let st = sim
        .driver()
        .friction_stats()
        .expect("friction distribution");
    assert_eq!(st.fallbacks, 0, "{st:?}");
    assert!(st.solves >= 200);
}

/// The friction-aware distribution under an effort limit it must meet by internal force (the
/// ADMM on the cone plan), and pads gauging welds: neither allocates on a tick.
#[test]
fn effort_limited_friction_plans_and_pad_gauges_allocate_nothing() {
    use tandem::control::law::pd::PdGains;
    use tandem::control::spatial::SpatialControllerParams;
    use tandem::control::spatial::distribute::friction::FrictionParams;
    use tandem::plant::spatial::GraspModel;
    let grip = presets::dual_ur5_grip();
    let GraspModel::Contact(c) = &grip.params.grasp_model else {
        panic!("contact grasps")
    };
    let mut g = PdGains::<6>::paper();
    g.gravity_compensation = true;
    let mut p = SpatialControllerParams::spec_s6(Law::Pd(g));
    p.friction = Some(FrictionParams::from_contact(c, 2.0));
    p.actuator.effort = Some(vec![
        150.0, 34.5, 150.0, 28.0, 28.0, 28.0, 150.0, 34.5, 150.0, 28.0, 28.0, 28.0,
    ]);
    // Welds gauged by the grip preset's pads.
    let mut weld = presets::dual_ur5();
    weld.params.pad_gauge = Some(c.clone());
    for (name, s) in [("contact, effort-limited", &grip), ("weld gauged", &weld)] {
        let (mut sim, _) =
            presets::spatial_s6_simulation_with(&s.params, s, &p, 1.0, 1e-4, 0.05).unwrap();
        for k in 0..5 {
            sim.tick(k).unwrap();
        }
        let n = count(|| {
            for k in 5..200 {
                sim.tick(k).unwrap();
            }
        });
        assert_eq!(n, 0, "{name}: ticks allocated {n} times");
        let st = sim
            .driver()
            .friction_stats()
            .expect("friction distribution");
        assert!(
            st.torque_limited > 0,
            "{name}: the limit never acted: {st:?}"
        );
        assert_eq!(st.fallbacks, 0, "{name}: {st:?}");
        let log = &sim.workspace().contacts;
        assert_eq!(log.readings.len(), 4, "{name}");
        assert_eq!(log.gauged, name.starts_with("weld"));
        assert!(
            log.readings.iter().all(|r| r.normal > 50.0),
            "{name}: {:?}",
            log.readings
        );
    }
}
