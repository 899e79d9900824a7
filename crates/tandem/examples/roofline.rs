//! `N` calls of one hot kernel, for operation counts (`docs/performance.md`, roofline table):
//! `valgrind --tool=lackey --detailed-counts=yes target/release/examples/roofline KERNEL N`
//! with `N = 0` and `N = 1000`; the difference over 1000 is the count per call.
//!
//! `KERNEL`: `rbf` (the controller's RBF pass, 4096 × 3, `tick_at_outputs`), `planar` (the
//! constrained derivative of the paper's two 2-link arms), `spatial` (the dual-UR5 welded
//! closed-chain derivative).
use nalgebra::{Vector3, Vector6};
use std::hint::black_box;
use tandem::control::rbf::{NnUpdate, Rbf, RbfNetwork};
use tandem::plant::planar::Plant;
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kernel = args.get(1).map_or("rbf", String::as_str);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let t0 = std::time::Instant::now();
    match kernel {
        "rbf" => {
            let rbf = Rbf::paper();
            let mut ws = rbf.workspace();
            let upd = NnUpdate::new(
                Vector3::new(120.0, 150.0, 120.0),
                Vector3::repeat(0.001),
                1e-3,
            )
            .expect("valid update");
            let mut net = RbfNetwork::<3>::for_basis(&rbf).expect("valid network");
            let mut z = [0.0; 12];
            for k in 0..n {
                z[0] = 0.19 + 1e-4 * k as f64;
                let z2 = Vector3::new(0.01, -0.02, 0.005);
                black_box(net.tick_at_outputs(&rbf, black_box(&z), &mut ws, 1.0, &z2, &upd));
            }
        }
        "planar" => {
            let plant = Plant::new(&presets::paper()).expect("paper plant");
            let y = plant
                .initial_state(presets::paper_start(), Vector3::new(0.01, 0.02, 0.0), None)
                .expect("initial state");
            let mut ws = plant.workspace();
            let mut input = plant.zero_input();
            input.tau.copy_from_slice(&[5.0, 1.5, -1.0, -0.2]);
            let mut dy = vec![0.0; plant.state_dim()];
            for _ in 0..n {
                black_box(plant.derivative(black_box(&y), &input, &mut ws, &mut dy));
            }
        }
        "spatial" => {
            let s = presets::dual_ur5();
            let plant = SpatialPlant::new(&s.params).expect("dual UR5 plant");
            let twist = Vector6::new(0.02, -0.01, 0.03, 0.1, -0.05, 0.2);
            let y = plant
                .initial_state(&s.x_wo, &twist, &s.q_guess)
                .expect("initial state");
            let mut ws = plant.workspace();
            let mut input = plant.zero_input();
            for (k, t) in input.tau.iter_mut().enumerate() {
                *t = (k as f64 * 0.9).sin() * 10.0;
            }
            let mut dy = vec![0.0; plant.state_dim()];
            // Two states, alternated: the workspace reuses the state-only part of the last
            // evaluation when the state is unchanged (a cache this count must not hit).
            let mut y2 = y.clone();
            y2[0] += 1e-9;
            for k in 0..n {
                let yk = if k % 2 == 0 { &y } else { &y2 };
                assert!(plant.derivative(black_box(yk), &input, &mut ws, &mut dy));
            }
        }
        other => {
            eprintln!("unknown kernel `{other}`; valid: rbf, planar, spatial");
            std::process::exit(2);
        }
    }
    if n > 0 {
        let ns = t0.elapsed().as_secs_f64() * 1e9 / n as f64;
        println!("{kernel}: {n} calls, {ns:.0} ns a call (wall clock, set-up included)");
    }
}
