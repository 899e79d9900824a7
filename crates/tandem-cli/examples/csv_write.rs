//! The cost of writing timeseries.csv for the 90 s paper run (NN `tuned`, constrained plant),
//! side by side in one process: the CLI's writer (`runner::write_timeseries`) and the writer it
//! replaced (`core::fmt` text pushed into a `csv::StringRecord`, one `String` per number), and the
//! simulation itself. `cargo run --release -p tandem-cli --example csv_write [REPEATS]`;
//! medians over the repeats.
use std::time::Instant;

use tandem::control::law::Law;
use tandem::control::planar::ControllerParams;
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::sim::{Log, SimParams};
use tandem_cli::files::F64Text;
use tandem_cli::output::planar::write_timeseries;

/// The numbers of the log as text into memory, the way `write_csv` does (no file, no sync).
fn format_now(log: &Log, out: &mut Vec<u8>) {
    let cols: Vec<&[f64]> = log.columns.iter().map(|c| c.data.as_slice()).collect();
    let mut text = F64Text::new();
    for i in 0..cols[0].len() {
        for (j, c) in cols.iter().enumerate() {
            if j > 0 {
                out.push(b',');
            }
            out.extend_from_slice(text.format_bytes(c[i]));
        }
        out.push(b'\n');
    }
}

/// The same, the way the writer before issue 12 did (`format!` text, one `String` per number,
/// through `csv::StringRecord`).
fn format_before(log: &Log, out: &mut Vec<u8>) {
    rows_before(&mut csv::Writer::from_writer(out), log);
}

/// The rows of `log` through `w` as the writer before issue 12 wrote them.
fn rows_before<W: std::io::Write>(w: &mut csv::Writer<W>, log: &Log) {
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

/// The writer before issue 12: `format!` text, one allocation per number.
fn write_before(path: &std::path::Path, log: &Log) {
    let file = std::fs::File::create(path).expect("create");
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
    w.write_record(log.names()).expect("header");
    rows_before(&mut w, log);
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
    let cp = ControllerParams::paper(Law::Nn(tandem::control::law::adaptive::NnGains::tuned()));
    let mut sim_times = Vec::new();
    let mut log = None;
    for _ in 0..repeats.min(3) {
        let (sim, _) = presets::paper_simulation(&cp, SimParams::paper(), Disturbance::paper())
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
        if k == 0 {
            // Every field reads back to the same bits (the texts may differ in the last digit
            // where two shortest texts are equally near; counted).
            let (a, b) = (
                std::fs::read_to_string(&p).expect("read"),
                std::fs::read_to_string(&q).expect("read"),
            );
            let (mut fields, mut differ) = (0usize, 0usize);
            for (la, lb) in a.lines().zip(b.lines()).skip(1) {
                for (fa, fb) in la.split(',').zip(lb.split(',')) {
                    let (x, y): (f64, f64) = (fa.parse().expect("num"), fb.parse().expect("num"));
                    assert!(x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()));
                    fields += 1;
                    differ += usize::from(fa != fb);
                }
            }
            assert_eq!(a.lines().count(), b.lines().count());
            println!("{fields} numbers read back identically; {differ} texts differ (ties)");
        }
    }
    let (mut fmt_now, mut fmt_before) = (Vec::new(), Vec::new());
    let mut buf = Vec::with_capacity(1 << 24);
    for _ in 0..repeats {
        buf.clear();
        let t0 = Instant::now();
        format_now(&log, &mut buf);
        fmt_now.push(t0.elapsed().as_secs_f64());
        buf.clear();
        let t0 = Instant::now();
        format_before(&log, &mut buf);
        fmt_before.push(t0.elapsed().as_secs_f64());
    }
    let numbers = log.columns.len() * log.columns[0].data.len();
    println!(
        "formatting only (into memory): now {:.2} ms ({:.1} ns a number), before {:.2} ms \
         ({:.1} ns a number)",
        1e3 * median(fmt_now.clone()),
        1e9 * median(fmt_now) / numbers as f64,
        1e3 * median(fmt_before.clone()),
        1e9 * median(fmt_before) / numbers as f64,
    );
    let bytes = std::fs::metadata(dir.join("now-0.csv")).map_or(0, |m| m.len());
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "90 s NN run: {} rows × {} columns, {:.1} MB; simulation {:.0} ms; \
         timeseries.csv (written whole, synced, renamed) now {:.1} ms, before (plain file, not \
         synced) {:.1} ms",
        log.columns[0].data.len(),
        log.columns.len(),
        bytes as f64 / 1e6,
        1e3 * median(sim_times),
        1e3 * median(now),
        1e3 * median(before),
    );
}
