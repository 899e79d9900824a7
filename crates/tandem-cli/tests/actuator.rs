//! `[controller.actuator]` (issue 24): the actuator stage every law's torques go through, set
//! from the scenario; its counts in `summary.json`'s `events`, its limit in the measured torque
//! rate, and bad values named with their line.

mod support;
use support::*;

/// An embedded scenario's text with `[controller.actuator]` appended.
fn with_actuator(dir: &std::path::Path, scenario: &str, name: &str, table: &str) -> String {
    let o = tandem(dir, &["scenario", "show", scenario]);
    ok(&o);
    let text = format!("{}\n[controller.actuator]\n{table}\n", stdout(&o));
    std::fs::write(dir.join(name), text).unwrap();
    name.to_string()
}

fn summary(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let o = tandem(dir, args);
    let out = args[args.iter().position(|a| *a == "--out").unwrap() + 1];
    assert!(code(&o) == 0 || code(&o) == 1, "{}", stderr(&o));
    read_json(&dir.join(out).join("summary.json"))
}

/// `joint_limits` of a summary: per joint (`n`), the ticks each limit acted on, consistent with
/// the tick counts of `events` (a tick counts there when the limit acted on any joint). Returns
/// the per-joint (rate-limited, effort-clipped) counts.
fn per_joint(s: &serde_json::Value, n: usize) -> (Vec<u64>, Vec<u64>) {
    let list = |k: &str| -> Vec<u64> {
        let a = s["joint_limits"][k].as_array().expect(k);
        assert_eq!(a.len(), n, "{k}: {}", s["joint_limits"]);
        a.iter().map(|c| c.as_u64().unwrap()).collect()
    };
    let (r, e) = (list("rate_limited"), list("effort_clipped"));
    for (per, total) in [
        (&r, s["events"]["rate_limited"].as_u64().unwrap()),
        (&e, s["events"]["torque_clips"].as_u64().unwrap()),
    ] {
        // Each joint's count is at most the ticks the limit acted on, and together the joints
        // account for every such tick.
        assert!(per.iter().all(|c| *c <= total), "{per:?} vs {total}");
        assert!(per.iter().sum::<u64>() >= total, "{per:?} vs {total}");
    }
    (r, e)
}

#[test]
fn a_rate_limit_bounds_the_measured_torque_rate() {
    let dir = scratch("actuator_rate");
    // The dual-UR5 NN start with the paper's switching chatters at 16276 N m/s
    // (tests/torque_rate.rs); at 1000 N m/s (a Franka's limit) the stage holds the rate but the
    // paper's switching robust term is not smooth enough for it: the run faults at 0.84 s. Over
    // its first 0.3 s the limit holds and acts.
    let f = with_actuator(&dir, "dual-ur5", "ur5-1000.toml", "rate_limit = 1000.0");
    let paper = embedded_with(
        &dir,
        "dual-ur5",
        "ur5-paper-1000.toml",
        PAPER_SWITCHING,
        "[controller.actuator]\nrate_limit = 1000.0",
    );
    let s = summary(
        &dir,
        &[
            "run",
            &paper,
            "--duration",
            "0.3",
            "--no-figures",
            "--out",
            "nn",
        ],
    );
    let peak = s["torque_rate"]["peak_Nm_per_s"].as_f64().unwrap();
    assert!(peak <= 1000.0 * (1.0 + 1e-12), "{peak}");
    assert!(
        s["events"]["rate_limited"].as_u64().unwrap() > 10,
        "{}",
        s["events"]
    );
    assert_eq!(s["events"]["filtered"], 0);
    // Per joint: the rate limit acted on several joints; the paper form's saturated robust term
    // also drives the first wrist joints (q4, q10) into their URDF effort of 28 N m.
    let (r, e) = per_joint(&s, 12);
    assert!(r.iter().filter(|c| **c > 0).count() >= 2, "{r:?}");
    assert!(e[3] > 0 && e[9] > 0, "{e:?}");
    // Computed torque at 1000 N m/s meets the S5 claims (its start needs 353 N m/s).
    let s = summary(
        &dir,
        &[
            "run",
            &f,
            "--controller",
            "ctc",
            "--duration",
            "3",
            "--no-figures",
            "--out",
            "ctc",
        ],
    );
    assert_eq!(s["s5_claims"]["pass"], true, "{}", s["s5_claims"]);
    assert!(s["torque_rate"]["peak_Nm_per_s"].as_f64().unwrap() <= 1000.0);
    // The paper-form NN law at 1500 N m/s: the start's 46 reversals are rate-limited and the S5
    // claims hold, z1 as without the limit.
    let f = embedded_with(
        &dir,
        "dual-ur5",
        "ur5-paper-1500.toml",
        PAPER_SWITCHING,
        "[controller.actuator]\nrate_limit = 1500.0",
    );
    let s = summary(
        &dir,
        &[
            "run",
            &f,
            "--duration",
            "3",
            "--no-figures",
            "--out",
            "nn1500",
        ],
    );
    let peak = s["torque_rate"]["peak_Nm_per_s"].as_f64().unwrap();
    assert!(peak <= 1500.0 * (1.0 + 1e-12), "{peak}");
    assert_eq!(s["s5_claims"]["pass"], true, "{}", s["s5_claims"]);
    assert!(s["events"]["rate_limited"].as_u64().unwrap() > 0);
}

