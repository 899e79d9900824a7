//! `tandem ik`, `tandem validate --branches` and `tandem place` (issue 22, "IK start that finds
//! the branch"): the UR5 pair's 8 branches per arm with the preset's own marked and feasible, a
//! listed `q_guess` line that picks its branch in a run, the Franka's samples said to be
//! samples, the options refused by name, the placement scan's reachable range (the
//! base-placement study's facts: nothing at 0.90 m, near singular at 1.00 m, fine at 1.40 m),
//! and the `--json` file's conventions.

mod support;

use std::fs;

use support::{code, exit, read_csv, read_json, scratch, stderr, stdout, tandem};

fn arm(js: &serde_json::Value, i: usize) -> &serde_json::Value {
    &js["arms"][i]
}

fn sols(a: &serde_json::Value) -> &Vec<serde_json::Value> {
    a["solutions"].as_array().expect("solutions")
}

fn q_of(s: &serde_json::Value) -> Vec<f64> {
    s["q"]
        .as_array()
        .expect("q")
        .iter()
        .map(|v| v.as_f64().expect("a number"))
        .collect()
}

/// Largest difference of two joint vectors modulo 2π.
fn gap(a: &[f64], b: &[f64]) -> f64 {
    let tau = std::f64::consts::TAU;
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let r = (x - y).rem_euclid(tau);
            r.min(tau - r)
        })
        .fold(0.0, f64::max)
}

#[test]
fn ik_lists_the_eight_ur5_branches_and_marks_the_presets_own() {
    let d = scratch("ur5");
    let o = tandem(&d, &["ik", "dual-ur5", "--json", "b.json"]);
    exit(&o, 0);
    let text = stdout(&o);
    let js = read_json(&d.join("b.json"));
    assert!(
        js["written_by"]
            .as_str()
            .is_some_and(|s| s.starts_with("tandem ik")),
        "{js}"
    );
    // The preset's start angles (SPEC-spatial S6), from the scenario.
    let h = -std::f64::consts::FRAC_PI_2;
    let s6 = [
        [-0.212431, -1.267797, 1.525974, -0.258177, 1.358366, h],
        [-0.350708, -1.754035, 2.044645, -0.290610, 1.220088, h],
    ];
    for i in 0..2 {
        let a = arm(&js, i);
        assert_eq!(a["kind"], "branches");
        let s = sols(a);
        assert_eq!(s.len(), 8, "arm {i}: {}", text);
        // Distinct modulo 2π, every one inside the UR5's ±2π limits.
        let qs: Vec<Vec<f64>> = s.iter().map(q_of).collect();
        for (k, q) in qs.iter().enumerate() {
            assert!(q.iter().all(|v| v.abs() <= std::f64::consts::TAU));
            for p in &qs[..k] {
                assert!(gap(p, q) > 1e-3, "arm {i}: two listed branches coincide");
            }
        }
        // Feasible ones first.
        let feasible: Vec<bool> = s
            .iter()
            .map(|x| x["path"]["whole_path"].as_bool().expect("bool"))
            .collect();
        assert!(feasible[0], "arm {i}: the first listed follows the path");
        assert!(
            feasible.windows(2).all(|w| w[0] || !w[1]),
            "arm {i}: feasible first: {feasible:?}"
        );
        // The preset's own branch: marked, on S6's start angles (the start is 1 cm inside the
        // circle, so within a few hundredths of a radian), and feasible along the whole lap.
        let own = a["own_rank"].as_u64().expect("own marked") as usize;
        let own_sol = &s[own - 1];
        assert_eq!(own_sol["own"], true);
        assert!(gap(&q_of(own_sol), &s6[i]) < 0.05, "{own_sol}");
        assert_eq!(own_sol["path"]["whole_path"], true, "{own_sol}");
        assert_eq!(own_sol["path"]["samples"], 121, "every 0.5 s over 60 s");
        assert!(own_sol["path"]["sigma_min"].as_f64().expect("σ") > 0.15);
        assert!(
            own_sol["q_guess"]
                .as_str()
                .is_some_and(|l| l.starts_with("q_guess = ["))
        );
        // Only the own branch is marked.
        assert_eq!(s.iter().filter(|x| x["own"] == true).count(), 1);
    }
    assert!(
        text.contains("8 branches inside the joint limits"),
        "{text}"
    );
    assert!(text.contains("1*"), "the own branch is marked: {text}");
    assert!(text.contains("q_guess = ["), "{text}");
}

