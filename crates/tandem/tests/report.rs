//! `report`: the summary of any run, computed by the library (issue 26, "metrics for any run").
//!
//! (a) for a built-in law, the library's spatial summary equals what the CLI wrote before the
//! metrics moved (values copied from the golden `dual-ur5 --controller pd --duration 3`
//! `summary.json`); (b) a user's own `Drive` that holds the start while a point-to-point path
//! moves away has the analytic path error; (c) an object held exactly on the path has none.

use nalgebra::{UnitQuaternion, Vector3, Vector6};
use tandem::control::law::Law;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::chart::Chart;
use tandem::drive::{Drive, Measurements, NoRecord};
use tandem::plant::spatial::SpatialPlant;
use tandem::plant::{ClosedChain, SpatialStart};
use tandem::reference::planar::path::Path;
use tandem::reference::spatial::path::Se3Path;
use tandem::report::planar::summarize_with_path;
use tandem::report::spatial::{SpatialRun, summarize_run};
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Outcome, SimParams, Simulation};

/// (a) The S6 dual-UR5 closed loop with the paper's PD gains for 3 s, as `tandem run dual-ur5
/// --controller pd --duration 3` (in `compare`): every number below is the CLI's
/// `summary.json` from before the move, compared bit for bit.
#[test]
fn builtin_law_summary_equals_the_cli_golden_values() {
    let s = tandem::presets::dual_ur5();
    let law = Law::Pd(PdGains::<6>::paper());
    let (sim, _) =
        tandem::presets::spatial_s6_simulation(&s.params, &s, law, 3.0, 1e-3, 1e-6).unwrap();
    let (outcome, sim) = sim.run(|_| {});
    let k = sim.driver().k_c();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let path = Se3Path::spec_s6();
    let run = SpatialRun {
        outcome: &outcome,
        plant: &plant,
        path: &path,
        chart: sim.driver().chart(),
        k_c: [k[0], k[1], k[2], k[3], k[4], k[5]],
        transient: 2.0,
    };
    let (r, _) = summarize_run(run);
    assert_eq!(r.rows, 300);
    let z1 = r.z1_p.unwrap();
    assert_eq!(z1.rms, 0.02193203525894652);
    assert_eq!(z1.max, 0.022553626849890058);
    assert_eq!(r.z1_p_after.unwrap().rms, 0.02226815457623804);
    assert_eq!(r.min_margin, Some(0.36860098015323195));
    assert_eq!(r.violations, 0);
    assert!(!r.margin_from_rows);
    assert_eq!(
        r.orientation_error_to_desired_max_after,
        Some(0.005071640487330616)
    );
    assert_eq!(r.wrench.unwrap().force_rms, 112.18364580485157);
    assert_eq!(r.joint_torque.as_ref().unwrap().rms, 14.248367449766032);
    assert_eq!(r.settling_time_1mm, None);
    assert_eq!(r.s5.z1_p_after.max, Some(0.022317960842742676));
    assert_eq!(r.s5.z1_rot_after.max, Some(0.005097497685568984));
    assert!(r.s5.completed_without_violation && !r.s5.pass);
    // The new path error: the same angle as the existing "to desired" key.
    assert_eq!(
        r.path_error_rot_after.unwrap().max,
        r.orientation_error_to_desired_max_after.unwrap()
    );
}

/// A user's law: a joint PD about the start plus the start's holding torques (README, "Your
/// own controller"). It logs no `z1`, no reference, no bounds.
struct HoldPd {
    q0: Vec<f64>,
    hold: Vec<f64>,
}

impl<P: ClosedChain> Drive<P> for HoldPd {
    type Record = NoRecord;
    fn new_record(&self) -> NoRecord {
        NoRecord
    }
    fn start(&mut self, _t0: f64, m: &Measurements<'_>) {
        self.q0.copy_from_slice(m.q)
    }
    fn tick(&mut self, _t: f64, m: &Measurements<'_>, tau: &mut [f64], _: &mut NoRecord) {
        for k in 0..tau.len() {
            tau[k] = self.hold[k] + 400.0 * (self.q0[k] - m.q[k]) - 20.0 * m.qd[k];
        }
    }
}

