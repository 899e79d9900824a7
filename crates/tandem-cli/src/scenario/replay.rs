//! Torque files for the `replay` controller.
//!
//! Columns are matched by their header names, never by position (units in brackets after a
//! name, `tau_q1 [N m]`, are ignored, and so is a UTF-8 byte-order mark):
//! - exactly one time column, `t` or `time` (seconds);
//! - one torque column per joint, in the plant's joint order (arm 1's joints first): a run's
//!   `timeseries.csv` names them `tau_q1`, `tau_q2`, …; a plain table may also call them
//!   `tau1`, `tau2`, …. A missing, duplicate or extra joint column is an error naming it.
//!   Every other column is ignored.
//!
//! A log from another tool names its columns otherwise (`stamp`, `joint_3_effort`,
//! `tau_arm1_q1`): a column map (`controller.replay_columns = ["stamp", "j1", …]`, or
//! `--replay-columns stamp,j1,…`) names the time column first and then one torque column per
//! joint, in the plant's joint order; a name the header lacks is an error that lists the header.
//!
//! Time stamps are snapped to the control grid `k h` when within [`SNAP`] of a tick (a log
//! written by an accumulated clock, `0.0010000000000000002`, replays on its tick, not one tick
//! late). Rows must be strictly increasing; a run's log (the `tau_q` layout) must also be evenly
//! spaced, so a missing row is an error naming it. Two modes:
//! - `hold` (default): each row holds until the next (zero-order hold, as a controller's
//!   torque does); every row must be on the grid;
//! - `linear`: linear interpolation between rows at every tick, for a log at another rate.
//!
//! Rows after the end of the run are not read (memory is bounded by the run).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use tandem::sim::Replay;

/// Largest distance of a time stamp from its tick that is snapped onto it, as a fraction of the
/// control period (1 %): the library's, which snaps a replay's stamps in the loop too.
pub use tandem::sim::replay::SNAP;

/// How rows are turned into torques between their time stamps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Each row holds until the next (zero-order hold); every row must be on the control grid.
    #[default]
    Hold,
    /// Linear interpolation between rows at every control tick (a log at another rate).
    Linear,
}

/// The bare name of a header cell: `tau_q1 [N m]` → `tau_q1`.
fn bare(name: &str) -> &str {
    name.trim_start_matches('\u{feff}')
        .split('[')
        .next()
        .unwrap_or(name)
        .trim()
}

/// The joint number of a torque column (`tau_q3`, `tau3` → 3).
fn joint(name: &str) -> Option<usize> {
    let k = name
        .strip_prefix("tau_q")
        .or_else(|| name.strip_prefix("tau"))?;
    if k.is_empty() || !k.bytes().all(|b| b.is_ascii_digit()) || k.len() > 6 {
        return None;
    }
    k.parse().ok()
}

/// Timing of the run the file is replayed into.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    /// Control period, s.
    pub control_period: f64,
    /// Duration, s.
    pub duration: f64,
}

/// Largest torque file read, bytes (256 MiB: about a million rows of twelve joints; rows after
/// the end of the run are not read, so only the run's part counts). Only a regular file is
/// read (a FIFO or `/dev/zero` is refused at once).
pub const MAX_REPLAY_BYTES: u64 = 256 << 20;

/// What a message about a header that tandem's names do not match suggests.
const MAP_HINT: &str = "for a log with other names, map them with controller.replay_columns = \
     [time, joint 1, joint 2, …] (or --replay-columns time,j1,j2,…)";

/// The header, for messages: at most 24 cells, each clipped, with the count.
fn header_list(names: &[&str]) -> String {
    let mut s = names
        .iter()
        .take(24)
        .map(|n| format!("`{}`", super::source::clip(n, 40)))
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > 24 {
        s.push_str(&format!(", … ({} columns)", names.len()));
    }
    s
}

