//! The spatial cooperative controller (SPEC-spatial S5): the iBLF on six outputs, the
//! controller's set-up checks, and the closed loop on two UR5-class and two Franka-class arms
//! along the SPEC-spatial S6 path.

use nalgebra::{SVector, Vector6};
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::iblf::{Iblf, v1};
use tandem::control::law::pd::PdGains;

/// Six smooth signals: `x_r,j(t)` and `z_j(t)` as sums of sines well inside the bounds.
struct Smooth6 {
    a: [[f64; 3]; 6],
    w: [[f64; 3]; 6],
    c: [f64; 6],
}

impl Smooth6 {
    fn x(&self, j: usize, t: f64) -> f64 {
        self.c[j]
            + (0..3)
                .map(|i| self.a[j][i] * (self.w[j][i] * t + i as f64).sin())
                .sum::<f64>()
    }
    fn v(&self, j: usize, t: f64) -> f64 {
        (0..3)
            .map(|i| self.a[j][i] * self.w[j][i] * (self.w[j][i] * t + i as f64).cos())
            .sum()
    }
    fn a(&self, j: usize, t: f64) -> f64 {
        (0..3)
            .map(|i| {
                -self.a[j][i] * self.w[j][i] * self.w[j][i] * (self.w[j][i] * t + i as f64).sin()
            })
            .sum()
    }
}

/// `d/dt f` by the 4th-order central difference.
fn d4(f: &dyn Fn(f64) -> f64, t: f64, h: f64) -> f64 {
    (f(t - 2.0 * h) - 8.0 * f(t - h) + 8.0 * f(t + h) - f(t + 2.0 * h)) / (12.0 * h)
}

#[test]
fn v1_derivative_is_32_on_six_outputs() {
    // V1 = Σ_j V1_j(z_j, x_r,j) (27) along smooth x_r(t), x_1(t) on the S6 bounds; its time
    // derivative by finite differences equals (32) summed over the six outputs, with α and
    // g(x_1) from the controller's Iblf<6> (not the free functions).
    let k = [0.167, 0.167, 0.1, 0.29, 0.29, 0.29];
    let kappa = [8.0, 8.0, 8.0, 6.0, 10.0, 12.0];
    let iblf = Iblf::<6>::new(SVector::from(k), SVector::from(kappa)).unwrap();
    let xr = Smooth6 {
        a: std::array::from_fn(|j| [0.2 * k[j], 0.1 * k[j], 0.05 * k[j]]),
        w: std::array::from_fn(|j| [0.7 + 0.1 * j as f64, 1.9, 3.1]),
        c: std::array::from_fn(|j| 0.2 * k[j] * if j % 2 == 0 { 1.0 } else { -1.0 }),
    };
    let z = Smooth6 {
        a: std::array::from_fn(|j| [0.15 * k[j], 0.1 * k[j], 0.05 * k[j]]),
        w: std::array::from_fn(|j| [1.3, 2.3 + 0.2 * j as f64, 5.0]),
        c: [0.0; 6],
    };
    let v_total = |t: f64| (0..6).map(|j| v1(z.x(j, t), xr.x(j, t), k[j])).sum::<f64>();
    let mut worst: f64 = 0.0;
    for i in 0..200 {
        let t = 0.05 * i as f64;
        let x_r = Vector6::from_fn(|j, _| xr.x(j, t));
        let xd_r = Vector6::from_fn(|j, _| xr.v(j, t));
        let xdd_r = Vector6::from_fn(|j, _| xr.a(j, t));
        let z1 = Vector6::from_fn(|j, _| z.x(j, t));
        let x1 = x_r + z1;
        let x2 = xd_r + Vector6::from_fn(|j, _| z.v(j, t));
        let ev = iblf.eval(&x1, &x2, &x_r, &xd_r, &xdd_r);
        assert!(!ev.any_saturated());
        let z2 = ev.z2(&x2);
        let v32: f64 = (0..6)
            .map(|j| -kappa[j] * ev.gain[j] * z1[j] * z1[j] + ev.gain[j] * z1[j] * z2[j])
            .sum();
        let fd = d4(&v_total, t, 1e-3);
        let scale: f64 = (0..6)
            .map(|j| ev.gain[j] * z1[j].abs() * (kappa[j] * z1[j].abs() + z2[j].abs()))
            .sum::<f64>()
            + 1e-15;
        let rel = (fd - v32).abs() / scale;
        worst = worst.max(rel);
        // 4th-order FD at h = 1 ms on signals up to 5 rad/s: truncation ≈ (5e-3)^4/30 ≈ 2e-11
        // of the derivative's scale; round-off ≈ 1e-16 · V1/h ≪ that.
        assert!(rel < 1e-8, "t = {t}: fd {fd} vs (32) {v32} (rel {rel:.2e})");
    }
    eprintln!("V̇1 on six outputs: max relative |FD − (32)| = {worst:.2e}");
}

// ---- closed loop -------------------------------------------------------------------------

use nalgebra::{Isometry3, Translation3, Vector3};
use tandem::control::Scheme;
use tandem::control::spatial::{SpatialController, SpatialControllerParams};
use tandem::model::disturbance::{Push, SpatialDisturbance};
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;
use tandem::presets::SpatialSetup;
use tandem::reference::spatial::path::Se3Path;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Formulation, Log, Outcome, SimParams, Simulation, SpatialStart};

