//! `tandem export` (issue 23): the MJCF is XML with tandem's joints in tandem's order, the
//! JSON carries the same start, a user's URDF file exports like an embedded model, and the
//! command refuses what it must (a planar scenario, an unknown format, a folder as --out, a
//! file it did not write, an input of the scenario). MuJoCo itself loads the files in
//! python/tests/test_export.py.

mod support;

use std::fs;

use support::{code, exit, scratch, stderr, stdout, tandem};

/// The joint names of an MJCF in document order, and each `joint`'s `type`.
fn joints(doc: &roxmltree::Document) -> Vec<(String, String)> {
    doc.descendants()
        .filter(|n| n.has_tag_name("joint") && n.attribute("name").is_some())
        .map(|n| {
            (
                n.attribute("name").unwrap_or_default().to_string(),
                n.attribute("type").unwrap_or("hinge").to_string(),
            )
        })
        .collect()
}

/// The library's set-up of an embedded scenario (what the command exports).
fn library_setup(name: &str) -> tandem_cli::export::Setup {
    use tandem_cli::export::{Format, setup};
    use tandem_cli::scenario::{self, Overrides};
    let (src, sc) = scenario::load(Some(name), &Overrides::default()).expect("load");
    setup(sc, &src, Format::Mjcf).expect("set-up")
}

fn numbers(s: &str) -> Vec<f64> {
    s.split_whitespace()
        .map(|v| v.parse().expect("a number"))
        .collect()
}

