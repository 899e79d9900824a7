//! A user-written driver plugs into the one simulation loop through the public API only: a joint
//! PD with gravity compensation (and the object's static load fed forward) drives the planar
//! paper plant and the spatial dual-UR5 plant with the same `Drive` implementation.

use nalgebra::Vector3;
use tandem::control::law::Law;
use tandem::drive::ControlEvents;
use tandem::drive::{Drive, Measurements, Record};
use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::model::disturbance::Disturbance;
use tandem::model::planar::grasp::distribute_wrench;
use tandem::plant::planar::Plant;
use tandem::plant::spatial::SpatialPlant;
use tandem::plant::{ClosedChain, SpatialStart};
use tandem::presets;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{SimParams, Simulation};

/// Joint PD around the start configuration `q0` with gravity compensation:
/// `τ = g(q) + τ_load + K_p (q0 − q) − K_d q̇`, `g` the arms' own gravity torques at the measured
/// angles (a model the user supplies), `τ_load` the constant share of the object's weight.
struct JointPd<G: FnMut(&[f64], &mut [f64])> {
    q0: Vec<f64>,
    tau_load: Vec<f64>,
    kp: f64,
    kd: f64,
    gravity: G,
    ticks: u64,
}

/// The record: the largest joint error of the tick (head) and the PD torque norm (tail).
#[derive(Default)]
struct PdRecord {
    e_max: f64,
    pd_norm: f64,
}

impl Record for PdRecord {
    fn head_columns(&self) -> Vec<(String, String)> {
        vec![("e_max".into(), "rad".into())]
    }
    fn tail_columns(&self) -> Vec<(String, String)> {
        vec![("pd_norm".into(), "N m".into())]
    }
    fn write_head(&self, out: &mut [f64]) {
        out[0] = self.e_max;
    }
    fn write_tail(&self, out: &mut [f64]) {
        out[0] = self.pd_norm;
    }
    fn non_finite(&self) -> Option<String> {
        if !self.e_max.is_finite() {
            Some("e_max".into())
        } else if !self.pd_norm.is_finite() {
            Some("pd_norm".into())
        } else {
            None
        }
    }
}

impl<P: ClosedChain, G: FnMut(&[f64], &mut [f64])> Drive<P> for JointPd<G> {
    type Record = PdRecord;
    fn new_record(&self) -> PdRecord {
        PdRecord::default()
    }
    fn start(&mut self, _t0: f64, meas: &Measurements<'_>) {
        self.q0.copy_from_slice(meas.q);
        self.ticks = 0;
    }
    fn tick(&mut self, _t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut PdRecord) {
        (self.gravity)(meas.q, tau);
        let (mut e_max, mut pd2) = (0.0f64, 0.0);
        for k in 0..tau.len() {
            let e = self.q0[k] - meas.q[k];
            let pd = self.kp * e - self.kd * meas.qd[k];
            tau[k] += self.tau_load[k] + pd;
            e_max = e_max.max(e.abs());
            pd2 += pd * pd;
        }
        rec.e_max = e_max;
        rec.pd_norm = pd2.sqrt();
        self.ticks += 1;
    }
    fn events(&self) -> ControlEvents {
        ControlEvents::default()
    }
}

fn ideal() -> SensorParams {
    SensorParams::default()
}

fn sim_params(duration: f64, plant_step: f64) -> SimParams {
    SimParams {
        duration,
        plant_step,
        log_period: 0.01,
        ..SimParams::paper()
    }
}