/// Which set-up.
#[derive(Clone, Copy, PartialEq)]
enum Arms {
    Ur5,
    Franka,
}

fn setup(a: Arms) -> SpatialSetup {
    match a {
        Arms::Ur5 => presets::dual_ur5(),
        Arms::Franka => presets::dual_franka(),
    }
}

fn nn(a: Arms) -> Law<6> {
    Law::Nn(match a {
        Arms::Ur5 => NnGains::dual_ur5(),
        Arms::Franka => NnGains::dual_franka(),
    })
}

fn sim_params(duration: f64) -> SimParams {
    SimParams {
        duration,
        plant_step: 1e-3,
        control_period: 1e-3,
        log_period: 0.01,
        start: [0.0; 3],
        formulation: Formulation::Constrained,
        max_drift: 1e-6,
        min_sigma: 1e-3,
    }
}

/// A closed-loop run on the S6 path from rest 1 cm inside the circle (as planar: the paper's
/// start offset), with the S6 disturbance plus `pushes`.
fn run_with(
    a: Arms,
    p: &SpatialControllerParams,
    duration: f64,
    pushes: Vec<Push<6>>,
) -> (Outcome, Simulation<SpatialPlant, SpatialController>) {
    run_path(a, p, Se3Path::spec_s6(), duration, pushes)
}

/// [`run_with`] on any path (start 1 cm off its `t = 0` pose along −x).
fn run_path(
    a: Arms,
    p: &SpatialControllerParams,
    path: Se3Path,
    duration: f64,
    pushes: Vec<Push<6>>,
) -> (Outcome, Simulation<SpatialPlant, SpatialController>) {
    let s = setup(a);
    let (c, _warnings) =
        SpatialController::new(p, &s.params, path.clone(), duration, &s.q_guess).unwrap();
    let d0 = path.sample(0.0);
    let start = SpatialStart {
        x_wo: Isometry3::from_parts(
            Translation3::from(d0.p - Vector3::new(0.01, 0.0, 0.0)),
            d0.r,
        ),
        q_guess: s.q_guess.clone(),
    };
    let mut dist = SpatialDisturbance::spec_s6();
    dist.pushes = pushes;
    let sim = Simulation::with_plant(
        SpatialPlant::new(&s.params).unwrap(),
        &start,
        &SensorParams::default(),
        c,
        dist,
        sim_params(duration),
    )
    .unwrap();
    sim.run(|_| {})
}

fn run(a: Arms, law: Law<6>, duration: f64) -> Outcome {
    run_with(a, &SpatialControllerParams::spec_s6(law), duration, vec![]).0
}

fn col<'a>(log: &'a Log, name: &str) -> &'a [f64] {
    log.get(name)
        .unwrap_or_else(|| panic!("no column {name}; have {:?}", log.names()))
}

/// `(‖z1_p‖, ‖z1_φ‖)` per log row.
fn z1_norms(log: &Log) -> Vec<(f64, f64)> {
    let g = |a: &str| col(log, &format!("z1.{a}"));
    let (x, y, z, rx, ry, rz) = (g("x"), g("y"), g("z"), g("rx"), g("ry"), g("rz"));
    (0..log.len())
        .map(|k| {
            (
                Vector3::new(x[k], y[k], z[k]).norm(),
                Vector3::new(rx[k], ry[k], rz[k]).norm(),
            )
        })
        .collect()
}

/// Largest `(‖z1_p‖, ‖z1_φ‖)` from `t0` on, and the RMS of `‖z1_p‖` there.
fn after(log: &Log, t0: f64) -> (f64, f64, f64) {
    let t = col(log, "t");
    let z = z1_norms(log);
    let mut m = (0.0f64, 0.0f64, 0.0f64);
    let mut n = 0.0;
    for (k, &(p, r)) in z.iter().enumerate() {
        if t[k] >= t0 {
            m.0 = m.0.max(p);
            m.1 = m.1.max(r);
            m.2 += p * p;
            n += 1.0;
        }
    }
    (m.0, m.1, (m.2 / n).sqrt())
}

fn assert_clean(name: &str, out: &Outcome) {
    assert!(out.fault.is_none(), "{name}: fault {:?}", out.fault);
    assert_eq!(out.violation_ticks, 0, "{name}: bound violated");
    assert!(
        out.max_drift < 1e-9 && out.max_drift_rot < 1e-9,
        "{name}: drift {:.2e} m, {:.2e} rad",
        out.max_drift,
        out.max_drift_rot
    );
}

