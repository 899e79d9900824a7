//! The simulation loop: determinism, replay, faults reported with time and state, bad settings.

use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::{Controller, ControllerParams};
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::reference::planar::path::Path;
use tandem::report::planar::summarize;
use tandem::sim::sensors::{ChannelNoise, SensorParams};
use tandem::sim::{Driver, FaultKind, Formulation, Outcome, Replay, SimParams, Simulation};

fn controller(law: Law<3>, duration: f64) -> Driver {
    let cp = ControllerParams::paper(law);
    Driver::Controller(Box::new(
        Controller::new(&cp, &presets::paper(), Path::paper(), duration)
            .unwrap()
            .0,
    ))
}

fn sim(
    driver: Driver,
    sensors: &SensorParams,
    duration: f64,
    log_period: f64,
    f: Formulation,
) -> Outcome {
    let mut sp = SimParams::paper();
    sp.duration = duration;
    sp.log_period = log_period;
    sp.formulation = f;
    Simulation::new(
        &presets::paper(),
        sensors,
        driver,
        Disturbance::paper(),
        sp,
        None,
    )
    .unwrap()
    .run(|_| {})
    .0
}

fn noisy() -> SensorParams {
    let n = ChannelNoise {
        std_dev: 2e-5,
        bias: 0.0,
        tau: 0.0,
        dropout: 0.01,
    };
    SensorParams {
        encoder_q: n,
        encoder_qd: ChannelNoise { std_dev: 1e-3, ..n },
        force: ChannelNoise {
            std_dev: 0.05,
            tau: 0.002,
            ..n
        },
        seed: 42,
        ..Default::default()
    }
}

#[test]
fn same_seed_gives_bitwise_identical_logs() {
    let a = sim(
        controller(Law::Nn(NnGains::tuned()), 2.0),
        &noisy(),
        2.0,
        0.01,
        Formulation::Constrained,
    );
    let b = sim(
        controller(Law::Nn(NnGains::tuned()), 2.0),
        &noisy(),
        2.0,
        0.01,
        Formulation::Constrained,
    );
    assert!(a.fault.is_none());
    assert_eq!(a.log, b.log);
    let mut other = noisy();
    other.seed = 43;
    let c = sim(
        controller(Law::Nn(NnGains::tuned()), 2.0),
        &other,
        2.0,
        0.01,
        Formulation::Constrained,
    );
    assert_ne!(a.log, c.log);
}

#[test]
fn replaying_logged_torques_reproduces_the_run() {
    // Log every tick, replay the joint torques open loop: same held inputs ⇒ the same motion.
    let run = sim(
        controller(Law::Pd(PdGains::<3>::paper()), 2.0),
        &SensorParams::default(),
        2.0,
        1e-3,
        Formulation::Constrained,
    );
    let t = run.log.get("t").unwrap().to_vec();
    let rows: Vec<Vec<f64>> = (0..t.len())
        .map(|k| {
            (1..=4)
                .map(|j| run.log.get(&format!("tau_q{j}")).unwrap()[k])
                .collect()
        })
        .collect();
    let replay = Replay::new(t, rows, 4).unwrap();
    let again = sim(
        Driver::Replay(replay),
        &SensorParams::default(),
        2.0,
        1e-3,
        Formulation::Constrained,
    );
    let mut worst: f64 = 0.0;
    for c in ["x_o.x", "x_o.y", "x_o.theta"] {
        for (a, b) in run
            .log
            .get(c)
            .unwrap()
            .iter()
            .zip(again.log.get(c).unwrap())
        {
            worst = worst.max((a - b).abs());
        }
    }
    println!("replay reproduces x_o to {worst:.2e}");
    assert!(worst == 0.0, "replay differs by {worst}");
}

/// Issue 22, "replay real logs": a simulator's accumulated 1 kHz clock stamps rows a rounding
/// unit or so off the tick (`0.001 + 0.001 + …`). The library's replay snaps them onto the
/// control grid when the loop hands it the control period, so the replay is still the run, bit
/// for bit; compared exactly, a third of the rows would apply a tick late.
#[test]
fn replay_of_a_log_stamped_by_an_accumulated_clock_is_on_time() {
    let run = sim(
        controller(Law::Pd(PdGains::<3>::paper()), 1.0),
        &SensorParams::default(),
        1.0,
        1e-3,
        Formulation::Constrained,
    );
    let n = run.log.get("t").unwrap().len();
    // The clock a simulator keeps: t += dt.
    let mut clock = Vec::with_capacity(n);
    let mut t = 0.0f64;
    for _ in 0..n {
        clock.push(t);
        t += 1e-3;
    }
    let exact: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
    let late = clock.iter().zip(&exact).filter(|(c, e)| c > e).count();
    assert!(
        late > n / 10,
        "the accumulated clock runs ahead on only {late} of {n} rows"
    );
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            (1..=4)
                .map(|j| run.log.get(&format!("tau_q{j}")).unwrap()[k])
                .collect()
        })
        .collect();
    // Compared exactly (no control period given), a row a rounding unit late is held a tick late.
    let mut raw = Replay::new(clock.clone(), rows.clone(), 4).unwrap();
    let k = (0..n).find(|&k| clock[k] > exact[k]).unwrap();
    assert_eq!(raw.at(exact[k]), rows[k - 1].as_slice());
    // Snapped: every stamp is its tick, and the row applies on time.
    let mut snapped = Replay::new(clock.clone(), rows.clone(), 4).unwrap();
    snapped.snap_to_grid(1e-3);
    assert_eq!(snapped.times(), exact.as_slice());
    assert_eq!(snapped.at(exact[k]), rows[k].as_slice());
    // And through the loop, which snaps by itself: the replay is the run.
    let again = sim(
        Driver::Replay(Replay::new(clock, rows, 4).unwrap()),
        &SensorParams::default(),
        1.0,
        1e-3,
        Formulation::Constrained,
    );
    for c in ["x_o.x", "x_o.y", "x_o.theta"] {
        assert_eq!(run.log.get(c).unwrap(), again.log.get(c).unwrap(), "{c}");
    }
}

