//! A scenario's controller outside the loop (issue 23): [`standalone::planar`] and
//! [`standalone::spatial`] build the controller `tandem run` builds, so stepped in lockstep with
//! the run's own simulation, fed each tick's readings (encoders and wrists, as the simulation's
//! driver read them), it gives the torques the run applied, bit for bit, for every law. The
//! planar log holds no joint rates, so the planar proof is here (the Python test checks the
//! dual-UR5 case from a logged run).

use tandem_cli::scenario::ControllerChoice as LawName;
use tandem_cli::scenario::standalone::{self, Standalone};
use tandem_cli::scenario::{self, EMBEDDED, Scenario, embedded_source, spatial};

/// An embedded scenario with `(from, to)` text replacements.
fn source(name: &str, edits: &[(&str, &str)]) -> scenario::Source {
    let e = EMBEDDED.iter().find(|e| e.name == name).unwrap();
    let mut src = embedded_source(e);
    for (from, to) in edits {
        assert!(src.text.contains(from), "{from}");
        src.text = src.text.replacen(from, to, 1);
    }
    src
}

/// Step `sim` and `c` together for `ticks` ticks; the largest |τ_standalone − τ_run|.
macro_rules! lockstep {
    ($sim:expr, $c:expr, $ticks:expr, $h:expr) => {{
        let (sim, c): (_, &mut Standalone) = ($sim, $c);
        let s = &c.start;
        let (q0, qd0, w0) = (s.q.clone(), s.qd.clone(), s.wrenches.clone());
        assert_eq!(sim.sensors().q(), &q0[..]);
        assert_eq!(sim.last_sensor_truth(), &w0[..]);
        c.start(0.0, &q0, &qd0, &w0);
        let mut tau = vec![0.0; c.n_q];
        let mut worst: f64 = 0.0;
        for k in 0..$ticks {
            sim.tick(k).unwrap();
            let (q, qd) = (sim.sensors().q().to_vec(), sim.sensors().qd().to_vec());
            let w = sim.last_readings().to_vec();
            c.tick(k as f64 * $h, &q, &qd, &w, &mut tau);
            for (a, b) in tau.iter().zip(sim.applied_torques()) {
                worst = worst.max((a - b).abs());
            }
        }
        worst
    }};
}

#[test]
fn planar_controller_steps_as_the_run_does_every_law_noisy_sensors() {
    // Sensor noise on: the readings the run's driver read are what the controller is given.
    let noise = [
        (
            "[sensors.encoder_q]   # joint angles, rad\nstd_dev = 0.0",
            "[sensors.encoder_q]\nstd_dev = 1e-4",
        ),
        (
            "[sensors.force]       # grasp forces, N\nstd_dev = 0.0",
            "[sensors.force]\nstd_dev = 0.05\ntau = 0.002",
        ),
    ];
    for law in [
        None,
        Some(LawName::Pd),
        Some(LawName::PdGravity),
        Some(LawName::Ctc),
    ] {
        let src = source("paper", &noise);
        let Scenario::Planar(mut sc) = scenario::parse(&src).unwrap() else {
            panic!()
        };
        let mut c = standalone::planar(&sc, &src, law).unwrap();
        // The run with the same law (as `--controller`, and pd-gravity's flag).
        if let Some(l) = law {
            sc.controller.kind = match l {
                LawName::Nn => scenario::ControllerKind::Nn,
                LawName::Pd | LawName::PdGravity => scenario::ControllerKind::Pd,
                LawName::Ctc => scenario::ControllerKind::Ctc,
                LawName::Replay => unreachable!("not a law"),
            };
            if l == LawName::PdGravity {
                sc.controller.pd.gravity_compensation = Some(true);
            }
        }
        let b = scenario::planar::build(&sc, &src).unwrap();
        let mut ready = scenario::planar::make_simulation(&sc, &b, &src).unwrap();
        let h = b.sim.control_period;
        let worst = lockstep!(&mut ready.sim, &mut c, 1500, h);
        assert_eq!(worst, 0.0, "{law:?}");
    }
}

#[test]
fn dual_ur5_controller_steps_as_the_run_does() {
    let src = source("dual-ur5", &[]);
    let Scenario::Spatial(sc) = scenario::parse(&src).unwrap() else {
        panic!()
    };
    let mut c = standalone::spatial(&sc, &src, None).unwrap();
    let b = spatial::build(&sc, &src).unwrap();
    let ready = spatial::make_simulation(&sc, &b, &src).unwrap();
    let spatial::SpatialSim::Control(mut sim) = ready.sim else {
        panic!()
    };
    let h = b.sim.control_period;
    let worst = lockstep!(&mut *sim, &mut c, 300, h);
    assert_eq!(worst, 0.0);
}

#[test]
fn a_replay_is_not_a_controller() {
    let src = source("paper", &[]);
    let Scenario::Planar(mut sc) = scenario::parse(&src).unwrap() else {
        panic!()
    };
    sc.controller.kind = scenario::ControllerKind::Replay;
    let e = standalone::planar(&sc, &src, None).err().unwrap();
    assert!(e.to_string().contains("not a controller"), "{e}");
}
