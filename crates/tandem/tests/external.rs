//! Issue 23: the loop's two doors out. A user's law that fails stops the run with a `driver`
//! fault at the tick's time and the last good state ([`tandem::sim::External`]); a plant stepped
//! from outside ([`tandem::sim::Stepped`]) with the torques a driver would have given is the
//! same simulation as the loop, bit for bit.

use tandem::drive::{Drive, Measurements, NoRecord};
use tandem::model::disturbance::SpatialDisturbance;
use tandem::plant::SpatialStart;
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;
use tandem::sim::sensors::{ChannelNoise, SensorParams};
use tandem::sim::{External, ExternalLaw, FaultKind, Held, SimParams, Simulation, Stepped};

/// Joint PD around the start plus the start's holding torques; fails at `fail_at` if given.
struct HoldPd {
    q0: Vec<f64>,
    hold: Vec<f64>,
    fail_at: Option<f64>,
}

impl HoldPd {
    fn torques(&self, m: &Measurements<'_>, tau: &mut [f64]) {
        for k in 0..tau.len() {
            tau[k] = self.hold[k] + 50.0 * (self.q0[k] - m.q[k]) - 5.0 * m.qd[k];
        }
    }
}

impl ExternalLaw for HoldPd {
    fn start(&mut self, _t0: f64, m: &Measurements<'_>) -> Result<(), String> {
        self.q0.copy_from_slice(m.q);
        Ok(())
    }
    fn tick(&mut self, t: f64, m: &Measurements<'_>, tau: &mut [f64]) -> Result<(), String> {
        if self.fail_at.is_some_and(|f| t >= f) {
            tau.fill(f64::NAN); // what a failing law leaves behind must not reach the plant
            return Err(format!("gave up at {t}"));
        }
        self.torques(m, tau);
        Ok(())
    }
}

/// The same law as a plain driver, to compare the loop with the stepped plant.
impl Drive<SpatialPlant> for HoldPd {
    type Record = NoRecord;
    fn new_record(&self) -> NoRecord {
        NoRecord
    }
    fn start(&mut self, t0: f64, m: &Measurements<'_>) {
        ExternalLaw::start(self, t0, m).unwrap();
    }
    fn tick(&mut self, _t: f64, m: &Measurements<'_>, tau: &mut [f64], _r: &mut NoRecord) {
        self.torques(m, tau);
    }
}

fn setup() -> (
    SpatialPlant,
    SpatialStart,
    Vec<f64>,
    SimParams,
    SensorParams,
) {
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
    sp.duration = 0.5;
    sp.plant_step = 5e-4;
    // Noisy sensors: the stepped plant must draw the same noise in the same order.
    let sensors = SensorParams {
        seed: 11,
        encoder_q: ChannelNoise {
            std_dev: 1e-5,
            ..Default::default()
        },
        force: ChannelNoise {
            std_dev: 0.05,
            ..Default::default()
        },
        ..Default::default()
    };
    (plant, start, hold, sp, sensors)
}

#[test]
fn a_failing_law_stops_the_run_with_a_driver_fault_and_clean_torques() {
    let (plant, start, hold, sp, sensors) = setup();
    let law = HoldPd {
        q0: vec![0.0; hold.len()],
        hold,
        fail_at: Some(0.2),
    };
    let sim = Simulation::with_plant(
        plant,
        &start,
        &sensors,
        External::new(Box::new(law)),
        SpatialDisturbance::zero(),
        sp,
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    let f = out.fault.expect("the law failed");
    assert_eq!(
        f.kind,
        FaultKind::Driver {
            message: "gave up at 0.2".into()
        }
    );
    assert!((f.t - 0.2).abs() < 1e-12, "{}", f.t);
    assert!(f.q.iter().chain(&f.x_o).all(|v| v.is_finite()));
    assert_eq!(out.ticks, 200);
    let text = f.to_string();
    assert!(text.starts_with("the law failed at t = 0.2000 s: gave up at 0.2; last good state"));
    // The log holds only finite, pre-failure torques.
    let tau = out.log.get("tau_q1").unwrap();
    assert!(tau.iter().all(|v| v.is_finite()));
}

#[test]
fn a_law_that_fails_to_start_stops_the_run_at_its_first_tick() {
    struct NoStart;
    impl ExternalLaw for NoStart {
        fn start(&mut self, _: f64, _: &Measurements<'_>) -> Result<(), String> {
            Err("not ready".into())
        }
        fn tick(&mut self, _: f64, _: &Measurements<'_>, _: &mut [f64]) -> Result<(), String> {
            panic!("ticked after a failed start")
        }
    }
    let (plant, start, _, sp, sensors) = setup();
    let sim = Simulation::with_plant(
        plant,
        &start,
        &sensors,
        External::new(Box::new(NoStart)),
        SpatialDisturbance::zero(),
        sp,
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    let f = out.fault.expect("start failed");
    assert_eq!(f.t, 0.0);
    assert_eq!(
        f.kind,
        FaultKind::Driver {
            message: "not ready".into()
        }
    );
}

#[test]
fn a_stepped_plant_is_the_loop_bit_for_bit() {
    let (plant, start, hold, sp, sensors) = setup();
    let law = || HoldPd {
        q0: vec![0.0; hold.len()],
        hold: hold.clone(),
        fail_at: None,
    };
    let zero = SpatialDisturbance::zero;
    let mut a =
        Simulation::with_plant(plant.clone(), &start, &sensors, law(), zero(), sp.clone()).unwrap();
    let b =
        Simulation::with_plant(plant, &start, &sensors, Held::new(hold.len()), zero(), sp).unwrap();
    let mut b = Stepped::new(b).unwrap();
    // The caller's copy of the law, started as the loop starts its driver: on the true start
    // (at rest, the sensors' truth); then fed what the stepped plant's sensors read.
    let mut mine = law();
    let (q, qd) = b.joints();
    let m = Measurements {
        q,
        qd,
        wrenches: b.sensor_truth(),
    };
    ExternalLaw::start(&mut mine, 0.0, &m).unwrap();
    let mut tau = vec![0.0; hold.len()];
    for k in 0..400 {
        a.tick(k).unwrap();
        {
            let s = b.sensors();
            let m = Measurements {
                q: s.q(),
                qd: s.qd(),
                wrenches: b.readings(),
            };
            assert_eq!(m.wrenches, a.last_readings(), "tick {k}");
            mine.torques(&m, &mut tau);
        }
        assert_eq!(tau.as_slice(), a.applied_torques(), "tick {k}");
        b.step(&tau, 1).unwrap();
        assert_eq!(b.state(), a.state(), "tick {k}");
    }
    assert!((b.time() - 0.4).abs() < 1e-12);
    let (lin, ang) = b.residual();
    assert!(lin < 1e-9 && ang < 1e-9, "{lin} {ang}");
    assert!(b.energy().total().is_finite());
}