#[test]
fn a_filter_and_an_effort_limit_count_their_ticks() {
    let dir = scratch("actuator_planar");
    let f = with_actuator(
        &dir,
        "paper",
        "p.toml",
        "effort = [8.0, 8.0, 8.0, 8.0]\nfilter_time_constant = 0.002",
    );
    let s = summary(
        &dir,
        &["run", &f, "--duration", "2", "--no-figures", "--out", "p"],
    );
    assert_eq!(s["completed"], true);
    assert_eq!(s["events"]["filtered"], 2000, "{}", s["events"]);
    assert!(s["peak_joint_torque"].as_f64().unwrap() <= 8.0);
    // Per joint: the effort limit clipped some joints; nothing was rate-limited.
    let (r, e) = per_joint(&s, 4);
    assert_eq!(r, vec![0; 4]);
    assert!(e.iter().any(|c| *c > 0), "{e:?}");
    // The terminal table shows the per-joint counts when a limit acted.
    let o = tandem(
        &dir,
        &["run", &f, "--duration", "2", "--no-figures", "--out", "p2"],
    );
    assert!(
        stdout(&o).contains("rate-limited / effort-clipped ticks by joint"),
        "{}",
        stdout(&o)
    );
    // A torque replay has no actuator stage: `null`, with the reason.
    let o = tandem(
        &dir,
        &[
            "run",
            "paper",
            "--replay",
            "p/timeseries.csv",
            "--duration",
            "0.5",
            "--no-figures",
            "--out",
            "r",
        ],
    );
    assert!(code(&o) == 0 || code(&o) == 1, "{}", stderr(&o));
    let s = read_json(&dir.join("r/summary.json"));
    assert!(s["joint_limits"].is_null(), "{}", s["joint_limits"]);
    assert!(
        s["unavailable"]["joint_limits"].is_string(),
        "{}",
        s["unavailable"]
    );
    // The written scenario keeps the table; a scenario without it writes none.
    let text = std::fs::read_to_string(dir.join("p/scenario.toml")).unwrap();
    assert!(text.contains("[controller.actuator]"), "{text}");
    assert!(text.contains("filter_time_constant = 0.002"), "{text}");
    assert!(!paper_text(&dir).contains("[controller.actuator]"));
}

