//! Spatial presets end to end: `tandem run dual-ur5` / `dual-franka` (short runs).

use std::path::Path;
use std::process::Command;

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
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

fn check(name: &str, s: &serde_json::Value) {
    assert_eq!(s["status"], "completed", "{name}: {s}");
    assert_eq!(s["violation_ticks"], 0, "{name}: {s}");
    assert!(s["max_drift_m"].as_f64().unwrap() < 1e-9, "{name}: {s}");
    // SPEC-spatial S5: ‖z1_p‖ < 1 mm and |z1_φ| < 1 mrad after 2 s.
    assert!(
        s["z1_p_max_after_2s_m"].as_f64().unwrap() < 1e-3,
        "{name}: {s}"
    );
    assert!(
        s["z1_rot_max_after_2s_rad"].as_f64().unwrap() < 1e-3,
        "{name}: {s}"
    );
}

#[test]
fn presets_meet_the_s5_claims_and_are_deterministic() {
    let tmp = std::env::temp_dir().join(format!("tandem-spatial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    for name in ["dual-ur5", "dual-franka"] {
        let a = tmp.join(format!("{name}-a"));
        let b = tmp.join(format!("{name}-b"));
        let sa = run(name, &a, "4");
        check(name, &sa);
        run(name, &b, "4");
        for f in [
            "timeseries.csv",
            "viewer.html",
            "snapshot_front.png",
            "summary.json",
        ] {
            assert!(
                std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(),
                "{name}: {f} differs between two runs"
            );
        }
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
