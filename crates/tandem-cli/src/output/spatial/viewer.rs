//! `viewer.html` and the snapshots of a spatial run: the logged poses thinned to
//! [`VIEWER_FPS`], the desired path, the wrist wrenches and two scalar tracks.

use std::path::Path;

use anyhow::Result;
use tandem::control::spatial::WRENCH_AXES;

use super::{Derived, Finished, col, six};
use crate::view::spatial::{ScalarTrack, scene_from_states, write_snapshots, write_viewer_file};

/// The flat plant states of the logged rows `rows` (`[q; X_WO (p, quaternion w x y z); qd;
/// twist]`, the twist and contact grasps' pad anchors left zero: the viewer draws poses only).
fn states(f: &Finished, rows: &[usize]) -> Vec<Vec<f64>> {
    let log = &f.outcome.log;
    let nq = f.plant.n_q();
    let mut names: Vec<String> = (1..=nq).map(|k| format!("q{k}")).collect();
    names.extend(
        ["x", "y", "z", "qw", "qx", "qy", "qz"]
            .iter()
            .map(|a| format!("x_o.{a}")),
    );
    names.extend((1..=nq).map(|k| format!("qd{k}")));
    let cols: Vec<&[f64]> = names.iter().map(|n| col(log, n)).collect();
    rows.iter()
        .map(|&k| {
            let mut y: Vec<f64> = cols
                .iter()
                .map(|c| c.get(k).copied().unwrap_or(0.0))
                .collect();
            y.resize(f.plant.state_dim(), 0.0);
            y
        })
        .collect()
}

/// At most this many viewer frames per simulated second (the log has 100 for the presets):
/// smooth playback, and a 60 s run's `viewer.html` stays small and fast to write.
pub const VIEWER_FPS: f64 = 25.0;

/// Writes `viewer.html` and the snapshots of `f` into `dir`.
pub(super) fn write_viewer(dir: &Path, scenario: &str, f: &Finished, d: &Derived) -> Result<()> {
    let log = &f.outcome.log;
    let n = d.t.len();
    let dt = if n > 1 { d.t[1] - d.t[0] } else { 1.0 };
    let stride = ((1.0 / VIEWER_FPS / dt).round() as usize).max(1);
    // Every `stride`-th row, and the last one.
    let mut idx: Vec<usize> = (0..n).step_by(stride).collect();
    if n > 0 && idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    let pick = |v: &[f64]| -> Vec<f64> { idx.iter().map(|&k| v[k]).collect() };
    let t = pick(&d.t);
    let st = states(f, &idx);
    let mut scene = scene_from_states(scenario, &f.plant, f.box_size, &t, &st);
    let t_end = t.last().copied().unwrap_or(0.0);
    let n_path = ((t_end * 4.0).ceil() as usize).max(1);
    scene.desired_path = (0..=n_path)
        .map(|k| {
            let p = f.path.sample(t_end * k as f64 / n_path as f64).p;
            [p.x, p.y, p.z]
        })
        .collect();
    // Pads (holding the box, or gauging welds or springs): their cones, their state per frame.
    if let (Some(c), Some(cp)) = (f.plant.pads(), f.plant.pad_params()) {
        for (i, list) in cp.pads.iter().enumerate() {
            for (j, pad) in list.iter().enumerate() {
                let col = log
                    .get(&format!("pad{}.{}.state", i + 1, j + 1))
                    .map(pick)
                    .unwrap_or_default();
                let nn = pad.normal.normalize();
                scene.pads.push(crate::view::spatial::PadTrack {
                    arm: i,
                    position: [pad.position.x, pad.position.y, pad.position.z],
                    normal: [nn.x, nn.y, nn.z],
                    radius: pad.radius,
                    mu: c.mu(),
                    state: col,
                });
            }
        }
    }
    let n_arms = f.plant.arms().len();
    let fcols: Option<Vec<[&[f64]; 6]>> = (1..=n_arms)
        .map(|i| six(log, &format!("F{i}"), &WRENCH_AXES))
        .collect();
    if let Some(fcols) = fcols {
        scene.wrenches = idx
            .iter()
            .map(|&k| {
                fcols
                    .iter()
                    .map(|c| [c[0][k], c[1][k], c[2][k], c[3][k], c[4][k], c[5][k]])
                    .collect()
            })
            .collect();
    }
    if d.z1_p.len() == n {
        scene
            .scalars
            .push(ScalarTrack::new("error |z1_p|", "m", pick(&d.z1_p)));
    }
    let m = col(log, "margin");
    if m.len() == n {
        scene.scalars.push(ScalarTrack::new("margin", "", pick(m)));
    }
    write_viewer_file(&scene, dir)?;
    write_snapshots(&scene, dir)?;
    Ok(())
}