#[test]
fn bad_actuator_values_name_the_field_and_line() {
    let dir = scratch("actuator_bad");
    for (scenario, table, want) in [
        (
            "dual-ur5",
            "rate_limit = -1.0",
            "controller.actuator.rate_limit = -1: must be finite and > 0",
        ),
        (
            "paper",
            "rate_limit = nan",
            "controller.actuator.rate_limit",
        ),
        (
            "paper",
            "filter_time_constant = 0.0001",
            "controller.actuator.filter_time_constant = 0.0001: must be at least the control period",
        ),
        (
            "paper",
            "effort = [1.0, 2.0]",
            "controller.actuator.effort: has 2 limits for 4 joints",
        ),
        (
            "dual-ur5",
            "effort = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0]",
            "controller.actuator.effort[10] = 0",
        ),
        ("paper", "rate = 5.0", "rate"),
        // Issue 24, "Bad input": zero, negative and NaN limits, and a filter faster than a tick.
        (
            "paper",
            "rate_limit = 0.0",
            "controller.actuator.rate_limit = 0: must be finite and > 0",
        ),
        (
            "paper",
            "effort = [8.0, -8.0, 8.0, 8.0]",
            "controller.actuator.effort[1] = -8: must be > 0",
        ),
        (
            "paper",
            "effort = [8.0, 8.0, nan, 8.0]",
            "controller.actuator.effort[2] = NaN: must be > 0",
        ),
        (
            "dual-franka",
            "filter_time_constant = nan",
            "controller.actuator.filter_time_constant = NaN: must be finite and > 0",
        ),
        (
            "dual-franka",
            "filter_time_constant = 0.0",
            "controller.actuator.filter_time_constant = 0: must be finite and > 0",
        ),
        (
            "dual-ur5",
            "filter_time_constant = 0.0002",
            "controller.actuator.filter_time_constant = 0.0002: must be at least the control period",
        ),
    ] {
        let f = with_actuator(&dir, scenario, "bad.toml", table);
        let o = tandem(&dir, &["validate", &f]);
        exit(&o, 2);
        let e = stderr(&o);
        assert!(e.contains(want), "{table}: {e}");
        assert!(e.contains("(line "), "{table}: {e}");
    }
}

/// Issue 24, "Bad input": an effort limit below the torque a joint needs to hold the start pose
/// at rest is refused at validation, naming the limit's field, the arm and URDF joint, and both
/// torques (dual-UR5: the shoulder-lift joints hold 34.254 N m of arm and box).
#[test]
fn an_effort_limit_that_cannot_hold_the_start_pose_names_the_joint_and_the_torques() {
    let dir = scratch("actuator_hold");
    let o = tandem(&dir, &["scenario", "show", "dual-ur5"]);
    ok(&o);
    let base = stdout(&o);
    let check = |name: &str, text: String, want: &[&str]| {
        std::fs::write(dir.join(name), text).unwrap();
        let o = tandem(&dir, &["validate", name]);
        exit(&o, 2);
        let e = stderr(&o);
        for w in want {
            assert!(e.contains(w), "{name}: {w}: {e}");
        }
        assert!(e.contains("(line "), "{name}: {e}");
    };
    // [controller.actuator] effort: the element that is too low.
    check(
        "effort.toml",
        format!(
            "{base}\n[controller.actuator]\neffort = [150.0, 20.0, 150.0, 28.0, 28.0, 28.0, 150.0, \
             150.0, 150.0, 28.0, 28.0, 28.0]\n"
        ),
        &[
            "controller.actuator.effort[1] = 20:",
            "arms[0] joint `shoulder_lift_joint` (joint 1) needs 34.254 N m to hold the start pose",
            "more than its effort limit 20 N m",
        ],
    );
    // controller.torque_limit.
    check(
        "limit.toml",
        base.replacen("[controller]\n", "[controller]\ntorque_limit = 10.0\n", 1),
        &[
            "controller.torque_limit = 10:",
            "needs 34.254 N m",
            "its effort limit 10 N m",
        ],
    );
    // A URDF's own `effort`: the arm's urdf field.
    let urdf = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tandem/models/ur5.urdf"),
    )
    .unwrap()
    .replace("effort=\"150\"", "effort=\"20\"");
    std::fs::write(dir.join("weak_ur5.urdf"), urdf).unwrap();
    check(
        "urdf.toml",
        base.replacen(
            "\nmodel = \"ur5\"\n",
            "\nurdf = \"weak_ur5.urdf\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"\n",
            1,
        ),
        &[
            "arms[0].urdf: the URDF `effort` of joint `shoulder_lift_joint`",
            "needs 34.254 N m",
            "its effort limit 20 N m",
        ],
    );
    // The limits the presets ship with hold their starts.
    for s in ["dual-ur5", "dual-franka"] {
        ok(&tandem(&dir, &["validate", s]));
    }
}

