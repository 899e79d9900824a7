//! Spatial presets end to end (issue 9, first part): `tandem run dual-ur5` / `dual-franka` run
//! the SPEC-spatial S6 set-ups (`tandem::fixtures`) with the NN law and write `timeseries.csv`,
//! `summary.json`, `viewer.html` and the snapshots into a marker-protected output folder.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use nalgebra::Vector3;
use serde_json::json;
use tandem::control::spatial::{SpatialLaw, SpatialNnGains};
use tandem::fixtures::SpatialSetup;
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::se3_path::Se3Path;
use tandem::sim::Outcome;

use crate::output::{OutputDir, write_csv, write_json_atomic};
use crate::viewer::{ScalarTrack, scene_from_states, write_snapshots, write_viewer_file};

/// The embedded spatial presets: name and one-line description.
pub const PRESETS: &[(&str, &str)] = &[
    (
        "dual-ur5",
        "SPEC-spatial S6: two UR5-class arms facing each other carry a 3 kg box (NN law)",
    ),
    (
        "dual-franka",
        "two 7-DOF Franka-class arms grasp a box from above (NN law)",
    ),
];

/// True if `name` is a spatial preset.
pub fn is_preset(name: &str) -> bool {
    PRESETS.iter().any(|(n, _)| *n == name)
}

/// What a spatial run measured.
pub struct Finished {
    /// The simulation outcome (log, fault, drift, margins).
    pub outcome: Outcome,
    /// The plant (for kinematics of the logged states).
    pub plant: SpatialPlant,
    /// Box edge lengths, m.
    pub box_size: [f64; 3],
    /// The desired path.
    pub path: Se3Path,
    /// Simulated duration, s.
    pub duration: f64,
}

fn setup(name: &str) -> (SpatialSetup, SpatialNnGains, [f64; 3]) {
    if name == "dual-franka" {
        (
            tandem::fixtures::dual_franka(),
            SpatialNnGains::dual_franka(),
            [0.4, 0.2, 0.2],
        )
    } else {
        (
            tandem::fixtures::dual_ur5(),
            SpatialNnGains::dual_ur5(),
            [0.4, 0.2, 0.2],
        )
    }
}

/// Runs preset `name` for `duration` s (the path's S6 start, 1 cm inside the circle).
pub fn run(name: &str, duration: f64) -> Result<Finished> {
    let (s, gains, box_size) = setup(name);
    let path = Se3Path::spec_s6();
    let (sim, warnings) = tandem::fixtures::spatial_s6_simulation(
        &s.params,
        &s,
        SpatialLaw::Nn(gains),
        duration,
        1e-3,
        1e-6,
    )
    .context("spatial simulation")?;
    for w in &warnings {
        eprintln!("warning ({name}): {w:?}");
    }
    let (outcome, _) = sim.run(|_| {});
    Ok(Finished {
        outcome,
        plant: SpatialPlant::new(&s.params).context("spatial plant")?,
        box_size,
        path,
        duration,
    })
}

fn col<'a>(log: &'a tandem::sim::Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// The summary of a spatial run (SPEC-spatial S5 claims measured after 2 s).
pub fn summary(name: &str, f: &Finished) -> serde_json::Value {
    let log = &f.outcome.log;
    let t = col(log, "t");
    let g = |a: &str| col(log, &format!("z1.{a}"));
    let (x, y, z, rx, ry, rz) = (g("x"), g("y"), g("z"), g("rx"), g("ry"), g("rz"));
    let (mut zp_max, mut zr_max, mut zp_ss, mut n) = (0.0f64, 0.0f64, 0.0, 0usize);
    for k in 0..t.len().min(x.len()).min(rz.len()) {
        if t[k] >= 2.0 {
            let p = Vector3::new(x[k], y[k], z[k]).norm();
            let r = Vector3::new(rx[k], ry[k], rz[k]).norm();
            zp_max = zp_max.max(p);
            zr_max = zr_max.max(r);
            zp_ss += p * p;
            n += 1;
        }
    }
    let o = &f.outcome;
    let status = if o.fault.is_some() {
        "fault"
    } else {
        "completed"
    };
    json!({
        "scenario": name,
        "controller": "nn",
        "duration": f.duration,
        "status": status,
        "fault": o.fault.as_ref().map(|e| format!("{e:?}")),
        "events": format!("{:?}", o.events),
        "violation_ticks": o.violation_ticks,
        "min_margin": o.min_margin,
        "max_drift_m": o.max_drift,
        "max_drift_rad": o.max_drift_rot,
        "z1_p_max_after_2s_m": zp_max,
        "z1_rot_max_after_2s_rad": zr_max,
        "z1_p_rms_after_2s_m": if n > 0 { (zp_ss / n as f64).sqrt() } else { f64::NAN },
    })
}

