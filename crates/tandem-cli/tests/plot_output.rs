//! Figures, animations and all-or-nothing outputs of the CLI.
//!
//! The modules are the CLI library's (`tandem_cli::figures::plot`, `files`, `view::planar::anim`).

use tandem_cli::figures::plot;
use tandem_cli::files as output;
use tandem_cli::view::planar::anim;

use std::fs;

use plot::{Panel, Series, Style};

mod support;
use support::*;

/// The paper's circle and a tracking trace with a decaying transient and deterministic noise.
struct Demo {
    t: Vec<f64>,
    xd: Vec<f64>,
    yd: Vec<f64>,
    xo: Vec<f64>,
    yo: Vec<f64>,
    z1x: Vec<f64>,
    z1y: Vec<f64>,
}

fn demo(n: usize) -> Demo {
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.03).collect();
    let noise = |i: usize| ((i as f64 * 12.9898).sin() * 43758.5453).fract() - 0.5;
    let xd: Vec<f64> = t.iter().map(|t| 0.2 * (0.1 * t).cos()).collect();
    let yd: Vec<f64> = t.iter().map(|t| 0.2 * (0.1 * t).sin()).collect();
    let xo: Vec<f64> = (0..n)
        .map(|i| xd[i] - 0.01 * (-2.0 * t[i]).exp() + 0.001 * noise(i))
        .collect();
    let yo: Vec<f64> = (0..n).map(|i| yd[i] + 0.001 * noise(i + n)).collect();
    let z1x = (0..n).map(|i| xo[i] - xd[i]).collect();
    let z1y = (0..n).map(|i| yo[i] - yd[i]).collect();
    Demo {
        t,
        xd,
        yd,
        xo,
        yo,
        z1x,
        z1y,
    }
}

fn tracking_panels(d: &Demo) -> Vec<Panel<'_>> {
    vec![
        Panel::new("object x", "t [s]", "x [m]")
            .with(Series::new("x_o", &d.t, &d.xo, Style::solid(0)))
            .with(Series::new("x_d", &d.t, &d.xd, Style::dashed(1)))
            .bounds(0.35, "±k_c"),
        Panel::new("tracking error z1,x", "t [s]", "z1,x [m]").with(Series::new(
            "z1,x",
            &d.t,
            &d.z1x,
            Style::solid(0),
        )),
        Panel::new("object y", "t [s]", "y [m]")
            .with(Series::new("y_o", &d.t, &d.yo, Style::solid(0)))
            .with(Series::new("y_d", &d.t, &d.yd, Style::dashed(1)))
            .bounds(0.35, "±k_c"),
        Panel::new("tracking error z1,y", "t [s]", "z1,y [m]").with(Series::new(
            "z1,y",
            &d.t,
            &d.z1y,
            Style::solid(0),
        )),
    ]
}

