//! A user's own `Drive` gets what tandem's laws get (issue 26): the README's `HoldPd` (a joint PD
//! around the start plus the holding torques) on the dual-UR5 plant, wrapped in a
//! [`tandem_cli::run::spatial::Finished`] with the scenario's path, chart and bounds, is written
//! by the same [`tandem_cli::output::spatial::write`] as `tandem run`: `summary.json` with the
//! tracking against the desired path, the margin and violations against `k_c`, the S5 claims
//! and the torque rate; `timeseries.csv`; the figures; the viewer.

use std::fs;

use tandem::control::spatial::chart::Chart;
use tandem::drive::{Drive, Measurements, NoRecord};
use tandem::nalgebra::{Vector3, Vector6};
use tandem::plant::{ClosedChain, SpatialStart, spatial::SpatialPlant};
use tandem::presets;
use tandem::reference::spatial::path::Se3Path;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{SimParams, Simulation};
use tandem_cli::output::spatial::write;
use tandem_cli::run::spatial::Finished;

mod support;
use support::*;

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

#[test]
fn a_users_drive_gets_the_summary_figures_and_viewer() {
    let s = presets::dual_ur5();
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
        duration: 0.3,
        plant_step: 5e-4,
        log_period: 0.01,
        ..SimParams::paper()
    };
    let sim = Simulation::with_plant(
        plant,
        &start,
        &SensorParams::default(),
        law,
        tandem::model::disturbance::SpatialDisturbance::zero(),
        run,
    )
    .unwrap();
    let (outcome, _) = sim.run(|_| {});
    // The desired path moves 1 cm along x in 50 ms while the law holds the start.
    let (p0, r0) = (s.x_wo.translation.vector, s.x_wo.rotation);
    let path =
        Se3Path::point_to_point(p0, r0, p0 + Vector3::new(0.01, 0.0, 0.0), r0, 0.0, 0.05).unwrap();
    let f = Finished {
        outcome,
        plant: SpatialPlant::new(&s.params).unwrap(),
        box_size: [0.4, 0.2, 0.2],
        path,
        duration: 0.3,
        controller: "hold-pd".into(),
        label: "hold PD".into(),
        k_c: [0.167, 0.167, 0.1, 0.29, 0.29, 0.29],
        chart: Chart::new(p0, r0),
        warnings: Vec::new(),
        contacts: None,
        friction: None,
    };
    let dir = scratch("custom_drive");
    let (summary, _, problems) = write(&dir, "hold", &f, true).unwrap();
    assert!(problems.is_empty(), "{problems:?}");
    let on_disk = read_json(&dir.join("summary.json"));
    assert_eq!(on_disk["label"], "hold PD");
    // Tracking against the desired path: the box stays at the start, 1 cm from the path's end.
    let after = summary["path_error_p_max_after_2s_m"]
        .as_f64()
        .or_else(|| summary["path_error_p_max_m"].as_f64())
        .unwrap();
    assert!((after - 0.01).abs() < 1e-3, "{after}");
    assert_eq!(summary["violation_ticks"], 0);
    assert!(summary["min_margin"].as_f64().unwrap() > 0.9);
    assert!(summary["s5_claims"].is_object(), "{}", summary["s5_claims"]);
    assert_eq!(summary["torque_rate"]["ticks"], 300);
    assert_eq!(
        summary["torque_rate"]["joints"].as_array().unwrap().len(),
        12
    );
    // The law has no z1 or weights of its own: those are null with a reason, never 0.
    assert!(
        summary["unavailable"]
            .as_object()
            .is_some_and(|m| !m.is_empty())
    );
    // The figures a law without z1, a reference or a wrench of its own has: the path (true
    // against desired), the margins to k_c, the grasp wrenches, the joint torques and limits.
    for f in [
        "path",
        "margins",
        "grasp_wrenches",
        "joint_torques",
        "joint_limits",
    ] {
        let (w, h) = check_png(&dir.join(format!("{f}.png")));
        assert!(w >= 800 && h >= 300, "{f}.png is {w}×{h}");
    }
    assert!(dir.join("viewer.html").is_file());
    assert!(fs::metadata(dir.join("timeseries.csv")).unwrap().len() > 1000);
    let _ = fs::remove_dir_all(&dir);
}