/// The flat plant states of the log (`[q; X_WO (p, quaternion w x y z); qd; twist]`, the twist
/// left zero: the viewer draws poses only).
fn states(f: &Finished) -> Vec<Vec<f64>> {
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
    (0..log.len())
        .map(|k| {
            let mut y: Vec<f64> = cols
                .iter()
                .map(|c| c.get(k).copied().unwrap_or(f64::NAN))
                .collect();
            y.resize(2 * nq + 13, 0.0);
            y
        })
        .collect()
}

/// Writes every output of `f` into `dir` (the temporary folder of an [`OutputDir`]).
pub fn write(dir: &Path, name: &str, f: &Finished) -> Result<serde_json::Value> {
    let log = &f.outcome.log;
    let header: Vec<String> = log
        .columns
        .iter()
        .map(|c| {
            if c.unit.is_empty() {
                c.name.clone()
            } else {
                format!("{} [{}]", c.name, c.unit)
            }
        })
        .collect();
    let cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    write_csv(&dir.join("timeseries.csv"), &header, &cols)?;

    let t = col(log, "t").to_vec();
    let mut scene = scene_from_states(name, &f.plant, f.box_size, &t, &states(f));
    let t_end = t.last().copied().unwrap_or(0.0);
    let n_path = ((t_end * 4.0).ceil() as usize).max(1);
    scene.desired_path = (0..=n_path)
        .map(|k| {
            let p = f.path.sample(t_end * k as f64 / n_path as f64).p;
            [p.x, p.y, p.z]
        })
        .collect();
    let n_arms = f.plant.arms().len();
    let axes = ["fx", "fy", "fz", "tx", "ty", "tz"];
    let fcols: Vec<Vec<&[f64]>> = (1..=n_arms)
        .map(|i| {
            axes.iter()
                .map(|a| col(log, &format!("F{i}.{a}")))
                .collect()
        })
        .collect();
    if fcols.iter().flatten().all(|c| c.len() == t.len()) {
        scene.wrenches = (0..t.len())
            .map(|k| {
                fcols
                    .iter()
                    .map(|c| [c[0][k], c[1][k], c[2][k], c[3][k], c[4][k], c[5][k]])
                    .collect()
            })
            .collect();
    }
    let g = |a: &str| col(log, &format!("z1.{a}"));
    let (x, y, z) = (g("x"), g("y"), g("z"));
    if x.len() == t.len() {
        let e = (0..t.len())
            .map(|k| Vector3::new(x[k], y[k], z[k]).norm())
            .collect();
        scene.scalars.push(ScalarTrack::new("error |z1_p|", "m", e));
    }
    let m = col(log, "margin");
    if m.len() == t.len() {
        scene
            .scalars
            .push(ScalarTrack::new("margin", "", m.to_vec()));
    }
    write_viewer_file(&scene, dir)?;
    write_snapshots(&scene, dir)?;
    let s = summary(name, f);
    write_json_atomic(&dir.join("summary.json"), &s)?;
    Ok(s)
}

/// `tandem run dual-ur5|dual-franka`.
pub fn cmd_run(name: &str, duration: Option<f64>, out: OutputDir) -> Result<bool> {
    let duration = duration.unwrap_or(60.0);
    let f = run(name, duration)?;
    let t0 = Instant::now();
    let s = write(out.tmp_dir(), name, &f)?;
    let w = t0.elapsed().as_secs_f64();
    let dir = out.commit()?;
    println!(
        "{name} — NN, {duration} s: simulated in {:.3} s, outputs in {} (written in {w:.3} s)",
        f.outcome.wall_time,
        dir.display()
    );
    println!("{}", serde_json::to_string_pretty(&s)?);
    Ok(f.outcome.fault.is_none())
}
