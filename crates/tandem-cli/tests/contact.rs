//! Contact grasps in scenario files (issue 25): `[plant.contact_grasps]` builds the library's
//! contact model, a run's `summary.json` reports the pads (slip, events, cone margins), and every
//! bad value gets an error naming the field with its line.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tandem_cli::scenario::spatial as sp;
use tandem_cli::scenario::{EMBEDDED, embedded_source};

fn tandem(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("tandem runs")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tandem-contact-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn grip_text() -> &'static str {
    EMBEDDED
        .iter()
        .find(|e| e.name == "dual-ur5-grip")
        .expect("embedded")
        .text
}

/// The embedded preset builds the library's contact model: four pads, μ = 0.3, 100 N, on the
/// box's half extents; and its plant is the dual-UR5 preset's but for the grasps.
#[test]
fn the_grip_preset_builds_contact_grasps() {
    let src = embedded_source(EMBEDDED.iter().find(|e| e.name == "dual-ur5-grip").unwrap());
    let sc = sp::parse(&src).unwrap();
    let b = sp::build(&sc, &src).unwrap();
    let tandem::plant::spatial::GraspModel::Contact(c) = &b.plant.grasp_model else {
        panic!("contact grasps");
    };
    assert_eq!(
        (c.mu, c.torsion, c.grip.clone()),
        (0.3, 0.002, vec![100.0; 2])
    );
    assert_eq!(c.pads.len(), 2);
    assert!(c.pads.iter().all(|p| p.len() == 2));
    assert_eq!(c.half_extents, nalgebra::Vector3::new(0.2, 0.1, 0.1));
    // The library's preset, bit for bit; the controller's friction model is its pads.
    assert_eq!(b.plant, tandem::presets::dual_ur5_grip().params);
    assert_eq!(
        b.controller.friction,
        Some(tandem::control::spatial::distribute::friction::FrictionParams::from_contact(c, 2.0))
    );
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
}

/// A short run of the preset with PD + gravity: the box is held (no slip, every pad in contact
/// with a positive margin) and the summary says so; a welded run's summary has `contacts: null`
/// with the reason.
#[test]
fn a_run_reports_the_pads() {
    let d = tmp("run");
    let o = tandem(
        &[
            "run",
            "dual-ur5-grip",
            "--controller",
            "pd-gravity",
            "--duration",
            "1",
            "--out",
            "grip",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("grip/summary.json")).unwrap()).unwrap();
    let c = &s["contacts"];
    assert_eq!(c["slipped"], false, "{c}");
    // The friction-aware distribution ran every tick, converged, never fell back.
    let dist = &c["distribution"];
    assert_eq!(dist["mode"], "friction", "{dist}");
    assert_eq!(dist["ticks"], 1000, "{dist}");
    assert_eq!(dist["fallbacks"], 0, "{dist}");
    assert_eq!(dist["unconverged"], 0, "{dist}");
    assert!(
        dist["min_planned_margin_N"].as_f64().unwrap() >= 1.0,
        "{dist}"
    );
    assert_eq!(c["events_total"], 0, "{c}");
    assert_eq!(c["slip_distance_m"], serde_json::json!([0.0, 0.0]));
    let pads = c["pads"].as_array().unwrap();
    assert_eq!(pads.len(), 4);
    for p in pads {
        assert_eq!(p["final_status"], "stick", "{p}");
        let m = p["min_margin_N"].as_f64().unwrap();
        // The path's accelerations take a fraction of the friction (0.3 × 100 N a pad).
        assert!(m > 10.0 && m < 0.3 * 100.0 * 1.5, "{p}");
        assert!(p["min_margin_t_s"].as_f64().unwrap() <= 1.0);
        // The elliptic cone's margin (N of normal force) is at most the tangential one / μ.
        let mc = p["min_cone_margin_N"].as_f64().unwrap();
        assert!(mc > 0.0 && mc <= m / 0.3 + 1e-9, "{p}");
        // The bottom pads carry the weight: 100 N ± the gripper's share of 29.4 N.
        let n = p["final_normal_N"].as_f64().unwrap();
        assert!((n - 100.0).abs() < 20.0, "{p}");
    }
    // The viewer draws the four pads with their cones and states (0: stick), and the time
    // series has their columns.
    let html = std::fs::read_to_string(d.join("grip/viewer.html")).unwrap();
    let at = html.find("\"pads\":[{").expect("pads in the viewer's data");
    let pads_json = &html[at..at + 2000.min(html.len() - at)];
    assert!(
        pads_json.contains("\"arm\":0") && pads_json.contains("\"mu\":0.3"),
        "{pads_json}"
    );
    assert!(pads_json.contains("\"state\":[0,0,"), "{pads_json}");
    let csv = std::fs::read_to_string(d.join("grip/timeseries.csv")).unwrap();
    let head = csv.lines().next().unwrap();
    for c in ["pad1.1.normal [N]", "pad2.2.margin [N]", "pad1.2.state [1]"] {
        assert!(head.contains(c), "{c} not in {head}");
    }
    // A welded run: `contacts` is null with the reason.
    let o = tandem(
        &["run", "dual-ur5", "--duration", "0.05", "--out", "weld"],
        &d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("weld/summary.json")).unwrap()).unwrap();
    assert!(s["contacts"].is_null());
    assert!(
        s["unavailable"]["contacts"]
            .as_str()
            .unwrap()
            .contains("contact_grasps")
    );
}