/// The dual UR5 held at its start by `HoldPd` for `duration` s.
fn hold_spatial(duration: f64) -> (Outcome, SpatialPlant, nalgebra::Isometry3<f64>) {
    let s = tandem::presets::dual_ur5();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y0 = plant
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap();
    let mut hold = vec![0.0; plant.n_q()];
    plant.holding_torques(&y0, &mut plant.workspace(), &mut hold);
    let law = HoldPd {
        q0: vec![0.0; hold.len()],
        hold,
    };
    let start = SpatialStart {
        x_wo: s.x_wo,
        q_guess: s.q_guess.clone(),
    };
    let run = SimParams {
        duration,
        plant_step: 5e-4,
        log_period: 0.01,
        ..SimParams::paper()
    };
    let sim = Simulation::with_plant(
        SpatialPlant::new(&s.params).unwrap(),
        &start,
        &SensorParams::default(),
        law,
        tandem::model::disturbance::SpatialDisturbance::zero(),
        run,
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    assert!(out.fault.is_none());
    (out, plant, s.x_wo)
}

/// (b) and (c), spatial: a path that moves 5 cm along x and turns 0.1 rad about z while the
/// object is held at the start. The held object moves by less than 1e-6 m/rad (checked from the
/// log), so the path error is the path's own displacement `‖p_d(t) − p_0‖`, `|φ_d(t)|`,
/// computed by hand; against a path that holds the start it is zero (to the holding error).
#[test]
fn user_drive_path_error_is_the_analytic_distance() {
    let (out, plant, x_wo) = hold_spatial(1.0);
    let log = &out.log;
    let p0 = x_wo.translation.vector;
    let r0 = x_wo.rotation;
    let t = log.get("t").unwrap();
    let ox = log.get("x_o.x").unwrap();
    let held = ox.iter().fold(0.0f64, |a, x| a.max((x - p0.x).abs()));
    assert!(held < 1e-6, "the object moved {held} m");

    let (dx, dphi, t0, dur) = (0.05, 0.1, 0.2, 0.5);
    let r1 = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), dphi) * r0;
    let path =
        Se3Path::point_to_point(p0, r0, p0 + Vector3::new(dx, 0.0, 0.0), r1, t0, dur).unwrap();
    let chart = Chart::new(p0, r0);
    let run = SpatialRun {
        outcome: &out,
        plant: &plant,
        path: &path,
        chart: &chart,
        k_c: [0.167, 0.167, 0.1, 0.29, 0.29, 0.29],
        transient: 0.8,
    };
    let (r, _) = summarize_run(run);
    // No z1 columns: the law's tracking metrics are absent, the path error is not.
    assert!(!r.has_z1 && r.z1_p.is_none());
    // Analytic: after t0 + dur the path is at rest at (dx, dphi) from the start.
    let pe = r.path_error_p.unwrap();
    let pa = r.path_error_p_after.unwrap();
    let ra = r.path_error_rot_after.unwrap();
    assert!((pe.max - dx).abs() < 2e-6, "{}", pe.max);
    assert!((pa.rms - dx).abs() < 2e-6 && (pa.max - dx).abs() < 2e-6);
    assert!((ra.max - dphi).abs() < 2e-6, "{}", ra.max);
    // The whole-run RMS against the hand-computed samples of the path.
    let ss: f64 = t
        .iter()
        .map(|&tk| {
            let d = (path.sample(tk).p - p0).norm();
            d * d
        })
        .sum();
    assert!((pe.rms - (ss / t.len() as f64).sqrt()).abs() < 2e-6);
    // The margin comes from the true pose and the scenario's bounds: 1 − |x1|/k_c ≈ 1 for a
    // held object at the chart centre.
    assert!(r.margin_from_rows && r.violations == 0);
    assert!((r.min_margin.unwrap() - 1.0).abs() < 1e-4);

    // (c) Held exactly on a path that holds the start: zero path error.
    let hold = Se3Path::point_to_point(p0, r0, p0, r0, 0.0, 1.0).unwrap();
    let run = SpatialRun { path: &hold, ..run };
    let (r, _) = summarize_run(run);
    assert!(r.path_error_p.unwrap().max < 1e-6);
    assert!(r.path_error_rot.unwrap().max < 1e-6);
}