#[test]
fn nn_tracks_the_s6_path_on_two_ur5_within_1_mm_and_1_mrad() {
    // SPEC-spatial S6 on two UR5-class arms, NN law (dual-UR5 gains), admittance on, the S6
    // disturbance, from rest 1 cm inside the circle: every |x_1j| < k_cj on the true pose at
    // every tick, ‖z1_p‖ < 1 mm and |z1_φ| < 1 mrad from 2 s on, no barrier hit.
    let out = run(Arms::Ur5, nn(Arms::Ur5), 12.0);
    assert_clean("nn/ur5", &out);
    let (zp, zr, rms) = after(&out.log, 2.0);
    let m = out.min_margin.unwrap();
    eprintln!(
        "nn/ur5: after 2 s max ‖z1_p‖ = {:.1} µm, max |z1_φ| = {:.1} µrad, RMS ‖z1_p‖ {:.1} µm; min margin {m:.3}; events {:?}; wall {:.2} s for 12 s",
        zp * 1e6,
        zr * 1e6,
        rms * 1e6,
        out.events,
        out.wall_time
    );
    assert!(zp < 1e-3 && zr < 1e-3);
    assert!(m > 0.0);
    assert_eq!(out.events.barrier_hits, 0);
    assert_eq!(out.events.non_finite, 0);
    assert_eq!(out.events.degenerate, 0);
}

/// Step response of `M_e ë + C_e ė + K_e e = K_e u(t)` from rest at time `t` (underdamped).
fn second_order_step(m: f64, c: f64, k: f64, t: f64) -> f64 {
    let wn = (k / m).sqrt();
    let z = c / (2.0 * (k * m).sqrt());
    assert!(z < 1.0);
    let wd = wn * (1.0 - z * z).sqrt();
    1.0 - (-z * wn * t).exp() * ((wd * t).cos() + z / (1.0 - z * z).sqrt() * (wd * t).sin())
}