/// The MJCF of each preset (to standard output) parses as XML, and its joints, sites, welds,
/// motors and keyframe follow tandem's order and tandem's start (the JSON export's).
#[test]
fn mjcf_is_xml_with_tandems_joints_order_and_start() {
    let d = scratch("mjcf");
    for (name, dof, robot) in [("dual-ur5", 6, "ur5"), ("dual-franka", 7, "franka")] {
        let o = tandem(&d, &["export", name]);
        exit(&o, 0);
        let xml = stdout(&o);
        assert!(
            xml.starts_with("<!-- written by tandem export"),
            "{}",
            &xml[..80]
        );
        let doc = roxmltree::Document::parse(&xml).expect("the MJCF is XML");
        let root = doc.root_element();
        assert!(root.has_tag_name("mujoco"));
        assert_eq!(root.attribute("model"), Some(name));
        let js = tandem(&d, &["export", name, "--format", "json"]);
        exit(&js, 0);
        let js: serde_json::Value = serde_json::from_str(&stdout(&js)).expect("JSON");
        assert_eq!(js["format"], "tandem-setup");
        assert_eq!(js["arms"][0]["model"], robot);
        let names: Vec<String> = js["joint_names"]
            .as_array()
            .expect("joint_names")
            .iter()
            .map(|v| v.as_str().expect("a name").to_string())
            .collect();
        assert_eq!(names.len(), 2 * dof);
        assert!(names[0].starts_with("arm0_") && names[dof].starts_with("arm1_"));
        let j = joints(&doc);
        let mut want: Vec<(String, String)> = names
            .iter()
            .map(|n| (n.clone(), "hinge".to_string()))
            .collect();
        want.push(("object".into(), "free".into()));
        assert_eq!(j, want, "{name}: joints in tandem's order, then the box");
        // One motor per joint, same order, limited to the URDF effort.
        let motors: Vec<_> = doc
            .descendants()
            .filter(|n| n.has_tag_name("motor") && n.attribute("joint").is_some())
            .collect();
        let motor_joints: Vec<&str> = motors.iter().filter_map(|n| n.attribute("joint")).collect();
        assert_eq!(
            motor_joints,
            names.iter().map(String::as_str).collect::<Vec<_>>()
        );
        for (k, m) in motors.iter().enumerate() {
            let arm = &js["arms"][k / dof]["chain"]["joints"][k % dof];
            let e = arm["effort"].as_f64().expect("effort");
            assert_eq!(m.attribute("ctrllimited"), Some("true"));
            assert_eq!(numbers(m.attribute("ctrlrange").unwrap_or("")), vec![-e, e]);
        }
        // A tool site per arm, a grasp site on the box, a weld between them.
        for i in 0..2 {
            for s in [format!("arm{i}_tool"), format!("arm{i}_grasp")] {
                assert!(
                    doc.descendants()
                        .any(|n| n.has_tag_name("site") && n.attribute("name") == Some(s.as_str())),
                    "{name}: site {s}"
                );
            }
            assert!(doc.descendants().any(|n| n.has_tag_name("weld")
                && n.attribute("site1") == Some(format!("arm{i}_tool").as_str())
                && n.attribute("site2") == Some(format!("arm{i}_grasp").as_str())));
        }
        // The keyframe: tandem's start q (bit for bit), the box pose, at rest, holding torques.
        let key = doc
            .descendants()
            .find(|n| n.has_tag_name("key"))
            .expect("a keyframe");
        assert_eq!(key.attribute("name"), Some("start"));
        // Compared with the library's set-up (serde_json's default float parser may be one
        // unit in the last place off; the text itself is exact, as Python's test shows).
        let setup = library_setup(name);
        let qpos = numbers(key.attribute("qpos").unwrap_or(""));
        let q: Vec<f64> = setup.arms.iter().flat_map(|a| a.q0.clone()).collect();
        assert_eq!(qpos.len(), 2 * dof + 7);
        assert_eq!(&qpos[..2 * dof], &q[..]);
        let p = setup.object_pose.translation.vector;
        assert_eq!(&qpos[2 * dof..2 * dof + 3], p.as_slice());
        let r = tandem_cli::export::wxyz(&setup.object_pose.rotation);
        assert_eq!(&qpos[2 * dof + 3..], &r[..]);
        let ctrl = numbers(key.attribute("ctrl").unwrap_or(""));
        let hold: Vec<f64> = setup.arms.iter().flat_map(|a| a.holding.clone()).collect();
        assert_eq!(ctrl, hold);
        assert!(
            numbers(key.attribute("qvel").unwrap_or(""))
                .iter()
                .all(|v| *v == 0.0)
        );
        // The box: explicit inertial with the scenario's mass; contacts off everywhere.
        let obj = doc
            .descendants()
            .find(|n| n.has_tag_name("body") && n.attribute("name") == Some("object"))
            .expect("the box");
        let inertial = obj
            .children()
            .find(|n| n.has_tag_name("inertial"))
            .expect("inertial");
        assert_eq!(inertial.attribute("mass"), Some("3"));
        assert!(
            doc.descendants()
                .any(|n| n.has_tag_name("flag") && n.attribute("contact") == Some("disable"))
        );
        let opt = doc
            .descendants()
            .find(|n| n.has_tag_name("option"))
            .expect("option");
        assert_eq!(opt.attribute("timestep"), Some("0.001"));
        assert_eq!(opt.attribute("integrator"), Some("RK4"));
    }
    let _ = fs::remove_dir_all(&d);
}