/// (b) and (c), planar: the paper's plant (horizontal, no disturbance) at rest under a zero
/// torque `Drive` stays at its start; a planar user `Drive` logs no `z1`, so the tracking
/// metrics are the true pose against the desired path: `‖(x_o − x_d)_xy‖` and `|θ_o − θ_d|`.
#[test]
fn planar_user_drive_is_measured_against_the_desired_path() {
    let params = tandem::presets::paper();
    let start = tandem::presets::planar::paper_start();
    let law = HoldPd {
        q0: vec![0.0; 4],
        hold: vec![0.0; 4],
    };
    let run = SimParams {
        duration: 1.0,
        start: [start.x, start.y, start.z],
        ..SimParams::paper()
    };
    let sim = Simulation::new(
        &params,
        &SensorParams::default(),
        law,
        tandem::model::disturbance::Disturbance::zero(),
        run,
        None,
    )
    .unwrap();
    let (out, _) = sim.run(|_| {});
    assert!(out.fault.is_none());
    // The zero-torque PD does not hold the planar object against gravity (it sags by mm and
    // turns): the path error is checked row by row against the hand computation, the exact
    // analytic case is the spatial test's.
    let (ox, oy, ot) = (
        out.log.get("x_o.x").unwrap(),
        out.log.get("x_o.y").unwrap(),
        out.log.get("x_o.theta").unwrap(),
    );
    assert!(out.log.get("z1.x").is_none());

    // (b) The path moves (3 cm, 4 cm, 0.1 rad) away between 0.2 s and 0.7 s: 5 cm after it.
    let to = start + Vector3::new(0.03, 0.04, 0.1);
    let path = Path::point_to_point(start, to, 0.2, 0.5).unwrap();
    let s = summarize_with_path(&out, &path, "hold-pd", "", [0.35; 3], 0.8, 1.0);
    // The true pose against the path, row by row, by hand.
    let t = out.log.get("t").unwrap();
    let (mut mx, mut mth, mut ss) = (0.0f64, 0.0f64, 0.0);
    for k in 0..t.len() {
        let d = path.sample(t[k]).p;
        let e = (ox[k] - d.x).hypot(oy[k] - d.y);
        mx = mx.max(e);
        mth = mth.max((ot[k] - d.z).abs());
        ss += e * e;
    }
    assert_eq!(s.max_path_error, Some(mx));
    assert_eq!(s.max_path_error_theta, Some(mth));
    assert!((s.rms_path_error.unwrap() - (ss / t.len() as f64).sqrt()).abs() < 1e-15);
    // The tracking metrics are the same distance (z1 = x_o − x_d, as for a replay).
    assert_eq!(s.max_z1, mx);
    // Margin and violations from the true pose and the bounds.
    let mm = (0..t.len()).fold(f64::INFINITY, |a, k| {
        a.min(1.0 - (ox[k].abs().max(oy[k].abs()).max(ot[k].abs())) / 0.35)
    });
    assert_eq!(s.violations, 0);
    assert!((s.min_margin - mm).abs() < 1e-15);

    // (c) An object exactly on the path (the last logged pose, held by the path): zero.
    let last = Vector3::new(ox[ox.len() - 1], oy[oy.len() - 1], ot[ot.len() - 1]);
    let on = Path::point_to_point(last, last, 0.0, 1.0).unwrap();
    let mut one = out.clone();
    for c in &mut one.log.columns {
        let k = c.data.len() - 1;
        c.data = vec![c.data[k]];
    }
    let s = summarize_with_path(&one, &on, "hold-pd", "", [0.35; 3], 0.8, 1.0);
    assert_eq!(s.max_path_error, Some(0.0));
    assert_eq!(s.max_path_error_theta, Some(0.0));
}