#[test]
fn a_listed_q_guess_line_picks_its_branch_in_validate_and_run() {
    let d = scratch("pick");
    let o = tandem(&d, &["ik", "dual-ur5", "--arm", "0", "--json", "b.json"]);
    exit(&o, 0);
    let js = read_json(&d.join("b.json"));
    assert_eq!(
        js["arms"].as_array().expect("arms").len(),
        1,
        "--arm 0 only"
    );
    let a = arm(&js, 0);
    let s = sols(a);
    let own = a["own_rank"].as_u64().expect("own") as usize - 1;
    // A branch other than the preset's that follows the whole path.
    let (k, pick) = s
        .iter()
        .enumerate()
        .find(|(k, x)| *k != own && x["path"]["whole_path"] == true)
        .expect("a second feasible branch");
    let line = pick["q_guess"].as_str().expect("line");
    let want = q_of(pick);
    assert!(
        gap(&want, &q_of(&s[own])) > 0.1,
        "branch {k} is another branch"
    );
    // The scenario copy with arm 1's q_guess replaced by the listed line.
    let text = stdout(&tandem(&d, &["scenario", "show", "dual-ur5"]));
    let first = text
        .lines()
        .find(|l| l.starts_with("q_guess = ["))
        .expect("a q_guess line");
    let edited = text.replacen(first, line, 1);
    assert_ne!(edited, text);
    fs::write(d.join("mine.toml"), &edited).expect("write");
    let v = tandem(&d, &["validate", "mine.toml"]);
    exit(&v, 0);
    let r = tandem(
        &d,
        &[
            "run",
            "mine.toml",
            "--duration",
            "0.01",
            "--no-figures",
            "--out",
            "run",
        ],
    );
    exit(&r, 0);
    let (h, rows) = read_csv(&d.join("run").join("timeseries.csv"));
    for (j, w) in want.iter().enumerate() {
        let c = h
            .iter()
            .position(|n| n.starts_with(&format!("q{} ", j + 1)) || *n == format!("q{}", j + 1))
            .unwrap_or_else(|| panic!("column q{} in {h:?}", j + 1));
        let got = rows[c][0];
        assert!(
            (got - w).abs() < 1e-9,
            "joint {}: the run starts at {got}, the branch is {w}",
            j + 1
        );
    }
}

#[test]
fn a_seven_joint_arm_lists_samples_and_says_so() {
    let d = scratch("franka");
    let o = tandem(
        &d,
        &[
            "ik",
            "dual-franka",
            "--arm",
            "1",
            "--starts",
            "40",
            "--json",
            "f.json",
        ],
    );
    exit(&o, 0);
    let text = stdout(&o);
    assert!(text.contains("self-motion manifold"), "{text}");
    assert!(text.contains("not discrete branches"), "{text}");
    let js = read_json(&d.join("f.json"));
    let a = arm(&js, 0);
    assert_eq!(a["arm"], 1);
    assert!(
        a["kind"].as_str().is_some_and(|k| k.starts_with("samples")),
        "{a}"
    );
    let s = sols(a);
    assert!(!s.is_empty());
    // The preset's own solution is one of them and carries the box the whole lap.
    let own = a["own_rank"].as_u64().expect("own") as usize - 1;
    assert_eq!(s[own]["path"]["whole_path"], true, "{}", s[own]);
    for x in s {
        assert_eq!(q_of(x).len(), 7);
    }
}

