//! Spatial presets end to end: `tandem run dual-ur5` / `dual-franka` (short runs), and the
//! spatial outputs (summary, CSV, figures, comparison) checked against independent computations.

use std::fs;
use std::path::Path;
use std::process::Command;

use nalgebra::DMatrix;
use serde_json::Value;
use tandem::control::law::Law;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem_cli::output::spatial::{self as output, Derived, Finished};

mod support;
use support::*;

/// The figures every NN run writes (PNG and SVG each).
const FIGURES: [&str; 11] = [
    "z1",
    "z2",
    "tracking",
    "path",
    "wrench",
    "grasp_wrenches",
    "internal_wrench",
    "joint_torques",
    "joint_limits",
    "weights",
    "margins",
];

fn run(name: &str, dir: &Path, duration: &str) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["run", name, "--duration", duration, "--out"])
        .arg(dir)
        .output()
        .expect("tandem runs");
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "timeseries.csv",
        "summary.json",
        "viewer.html",
        "snapshot_front.png",
        "snapshot_side.png",
        "snapshot_top.png",
    ] {
        assert!(dir.join(f).is_file(), "{name}: no {f}");
    }
    for f in FIGURES {
        let (w, h) = check_png(&dir.join(format!("{f}.png")));
        assert!(w >= 800 && h >= 300, "{name}: {f}.png is {w}×{h}");
        check_xml(&fs::read_to_string(dir.join(format!("{f}.svg"))).unwrap());
    }
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

fn check(name: &str, s: &Value) {
    assert_eq!(s["status"], "completed", "{name}: {s}");
    assert_eq!(s["violation_ticks"], 0, "{name}: {s}");
    // SPEC-spatial S4: the closed chain's drift stays below 1e-9 m (and rad).
    assert!(s["max_drift_m"].as_f64().unwrap() < 1e-9, "{name}: {s}");
    assert!(s["max_drift_rad"].as_f64().unwrap() < 1e-9, "{name}: {s}");
    // SPEC-spatial S5: ‖z1_p‖ < 1 mm and |z1_φ| < 1 mrad after 2 s, measured and passed.
    let c = &s["s5_claims"];
    assert!(
        c["z1_p_after_2s"]["max_m"].as_f64().unwrap() < 1e-3,
        "{name}: {c}"
    );
    assert!(
        c["z1_rot_after_2s"]["max_rad"].as_f64().unwrap() < 1e-3,
        "{name}: {c}"
    );
    assert_eq!(c["pass"], true, "{name}: {c}");
    assert_eq!(
        s["z1_p_max_after_2s_m"], c["z1_p_after_2s"]["max_m"],
        "{name}: one measurement"
    );
    // An NN run has every metric: nothing is unavailable except possibly weight settling (and
    // the contact pads' record of a welded preset).
    let un = s["unavailable"].as_object().unwrap();
    assert!(
        un.keys()
            .all(|k| k == "weight_settling_time_s.*" || k == "contacts"),
        "{name}: unavailable {un:?}"
    );
    for k in [
        "orientation_error_max_after_2s_rad",
        "wrench_force_rms_N",
        "joint_torque_peak_Nm",
        "q_switch_min",
        "settling_time_1mm_s",
    ] {
        assert!(
            s[k].as_f64().is_some_and(f64::is_finite),
            "{name}: {k} = {}",
            s[k]
        );
    }
    assert_eq!(
        s["jacobian_sigma_min"].as_array().unwrap().len(),
        2,
        "{name}"
    );
    assert!(
        s["closest_joint_limit"]["margin_rad"].as_f64().unwrap() > 0.0,
        "{name}"
    );
    assert!(
        s["timing"]["real_time_factor"].as_f64().unwrap() > 0.0,
        "{name}"
    );
}

/// `summary.json` without its `timing` (wall times differ from run to run).
fn without_timing(dir: &Path) -> Value {
    let mut v: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("timing");
    v
}