#[test]
fn a_push_and_a_twist_make_the_reference_comply_and_it_returns() {
    // SPEC §3.1 in six dimensions: a constant wrench p on the object reaches the arms as the
    // controller's share of it (min-norm distribution: the object-level law cancels p, so the
    // commanded wrenches change by share(−p) and the object-on-tool wrenches by share(p)); each
    // arm's generator then settles at e_i = share_i(p)/K_e per axis, along the step response of
    // M_e ë + C_e ė + K_e e, and the object reference is the fit of the offset tool poses. A 5 N
    // push along world x for 2 s (from 3 s) and a 0.5 N m twist about world z for 2 s (from
    // 9 s); the reference must move as predicted (within 10 %) and return.
    use tandem::control::spatial::chart::Chart;
    use tandem::control::spatial::distribute::Distribution;
    use tandem::geometry::so3::exp_quat;
    use tandem::reference::spatial::admittance::{AdmittanceSe3Params, tool_from_object_se3};
    use tandem::reference::spatial::{PoseSample, fit};
    let a = Arms::Ur5;
    let p = SpatialControllerParams::spec_s6(nn(a));
    let pushes = vec![
        Push {
            t0: 3.0,
            duration: 2.0,
            wrench: [5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        },
        Push {
            t0: 9.0,
            duration: 2.0,
            wrench: [0.0, 0.0, 0.0, 0.0, 0.0, 0.5],
        },
    ];
    let (out, sim) = run_with(a, &p, 16.0, pushes.clone());
    assert_clean("push", &out);
    // The same run without the pushes: the pushes' effect is the difference.
    let (calm, _) = run_with(a, &p, 16.0, vec![]);
    let (log, log0) = (&out.log, &calm.log);
    let t = col(log, "t");
    let row = |tt: f64| t.iter().position(|&x| x >= tt - 1e-9).unwrap();
    let off = |k: usize| -> Vector6<f64> {
        Vector6::from_fn(|j, _| {
            let ax = ["x", "y", "z", "rx", "ry", "rz"][j];
            let c = format!("x_r.{ax}");
            col(log, &c)[k] - col(log0, &c)[k]
        })
    };
    let s = setup(a);
    let adm = AdmittanceSe3Params::default();
    let chart: Chart = *sim.driver().chart();
    let path = Se3Path::spec_s6();
    let mut dist = Distribution::new(2, p.metric_length).unwrap();
    for push in &pushes {
        // The prediction at the end of the push (t1), on the desired pose there.
        let t1 = push.t0 + push.duration;
        let d = path.sample(t1);
        let r: Vec<Vector3<f64>> = s
            .params
            .grasps
            .iter()
            .map(|g| d.r * g.translation.vector)
            .collect();
        let mut share = vec![Vector6::zeros(); 2];
        assert!(dist.distribute(&r, &Vector6::from(push.wrench), 0.0, &mut share));
        let y = second_order_step(adm.m_e[0], adm.c_e[0], adm.k_e[0], push.duration);
        let tools: Vec<PoseSample> = s
            .params
            .grasps
            .iter()
            .zip(&share)
            .map(|(g, f)| {
                let mut tl = tool_from_object_se3(&d, g);
                let e = f.component_div(&adm.k_e) * y;
                tl.p += e.fixed_rows::<3>(0);
                tl.q = exp_quat(&e.fixed_rows::<3>(3).into_owned()) * tl.q;
                tl
            })
            .collect();
        let fitted = fit(&s.params.grasps, &tools, &d.r).sample;
        let want = chart.coords(&fitted.p, &fitted.q) - chart.coords(&d.p, &d.r);
        let got = off(row(t1));
        let before = off(row(push.t0));
        eprintln!(
            "push {:?}: x_r − x_d at the end {:?} (predicted {:?}), before {:.2e}",
            push.wrench,
            got.as_slice(),
            want.as_slice(),
            before.norm()
        );
        // Every axis within 10 % of the predicted excursion's size (what is left of an earlier
        // push is below 1 % of it).
        let j = want.iamax();
        assert!(
            before.amax() < 0.01 * want[j].abs(),
            "before the push {:?}",
            before.as_slice()
        );
        assert!(
            (got - want).amax() < 0.1 * want[j].abs(),
            "moved {:?} (predicted {:?})",
            got.as_slice(),
            want.as_slice()
        );
        // It returns: 3.5 s after the push, within 2 % of the excursion (the generator's
        // envelope e^{−ζω_n t} is 0.4 % by then).
        let back = off(row(t1 + 3.5));
        assert!(
            back.amax() < 0.02 * want[j].abs(),
            "{:?} after the push (excursion {})",
            back.as_slice(),
            want[j]
        );
    }
}

#[test]
fn pd_tracks_worse_than_nn_and_every_law_stays_stable_with_the_admittance_on() {
    // Every law and scheme on the S6 path with the admittance on: no fault, no bound violation,
    // drift < 1e-9. PD (the paper's baseline: no gravity compensation, SPEC §3.5) tracks worse
    // than NN (RMS ‖z1_p‖ after 2 s); computed torque with the exact model tracks best.
    let a = Arms::Ur5;
    let mut rms = Vec::new();
    for (name, law, scheme) in [
        ("nn", nn(a), Scheme::Object),
        ("pd", Law::Pd(PdGains::<6>::paper()), Scheme::Object),
        ("ctc", Law::Ctc(CtcGains::<6>::default()), Scheme::Object),
        ("pd per-arm", Law::Pd(PdGains::<6>::paper()), Scheme::PerArm),
        (
            "pd+g",
            Law::Pd(PdGains {
                gravity_compensation: true,
                ..PdGains::<6>::paper()
            }),
            Scheme::Object,
        ),
    ] {
        let mut p = SpatialControllerParams::spec_s6(law);
        p.scheme = scheme;
        let (out, _) = run_with(a, &p, 8.0, vec![]);
        assert_clean(name, &out);
        let (zp, zr, r) = after(&out.log, 2.0);
        eprintln!(
            "{name}: after 2 s max ‖z1_p‖ {:.1} µm, max |z1_φ| {:.1} µrad, RMS ‖z1_p‖ {:.1} µm, min margin {:.3}",
            zp * 1e6,
            zr * 1e6,
            r * 1e6,
            out.min_margin.unwrap()
        );
        rms.push((name, r, zr));
    }
    let (nn_rms, pd_rms) = (rms[0].1, rms[1].1);
    assert!(
        pd_rms > 10.0 * nn_rms,
        "PD RMS {pd_rms:.2e} vs NN {nn_rms:.2e}"
    );
    // The per-arm PD also sags; computed torque and PD with gravity compensation (model-based)
    // track within a tenth of a millimetre on this slow path, the NN without a model as well.
    assert!(rms[3].1 > 10.0 * nn_rms);
    for (name, r, zr) in &rms[2..] {
        if *name != "pd per-arm" {
            assert!(
                *r < 1e-4 && *zr < 1e-3,
                "{name}: RMS {r:.2e} m, max |z1_φ| {zr:.2e}"
            );
        }
    }
}

/// Per log row and arm: `‖N q̇‖` and `‖N (q − q_rest)‖` with `N = I − J⁺J` the projector on
/// the tool Jacobian's null space (the self-motion of a redundant arm), `q_rest` = the start.
fn self_motion(log: &Log, a: Arms) -> Vec<(f64, f64)> {
    use nalgebra::{DMatrix, DVector};
    use tandem::dynamics::spatial::{ChainData, kinematics};
    let s = setup(a);
    let mut out = Vec::new();
    let nq: usize = s.params.arms.iter().map(|a| a.chain.dof()).sum();
    let q: Vec<&[f64]> = (0..nq).map(|k| col(log, &format!("q{}", k + 1))).collect();
    let qd: Vec<&[f64]> = (0..nq).map(|k| col(log, &format!("qd{}", k + 1))).collect();
    let mut data: Vec<ChainData> = s.params.arms.iter().map(ChainData::new).collect();
    for row in 0..log.len() {
        let (mut v, mut e) = (0.0f64, 0.0f64);
        let mut off = 0;
        for (i, arm) in s.params.arms.iter().enumerate() {
            let n = arm.chain.dof();
            let qi: Vec<f64> = (0..n).map(|k| q[off + k][row]).collect();
            let qdi = DVector::from_fn(n, |k, _| qd[off + k][row]);
            let dq = DVector::from_fn(n, |k, _| q[off + k][row] - q[off + k][0]);
            kinematics(arm, &qi, None, &mut data[i]);
            let j = DMatrix::from_fn(6, n, |r, c| data[i].J[(r, c)]);
            let jp = j.transpose() * (&j * j.transpose()).try_inverse().unwrap();
            let proj = DMatrix::identity(n, n) - &jp * &j;
            v = v.max((&proj * qdi).norm());
            e = e.max((&proj * dq).norm());
            off += n;
        }
        out.push((v, e));
    }
    out
}

#[test]
fn nn_tracks_on_two_franka_with_the_self_motion_bounded_and_damped() {
    // Two 7-DOF Franka-class arms (grasps from above), the S6 path, NN law (dual-Franka
    // gains): the same claims as on UR5, and the self-motion of each arm (its velocity in the
    // null space of the tool Jacobian, and its posture drift there) stays small and dies out.
    let a = Arms::Franka;
    let out = run(a, nn(a), 12.0);
    assert_clean("nn/franka", &out);
    let (zp, zr, rms) = after(&out.log, 2.0);
    let sm = self_motion(&out.log, a);
    let t = col(&out.log, "t");
    let peak_v = sm.iter().map(|x| x.0).fold(0.0, f64::max);
    let late_v = sm
        .iter()
        .zip(t)
        .filter(|(_, t)| **t >= 10.0)
        .map(|(x, _)| x.0)
        .fold(0.0, f64::max);
    let drift = sm.iter().map(|x| x.1).fold(0.0, f64::max);
    eprintln!(
        "nn/franka: after 2 s max ‖z1_p‖ {:.1} µm, max |z1_φ| {:.1} µrad, RMS {:.1} µm, min margin {:.3}; self-motion speed peak {peak_v:.2e} rad/s, after 10 s {late_v:.2e}; posture drift in the null space ≤ {drift:.2e} rad; events {:?}",
        zp * 1e6,
        zr * 1e6,
        rms * 1e6,
        out.min_margin.unwrap(),
        out.events
    );
    assert!(zp < 1e-3 && zr < 1e-3);
    assert!(peak_v < 0.05 && drift < 0.05);
    // Damped: a point-to-point move (5 cm along y and 10° about z in 3 s, quintic time law,
    // geodesic in orientation) excites the self-motion; once the object holds still, it dies
    // out (the posture task's damping) instead of drifting.
    let d0 = Se3Path::spec_s6().sample(0.0);
    let rz = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 10f64.to_radians());
    let ptp = Se3Path::point_to_point(
        d0.p,
        d0.r,
        d0.p + Vector3::new(0.0, 0.05, 0.0),
        rz * d0.r,
        0.5,
        3.0,
    )
    .unwrap();
    let mut p = SpatialControllerParams::spec_s6(nn(a));
    p.k_c = [0.1, 0.1, 0.1, 0.29, 0.29, 0.29];
    let (out, _) = run_path(a, &p, ptp, 8.0, vec![]);
    assert_clean("nn/franka ptp", &out);
    let sm = self_motion(&out.log, a);
    let t = col(&out.log, "t");
    let during = sm
        .iter()
        .zip(t)
        .filter(|(_, t)| **t < 3.5)
        .map(|(x, _)| x.0)
        .fold(0.0, f64::max);
    let late = sm
        .iter()
        .zip(t)
        .filter(|(_, t)| **t >= 6.5)
        .map(|(x, _)| x.0)
        .fold(0.0, f64::max);
    let (zp, zr, _) = after(&out.log, 5.0);
    eprintln!(
        "nn/franka point-to-point: self-motion speed peak {during:.2e} rad/s during the move, ≤ {late:.2e} from 3 s after it; after 5 s ‖z1_p‖ ≤ {:.1} µm, |z1_φ| ≤ {:.1} µrad",
        zp * 1e6,
        zr * 1e6
    );
    assert!(during < 0.05);
    assert!(
        late < 0.05 * during,
        "self-motion not damped: {late:.2e} vs {during:.2e}"
    );
    assert!(zp < 1e-3 && zr < 1e-3);
}

