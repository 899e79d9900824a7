//! Sweep figures, from the table alone (so `merge` draws the same ones):
//!
//! - `sweep_rms_z1_after.png/.svg` (or `sweep_rms_z1` for runs shorter than the transient;
//!   `sweep_z1_p_rms_after_2s_m` or `sweep_z1_p_rms_m` for a spatial base): the
//!   RMS tracking error against each
//!   varied field (one `+` per completed run; a field whose values are not numbers, such as a
//!   vector gain, is plotted against its position in the grid or choice list);
//! - `sweep_histograms.png/.svg`: a histogram of the drawn values of each random field.

use std::path::Path;

use anyhow::Result;
use serde_json::Value as Json;

use super::run::Row;
use crate::figures::plot::{self, Panel, Series, Style};

/// The plotted metric: (column, scale, axis label), the first one the table has with a number
/// in a completed run: the whole-run RMS when the runs are shorter than the transient window;
/// the spatial table's position error `‖z1_p‖` for a spatial base.
const METRICS: [(&str, f64, &str); 4] = [
    ("rms_z1_after", 1e3, "RMS ‖z1_xy‖ after the transient [mm]"),
    ("rms_z1", 1e3, "RMS ‖z1_xy‖, whole run [mm]"),
    (
        "z1_p_rms_after_2s_m",
        1e3,
        "RMS ‖z1_p‖ after the transient [mm]",
    ),
    ("z1_p_rms_m", 1e3, "RMS ‖z1_p‖, whole run [mm]"),
];

/// `+` markers as one line series (non-finite points break the line).
fn crosses(pts: &[(f64, f64)]) -> (Vec<f64>, Vec<f64>) {
    let span = |v: Vec<f64>| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let r = hi - lo;
        if r > 0.0 { r } else { lo.abs().max(1.0) }
    };
    let dx = 0.012 * span(pts.iter().map(|p| p.0).collect());
    let dy = 0.025 * span(pts.iter().map(|p| p.1).collect());
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for &(a, b) in pts {
        for (p, q) in [
            (a - dx, b),
            (a + dx, b),
            (f64::NAN, f64::NAN),
            (a, b - dy),
            (a, b + dy),
            (f64::NAN, f64::NAN),
        ] {
            x.push(p);
            y.push(q);
        }
    }
    (x, y)
}

/// A step outline of a histogram of `v`.
fn histogram(v: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bins = ((v.len() as f64).sqrt().round() as usize).clamp(5, 40);
    let width = if hi > lo {
        (hi - lo) / bins as f64
    } else {
        1.0
    };
    let mut counts = vec![0usize; bins];
    for x in v {
        let k = (((x - lo) / width) as usize).min(bins - 1);
        counts[k] += 1;
    }
    let (mut x, mut y) = (vec![lo], vec![0.0]);
    for (k, c) in counts.iter().enumerate() {
        let a = lo + k as f64 * width;
        x.extend([a, a + width]);
        y.extend([*c as f64, *c as f64]);
    }
    x.push(lo + bins as f64 * width);
    y.push(0.0);
    (x, y)
}

/// Write the sweep figures into `dir`.
pub fn write(dir: &Path, resolved: &Json, header: &[String], rows: &[Row]) -> Result<()> {
    let vary = resolved["vary"].as_array().cloned().unwrap_or_default();
    let col = |name: &str| header.iter().position(|h| h == name);
    let Some(status) = col("status") else {
        return Ok(());
    };
    let Some((metric, shown)) = METRICS.iter().find_map(|m| {
        let c = col(m.0)?;
        rows.iter()
            .any(|r| r.cells[status] == "completed" && r.cells[c].parse::<f64>().is_ok())
            .then_some((c, *m))
    }) else {
        return Ok(());
    };
    let mut scatter_data: Vec<(String, String, Vec<f64>, Vec<f64>)> = Vec::new();
    let mut hist_data: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
    for p in &vary {
        let path = p["path"].as_str().unwrap_or("").to_string();
        let kind = p["kind"].as_str().unwrap_or("");
        let Some(c) = col(&path) else { continue };
        let list: Vec<String> = p["values"][kind]
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|v| {
                        super::cell(
                            &toml::Value::try_from(v).unwrap_or(toml::Value::Boolean(false)),
                        )
                    })
                    .collect()
            })
            .unwrap_or_default();
        let numeric = rows.iter().all(|r| r.cells[c].parse::<f64>().is_ok());
        let x_of = |s: &str| -> Option<f64> {
            if numeric {
                s.parse().ok()
            } else {
                list.iter().position(|v| v == s).map(|i| i as f64)
            }
        };
        let mut pts = Vec::new();
        for r in rows {
            if r.cells[status] != "completed" {
                continue;
            }
            if let (Some(x), Ok(y)) = (x_of(&r.cells[c]), r.cells[metric].parse::<f64>()) {
                pts.push((x, y * shown.1));
            }
        }
        let x_label = if numeric {
            path.clone()
        } else {
            format!(
                "{path}: position in the {kind} list (0 = {})",
                list.first().map_or("", |s| s.as_str())
            )
        };
        if !pts.is_empty() {
            let (x, y) = crosses(&pts);
            scatter_data.push((path.clone(), x_label, x, y));
        }
        if kind != "grid" && numeric {
            let v: Vec<f64> = rows
                .iter()
                .filter_map(|r| r.cells[c].parse().ok())
                .collect();
            let (x, y) = histogram(&v);
            hist_data.push((path, x, y));
        }
    }
    if !scatter_data.is_empty() {
        let panels: Vec<Panel> = scatter_data
            .iter()
            .map(|(path, xl, x, y)| {
                Panel::new(format!("{} against {path}", shown.0), xl.clone(), shown.2)
                    .with(Series::new("completed runs", x, y, Style::solid(0)))
            })
            .collect();
        plot::panels(
            &dir.join(format!("sweep_{}", shown.0)),
            &format!("sweep: {} against each varied field", shown.0),
            &panels,
            panels.len().min(2),
        )?;
    }
    if !hist_data.is_empty() {
        let panels: Vec<Panel> = hist_data
            .iter()
            .map(|(path, x, y)| {
                Panel::new(format!("drawn values of {path}"), path.clone(), "runs")
                    .with(Series::new("", x, y, Style::solid(1)))
            })
            .collect();
        plot::panels(
            &dir.join("sweep_histograms"),
            "sweep: histograms of the random draws",
            &panels,
            panels.len().min(2),
        )?;
    }
    Ok(())
}
