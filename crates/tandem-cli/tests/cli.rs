//! End-to-end tests of the `tandem` binary: outputs exist and parse, agree with each other, are
//! deterministic, and bad input is reported with the place, a suggestion and exit code 2.
//!
//! Every run is short (1–2 simulated seconds) so that the whole file takes a few seconds.

use std::fs;

mod support;
use support::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn run_writes_every_output_and_they_agree() {
    let d = scratch("run");
    let o = tandem(&d, &["run", "--duration", "2", "--out", "res"]);
    ok(&o);
    let res = d.join("res");
    assert!(stdout(&o).contains("RMS ‖z1_xy‖"), "{}", stdout(&o));

    // Time series: units in the header, one row per log period.
    let (h, cols) = read_csv(&res.join("timeseries.csv"));
    for name in [
        "t [s]",
        "x_o.x [m]",
        "x_o.theta [rad]",
        "z1.x [m]",
        "z2.x [m/s]",
        "tau.theta [N m]",
        "w_norm.x [1]",
        "tau_q4 [N m]",
        "F2.y [N]",
        "Q [1]",
        "margin [1]",
    ] {
        assert!(h.iter().any(|n| n == name), "missing `{name}` in {h:?}");
    }
    let t = column(&h, &cols, "t [s]");
    assert_eq!(t.len(), 67, "2 s at 0.03 s: rows at 0, 0.03, …, 1.98");

    // The summary agrees with the time series.
    let s = read_json(&res.join("summary.json"));
    assert_eq!(s["scenario"], "paper");
    assert_eq!(s["controller"], "nn");
    assert_eq!(s["gains"], "tuned");
    assert_eq!(s["seed"], 0);
    assert_eq!(s["completed"], true);
    assert!(s["fault"].is_null());
    assert!(s["tandem_version"].is_string());
    let kernel = s["rbf_kernel"].as_str().expect("rbf_kernel");
    assert!(
        tandem::control::rbf::Kernel::parse(kernel).is_ok(),
        "{kernel}"
    );
    assert!(s["timing"]["wall_time"].is_number());
    let (zx, zy) = (column(&h, &cols, "z1.x [m]"), column(&h, &cols, "z1.y [m]"));
    let e: Vec<f64> = zx.iter().zip(zy).map(|(a, b)| a.hypot(*b)).collect();
    let max = e.iter().fold(0.0f64, |a, b| a.max(*b));
    let rms = (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    assert!(close(max, s["max_z1"].as_f64().expect("max_z1"), 1e-12));
    assert!(close(rms, s["rms_z1"].as_f64().expect("rms_z1"), 1e-12));
    let (xo, yo) = (
        column(&h, &cols, "x_o.x [m]"),
        column(&h, &cols, "x_o.y [m]"),
    );
    let th = column(&h, &cols, "x_o.theta [rad]");
    let margin = (0..t.len())
        .map(|k| {
            [xo[k], yo[k], th[k]]
                .iter()
                .fold(f64::INFINITY, |m, v| m.min(1.0 - v.abs() / 0.35))
        })
        .fold(f64::INFINITY, f64::min);
    // The summary's margin is taken over every control tick, the CSV's over the logged rows:
    // never larger, and close (the pose moves < 1 mm between rows here).
    let sm = s["min_margin"].as_f64().expect("min_margin");
    assert!(
        sm <= margin + 1e-12 && margin - sm < 1e-2,
        "summary {sm} vs CSV {margin}"
    );
    let peak = (1..=4)
        .flat_map(|k| column(&h, &cols, &format!("tau_q{k} [N m]")).iter())
        .fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(close(
        peak,
        s["peak_joint_torque"].as_f64().expect("peak"),
        1e-12
    ));

    // The resolved scenario parses and validates.
    let sc = fs::read_to_string(res.join("scenario.toml")).expect("scenario.toml");
    let v: toml::Table = toml::from_str(&sc).expect("scenario.toml is TOML");
    assert_eq!(v["controller"]["kind"].as_str(), Some("nn"));
    assert_eq!(v["run"]["duration"].as_float(), Some(2.0));
    ok(&tandem(&d, &["validate", "res/scenario.toml"]));

    // Figures: PNG and SVG of each; the animation.
    for stem in [
        "xy_path",
        "trajectories",
        "z1",
        "z2",
        "wrench",
        "weights",
        "grasp_forces",
        "joint_torques",
        "switching",
    ] {
        let png = fs::read(res.join(format!("{stem}.png"))).expect("png");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{stem}.png signature");
        let svg = fs::read_to_string(res.join(format!("{stem}.svg"))).expect("svg");
        assert!(svg.contains("<svg"), "{stem}.svg has no <svg> root");
        assert!(
            svg.trim_end().ends_with("</svg>"),
            "{stem}.svg is truncated"
        );
    }
    let anim = fs::read_to_string(res.join("animation.svg")).expect("animation");
    assert!(anim.contains("<svg") && anim.contains("<animate"));
    // Nothing else is left behind (no temporary folders).
    let names: Vec<String> = fs::read_dir(&d)
        .expect("ls")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["res".to_string()], "{names:?}");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn same_seed_gives_identical_outputs() {
    let d = scratch("determinism");
    // The lemniscate scenario has noisy sensors, so the seed matters.
    let args = |out: &'static str, seed: &'static str| {
        vec![
            "run",
            "lemniscate",
            "--duration",
            "1",
            "--no-figures",
            "--seed",
            seed,
            "--out",
            out,
        ]
    };
    ok(&tandem(&d, &args("a", "7")));
    ok(&tandem(&d, &args("b", "7")));
    ok(&tandem(&d, &args("c", "8")));
    let read = |p: &str| fs::read(d.join(p)).expect("read");
    assert!(
        read("a/timeseries.csv") == read("b/timeseries.csv"),
        "same seed, different time series"
    );
    assert!(read("a/scenario.toml") == read("b/scenario.toml"));
    let strip = |p: &str| {
        let mut v = read_json(&d.join(p));
        v.as_object_mut().expect("object").remove("timing");
        serde_json::to_string_pretty(&v).expect("json")
    };
    assert_eq!(strip("a/summary.json"), strip("b/summary.json"));
    assert!(
        read("a/timeseries.csv") != read("c/timeseries.csv"),
        "another seed should change the noisy run"
    );
    // The resolved scenario reproduces the run.
    ok(&tandem(
        &d,
        &["run", "a/scenario.toml", "--no-figures", "--out", "r"],
    ));
    assert!(read("a/timeseries.csv") == read("r/timeseries.csv"));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn existing_output_folder_is_refused_without_force() {
    let d = scratch("force");
    let args = [
        "run",
        "--controller",
        "pd",
        "--duration",
        "1",
        "--no-figures",
        "--out",
        "res",
    ];
    ok(&tandem(&d, &args));
    let before = fs::read(d.join("res/summary.json")).expect("summary");
    let o = tandem(&d, &args);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("exists") && e.contains("--force"), "{e}");
    assert!(
        e.contains("tandem run --controller pd --duration 1 --no-figures --out res --force"),
        "the exact re-run command: {e}"
    );
    assert_eq!(
        fs::read(d.join("res/summary.json")).expect("summary"),
        before
    );
    let mut forced = args.to_vec();
    forced.push("--force");
    ok(&tandem(&d, &forced));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn misspelled_field_is_located_with_a_suggestion() {
    let d = scratch("typo");
    paper_with(
        &d,
        "typo.toml",
        &[("mass = 0.85 ", "masss = 0.85")], // arm 1, link 2
    );
    for cmd in ["validate", "run"] {
        let o = tandem(&d, &[cmd, "typo.toml"]);
        assert_eq!(code(&o), 2, "{cmd}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("typo.toml"), "{e}");
        assert!(
            e.contains("unknown field `masss` at arms[0].links[1] (line"),
            "{e}"
        );
        assert!(e.contains("did you mean `mass`?"), "{e}");
    }
    assert!(
        !d.join("out").exists(),
        "a bad scenario must not create outputs"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn bad_values_name_the_field() {
    let d = scratch("values");
    let cases: [(&str, &str, &str, &str); 5] = [
        (
            "mass = 0.85 ",
            "mass = -0.85",
            "arms[0].links[1].mass = -0.85",
            "must be finite and > 0",
        ),
        (
            "control_period = 0.001 ",
            "control_period = 0.0015",
            "run.control_period = 0.0015",
            "whole multiple of plant_step",
        ),
        (
            "log_period = 0.03 ",
            "log_period = 0.0305",
            "run.log_period = 0.0305",
            "whole multiple of control_period",
        ),
        (
            "kind = \"circle\"",
            "kind = \"circel\"",
            "path.kind",
            "did you mean \"circle\"?",
        ),
        (
            "k_c = [0.35, 0.35, 0.35]",
            "k_c = [0.15, 0.35, 0.35]",
            "controller.k_c[0] = 0.15",
            "largest excursion",
        ),
    ];
    for (i, (from, to, path, why)) in cases.iter().enumerate() {
        let f = format!("bad{i}.toml");
        paper_with(&d, &f, &[(from, to)]);
        let o = tandem(&d, &["validate", &f]);
        assert_eq!(code(&o), 2, "{f}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(&format!("{f}: ")), "{e}");
        assert!(e.contains(path), "`{path}` not in: {e}");
        assert!(e.contains(why), "`{why}` not in: {e}");
        assert!(e.contains("(line "), "no line in: {e}");
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn validate_accepts_embedded_scenarios_and_suggests_names() {
    let d = scratch("validate");
    for name in ["paper", "push", "lemniscate"] {
        let o = tandem(&d, &["validate", name]);
        ok(&o);
        assert!(stdout(&o).starts_with("ok"), "{}", stdout(&o));
    }
    let o = tandem(&d, &["validate", "papr"]);
    assert_eq!(code(&o), 2);
    assert!(
        stderr(&o).contains("did you mean `paper`?"),
        "{}",
        stderr(&o)
    );
    let o = tandem(&d, &["scenario", "list"]);
    ok(&o);
    assert!(stdout(&o).contains("paper") && stdout(&o).contains("lemniscate"));
    // The shown scenario is a valid file of its own.
    let p = paper_with(&d, "copy.toml", &[]);
    ok(&tandem(&d, &["validate", p.to_str().expect("path")]));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn compare_writes_a_report_with_all_four_controllers() {
    let d = scratch("compare");
    let o = tandem(&d, &["compare", "--duration", "1", "--out", "cmp"]);
    ok(&o);
    let cmp = d.join("cmp");
    let report = fs::read_to_string(cmp.join("report.md")).expect("report.md");
    for label in ["PD", "NN (paper)", "NN (tuned)", "CTC"] {
        assert!(report.contains(&format!("| {label} ")), "{label} missing");
        assert!(stdout(&o).contains(label));
    }
    for stem in [
        "compare_xy",
        "compare_trajectories",
        "compare_z1",
        "compare_wrench",
        "compare_margin",
    ] {
        assert!(report.contains(&format!("({stem}.png)")), "{stem} link");
        let png = fs::read(cmp.join(format!("{stem}.png"))).expect("png");
        assert_eq!(&png[..4], b"\x89PNG");
    }
    let s = read_json(&cmp.join("summary.json"));
    for slug in ["pd", "nn-paper", "nn-tuned", "ctc"] {
        assert_eq!(s["runs"][slug]["completed"], true, "{slug}");
        assert!(cmp.join(slug).join("timeseries.csv").is_file());
    }
    // One common start.
    for slug in ["pd", "nn-paper", "nn-tuned", "ctc"] {
        let (h, cols) = read_csv(&cmp.join(slug).join("timeseries.csv"));
        assert_eq!(column(&h, &cols, "x_o.x [m]")[0], 0.19, "{slug}");
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn replaying_a_runs_torques_reproduces_its_motion() {
    let d = scratch("replay");
    // Log every control tick, so that the logged torques are exactly the applied ones.
    paper_with(
        &d,
        "fine.toml",
        &[("log_period = 0.03 ", "log_period = 0.001")],
    );
    let common = ["--duration", "1", "--no-figures"];
    let mut a = vec!["run", "fine.toml", "--controller", "pd", "--out", "pd"];
    a.extend(common);
    ok(&tandem(&d, &a));
    let mut b = vec![
        "run",
        "fine.toml",
        "--replay",
        "pd/timeseries.csv",
        "--out",
        "re",
    ];
    b.extend(common);
    ok(&tandem(&d, &b));
    let (ha, ca) = read_csv(&d.join("pd/timeseries.csv"));
    let (hb, cb) = read_csv(&d.join("re/timeseries.csv"));
    assert_eq!(ca[0].len(), 1000);
    assert_eq!(cb[0].len(), 1000);
    for name in ["x_o.x [m]", "x_o.y [m]", "x_o.theta [rad]", "F1.x [N]"] {
        let (x, y) = (column(&ha, &ca, name), column(&hb, &cb, name));
        let err = x
            .iter()
            .zip(y)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(err <= 1e-9, "{name}: replay differs by {err}");
    }
    let s = read_json(&d.join("re/summary.json"));
    assert_eq!(s["controller"], "replay");

    // A plain `t,tau1,…` table (columns by name, any order) works too: the same torques, the
    // same motion.
    let mut plain = String::from("t,tau1,tau2,tau3,tau4\n");
    let tau: Vec<&[f64]> = (1..=4)
        .map(|k| column(&ha, &ca, &format!("tau_q{k} [N m]")))
        .collect();
    for (r, t) in column(&ha, &ca, "t [s]").iter().enumerate() {
        let row: Vec<String> = tau.iter().map(|c| format!("{:e}", c[r])).collect();
        plain.push_str(&format!("{t:e},{}\n", row.join(",")));
    }
    fs::write(d.join("plain.csv"), plain).expect("write");
    let mut p = vec![
        "run",
        "fine.toml",
        "--replay",
        "plain.csv",
        "--out",
        "plain",
    ];
    p.extend(common);
    ok(&tandem(&d, &p));
    let (hp, cp) = read_csv(&d.join("plain/timeseries.csv"));
    let (x, y) = (column(&ha, &ca, "x_o.x [m]"), column(&hp, &cp, "x_o.x [m]"));
    let err = x
        .iter()
        .zip(y)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(err <= 1e-9, "plain table: replay differs by {err}");

    // A file with the wrong number of joints is bad input.
    fs::write(d.join("short.csv"), "t,tau1\n0,1\n").expect("write");
    let o = tandem(&d, &["validate", "fine.toml"]);
    ok(&o);
    let mut s = vec![
        "run",
        "fine.toml",
        "--replay",
        "short.csv",
        "--out",
        "short",
    ];
    s.extend(common);
    let o = tandem(&d, &s);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("4 joints"), "{}", stderr(&o));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_run_fault_writes_its_outputs_and_exits_1() {
    let d = scratch("fault");
    // The paper's first-order admittance on the raw force diverges within milliseconds (SPEC §3.1).
    paper_with(
        &d,
        "first_order.toml",
        &[
            ("m_e = 200.0", "m_e = 0.0"),
            ("tau_f = 0.01 ", "tau_f = 0.0 "),
        ],
    );
    let o = tandem(
        &d,
        &[
            "run",
            "first_order.toml",
            "--controller",
            "pd",
            "--duration",
            "1",
            "--out",
            "f",
        ],
    );
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    assert!(stderr(&o).contains("first-order"), "the set-up warning");
    let s = read_json(&d.join("f/summary.json"));
    assert_eq!(s["completed"], false);
    assert!(s["fault"]["kind"].is_string(), "{s}");
    assert!(s["fault_message"].is_string());
    assert!(d.join("f/timeseries.csv").is_file());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_resolved_scenario_still_switches_the_gain_preset() {
    // Regression: `scenario.toml` used to spell out the preset's values as overrides, so
    // `--gains paper` (and compare's paper column) ran the tuned gains again.
    let d = scratch("preset");
    ok(&tandem(
        &d,
        &["run", "--duration", "2", "--no-figures", "--out", "tuned"],
    ));
    ok(&tandem(
        &d,
        &[
            "run",
            "tuned/scenario.toml",
            "--gains",
            "paper",
            "--duration",
            "2",
            "--no-figures",
            "--out",
            "paper",
        ],
    ));
    let t = read_json(&d.join("tuned/summary.json"));
    let p = read_json(&d.join("paper/summary.json"));
    assert_eq!(p["gains"], "paper", "{}", p["gains"]);
    assert_eq!(
        p["scenario"], "paper",
        "the resolved file keeps its scenario's name"
    );
    let (a, b) = (t["rms_z1"].as_f64().unwrap(), p["rms_z1"].as_f64().unwrap());
    assert!(
        (a - b).abs() > 1e-6,
        "paper and tuned gains gave the same run ({a} vs {b})"
    );
    let _ = fs::remove_dir_all(&d);
}