/// The NN run on two UR5 tick by tick for `ticks` ms, logging every tick; `each(k, ŵ)` sees the
/// weights after tick `k`.
fn run_ticks(
    ticks: usize,
    mut each: impl FnMut(usize, &[f64]),
) -> (Log, tandem::control::spatial::chart::Chart) {
    let a = Arms::Ur5;
    let s = setup(a);
    let duration = ticks as f64 * 1e-3;
    let p = SpatialControllerParams::spec_s6(nn(a));
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
    let mut sp = sim_params(duration);
    sp.log_period = 1e-3;
    let mut sim = Simulation::with_plant(
        SpatialPlant::new(&s.params).unwrap(),
        &start,
        &SensorParams::default(),
        c,
        SpatialDisturbance::spec_s6(),
        sp,
    )
    .unwrap();
    for k in 0..ticks {
        sim.tick(k).unwrap();
        each(k, &sim.driver().adaptive().unwrap().weights());
    }
    let (out, sim) = sim.run(|_| {});
    (out.log, *sim.driver().chart())
}

#[test]
fn lyapunov_function_v3_decreases_outside_its_ultimate_bound_on_six_outputs() {
    // V3 (46) = V1 + ½ z2ᵀ M_x z2 + ½ Σ_j ‖Ŵ_j − W*_j‖²/Θ_j on six outputs along the closed
    // loop, with M_x = E⁻ᵀ 𝓜 E⁻¹ the chart-space inertia at the logged joints. The ideal
    // weights are unknown; the load changes slowly along the path, so W* = the learnt weights at
    // 1.5 s of an identical first run (as the planar test). Claim (51): V̇3 ≤ −η3 V3 + C3, i.e.
    // V3 decreases while it is above its ultimate level.
    use tandem::control::spatial::model::ObjectModel;
    let ticks = 1500;
    let mut w_star = Vec::new();
    run_ticks(ticks, |k, w| {
        if k == ticks - 1 {
            w_star = w.to_vec();
        }
    });
    let g = NnGains::dual_ur5();
    let nodes = w_star.len() / 6;
    let theta_of = |i: usize| g.theta[i / nodes];
    let vw = |w: &[f64]| -> f64 {
        w.iter()
            .zip(&w_star)
            .enumerate()
            .map(|(i, (a, b))| 0.5 * (a - b) * (a - b) / theta_of(i))
            .sum()
    };
    let mut v_w = vec![0.0; ticks];
    let mut prev = vw(&vec![0.0; w_star.len()]);
    let (log, chart) = run_ticks(ticks, |k, w| {
        v_w[k] = prev;
        prev = vw(w);
    });
    let s = setup(Arms::Ur5);
    let model = ObjectModel::new(&s.params).unwrap();
    let mut ws = model.workspace();
    let k_c = SpatialControllerParams::spec_s6(nn(Arms::Ur5)).k_c;
    let ax = ["x", "y", "z", "rx", "ry", "rz"];
    let get =
        |g: &str| -> Vec<&[f64]> { ax.iter().map(|a| col(&log, &format!("{g}.{a}"))).collect() };
    let (xh, z1, xr, z2, xdh) = (
        get("x_hat"),
        get("z1"),
        get("x_r"),
        get("z2"),
        get("xd_hat"),
    );
    let nq = model.n_q();
    let q: Vec<&[f64]> = (0..nq).map(|k| col(&log, &format!("q{}", k + 1))).collect();
    let mut v3 = vec![0.0; ticks];
    for k in 0..ticks {
        let v1s: f64 = (0..6).map(|j| v1(z1[j][k], xr[j][k], k_c[j])).sum();
        let x1 = Vector6::from_fn(|j, _| xh[j][k]);
        let x1d = Vector6::from_fn(|j, _| xdh[j][k]);
        let qk: Vec<f64> = (0..nq).map(|i| q[i][k]).collect();
        let pose = chart.pose(&x1);
        let jac = chart.jacobian(
            &x1.fixed_rows::<3>(3).into_owned(),
            &x1d.fixed_rows::<3>(3).into_owned(),
        );
        model.kinematics(&qk, &vec![0.0; nq], &mut ws);
        let m = model
            .dynamics(&qk, &vec![0.0; nq], &pose, &Vector6::zeros(), &mut ws)
            .unwrap()
            .m;
        let ei = jac.e_inv();
        let mx = ei.transpose() * m * ei;
        let z2k = Vector6::from_fn(|j, _| z2[j][k]);
        v3[k] = v1s + 0.5 * z2k.dot(&(mx * z2k)) + v_w[k];
    }
    let ultimate = v3[ticks - 200..].iter().cloned().fold(0.0, f64::max);
    eprintln!(
        "V3(0) = {:.3e}, V3(0.5 s) = {:.3e}, level over the last 0.2 s {:.3e}",
        v3[0], v3[500], ultimate
    );
    assert!(
        v3[0] > 100.0 * ultimate,
        "V3 should fall by two orders of magnitude"
    );
    // Above 300× the final level V3 decreases on every tick. Below it, during the transient
    // (196–265 ms, at up to 239× the final level with the smooth default's `Q ≡ 1`; 136–166×
    // with the paper's switching, whose robust term acted there), V3 rises by about 20 %: the
    // weights move away
    // from W* while the network, an adaptive bias here (ϑ² = 50), takes in the transient force
    // 𝓜α̇ that no constant weight represents. That is the proof's approximation error ε in
    // C3 (51) (z2ᵀε ≤ K2 z2²/2 + ε²/(2 K2)), not a violation; the test bounds every rise.
    let mut checked = 0;
    let mut worst_rise: f64 = 0.0;
    let top_rise = (1..ticks)
        .filter(|&k| v3[k] >= v3[k - 1])
        .map(|k| (v3[k - 1] / ultimate, k))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    eprintln!(
        "highest level at which V3 rose: {:.1}× the final level, at {} ms",
        top_rise.0, top_rise.1
    );
    for k in 1..ticks {
        if v3[k] >= v3[k - 1] {
            worst_rise = worst_rise.max(v3[k] / v3[k - 1] - 1.0);
        }
    }
    // The largest excursion above the running minimum (measured: 22 % with the paper's
    // switching, at 136–166× the final level); a bounded, transient rise.
    let mut running_min = v3[0];
    let mut largest_excursion: f64 = 0.0;
    for &v in &v3 {
        running_min = running_min.min(v);
        largest_excursion = largest_excursion.max(v / running_min - 1.0);
    }
    for k in 1..ticks {
        if v3[k - 1] > 300.0 * ultimate {
            assert!(
                v3[k] < v3[k - 1],
                "V3 rose at t = {k} ms: {} -> {}",
                v3[k - 1],
                v3[k]
            );
            checked += 1;
        }
    }
    eprintln!(
        "largest rise of V3 (below 300× its final level): {:.1} % over its running minimum (per tick {:.2e})",
        100.0 * largest_excursion,
        worst_rise
    );
    assert!(
        largest_excursion < 0.3,
        "V3 rose by {:.1} %",
        100.0 * largest_excursion
    );
    eprintln!("V3 decreased on all {checked} ticks above 300× its final level");
    assert!(checked > 10);
}

