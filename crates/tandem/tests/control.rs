//! Closed-loop behaviour of the control laws on the constrained plant (issue: control laws).

use nalgebra::Vector3;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::iblf;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::{Controller, ControllerParams};
use tandem::error::ModelError;
use tandem::model::disturbance::{Disturbance, Push};
use tandem::plant::planar::Plant;
use tandem::presets;
use tandem::reference::planar::admittance::AdmittanceParams;
use tandem::reference::planar::path::Path;
use tandem::report::planar::{Summary, summarize};
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Driver, Log, SimParams, Simulation};

fn params(law: Law<3>) -> ControllerParams {
    ControllerParams::paper(law)
}

fn run(cp: ControllerParams, dist: Disturbance, duration: f64, log_period: f64) -> (Summary, Log) {
    let sp = SimParams {
        duration,
        log_period,
        ..SimParams::paper()
    };
    let name = cp.law.name();
    let (sim, _) = presets::paper_simulation(&cp, sp, dist).unwrap();
    let (out, _) = sim.run(|_| {});
    let s = summarize(&out, name, "", [0.35; 3], 2.0, duration);
    assert!(s.completed, "{name}: run stopped: {:?}", s.fault);
    (s, out.log)
}

#[test]
fn nn_tuned_respects_the_bound_and_settles_within_2_s() {
    let (s, _) = run(
        params(Law::Nn(NnGains::tuned())),
        Disturbance::paper(),
        6.0,
        0.01,
    );
    println!("{s:#?}");
    assert_eq!(s.violations, 0);
    assert_eq!(s.events.barrier_hits, 0);
    assert!(s.min_margin > 0.4, "margin {}", s.min_margin);
    let ts = s.settling_time_1mm.expect("z1 never settled below 1 mm");
    assert!(ts < 2.0, "settling {ts} s");
    // SPEC §3.4 measured RMS z1 after 5 s ≈ 0.05 mm; require < 0.2 mm after 2 s.
    assert!(
        s.rms_z1_after < 2e-4,
        "rms z1 after 2 s = {}",
        s.rms_z1_after
    );
}

/// Run the tuned NN law tick by tick for `ticks` ms (log every tick), calling `each` with the
/// controller's weights after every tick.
fn run_ticks(ticks: usize, mut each: impl FnMut(usize, &[f64])) -> Log {
    let plant = presets::paper();
    let duration = ticks as f64 * 1e-3;
    let (c, _) = Controller::new(
        &params(Law::Nn(NnGains::tuned())),
        &plant,
        Path::paper(),
        duration,
    )
    .unwrap();
    let mut sp = SimParams::paper();
    sp.duration = duration;
    sp.log_period = 1e-3;
    let mut sim = Simulation::new(
        &plant,
        &SensorParams::default(),
        Driver::Controller(Box::new(c)),
        Disturbance::paper(),
        sp,
        None,
    )
    .unwrap();
    for k in 0..ticks {
        sim.tick(k).unwrap();
        if let Driver::Controller(c) = sim.driver() {
            each(k, &c.adaptive().unwrap().weights());
        }
    }
    let (out, _) = sim.run(|_| {});
    out.log
}