/// The planar law: arm gravity from `Arm::dynamics`, the object's weight `G_o` distributed over
/// the grasps (minimum norm) and mapped by `J_eᵀ` at the start.
fn planar_pd(plant: &Plant, y0: &[f64]) -> JointPd<impl FnMut(&[f64], &mut [f64]) + use<>> {
    let (q, x, _, _) = plant.split(y0);
    let n = plant.n_q();
    let mut tx = vec![nalgebra::Vector2::zeros(); plant.arms().len()];
    assert!(distribute_wrench(
        plant.grasps(),
        x.z,
        &plant.object().G_o,
        0.0,
        &mut tx
    ));
    let mut tau_load = vec![0.0; n];
    let mut terms: Vec<_> = plant.arms().iter().map(|a| a.terms()).collect();
    for (i, arm) in plant.arms().iter().enumerate() {
        let o = plant.offset(i);
        let d = arm.dof();
        arm.dynamics(&q[o..o + d], &vec![0.0; d], plant.gravity(), &mut terms[i]);
        for k in 0..d {
            let j = terms[i].J.column(k);
            tau_load[o + k] = j.dot(&tx[i]);
        }
    }
    let arms = plant.arms().to_vec();
    let offsets: Vec<usize> = (0..arms.len()).map(|i| plant.offset(i)).collect();
    let g = plant.gravity();
    let zeros = vec![0.0; n];
    let gravity = move |q: &[f64], tau: &mut [f64]| {
        for (i, arm) in arms.iter().enumerate() {
            let (o, d) = (offsets[i], arm.dof());
            arm.dynamics(&q[o..o + d], &zeros[o..o + d], g, &mut terms[i]);
            for k in 0..d {
                tau[o + k] = terms[i].G[k];
            }
        }
    };
    JointPd {
        q0: q.to_vec(),
        tau_load,
        kp: 400.0,
        kd: 20.0,
        gravity,
        ticks: 0,
    }
}

/// The spatial law: arm gravity from `dynamics::spatial::gravity`; the object's share is the plant's
/// holding torques at the start minus the arms' own gravity there.
fn spatial_pd(plant: &SpatialPlant, y0: &[f64]) -> JointPd<impl FnMut(&[f64], &mut [f64]) + use<>> {
    let n = plant.n_q();
    let mut hold = vec![0.0; n];
    plant.holding_torques(y0, &mut plant.workspace(), &mut hold);
    let arms = plant.arms().to_vec();
    let offsets: Vec<usize> = (0..arms.len()).map(|i| plant.offset(i)).collect();
    let g = plant.gravity();
    let mut data: Vec<ChainData> = arms.iter().map(ChainData::new).collect();
    let mut gravity = move |q: &[f64], tau: &mut [f64]| {
        for (i, arm) in arms.iter().enumerate() {
            let (o, d) = (offsets[i], arm.chain.dof());
            spatial::gravity(arm, &q[o..o + d], &g, &mut tau[o..o + d], &mut data[i]);
        }
    };
    let mut g0 = vec![0.0; n];
    gravity(&y0[..n], &mut g0);
    JointPd {
        q0: y0[..n].to_vec(),
        tau_load: hold.iter().zip(&g0).map(|(h, g)| h - g).collect(),
        kp: 400.0,
        kd: 20.0,
        gravity,
        ticks: 0,
    }
}

fn col<'a>(log: &'a tandem::sim::Log, name: &str) -> &'a [f64] {
    log.get(name)
        .unwrap_or_else(|| panic!("column {name} missing"))
}

#[test]
fn a_user_joint_pd_holds_the_planar_paper_plant() {
    let params = presets::paper();
    let plant = Plant::new(&params).unwrap();
    let y0 = plant
        .initial_state(presets::paper_start(), Vector3::zeros(), None)
        .unwrap();
    let pd = planar_pd(&plant, &y0);
    // The paper's disturbance F_d = (0.02 sin t, 0.02 cos t, 0) N works against the PD.
    let sim = Simulation::new(
        &params,
        &ideal(),
        pd,
        Disturbance::paper(),
        sim_params(2.0, 1e-3),
        None,
    )
    .unwrap();
    let (out, sim) = sim.run(|_| {});
    assert!(out.fault.is_none(), "{:?}", out.fault);
    assert_eq!(out.ticks, 2000);
    assert_eq!(sim.driver().ticks, 2000);
    let log = &out.log;
    let names = log.names();
    assert_eq!(
        names[..6],
        [
            "t [s]",
            "x_o.x [m]",
            "x_o.y [m]",
            "x_o.theta [rad]",
            "e_max [rad]",
            "tau_q1 [N m]"
        ]
    );
    assert_eq!(names[names.len() - 2..], ["pd_norm [N m]", "drift [m]"]);
    assert!(log.get("F_meas2.y").is_some() && log.get("q4").is_some());
    let x0 = presets::paper_start();
    let dev = (0..log.len())
        .map(|k| {
            let x = col(log, "x_o.x")[k] - x0.x;
            let y = col(log, "x_o.y")[k] - x0.y;
            x.hypot(y)
        })
        .fold(0.0f64, f64::max);
    let e_max = col(log, "e_max").iter().fold(0.0f64, |a, b| a.max(*b));
    println!(
        "planar: max |p_o − p_o(0)| = {dev:.3e} m, max joint error {e_max:.3e} rad, max drift {:.3e} m",
        out.max_drift
    );
    assert!(e_max > 0.0, "the disturbance moves the joints");
    // Measured: 5.4e-6 m (joint errors ≤ 1.5e-5 rad), drift ≤ 8e-16 m.
    assert!(dev < 2e-5, "the object left its start by {dev} m");
    assert!(out.max_drift < 1e-9, "drift {}", out.max_drift);
    assert!(col(log, "drift").iter().all(|d| *d < 1e-9));
    assert!(
        out.min_margin.is_none(),
        "a PD without bounds has no margin"
    );
    // Ideal sensors read the plant's grasp forces exactly (planar: world axes both).
    for i in 1..=2 {
        for a in ["x", "y"] {
            let f = col(log, &format!("F{i}.{a}"));
            let m = col(log, &format!("F_meas{i}.{a}"));
            assert_eq!(f, m, "F{i}.{a}");
        }
    }
    // The arms carry the object's weight (9.8 N) between them.
    let fy = col(log, "F1.y")[log.len() - 1] + col(log, "F2.y")[log.len() - 1];
    // (plus the 0.02 N disturbance and the small accelerations).
    assert!((fy + 9.8).abs() < 0.05, "ΣF_y = {fy}");
}