/// The grip scenario with `edits` applied, validated: exit 2 and every fragment of `want` in
/// the error.
fn bad(d: &Path, edits: &[(&str, &str)], want: &[&str]) {
    let mut text = grip_text().to_string();
    for (a, b) in edits {
        assert!(text.contains(a), "edit `{a}` not in the preset");
        text = text.replacen(a, b, 1);
    }
    let file = d.join("grip.toml");
    std::fs::write(&file, &text).unwrap();
    let o = tandem(&["validate", file.to_str().unwrap()], d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{edits:?}: {err}");
    for w in want {
        assert!(err.contains(w), "{edits:?}: `{w}` not in:\n{err}");
    }
}

fn line_of(needle: &str) -> String {
    let at = grip_text().find(needle).unwrap();
    format!("line {}", grip_text()[..at].matches('\n').count() + 1)
}

#[test]
fn bad_contact_values_name_the_field_and_line() {
    let d = tmp("bad");
    let mu = line_of("mu = 0.3");
    bad(
        &d,
        &[("mu = 0.3", "mu = 0.0")],
        &["plant.contact_grasps.mu", "positive", &mu],
    );
    bad(
        &d,
        &[("mu = 0.3", "mu = nan")],
        &["plant.contact_grasps.mu", "NaN"],
    );
    bad(
        &d,
        &[("mu = 0.3", "mu = -0.3")],
        &["plant.contact_grasps.mu"],
    );
    // A torsion coefficient without a friction coefficient.
    bad(
        &d,
        &[("mu = 0.3\n", "")],
        &[
            "plant.contact_grasps.torsion",
            "needs a friction coefficient",
        ],
    );
    bad(
        &d,
        &[("torsion = 0.002", "torsion = -0.002")],
        &["plant.contact_grasps.torsion"],
    );
    bad(
        &d,
        &[("grip = 100.0", "grip = -5.0")],
        &["plant.contact_grasps.grip", &line_of("grip = 100.0")],
    );
    bad(
        &d,
        &[("normal_stiffness = 1e5", "normal_stiffness = 0.0")],
        &["plant.contact_grasps.normal_stiffness"],
    );
    // A pad that does not touch its face at the start pose (1 mm off the top face).
    bad(
        &d,
        &[(
            "position = [-0.1, 0.0, 0.03]",
            "position = [-0.101, 0.0, 0.03]",
        )],
        &[
            "plant.contact_grasps.pads[0].position",
            "does not touch",
            "1.0000 mm",
        ],
    );
    // A pad outside its face (a 12 cm pad on a 20 cm wide face, 3 cm from its end).
    bad(
        &d,
        &[(
            "normal = [1.0, 0.0, 0.0], radius = 0.01",
            "normal = [1.0, 0.0, 0.0], radius = 0.06",
        )],
        &["plant.contact_grasps.pads[0]", "outside the face"],
    );
    // A pad pressing at a slant.
    bad(
        &d,
        &[("normal = [1.0, 0.0, 0.0]", "normal = [1.0, 0.1, 0.0]")],
        &["plant.contact_grasps.pads[0].normal", "off the normal"],
    );
    // Compliant and contact grasps at once.
    bad(
        &d,
        &[(
            "\n[plant.contact_grasps]",
            "\n[plant.compliant_grasps]\nstiffness = [1e5, 1e5, 1e5, 100.0, 100.0, 100.0]\ndamping = [1.0, 1.0, 1.0, 0.1, 0.1, 0.1]\n\n[plant.contact_grasps]",
        )],
        &["plant.contact_grasps", "not both"],
    );
    // A step the pads' fastest mode cannot take.
    bad(
        &d,
        &[("plant_step = 0.0001", "plant_step = 0.001")],
        &["run.plant_step", "wrist_3_link", "unstable"],
    );
    // No pads at all: the file's list is named.
    let pads = grip_text()
        .split_once("pads = [\n")
        .and_then(|(_, rest)| rest.split_once("\n]\n"))
        .map(|(body, _)| format!("pads = [\n{body}\n]\n"))
        .unwrap();
    bad(
        &d,
        &[(pads.as_str(), "pads = []\n")],
        &["plant.contact_grasps.pads:", "at least one pad"],
    );
    // The distribution's settings.
    bad(
        &d,
        &[("friction_margin = 2.0", "friction_margin = -1.0")],
        &["controller.friction_margin", "≥ 0"],
    );
    bad(
        &d,
        &[("distribution = \"friction\"", "distribution = \"weld\"")],
        &["controller.friction_margin", "distribution = \"friction\""],
    );
    bad(
        &d,
        &[("distribution = \"friction\"", "distribution = \"magic\"")],
        &["distribution", "magic"],
    );
    // An unknown key.
    bad(
        &d,
        &[("grip = 100.0", "grip = 100.0\nfriction = 0.3")],
        &["friction", "unknown field"],
    );
}

/// Planar grasps are welds: a planar file with contact grasps is refused by the field.
#[test]
fn planar_contact_grasps_are_refused() {
    let d = tmp("planar");
    let paper = EMBEDDED.iter().find(|e| e.name == "paper").unwrap().text;
    let text = format!("{paper}\n[plant.contact_grasps]\nmu = 0.5\ngrip = 10.0\npads = []\n");
    // The planar file may already have a [plant] table: append into it instead.
    let text = if paper.contains("\n[plant]\n") {
        paper.replacen(
            "\n[plant]\n",
            "\n[plant.contact_grasps]\nmu = 0.5\ngrip = 10.0\npads = []\n\n[plant]\n",
            1,
        )
    } else {
        text
    };
    let file = d.join("p.toml");
    std::fs::write(&file, text).unwrap();
    let o = tandem(&["validate", file.to_str().unwrap()], &d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("plant.contact_grasps") && err.contains("planar grasps are welds"),
        "{err}"
    );
}

/// The friction-aware distribution needs contact grasps.
#[test]
fn the_friction_distribution_needs_contact_grasps() {
    let d = tmp("dist");
    let ur5 = EMBEDDED.iter().find(|e| e.name == "dual-ur5").unwrap().text;
    let text = ur5.replacen(
        "kind = \"nn\"",
        "kind = \"nn\"\ndistribution = \"friction\"",
        1,
    );
    let file = d.join("u.toml");
    std::fs::write(&file, text).unwrap();
    let o = tandem(&["validate", file.to_str().unwrap()], &d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("controller.distribution") && err.contains("[plant.contact_grasps]"),
        "{err}"
    );
}

/// `gauge_only = true`: the grasps stay welds (or springs) and the pads report the force each
/// would carry. On the grip preset the gauged welds give the held pads' normal forces (the
/// box's weight and the grip: the same statics) to 0.2 N of 100 N after the start's
/// transient, say `held_by = "gauge"`, and name the first tick a weaker grip would slip; the
/// JSON export carries the pads; springs take a gauge too.
#[test]
fn gauged_welds_and_springs_report_the_friction_they_would_need() {
    let d = tmp("gauge");
    let gauged = grip_text().replacen("grip = 100.0", "gauge_only = true\ngrip = 100.0", 1);
    let weak = gauged.replacen("grip = 100.0", "grip = 8.0", 1);
    let springs = gauged.replacen(
        "\n[plant.contact_grasps]\n",
        "\n[plant.compliant_grasps]\nstiffness = [1e5, 1e5, 1e5, 1e3, 1e3, 1e3]\ndamping = [200.0, 200.0, 200.0, 0.3, 0.3, 0.3]\n\n[plant.contact_grasps]\n",
        1,
    );
    for (name, text) in [("gauged", &gauged), ("weak", &weak), ("springs", &springs)] {
        std::fs::write(d.join(format!("{name}.toml")), text).unwrap();
    }
    let run = |file: &str, out: &str, law: &str| -> serde_json::Value {
        let o = tandem(
            &[
                "run",
                file,
                "--controller",
                law,
                "--duration",
                "1",
                "--out",
                out,
            ],
            &d,
        );
        assert!(
            o.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(out).join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(s["status"], "completed", "{file}");
        s["contacts"].clone()
    };
    let held = run("dual-ur5-grip", "held", "pd-gravity");
    let gauge = run("gauged.toml", "gauged", "pd-gravity");
    assert_eq!(held["held_by"], "friction");
    assert_eq!(gauge["held_by"], "gauge", "{gauge}");
    assert_eq!(gauge["would_slip"], false, "{gauge}");
    assert!(gauge.get("slip_distance_m").is_none(), "{gauge}");
    assert_eq!(gauge["distribution"]["mode"], "friction");
    assert_eq!(gauge["distribution"]["fallbacks"], 0);
    let (hp, gp) = (
        held["pads"].as_array().unwrap(),
        gauge["pads"].as_array().unwrap(),
    );
    assert_eq!(gp.len(), 4);
    for (h, g) in hp.iter().zip(gp) {
        let (nh, ng) = (
            h["final_normal_N"].as_f64().unwrap(),
            g["final_normal_N"].as_f64().unwrap(),
        );
        assert!((nh - ng).abs() < 0.2, "held {h}\ngauged {g}");
        assert_eq!(g["final_status"], "stick", "{g}");
        assert!(g["min_cone_margin_N"].as_f64().unwrap() > 0.0, "{g}");
    }
    // 8 N a pad cannot hold the 3 kg box's 29.4 N by friction (4 × 0.3 × 8 = 9.6 N): the
    // welds carry it, and the gauge says the pads would have slipped from the first ticks.
    let w = run("weak.toml", "weak", "pd-gravity");
    assert_eq!(w["would_slip"], true, "{w}");
    assert!(w["first_would_slip_t_s"].as_f64().unwrap() < 0.01, "{w}");
    assert!(w["events_total"].as_u64().unwrap() >= 1, "{w}");
    // Springs gauged (under the NN law: PD + gravity chatters on these wrist springs, and
    // the gauge then reports pads far outside their cones, issue 24): the same statics.
    let s = run("springs.toml", "springs", "nn");
    assert_eq!(s["held_by"], "gauge", "{s}");
    assert_eq!(s["would_slip"], false, "{s}");
    for (h, g) in hp.iter().zip(s["pads"].as_array().unwrap()) {
        let (nh, ng) = (
            h["final_normal_N"].as_f64().unwrap(),
            g["final_normal_N"].as_f64().unwrap(),
        );
        assert!((nh - ng).abs() < 0.5, "held {h}\nsprings {g}");
    }
    // The terminal table says so.
    let o = tandem(
        &["run", "gauged.toml", "--duration", "0.05", "--out", "t"],
        &d,
    );
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("gauged: pads would hold"), "{table}");
    assert!(table.contains("min friction-cone margin"), "{table}");
    // The JSON export carries the gauge's pads; the grasps are welds.
    let o = tandem(&["export", "gauged.toml", "--format", "json"], &d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["grasps"]["model"], "weld", "{}", j["grasps"]);
    assert_eq!(j["pad_gauge"]["model"], "gauge");
    assert_eq!(j["pad_gauge"]["grip"], serde_json::json!([100.0, 100.0]));
}