#[test]
fn lyapunov_function_decreases_outside_its_ultimate_bound() {
    // V3 (46) = V1 + ½ z2ᵀ𝓜 z2 + ½ Σ_j W̃_jᵀ Θ_j⁻¹ W̃_j along the closed loop, with 𝓜 of the true
    // plant at the pose. The ideal weights W* are unknown; the load along the path changes slowly
    // (0.1 rad/s), so W* is taken as the learnt weights at 1.5 s, after convergence, from an
    // identical (deterministic) first run. Claim (51): V̇3 ≤ −η3 V3 + C3, i.e. V3 decreases while
    // it is above its ultimate level C3/η3.
    let ticks = 1500;
    let mut w_star = Vec::new();
    run_ticks(ticks, |k, w| {
        if k == ticks - 1 {
            w_star = w.to_vec();
        }
    });
    let theta = NnGains::tuned().theta;
    let mut v_w = vec![0.0; ticks];
    // The second run: the log's row k is taken at the start of tick k, before its update, so
    // pair it with the weights after tick k − 1 (zero weights for row 0).
    let mut prev = 0.0;
    for (j, th) in theta.iter().enumerate() {
        prev += 0.5 * w_star.iter().skip(j).step_by(3).map(|w| w * w).sum::<f64>() / th;
    }
    let log = run_ticks(ticks, |k, w| {
        v_w[k] = prev;
        let mut s = 0.0;
        for (i, (a, b)) in w.iter().zip(&w_star).enumerate() {
            s += 0.5 * (a - b) * (a - b) / theta[i % 3];
        }
        prev = s;
    });
    let plant = Plant::new(&presets::paper()).unwrap();
    let mut ws = plant.workspace();
    let ax = ["x", "y", "theta"];
    let mut cols: Vec<Vec<f64>> = Vec::new();
    for g in ["x_hat", "z1", "x_r", "z2"] {
        for a in ax {
            cols.push(log.get(&format!("{g}.{a}")).unwrap().to_vec());
        }
    }
    let n = ticks;
    let mut v3 = vec![0.0; n];
    for k in 0..n {
        let x = Vector3::new(cols[0][k], cols[1][k], cols[2][k]);
        let z2 = Vector3::new(cols[9][k], cols[10][k], cols[11][k]);
        let v1: f64 = (0..3)
            .map(|j| iblf::v1(cols[3 + j][k], cols[6 + j][k], 0.35))
            .sum();
        let m = plant
            .object_space(&x, &Vector3::zeros(), &mut ws)
            .unwrap()
            .M;
        v3[k] = v1 + 0.5 * z2.dot(&(m * z2)) + v_w[k];
    }
    let ultimate = v3[n - 200..].iter().cloned().fold(0.0, f64::max);
    println!(
        "V3(0) = {:.3e}, V3(0.5 s) = {:.3e}, level over the last 0.2 s {:.3e}",
        v3[0], v3[500], ultimate
    );
    assert!(
        v3[0] > 100.0 * ultimate,
        "V3 should fall by two orders of magnitude"
    );
    let first_rise = (1..n).find(|&k| v3[k] >= v3[k - 1]).unwrap_or(n);
    println!(
        "first rise at {first_rise} ms, V3 there {:.3e} = {:.1}× the final level",
        v3[first_rise - 1],
        v3[first_rise - 1] / ultimate
    );
    // The ultimate level C3/η3 is not computable (W* is not constant: the load varies along the
    // path, and the ZOH, admittance and disturbance add terms); 20× the final level is used.
    let mut checked = 0;
    for k in 1..n {
        if v3[k - 1] > 20.0 * ultimate {
            assert!(
                v3[k] < v3[k - 1],
                "V3 rose at t = {k} ms: {} -> {}",
                v3[k - 1],
                v3[k]
            );
            checked += 1;
        }
    }
    println!("V3 decreased on all {checked} steps above 20× its final level");
    assert!(checked > 10);
}

#[test]
fn a_push_makes_the_reference_comply_and_return() {
    // SPEC §3.1: two arms in parallel comply about push/(2 K_e); a 2 N push for 2 s moved x_r by
    // 1.05 mm (the second-order response has not fully settled at 2 s: e(2 s) = 1.046 mm).
    let mut d = Disturbance::paper();
    d.pushes.push(Push {
        t0: 3.0,
        duration: 2.0,
        wrench: [2.0, 0.0, 0.0],
    });
    for law in [Law::Nn(NnGains::tuned()), Law::Pd(PdGains::<3>::paper())] {
        let name = law.name();
        let (_, log) = run(params(law), d.clone(), 12.0, 0.01);
        let t = log.get("t").unwrap();
        let off: Vec<f64> = log
            .get("x_r.x")
            .unwrap()
            .iter()
            .zip(log.get("x_d.x").unwrap())
            .map(|(a, b)| a - b)
            .collect();
        let at = |s: f64| off[t.iter().position(|&x| x >= s - 1e-9).unwrap()];
        let before = at(2.99);
        let peak = off.iter().cloned().fold(f64::MIN, f64::max);
        println!(
            "{name}: offset before {:.2e} m, peak {:.4e} m, at 12 s {:.2e} m",
            before,
            peak,
            at(11.99)
        );
        assert!(
            before.abs() < 5e-5,
            "{name}: offset before the push {before}"
        );
        assert!(
            (peak - 1.0e-3).abs() < 0.15e-3,
            "{name}: peak compliance {peak} m, expected ≈ 1 mm"
        );
        assert!(
            at(11.99).abs() < 2e-5,
            "{name}: did not return ({} m)",
            at(11.99)
        );
    }
}

