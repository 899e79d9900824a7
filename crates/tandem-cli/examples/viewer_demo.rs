//! The 3-D viewer on real kinematics: the SPEC-spatial S6 path played **kinematically** (inverse
//! kinematics of the closed chain at each desired pose, no dynamics, no controller) on the
//! dual-UR5 set-up and on the dual-Franka set-up (7-DOF arms, grasps from above).
//!
//! ```text
//! cargo run --release -p tandem-cli --example viewer_demo -- [OUT_DIR] [SECONDS] [FPS]
//! ```
//!
//! Writes `OUT_DIR/ur5/{viewer.html, snapshot_*.png, snapshot_*.svg}` and the same under
//! `OUT_DIR/franka/` (default OUT_DIR: a folder in the system's temporary folder; default 60 s
//! at 30 frames per second).

use tandem_cli::view::spatial as viewer;

use std::path::PathBuf;

use anyhow::Result;
use tandem::nalgebra::Vector3;
use tandem::reference::spatial::path::{CircleParams, Se3Path};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args
        .first()
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("tandem-viewer-demo"));
    let seconds: f64 = args.get(1).map_or(Ok(60.0), |s| s.parse())?;
    let fps: f64 = args.get(2).map_or(Ok(30.0), |s| s.parse())?;

    // Dual UR5, the S6 path.
    let path = Se3Path::spec_s6();
    let pb = viewer::demo::play(&tandem::presets::dual_ur5(), &path, seconds, fps)?;
    let scene = viewer::demo::scene(
        "dual UR5, S6 path, kinematic playback",
        &pb,
        &path,
        [0.4, 0.2, 0.2],
    );
    write(&scene, &out.join("ur5"))?;

    // Dual Franka: the S6 circle about the set-up's start height (box at z = 0.35 m).
    let mut c = CircleParams::spec_s6();
    c.center = Vector3::new(-0.1, 0.0, 0.35);
    let path = Se3Path::circle(&c)?;
    let pb = viewer::demo::play(&tandem::presets::dual_franka(), &path, seconds, fps)?;
    let scene = viewer::demo::scene(
        "dual Franka (7-DOF), S6-type path, kinematic playback",
        &pb,
        &path,
        [0.4, 0.2, 0.2],
    );
    write(&scene, &out.join("franka"))?;
    Ok(())
}

fn write(scene: &viewer::Scene3d, dir: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    let html = viewer::write_viewer_file(scene, dir)?;
    viewer::write_snapshots(scene, dir)?;
    let size = std::fs::metadata(&html)?.len();
    println!(
        "{}: {} frames, {:.2} MB",
        html.display(),
        scene.times.len(),
        size as f64 / 1e6
    );
    Ok(())
}