/// A sinusoidal push on the spatial object: 2 N along x, 0.2 N m about z (world axes).
fn push() -> tandem::model::disturbance::SpatialDisturbance {
    tandem::model::disturbance::Disturbance {
        amplitude: [2.0, 0.0, 0.0, 0.0, 0.0, 0.2],
        frequency: [2.0; 6],
        phase: [0.0; 6],
        pushes: vec![],
    }
}

#[test]
fn the_same_user_law_holds_the_spatial_dual_ur5() {
    let s = presets::dual_ur5();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y0 = plant
        .initial_state(&s.x_wo, &nalgebra::Vector6::zeros(), &s.q_guess)
        .unwrap();
    let pd = spatial_pd(&plant, &y0);
    let start = SpatialStart {
        x_wo: s.x_wo,
        q_guess: s.q_guess.clone(),
    };
    {
        // One tick by hand on a twin run.
        let mut sim = Simulation::with_plant(
            plant.clone(),
            &start,
            &ideal(),
            spatial_pd(&plant, &y0),
            push(),
            sim_params(2.0, 5e-4),
        )
        .unwrap();
        assert_eq!(
            sim.state(),
            &y0[..],
            "the start is the plant's initial state"
        );
        // The accessor evaluates the wrenches for the state (zero torque held at the start).
        let w0 = sim.grasp_wrenches().unwrap().to_vec();
        assert_eq!(w0.len(), 12);
        sim.tick(0).unwrap();
        // Ideal sensors: the readings are the plant's wrenches in tool axes.
        assert_eq!(sim.last_readings(), sim.last_sensor_truth());
        assert_eq!(
            sim.last_wrenches(),
            &w0[..],
            "tick 0 samples the start's wrenches"
        );
    }
    let sim =
        Simulation::with_plant(plant, &start, &ideal(), pd, push(), sim_params(2.0, 5e-4)).unwrap();
    let (out, sim) = sim.run(|_| {});
    assert!(out.fault.is_none(), "{:?}", out.fault);
    assert_eq!(out.ticks, 2000);
    let log = &out.log;
    let names = log.names();
    let expect_head = [
        "t [s]",
        "x_o.x [m]",
        "x_o.y [m]",
        "x_o.z [m]",
        "x_o.qw [1]",
        "x_o.qx [1]",
        "x_o.qy [1]",
        "x_o.qz [1]",
        "v_o.x [m/s]",
        "v_o.y [m/s]",
        "v_o.z [m/s]",
        "w_o.x [rad/s]",
        "w_o.y [rad/s]",
        "w_o.z [rad/s]",
        "e_max [rad]",
        "tau_q1 [N m]",
    ];
    assert_eq!(names[..16], expect_head);
    for c in [
        "q12 [rad]",
        "qd12 [rad/s]",
        "F1.fx [N]",
        "F2.tz [N m]",
        "F_meas1.fx [N]",
        "F_meas2.tz [N m]",
    ] {
        assert!(names.iter().any(|n| n == c), "{c} missing");
    }
    assert_eq!(
        names[names.len() - 3..],
        ["pd_norm [N m]", "drift [m]", "drift_rot [rad]"]
    );
    assert_eq!(names.len(), 1 + 13 + 1 + 12 + 24 + 12 + 12 + 1 + 2);
    let p0 = s.x_wo.translation.vector;
    let dev = (0..log.len())
        .map(|k| {
            Vector3::new(
                col(log, "x_o.x")[k],
                col(log, "x_o.y")[k],
                col(log, "x_o.z")[k],
            )
            .metric_distance(&p0)
        })
        .fold(0.0f64, f64::max);
    let e_max = col(log, "e_max").iter().fold(0.0f64, |a, b| a.max(*b));
    println!(
        "spatial: max |p_o − p_o(0)| = {dev:.3e} m, max joint error {e_max:.3e} rad, max drift {:.3e} m, {:.3e} rad; wall {:.3} s",
        out.max_drift, out.max_drift_rot, out.wall_time
    );
    assert!(e_max > 0.0, "the push moves the joints");
    // Measured: 2.4e-4 m under the 2 N push (joint errors ≤ 5.3e-4 rad), drift ≤ 1.5e-13 m
    // and 5e-15 rad.
    assert!(dev < 5e-4, "the object left its start by {dev} m");
    assert!(out.max_drift < 1e-9, "drift {}", out.max_drift);
    assert!(
        out.max_drift_rot < 1e-9,
        "rotational drift {}",
        out.max_drift_rot
    );
    // The world-axes grasp wrenches carry the object's weight; the tool-axes readings have
    // the same magnitudes per arm.
    let k = log.len() - 1;
    let fz = col(log, "F1.fz")[k] + col(log, "F2.fz")[k];
    let weight = s.params.object.mass * 9.81;
    assert!(
        (fz + weight).abs() < 1e-3 * weight,
        "ΣF_z = {fz}, weight {weight}"
    );
    for i in 1..=2 {
        let norm = |g: &str, a: [&str; 3]| {
            a.iter()
                .map(|c| col(log, &format!("{g}{i}.{c}"))[k].powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let (fw, fm) = (
            norm("F", ["fx", "fy", "fz"]),
            norm("F_meas", ["fx", "fy", "fz"]),
        );
        assert!(
            (fw - fm).abs() < 1e-9 * fw.max(1.0),
            "arm {i}: {fw} vs {fm}"
        );
    }
    let _ = sim;
}

/// A driver that applies constant torques (optionally a NaN on one joint) and keeps the
/// largest force and torque channel it read.
struct Probe {
    tau: Vec<f64>,
    nan_at: Option<usize>,
    max_f: f64,
    max_t: f64,
}

impl<P: ClosedChain> Drive<P> for Probe {
    type Record = tandem::drive::NoRecord;
    fn new_record(&self) -> Self::Record {
        tandem::drive::NoRecord
    }
    fn start(&mut self, _t0: f64, _meas: &Measurements<'_>) {}
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], _: &mut Self::Record) {
        tau.copy_from_slice(&self.tau);
        if let Some(j) = self.nan_at
            && t >= 0.05
        {
            tau[j] = f64::NAN;
        }
        for (c, v) in meas.wrenches.iter().enumerate() {
            if c % 6 < 3 {
                self.max_f = self.max_f.max(v.abs());
            } else {
                self.max_t = self.max_t.max(v.abs());
            }
        }
    }
}

#[test]
fn spatial_runs_check_health_and_inject_faults() {
    use tandem::sim::faults::Faults;
    use tandem::sim::{FaultKind, Formulation};
    let s = presets::dual_ur5();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y0 = plant
        .initial_state(&s.x_wo, &nalgebra::Vector6::zeros(), &s.q_guess)
        .unwrap();
    let mut hold = vec![0.0; plant.n_q()];
    plant.holding_torques(&y0, &mut plant.workspace(), &mut hold);
    let probe = |nan_at| Probe {
        tau: hold.clone(),
        nan_at,
        max_f: 0.0,
        max_t: 0.0,
    };
    let start = SpatialStart {
        x_wo: s.x_wo,
        q_guess: s.q_guess.clone(),
    };
    let build = |p: SimParams, d: Probe| {
        Simulation::with_plant(
            plant.clone(),
            &start,
            &ideal(),
            d,
            tandem::model::disturbance::SpatialDisturbance::zero(),
            p,
        )
    };
    // The reduced formulation is planar only: an error naming the field.
    let mut p = sim_params(0.5, 5e-4);
    p.formulation = Formulation::Reduced;
    let e = build(p, probe(None))
        .err()
        .expect("reduced must be refused");
    assert!(e.to_string().starts_with("formulation"), "{e}");
    // A drift bound below the round-off stops the run at the first check, with both drifts.
    let mut p = sim_params(0.5, 5e-4);
    p.max_drift = 1e-16;
    let (out, _) = build(p, probe(None)).unwrap().run(|_| {});
    let f = out.fault.expect("drift fault");
    assert!(
        matches!(
            f.kind,
            FaultKind::ConstraintDrift {
                rotation: Some(_),
                ..
            }
        ),
        "{f}"
    );
    assert_eq!(f.x_o.len(), 7, "pose + quaternion");
    assert_eq!(f.q.len(), 12);
    assert!(
        (f.t - 0.01).abs() < 1e-12 && f.to_string().contains(" rad at t = 0.0100 s"),
        "{f}"
    );
    // A non-finite torque is named as its log column, the state is the last good one.
    let (out, _) = build(sim_params(0.5, 5e-4), probe(Some(2)))
        .unwrap()
        .run(|_| {});
    let f = out.fault.expect("non-finite fault");
    assert_eq!(
        f.kind,
        FaultKind::NonFiniteSignal {
            signal: "tau_q3".into()
        }
    );
    assert!(f.x_o.iter().chain(&f.q).all(|v| v.is_finite()));
    // Injected faults act on all six wrist channels: saturation on the three forces only.
    let (_, clean) = build(sim_params(0.2, 5e-4), probe(None))
        .unwrap()
        .run(|_| {});
    let faults = Faults {
        force_limit: Some(5.0),
        force_delay: 0.002,
        ..Faults::default()
    };
    let (out, sat) = build(sim_params(0.2, 5e-4), probe(None))
        .unwrap()
        .with_faults(&faults)
        .unwrap()
        .run(|_| {});
    assert!(out.fault.is_none());
    let (c, d) = (clean.driver(), sat.driver());
    println!(
        "wrist readings: clean max |f| {:.3} N, |τ| {:.3} N m; saturated max |f| {:.3} N, |τ| {:.3} N m",
        c.max_f, c.max_t, d.max_f, d.max_t
    );
    assert!(c.max_f > 5.0, "the clean forces exceed the limit");
    assert_eq!(d.max_f, 5.0);
    assert!(d.max_t > 0.0 && (d.max_t - c.max_t).abs() < 1e-6 * c.max_t);
}

#[test]
fn tandems_controller_is_a_driver_itself() {
    // The planar controller as `D` directly and through the CLI's `Driver` enum: the same run.
    use tandem::control::law::adaptive::NnGains;
    use tandem::control::planar::{Controller, ControllerParams};
    use tandem::reference::planar::path::Path;
    use tandem::sim::Driver;
    let params = presets::paper();
    let ctl = || {
        Controller::new(
            &ControllerParams::paper(Law::Nn(NnGains::tuned())),
            &params,
            Path::paper(),
            2.0,
        )
        .unwrap()
        .0
    };
    let sp = SimParams {
        duration: 2.0,
        ..SimParams::paper()
    };
    let run_a = Simulation::new(
        &params,
        &ideal(),
        ctl(),
        Disturbance::paper(),
        sp.clone(),
        None,
    )
    .unwrap()
    .run(|_| {})
    .0;
    let run_b = Simulation::new(
        &params,
        &ideal(),
        Driver::Controller(Box::new(ctl())),
        Disturbance::paper(),
        sp,
        None,
    )
    .unwrap()
    .run(|_| {})
    .0;
    assert_eq!(run_a.log, run_b.log);
    assert_eq!(run_a.min_margin, run_b.min_margin);
    assert!(run_a.min_margin.is_some_and(|m| m > 0.0));
    assert_eq!(run_a.log.names().len(), 1 + 3 + 27 + 4 + 4 + 4 + 4 + 2 + 1);
}
