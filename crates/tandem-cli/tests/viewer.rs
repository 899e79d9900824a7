//! The 3-D viewer (SPEC-spatial S7): the page and the snapshots of a kinematic playback of the
//! S6 path on the dual-UR5 and dual-Franka set-ups, the edge cases (no wrenches, one frame,
//! NaN in a state, 7-DOF arms), and the page in a real browser (headless Chromium through
//! `tests/browser/viewer_check.js`: no network request, no console error, the arms move).
//!
//! The browser test needs `/usr/bin/chromium` (or `TANDEM_CHROMIUM`), `node` and
//! `npm ci` in `tests/browser`, so a plain `cargo test` lists it as ignored (with what it needs);
//! `.ci/run` installs them and runs it with `--ignored`, where anything missing fails it.
//!

use tandem_cli::view::spatial as viewer;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use tandem::nalgebra::Vector3;
use tandem::reference::spatial::path::{CircleParams, Se3Path};
use viewer::{Scene3d, demo};

mod support;
use support::*;

const BOX: [f64; 3] = [0.4, 0.2, 0.2];

/// The S6 path played kinematically on the dual UR5 over `seconds` at `fps`.
fn ur5_scene(seconds: f64, fps: f64) -> Scene3d {
    let path = Se3Path::spec_s6();
    let pb = demo::play(&tandem::presets::dual_ur5(), &path, seconds, fps).expect("playback");
    demo::scene("dual UR5, S6 path, kinematic playback", &pb, &path, BOX)
}

/// The S6 circle about the Franka set-up's start (box at z = 0.35 m), played kinematically.
fn franka_scene(seconds: f64, fps: f64) -> Scene3d {
    let mut c = CircleParams::spec_s6();
    c.center = Vector3::new(-0.1, 0.0, 0.35);
    let path = Se3Path::circle(&c).expect("circle");
    let pb = demo::play(&tandem::presets::dual_franka(), &path, seconds, fps).expect("playback");
    demo::scene("dual Franka, kinematic playback", &pb, &path, BOX)
}