// ---- set-up checks and bad input -----------------------------------------------------------

fn build(
    a: Arms,
    p: &SpatialControllerParams,
    path: Se3Path,
) -> Result<(SpatialController, Vec<tandem::control::ControlWarning>), tandem::ModelError> {
    let s = setup(a);
    SpatialController::new(p, &s.params, path, 10.0, &s.q_guess)
}

fn err_param(
    r: Result<(SpatialController, Vec<tandem::control::ControlWarning>), tandem::ModelError>,
) -> String {
    match r {
        Ok(_) => panic!("expected an error"),
        Err(e) => {
            let s = e.to_string();
            eprintln!("error: {s}");
            s
        }
    }
}

#[test]
fn bad_gains_bounds_paths_and_postures_are_typed_errors_naming_the_parameter() {
    let a = Arms::Ur5;
    let base = SpatialControllerParams::spec_s6(nn(a));
    let s6 = Se3Path::spec_s6;
    // Non-positive gains.
    let mut g = NnGains::dual_ur5();
    g.k2[4] = 0.0;
    let mut p = base.clone();
    p.law = Law::Nn(g);
    assert!(err_param(build(a, &p, s6())).contains("gains.k2[4]"));
    let mut p = base.clone();
    p.law = Law::Pd(PdGains {
        k_d: [1.0, 1.0, 1.0, 1.0, -2.0, 1.0],
        ..PdGains::<6>::paper()
    });
    assert!(err_param(build(a, &p, s6())).contains("gains.k_d[4]"));
    let mut p = base.clone();
    p.law = Law::Ctc(CtcGains {
        k_p: [0.0; 6],
        ..Default::default()
    });
    assert!(err_param(build(a, &p, s6())).contains("gains.k_p[0]"));
    // A rotational bound at or above π; one above π/2 is a warning.
    let mut p = base.clone();
    p.k_c[5] = std::f64::consts::PI;
    assert!(err_param(build(a, &p, s6())).contains("k_c[5]"));
    let mut p = base.clone();
    p.law = Law::Pd(PdGains::<6>::paper());
    p.k_c[3] = 1.7;
    let (_, w) = build(a, &p, s6()).unwrap();
    assert!(w.iter().any(|w| w.to_string().contains("k_c[3]")), "{w:?}");
    // A path that leaves the bound.
    let mut p = base.clone();
    p.k_c[1] = 0.08; // 10 s of the 60 s circle reach y = 0.1 sin 60° = 0.0866 m
    let e = err_param(build(a, &p, s6()));
    assert!(e.contains("k_c[1]") && e.contains("0.0866"), "{e}");
    // A path out of the arms' reach (a 0.6 m circle).
    use tandem::reference::spatial::path::CircleParams;
    let mut c = CircleParams::spec_s6();
    c.radius = 0.6;
    let mut p = base.clone();
    p.law = Law::Pd(PdGains::<6>::paper());
    p.k_c = [1.0, 1.0, 0.1, 0.29, 0.29, 0.29];
    let e = err_param(build(a, &p, Se3Path::circle(&c).unwrap()));
    assert!(e.contains("path") && e.contains("reach"), "{e}");
    // The paper's full grid on six outputs; the per-arm scheme with the NN law.
    let mut g = NnGains::dual_ur5();
    g.network = tandem::control::rbf::structured::NetworkStructure::FullGrid;
    let mut p = base.clone();
    p.law = Law::Nn(g);
    assert!(err_param(build(a, &p, s6())).contains("gains.network"));
    let mut p = base.clone();
    p.scheme = Scheme::PerArm;
    assert!(err_param(build(a, &p, s6())).contains("scheme"));
    // An unreachable posture of a redundant arm (outside a joint's limits).
    let fr = setup(Arms::Franka);
    let mut p = SpatialControllerParams::spec_s6(nn(Arms::Franka));
    let mut q = fr.q_guess.clone();
    q[3] = 1.0; // panda_joint4 must stay in [−3.07, −0.07]
    p.posture.q_rest = Some(q);
    assert!(err_param(build(Arms::Franka, &p, s6())).contains("posture.q_rest[3]"));
    let mut p = SpatialControllerParams::spec_s6(nn(Arms::Franka));
    p.posture.kd = 0.0;
    assert!(err_param(build(Arms::Franka, &p, s6())).contains("posture.kd"));
    // A risky tuning is a warning with the reason: K2 far below 𝓜 K1.
    let mut g = NnGains::dual_ur5();
    g.k2[0] = 1.0;
    let mut p = base.clone();
    p.law = Law::Nn(g);
    let (_, w) = build(a, &p, s6()).unwrap();
    let w: Vec<String> = w.iter().map(|w| w.to_string()).collect();
    eprintln!("warnings: {w:?}");
    assert!(
        w.iter()
            .any(|w| w.contains("gains.k2[0]") && w.contains("K1")),
        "{w:?}"
    );
    // The presets themselves give no warning.
    for arms in [Arms::Ur5, Arms::Franka] {
        let (_, w) = build(arms, &SpatialControllerParams::spec_s6(nn(arms)), s6()).unwrap();
        assert!(w.is_empty(), "preset warnings: {w:?}");
    }
}

