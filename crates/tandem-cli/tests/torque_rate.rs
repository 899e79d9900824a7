//! Torque rate and chattering in every run's report (issue 24, "measure it"): `summary.json`'s
//! `torque_rate` block and the terminal table, planar and spatial alike, from the torques of
//! every control tick. The dual-UR5 NN start with the paper's switching and robust term
//! (`smoothing = "paper"`, `d1 = 1`, `d2 = 1.5`) is the measured case: Q drops below 1 from
//! 16 to 68 ms and the joint torques reverse tick to tick (46 ticks, up to 16.3 N m in 1 ms);
//! `crates/tandem/tests/torque.rs` pins the same numbers on the library's monitor, so this test
//! proves the CLI reports the monitor's result, not a recomputation from the logged rows.

mod support;
use support::*;

fn summary_after(dir: &std::path::Path, args: &[&str]) -> (serde_json::Value, String) {
    let o = tandem(dir, args);
    ok(&o);
    let out = args[args.iter().position(|a| *a == "--out").unwrap() + 1];
    (read_json(&dir.join(out).join("summary.json")), stdout(&o))
}

#[test]
fn the_dual_ur5_nn_start_reports_its_chattering() {
    let dir = scratch("torque_rate_ur5");
    // The paper's switching and robust term (the preset's smooth default does not chatter:
    // tests/smooth_nn.rs).
    let f = embedded_with(&dir, "dual-ur5", "paper-form.toml", PAPER_SWITCHING, "");
    let (s, text) = summary_after(
        &dir,
        &["run", &f, "--duration", "0.2", "--no-figures", "--out", "u"],
    );
    let tr = &s["torque_rate"];
    assert_eq!(tr["chatter_ticks"], 46, "{tr}");
    assert_eq!(tr["peak_joint"], "q9", "{tr}");
    assert_eq!(tr["peak_t_s"], 0.022, "{tr}");
    let peak = tr["peak_Nm_per_s"].as_f64().unwrap();
    assert!((peak - 16276.2).abs() < 0.1, "{peak}");
    assert_eq!(tr["ticks"], 200);
    assert_eq!(tr["threshold_Nm"], 0.5);
    assert_eq!(tr["ignore_before_s"], 0.01);
    let joints = tr["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 12);
    // The block is consistent: the peak is the largest joint's, the joint-tick count their sum.
    let max = joints
        .iter()
        .map(|j| j["peak_Nm_per_s"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(max, peak);
    let sum: u64 = joints.iter().map(|j| j["chatter"].as_u64().unwrap()).sum();
    assert_eq!(tr["chatter_joint_ticks"].as_u64().unwrap(), sum);
    assert!(
        text.contains("chattering ticks (reversals > 0.5 N m)"),
        "{text}"
    );
    assert!(text.contains("16276 N m/s (q9, 0.022 s)"), "{text}");
}

#[test]
fn planar_runs_report_it_too() {
    let dir = scratch("torque_rate_planar");
    // The tuned NN law is smooth; the paper's gains end in the limit cycle of SPEC §3.4.
    let (tuned, _) = summary_after(
        &dir,
        &[
            "run",
            "paper",
            "--duration",
            "3",
            "--no-figures",
            "--out",
            "t",
        ],
    );
    let (paper, text) = summary_after(
        &dir,
        &[
            "run",
            "paper",
            "--gains",
            "paper",
            "--duration",
            "5",
            "--no-figures",
            "--out",
            "p",
        ],
    );
    assert_eq!(
        tuned["torque_rate"]["chatter_ticks"], 0,
        "{}",
        tuned["torque_rate"]
    );
    assert_eq!(tuned["torque_rate"]["joints"].as_array().unwrap().len(), 4);
    assert_eq!(tuned["torque_rate"]["ticks"], 3000);
    let chatter = paper["torque_rate"]["chatter_ticks"].as_u64().unwrap();
    assert!(
        chatter > 1000,
        "the paper's gains chatter: {}",
        paper["torque_rate"]
    );
    assert!(text.contains("peak joint torque rate"), "{text}");
}
