//! Issue 22, "Refuse what cannot be run" (the command line's part): a spatial file's
//! `metrics.transient = -1` is refused as the planar loader refuses it, and `merge` recomputes a
//! shard's hash from its `sweep` section instead of trusting the stored one; an object a million
//! times heavier than its arms (a 1e308 kg box validated and then faulted at t = 0) is refused by
//! its field and line, and a warning never prints a huge number as hundreds of digits.

use std::fs;

mod support;
use support::*;

#[test]
fn a_negative_transient_is_refused_for_spatial_files_as_for_planar_ones() {
    let d = scratch("transient");
    for (preset, from) in [("dual-ur5", "transient = 2.0"), ("paper", "transient = ")] {
        let o = tandem(&d, &["scenario", "show", preset]);
        ok(&o);
        let text = stdout(&o);
        let line = text
            .lines()
            .find(|l| l.starts_with(from))
            .unwrap_or_else(|| panic!("{preset} has no `{from}`"))
            .to_string();
        fs::write(d.join("t.toml"), text.replacen(&line, "transient = -1", 1)).expect("write");
        let o = tandem(&d, &["validate", "t.toml"]);
        exit(&o, 2);
        assert!(
            stderr(&o).contains("metrics.transient = -1: must be finite and >= 0"),
            "{preset}: {}",
            stderr(&o)
        );
    }
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn merge_recomputes_the_hash_from_the_sweep_section() {
    let d = scratch("hash");
    fs::write(
        d.join("sw.toml"),
        "base = \"paper\"\nduration = 0.2\nseed = 5\n[set]\n\"controller.kind\" = \"pd\"\n[vary]\n\"object.mass\" = { grid = [1.0, 1.1] }\n",
    )
    .expect("write");
    for (s, out) in [("0/2", "A"), ("1/2", "B")] {
        ok(&tandem(
            &d,
            &[
                "sweep",
                "sw.toml",
                "--shard",
                s,
                "--out",
                out,
                "--no-figures",
            ],
        ));
    }
    ok(&tandem(
        &d,
        &["merge", "A", "B", "--out", "m", "--no-figures"],
    ));
    // Both shards' `sweep` sections edited alike (their stored hashes still agree): another
    // sweep than the one that ran, refused.
    for s in ["A", "B"] {
        let p = d.join(s).join("sweep.json");
        let text = fs::read_to_string(&p).expect("read");
        let edited = text.replacen("\"seed\": 5", "\"seed\": 6", 1);
        assert_ne!(edited, text, "sweep.json records the seed");
        fs::write(&p, edited).expect("write");
    }
    let o = tandem(&d, &["merge", "A", "B", "--out", "m2", "--no-figures"]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("does not match its `sweep` section"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("m2").exists());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn an_object_no_arm_can_carry_is_refused_by_its_field_and_line() {
    let d = scratch("mass");
    let o = tandem(&d, &["scenario", "show", "dual-ur5"]);
    ok(&o);
    let text = stdout(&o);
    let line = text
        .lines()
        .find(|l| l.starts_with("mass = "))
        .expect("dual-ur5 has an object mass")
        .to_string();
    let at = text.lines().position(|l| l == line).unwrap() + 1;
    for (mass, refused) in [
        ("1e308", true),
        ("1e300", true),
        ("5e7", true),
        ("20", false),
    ] {
        fs::write(
            d.join("m.toml"),
            text.replacen(&line, &format!("mass = {mass}"), 1),
        )
        .unwrap();
        let o = tandem(&d, &["validate", "m.toml"]);
        let e = stderr(&o);
        if refused {
            exit(&o, 2);
            assert!(
                e.contains(&format!("object.mass = {mass}: must be at most 1e6 times the arms' total mass (33.988 kg)")),
                "{mass}: {e}"
            );
            assert!(e.contains(&format!("(line {at}, column 8)")), "{mass}: {e}");
        } else {
            ok(&o);
            // A heavy but carried box warns about the gains; no number in it runs to 300 digits.
            assert!(e.lines().all(|l| l.len() < 600), "{e}");
        }
    }
    // A box the arms' joints cannot hold at rest (issue 24): refused at validation, naming the
    // limit's source, the joint and both torques.
    fs::write(d.join("m.toml"), text.replacen(&line, "mass = 1e4", 1)).unwrap();
    let o = tandem(&d, &["validate", "m.toml"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("arms[0] joint `shoulder_lift_joint` (joint 1) needs 28288.567 N m to hold the start pose")
            && e.contains("more than its effort limit 150 N m"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

/// Say the right field (issue 22): a spatial file whose arms were emptied is still read as
/// spatial (its box has three edges) and blames `arms`, not a planar field; the library's grasp
/// model is the file's `plant.compliant_grasps`, with its line; a negative shard index gets the
/// sweep's own message, not clap's `-- -1` hint.
#[test]
fn the_right_field_is_named() {
    let d = scratch("refuse_right_field");
    let text = stdout(&tandem(&d, &["scenario", "show", "dual-ur5"]));
    let start = text.find("[[arms]]").unwrap();
    let end = text.find("\n[object]").unwrap();
    fs::write(
        d.join("empty.toml"),
        format!("{}arms = []\n{}", &text[..start], &text[end..]),
    )
    .unwrap();
    let o = tandem(&d, &["validate", "empty.toml"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("arms: give at least one arm"), "{e}");
    assert!(!e.contains("admittance"), "{e}");

    fs::write(
        d.join("soft.toml"),
        text.replacen(
            "[plant]",
            "[plant]\ncompliant_grasps = { stiffness = [-1.0, 1e5, 1e5, 1e3, 1e3, 1e3], damping = [10.0, 10.0, 10.0, 1.0, 1.0, 1.0] }",
            1,
        ),
    )
    .unwrap();
    let o = tandem(&d, &["validate", "soft.toml"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("plant.compliant_grasps.stiffness[0] = -1: must be finite and > 0"),
        "{e}"
    );
    assert!(e.contains("(line "), "{e}");
    assert!(!e.contains("not set in the file"), "{e}");

    fs::write(
        d.join("s.toml"),
        "base = \"paper\"\n[vary]\n\"run.seed\" = { grid = [1, 2] }\n",
    )
    .unwrap();
    let o = tandem(&d, &["sweep", "s.toml", "--shard", "-1/4"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("--shard -1/4: I must be a whole number from 0 to N − 1"),
        "{e}"
    );
    let _ = fs::remove_dir_all(&d);
}

/// A compliant grasp's fastest mode against the plant step (issue 22): the UR5's tool link on a
/// 1e3 N m/rad grasp spring oscillates at about 3440 rad/s, beyond RK4's stability at 1 ms (the
/// run went non-finite at 9 ms); validation refuses `run.plant_step` with the step that resolves
/// it. At 0.25 ms it validates, warns that the file's weld-sized `max_drift` would stop it, and
/// without that `max_drift` (0.05 m and rad for compliant grasps) the run completes.
#[test]
fn a_compliant_grasp_needs_a_step_that_resolves_it() {
    let d = scratch("refuse_grasp_step");
    let text = stdout(&tandem(&d, &["scenario", "show", "dual-ur5"]));
    let soft = text.replacen(
        "[plant]",
        "[plant]\ncompliant_grasps = { stiffness = [1e5, 1e5, 1e5, 1e3, 1e3, 1e3], damping = [100.0, 100.0, 100.0, 1.0, 1.0, 1.0] }",
        1,
    );
    fs::write(d.join("fast.toml"), &soft).unwrap();
    let o = tandem(&d, &["validate", "fast.toml"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("run.plant_step = 0.001 s is too long"), "{e}");
    assert!(e.contains("`wrist_3_link`"), "{e}");
    // Overdamped on the rotational axes (1 N m s/rad on 8.5e-5 kg m²): the fast real root
    // 10 700 1/s, not the spring's 3440 rad/s, sets the step.
    assert!(
        e.contains("overdamped: its fast root |λ| = 10700 1/s"),
        "{e}"
    );
    assert!(e.contains("use plant_step ≤ 9.34e-5 s"), "{e}");
    assert!(e.contains("(line "), "{e}");

    // The case: 2 N m s/rad on the wrist at 0.25 ms validated (the spring's ω h = 0.86)
    // and went non-finite at 5 ms; the damped root (23 100 1/s, h |λ| = 5.8) is refused.
    let damped = soft
        .replacen("1.0, 1.0, 1.0] }", "2.0, 2.0, 2.0] }", 1)
        .replacen("plant_step = 0.001 ", "plant_step = 0.00025 ", 1);
    fs::write(d.join("damped.toml"), &damped).unwrap();
    let o = tandem(&d, &["validate", "damped.toml"]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("run.plant_step = 0.00025 s is too long"), "{e}");
    assert!(e.contains("|λ| = 23100 1/s"), "{e}");
    assert!(e.contains("plant.compliant_grasps.damping"), "{e}");
    assert!(e.contains("use plant_step ≤ 4.33e-5 s"), "{e}");

    let small = soft.replacen("plant_step = 0.001 ", "plant_step = 0.00025 ", 1);
    assert_ne!(small, soft);
    fs::write(d.join("small.toml"), &small).unwrap();
    let o = tandem(&d, &["validate", "small.toml"]);
    ok(&o);
    assert!(
        stderr(&o).contains("run.max_drift = 1e-6 stops the run"),
        "{}",
        stderr(&o)
    );

    let line = small.lines().find(|l| l.starts_with("max_drift")).unwrap();
    fs::write(d.join("ok.toml"), small.replacen(line, "", 1)).unwrap();
    let o = tandem(
        &d,
        &[
            "run",
            "ok.toml",
            "--controller",
            "ctc",
            "--duration",
            "0.05",
            "--no-figures",
            "--out",
            "o",
        ],
    );
    ok(&o);
    assert_eq!(read_json(&d.join("o/summary.json"))["status"], "completed");
    let _ = fs::remove_dir_all(&d);
}

/// The planar twin (issue 22: "an object mass of 1e308 validates and faults at t = 0"): an
/// object a million times heavier than the arms is refused by its field, in the matrix form
/// (`object.inertia[k]`) and in the mass form (`object.mass`).
#[test]
fn an_absurd_planar_object_is_refused_by_its_field() {
    let d = scratch("refuse_planar_object");
    let p = paper_with(
        &d,
        "m.toml",
        &[("inertia = [1.0, 1.0, 1.0]", "inertia = [1e308, 1e308, 1.0]")],
    );
    let o = tandem(&d, &["validate", &p.display().to_string()]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains(
            "object.inertia[0] = 1e308: must be at most 1e6 times the arms' total mass (5.700 kg)"
        ),
        "{e}"
    );
    assert!(e.contains("(line 64, column 12)"), "{e}");
    let p = paper_with(
        &d,
        "r.toml",
        &[("inertia = [1.0, 1.0, 1.0]", "inertia = [1.0, 1.0, 1e308]")],
    );
    let e = stderr(&tandem(&d, &["validate", &p.display().to_string()]));
    assert!(
        e.contains("object.inertia[2] = 1e308: must be at most 1e6 times the arms' total mass (5.700 kg × 1 m²)"),
        "{e}"
    );
    // The mass form names object.mass (its line).
    let p = paper_with(
        &d,
        "mass.toml",
        &[
            ("inertia = [1.0, 1.0, 1.0]", "mass = 1e308\ninertia = 1.0"),
            ("gravity = [0.0, 9.8, 0.0]", ""),
        ],
    );
    let o = tandem(&d, &["validate", &p.display().to_string()]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(
        e.contains("object.mass = 1e308: must be at most 1e6"),
        "{e}"
    );
    // A heavy box the arms carry is not refused by this rule.
    let p = paper_with(
        &d,
        "ok.toml",
        &[("inertia = [1.0, 1.0, 1.0]", "inertia = [20.0, 20.0, 1.0]")],
    );
    let e = stderr(&tandem(&d, &["validate", &p.display().to_string()]));
    assert!(!e.contains("must be at most 1e6"), "{e}");
}
