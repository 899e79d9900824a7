//! Regression tests of the hardening issue: one test per reported defect, named after it, plus
//! the classes found on the way. Every run is short (at most a few simulated seconds).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod support;
use support::*;

/// Every file under `dir` with its content (sorted), to compare a tree before and after.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).expect("read_dir").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), fs::read(&p).expect("read")));
            }
        }
    }
    out.sort();
    out
}

const SHORT: [&str; 5] = ["--duration", "0.2", "--no-figures", "--controller", "pd"];

// ---------------------------------------------------------------------------------------------
// 1. --force replaces only folders tandem wrote.

#[test]
fn force_never_deletes_the_scenario_file() {
    let d = scratch("force-scenario");
    let s = paper_with(&d, "my.toml", &[]);
    let before = tree(&d);
    let mut args = vec!["run", "my.toml", "--out", "my.toml", "--force"];
    args.extend(SHORT);
    let o = tandem(&d, &args);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("is the input file my.toml"),
        "{}",
        stderr(&o)
    );
    assert!(s.is_file());
    assert_eq!(tree(&d), before, "nothing changed");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn force_never_deletes_the_working_folder() {
    let d = scratch("force-cwd");
    let here = d.join("here");
    fs::create_dir(&here).expect("mkdir");
    paper_with(&here, "s.toml", &[]);
    // Even a marker does not make the current folder (or a parent) replaceable.
    fs::write(here.join(".tandem-output"), "").expect("marker");
    let before = tree(&d);
    for out in ["../here", ".", ".."] {
        let mut args = vec!["run", "s.toml", "--out", out, "--force"];
        args.extend(SHORT);
        let o = tandem(&here, &args);
        exit(&o, 2);
        assert!(
            stderr(&o).contains("current folder"),
            "{out}: {}",
            stderr(&o)
        );
    }
    assert_eq!(tree(&d), before, "nothing changed");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn force_never_turns_a_file_into_a_folder() {
    let d = scratch("force-file");
    fs::write(d.join("notes.txt"), "mine").expect("write");
    let mut args = vec!["run", "--out", "notes.txt", "--force"];
    args.extend(SHORT);
    let o = tandem(&d, &args);
    exit(&o, 2);
    assert!(stderr(&o).contains("is a file"), "{}", stderr(&o));
    assert_eq!(
        fs::read_to_string(d.join("notes.txt")).expect("read"),
        "mine"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn force_never_deletes_a_folder_tandem_did_not_write() {
    let d = scratch("force-foreign");
    fs::create_dir(d.join("photos")).expect("mkdir");
    fs::write(d.join("photos/cat.jpg"), "meow").expect("write");
    let before = tree(&d);
    for cmd in ["run", "compare"] {
        let mut args = vec![cmd, "--out", "photos", "--force", "--duration", "0.2"];
        args.push("--no-figures");
        let o = tandem(&d, &args);
        exit(&o, 2);
        assert!(stderr(&o).contains(".tandem-output"), "{}", stderr(&o));
    }
    assert_eq!(tree(&d), before, "nothing changed");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn force_never_deletes_a_folder_holding_the_scenario_or_replay() {
    let d = scratch("force-holds");
    // A tandem output folder, with the user's edited scenario saved inside it.
    let mut args = vec!["run", "--out", "res"];
    args.extend(SHORT);
    exit(&tandem(&d, &args), 0);
    paper_with(&d.join("res"), "edited.toml", &[]);
    let before = tree(&d);
    let mut args = vec!["run", "res/edited.toml", "--out", "res", "--force"];
    args.extend(SHORT);
    let o = tandem(&d, &args);
    exit(&o, 2);
    assert!(stderr(&o).contains("input file"), "{}", stderr(&o));
    // Replaying the folder's own torques into it would delete the replayed file.
    let o = tandem(
        &d,
        &[
            "run",
            "--replay",
            "res/timeseries.csv",
            "--out",
            "res",
            "--force",
            "--duration",
            "0.1",
            "--no-figures",
        ],
    );
    exit(&o, 2);
    assert!(stderr(&o).contains("input file"), "{}", stderr(&o));
    assert_eq!(tree(&d), before, "nothing changed");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn force_replaces_a_folder_tandem_wrote() {
    let d = scratch("force-ok");
    let mut args = vec!["run", "--out", "res"];
    args.extend(SHORT);
    exit(&tandem(&d, &args), 0);
    assert!(d.join("res/.tandem-output").is_file(), "marker written");
    fs::write(d.join("res/stale.txt"), "old").expect("write");
    args.push("--force");
    exit(&tandem(&d, &args), 0);
    assert!(!d.join("res/stale.txt").exists(), "replaced whole");
    assert!(d.join("res/summary.json").is_file());
    let names: Vec<String> = fs::read_dir(&d)
        .expect("ls")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["res"], "no temporary folder left: {names:?}");
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// 2. Bounded work for every input.

/// Run the binary in `cwd`, killing it (and failing) if it takes more than `secs` seconds.
fn tandem_within(cwd: &Path, args: &[&str], secs: f64) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn tandem");
    let t0 = std::time::Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if t0.elapsed().as_secs_f64() > secs {
            let _ = child.kill();
            let _ = child.wait();
            panic!("tandem {args:?} did not return within {secs} s");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

#[test]
fn validate_returns_for_a_circle_or_lemniscate_with_a_huge_phase() {
    let d = scratch("phase");
    for phase in [
        "1e20",
        "-1e308",
        "9223372036854775807.0",
        "9.223372036854775807e18",
    ] {
        paper_with(
            &d,
            "circle.toml",
            &[("phase = 0.0           #", &format!("phase = {phase} #"))],
        );
        paper_with(
            &d,
            "lem.toml",
            &[
                ("kind = \"circle\"", "kind = \"lemniscate\""),
                ("radius = 0.2", "size = 0.2"),
                ("phase = 0.0           #", &format!("phase = {phase} #")),
            ],
        );
        for f in ["circle.toml", "lem.toml"] {
            let o = tandem_within(&d, &["validate", f], 10.0);
            exit(&o, 2);
            let e = stderr(&o);
            assert!(
                e.contains("path.phase") && e.contains("line 90"),
                "{f} {phase}: {e}"
            );
        }
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn duration_1e9_is_refused_at_validation_not_allocated() {
    let d = scratch("duration");
    paper_with(&d, "long.toml", &[("duration = 90.0", "duration = 1e9")]);
    let o = tandem_within(&d, &["validate", "long.toml"], 10.0);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("run.duration = 1e9") && e.contains("1.000e12 control ticks"),
        "{e}"
    );
    // Within the tick limit, but a log of 1.5 GB: refused with the size and the remedy.
    paper_with(&d, "log.toml", &[("duration = 90.0", "duration = 1e5")]);
    for args in [
        &["validate", "log.toml"][..],
        &["run", "log.toml", "--no-figures"][..],
        &["run", "--duration", "1e5"][..],
    ] {
        let o = tandem_within(&d, args, 10.0);
        exit(&o, 2);
        let e = stderr(&o);
        assert!(
            e.contains("run.duration = 100000:")
                && e.contains("3333335 rows")
                && e.contains("GB, more than the 0.5 GB limit")
                && e.contains("raise the log period to at least 9.000e-2 s"),
            "{args:?}: {e}"
        );
    }
    assert!(!d.join("out").exists(), "nothing written");
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// 4. Non-finite values are faults; missing metrics are null with a reason.

/// No NaN or infinity anywhere in a CSV file or in a JSON file's text.
fn assert_all_finite(dir: &Path) {
    let csv = fs::read_to_string(dir.join("timeseries.csv")).expect("csv");
    for (i, line) in csv.lines().enumerate().skip(1) {
        for cell in line.split(',') {
            let v: f64 = cell
                .parse()
                .unwrap_or_else(|_| panic!("line {i}: `{cell}`"));
            assert!(v.is_finite(), "timeseries.csv line {}: {cell}", i + 1);
        }
    }
    let json = fs::read_to_string(dir.join("summary.json")).expect("json");
    for bad in ["NaN", "Infinity", "inf"] {
        assert!(!json.contains(bad), "summary.json has {bad}");
    }
}

/// The paper scenario with the force sensor's noise `std_dev` set to `sd`.
fn with_force_noise(dir: &Path, sd: &str) -> PathBuf {
    let mut text = paper_text(dir);
    let i = text.find("[sensors.force]").expect("force section");
    let j = i + text[i..].find("std_dev = 0.0").expect("std_dev");
    text.replace_range(j..j + "std_dev = 0.0".len(), &format!("std_dev = {sd}"));
    let p = dir.join("noisy.toml");
    fs::write(&p, text).expect("write");
    p
}

#[test]
fn huge_force_sensor_noise_is_a_fault_never_nan_in_the_csv() {
    let d = scratch("noise");
    for sd in ["1.7e308", "1e300", "1e150"] {
        with_force_noise(&d, sd);
        let out = format!("o{sd}");
        let o = tandem(
            &d,
            &["run", "noisy.toml", "--duration", "0.3", "--out", &out],
        );
        exit(&o, 1);
        let e = stderr(&o);
        assert!(e.contains("became non-finite at t = "), "{sd}: {e}");
        assert!(e.contains("last good state x_o = (0.19000, "), "{e}");
        let dir = d.join(&out);
        assert_all_finite(&dir);
        let s = read_json(&dir.join("summary.json"));
        assert_eq!(s["completed"], false, "{sd}");
        let kind = s["fault"]["kind"].as_str().unwrap_or("");
        assert!(kind.starts_with("non_finite"), "{sd}: {kind}");
        assert!(
            s["fault_message"]
                .as_str()
                .unwrap_or("")
                .contains("non-finite")
        );
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn gravity_1e308_is_a_validation_error_never_nan_forces() {
    let d = scratch("gravity");
    paper_with(&d, "g.toml", &[("gravity = 9.8 ", "gravity = 1e308 ")]);
    let o = tandem(&d, &["run", "g.toml", "--duration", "0.2", "--no-figures"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("plant.gravity") && e.contains("line 75"), "{e}");
    assert!(!d.join("out").exists());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn metrics_that_do_not_exist_are_null_with_a_reason_never_0() {
    let d = scratch("metrics");
    // 0.3 s: nothing after the 5 s transient; PD has no weights.
    let o = tandem(
        &d,
        &[
            "run",
            "--controller",
            "pd",
            "--duration",
            "0.3",
            "--no-figures",
            "--out",
            "pd",
        ],
    );
    exit(&o, 0);
    let s = read_json(&d.join("pd/summary.json"));
    let why = &s["unavailable"];
    for k in ["rms_z1_after", "max_z1_after", "max_z1_theta_after"] {
        assert!(s[k].is_null(), "{k} = {}", s[k]);
        assert!(
            why[k].as_str().unwrap_or("").starts_with("run too short"),
            "{k}: {why}"
        );
    }
    assert!(s["final_weight_norms"].is_null());
    assert!(
        why["final_weight_norms"]
            .as_str()
            .unwrap_or("")
            .contains("no NN weights")
    );
    assert!(s["rms_z1"].as_f64().expect("exists") > 0.0);
    // A replay has no commanded wrench.
    let o = tandem(
        &d,
        &[
            "run",
            "--replay",
            "pd/timeseries.csv",
            "--duration",
            "0.3",
            "--no-figures",
            "--out",
            "rp",
        ],
    );
    exit(&o, 0);
    let s = read_json(&d.join("rp/summary.json"));
    for k in ["rms_wrench", "peak_wrench", "wrench_roughness"] {
        assert!(s[k].is_null(), "{k} = {}", s[k]);
        assert!(
            s["unavailable"][k]
                .as_str()
                .unwrap_or("")
                .contains("replay"),
            "{k}"
        );
    }
    // Every null of the summary has a reason.
    for (k, v) in s.as_object().expect("object") {
        if v.is_null() && k != "fault" && k != "fault_message" {
            assert!(
                s["unavailable"].get(k).is_some(),
                "{k} is null without a reason"
            );
        }
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn fault_message_prints_a_diverged_state_readably() {
    use tandem::sim::{Fault, FaultKind};
    let f = Fault {
        t: 0.006,
        kind: FaultKind::NonFinite,
        x_o: vec![1.7e96, -3.0e300, 0.25],
        q: vec![1e300, 0.5, -2e-9, 0.0],
    };
    let s = f.to_string();
    assert!(s.len() < 200, "{} chars: {s}", s.len());
    assert!(
        s.contains("x_o = (1.700e96, -3.000e300, 0.25000)")
            && s.contains("q = [1.000e300, 0.5000, -2.000e-9, 0.0000]"),
        "{s}"
    );
}

// ---------------------------------------------------------------------------------------------
// 5. Strict shapes; a start outside the bounds is a validation error.

/// `validate` on the edited paper scenario: exit 2 and the message.
fn refused(d: &Path, edits: &[(&str, &str)]) -> String {
    paper_with(d, "bad.toml", edits);
    let o = tandem_within(d, &["validate", "bad.toml"], 20.0);
    exit(&o, 2);
    stderr(&o)
}

#[test]
fn a_non_finite_number_in_another_laws_section_is_refused() {
    // The NN run does not use the CTC or PD gains, but `tandem compare` does: `nan` or `inf`
    // there passed validation before.
    let d = scratch("other-law");
    for (edit, want) in [
        (
            ("model_error = 0.0", "model_error = nan"),
            "controller.ctc.model_error = NaN: must be a finite number (line 163, column 15)",
        ),
        (
            ("k_d = [450.0,", "k_d = [inf,"),
            "controller.pd.k_d[0] = inf: must be a finite number (line 158, column 8)",
        ),
    ] {
        let e = refused(&d, &[edit]);
        assert!(e.contains(want), "{edit:?}: {e}");
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn too_long_arrays_are_errors_never_cut_short() {
    let d = scratch("arrays");
    for (edit, field, line) in [
        (
            ("base = [-0.38, 0.0]", "base = [-0.38, 0.0, 99.0, \"x\"]"),
            "arms[0].base has 4 entries; it takes exactly 2",
            "line 21",
        ),
        (
            ("start = [0.19, 0.0, 0.0]", "start = [0.19, 0.0, 0.0, 1.0]"),
            "run.start has 4 entries; it takes exactly 3",
            "line 192",
        ),
        (
            ("k_c = [0.35, 0.35, 0.35]", "k_c = [0.35, 0.35, 0.35, 0.35]"),
            "controller.k_c has 4 entries; it takes exactly 3",
            "line 131",
        ),
        (
            (
                "gravity = [0.0, 9.8, 0.0]",
                "gravity = [0.0, 9.8, 0.0, 0.0]",
            ),
            "object.gravity has 4 entries; it takes exactly 3",
            "line 69",
        ),
    ] {
        let e = refused(&d, &[edit]);
        assert!(e.contains(field) && e.contains(line), "{field}: {e}");
    }
    // Too short stays an error too (serde's own message, located).
    let e = refused(&d, &[("k_c = [0.35, 0.35, 0.35]", "k_c = [0.35, 0.35]")]);
    assert!(
        e.contains("controller.k_c") && e.contains("line 131"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_start_outside_the_bounds_is_a_validation_error() {
    let d = scratch("start");
    let e = refused(
        &d,
        &[("start = [0.19, 0.0, 0.0]", "start = [0.19, 0.0, 0.4]")],
    );
    assert!(
        e.contains("run.start[2] = 0.4 rad is outside the output bound")
            && e.contains("controller.k_c[2] = 0.35")
            && e.contains("line 192, column 21"),
        "{e}"
    );
    let e = refused(
        &d,
        &[("start = [0.19, 0.0, 0.0]", "start = [-0.35, 0.0, 0.0]")],
    );
    assert!(e.contains("run.start[0] = -0.35 m"), "{e}");
    // Out of an arm's reach: the start breaks a grasp.
    let e = refused(
        &d,
        &[("start = [0.19, 0.0, 0.0]", "start = [0.3, 0.3, 0.0]")],
    );
    assert!(
        e.contains("run.start") && e.contains("cannot be reached"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// 6. Errors blame the right field; warnings carry scenario paths and lines.

#[test]
fn q_guess_with_nan_blames_q_guess_not_run_start() {
    let d = scratch("qguess");
    // A 3-link arm 1 (its q_guess is used) whose guess has a NaN.
    let text = paper_edited(
        &d,
        &[(
            "grasp = [-0.05, 0.0]",
            "grasp = [-0.05, 0.0]\nq_guess = [0.5, nan, 1.0]",
        )],
    );
    let i = text.find("[[arms.links]]        # link 2").expect("link 2");
    let j = i + text[i..].find("\n[[arms]]").expect("arm 2");
    let link = text[i..j].to_string();
    let mut text = text;
    text.insert_str(j, &format!("\n{link}"));
    fs::write(d.join("bad.toml"), text).expect("write");
    let o = tandem(&d, &["validate", "bad.toml"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("arms[0].q_guess[1] = NaN: must be finite") && e.contains("line 28"),
        "{e}"
    );
    assert!(!e.contains("run.start"), "{e}");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn coincident_grasps_blame_the_grasp_not_controller_delta() {
    let d = scratch("grasps");
    let e = refused(
        &d,
        &[
            ("grasp = [-0.05, 0.0]", "grasp = [0.0, 0.0]"),
            ("grasp = [0.05, 0.0]", "grasp = [0.0, 0.0]"),
        ],
    );
    assert!(
        e.contains("arms[1].grasp = (0, 0) coincides with arms[0].grasp") && e.contains("line 46"),
        "{e}"
    );
    assert!(!e.contains("delta"), "{e}");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn omega_1e308_names_omega_not_a_nan_pose() {
    let d = scratch("omega");
    let e = refused(&d, &[("omega = 0.1 ", "omega = 1e308 ")]);
    assert!(
        e.contains("path.omega = 1e308") && e.contains("line 89") && !e.contains("NaN"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn nn_levels_is_reported_as_nn_levels_where_it_is_set() {
    let d = scratch("levels");
    let many: Vec<String> = (0..21)
        .map(|k| format!("{:.1}", -1.0 + 0.1 * k as f64))
        .collect();
    let line = format!("[controller.nn]\nlevels = [{}]\n", many.join(", "));
    let e = refused(&d, &[("[controller.nn]\n", &line)]);
    assert!(
        e.contains("controller.nn.levels") && e.contains("line 141"),
        "{e}"
    );
    assert!(
        !e.contains("rbf") && !e.contains("not set in the file"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn warnings_name_scenario_fields_with_their_line() {
    let d = scratch("warnings");
    paper_with(
        &d,
        "w.toml",
        &[
            ("gains = \"tuned\"", "gains = \"paper\""),
            (
                "[controller.nn]\n",
                "[controller.nn]\nk2 = [11.0, 15.0, 10.0]\n",
            ),
            ("m_e = 200.0 ", "m_e = 0.0 "),
        ],
    );
    let o = tandem(&d, &["validate", "w.toml"]);
    exit(&o, 0);
    let e = stderr(&o);
    for j in 0..3 {
        assert!(
            e.contains(&format!(
                "warning (NN (paper)): controller.nn.k2[{j}]: K2 = "
            )),
            "{e}"
        );
    }
    assert!(e.contains("(w.toml, line 141)"), "{e}");
    assert!(e.contains("admittance.m_e[0] = 0 selects") && e.contains("(w.toml, line 176)"));
    assert!(!e.contains("gains.k2"), "library path leaked: {e}");
    // From the preset, not the file: said so.
    let o = tandem(&d, &["validate", "paper"]);
    exit(&o, 0);
    let o = tandem(
        &d,
        &[
            "run",
            "--gains",
            "paper",
            "--duration",
            "0.1",
            "--no-figures",
        ],
    );
    exit(&o, 0);
    let e = stderr(&o);
    assert!(
        e.contains("controller.nn.k2[0]: K2 = 11")
            && e.contains("(preset or default value, not set in the file)"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_name_cannot_escape_the_out_folder() {
    let d = scratch("name");
    let base = d.join("work");
    fs::create_dir(&base).expect("mkdir");
    for name in ["../../escaped", "..", "a/b", "a\\\\b", ".hidden"] {
        let text = format!("name = \"{name}\"\n{}", paper_text(&base));
        fs::write(base.join("s.toml"), text).expect("write");
        let mut args = vec!["run", "s.toml"];
        args.extend(SHORT);
        let o = tandem(&base, &args);
        exit(&o, 2);
        let e = stderr(&o);
        assert!(e.contains("name = ") && e.contains("line 1"), "{name}: {e}");
    }
    let names: Vec<String> = fs::read_dir(&d)
        .expect("ls")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["work"], "nothing written outside: {names:?}");
    assert!(!base.join("out").exists());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_syntax_error_on_a_50_mb_line_echoes_one_line_of_context() {
    let d = scratch("longline");
    let text = paper_text(&d);
    // 10 MB: under the 16 MiB file limit (a 50 MB file is refused unread).
    let long = text.replacen(
        "description =",
        &format!("x = {} @\ndescription =", "1".repeat(10_000_000)),
        1,
    );
    fs::write(d.join("long.toml"), &long).expect("write");
    let quoted = text.replacen(
        "k_c = [0.35, 0.35, 0.35]",
        &format!("k_c = [\"{}\", 0.35, 0.35]", "a".repeat(10_000_000)),
        1,
    );
    fs::write(d.join("quoted.toml"), &quoted).expect("write");
    let huge = format!("x = {}\n", "1".repeat(50_000_000));
    fs::write(d.join("huge.toml"), &huge).expect("write");
    for (f, needle) in [
        ("long.toml", "TOML syntax error"),
        ("quoted.toml", "controller.k_c[0] (line 131, column 8)"),
        ("huge.toml", "larger than 16 MiB"),
    ] {
        let o = tandem_within(&d, &["validate", f], 20.0);
        exit(&o, 2);
        let e = stderr(&o);
        assert!(e.len() < 1500, "{f}: {} bytes of stderr", e.len());
        assert!(e.contains(needle), "{f}: {e}");
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_utf8_byte_order_mark_is_accepted() {
    let d = scratch("bom");
    let text = format!("\u{feff}{}", paper_text(&d));
    fs::write(d.join("bom.toml"), text).expect("write");
    let o = tandem(&d, &["validate", "bom.toml"]);
    exit(&o, 0);
    // Lines still count from the file's first line.
    let text = format!(
        "\u{feff}{}",
        paper_edited(&d, &[("delta = 0.005", "delta = -1.0")])
    );
    fs::write(d.join("bad.toml"), text).expect("write");
    let o = tandem(&d, &["validate", "bad.toml"]);
    exit(&o, 2);
    assert!(stderr(&o).contains("controller.delta = -1") && stderr(&o).contains("line 132"));
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// 7. Replay robust to real logs.

#[test]
fn replay_of_a_log_one_rounding_unit_off_replays_on_its_tick() {
    let d = scratch("clock");
    paper_with(
        &d,
        "fine.toml",
        &[("log_period = 0.03 ", "log_period = 0.001")],
    );
    let common = ["--duration", "3", "--no-figures"];
    let mut a = vec!["run", "fine.toml", "--controller", "pd", "--out", "pd"];
    a.extend(common);
    exit(&tandem(&d, &a), 0);
    let (h, c) = read_csv(&d.join("pd/timeseries.csv"));
    // The same torques stamped by an accumulated clock (t += 0.001): 0.0010000000000000002, ...
    let mut text = String::from("t [s],tau_q1 [N m],tau_q2 [N m],tau_q3 [N m],tau_q4 [N m]\n");
    let tau: Vec<&[f64]> = (1..=4)
        .map(|k| column(&h, &c, &format!("tau_q{k} [N m]")))
        .collect();
    let mut t = 0.0f64;
    let mut off = 0;
    for r in 0..tau[0].len() {
        off += usize::from(t != r as f64 * 1e-3);
        let row: Vec<String> = tau.iter().map(|v| format!("{:?}", v[r])).collect();
        text.push_str(&format!("{t:?},{}\n", row.join(",")));
        t += 0.001;
    }
    assert!(off > 1000, "the clock is off the grid on {off} rows");
    fs::write(d.join("clock.csv"), text).expect("write");
    let mut b = vec!["run", "fine.toml", "--replay", "clock.csv", "--out", "re"];
    b.extend(common);
    exit(&tandem(&d, &b), 0);
    let (hb, cb) = read_csv(&d.join("re/timeseries.csv"));
    for name in ["x_o.x [m]", "x_o.y [m]", "x_o.theta [rad]"] {
        let err = column(&h, &c, name)
            .iter()
            .zip(column(&hb, &cb, name))
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(err <= 1e-9, "{name}: the replay is off by {err}");
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn replay_columns_are_matched_by_header_name() {
    let d = scratch("names");
    let run = |file: &str, text: &str, extra: &[&str]| -> Output {
        fs::write(d.join(file), text).expect("write");
        let mut a = vec![
            "run",
            "--replay",
            file,
            "--duration",
            "0.05",
            "--no-figures",
        ];
        a.extend(extra);
        let out = format!("o-{file}");
        a.extend(["--out", out.as_str()]);
        tandem(&d, &a)
    };
    let o = run("t5.csv", "t,t,t,t,t\n0,1,1,1,1\n", &[]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("duplicate time column"),
        "{}",
        stderr(&o)
    );
    let o = run("miss.csv", "t,tau1,tau2,tau4\n0,1,1,1\n", &[]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("missing torque column `tau3`"),
        "{}",
        stderr(&o)
    );
    let o = run(
        "dup.csv",
        "t [s],tau_q1,tau_q2,tau_q2,tau_q3,tau_q4\n0,1,1,1,1,1\n",
        &[],
    );
    exit(&o, 2);
    assert!(
        stderr(&o).contains("duplicate torque column `tau_q2`"),
        "{}",
        stderr(&o)
    );
    // Any order, extra columns ignored.
    let o = run(
        "order.csv",
        "tau4,note,tau2,t,tau3,tau1\n0,9,0,0,0,0\n",
        &[],
    );
    exit(&o, 0);
    // Non-monotonic or gapped logs name the row.
    let o = run(
        "back.csv",
        "t,tau1,tau2,tau3,tau4\n0,0,0,0,0\n0.002,0,0,0,0\n0.001,0,0,0,0\n",
        &[],
    );
    exit(&o, 2);
    assert!(
        stderr(&o).contains("line 4: t = 0.001 does not increase"),
        "{}",
        stderr(&o)
    );
    let o = run(
        "gap.csv",
        "t,tau_q1,tau_q2,tau_q3,tau_q4\n0,0,0,0,0\n0.001,0,0,0,0\n0.002,0,0,0,0\n0.004,0,0,0,0\n",
        &[],
    );
    exit(&o, 2);
    assert!(
        stderr(&o).contains("line 5: a gap in the log"),
        "{}",
        stderr(&o)
    );
    // Off the grid: refused for hold, interpolated on request.
    let off = "t,tau1,tau2,tau3,tau4\n0,0,0,0,0\n0.0015,1,1,1,1\n0.0035,0,0,0,0\n";
    let o = run("off.csv", off, &[]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("not on the control grid"),
        "{}",
        stderr(&o)
    );
    let o = run("off2.csv", off, &["--replay-interpolation", "linear"]);
    exit(&o, 0);
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// Found by the fuzz test (tests/fuzz.rs).

#[test]
fn a_tiny_plant_step_is_refused_not_an_endless_run() {
    // plant_step = 2e-144: 4.6e140 RK4 substeps per tick (the count saturated usize).
    let d = scratch("substeps");
    let e = refused(
        &d,
        &[(
            "plant_step = 0.001 ",
            "plant_step = 2.174625375516394e-144 ",
        )],
    );
    assert!(
        e.contains("run.plant_step = 2.174625375516394e-144")
            && e.contains("4.598e140 plant steps per control period, more than 1000"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// 10. Fault injection.

#[test]
fn fault_injection_knobs_complete_or_stop_with_a_named_fault() {
    let d = scratch("faults");
    let base = paper_text(&d);
    for (i, knob) in [
        "dropout_rate = 5.0\ndropout_length = 0.3",
        "force_limit = 0.5",
        "force_delay = 0.3",
        "encoder_resolution = 0.01",
        "torque_limit = 2.0",
        "torque_rate = 100.0",
        "payload_mass = 3.0\npayload_inertia = 3.0",
    ]
    .iter()
    .enumerate()
    {
        fs::write(d.join("f.toml"), format!("{base}\n[faults]\n{knob}\n")).expect("write");
        let out = format!("o{i}");
        for ctl in ["pd", "nn"] {
            let o = tandem(
                &d,
                &[
                    "run",
                    "f.toml",
                    "--controller",
                    ctl,
                    "--duration",
                    "2",
                    "--no-figures",
                    "--out",
                    &out,
                    "--force",
                ],
            );
            let s = read_json(&d.join(&out).join("summary.json"));
            match code(&o) {
                0 => assert_eq!(s["completed"], true, "{knob}"),
                1 => {
                    assert!(s["fault"]["kind"].is_string(), "{knob}: {}", s["fault"]);
                    assert!(stderr(&o).contains("the ") && stderr(&o).contains(" run stopped: "));
                }
                c => panic!("{knob} ({ctl}): exit {c}: {}", stderr(&o)),
            }
            assert_all_finite(&d.join(&out));
            // The resolved scenario keeps the knob.
            let resolved = fs::read_to_string(d.join(&out).join("scenario.toml")).expect("toml");
            assert!(resolved.contains("[faults]"), "{knob}");
        }
    }
    // Bad knobs name their field.
    for (knob, field) in [
        (
            "force_delay = 0.0005",
            "faults.force_delay = 0.0005: must be a whole multiple",
        ),
        ("dropout_rate = -1.0", "faults.dropout_rate = -1"),
        ("torque_limit = 0.0", "faults.torque_limit = 0"),
        ("payload_mass = 0.0", "faults.payload_mass = 0"),
        (
            "force_delay = 2.0",
            "faults.force_delay = 2: must be at most 1 s",
        ),
    ] {
        fs::write(d.join("b.toml"), format!("{base}\n[faults]\n{knob}\n")).expect("write");
        let o = tandem(&d, &["validate", "b.toml"]);
        exit(&o, 2);
        assert!(stderr(&o).contains(field), "{knob}: {}", stderr(&o));
        assert!(stderr(&o).contains("(line 20"), "{knob}: {}", stderr(&o));
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn injected_faults_are_deterministic_and_change_the_run() {
    let d = scratch("faults-det");
    let base = paper_text(&d);
    fs::write(
        d.join("f.toml"),
        format!("{base}\n[faults]\ndropout_rate = 2.0\ndropout_length = 0.05\nencoder_resolution = 0.001\n"),
    )
    .expect("write");
    let run = |out: &str, file: &str| {
        let o = tandem(
            &d,
            &[
                "run",
                file,
                "--controller",
                "pd",
                "--duration",
                "2",
                "--no-figures",
                "--out",
                out,
            ],
        );
        exit(&o, 0);
        fs::read(d.join(out).join("timeseries.csv")).expect("csv")
    };
    fs::write(d.join("n.toml"), &base).expect("write");
    let (a, b, n) = (run("a", "f.toml"), run("b", "f.toml"), run("n", "n.toml"));
    assert_eq!(a, b, "same seed, same faults: identical logs");
    assert_ne!(a, n, "the faults change the run");
    let _ = fs::remove_dir_all(&d);
}

// ---------------------------------------------------------------------------------------------
// Other classes found on the way.

#[test]
fn messages_never_print_hundreds_of_digits() {
    let d = scratch("digits");
    let o = tandem(&d, &["run", "--duration", "1e-300", "--no-figures"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("must not exceed the duration (1e-300 s)"), "{e}");
    assert!(!e.contains("0.0000000000"), "{e}");
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_closed_pipe_ends_tandem_quietly_not_with_a_panic() {
    use std::process::Stdio;
    let d = scratch("pipe");
    for _ in 0..5 {
        let mut child = Command::new(BIN)
            .args(["scenario", "show", "paper"])
            .current_dir(&d)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        drop(child.stdout.take()); // the reader goes away before tandem writes
        let out = child.wait_with_output().expect("wait");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
        assert_ne!(out.status.code(), Some(101), "{err}");
    }
    let _ = fs::remove_dir_all(&d);
}

/// `TANDEM_KERNEL` is an environment variable, not a scenario field: a bad value is refused
/// before anything is read or written, with an error that names the variable and lists the
/// valid kernels; a valid one runs.
#[test]
fn a_bad_tandem_kernel_names_the_environment_variable_and_writes_nothing() {
    let dir = support::scratch("kernel_env");
    let run = |k: &str| {
        Command::new(support::BIN)
            .args(["run", "--duration", "0.2", "--out", "o"])
            .current_dir(&dir)
            .env("TANDEM_KERNEL", k)
            .output()
            .expect("run tandem")
    };
    let o = run("sse9");
    support::exit(&o, 2);
    let e = support::stderr(&o);
    assert!(
        e.contains("environment variable TANDEM_KERNEL")
            && e.contains("unknown kernel `sse9`")
            && e.contains("portable")
            && e.contains("batched")
            && !e.contains("line "),
        "{e}"
    );
    assert!(!dir.join("o").exists());
    let o = run("portable");
    support::exit(&o, 0);
    assert!(dir.join("o/summary.json").is_file());
}

/// `--kernel` (a global option) forces the kernel over `TANDEM_KERNEL`, and `summary.json`
/// records it; a bad name is refused before anything is written, naming the option and
/// listing the valid kernels.
#[test]
fn the_kernel_option_overrides_the_environment_and_a_bad_one_writes_nothing() {
    let dir = support::scratch("kernel_opt");
    let run = |args: &[&str], env: &str| {
        Command::new(support::BIN)
            .args(args)
            .current_dir(&dir)
            .env("TANDEM_KERNEL", env)
            .output()
            .expect("run tandem")
    };
    let o = run(
        &[
            "--kernel",
            "portable",
            "run",
            "--duration",
            "0.2",
            "--out",
            "a",
        ],
        "sse9",
    );
    support::exit(&o, 0);
    assert_eq!(
        read_json(&dir.join("a/summary.json"))["rbf_kernel"],
        "portable"
    );
    // After the subcommand too (global), over a valid environment value.
    if tandem::control::rbf::Kernel::parse("avx2").is_ok() {
        let o = run(
            &["run", "--duration", "0.2", "--out", "b", "--kernel", "avx2"],
            "portable",
        );
        support::exit(&o, 0);
        assert_eq!(read_json(&dir.join("b/summary.json"))["rbf_kernel"], "avx2");
    }
    let o = run(
        &["--kernel", "sse9", "run", "--duration", "0.2", "--out", "c"],
        "portable",
    );
    support::exit(&o, 2);
    let e = support::stderr(&o);
    assert!(
        e.contains("--kernel")
            && e.contains("unknown kernel `sse9`")
            && e.contains("batched-f32")
            && !e.contains("TANDEM_KERNEL"),
        "{e}"
    );
    assert!(!dir.join("c").exists());
    let _ = fs::remove_dir_all(&dir);
}