/// A user's scenario with `urdf = "..."` exports too: the path in the JSON, the URDF text
/// verbatim, the same chain as the embedded model's.
#[test]
fn a_users_urdf_file_exports() {
    let d = scratch("urdf");
    let urdf = include_str!("../../tandem/models/ur5.urdf");
    fs::write(d.join("my_arm.urdf"), urdf).expect("write urdf");
    let o = tandem(&d, &["scenario", "show", "dual-ur5"]);
    exit(&o, 0);
    let text = stdout(&o).replace(
        "\nmodel = \"ur5\"",
        "\nurdf = \"my_arm.urdf\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"",
    );
    fs::write(d.join("mine.toml"), text).expect("write scenario");
    let o = tandem(&d, &["export", "mine.toml", "--out", "mine.json"]);
    exit(&o, 0);
    let js: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(d.join("mine.json")).expect("read"))
            .expect("JSON");
    let a = &js["arms"][1];
    assert_eq!(a["model"], serde_json::Value::Null);
    assert!(
        a["urdf_path"]
            .as_str()
            .expect("urdf_path")
            .ends_with("my_arm.urdf")
    );
    assert_eq!(a["urdf"], urdf);
    let e = tandem(&d, &["export", "dual-ur5", "--format", "json"]);
    let e: serde_json::Value = serde_json::from_str(&stdout(&e)).expect("JSON");
    assert_eq!(a["chain"], e["arms"][1]["chain"]);
    assert_eq!(js["start"], e["start"]);
    let o = tandem(&d, &["export", "mine.toml", "--out", "mine.xml"]);
    exit(&o, 0);
    let xml = fs::read_to_string(d.join("mine.xml")).expect("read");
    roxmltree::Document::parse(&xml).expect("XML");
    assert!(xml.contains(&d.join("my_arm.urdf").display().to_string()));
    let _ = fs::remove_dir_all(&d);
}

