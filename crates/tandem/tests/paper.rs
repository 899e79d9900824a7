//! The paper's claims on the full 90 s scenario (SPEC §4), one test per claim. Long: run with
//! `cargo test --release -- --ignored` (CI does).

use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::ControllerParams;
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::report::planar::{Summary, summarize};
use tandem::sim::{Log, SimParams};

fn paper_run(law: Law<3>) -> (Summary, Log) {
    let name = law.name();
    let cp = ControllerParams::paper(law);
    let (sim, _) =
        presets::paper_simulation(&cp, SimParams::paper(), Disturbance::paper()).unwrap();
    let (out, _) = sim.run(|_| {});
    let s = summarize(&out, name, "", [0.35; 3], 5.0, 90.0);
    println!("{name}: {s:#?}");
    assert!(s.completed, "{name}: {:?}", s.fault);
    (s, out.log)
}

#[test]
#[ignore = "90 s scenario; run with --ignored"]
fn tuned_nn_reproduces_the_papers_claims() {
    let (nn, log) = paper_run(Law::Nn(NnGains::tuned()));
    let (pd, _) = paper_run(Law::Pd(PdGains::<3>::paper()));
    // The object stays inside |x_1j| < 0.35 for the whole run (Fig. 12).
    let worst = ["x_o.x", "x_o.y", "x_o.theta"]
        .iter()
        .map(|c| {
            log.get(c)
                .unwrap()
                .iter()
                .fold(0.0f64, |a, v| a.max(v.abs()))
        })
        .fold(0.0, f64::max);
    assert!(worst < 0.35, "max |x_1j| = {worst}");
    assert_eq!(nn.violations, 0);
    assert_eq!(nn.events.barrier_hits, 0);
    // z1 settles within about 2 s into a small neighbourhood (Figs. 13–14).
    assert!(nn.settling_time_1mm.unwrap() < 2.0);
    assert!(
        nn.rms_z1_after < 1e-4,
        "rms z1 after 5 s {}",
        nn.rms_z1_after
    );
    // Weight norms (Fig. 16): with ϑ² = 50 the basis is nearly constant, so ‖Ŵ_j‖ ≈ |τ_j|/‖S‖
    // follows the load, which changes along the circle; the norms reach the load within about
    // 2 s and then track it — they do not settle to constants (SPEC §3.4). Check: after 2 s the
    // ratio ‖Ŵ_y‖/|τ_y| stays within 10 % of its median.
    let t = log.get("t").unwrap();
    let w = log.get("w_norm.y").unwrap();
    let tau = log.get("tau.y").unwrap();
    let k2 = t.iter().position(|&x| x >= 2.0).unwrap();
    let mut r: Vec<f64> = (k2..t.len()).map(|k| w[k] / tau[k].abs()).collect();
    let ratios = r.clone();
    r.sort_by(f64::total_cmp);
    let med = r[r.len() / 2];
    let worst = ratios
        .iter()
        .map(|x| (x - med).abs() / med)
        .fold(0.0, f64::max);
    println!(
        "‖Ŵ_y‖/|τ_y| after 2 s: median {med:.4e}, worst deviation {:.1} %",
        100.0 * worst
    );
    assert!(
        worst < 0.1,
        "weight norm does not track the load after 2 s ({worst})"
    );
    // The wrench is steadier and not larger than PD's (Figs. 10 vs 15).
    assert!(nn.wrench_roughness < pd.wrench_roughness);
    assert!(nn.peak_wrench <= pd.peak_wrench);
    // PD tracks with a larger error (no gravity compensation).
    assert!(pd.rms_z1_after > 10.0 * nn.rms_z1_after);
}

#[test]
#[ignore = "90 s scenario; run with --ignored"]
fn paper_gains_run_to_the_end_and_respect_the_bound() {
    // Reported as it is (SPEC §3.4): bounded, z1 small, but chattering and a large wrench.
    let (s, _) = paper_run(Law::Nn(NnGains::paper()));
    assert_eq!(s.violations, 0);
    // A chaotic limit cycle: check the RMS, bound the peak loosely (see tests/control.rs).
    assert!(s.rms_z1_after < 1e-3);
    assert!(s.max_z1_after < 3e-3);
    assert!(s.wrench_roughness > 10.0);
}
