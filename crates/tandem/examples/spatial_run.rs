//! A closed-loop run of the spatial controller on the SPEC-spatial S6 scenario, through the
//! simulation loop: `cargo run --release -p tandem --example spatial_run -- [nn|pd|ctc]
//! [ur5|franka] [seconds]`. Prints the tracking error every second and the real-time factor
//! (also the target of `valgrind --tool=callgrind` for instruction counts).

use nalgebra::Vector3;
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let law = args.get(1).map_or("nn", String::as_str);
    let franka = args.get(2).is_some_and(|s| s == "franka");
    let duration: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let setup = if franka {
        tandem::presets::dual_franka()
    } else {
        tandem::presets::dual_ur5()
    };
    let law = match law {
        "pd" => Law::Pd(PdGains::<6>::paper()),
        "ctc" => Law::Ctc(CtcGains::<6>::default()),
        _ if franka => Law::Nn(NnGains::dual_franka()),
        _ => Law::Nn(NnGains::dual_ur5()),
    };
    let t0 = std::time::Instant::now();
    let (sim, warnings) =
        tandem::presets::spatial_s6_simulation(&setup.params, &setup, law, duration, 1e-3, 1e-6)
            .expect("simulation");
    println!(
        "set-up {:.3} s; path inertia (chart diagonal) {:.3?}; warnings: {warnings:?}",
        t0.elapsed().as_secs_f64(),
        sim.driver().path_inertia().as_slice()
    );
    let (out, _) = sim.run(|_| {});
    let log = &out.log;
    let t = log.get("t").unwrap();
    let g = |n: &str| log.get(n).unwrap();
    for k in (0..log.len()).step_by(100) {
        let zp = Vector3::new(g("z1.x")[k], g("z1.y")[k], g("z1.z")[k]).norm();
        let zr = Vector3::new(g("z1.rx")[k], g("z1.ry")[k], g("z1.rz")[k]).norm();
        println!(
            "t = {:5.2} s  ‖z1_p‖ = {:9.3e} m  |z1_φ| = {:9.3e} rad  Q = {:.3}  margin = {:.3}",
            t[k],
            zp,
            zr,
            g("Q")[k],
            g("margin")[k]
        );
    }
    println!(
        "{duration} s simulated in {:.3} s: {:.1}× real time ({:.1} µs per 1 ms tick); fault {:?}; events {:?}; drift {:.2e} m, {:.2e} rad",
        out.wall_time,
        duration / out.wall_time,
        out.wall_time / out.ticks as f64 * 1e6,
        out.fault,
        out.events,
        out.max_drift,
        out.max_drift_rot
    );
}