#[test]
fn pd_tracks_with_more_vibration_and_a_larger_wrench() {
    let (nn, _) = run(
        params(Law::Nn(NnGains::tuned())),
        Disturbance::paper(),
        6.0,
        0.03,
    );
    let (pd, _) = run(
        params(Law::Pd(PdGains::<3>::paper())),
        Disturbance::paper(),
        6.0,
        0.03,
    );
    println!(
        "NN: rms z1 {:.2e} rough {:.3} peak {:.2}; PD: rms z1 {:.2e} rough {:.3} peak {:.2}",
        nn.rms_z1_after,
        nn.wrench_roughness,
        nn.peak_wrench,
        pd.rms_z1_after,
        pd.wrench_roughness,
        pd.peak_wrench
    );
    assert_eq!(pd.violations, 0);
    assert!(pd.rms_z1_after > 10.0 * nn.rms_z1_after);
    assert!(pd.wrench_roughness > nn.wrench_roughness);
    assert!(pd.peak_wrench >= nn.peak_wrench);
}

#[test]
fn paper_gains_stay_bounded_but_chatter() {
    // SPEC §3.4: with the paper's gains z1 is small and the bound holds, but z2 chatters in a
    // limit cycle and the wrench is larger than PD's.
    let (paper, log) = run(
        params(Law::Nn(NnGains::paper())),
        Disturbance::paper(),
        4.0,
        0.001,
    );
    let (tuned, _) = run(
        params(Law::Nn(NnGains::tuned())),
        Disturbance::paper(),
        4.0,
        0.001,
    );
    let z2 = log.get("z2.x").unwrap();
    let rms_z2 = (z2[2000..].iter().map(|v| v * v).sum::<f64>() / (z2.len() - 2000) as f64).sqrt();
    println!(
        "paper gains: rms z2.x after 2 s {rms_z2:.3e} m/s, roughness {:.1} vs tuned {:.2}",
        paper.wrench_roughness, tuned.wrench_roughness
    );
    assert_eq!(paper.violations, 0);
    println!(
        "paper gains: max z1 after 2 s {:.3e}, rms {:.3e}",
        paper.max_z1_after, paper.rms_z1_after
    );
    // The limit cycle is chaotic: round-off-level changes anywhere in the loop move its peaks
    // (max |z1| after 2 s has been measured at 0.6–1.1 mm), so the claim is checked on the RMS,
    // with the peak bounded loosely.
    assert!(paper.rms_z1_after < 1e-3);
    assert!(paper.max_z1_after < 3e-3);
    assert!(rms_z2 > 0.005, "expected chattering z2, rms {rms_z2}");
    assert!(paper.wrench_roughness > 10.0 * tuned.wrench_roughness);
}

fn err_of(cp: ControllerParams) -> String {
    match Controller::new(&cp, &presets::paper(), Path::paper(), 90.0) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("accepted bad parameters"),
    }
}

#[test]
fn gains_that_break_the_theory_are_named() {
    let nn = |f: &dyn Fn(&mut NnGains<3>)| {
        let mut g = NnGains::tuned();
        f(&mut g);
        params(Law::Nn(g))
    };
    let e = err_of(nn(&|g| g.k1[0] = 0.0));
    assert!(e.contains("gains.k1[0]"), "{e}");
    let e = err_of(nn(&|g| g.k2[1] = -1.0));
    assert!(e.contains("gains.k2[1]"), "{e}");
    let e = err_of(nn(&|g| g.theta[2] = 0.0));
    assert!(e.contains("gains.theta[2]"), "{e}");
    let e = err_of(nn(&|g| g.sigma[0] = 0.0));
    assert!(e.contains("gains.sigma[0]"), "{e}");
    let e = err_of(nn(&|g| g.omega = 0.5));
    assert!(e.contains("omega"), "{e}");
    let e = err_of(nn(&|g| g.d1 = 2.0));
    assert!(e.contains("d1"), "{e}");
    // k_c not above the path's reach (the circle reaches 0.2 m).
    let mut cp = params(Law::Pd(PdGains::<3>::paper()));
    cp.k_c = [0.15, 0.35, 0.35];
    let e = err_of(cp);
    assert!(
        e.contains("k_c[0]") && e.contains("max |x_d,0| = 0.2000 m"),
        "{e}"
    );
    // A path the arms cannot follow: a 0.25 m circle centred at (0.1, 0) passes 0.6 m from the
    // left arm's base at (−0.38, 0).
    let wide = Path::circle(nalgebra::Vector2::new(0.1, 0.0), 0.25, 0.1, 0.0, 0.0).unwrap();
    let mut cp = params(Law::Pd(PdGains::<3>::paper()));
    cp.k_c = [0.36, 0.36, 0.35];
    let e = Controller::new(&cp, &presets::paper(), wide, 90.0)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("path") && e.contains("arms[0]") && e.contains("t = "),
        "{e}"
    );
    // A path that starts outside the bound.
    // (a 0.1 m circle about (0, 0.3) starting at its top, (0, 0.4): reachable, above k_c = 0.35)
    let path = Path::circle(
        nalgebra::Vector2::new(0.0, 0.3),
        0.1,
        0.1,
        std::f64::consts::FRAC_PI_2,
        0.0,
    )
    .unwrap();
    let e = Controller::new(
        &params(Law::Pd(PdGains::<3>::paper())),
        &presets::paper(),
        path,
        10.0,
    )
    .err()
    .unwrap();
    assert!(
        matches!(e, ModelError::Invalid { ref param, .. } if param == "k_c[1]"),
        "{e}"
    );
}