/// The header cells of the column map `columns` (time first, then one per joint), or an error
/// naming the entry the header lacks (or holds twice) and listing the header.
fn mapped(names: &[&str], columns: &[String], n_q: usize) -> Result<(usize, Vec<usize>)> {
    if columns.len() != n_q + 1 {
        bail!(
            "replay_columns has {} names; it needs {} (the time column, then one torque column per joint: the plant has {n_q} joints)",
            columns.len(),
            n_q + 1
        );
    }
    let mut cells = Vec::with_capacity(columns.len());
    for (k, want) in columns.iter().enumerate() {
        let what = if k == 0 {
            "the time column".to_string()
        } else {
            format!("joint {k}'s torque")
        };
        let hits: Vec<usize> = (0..names.len())
            .filter(|&c| names[c] == bare(want))
            .collect();
        match hits.as_slice() {
            [c] => cells.push(*c),
            [] => bail!(
                "replay_columns[{k}] = `{}` ({what}) is not in the file's header: {}",
                crate::scenario::clip(want, 40),
                header_list(names)
            ),
            [a, b, ..] => bail!(
                "replay_columns[{k}] = `{}` ({what}) names header cells {} and {}",
                crate::scenario::clip(want, 40),
                a + 1,
                b + 1
            ),
        }
    }
    Ok((cells[0], cells[1..].to_vec()))
}

/// The time and torque columns by tandem's names (`t`/`time`; `tau_q1…` of a run's log, or
/// `tau1…`), and whether the file is a run's log (evenly spaced rows).
fn by_name(names: &[&str], n_q: usize) -> Result<(usize, Vec<usize>, bool)> {
    let show = |n: &str| super::source::clip(n, 40);
    // The time column: exactly one.
    let t_cols: Vec<usize> = (0..names.len())
        .filter(|&c| names[c].eq_ignore_ascii_case("t") || names[c].eq_ignore_ascii_case("time"))
        .collect();
    let t_col = match t_cols.as_slice() {
        [c] => *c,
        [] => bail!(
            "no time column: the header needs `t` (or `t [s]`), found {}; {MAP_HINT}",
            header_list(names)
        ),
        [a, b, ..] => bail!(
            "duplicate time column: header cells {} and {} are both `{}`",
            a + 1,
            b + 1,
            show(names[*b])
        ),
    };
    // Torque columns by joint number: each of 1..=n_q exactly once, none beyond.
    let mut by_joint: BTreeMap<usize, usize> = BTreeMap::new();
    let log_layout = names.iter().any(|n| n.starts_with("tau_q"));
    for (c, n) in names.iter().enumerate() {
        let Some(k) = joint(n) else { continue };
        if log_layout && !n.starts_with("tau_q") {
            continue;
        }
        if k == 0 || k > n_q {
            bail!(
                "column `{}` names joint {k}, but the plant has {n_q} joints (tau_q1..tau_q{n_q})",
                show(n)
            );
        }
        if let Some(prev) = by_joint.insert(k, c) {
            bail!(
                "duplicate torque column `{}` (header cells {} and {})",
                show(n),
                prev + 1,
                c + 1
            );
        }
    }
    let prefix = if log_layout { "tau_q" } else { "tau" };
    if let Some(k) = (1..=n_q).find(|k| !by_joint.contains_key(k)) {
        bail!(
            "missing torque column `{prefix}{k}`: the plant has {n_q} joints, so the file needs \
             {prefix}1..{prefix}{n_q} (found {} torque column(s)); the file's header: {}; {MAP_HINT}",
            by_joint.len(),
            header_list(names)
        );
    }
    let cols: Vec<usize> = (1..=n_q).map(|k| by_joint[&k]).collect();
    Ok((t_col, cols, log_layout))
}

