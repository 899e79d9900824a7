//! Torque files for the `replay` controller.
//!
//! Two layouts are accepted, told apart by their header:
//! - a run's `timeseries.csv`: the time column `t [s]` and the joint torques `tau_q1 [N m]`,
//!   `tau_q2 [N m]`, … are picked by name (every other column is ignored);
//! - a plain table `t,tau1,tau2,…`: a `t` (or `time`) column plus one column per joint, in the
//!   plant's joint order (arm 1's joints first), whatever their names.
//!
//! Units in brackets after a name are ignored. Each row is held until the next one (zero-order
//! hold, [`tandem::sim::Replay`]); before the first row the first row applies.

use std::path::Path;

use anyhow::{Context, Result, bail};
use tandem::sim::Replay;

/// The bare name of a header cell: `tau_q1 [N m]` → `tau_q1`.
fn bare(name: &str) -> &str {
    name.split('[').next().unwrap_or(name).trim()
}

/// Read a torque file for a plant with `n_q` joints.
pub fn load(path: &Path, n_q: usize) -> Result<Replay> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_path(path)
        .with_context(|| format!("cannot open {}", path.display()))?;
    let headers = rdr.headers().context("cannot read the header row")?.clone();
    let names: Vec<&str> = headers.iter().map(bare).collect();
    let Some(t_col) = names
        .iter()
        .position(|n| n.eq_ignore_ascii_case("t") || n.eq_ignore_ascii_case("time"))
    else {
        bail!(
            "no time column: the header needs `t` (or `t [s]`), found {}",
            names
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    };
    // A run's time series: the tau_q<k> columns by number. Otherwise every other column.
    let mut tau: Vec<(usize, usize)> = names
        .iter()
        .enumerate()
        .filter_map(|(c, n)| {
            n.strip_prefix("tau_q")
                .and_then(|k| k.parse::<usize>().ok())
                .map(|k| (k, c))
        })
        .collect();
    let cols: Vec<usize> = if tau.is_empty() {
        (0..names.len()).filter(|&c| c != t_col).collect()
    } else {
        tau.sort();
        for (i, (k, _)) in tau.iter().enumerate() {
            if *k != i + 1 {
                bail!(
                    "the torque columns tau_q1..tau_q{} are not complete",
                    tau.len()
                );
            }
        }
        tau.iter().map(|&(_, c)| c).collect()
    };
    if cols.len() != n_q {
        bail!(
            "{} torque column(s) ({}) for a plant with {n_q} joints",
            cols.len(),
            cols.iter()
                .map(|&c| format!("`{}`", names[c]))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let mut times = Vec::new();
    let mut rows = Vec::new();
    for (r, rec) in rdr.records().enumerate() {
        let line = r + 2;
        let rec = rec.with_context(|| format!("line {line}"))?;
        let num = |c: usize| -> Result<f64> {
            let s = rec.get(c).unwrap_or("");
            s.parse::<f64>().with_context(|| {
                format!("line {line}, column `{}`: `{s}` is not a number", names[c])
            })
        };
        times.push(num(t_col)?);
        rows.push(cols.iter().map(|&c| num(c)).collect::<Result<Vec<f64>>>()?);
    }
    Replay::new(times, rows, n_q).map_err(|e| anyhow::anyhow!("{e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("tandem-replay-{}-{name}", std::process::id()));
        std::fs::write(&p, text).expect("write");
        p
    }

    #[test]
    fn reads_plain_and_timeseries_layouts() {
        let p = write("plain.csv", "t,tau1,tau2\n0,1,2\n0.5,3,4\n");
        let mut r = load(&p, 2).expect("plain");
        assert_eq!(r.at(0.7), &[3.0, 4.0]);
        let p = write(
            "ts.csv",
            "t [s],x_o.x [m],tau_q2 [N m],tau_q1 [N m]\n0,9,2,1\n1,9,4,3\n",
        );
        let mut r = load(&p, 2).expect("timeseries");
        assert_eq!(r.at(0.0), &[1.0, 2.0]);
        assert_eq!(r.at(1.5), &[3.0, 4.0]);
    }

    #[test]
    fn explains_bad_files() {
        let p = write("bad.csv", "t,tau1\n0,1\n");
        let e = load(&p, 2).expect_err("too few").to_string();
        assert!(e.contains("1 torque column"), "{e}");
        let p = write("bad2.csv", "t,a,b\n0,1,x\n");
        let e = format!("{:#}", load(&p, 2).expect_err("nan"));
        assert!(e.contains("line 2, column `b`"), "{e}");
        let p = write("bad3.csv", "time,a,b\n1,1,1\n0,1,1\n");
        let e = load(&p, 2).expect_err("order").to_string();
        assert!(e.contains("increasing"), "{e}");
    }
}