#[test]
fn the_papers_first_order_admittance_is_allowed_but_warned() {
    let mut cp = params(Law::Pd(PdGains::<3>::paper()));
    cp.admittance = Some(AdmittanceParams::paper_first_order(626.0, 1000.0));
    let (_, w) = Controller::new(&cp, &presets::paper(), Path::paper(), 10.0).unwrap();
    assert!(!w.is_empty());
    let msg = w[0].to_string();
    println!("{msg}");
    assert!(
        msg.to_lowercase().contains("first-order") || msg.to_lowercase().contains("first order"),
        "{msg}"
    );
}

#[test]
fn both_laws_are_stable_with_and_without_the_admittance() {
    for adm in [true, false] {
        for law in [
            Law::Nn(NnGains::tuned()),
            Law::Pd(PdGains::<3>::paper()),
            Law::Ctc(Default::default()),
        ] {
            let name = law.name();
            let mut cp = params(law);
            if !adm {
                cp.admittance = None;
            }
            let (s, _) = run(cp, Disturbance::paper(), 4.0, 0.03);
            assert_eq!(s.violations, 0, "{name} adm={adm}");
            assert!(
                s.max_z1_after < 0.02,
                "{name} adm={adm}: max z1 after 2 s = {}",
                s.max_z1_after
            );
        }
    }
}

#[test]
fn per_arm_scheme_tracks_with_both_laws() {
    use tandem::control::Scheme;
    let mut results = Vec::new();
    for law in [Law::Nn(NnGains::tuned()), Law::Pd(PdGains::<3>::paper())] {
        let name = law.name();
        let mut cp = params(law);
        cp.scheme = Scheme::PerArm;
        let (s, _) = run(cp, Disturbance::paper(), 6.0, 0.03);
        println!(
            "per-arm {name}: rms z1 after 2 s {:.2e} m, peak wrench {:.1} N, grasp forces {:?}",
            s.rms_z1_after, s.peak_wrench, s.grasp_force_range
        );
        assert_eq!(s.violations, 0, "{name}");
        assert!(
            s.max_z1_after < 5e-3,
            "{name}: max z1 after 2 s {}",
            s.max_z1_after
        );
        results.push(s);
    }
    // The adaptive law learns what PD leaves as a steady error (gravity, internal force).
    assert!(results[0].rms_z1_after < 0.5 * results[1].rms_z1_after);
    // Computed torque is object-scheme only: a clear error.
    let mut cp = params(Law::Ctc(Default::default()));
    cp.scheme = Scheme::PerArm;
    assert!(err_of(cp).contains("object scheme"));
}