/// Compliant grasps (1e5 N/m, 1e3 N m/rad) on dual-UR5 under PD + model gravity: the UR5
/// flange's spring mode (≈ 3 450 rad/s) is beyond the 1 kHz loop's Nyquist frequency, and the
/// law, which assumes welds, drives it tick to tick (a period-2 oscillation, wrists clipped at
/// their effort). `validate` warns and names the output filter; with it at 20 control periods
/// the run is smooth and inside its bounds. 0.3 s is enough: the oscillation grows ×6 a tick
/// from the 5th.
#[test]
fn compliant_grasps_get_the_output_filter_that_stops_their_chatter() {
    let d = scratch("compliant-filter");
    let o = tandem(&d, &["scenario", "show", "dual-ur5"]);
    ok(&o);
    let base = stdout(&o)
        .replacen(
            "\n[path]\n",
            "\n[plant.compliant_grasps]\nstiffness = [1e5, 1e5, 1e5, 1e3, 1e3, 1e3]\n\
             damping = [282.8, 282.8, 282.8, 0.632, 0.632, 0.632]\n\n[path]\n",
            1,
        )
        .replacen("plant_step = 0.001", "plant_step = 0.00025", 1)
        .lines()
        .filter(|l| !l.starts_with("max_drift"))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(base.contains("[plant.compliant_grasps]"), "edit");
    std::fs::write(d.join("bare.toml"), &base).unwrap();
    std::fs::write(
        d.join("filtered.toml"),
        format!("{base}\n[controller.actuator]\nfilter_time_constant = 0.02\n"),
    )
    .unwrap();
    // The warning names the knob, its value and the mode; none once the filter is set.
    let o = tandem(&d, &["validate", "bare.toml"]);
    ok(&o);
    let err = stderr(&o);
    assert!(
        err.contains("plant.compliant_grasps")
            && err.contains("filter_time_constant = 0.02")
            && err.contains("wrist_3_link"),
        "{err}"
    );
    let o = tandem(&d, &["validate", "filtered.toml"]);
    ok(&o);
    assert!(
        !stderr(&o).contains("filter_time_constant"),
        "{}",
        stderr(&o)
    );
    let run = |file: &str, out: &str| {
        summary(
            &d,
            &[
                "run",
                file,
                "--controller",
                "pd-gravity",
                "--duration",
                "0.3",
                "--out",
                out,
            ],
        )
    };
    let bare = run("bare.toml", "bare");
    let filtered = run("filtered.toml", "filtered");
    let chatter = |s: &serde_json::Value| s["torque_rate"]["chatter_ticks"].as_u64().unwrap();
    assert!(chatter(&bare) > 200, "{}", bare["torque_rate"]);
    assert!(
        bare["events"]["torque_clips"].as_u64().unwrap() > 200,
        "{}",
        bare["events"]
    );
    assert_eq!(chatter(&filtered), 0, "{}", filtered["torque_rate"]);
    assert_eq!(
        filtered["events"]["torque_clips"], 0,
        "{}",
        filtered["events"]
    );
    assert_eq!(filtered["violation_ticks"], 0);
    assert_eq!(filtered["status"], "completed");
}