/// Read a torque file for a plant with `n_q` joints; `columns` is the column map (time first,
/// then one per joint), or `None` for tandem's own names.
pub fn load(
    path: &Path,
    n_q: usize,
    timing: Timing,
    mode: Interpolation,
    columns: Option<&[String]>,
) -> Result<Replay> {
    let file = crate::scenario::open_limited(path, MAX_REPLAY_BYTES)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(file);
    let headers = rdr.headers().context("cannot read the header row")?.clone();
    let names: Vec<&str> = headers.iter().map(bare).collect();
    let show = |n: &str| super::source::clip(n, 40);

    let (t_col, cols, log_layout) = match columns {
        Some(map) => {
            let (t, c) = mapped(&names, map, n_q)?;
            (t, c, false)
        }
        None => by_name(&names, n_q)?,
    };

    // Rows, up to the first one past the end of the run.
    let h = timing.control_period;
    let t_stop = timing.duration + h;
    let max_rows = (timing.duration / h).ceil() as usize + 2;
    let mut times: Vec<f64> = Vec::new();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut lines: Vec<u64> = Vec::new();
    let mut rec = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut rec) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                bail!(
                    "line {line}: {}",
                    crate::scenario::clip(&e.to_string(), 200)
                );
            }
        }
        let line = rec.position().map_or(0, |p| p.line());
        let num = |c: usize| -> Result<f64> {
            let s = rec.get(c).unwrap_or("");
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(_) => bail!(
                    "line {line}, column `{}`: `{s}` is not finite",
                    show(names[c])
                ),
                Err(_) => bail!(
                    "line {line}, column `{}`: `{}` is not a number",
                    show(names[c]),
                    crate::scenario::clip(s, 40)
                ),
            }
        };
        let t = num(t_col)?;
        let row = cols.iter().map(|&c| num(c)).collect::<Result<Vec<f64>>>()?;
        let past = t > t_stop;
        times.push(t);
        rows.push(row);
        lines.push(line);
        if past || times.len() > max_rows.saturating_mul(64) {
            break;
        }
    }
    if times.is_empty() {
        bail!("no data rows");
    }

    // Order, then the grid.
    for k in 1..times.len() {
        if !(times[k] > times[k - 1]) {
            bail!(
                "line {}: t = {} does not increase (line {} has t = {}); rows must be in time order",
                lines[k],
                times[k],
                lines[k - 1],
                times[k - 1]
            );
        }
    }
    let snapped: Vec<Option<f64>> = times
        .iter()
        .map(|&t| tandem::sim::replay::snap_to_grid(t, h))
        .collect();
    let times = match mode {
        Interpolation::Hold => {
            let mut out = Vec::with_capacity(times.len());
            for (k, s) in snapped.iter().enumerate() {
                match s {
                    Some(s) if k == 0 || *s > out[k - 1] => out.push(*s),
                    Some(_) => bail!(
                        "line {}: t = {} falls on the same control tick as line {} (h = {h} s)",
                        lines[k],
                        times[k],
                        lines[k - 1]
                    ),
                    None => bail!(
                        "line {}: t = {} is not on the control grid (multiples of {h} s, within {} %); \
                         replay a log at another rate with interpolation = \"linear\" (--replay-interpolation linear)",
                        lines[k],
                        times[k],
                        SNAP * 100.0
                    ),
                }
            }
            out
        }
        // Snap what is on the grid; keep the rest as stamped.
        Interpolation::Linear => times
            .iter()
            .zip(&snapped)
            .map(|(t, s)| s.unwrap_or(*t))
            .collect(),
    };
    // A run's log is evenly spaced: a different step is a missing (or extra) row.
    if log_layout && times.len() > 2 {
        let step = times[1] - times[0];
        for k in 2..times.len() {
            let d = times[k] - times[k - 1];
            if (d - step).abs() > SNAP * h {
                bail!(
                    "line {}: a gap in the log: t jumps from {} to {} s ({} s), the log's step is {} s",
                    lines[k],
                    times[k - 1],
                    times[k],
                    crate::scenario::num(d),
                    crate::scenario::num(step)
                );
            }
        }
    }
    let r = Replay::new(times, rows, n_q).map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(match mode {
        Interpolation::Hold => r,
        Interpolation::Linear => r.linear(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("tandem-replay-{}-{name}", std::process::id()));
        std::fs::write(&p, text).expect("write");
        p
    }

    const MS: Timing = Timing {
        control_period: 1e-3,
        duration: 2.0,
    };

    #[test]
    fn reads_plain_and_timeseries_layouts() {
        let p = write("plain.csv", "t,tau2,tau1\n0,2,1\n0.5,4,3\n");
        let mut r = load(&p, 2, MS, Interpolation::Hold, None).expect("plain");
        assert_eq!(r.at(0.7), &[3.0, 4.0]);
        let p = write(
            "ts.csv",
            "t [s],x_o.x [m],tau_q2 [N m],tau_q1 [N m]\n0,9,2,1\n1,9,4,3\n",
        );
        let mut r = load(&p, 2, MS, Interpolation::Hold, None).expect("timeseries");
        assert_eq!(r.at(0.0), &[1.0, 2.0]);
        assert_eq!(r.at(1.5), &[3.0, 4.0]);
        let p = write("bom.csv", "\u{feff}t,tau1,tau2\n0,1,2\n");
        assert!(load(&p, 2, MS, Interpolation::Hold, None).is_ok());
    }

    #[test]
    fn explains_bad_files() {
        let e = |text: &str| {
            let p = write("bad.csv", text);
            format!(
                "{:#}",
                load(&p, 2, MS, Interpolation::Hold, None).expect_err(text)
            )
        };
        assert!(e("t,tau1\n0,1\n").contains("missing torque column `tau2`"));
        assert!(e("t,tau1,tau2\n0,1,x\n").contains("line 2, column `tau2`"));
        assert!(e("time,tau1,tau2\n1,1,1\n0,1,1\n").contains("line 3: t = 0 does not increase"));
        assert!(e("t,t,t,t,t\n0,1,1,1,1\n").contains("duplicate time column"));
        assert!(e("t,tau1,tau1,tau2\n0,1,1,1\n").contains("duplicate torque column `tau1`"));
        assert!(e("t,tau1,tau2,tau3\n0,1,1,1\n").contains("`tau3` names joint 3"));
        assert!(e("t,a,b\n0,1,1\n").contains("missing torque column `tau1`"));
        assert!(e("t,tau1,tau2\n0,1,1\n0.0005,1,1\n").contains("not on the control grid"));
        assert!(e("t,tau_q1,tau_q2\n0,1,1\n0.01,1,1\n0.03,1,1\n").contains("line 4: a gap"));
    }

    #[test]
    fn accumulated_clock_snaps_onto_its_tick() {
        // t_k = t_{k−1} + 0.001, summed: 0.0010000000000000002 and drifting.
        let mut text = String::from("t,tau1\n");
        let mut t = 0.0f64;
        for k in 0..3000 {
            text.push_str(&format!("{t:?},{k}\n"));
            t += 0.001;
        }
        let p = write("clock.csv", &text);
        let mut r = load(
            &p,
            1,
            Timing {
                control_period: 1e-3,
                duration: 3.0,
            },
            Interpolation::Hold,
            None,
        )
        .expect("snapped");
        for k in [1usize, 7, 1000, 2999] {
            assert_eq!(r.at(k as f64 * 1e-3), &[k as f64], "tick {k}");
        }
    }

    #[test]
    fn linear_interpolates_a_log_at_another_rate() {
        let p = write("coarse.csv", "t,tau1\n0,0\n0.01,1\n0.02,3\n");
        let mut r = load(&p, 1, MS, Interpolation::Linear, None).expect("linear");
        assert_eq!(r.at(0.0), &[0.0]);
        assert!((r.at(0.004)[0] - 0.4).abs() < 1e-12);
        assert!((r.at(0.015)[0] - 2.0).abs() < 1e-12);
        assert_eq!(r.at(0.5), &[3.0]);
        // Off-grid rows are fine when interpolating.
        let p = write("off.csv", "t,tau1\n0,0\n0.0005,1\n0.0025,3\n");
        let mut r = load(&p, 1, MS, Interpolation::Linear, None).expect("linear");
        assert!((r.at(0.001)[0] - 1.5).abs() < 1e-12);
    }
}
