//! Issue 22, "Replay real logs": a log from another tool names its columns otherwise
//! (`stamp`, `tau_arm1_q1`, `joint_3_effort`) and stamps its rows with an accumulated clock. A
//! column map (`controller.replay_columns`, `--replay-columns`) reads it, the replay is then the
//! run it came from, and a header the map or tandem's names do not match is an error that lists
//! the file's header.

use std::fs;
use std::path::Path;

mod support;
use support::*;

/// A 1 s PD run of the paper scenario logged every tick, and its `timeseries.csv`.
fn logged_run(d: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let s = paper_with(d, "pd.toml", &[("log_period = 0.03", "log_period = 0.001")]);
    ok(&tandem(
        d,
        &[
            "run",
            s.to_str().unwrap(),
            "--controller",
            "pd",
            "--duration",
            "1",
            "--no-figures",
            "--out",
            "pd",
        ],
    ));
    read_csv(&d.join("pd/timeseries.csv"))
}

/// The run's torques under another tool's names, stamped by an accumulated clock.
fn foreign_log(d: &Path, h: &[String], cols: &[Vec<f64>]) {
    let mut text =
        String::from("stamp,gripper_width,joint_1_effort,joint_2_effort,tau_arm2_q1,tau_arm2_q2\n");
    let mut clock = 0.0f64;
    for k in 0..cols[0].len() {
        text.push_str(&format!("{clock:?},0.04"));
        for j in 1..=4 {
            text.push_str(&format!(
                ",{:?}",
                column(h, cols, &format!("tau_q{j} [N m]"))[k]
            ));
        }
        text.push('\n');
        clock += 0.001;
    }
    fs::write(d.join("other.csv"), text).unwrap();
}

const MAP: &str = "stamp,joint_1_effort,joint_2_effort,tau_arm2_q1,tau_arm2_q2";

#[test]
fn a_foreign_log_replays_through_a_column_map_as_the_run_it_came_from() {
    let d = scratch("map");
    let (h, cols) = logged_run(&d);
    foreign_log(&d, &h, &cols);
    // --replay-columns on the command line.
    ok(&tandem(
        &d,
        &[
            "run",
            "pd.toml",
            "--replay",
            "other.csv",
            "--replay-columns",
            MAP,
            "--duration",
            "1",
            "--no-figures",
            "--out",
            "cli",
        ],
    ));
    // controller.replay_columns in the file.
    let map = MAP
        .split(',')
        .map(|c| format!("\"{c}\""))
        .collect::<Vec<_>>()
        .join(", ");
    let s = paper_with(
        &d,
        "mapped.toml",
        &[
            ("log_period = 0.03", "log_period = 0.001"),
            (
                "\nkind = \"nn\"",
                &format!("\nkind = \"replay\"\nreplay = \"other.csv\"\nreplay_columns = [{map}]"),
            ),
        ],
    );
    ok(&tandem(
        &d,
        &[
            "run",
            s.to_str().unwrap(),
            "--duration",
            "1",
            "--no-figures",
            "--out",
            "file",
        ],
    ));
    // Both reproduce the run's object motion exactly (the same torques on the same ticks).
    for out in ["cli", "file"] {
        let (h2, c2) = read_csv(&d.join(out).join("timeseries.csv"));
        for c in ["x_o.x [m]", "x_o.y [m]", "x_o.theta [rad]"] {
            let (a, b) = (column(&h, &cols, c), column(&h2, &c2, c));
            assert_eq!(a.len(), b.len(), "{out}: {c} rows");
            if let Some(k) = (0..a.len()).find(|&k| a[k] != b[k]) {
                panic!("{out}: {c} row {k}: {} replayed as {}", a[k], b[k]);
            }
        }
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn a_header_that_does_not_match_is_listed_in_the_error() {
    let d = scratch("header");
    let (h, cols) = logged_run(&d);
    foreign_log(&d, &h, &cols);
    // tandem's own names do not match: the header and the way out are said.
    let o = tandem(
        &d,
        &[
            "run",
            "paper",
            "--replay",
            "other.csv",
            "--duration",
            "1",
            "--no-figures",
        ],
    );
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("no time column"), "{e}");
    assert!(
        e.contains("`stamp`, `gripper_width`, `joint_1_effort`"),
        "{e}"
    );
    assert!(e.contains("--replay-columns"), "{e}");
    // A map entry the header lacks names the entry and lists the header.
    let o = tandem(
        &d,
        &[
            "run",
            "paper",
            "--replay",
            "other.csv",
            "--replay-columns",
            "stamp,joint_1_effort,joint_2_effort,joint_3_effort,tau_arm2_q2",
            "--duration",
            "1",
            "--no-figures",
        ],
    );
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("replay_columns[3] = `joint_3_effort` (joint 3's torque) is not in the file's header: `stamp`, `gripper_width`"), "{e}");
    // The wrong count.
    let o = tandem(
        &d,
        &[
            "run",
            "paper",
            "--replay",
            "other.csv",
            "--replay-columns",
            "stamp,joint_1_effort",
            "--duration",
            "1",
            "--no-figures",
        ],
    );
    exit(&o, 2);
    assert!(
        stderr(&o).contains("replay_columns has 2 names; it needs 5"),
        "{}",
        stderr(&o)
    );
    // A map without a replay.
    let o = tandem(
        &d,
        &[
            "run",
            "paper",
            "--controller",
            "pd",
            "--replay-columns",
            MAP,
            "--no-figures",
        ],
    );
    exit(&o, 2);
    assert!(
        stderr(&o).contains("--replay-columns is for a replay"),
        "{}",
        stderr(&o)
    );
    let _ = fs::remove_dir_all(&d);
}