/// The JSON embedded in a page.
fn page_data(html: &str) -> Value {
    let start = html
        .find(r#"<script id="scene-data" type="application/json">"#)
        .expect("data element")
        + r#"<script id="scene-data" type="application/json">"#.len();
    let end = start + html[start..].find("</script>").expect("end of data");
    serde_json::from_str(&html[start..end]).expect("the embedded data is JSON")
}

/// Writes the page and the snapshots into a fresh folder; checks what every page must hold.
fn write_all(scene: &Scene3d, name: &str) -> (PathBuf, String) {
    let dir = scratch(name);
    let html_path = viewer::write_viewer_file(scene, &dir).expect("write viewer.html");
    viewer::write_snapshots(scene, &dir).expect("write snapshots");
    let html = fs::read_to_string(&html_path).expect("read page");
    // Self-contained: no reference to anything outside the file.
    for bad in ["http://", "https://", "src=", "@import", "url("] {
        assert!(!html.contains(bad), "{name}: the page contains {bad:?}");
    }
    assert!(html.contains(r#"<link rel="icon" href="data:,">"#));
    assert_eq!(
        listing(&dir),
        [
            "snapshot_front.png",
            "snapshot_front.svg",
            "snapshot_side.png",
            "snapshot_side.svg",
            "snapshot_top.png",
            "snapshot_top.svg",
            "viewer.html",
        ],
        "{name}: only the outputs, no temporary file left"
    );
    for v in ["front", "side", "top"] {
        let png = fs::read(dir.join(format!("snapshot_{v}.png"))).expect("png");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{name}: {v} is a PNG");
        let svg = fs::read_to_string(dir.join(format!("snapshot_{v}.svg"))).expect("svg");
        assert!(
            svg.contains("<svg") && svg.contains("[m]"),
            "{name}: {v} svg"
        );
    }
    (html_path, html)
}

#[test]
fn dual_ur5_playback_page_and_snapshots() {
    // A full lap at 30 frames per second: the S6 run's length.
    let scene = ur5_scene(60.0, 30.0);
    assert_eq!(scene.times.len(), 1801);
    assert_eq!(scene.arms.len(), 2);
    assert_eq!(scene.arms[0].joints[0].len(), 6);
    // Forward kinematics closes the chain: each tool sits on its grasp (0.2 m from the centre
    // along the box's long axis), and the box follows the S6 circle.
    for k in [0, 450, 900, 1800] {
        let (p, _) = scene.object.poses[k];
        let d = Se3Path::spec_s6().sample(scene.times[k]).p;
        assert!(
            (Vector3::from(p) - d).norm() < 1e-12,
            "frame {k}: box on the path"
        );
        for a in &scene.arms {
            let t = Vector3::from(a.tool[k].0);
            assert!(
                ((t - Vector3::from(p)).norm() - 0.2).abs() < 1e-6,
                "frame {k}"
            );
        }
    }
    let (path, html) = write_all(&scene, "ur5");
    let size = fs::metadata(&path).unwrap().len();
    println!("dual UR5, 60 s at 30 fps: viewer.html {size} bytes");
    assert!(
        size < 2_000_000,
        "a minute at 30 fps stays small ({size} B)"
    );
    let data = page_data(&html);
    assert_eq!(data["times"].as_array().unwrap().len(), 1801);
    assert_eq!(data["arms"][0]["joints"][0].as_array().unwrap().len(), 6);
    assert_eq!(data["wrenches"][0].as_array().unwrap().len(), 2);
    assert_eq!(data["scalars"].as_array().unwrap().len(), 3);
    assert!(data["valid"].as_array().unwrap().iter().all(|v| v == true));
    // Rounded to 0.1 mm: the base of arm 1 at x = −0.7 m.
    assert_eq!(data["arms"][0]["base"], serde_json::json!([-0.7, 0, 0]));
}

#[test]
fn dual_franka_seven_dof() {
    let scene = franka_scene(20.0, 10.0);
    assert_eq!(scene.arms[0].joints[0].len(), 7);
    let (_, html) = write_all(&scene, "franka");
    let data = page_data(&html);
    assert_eq!(data["arms"][1]["joints"][5].as_array().unwrap().len(), 7);
}

/// The edge cases: no wrenches, a single frame, a NaN in a state.
fn edge_scenes() -> Vec<(&'static str, Scene3d)> {
    let mut no_wrench = ur5_scene(4.0, 10.0);
    no_wrench.wrenches.clear();
    no_wrench.scalars.clear();
    let single = ur5_scene(0.0, 30.0);
    assert_eq!(single.times.len(), 1);
    // NaN in a state: a joint angle of arm 2 at frames 10..15 (as a faulted run would log).
    let path = Se3Path::spec_s6();
    let mut pb = demo::play(&tandem::presets::dual_ur5(), &path, 4.0, 10.0).unwrap();
    for k in 10..15 {
        pb.states[k][8] = f64::NAN;
    }
    pb.states[20][0] = f64::INFINITY;
    let nan = demo::scene("NaN in a state", &pb, &path, BOX);
    vec![
        ("no-wrenches", no_wrench),
        ("single-frame", single),
        ("nan-state", nan),
    ]
}

#[test]
fn edge_cases_write_whole_pages() {
    for (name, scene) in edge_scenes() {
        let (_, html) = write_all(&scene, name);
        let data = page_data(&html);
        match name {
            "no-wrenches" => assert_eq!(data["wrenches"], serde_json::json!([])),
            "single-frame" => assert_eq!(data["times"], serde_json::json!([0])),
            "nan-state" => {
                let valid = data["valid"].as_array().unwrap();
                let bad: Vec<usize> = (0..valid.len()).filter(|&k| valid[k] == false).collect();
                assert_eq!(bad, [10, 11, 12, 13, 14, 20]);
                assert!(data["arms"][1]["joints"][12].is_null());
                assert!(
                    data["notes"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .any(|n| n.as_str().unwrap().contains("6 of 41 frames"))
                );
            }
            _ => unreachable!(),
        }
    }
}

#[test]
fn state_of_the_wrong_length_is_a_skipped_frame() {
    let setup = tandem::presets::dual_ur5();
    let plant = tandem::plant::spatial::SpatialPlant::new(&setup.params).unwrap();
    let good = plant
        .initial_state(&setup.x_wo, &Default::default(), &setup.q_guess)
        .unwrap();
    let states = vec![good.clone(), vec![0.0; 3], good];
    let scene = viewer::scene_from_states("short state", &plant, BOX, &[0.0, 0.1, 0.2], &states);
    assert!(scene.arms[0].joints[1].iter().all(|p| p[0].is_nan()));
    assert!(scene.object.poses[1].0[0].is_nan());
    let data = viewer::scene_json(&scene);
    assert_eq!(data["valid"], serde_json::json!([true, false, true]));
    assert!(data["object"][1].is_null() && data["arms"][1]["tool"][1].is_null());
    assert_eq!(data["arms"][0]["name"], "arm 1 (ur5)");
}

#[test]
fn no_frame_at_all() {
    let scene = Scene3d {
        title: "empty".into(),
        ..Scene3d::default()
    };
    let html = viewer::write_viewer(&scene);
    assert_eq!(page_data(&html)["times"], serde_json::json!([]));
    let dir = scratch("empty");
    let err = viewer::write_snapshots(&scene, &dir).unwrap_err();
    assert!(err.to_string().contains("no frame"), "{err}");
    assert!(listing(&dir).is_empty(), "nothing written");
}

#[test]
fn script_text_cannot_close_the_page() {
    let mut scene = ur5_scene(0.0, 30.0);
    scene.title = "a</script><script>alert(1)</script>".into();
    scene.notes.push("</script>".into());
    let html = viewer::write_viewer(&scene);
    assert_eq!(html.matches("</script>").count(), 2, "only the page's own");
    assert_eq!(
        page_data(&html)["title"],
        "a</script><script>alert(1)</script>"
    );
}

// ---------------------------------------------------------------------------------------------
// In a real browser.

/// Chromium and the Node script's folder, or why the browser test cannot run.
fn browser() -> Result<(PathBuf, PathBuf), String> {
    let exe = PathBuf::from(
        std::env::var("TANDEM_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into()),
    );
    if !exe.exists() {
        return Err(format!("no Chromium at {}", exe.display()));
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser");
    if !dir.join("node_modules/playwright-core").exists() {
        return Err(format!(
            "no node_modules in {} (run `npm ci` there)",
            dir.display()
        ));
    }
    match Command::new("node").arg("--version").output() {
        Ok(o) if o.status.success() => Ok((exe, dir)),
        _ => Err("no `node` on PATH".into()),
    }
}

/// Runs the Node check on a page; panics with its output when it fails.
fn check_in_browser(exe: &Path, dir: &Path, html: &Path) -> Value {
    let out_dir = html.parent().unwrap();
    let out = Command::new("node")
        .arg(dir.join("viewer_check.js"))
        .arg(html)
        .arg(out_dir)
        .arg(exe)
        .output()
        .expect("run node");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{}: the browser check failed\nstdout: {stdout}\nstderr: {stderr}",
        html.display()
    );
    let line = stdout.lines().last().unwrap_or("");
    serde_json::from_str(line).unwrap_or_else(|e| panic!("report {line:?}: {e}"))
}

#[test]
#[ignore = "needs Chromium, Node and `npm ci` in crates/tandem-cli/tests/browser (.ci/run installs them); run with --ignored"]
fn renders_in_headless_chromium() {
    let (exe, dir) = browser().unwrap_or_else(|why| {
        panic!("the browser test needs Chromium, Node and playwright-core: {why} (.ci/run installs them)")
    });
    // The dual-UR5 lap: no request but the file, no console error, something drawn, and the
    // arms' region differs between t = 0 and t = T/2 (the box is half a lap round).
    let (html, _) = write_all(&ur5_scene(60.0, 30.0), "browser-ur5");
    let r = check_in_browser(&exe, &dir, &html);
    println!("dual UR5 in Chromium: {r}");
    let file_url = format!("file://{}", html.display());
    assert_eq!(r["requests"], serde_json::json!([file_url]));
    assert_eq!(r["problems"], serde_json::json!([]));
    assert_eq!(r["frames"], 1801);
    assert_eq!(r["t"], serde_json::json!([0, 30]));
    let nb = r["non_background_share"].as_f64().unwrap();
    assert!(nb > 0.03, "the 3-D view is not blank ({nb})");
    let d = r["arm_box_diff_share"].as_f64().unwrap();
    assert!(
        d > 0.05 && r["arm_box_pixels"].as_u64().unwrap() > 20_000,
        "the arms moved on screen ({d} of {} pixels differ)",
        r["arm_box_pixels"]
    );
    // The controls: space plays (at 4× for 0.5 s) and pauses; buttons, orbit, zoom and pan
    // change the picture.
    let c = &r["controls"];
    let played = c["space_played_s"].as_f64().unwrap();
    // (Loose bounds: a loaded machine may draw fewer frames; 2 s is typical.)
    assert!(
        played > 0.1 && played < 30.0,
        "played {played} s of the run"
    );
    for k in [
        "space_paused",
        "top_button",
        "reset_button",
        "orbit",
        "zoom",
        "pan",
    ] {
        assert_eq!(c[k], true, "control {k}: {c}");
    }
    // The 7-DOF pair and the edge cases render without error too.
    let (html, _) = write_all(&franka_scene(20.0, 10.0), "browser-franka");
    let r = check_in_browser(&exe, &dir, &html);
    assert!(r["arm_box_diff_share"].as_f64().unwrap() > 0.05, "{r}");
    // No frame at all: the page still loads without error (the snapshots refuse, see above).
    let empty = Scene3d {
        title: "empty".into(),
        ..Scene3d::default()
    };
    let html = viewer::write_viewer_file(&empty, &scratch("browser-empty")).unwrap();
    let r = check_in_browser(&exe, &dir, &html);
    let hud = r["hud_text"][0].as_str().unwrap();
    assert!(hud.contains("no frame with finite values"), "{hud}");
    for (name, scene) in edge_scenes() {
        let (html, _) = write_all(&scene, &format!("browser-{name}"));
        let r = check_in_browser(&exe, &dir, &html);
        println!("{name} in Chromium: {r}");
        assert!(r["non_background_share"].as_f64().unwrap() > 0.03, "{name}");
        if name == "nan-state" {
            // t = T/2 = 2 s is frame 20, whose state holds an infinity: the HUD says so.
            let hud = r["hud_text"][1].as_str().unwrap();
            assert!(
                hud.contains("non-finite values: frame 20 is shown"),
                "{hud}"
            );
        }
        if name == "single-frame" {
            assert_eq!(r["arm_box_diff_share"], 0.0, "one frame: nothing moves");
        }
    }
}

/// Pads in the snapshots: the end pose's pads outlined and grouped by their state then (a
/// legend entry per state present), on the tool they ride; a pad of an arm that does not exist
/// or without a state is skipped, not drawn at the origin.
#[test]
fn snapshots_draw_the_pads_by_state() {
    let mut scene = ur5_scene(1.0, 10.0);
    let frames = scene.times.len();
    let pad = |arm: usize, n: f64, last: f64| viewer::PadTrack {
        arm,
        position: [0.0, 0.0, 0.0],
        normal: [0.0, 0.0, n],
        radius: 0.01,
        mu: 0.3,
        state: {
            let mut s = vec![0.0; frames];
            *s.last_mut().unwrap() = last;
            s
        },
    };
    scene.pads = vec![pad(0, 1.0, 0.0), pad(1, 1.0, 1.0), pad(5, 1.0, 2.0)];
    scene.pads.push(viewer::PadTrack {
        state: Vec::new(),
        ..pad(0, -1.0, 0.0)
    });
    let (html_path, _) = write_all(&scene, "pads");
    let dir = html_path.parent().unwrap();
    let svg = fs::read_to_string(dir.join("snapshot_front.svg")).unwrap();
    assert!(
        svg.contains("pads: stick") && svg.contains("pads: slip"),
        "legend"
    );
    assert!(
        !svg.contains("pads: separated"),
        "arm 6 does not exist: nothing drawn"
    );
}