/// The output rules: an existing file is never replaced without --force; with --force only
/// a file tandem export wrote; never an input of the scenario; never a folder.
#[test]
fn export_refuses_to_overwrite_what_it_did_not_write() {
    let d = scratch("overwrite");
    let run = |args: &[&str]| tandem(&d, args);
    // Written once; again without --force: refused, the file unchanged, the command shown.
    exit(&run(&["export", "dual-ur5", "--out", "scene.xml"]), 0);
    let first = fs::read(d.join("scene.xml")).expect("read");
    let o = run(&["export", "dual-franka", "--out", "scene.xml"]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("exists (nothing was written)"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    assert_eq!(fs::read(d.join("scene.xml")).expect("read"), first);
    // With --force: tandem wrote it, so it is replaced (MJCF and JSON alike).
    exit(
        &run(&["export", "dual-franka", "--out", "scene.xml", "--force"]),
        0,
    );
    assert!(
        fs::read_to_string(d.join("scene.xml"))
            .expect("read")
            .contains("dual-franka")
    );
    exit(&run(&["export", "dual-ur5", "--out", "scene.json"]), 0);
    exit(
        &run(&["export", "dual-franka", "--out", "scene.json", "--force"]),
        0,
    );
    // A file tandem did not write: refused even with --force, untouched.
    fs::write(d.join("mine.xml"), "<mujoco/>\n").expect("write");
    let o = run(&["export", "dual-ur5", "--out", "mine.xml", "--force"]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("tandem did not write it"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        fs::read_to_string(d.join("mine.xml")).expect("read"),
        "<mujoco/>\n"
    );
    // The scenario file itself, and the URDF it names: inputs, never replaced.
    let o = run(&["scenario", "show", "dual-ur5"]);
    let text = stdout(&o).replacen(
        "\nmodel = \"ur5\"",
        "\nurdf = \"arm.urdf\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"",
        1,
    );
    // Even a file that carries the mark is refused when it is an input.
    let marked = format!(
        "<!-- written by tandem export -->\n{}",
        include_str!("../../tandem/models/ur5.urdf")
    );
    fs::write(d.join("arm.urdf"), &marked).expect("write urdf");
    fs::write(
        d.join("s.toml"),
        format!("# written by tandem export\n{text}"),
    )
    .expect("write");
    for (target, what) in [("arm.urdf", "arms[0].urdf"), ("s.toml", "the scenario")] {
        let before = fs::read(d.join(target)).expect("read");
        let o = run(&[
            "export", "s.toml", "--out", target, "--force", "--format", "mjcf",
        ]);
        exit(&o, 2);
        assert!(
            stderr(&o).contains("is the input") && stderr(&o).contains(what),
            "{}",
            stderr(&o)
        );
        assert_eq!(fs::read(d.join(target)).expect("read"), before);
    }
    // A folder as --out, and a symbolic link.
    fs::create_dir(d.join("models")).expect("mkdir");
    let o = run(&["export", "dual-ur5", "--out", "models"]);
    exit(&o, 2);
    assert!(stderr(&o).contains("is a folder"), "{}", stderr(&o));
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(d.join("scene.xml"), d.join("link.xml")).expect("symlink");
        let o = run(&["export", "dual-ur5", "--out", "link.xml", "--force"]);
        exit(&o, 2);
        assert!(stderr(&o).contains("symbolic link"), "{}", stderr(&o));
    }
    // A missing parent folder is created, as `tandem run --out` does.
    exit(
        &run(&["export", "dual-ur5", "--out", "sub/dir/scene.xml"]),
        0,
    );
    assert!(d.join("sub/dir/scene.xml").is_file());
    // Nothing else was left behind (no temporary files).
    let mut left: Vec<String> = fs::read_dir(&d)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(
        left,
        [
            "arm.urdf",
            "link.xml",
            "mine.xml",
            "models",
            "s.toml",
            "scene.json",
            "scene.xml",
            "sub"
        ]
    );
    let _ = fs::remove_dir_all(&d);
}

/// Bad input, exit code 2 with a message that says what to do: a planar scenario, an unknown
/// format, a format that contradicts --out's extension, an unknown scenario, no scenario.
#[test]
fn export_errors_name_the_problem() {
    let d = scratch("errors");
    let cases: &[(&[&str], &str)] = &[
        (
            &["export", "paper"],
            "planar export: embedded scenario `paper` is a planar scenario",
        ),
        (&["export", "paper", "--format", "json"], "planar export:"),
        (
            &["export", "dual-ur5", "--format", "urdf"],
            "invalid value 'urdf' for '--format",
        ),
        (
            &["export", "dual-ur5", "--format", "json", "--out", "x.xml"],
            "--format json but --out x.xml names a .xml file",
        ),
        (&["export", "dual-ur6"], "dual-ur5"),
        (&["export"], "SCENARIO"),
    ];
    for (args, want) in cases {
        let o = tandem(&d, args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(stdout(&o).is_empty(), "{args:?}");
    }
    assert!(
        fs::read_dir(&d).expect("list").next().is_none(),
        "nothing written"
    );
    // The format follows --out's extension; `-` is standard output.
    exit(&tandem(&d, &["export", "dual-ur5", "--out", "a.json"]), 0);
    assert!(
        fs::read_to_string(d.join("a.json"))
            .expect("read")
            .starts_with('{')
    );
    let o = tandem(
        &d,
        &["export", "dual-ur5", "--out", "-", "--format", "json"],
    );
    exit(&o, 0);
    assert!(stdout(&o).starts_with('{'));
    // A compliant grasp cannot be a MuJoCo weld: MJCF refuses with the field, JSON gives it.
    let o = tandem(&d, &["scenario", "show", "dual-ur5"]);
    // (A plant step that resolves the grasp spring's mode: 1 ms is refused at validation; the
    // damping about critical on the UR5 wrist, which 0.25 ms resolves.)
    let text = stdout(&o)
        .replace(
            "baumgarte = 20.0",
            "baumgarte = 20.0\ncompliant_grasps = { stiffness = [1e5, 1e5, 1e5, 1e3, 1e3, 1e3], damping = [283.0, 283.0, 283.0, 0.5, 0.5, 0.5] }",
        )
        .replacen("plant_step = 0.001 ", "plant_step = 0.00025 ", 1);
    fs::write(d.join("soft.toml"), text).expect("write");
    let o = tandem(&d, &["export", "soft.toml"]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("mjcf export: plant.compliant_grasps"),
        "{}",
        stderr(&o)
    );
    let o = tandem(&d, &["export", "soft.toml", "--format", "json"]);
    exit(&o, 0);
    let js: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(js["grasps"]["model"], "compliant");
    let _ = fs::remove_dir_all(&d);
}