#[test]
fn reduced_and_constrained_plants_give_the_same_closed_loop_metrics() {
    let a = sim(
        controller(Law::Nn(NnGains::tuned()), 3.0),
        &SensorParams::default(),
        3.0,
        0.01,
        Formulation::Constrained,
    );
    let b = sim(
        controller(Law::Nn(NnGains::tuned()), 3.0),
        &SensorParams::default(),
        3.0,
        0.01,
        Formulation::Reduced,
    );
    let sa = summarize(&a, "nn", "", [0.35; 3], 1.0, 3.0);
    let sb = summarize(&b, "nn", "", [0.35; 3], 1.0, 3.0);
    println!(
        "rms z1 after 1 s: constrained {:.4e}, reduced {:.4e}",
        sa.rms_z1_after, sb.rms_z1_after
    );
    assert!(sa.completed && sb.completed);
    assert!((sa.rms_z1_after - sb.rms_z1_after).abs() < 1e-3 * sa.rms_z1_after + 1e-9);
    let xa = a.log.get("x_o.x").unwrap();
    let xb = b.log.get("x_o.x").unwrap();
    let d = xa
        .iter()
        .zip(xb)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    println!("max |Δx| = {d:.2e} m");
    assert!(d < 1e-8, "closed-loop trajectories differ by {d}");
}

#[test]
fn a_violent_run_stops_with_a_fault_that_names_time_and_state() {
    // Constant large torques fold the arms: the run must stop cleanly, the log must hold only
    // finite rows, and the fault must carry the time and a finite last good state.
    let replay = Replay::new(vec![0.0], vec![vec![40.0, -40.0, 40.0, 40.0]], 4).unwrap();
    let out = sim(
        Driver::Replay(replay),
        &SensorParams::default(),
        5.0,
        0.001,
        Formulation::Constrained,
    );
    let f = out.fault.clone().expect("expected a fault");
    println!("{f}");
    assert!(f.t > 0.0 && f.t < 5.0);
    assert!(matches!(
        f.kind,
        FaultKind::Singular { .. } | FaultKind::ConstraintDrift { .. } | FaultKind::NonFinite
    ));
    assert!(f.x_o.iter().chain(f.q.iter()).all(|v| v.is_finite()));
    for c in &out.log.columns {
        assert!(
            c.data.iter().all(|v| v.is_finite()),
            "non-finite value in column {}",
            c.name
        );
    }
    let s = summarize(&out, "replay", "", [0.35; 3], 1.0, 5.0);
    assert!(!s.completed);
}

#[test]
fn bad_periods_are_named() {
    let err = |edit: &dyn Fn(&mut SimParams)| {
        let mut sp = SimParams::paper();
        edit(&mut sp);
        let driver = controller(Law::Pd(PdGains::<3>::paper()), 90.0);
        match Simulation::new(
            &presets::paper(),
            &SensorParams::default(),
            driver,
            Disturbance::paper(),
            sp,
            None,
        ) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("accepted bad settings"),
        }
    };
    let e = err(&|sp| sp.plant_step = 0.3e-3);
    assert!(
        e.contains("control_period") && e.contains("plant_step"),
        "{e}"
    );
    let e = err(&|sp| sp.log_period = 0.0015);
    assert!(e.contains("log_period"), "{e}");
    let e = err(&|sp| sp.start = [0.6, 0.0, 0.0]);
    assert!(e.contains("arms[0]") && e.contains("reaches"), "{e}");
}

#[test]
fn bound_violations_are_counted_every_tick_not_only_on_logged_rows() {
    // PD without gravity compensation, with a bound just above the path's x reach: the object
    // overshoots it. With a log row only every 0.5 s, the per-tick count must see more.
    let cp = ControllerParams {
        k_c: [0.201, 0.35, 0.35],
        ..ControllerParams::paper(Law::Pd(PdGains::<3>::paper()))
    };
    let (c, _) = Controller::new(&cp, &presets::paper(), Path::paper(), 70.0).unwrap();
    let mut sp = SimParams::paper();
    sp.duration = 70.0;
    sp.log_period = 0.5;
    let sim = Simulation::new(
        &presets::paper(),
        &SensorParams::default(),
        Driver::Controller(Box::new(c)),
        Disturbance::paper(),
        sp,
        None,
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    let s = summarize(&out, "pd", "", cp.k_c, 5.0, 70.0);
    let x = out.log.get("x_o.x").unwrap();
    let rows = x.iter().filter(|v| v.abs() >= 0.201).count();
    println!(
        "violations: {} ticks, {rows} logged rows; min margin {:.4}",
        s.violations, s.min_margin
    );
    assert!(
        s.violations > 10 * rows.max(1),
        "{} ticks vs {rows} rows",
        s.violations
    );
    assert!(s.min_margin < 0.0);
}