#[test]
fn non_finite_measurements_give_zero_torque_and_are_counted_never_nan() {
    use tandem::drive::Measurements;
    let a = Arms::Ur5;
    let s = setup(a);
    let (mut c, _) = build(
        a,
        &SpatialControllerParams::spec_s6(nn(a)),
        Se3Path::spec_s6(),
    )
    .unwrap();
    let n = s.q_guess.len();
    let wr = vec![0.0; 12];
    let qd = vec![0.0; n];
    c.start(
        0.0,
        &Measurements {
            q: &s.q_guess,
            qd: &qd,
            wrenches: &wr,
        },
    );
    let mut rec = tandem::control::spatial::SpatialTickRecord::new(2);
    let mut tau = vec![1.0; n];
    let mut q = s.q_guess.clone();
    q[2] = f64::NAN;
    c.tick(
        0.0,
        &Measurements {
            q: &q,
            qd: &qd,
            wrenches: &wr,
        },
        &mut tau,
        &mut rec,
    );
    assert!(tau.iter().all(|v| *v == 0.0));
    assert!(c.events().non_finite + c.events().degenerate >= 1);
    // A NaN wrist reading is held by the admittance; the torques stay finite.
    let mut wr2 = wr.clone();
    wr2[4] = f64::NAN;
    c.tick(
        1e-3,
        &Measurements {
            q: &s.q_guess,
            qd: &qd,
            wrenches: &wr2,
        },
        &mut tau,
        &mut rec,
    );
    assert!(tau.iter().all(|v| v.is_finite()));
    assert!(rec.x_r.iter().all(|v| v.is_finite()));
}

