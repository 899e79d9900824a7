//! Spatial scenario files (issue 9): the embedded presets are exactly the library's S6 set-ups,
//! a user URDF on disk runs like the embedded model, a run's resolved `scenario.toml` and a
//! torque replay reproduce it, and every kind of bad input gets an error naming the field (and
//! the URDF's own line where the fault is in the URDF).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::spatial::SpatialControllerParams;
use tandem::reference::spatial::path::Se3Path;
use tandem_cli::scenario::spatial as sp;
use tandem_cli::scenario::{EMBEDDED, Kind};
use tandem_cli::scenario::{Source, embedded_source};

fn tandem(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("tandem runs")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tandem-spsc-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn preset(name: &str) -> Source {
    embedded_source(EMBEDDED.iter().find(|e| e.name == name).unwrap())
}

fn built(name: &str) -> (sp::SpatialScenario, sp::SpatialBuilt) {
    let src = preset(name);
    let sc = sp::parse(&src).unwrap();
    let b = sp::build(&sc, &src).unwrap();
    (sc, b)
}

#[test]
fn presets_are_the_library_s6_setups_exactly() {
    // The Franka preset has its maker's torque-rate limit (FRANKA_TORQUE_RATE_LIMIT).
    for (name, setup, want) in [
        (
            "dual-ur5",
            tandem::presets::dual_ur5(),
            SpatialControllerParams::spec_s6(Law::Nn(NnGains::dual_ur5())),
        ),
        (
            "dual-franka",
            tandem::presets::dual_franka(),
            SpatialControllerParams::spec_s6_franka(Law::Nn(NnGains::dual_franka())),
        ),
    ] {
        let (sc, b) = built(name);
        assert_eq!(tandem_cli::scenario::kind_of(&preset(name)), Kind::Spatial);
        // Plant: arms (chains, base placements), grasp frames, object, gravity, Baumgarte — bit
        // for bit (the files write the same numbers the presets compute).
        assert_eq!(b.plant, setup.params, "{name}: plant");
        assert_eq!(b.start.q_guess, setup.q_guess, "{name}: IK guess");
        assert_eq!(b.path, Se3Path::spec_s6(), "{name}: path");
        assert_eq!(b.controller, want, "{name}: controller");
        assert_eq!(
            b.disturbance,
            tandem::model::disturbance::SpatialDisturbance::spec_s6()
        );
        // S6: the start at rest 1 cm inside the circle.
        let d0 = b.path.sample(0.0);
        assert_eq!(
            b.start.x_wo.translation.vector,
            d0.p - nalgebra::Vector3::x() * 0.01
        );
        assert_eq!(b.start.x_wo.rotation, d0.r);
        assert_eq!(sc.metrics.transient, 2.0);
        assert!(b.warnings.is_empty(), "{name}: {:?}", b.warnings);
    }
}

#[test]
fn the_default_design_is_measured_on_the_path() {
    // Without `design.inertia` the NN gains come from the chart-space inertia along the path:
    // 1.1 × the largest value, rounded up to two digits. The preset's hand-rounded inertia
    // (20, 15, 12 kg; 0.03, 0.8, 0.9 kg m²) must be within that rule's reach of it.
    let src = preset("dual-ur5");
    let mut sc = sp::parse(&src).unwrap();
    sc.controller.nn.design.get_or_insert_default().inertia = None;
    sc.run.duration = 1.0;
    let b = sp::build(&sc, &src).unwrap();
    let r = sp::make_simulation(&sc, &b, &src).unwrap();
    let m = r.path_inertia.unwrap();
    let preset_m = [20.0, 15.0, 12.0, 0.03, 0.8, 0.9];
    let Some(Law::Nn(g)) = r.controller.as_ref().map(|c| c.law.clone()) else {
        panic!("nn law")
    };
    for j in 0..6 {
        let d = sp::round_up_2(m[j]);
        assert!(
            d >= 1.1 * m[j] && d <= 1.1 * m[j] * 1.1,
            "axis {j}: {d} for {}",
            m[j]
        );
        // The design: K2 = 2 ζ m ω_n.
        assert!((g.k2[j] - 2.0 * 0.8 * d * 20.0).abs() < 1e-12 * g.k2[j]);
        // The preset's inertia is the same magnitude (within 40 %).
        assert!(
            (preset_m[j] / d - 1.0).abs() < 0.4,
            "axis {j}: {} vs {d}",
            preset_m[j]
        );
    }
    assert_eq!(sp::round_up_2(18.7), 21.0);
    assert_eq!(sp::round_up_2(0.0262), 0.029);
}

/// A scenario that uses a URDF file on disk (a copy of the embedded UR5 model) instead of
/// `model = "ur5"`, shortened to `duration` s.
fn user_scenario(dir: &Path, duration: &str, extra: &[(&str, &str)]) -> PathBuf {
    std::fs::write(dir.join("arm.urdf"), tandem::model::spatial::urdf::UR5_URDF).unwrap();
    let mut text = preset("dual-ur5")
        .text
        .replace(
            "\nmodel = \"ur5\"",
            "\nurdf = \"arm.urdf\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"",
        )
        .replace("\nduration = 60.0", &format!("\nduration = {duration}"));
    for (a, b) in extra {
        assert!(text.contains(a), "{a}");
        text = text.replacen(a, b, 1);
    }
    let p = dir.join("my.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn a_user_urdf_runs_like_the_embedded_model_and_reruns_and_replays_exactly() {
    let d = tmp("user");
    let file = user_scenario(
        &d,
        "1.0",
        &[("\nlog_period = 0.01", "\nlog_period = 0.001")],
    );
    let f = file.to_str().unwrap();
    let o = tandem(&["run", f, "--out", "user"], &d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The same scenario with the embedded model.
    let emb = d.join("emb.toml");
    std::fs::write(
        &emb,
        preset("dual-ur5")
            .text
            .replace("\nduration = 60.0", "\nduration = 1.0")
            .replace("\nlog_period = 0.01", "\nlog_period = 0.001"),
    )
    .unwrap();
    let o = tandem(&["run", "emb.toml", "--out", "emb"], &d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let a = std::fs::read(d.join("user/timeseries.csv")).unwrap();
    assert_eq!(a, std::fs::read(d.join("emb/timeseries.csv")).unwrap());
    // The run's resolved scenario.toml runs to the same bytes.
    let o = tandem(&["run", "user/scenario.toml", "--out", "again"], &d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(a, std::fs::read(d.join("again/timeseries.csv")).unwrap());
    // Replaying the logged torques (every tick) reproduces the motion exactly.
    let o = tandem(
        &[
            "run",
            f,
            "--replay",
            "user/timeseries.csv",
            "--out",
            "replay",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = |p: &str| {
        let mut r = csv::Reader::from_path(d.join(p)).unwrap();
        let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        let rows: Vec<Vec<f64>> = r
            .records()
            .map(|x| x.unwrap().iter().map(|v| v.parse().unwrap()).collect())
            .collect();
        (h, rows)
    };
    let (ha, ra) = read("user/timeseries.csv");
    let (hb, rb) = read("replay/timeseries.csv");
    assert_eq!(ra.len(), rb.len());
    let mut compared = 0;
    for name in [
        "x_o.x [m]",
        "x_o.z [m]",
        "x_o.qy [1]",
        "q1 [rad]",
        "q12 [rad]",
    ] {
        let (i, j) = (
            ha.iter().position(|h| h == name).unwrap(),
            hb.iter().position(|h| h == name).unwrap(),
        );
        for (x, y) in ra.iter().zip(&rb) {
            assert_eq!(x[i], y[j], "{name}");
            compared += 1;
        }
    }
    assert!(ra.len() >= 1000);
    assert_eq!(compared, 5 * ra.len());
    // Nothing of the user's was touched.
    assert_eq!(
        std::fs::read_to_string(d.join("arm.urdf")).unwrap(),
        tandem::model::spatial::urdf::UR5_URDF
    );
}

#[test]
fn show_list_validate_and_every_law_run_from_a_file() {
    let d = tmp("laws");
    let o = tandem(&["scenario", "list"], &d);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("dual-ur5") && s.contains("dual-franka"), "{s}");
    let o = tandem(&["scenario", "show", "dual-franka"], &d);
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        preset("dual-franka").text
    );
    let o = tandem(&["validate", "dual-franka"], &d);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && s.contains("7 joints"), "{s}");
    let file = user_scenario(&d, "0.5", &[]);
    for law in ["pd", "ctc"] {
        let o = tandem(
            &[
                "run",
                file.to_str().unwrap(),
                "--controller",
                law,
                "--out",
                law,
            ],
            &d,
        );
        assert!(
            o.status.success(),
            "{law}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(law).join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(s["status"], "completed", "{law}: {s}");
    }
    // --gains names planar presets.
    let o = tandem(&["run", "dual-ur5", "--gains", "tuned"], &d);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("[controller.nn]"));
}

/// `tandem validate` on the user scenario with `edits`: exit 2 and a message with every
/// fragment of `want`.
fn bad(d: &Path, edits: &[(&str, &str)], want: &[&str]) {
    let file = user_scenario(d, "1.0", edits);
    let o = tandem(&["validate", file.to_str().unwrap()], d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{edits:?}: {err}");
    for w in want {
        assert!(err.contains(w), "{edits:?}: `{w}` not in:\n{err}");
    }
}

#[test]
fn bad_input_names_the_field_and_the_urdf_line() {
    let d = tmp("bad");
    // A missing URDF file.
    bad(
        &d,
        &[("urdf = \"arm.urdf\"", "urdf = \"nowhere.urdf\"")],
        &["arms[0].urdf", "cannot read", "nowhere.urdf", "line 20"],
    );
    // A malformed URDF: the XML error's own line in the URDF.
    std::fs::write(
        d.join("cut.urdf"),
        &tandem::model::spatial::urdf::UR5_URDF[..3000],
    )
    .unwrap();
    bad(
        &d,
        &[("urdf = \"arm.urdf\"", "urdf = \"cut.urdf\"")],
        &["arms[0].urdf", "cut.urdf", "URDF line", "malformed XML"],
    );
    // A URDF fault inside an element: a negative mass on a known line.
    let text = tandem::model::spatial::urdf::UR5_URDF;
    let at = text.find("<mass value=\"").unwrap();
    let line = text[..at].matches('\n').count() + 1;
    let end = at + text[at..].find("/>").unwrap();
    let neg = format!("{}<mass value=\"-1.0\"{}", &text[..at], &text[end..]);
    std::fs::write(d.join("neg.urdf"), neg).unwrap();
    bad(
        &d,
        &[("urdf = \"arm.urdf\"", "urdf = \"neg.urdf\"")],
        &["arms[0].urdf", &format!("URDF line {line}"), "mass"],
    );
    // A link that does not exist, with a suggestion.
    bad(
        &d,
        &[("tool_link = \"tool0\"", "tool_link = \"tool9\"")],
        &[
            "arms[0].tool_link",
            "tool9",
            "did you mean `tool0`",
            "line 22",
        ],
    );
    // A URDF arm without its links named.
    bad(
        &d,
        &[("base_link = \"base_link\"\n", "")],
        &["arms[0].base_link", "names its base link"],
    );
    // Both a model and a file; neither.
    bad(
        &d,
        &[(
            "urdf = \"arm.urdf\"",
            "urdf = \"arm.urdf\"\nmodel = \"ur5\"",
        )],
        &["arms[0].urdf", "not both"],
    );
    // An unknown embedded model, with the choices.
    bad(
        &d,
        &[("urdf = \"arm.urdf\"", "model = \"ur10\"")],
        &["arms[0].model", "ur10", "\"ur5\""],
    );
    // A base placement that puts the path out of the arm's reach.
    bad(
        &d,
        &[(
            "position = [-0.70, 0.0, 0.0]",
            "position = [-1.70, 0.0, 0.0]",
        )],
        &["arms[0].base", "out of the arm's reach", "line 25"],
    );
    // A grasp frame the arm cannot reach (2 m off the box).
    bad(
        &d,
        &[("position = [-0.2, 0.0, 0.0]", "position = [-2.2, 0.0, 0.0]")],
        &["arms[0]", "reach"],
    );
    // A quaternion that is not unit; axes that are not orthonormal or left-handed.
    bad(
        &d,
        &[("rpy = [0.0, 0.0, 0.0]", "quaternion = [1.0, 0.1, 0.0, 0.0]")],
        &[
            "arms[0].base.quaternion",
            "unit quaternion",
            "norm is 1.004987",
        ],
    );
    bad(
        &d,
        &[("[1.0, 0.0, 0.0]] }", "[1.0, 0.0, 0.1]] }")],
        &["arms[0].grasp.axes", "orthonormal"],
    );
    bad(
        &d,
        &[("[1.0, 0.0, 0.0]] }", "[-1.0, 0.0, 0.0]] }")],
        &["arms[0].grasp.axes", "right-handed"],
    );
    bad(
        &d,
        &[(
            "rpy = [0.0, 0.0, 0.0]",
            "rpy = [0.0, 0.0, 0.0], quaternion = [1.0, 0.0, 0.0, 0.0]",
        )],
        &["arms[0].base.rpy", "not several"],
    );
    // Wrong lengths: q_guess against the chain, and a fixed-size array.
    bad(
        &d,
        &[("q_guess = [-0.212431, ", "q_guess = [")],
        &["arms[0].q_guess has 5 entries", "6 joints"],
    );
    bad(
        &d,
        &[("size = [0.4, 0.2, 0.2]", "size = [0.4, 0.2, 0.2, 0.1]")],
        &["object.size has 4 entries", "exactly 3"],
    );
    // A misspelt field, with a suggestion.
    bad(
        &d,
        &[("squeeze = 5.0", "squeze = 5.0")],
        &["unknown field `squeze`", "did you mean `squeeze`"],
    );
    // A rotational bound at or above π; a path outside the bounds.
    bad(
        &d,
        &[(
            "k_c = [0.167, 0.167, 0.1, 0.29, 0.29, 0.29]",
            "k_c = [0.167, 0.167, 0.1, 0.29, 3.2, 0.29]",
        )],
        &["controller.k_c[4]", "below π"],
    );
    bad(
        &d,
        &[("radius = 0.1", "radius = 0.3")],
        &["controller.k_c[0]", "largest excursion"],
    );
    // A non-positive gain, a spline without waypoints, a non-finite start offset.
    bad(&d, &[("k1 = 8.0", "k1 = -8.0")], &["controller.nn", "k1"]);
    bad(
        &d,
        &[("kind = \"circle\"", "kind = \"spline\"")],
        &["path.waypoints", "needs"],
    );
    bad(
        &d,
        &[("mass = 3.0", "mass = -3.0")],
        &["object.mass", "> 0"],
    );
    // Hostile files: a URDF or a replay that is a folder, a URDF that is a binary file, NaN.
    std::fs::create_dir_all(d.join("folder")).unwrap();
    let mut binary = b"\x7fELF\x02\x01\x01\x00".to_vec();
    binary.extend((0u8..=255).cycle().take(4000));
    std::fs::write(d.join("bin.urdf"), binary).unwrap();
    bad(
        &d,
        &[("urdf = \"arm.urdf\"", "urdf = \"folder\"")],
        &["arms[0].urdf", "cannot read", "folder", "line 20"],
    );
    bad(
        &d,
        &[("urdf = \"arm.urdf\"", "urdf = \"bin.urdf\"")],
        &["arms[0].urdf", "not UTF-8 text", "offset 136", "line 20"],
    );
    bad(
        &d,
        &[("kind = \"nn\"", "kind = \"replay\"\nreplay = \"folder\"")],
        &["controller.replay", "folder", "(line 78, column 10)"],
    );
    bad(
        &d,
        &[("mass = 3.0", "mass = nan")],
        &["object.mass = NaN", "finite"],
    );
    bad(
        &d,
        &[("start_offset = [-0.01,", "start_offset = [nan,")],
        &["run.start_offset[0]", "finite"],
    );
    // The NN design's inputs are named as the file gives them, with their place (they were
    // reported as the designed gain `controller.nn.k1[0]`, "not set in the file").
    bad(
        &d,
        &[("k1 = 8.0, omega_n", "k1 = nan, omega_n")],
        &[
            "controller.nn.design.k1 = NaN",
            "> 0",
            "(line 100, column 63)",
        ],
    );
    bad(
        &d,
        &[("inertia = [20.0,", "inertia = [-20.0,")],
        &[
            "controller.nn.design.inertia[0] = -20",
            "> 0",
            "(line 100, column 23)",
        ],
    );
    // A NaN in a frame's axes is named by its entry (it passed the orthonormality test: the
    // largest entry of |RᵀR − I| skipped it, and the library named only `arms[0].grasp`).
    bad(
        &d,
        &[("[1.0, 0.0, 0.0]] }", "[1.0, 0.0, nan]] }")],
        &["arms[0].grasp.axes[2][2]: must be finite", "line 27"],
    );
    // A start guess no joint can take is blamed, before the inverse kinematics fails from it
    // and blames the base (it did, for 1e308).
    bad(
        &d,
        &[("q_guess = [-0.212431,", "q_guess = [1e308,")],
        &[
            "arms[0].q_guess[0] = 1e308",
            "shoulder_pan_joint",
            "(line 29, column 12)",
        ],
    );
    // A non-finite number in a law this run does not use (`tandem compare` runs them all).
    bad(
        &d,
        &[("model_error = 0.0", "model_error = nan")],
        &["controller.ctc.model_error = NaN", "finite", "line 109"],
    );
    // A start offset the arms cannot hold: the error names and points at run.start_offset
    // (its line in the file), not at the first arm, and still says which arm fails.
    let line = user_scenario(&d, "1.0", &[])
        .to_str()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .unwrap()
        .lines()
        .position(|l| l.starts_with("start_offset"))
        .unwrap()
        + 1;
    for big in ["5.0", "1e300"] {
        bad(
            &d,
            &[(
                "start_offset = [-0.01, 0.0, 0.0",
                &format!("start_offset = [{big}, 0.0, 0.0"),
            )],
            &[
                "error: ",
                ": run.start_offset = [",
                "the start pose",
                "arms[0]: cannot reach",
                &format!("(line {line}, column 16)"),
            ],
        );
    }
}

#[test]
fn three_arms_from_a_file_with_the_designed_gains_meet_the_s5_claims() {
    // A third UR5-class arm at (0, −0.70, 0) facing +y holds the box's −y face (as
    // `presets::three_ur5`); the NN gains are designed on the measured path inertia (no
    // `design.inertia`): with the dual-UR5 inertia the rotational K2 would be too small (warned).
    let d = tmp("three");
    let third = "[[arms]]\nmodel = \"ur5\"\n\
        base = { position = [0.0, -0.70, 0.0], rpy = [0.0, 0.0, 1.5707963267948966] }\n\
        grasp = { position = [0.0, -0.1, 0.0], axes = [[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] }\n\
        q_guess = [-0.212431, -1.267797, 1.525974, -0.258177, 1.358366, -1.5707963267948966]\n\n\
        # --- Object";
    let text = preset("dual-ur5")
        .text
        .replacen("# --- Object", third, 1)
        .replace("name = \"dual-ur5\"", "name = \"three-ur5\"")
        .replace("\nduration = 60.0", "\nduration = 4.0")
        .replace(
            "design = { inertia = [20.0, 15.0, 12.0, 0.03, 0.8, 0.9], ",
            "design = { ",
        );
    std::fs::write(d.join("three.toml"), text).unwrap();
    let o = tandem(&["run", "three.toml", "--out", "out"], &d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("warning"), "{err}");
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("out/summary.json")).unwrap()).unwrap();
    assert_eq!(s["status"], "completed", "{s}");
    assert_eq!(s["violation_ticks"], 0, "{s}");
    assert!(s["max_drift_m"].as_f64().unwrap() < 1e-9, "{s}");
    assert!(s["z1_p_max_after_2s_m"].as_f64().unwrap() < 1e-3, "{s}");
    assert!(s["z1_rot_max_after_2s_rad"].as_f64().unwrap() < 1e-3, "{s}");
}

#[test]
fn a_urdf_chain_longer_than_any_arm_is_refused_before_the_plant_exists() {
    // 40 revolute joints (the plant's matrices grow with the square of the joint count; a
    // generated or whole-cell URDF must not allocate them).
    let d = tmp("long");
    let n = 40;
    let mut urdf = String::from("<robot name=\"long\">\n");
    for k in 0..=n {
        urdf.push_str(&format!(
            "<link name=\"l{k}\"><inertial><mass value=\"1\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
        ));
    }
    for k in 0..n {
        urdf.push_str(&format!(
            "<joint name=\"j{k}\" type=\"revolute\"><parent link=\"l{k}\"/><child link=\"l{}\"/><origin xyz=\"0 0 0.05\"/><axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"1\"/></joint>\n",
            k + 1
        ));
    }
    urdf.push_str("</robot>\n");
    std::fs::write(d.join("long.urdf"), urdf).unwrap();
    bad(
        &d,
        &[
            ("urdf = \"arm.urdf\"", "urdf = \"long.urdf\""),
            ("base_link = \"base_link\"", "base_link = \"l0\""),
            ("tool_link = \"tool0\"", "tool_link = \"l40\""),
        ],
        &["arms[0].urdf", "40 moving joints", "at most 16"],
    );
}

/// A start guess outside a joint's limits that no whole turn brings inside is refused naming
/// the guess and the joint's limits (Franka's elbow, [−3.07, −0.07] rad: 2.0 − 2π = −4.28 is
/// outside too); a guess one turn off the limits is the same pose and is taken.
#[test]
fn a_start_guess_outside_the_limits_is_refused_unless_a_turn_brings_it_in() {
    let d = tmp("guess");
    let text = EMBEDDED
        .iter()
        .find(|e| e.name == "dual-franka")
        .unwrap()
        .text;
    let at = "q_guess = [0.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785]";
    assert!(text.contains(at));
    for (guess, ok) in [("2.0", false), ("4.283185307179586", true)] {
        let t = text.replacen(
            at,
            &format!("q_guess = [0.0, 0.3, 0.0, {guess}, 0.0, 2.3, 0.785]"),
            1,
        );
        let file = d.join("f.toml");
        std::fs::write(&file, t).unwrap();
        let o = tandem(&["validate", file.to_str().unwrap()], &d);
        let err = String::from_utf8_lossy(&o.stderr);
        if ok {
            assert!(!err.contains("q_guess"), "{guess}: {err}");
        } else {
            assert_eq!(o.status.code(), Some(2), "{err}");
            assert!(
                err.contains("arms[0].q_guess[3] = 2")
                    && err.contains("outside joint `panda_joint4`'s limits")
                    && err.contains("whole turns"),
                "{err}"
            );
        }
    }
}
