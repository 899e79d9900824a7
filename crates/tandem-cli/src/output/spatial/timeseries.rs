//! `timeseries.csv` of a spatial run: the logged columns and the derived ones.

use std::path::Path;

use anyhow::Result;
use tandem::control::spatial::{AXES, WRENCH_AXES};

use super::{Derived, Finished};

/// `timeseries.csv`: every logged column (`name [unit]`), then the true pose in the output chart
/// `x_1.*` and the true grasp wrenches in tool axes `F_tool{i}.*` (the `F_meas{i}.*` columns are
/// the wrist sensors' readings, with their noise and filter).
pub fn write_timeseries(path: &Path, f: &Finished, d: &Derived) -> Result<()> {
    let log = &f.outcome.log;
    let mut header: Vec<String> = log
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
    let mut cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    let n = log.len();
    if d.x1.len() == 6 {
        for (j, a) in AXES.iter().enumerate() {
            header.push(format!("x_1.{a} [{}]", if j < 3 { "m" } else { "rad" }));
            cols.push(&d.x1[j]);
        }
    }
    for (i, w) in d.f_tool.iter().enumerate() {
        for (j, a) in WRENCH_AXES.iter().enumerate() {
            header.push(format!(
                "F_tool{}.{a} [{}]",
                i + 1,
                if j < 3 { "N" } else { "N m" }
            ));
            cols.push(&w[j]);
        }
    }
    if let Some((j, c)) = cols.iter().enumerate().find(|(_, c)| c.len() != n) {
        anyhow::bail!(
            "cannot write {}: column '{}' has {} rows, not {n}",
            path.display(),
            header[j],
            c.len()
        );
    }
    // The shared writer: shortest round-trip numbers, no allocation per row or number.
    crate::files::write_csv(path, &header, &cols)
}
