//! The cost of writing timeseries.csv for the 90 s paper run (NN `tuned`, constrained plant),
//! side by side in one process: the CLI's writer (`runner::write_timeseries`) and the writer it
//! replaced (`core::fmt` text pushed into a `csv::StringRecord`, one `String` per number), and the
//! simulation itself. `cargo run --release -p tandem-cli --example csv_write [REPEATS]`;
//! medians over the repeats.
use std::time::Instant;

use tandem::control::{ControllerParams, LawParams};
use tandem::disturbance::Disturbance;
use tandem::fixtures;
use tandem::sim::{Log, SimParams};
use tandem_cli::runner::write_timeseries;

/// The writer before issue 12: `format!` text, one allocation per number.
fn write_before(path: &std::path::Path, log: &Log) {
    fn text(v: f64) -> String {
        let a = v.abs();
        if v.is_nan() {
            String::from("NaN")
        } else if v.is_infinite() {
            String::from(if v > 0.0 { "inf" } else { "-inf" })
        } else if a == 0.0 || (1e-5..1e16).contains(&a) {
            format!("{v}")
        } else {
            format!("{v:e}")
        }
    }
    let file = std::fs::File::create(path).expect("create");
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
    w.write_record(log.names()).expect("header");
    let cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    let mut rec = csv::StringRecord::with_capacity(16 * cols.len(), cols.len());
    for i in 0..cols[0].len() {
        rec.clear();
        for c in &cols {
            rec.push_field(&text(c[i]));
        }
        w.write_record(&rec).expect("row");
    }
    w.flush().expect("flush");
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let cp = ControllerParams::paper(LawParams::Nn(tandem::adaptive::NnGains::tuned()));
    let mut sim_times = Vec::new();
    let mut log = None;
    for _ in 0..repeats.min(3) {
        let (sim, _) = fixtures::paper_simulation(&cp, SimParams::paper(), Disturbance::paper())
            .expect("paper simulation");
        let t0 = Instant::now();
        let (out, _) = sim.run(|_| {});
        sim_times.push(t0.elapsed().as_secs_f64());
        log = Some(out.log);
    }
    let log = log.expect("one run");
    let dir = std::env::temp_dir().join(format!("tandem-csv-write-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let (mut now, mut before) = (Vec::new(), Vec::new());
    for k in 0..repeats {
        let p = dir.join(format!("now-{k}.csv"));
        let t0 = Instant::now();
        write_timeseries(&p, &log).expect("write");
        now.push(t0.elapsed().as_secs_f64());
        let q = dir.join(format!("before-{k}.csv"));
        let t0 = Instant::now();
        write_before(&q, &log);
        before.push(t0.elapsed().as_secs_f64());
        assert_eq!(
            std::fs::read(&p).expect("read"),
            std::fs::read(&q).expect("read"),
            "the two writers must give the same bytes"
        );
    }
    let bytes = std::fs::metadata(dir.join("now-0.csv")).map_or(0, |m| m.len());
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "90 s NN run: {} rows × {} columns, {:.1} MB; simulation {:.0} ms; \
         timeseries.csv now {:.1} ms, before {:.1} ms (identical bytes)",
        log.columns[0].data.len(),
        log.columns.len(),
        bytes as f64 / 1e6,
        1e3 * median(sim_times),
        1e3 * median(now),
        1e3 * median(before),
    );
}