#[test]
fn the_internal_force_is_the_commanded_squeeze() {
    // Object scheme: K_e δ = 1000 × 0.005 = 5 N, commanded in the null space of 𝐉ᵀ, with the
    // arms' own gravity's internal part fed forward (otherwise it adds 2–7 N along the paper's
    // path). The squeeze along the grasp axis is (F2.x − F1.x)/2 for the paper's grasps at θ ≈ 0.
    // Per-arm scheme: the offsets δ squeeze through the per-arm law in series with the
    // admittance spring, K_P K_e δ/(K_P + K_e) = 4.17 N for PD, plus the arms' uncompensated
    // internal gravity (measured 4.5–5.0 N; before the fix it squeezed twice, 9.7 N).
    use tandem::control::Scheme;
    for (law, scheme, lo, hi) in [
        (Law::Nn(NnGains::tuned()), Scheme::Object, 4.9, 5.1),
        (Law::Pd(PdGains::<3>::paper()), Scheme::Object, 4.9, 5.1),
        (Law::Pd(PdGains::<3>::paper()), Scheme::PerArm, 3.5, 5.5),
    ] {
        let name = format!("{} {scheme:?}", law.name());
        let mut cp = params(law);
        cp.scheme = scheme;
        let (_, log) = run(cp, Disturbance::paper(), 10.0, 0.01);
        let (f1, f2) = (log.get("F1.x").unwrap(), log.get("F2.x").unwrap());
        let s: Vec<f64> = f1
            .iter()
            .zip(f2)
            .skip(200)
            .map(|(a, b)| (b - a) / 2.0)
            .collect();
        let (min, max) = (
            s.iter().cloned().fold(f64::MAX, f64::min),
            s.iter().cloned().fold(f64::MIN, f64::max),
        );
        println!("{name}: internal force {min:.2} … {max:.2} N");
        assert!(
            min > lo && max < hi,
            "{name}: internal force {min:.2} … {max:.2} N"
        );
    }
}