#[test]
fn options_are_refused_by_name() {
    let d = scratch("refuse");
    for (args, needle) in [
        (vec!["ik", "dual-ur5", "--starts", "0"], "--starts 0"),
        (
            vec!["ik", "dual-ur5", "--starts", "100000000"],
            "--starts 100000000",
        ),
        (vec!["ik", "dual-ur5", "--arm", "2"], "--arm 2"),
        (vec!["ik", "dual-ur5", "--every", "0"], "--every 0"),
        (vec!["ik", "dual-ur5", "--every", "1e-9"], "--every"),
        (vec!["ik", "paper"], "tandem ik takes a spatial scenario"),
        (
            vec!["validate", "--branches", "paper"],
            "tandem validate --branches takes a spatial scenario",
        ),
        (vec!["place", "dual-ur5", "--step", "0"], "--step 0"),
        (
            vec![
                "place", "dual-ur5", "--from", "0.1", "--to", "90", "--step", "0.01",
            ],
            "--step 0.01",
        ),
        (
            vec!["place", "dual-ur5", "--from", "1.5", "--to", "1.0"],
            "--to 1",
        ),
    ] {
        let o = tandem(&d, &args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn validate_branches_validates_and_lists() {
    let d = scratch("validate");
    let o = tandem(&d, &["validate", "--branches", "dual-ur5"]);
    exit(&o, 0);
    let t = stdout(&o);
    assert!(t.starts_with("ok: "), "{t}");
    assert_eq!(
        t.matches("8 branches inside the joint limits").count(),
        2,
        "{t}"
    );
}

#[test]
fn place_finds_the_studys_reachable_range() {
    let d = scratch("place");
    let o = tandem(
        &d,
        &[
            "place", "dual-ur5", "--from", "0.9", "--to", "1.5", "--step", "0.1", "--json",
            "p.json",
        ],
    );
    exit(&o, 0);
    let text = stdout(&o);
    let js = read_json(&d.join("p.json"));
    assert!(
        js["written_by"]
            .as_str()
            .is_some_and(|s| s.starts_with("tandem place"))
    );
    assert!((js["current"].as_f64().expect("current") - 1.4).abs() < 1e-12);
    let rows = js["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 7, "{text}");
    let at = |d: f64| {
        rows.iter()
            .find(|r| (r["d"].as_f64().expect("d") - d).abs() < 1e-9)
            .unwrap_or_else(|| panic!("row {d}"))
    };
    // 0.90 m: arm 2's wrist centre cannot come close enough to its base axis, on any branch.
    assert_eq!(at(0.9)["reachable"], false, "{text}");
    // 1.00 m: reachable but near singular (the study: σ_min 0.029).
    let r1 = at(1.0);
    assert_eq!(r1["reachable"], true, "{text}");
    let s1 = r1["arms"]
        .as_array()
        .expect("arms")
        .iter()
        .map(|a| a["path"]["sigma_min"].as_f64().expect("σ"))
        .fold(f64::INFINITY, f64::min);
    assert!(s1 < 0.035, "σ_min at 1.00 m: {s1}");
    assert_eq!(at(1.4)["reachable"], true, "{text}");
    let ranges = js["reachable"].as_array().expect("ranges");
    let inside = |x: f64| {
        ranges.iter().any(|r| {
            let a = r[0].as_f64().expect("a");
            let b = r[1].as_f64().expect("b");
            x >= a - 1e-9 && x <= b + 1e-9
        })
    };
    assert!(!inside(0.9) && inside(1.4), "{ranges:?}");
    let best = js["best"]["d"].as_f64().expect("best");
    assert!(best > 1.25 && best < 1.55, "best conditioned {best}");
    assert!(text.contains("current 1.400 m is inside"), "{text}");
}

#[test]
fn json_out_follows_the_force_conventions() {
    let d = scratch("json");
    // A file tandem did not write is never replaced, even with --force.
    fs::write(d.join("notes.json"), "{\"mine\": true}\n").expect("write");
    let o = tandem(
        &d,
        &[
            "ik",
            "dual-ur5",
            "--arm",
            "0",
            "--starts",
            "20",
            "--json",
            "notes.json",
        ],
    );
    exit(&o, 2);
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    let o = tandem(
        &d,
        &[
            "ik",
            "dual-ur5",
            "--arm",
            "0",
            "--starts",
            "20",
            "--json",
            "notes.json",
            "--force",
        ],
    );
    exit(&o, 2);
    assert!(stderr(&o).contains("did not write it"), "{}", stderr(&o));
    assert_eq!(
        fs::read_to_string(d.join("notes.json")).expect("read"),
        "{\"mine\": true}\n"
    );
    // Its own file: refused without --force, replaced with it.
    let args = [
        "ik", "dual-ur5", "--arm", "0", "--starts", "20", "--json", "b.json",
    ];
    exit(&tandem(&d, &args), 0);
    let o = tandem(&d, &args);
    exit(&o, 2);
    let mut forced = args.to_vec();
    forced.push("--force");
    exit(&tandem(&d, &forced), 0);
    // A scenario file (an input of the run) is never replaced.
    let text = stdout(&tandem(&d, &["scenario", "show", "dual-ur5"]));
    fs::write(d.join("s.toml"), &text).expect("write");
    let o = tandem(
        &d,
        &[
            "ik", "s.toml", "--arm", "0", "--starts", "20", "--json", "s.toml", "--force",
        ],
    );
    exit(&o, 2);
    assert_eq!(fs::read_to_string(d.join("s.toml")).expect("read"), text);
}

#[test]
fn place_refuses_a_single_arm() {
    let d = scratch("one");
    let text = stdout(&tandem(&d, &["scenario", "show", "dual-ur5"]));
    let (a, b) = (
        text.find("# Arm 2").expect("arm 2"),
        text.find("# --- Object").expect("object"),
    );
    let one = format!("{}{}", &text[..a], &text[b..]);
    fs::write(d.join("one.toml"), one).expect("write");
    let o = tandem(&d, &["place", "one.toml"]);
    exit(&o, 2);
    assert!(stderr(&o).contains("has 1 arm"), "{}", stderr(&o));
    // `tandem ik` lists its branches all the same.
    let o = tandem(&d, &["ik", "one.toml", "--starts", "50"]);
    exit(&o, 0);
    assert!(
        stdout(&o).contains("arm 0 (ur5, 6 joints)"),
        "{}",
        stdout(&o)
    );
}