#[test]
fn panels_write_png_and_svg() {
    let dir = scratch("panels");
    let d = demo(3001);
    let ps = tracking_panels(&d);
    plot::panels(&dir.join("tracking"), "Tracking (NN)", &ps, 2).expect("figure");
    let (w, h) = check_png(&dir.join("tracking.png"));
    assert_eq!((w, h), plot::figure_size(&ps, 2));
    assert_eq!(w, 1200);
    let svg = fs::read_to_string(dir.join("tracking.svg")).expect("svg");
    check_xml(&svg);
    for label in ["Tracking (NN)", "z1,x [m]", "t [s]", "±k_c", "x_d"] {
        assert!(svg.contains(label), "SVG shows '{label}'");
    }
    // Only the two figures, no temporary files left behind.
    assert_eq!(listing(&dir), vec!["tracking.png", "tracking.svg"]);
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn xy_path_writes_png_and_svg() {
    let dir = scratch("xy");
    let d = demo(3001);
    plot::xy_path(
        &dir.join("xy"),
        "Object path",
        (&d.xo, &d.yo),
        (&d.xd, &d.yd),
        Some((0.35, 0.35)),
        &[],
    )
    .expect("xy figure");
    let (w, h) = check_png(&dir.join("xy.png"));
    assert!(w >= 600 && h >= 600);
    check_xml(&fs::read_to_string(dir.join("xy.svg")).expect("svg"));
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn rendered_pixels_show_data_and_bounds() {
    let d = demo(3001);
    let ps = tracking_panels(&d);
    let size = (1200, 700);
    let rgb = plot::render_rgb("t", &ps, 2, size).expect("render");
    assert_eq!(rgb.len(), 3 * 1200 * 700);
    let count = |c: (u8, u8, u8)| rgb.chunks(3).filter(|p| (p[0], p[1], p[2]) == c).count();
    let white = count((255, 255, 255));
    let total = 1200 * 700;
    assert!(white > total / 2, "mostly white background");
    assert!(white < total * 98 / 100, "but something is drawn");
    assert!(count(plot::PALETTE[0]) > 2000, "blue data lines");
    assert!(count(plot::PALETTE[1]) > 500, "orange desired lines");
    assert!(count((0, 0, 0)) > 1000, "black dashed bounds");
}

#[test]
fn huge_and_constant_series_plot() {
    let n = 500_000;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-4).collect();
    let mut y: Vec<f64> = t.iter().map(|t| t.sin()).collect();
    y[n / 2] = 40.0; // a spike must survive decimation and set the range
    let flat = vec![2.0; n];
    let zeros = vec![0.0; 3];
    let ps = vec![
        Panel::new("huge", "t [s]", "y [-]").with(Series::new("y", &t, &y, Style::solid(0))),
        Panel::new("constant", "t [s]", "c [-]").with(Series::new("c", &t, &flat, Style::solid(2))),
        Panel::new("zeros", "t [s]", "z [-]").with(Series::new(
            "z",
            &t[..3],
            &zeros,
            Style::solid(3),
        )),
    ];
    let started = std::time::Instant::now();
    let svg = plot::render_svg("big", &ps, 3, (1500, 400)).expect("render");
    check_xml(&svg);
    // Decimated: far fewer points than samples.
    assert!(svg.len() < 1_500_000, "SVG is {} bytes", svg.len());
    assert!(started.elapsed().as_secs_f64() < 10.0);
}

#[test]
fn bad_figure_input_is_an_error_and_writes_nothing() {
    let dir = scratch("bad");
    let x = [0.0, 1.0, 2.0];
    let y = [0.0, 1.0];
    let ragged = [Panel::new("p", "t [s]", "y").with(Series::new("s", &x, &y, Style::solid(0)))];
    let err = plot::panels(&dir.join("bad"), "", &ragged, 1).expect_err("ragged series");
    assert!(format!("{err:#}").contains("3 points"), "{err:#}");
    let empty: [f64; 0] = [];
    let none =
        [Panel::new("p", "t [s]", "y").with(Series::new("s", &empty, &empty, Style::solid(0)))];
    assert!(plot::panels(&dir.join("none"), "", &none, 1).is_err());
    assert!(plot::panels(&dir.join("zero"), "", &[], 1).is_err());
    assert!(listing(&dir).is_empty(), "{:?}", listing(&dir));
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn csv_round_trips_exactly() {
    let dir = scratch("csv");
    let t: Vec<f64> = (0..1000).map(|i| i as f64 * 0.03).collect();
    let odd = [
        1.0 / 3.0,
        -0.0,
        1e-300,
        5e-324,
        f64::MAX,
        -2.5e-7,
        0.1 + 0.2,
        123456789.125,
    ];
    let x: Vec<f64> = (0..1000)
        .map(|i| odd[i % odd.len()] * (1 + i / 8) as f64)
        .collect();
    let header = vec![
        String::from("t [s]"),
        String::from("x_o.x [m]"),
        String::from("note, with comma [-]"),
    ];
    let path = dir.join("ts.csv");
    output::write_csv(&path, &header, &[&t, &x, &x]).expect("write");
    let mut r = csv::Reader::from_path(&path).expect("open");
    let got_header: Vec<String> = r
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    assert_eq!(got_header, header);
    let mut n = 0;
    for (i, rec) in r.records().enumerate() {
        let rec = rec.expect("record");
        assert_eq!(rec.len(), 3);
        let a: f64 = rec[0].parse().expect("t");
        let b: f64 = rec[1].parse().expect("x");
        assert_eq!(a.to_bits(), t[i].to_bits(), "row {i} t: {}", &rec[0]);
        assert_eq!(b.to_bits(), x[i].to_bits(), "row {i} x: {}", &rec[1]);
        n += 1;
    }
    assert_eq!(n, 1000);
    assert_eq!(listing(&dir), vec!["ts.csv"], "no temporary file left");
    // Mismatched columns: error, and the previous file is untouched.
    let before = fs::read(&path).expect("read");
    assert!(output::write_csv(&path, &header, &[&t, &x[..10], &x]).is_err());
    assert!(output::write_csv(&path, &header[..2], &[&t, &x, &x]).is_err());
    assert_eq!(fs::read(&path).expect("read"), before);
    assert_eq!(listing(&dir), vec!["ts.csv"]);
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn json_and_text_are_written_atomically() {
    let dir = scratch("json");
    let v = serde_json::json!({"rms_z1": [1e-4, 2e-4], "controller": "nn"});
    output::write_json_atomic(&dir.join("summary.json"), &v).expect("json");
    let back: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).expect("read"))
            .expect("parse");
    assert_eq!(back, v);
    output::write_text_atomic(&dir.join("a.txt"), "one").expect("text");
    output::write_text_atomic(&dir.join("a.txt"), "two").expect("overwrite");
    assert_eq!(fs::read_to_string(dir.join("a.txt")).expect("read"), "two");
    assert_eq!(listing(&dir), vec!["a.txt", "summary.json"]);
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn output_dir_refuses_existing_folder_without_force() {
    let parent = scratch("refuse");
    let fin = parent.join("run");
    fs::create_dir(&fin).expect("existing");
    fs::write(fin.join("old.txt"), "old").expect("old file");
    let err = output::OutputDir::create(&fin, false, &[]).expect_err("must refuse");
    let msg = err.to_string();
    assert!(msg.contains("exists") && msg.contains("--force"), "{msg}");
    // Nothing was created next to it, and the old results are intact.
    assert_eq!(listing(&parent), vec!["run"]);
    assert_eq!(fs::read_to_string(fin.join("old.txt")).expect("old"), "old");
    let _ = fs::remove_dir_all(&parent);
}

#[test]
fn output_dir_commit_creates_and_force_replaces() {
    let parent = scratch("commit");
    let fin = parent.join("run");

    // Fresh: written in a hidden temporary folder, visible only after commit.
    let out = output::OutputDir::create(&fin, false, &[]).expect("create");
    fs::write(out.path("a.txt"), "new").expect("write");
    assert!(!fin.exists(), "not visible before commit");
    assert_eq!(out.final_dir(), fin.as_path());
    let got = out.commit().expect("commit");
    assert_eq!(got, fin);
    assert_eq!(listing(&fin), vec![output::MARKER, "a.txt"]);
    assert_eq!(listing(&parent), vec!["run"]);

    // Existing + force: replaced whole (the old file does not survive), no leftovers.
    let out = output::OutputDir::create(&fin, true, &[]).expect("create with force");
    fs::write(out.path("b.txt"), "newer").expect("write");
    assert_eq!(
        listing(&fin),
        vec![output::MARKER, "a.txt"],
        "old intact until commit"
    );
    out.commit().expect("commit with force");
    assert_eq!(listing(&fin), vec![output::MARKER, "b.txt"]);
    assert_eq!(
        fs::read_to_string(fin.join("b.txt")).expect("read"),
        "newer"
    );
    assert_eq!(
        listing(&parent),
        vec!["run"],
        "no temporary or old folder left"
    );

    // Existing, created after a non-forced create: commit refuses and keeps the old one.
    let other = parent.join("other");
    let out = output::OutputDir::create(&other, false, &[]).expect("create");
    fs::write(out.path("c.txt"), "c").expect("write");
    fs::create_dir(&other).expect("someone else");
    assert!(out.commit().is_err());
    assert!(listing(&other).is_empty());
    // A folder tandem did not write (no marker) is refused by force, before and at commit.
    let err = output::OutputDir::create(&other, true, &[]).expect_err("no marker");
    assert!(err.to_string().contains(output::MARKER), "{err}");
    let out = output::OutputDir::create(&parent.join("third"), true, &[]).expect("create");
    fs::create_dir(parent.join("third")).expect("someone else, no marker");
    assert!(out.commit().is_err());
    fs::remove_dir(parent.join("third")).expect("rmdir");
    assert_eq!(
        listing(&parent),
        vec!["other", "run"],
        "temporary folder removed"
    );
    let _ = fs::remove_dir_all(&parent);
}

#[test]
fn dropped_output_dir_leaves_nothing() {
    let parent = scratch("drop");
    let fin = parent.join("run");
    {
        let out = output::OutputDir::create(&fin, false, &[]).expect("create");
        fs::create_dir(out.path("figures")).expect("subdir");
        fs::write(out.path("figures/x.txt"), "x").expect("write");
        assert_eq!(listing(&parent).len(), 1, "one temporary folder");
        // Dropped without commit (an error or a panic on the way).
    }
    assert!(listing(&parent).is_empty(), "{:?}", listing(&parent));
    // With force and an existing folder, dropping keeps the old results.
    fs::create_dir(&fin).expect("existing");
    fs::write(fin.join("keep.txt"), "keep").expect("write");
    fs::write(fin.join(output::MARKER), "").expect("marker");
    {
        let out = output::OutputDir::create(&fin, true, &[]).expect("create");
        fs::write(out.path("new.txt"), "n").expect("write");
    }
    assert_eq!(listing(&parent), vec!["run"]);
    assert_eq!(listing(&fin), vec![output::MARKER, "keep.txt"]);
    let _ = fs::remove_dir_all(&parent);
}

/// Two 2-link arms (l = 0.3 m, bases at ±0.38 m, mirrored elbows) holding a 0.1 m box.
fn two_arm_frames(d: &Demo) -> anim::AnimFrames {
    let ik = |base: f64, p: [f64; 2], elbow: f64| -> Vec<[f64; 2]> {
        let (dx, dy) = (p[0] - base, p[1]);
        let l = 0.3;
        let c2 = ((dx * dx + dy * dy - 2.0 * l * l) / (2.0 * l * l)).clamp(-1.0, 1.0);
        let q2 = elbow * c2.acos();
        let q1 = dy.atan2(dx) - (l * q2.sin()).atan2(l + l * q2.cos());
        vec![[base, 0.0], [base + l * q1.cos(), l * q1.sin()], p]
    };
    let frames = (0..d.t.len())
        .map(|i| {
            let (x, y, h) = (d.xo[i], d.yo[i], 0.05);
            anim::Frame {
                t: d.t[i],
                arms: vec![ik(-0.38, [x - h, y], -1.0), ik(0.38, [x + h, y], 1.0)],
                object: vec![
                    [x - h, y - h],
                    [x + h, y - h],
                    [x + h, y + h],
                    [x - h, y + h],
                ],
                desired: Some([d.xd[i], d.yd[i]]),
            }
        })
        .collect();
    anim::AnimFrames {
        frames,
        desired_path: d.xd.iter().zip(&d.yd).map(|(x, y)| [*x, *y]).collect(),
        bounds: Some((0.35, 0.35)),
    }
}

#[test]
fn animation_is_small_self_contained_and_consistent() {
    let dir = scratch("anim");
    let d = demo(3001);
    let frames = two_arm_frames(&d);
    let opts = anim::AnimOptions {
        speed: 5.0,
        title: String::from("NN <paper> & co"),
        ..anim::AnimOptions::default()
    };
    let path = dir.join("anim.svg");
    anim::animated_svg(&path, &frames, &opts).expect("animation");
    let svg = fs::read_to_string(&path).expect("read");
    check_xml(&svg);
    assert!(svg.len() < 2_000_000, "{} bytes", svg.len());
    assert!(svg.contains("NN &lt;paper&gt; &amp; co"), "title escaped");
    assert!(!svg.contains("href"), "no external references");
    assert!(svg.contains(r#"dur="18.000s""#), "90 s at 5x speed");
    // Every linear animation has one value per key frame and matching keyTimes.
    let mut linear = 0;
    for chunk in svg.split("<animate ").skip(1) {
        let attr = |name: &str| -> Option<&str> {
            let start = chunk.find(&format!(" {name}=\""))? + name.len() + 3;
            Some(&chunk[start..start + chunk[start..].find('"')?])
        };
        assert_eq!(attr("repeatCount"), Some("indefinite"));
        if attr("calcMode") == Some("linear") {
            let kt = attr("keyTimes").expect("keyTimes").split(';').count();
            let vals = attr("values").expect("values").split(';').count();
            assert_eq!(kt, 300, "at most 300 key frames");
            assert_eq!(vals, kt);
            linear += 1;
        }
    }
    // 2 arms + object + desired cx, cy + trail offset.
    assert_eq!(linear, 6);
    // One time label per key frame.
    assert_eq!(svg.matches("attributeName=\"visibility\"").count(), 300);
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn single_frame_animation_is_static() {
    let d = demo(1);
    let frames = two_arm_frames(&d);
    let svg = anim::render_animated_svg(&frames, &anim::AnimOptions::default()).expect("svg");
    check_xml(&svg);
    assert!(!svg.contains("<animate"));
}