/// `timeseries.csv` parses: a `name [unit]` header, one finite number per column on every row.
fn check_csv(name: &str, dir: &Path) {
    let mut r = csv::Reader::from_path(dir.join("timeseries.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    for c in &h {
        assert!(
            c.ends_with(']') && c.contains(" ["),
            "{name}: header {c:?} has no unit"
        );
    }
    for want in [
        "x_d.rz [rad]",
        "x_r.x [m]",
        "z2.rx [rad/s]",
        "F_tool2.tz [N m]",
        "w_int1.fx [N]",
        "tau_q12 [N m]",
        "Q [1]",
        "w_norm.rz [1]",
        "margin [1]",
        "x_1.ry [rad]",
        "qd7 [rad/s]",
        "x_o.qw [1]",
        "w_o.z [rad/s]",
    ] {
        assert!(h.iter().any(|c| c == want), "{name}: no column {want}");
    }
    let mut rows = 0;
    for rec in r.records() {
        let rec = rec.unwrap();
        assert_eq!(rec.len(), h.len(), "{name}: ragged row");
        for v in &rec {
            assert!(v.parse::<f64>().unwrap().is_finite(), "{name}: {v}");
        }
        rows += 1;
    }
    assert!(rows > 100, "{name}: {rows} rows");
}

#[test]
fn presets_meet_the_s5_claims_and_are_deterministic() {
    let tmp = std::env::temp_dir().join(format!("tandem-spatial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    for name in ["dual-ur5", "dual-franka"] {
        let a = tmp.join(format!("{name}-a"));
        let b = tmp.join(format!("{name}-b"));
        // 3 s: the S5 claims are measured from 2 s on.
        let sa = run(name, &a, "3");
        check(name, &sa);
        check_csv(name, &a);
        run(name, &b, "3");
        let mut files: Vec<String> = fs::read_dir(&a)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|f| f != "summary.json")
            .collect();
        files.sort();
        assert!(files.len() >= 2 * FIGURES.len() + 8, "{name}: {files:?}");
        for f in &files {
            assert!(
                fs::read(a.join(f)).unwrap() == fs::read(b.join(f)).unwrap(),
                "{name}: {f} differs between two runs"
            );
        }
        assert_eq!(
            without_timing(&a),
            without_timing(&b),
            "{name}: summary.json differs"
        );
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

#[test]
fn presets_are_listed() {
    let out = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["scenario", "list"])
        .output()
        .unwrap();
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("dual-ur5") && s.contains("dual-franka"), "{s}");
}

/// A finished run of the S6 set-up `setup` with `law` (for the laws no preset runs yet).
fn finished(franka: bool, law: Law<6>, duration: f64) -> Finished {
    let s = if franka {
        tandem::presets::dual_franka()
    } else {
        tandem::presets::dual_ur5()
    };
    let (name, label) = (law.name().to_string(), law.name().to_uppercase());
    let (sim, _) =
        tandem::presets::spatial_s6_simulation(&s.params, &s, law, duration, 1e-3, 1e-6).unwrap();
    let (outcome, sim) = sim.run(|_| {});
    let k = sim.driver().k_c();
    Finished {
        outcome,
        plant: tandem::plant::spatial::SpatialPlant::new(&s.params).unwrap(),
        box_size: [0.4, 0.2, 0.2],
        path: tandem::reference::spatial::path::Se3Path::spec_s6(),
        duration,
        controller: name,
        label,
        k_c: [k[0], k[1], k[2], k[3], k[4], k[5]],
        chart: *sim.driver().chart(),
        warnings: vec![],
        contacts: None,
        friction: None,
    }
}

/// σ_min of each arm's tool Jacobian and the closest approach to a joint limit, recomputed
/// independently on every logged row: the Jacobian's singular values by nalgebra's SVD (the
/// summary uses the eigenvalues of J Jᵀ), the limits straight from the chains.
#[test]
fn sigma_min_and_joint_limit_match_an_independent_computation() {
    for franka in [false, true] {
        let f = tandem_cli::run::spatial::run(if franka { "dual-franka" } else { "dual-ur5" }, 1.0)
            .unwrap();
        let d = Derived::new(&f);
        let s = output::summary("test", &f, &d, None);
        let log = &f.outcome.log;
        let t = log.get("t").unwrap();
        let mut off = 0;
        let mut closest = (f64::INFINITY, String::new(), 0.0);
        for (i, arm) in f.plant.arms().iter().enumerate() {
            let n = arm.chain.dof();
            let mut data = tandem::dynamics::spatial::ChainData::new(arm);
            let (mut best, mut at) = (f64::INFINITY, 0.0);
            for k in 0..log.len() {
                let q: Vec<f64> = (0..n)
                    .map(|j| log.get(&format!("q{}", off + j + 1)).unwrap()[k])
                    .collect();
                tandem::dynamics::spatial::kinematics(arm, &q, None, &mut data);
                let j = DMatrix::from_iterator(6, n, data.J.iter().copied());
                let sv = j.svd(false, false).singular_values;
                let smin = sv.iter().fold(f64::INFINITY, |a, &b| a.min(b));
                if smin < best {
                    (best, at) = (smin, t[k]);
                }
                for (jj, joint) in arm.chain.joints.iter().enumerate() {
                    let m = (q[jj] - joint.limits.lower).min(joint.limits.upper - q[jj]);
                    if m < closest.0 {
                        closest = (m, joint.name.clone(), t[k]);
                    }
                }
            }
            let got = &s["jacobian_sigma_min"][i];
            // Both are double-precision decompositions of the same well-conditioned matrix
            // (σ ≈ 0.1–0.2, σ_max ≈ 1): they agree to ~1e-15; 1e-10 leaves room.
            let g = got["sigma_min"].as_f64().unwrap();
            assert!((g - best).abs() < 1e-10, "arm {}: {g} vs SVD {best}", i + 1);
            assert_eq!(got["t_s"].as_f64().unwrap(), at, "arm {}", i + 1);
            off += n;
        }
        let c = &s["closest_joint_limit"];
        // The same subtraction on the same numbers: exact.
        assert_eq!(c["margin_rad"].as_f64().unwrap(), closest.0, "{c}");
        assert_eq!(c["joint"], closest.1.as_str());
        assert_eq!(c["t_s"].as_f64().unwrap(), closest.2);
    }
}

/// A comparison of NN, PD and computed torque from one start: the report's table has a column
/// per law, `summary.json` is keyed by label, the overlay figures exist, and the laws without a
/// network have `null` weights with a reason and no weight figure.
#[test]
fn compare_writes_report_summary_and_overlays() {
    let runs = [
        tandem_cli::run::spatial::run("dual-ur5", 1.0).unwrap(),
        finished(false, Law::Pd(PdGains::<6>::paper()), 1.0),
        finished(false, Law::Ctc(CtcGains::<6>::default()), 1.0),
    ];
    let labels = ["NN", "PD", "CTC"];
    let pairs: Vec<(&str, &Finished)> = labels.iter().copied().zip(runs.iter()).collect();
    let dir = std::env::temp_dir().join(format!("tandem-spatial-compare-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    let (sums, problems) = output::write_compare(&dir, "dual-ur5", &pairs, true).unwrap();
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(sums.len(), 3);
    let md = fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(md.contains("| metric | NN | PD | CTC |"), "{md}");
    for stem in ["compare_z1", "compare_wrench", "compare_margin"] {
        check_png(&dir.join(format!("{stem}.png")));
        check_xml(&fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap());
        assert!(
            md.contains(&format!("({stem}.png)")),
            "{stem} not in the report"
        );
    }
    let all: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for l in labels {
        let s = &all["runs"][l];
        assert_eq!(s["label"], l);
        let sub = dir.join(s["folder"].as_str().unwrap());
        assert!(sub.join("timeseries.csv").is_file() && sub.join("z1.png").is_file());
        assert_eq!(sub.join("weights.png").is_file(), l == "NN", "{l}");
        if l != "NN" {
            assert!(s["weight_norm_final"].is_null(), "{l}");
            assert!(s["unavailable"]["weight_norm_final"].is_string(), "{l}");
            assert!(s["unavailable"]["q_switch_min"].is_string(), "{l}");
        }
        // The 1 s runs end before the S5 window: null with a reason, and the claim fails.
        assert!(s["z1_p_max_after_2s_m"].is_null(), "{l}");
        assert!(s["unavailable"]["z1_p_max_after_2s_m"].is_string(), "{l}");
        assert_eq!(s["s5_claims"]["pass"], false, "{l}");
    }
    let _ = fs::remove_dir_all(&dir);
}

/// A log without some columns (as a law or a scenario that does not produce them): the summary
/// writes `null` with a reason, never 0 or NaN, and the other outputs are still written.
#[test]
fn absent_columns_are_null_with_a_reason() {
    let mut f = tandem_cli::run::spatial::run("dual-ur5", 2.5).unwrap();
    f.outcome.log.columns.retain(|c| {
        !(c.name.starts_with("z1.")
            || c.name.starts_with("w_int")
            || c.name.starts_with("w_norm")
            || c.name == "angle_error"
            || c.name == "Q")
    });
    let dir = std::env::temp_dir().join(format!("tandem-spatial-absent-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    let (s, _, problems) = output::write(&dir, "absent", &f, true).unwrap();
    assert!(problems.is_empty(), "{problems:?}");
    for k in [
        "z1_p_max_after_2s_m",
        "z1_rot_max_after_2s_rad",
        "settling_time_1mm_s",
        "orientation_error_max_after_2s_rad",
        "internal_wrench",
        "weight_norm_final",
    ] {
        assert!(s[k].is_null(), "{k} = {}", s[k]);
        assert!(s["unavailable"][k].is_string(), "{k}: no reason");
    }
    assert_eq!(s["s5_claims"]["pass"], false);
    // Still there: what does not need the removed columns.
    assert!(s["jacobian_sigma_min"].is_array() && s["wrench_force_rms_N"].is_number());
    assert!(!dir.join("z1.png").exists() && !dir.join("weights.png").exists());
    assert!(dir.join("tracking.png").is_file() && dir.join("timeseries.csv").is_file());
    let _ = fs::remove_dir_all(&dir);
}
