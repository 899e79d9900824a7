//! `--controller pd-gravity` (issue 23): PD with the model's gravity on planar and spatial
//! scenarios, the same as `kind = "pd"` with `controller.pd.gravity_compensation = true`. On the
//! paper's arms PD without it sags by `𝓖/K_P` (the 4.2 mm RMS of `z1` after the transient),
//! with it the error is far below a millimetre.

mod support;
use support::*;

#[test]
fn pd_gravity_runs_on_both_kinds() {
    let d = scratch("pd_gravity");
    let o = tandem(
        &d,
        &[
            "run",
            "paper",
            "--controller",
            "pd-gravity",
            "--duration",
            "8",
            "--no-figures",
        ],
    );
    ok(&o);
    let g = read_json(&d.join("out/paper-pd-gravity/summary.json"));
    assert_eq!(g["label"], "PD + gravity");
    let o = tandem(
        &d,
        &[
            "run",
            "paper",
            "--controller",
            "pd",
            "--duration",
            "8",
            "--no-figures",
        ],
    );
    ok(&o);
    let p = read_json(&d.join("out/paper-pd/summary.json"));
    assert_eq!(p["label"], "PD");
    let (eg, ep) = (
        g["rms_z1_after"].as_f64().unwrap(),
        p["rms_z1_after"].as_f64().unwrap(),
    );
    assert!(ep > 3e-3 && eg < 0.1 * ep, "PD {ep} m, PD + gravity {eg} m");

    let o = tandem(
        &d,
        &[
            "run",
            "dual-ur5",
            "--controller",
            "pd-gravity",
            "--duration",
            "0.5",
            "--no-figures",
            "--out",
            "u",
        ],
    );
    ok(&o);
    let u = read_json(&d.join("u/summary.json"));
    assert_eq!(u["label"], "PD + gravity");
    assert_eq!(u["controller"], "pd-gravity");
    // The scenario as run says it, so `tandem run scenario.toml` repeats it.
    let echo = std::fs::read_to_string(d.join("u/scenario.toml")).unwrap();
    assert!(echo.contains("gravity_compensation = true"), "{echo}");
    let _ = std::fs::remove_dir_all(&d);
}