#[test]
fn redundant_arms_carry_the_object_with_a_damped_self_motion() {
    // Two 3-link arms, PD on the object; the law fixes the end-effectors, the null-space term
    // damps the self-motion and compensates its gravity. The joint angles must settle (log rows
    // 5 s apart differ by < 1 mrad once the object tracks) and the object must track.
    let (plant, guess) = presets::redundant_pair();
    let (c, _) = Controller::new(
        &params(Law::Pd(PdGains::<3>::paper())),
        &plant,
        Path::paper(),
        10.0,
    )
    .unwrap();
    let mut sp = SimParams::paper();
    sp.duration = 10.0;
    sp.log_period = 0.01;
    let sim = Simulation::new(
        &plant,
        &SensorParams::default(),
        Driver::Controller(Box::new(c)),
        Disturbance::paper(),
        sp,
        Some(&guess),
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    assert!(out.fault.is_none(), "{:?}", out.fault);
    let s = summarize(&out, "pd", "", [0.35; 3], 2.0, 10.0);
    println!(
        "3-link PD: max z1 after 2 s {:.2e} m, peak joint torque {:.1} N m",
        s.max_z1_after, s.peak_joint_torque
    );
    assert!(s.max_z1_after < 0.012, "max z1 {}", s.max_z1_after);
    // Self-motion settles: the joint velocity's component in the null space of J_e (by central
    // differences of the logged angles, 10 ms apart) is small after 5 s.
    let model = Plant::new(&plant).unwrap();
    let t = out.log.get("t").unwrap();
    let q: Vec<&[f64]> = (1..=6)
        .map(|j| out.log.get(&format!("q{j}")).unwrap())
        .collect();
    let mut worst: f64 = 0.0;
    for k in (t.iter().position(|&x| x >= 5.0).unwrap()..t.len() - 1).step_by(10) {
        for (i, arm) in model.arms().iter().enumerate() {
            let qi: Vec<f64> = (0..3).map(|j| q[3 * i + j][k]).collect();
            let qd: Vec<f64> = (0..3)
                .map(|j| (q[3 * i + j][k + 1] - q[3 * i + j][k - 1]) / (t[k + 1] - t[k - 1]))
                .collect();
            let mut terms = arm.terms();
            arm.kinematics(&qi, &qd, &mut terms);
            let j = &terms.J;
            let qdv = nalgebra::DVector::from_column_slice(&qd);
            let jjt = j * j.transpose();
            let w = jjt.try_inverse().unwrap() * (j * &qdv);
            let null = &qdv - j.transpose() * w;
            worst = worst.max(null.norm());
        }
    }
    println!("3-link PD: largest null-space joint speed after 5 s {worst:.2e} rad/s");
    assert!(worst < 0.01, "self-motion not damped: {worst} rad/s");
}

#[test]
fn the_papers_nn_gains_are_allowed_but_warned() {
    let (_, w) = Controller::new(
        &params(Law::Nn(NnGains::paper())),
        &presets::paper(),
        Path::paper(),
        90.0,
    )
    .unwrap();
    for x in &w {
        println!("{x}");
    }
    assert_eq!(w.len(), 3, "one warning per axis: {w:?}");
    assert!(w[1].to_string().contains("gains.k2[1]") && w[1].to_string().contains("limit cycle"));
    let (_, w) = Controller::new(
        &params(Law::Nn(NnGains::tuned())),
        &presets::paper(),
        Path::paper(),
        90.0,
    )
    .unwrap();
    assert!(w.is_empty(), "{w:?}");
}

#[test]
fn pd_gravity_compensation_holds_the_arms_and_object_still() {
    // PD with gravity compensation (SPEC §3.5 plus the model's 𝓖 of (14)): at rest on the
    // desired pose with zero error, the controller's model equal to the plant, it commands 𝓖
    // (distributed, with the arms' internal gravity part), so every acceleration of the constrained plant
    // (joints and object) vanishes to round-off; the paper's plain PD commands no gravity and
    // the object falls at about g. Then 1 s closed loop from there: compensated, the object
    // stays put (measured 5e-16 m); plain PD sags by about 𝓖/K_P (6.8 mm). Without the
    // admittance (and so without squeeze): its force filter would take in the first tick's
    // grasp forces (those of the torques before the first command) and move the reference.
    use tandem::control::planar::TickRecord;
    use tandem::drive::Measurements;
    use tandem::plant::planar::{PlantInput, PlantParams};
    let model = PlantParams::paper();
    let plant = Plant::new(&model).unwrap();
    let p0 = presets::paper_start();
    let path = Path::point_to_point(p0, p0, 0.0, 1.0).unwrap();
    let y = plant.initial_state(p0, Vector3::zeros(), None).unwrap();
    let n = plant.n_q();
    let forces = vec![0.0; 2 * plant.arms().len()];
    let meas = Measurements {
        q: &y[..n],
        qd: &y[n + 3..2 * n + 3],
        wrenches: &forces,
    };
    for compensate in [false, true] {
        let mut cp = params(Law::Pd(PdGains {
            gravity_compensation: compensate,
            ..PdGains::<3>::paper()
        }));
        cp.disturbance_bound = [0.0; 3];
        cp.admittance = None;
        let (mut c, _) = Controller::new(&cp, &model, path.clone(), 1.0).unwrap();
        c.start(0.0, &meas);
        let (mut tau, mut rec) = (vec![0.0; n], TickRecord::default());
        c.tick(0.0, &meas, &mut tau, &mut rec);
        assert!(rec.z1.norm() < 1e-12, "z1 = {}", rec.z1);
        let mut ws = plant.workspace();
        let mut dy = vec![0.0; y.len()];
        let input = PlantInput {
            tau: tau.clone(),
            f_d: Vector3::zeros(),
        };
        assert!(plant.derivative(&y, &input, &mut ws, &mut dy));
        // dy = [q̇, ẋ_o, q̈, ẍ_o]: the accelerations.
        let acc = dy[n + 3..].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        // Closed loop, 1 s, no disturbance, ideal sensors.
        let sp = SimParams {
            duration: 1.0,
            log_period: 0.01,
            start: [p0.x, p0.y, p0.z],
            ..SimParams::paper()
        };
        let sim = Simulation::new(
            &model,
            &SensorParams::default(),
            Driver::Controller(Box::new(c)),
            Disturbance::none(),
            sp,
            None,
        )
        .unwrap();
        let (out, _) = sim.run(|_| {});
        let sag = ["x_o.x", "x_o.y", "x_o.theta"]
            .iter()
            .enumerate()
            .flat_map(|(j, c)| {
                out.log
                    .get(c)
                    .unwrap()
                    .iter()
                    .map(move |v| (v - p0[j]).abs())
            })
            .fold(0.0_f64, f64::max);
        println!(
            "gravity compensation {compensate}: torques {tau:.4?} N m, largest acceleration {acc:.3e}, largest pose error over 1 s {sag:.3e}"
        );
        if compensate {
            assert!(acc < 1e-10, "accelerations up to {acc:e}");
            assert!(sag < 1e-12, "moved by {sag:e}");
        } else {
            assert!(acc > 1.0, "plain PD: accelerations up to {acc:e}");
            assert!(sag > 1e-3, "plain PD: sagged by {sag:e} only");
        }
    }
    // Where the reduced model (14) does not apply, it is refused by name.
    let gc = Law::Pd(PdGains {
        gravity_compensation: true,
        ..PdGains::<3>::paper()
    });
    let mut cp = params(gc.clone());
    cp.scheme = tandem::control::Scheme::PerArm;
    let e = err_of(cp);
    assert!(e.contains("gains.gravity_compensation"), "{e}");
    let (redundant, _) = presets::redundant_pair();
    let e = Controller::new(&params(gc), &redundant, Path::paper(), 1.0)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("arms[0]") && e.contains("2-link"), "{e}");
}
