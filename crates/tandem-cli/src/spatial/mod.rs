//! Spatial presets end to end (issue 9, first part): `tandem run dual-ur5` / `dual-franka` run
//! the SPEC-spatial S6 set-ups (`tandem::fixtures`) with the NN law and write `timeseries.csv`,
//! `summary.json`, `viewer.html` and the snapshots into a marker-protected output folder.

pub mod figures;
pub mod output;

use anyhow::{Context, Result};
use tandem::control::spatial::{SpatialLaw, SpatialNnGains};
use tandem::fixtures::SpatialSetup;
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::se3_path::Se3Path;

use crate::output::OutputDir;
pub use output::Finished;

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
    let (outcome, sim) = sim.run(|_| {});
    let k_c = sim.driver().k_c();
    Ok(Finished {
        outcome,
        plant: SpatialPlant::new(&s.params).context("spatial plant")?,
        box_size,
        path,
        duration,
        controller: "nn".into(),
        label: "NN".into(),
        k_c: [k_c[0], k_c[1], k_c[2], k_c[3], k_c[4], k_c[5]],
        chart: *sim.driver().chart(),
        warnings: warnings.iter().map(|w| format!("{w:?}")).collect(),
    })
}

/// `tandem run dual-ur5|dual-franka`.
pub fn cmd_run(name: &str, duration: Option<f64>, out: OutputDir) -> Result<bool> {
    let duration = duration.unwrap_or(60.0);
    let f = run(name, duration)?;
    let (s, times, problems) = output::write(out.tmp_dir(), name, &f, true)?;
    for p in &problems {
        eprintln!("warning: {p}");
    }
    let dir = out.commit()?;
    println!("{name} — {}, {duration} s", f.label);
    print!("{}", output::text(&[(f.label.as_str(), &s)]));
    println!(
        "outputs in {} (simulated in {:.3} s, written in {:.3} s: kinematics {:.3}, CSV {:.3}, \
         viewer {:.3}, figures {:.3}, in parallel)",
        dir.display(),
        f.outcome.wall_time,
        times.total,
        times.derive,
        times.csv,
        times.viewer,
        times.figures
    );
    Ok(f.outcome.fault.is_none())
}