#[test]
fn the_path_chart_rates_and_the_controller_chart_agree() {
    // Two implementations of the S5 chart's rates: `se3_path::chart_rates` (the desired path's,
    // up to the third derivative, by the left-Jacobian series) and `control::spatial::chart::Chart::sample` (what the
    // controller uses on every pose sample). On a circle whose orientation swings by 0.8 rad
    // about a tilted axis, with a chart about an arbitrary R_ref (so φ and ω are not parallel),
    // x_1, ẋ_1 and ẍ_1 agree to round-off.
    use nalgebra::UnitQuaternion;
    use tandem::control::spatial::chart::Chart;
    use tandem::reference::spatial::admittance::pose_sample;
    use tandem::reference::spatial::path::{CircleParams, chart_rates};
    let mut cp = CircleParams::spec_s6();
    cp.axis = Vector3::new(1.0, 2.0, 3.0).normalize();
    cp.amplitude = 0.8;
    let path = Se3Path::circle(&cp).unwrap();
    let r_ref = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5));
    let chart = Chart::new(Vector3::new(0.01, -0.02, 0.3), r_ref);
    let mut worst: f64 = 0.0;
    for k in 0..600 {
        let s = path.sample(0.1 * k as f64);
        let a = chart_rates(&s, &chart.c, &chart.r_ref);
        let b = chart.sample(&pose_sample(&s));
        for (x, y) in [(a[0], b.x1), (a[1], b.x1_dot), (a[2], b.x1_ddot)] {
            worst = worst.max((x - y).amax() / (1.0 + y.amax()));
        }
    }
    eprintln!("chart_rates vs Chart::sample: max relative difference {worst:.2e}");
    assert!(worst > 0.0 && worst < 1e-13, "{worst:.2e}");
}

#[test]
fn pd_and_computed_torque_stay_stable_on_two_franka() {
    // The baselines on the 7-DOF set-up (posture task in the null space), admittance on.
    for (name, law) in [
        ("pd/franka", Law::Pd(PdGains::<6>::paper())),
        (
            "pd+g/franka",
            Law::Pd(PdGains {
                gravity_compensation: true,
                ..PdGains::<6>::paper()
            }),
        ),
        ("ctc/franka", Law::Ctc(CtcGains::<6>::default())),
    ] {
        let (out, _) = run_with(
            Arms::Franka,
            &SpatialControllerParams::spec_s6(law),
            6.0,
            vec![],
        );
        let (zp, zr, rms) = after(&out.log, 2.0);
        let log = &out.log;
        let worst: Vec<String> = ["x", "y", "z", "rx", "ry", "rz"]
            .iter()
            .map(|a| {
                let c = col(log, &format!("x_hat.{a}"));
                format!("{a} {:.4}", c.iter().fold(0.0f64, |m, v| m.max(v.abs())))
            })
            .collect();
        eprintln!(
            "{name}: after 2 s max ‖z1_p‖ {:.1} µm, max |z1_φ| {:.1} µrad, RMS {:.1} µm, min margin {:.3}, violation ticks {}, max |x_1j| {worst:?}",
            zp * 1e6,
            zr * 1e6,
            rms * 1e6,
            out.min_margin.unwrap(),
            out.violation_ticks
        );
        assert!(out.fault.is_none(), "{name}: {:?}", out.fault);
        if name != "pd/franka" {
            assert_clean(name, &out);
            assert!(zp < 1e-3 && zr < 1e-2, "{name}");
        }
    }
}
