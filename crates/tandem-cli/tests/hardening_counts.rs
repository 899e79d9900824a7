//! Issue 22, "Counts are checked before work": a sweep's run count (the grid product, overflow
//! detected, the true count said) is refused before any set-up, planar and spatial alike; a
//! hand-edited shard count cannot make `merge` build a string per missing shard; `--threads`
//! is bounded. Every child is killed (and the test fails) if it does not return in time.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

mod support;
use support::*;

/// Refused with exit 2 within `secs`, the message holding every one of `parts`; the message.
fn refused_within(d: &Path, args: &[&str], secs: u64, parts: &[&str]) -> String {
    let t0 = Instant::now();
    let o = within(d, args, Duration::from_secs(secs))
        .unwrap_or_else(|| panic!("tandem {args:?} was killed after {secs} s"));
    let err = stderr(&o);
    exit(&o, 2);
    for p in parts {
        assert!(err.contains(p), "tandem {args:?}: no `{p}` in\n{err}");
    }
    assert!(
        t0.elapsed() < Duration::from_secs(secs),
        "took {:?}",
        t0.elapsed()
    );
    err
}

/// A `[vary]` grid of `n` values for each of `fields`.
fn grid_sweep(base: &str, fields: &[&str], n: usize) -> String {
    let mut s = format!("base = \"{base}\"\nduration = 0.1\n[vary]\n");
    for (k, f) in fields.iter().enumerate() {
        let vals: Vec<String> = (0..n)
            .map(|i| match *f {
                "run.seed" => format!("{}", i + 1000 * k),
                _ => format!("{:.4}", 1.0 + i as f64 * 1e-4),
            })
            .collect();
        s.push_str(&format!("\"{f}\" = {{ grid = [{}] }}\n", vals.join(", ")));
    }
    s
}

#[test]
fn a_billion_run_grid_is_refused_at_once_with_its_true_count_planar_and_spatial() {
    let d = scratch("billion");
    for base in ["paper", "dual-ur5"] {
        fs::write(
            d.join("big.toml"),
            grid_sweep(base, &["object.mass", "run.duration", "run.seed"], 1000),
        )
        .expect("write");
        refused_within(
            &d,
            &["sweep", "big.toml", "--out", "o", "--no-figures"],
            5,
            &[
                "1000000000 (10^9) runs",
                "1000 × 1000 × 1000",
                "at most 10000000",
            ],
        );
        assert!(!d.join("o").exists());
    }
    // Past 2^64: the product overflows a u64 (the old count saturated), the true count is said.
    let mut s = String::from("base = \"paper\"\n[vary]\n");
    for k in 0..7 {
        let vals: Vec<String> = (0..1000).map(|i| format!("{}", 4 + i)).collect();
        // Seven distinct fields of 1000 values each.
        let path = [
            "controller.nn.k1",
            "controller.nn.k2",
            "object.mass",
            "run.duration",
            "run.seed",
            "admittance.k_e",
            "admittance.c_e",
        ][k];
        s.push_str(&format!(
            "\"{path}\" = {{ grid = [{}] }}\n",
            vals.join(", ")
        ));
    }
    fs::write(d.join("huge.toml"), s).expect("write");
    refused_within(
        &d,
        &["sweep", "huge.toml", "--out", "o"],
        5,
        &["1000000000000000000000 (10^21) runs"],
    );
    let _ = fs::remove_dir_all(&d);
}

/// Two real shards of a 2-run sweep, their `sweep.json` edited to claim `count` shards.
fn shards_claiming(d: &Path, count: u64) {
    fs::write(
        d.join("sw.toml"),
        "base = \"paper\"\nduration = 0.2\n[set]\n\"controller.kind\" = \"pd\"\n[vary]\n\"object.mass\" = { grid = [1.0, 1.1] }\n",
    )
    .expect("write");
    for (s, out) in [("0/2", "A"), ("1/2", "B")] {
        ok(&tandem(
            d,
            &[
                "sweep",
                "sw.toml",
                "--shard",
                s,
                "--out",
                out,
                "--no-figures",
            ],
        ));
        let p = d.join(out).join("sweep.json");
        let text = fs::read_to_string(&p).expect("read");
        let edited = text.replace("\"count\": 2", &format!("\"count\": {count}"));
        assert_ne!(edited, text, "sweep.json has a shard count");
        fs::write(&p, edited).expect("write");
    }
}

#[test]
fn a_hand_edited_shard_count_is_bounded_and_the_missing_shards_are_counted() {
    let d = scratch("shards");
    // 10^15 shards: refused as a count, at once (the old merge built a string per missing shard
    // and aborted at 4 GB).
    let (one, two) = (d.join("one"), d.join("two"));
    fs::create_dir_all(&one).expect("mkdir");
    fs::create_dir_all(&two).expect("mkdir");
    shards_claiming(&one, 1_000_000_000_000_000);
    let err = refused_within(
        &one,
        &["merge", "A", "B", "--out", "m"],
        10,
        &["sweep.json", "at most 10000000 shards"],
    );
    assert!(err.len() < 2000, "{} bytes", err.len());
    // 10^7 shards, the largest count: two present, the rest counted, three named.
    shards_claiming(&two, 10_000_000);
    let err = refused_within(
        &two,
        &["merge", "A", "B", "--out", "m"],
        10,
        &["9999998 shards are missing: 2/10000000, 3/10000000, 4/10000000, … (and 9999995 more)"],
    );
    assert!(err.len() < 2000, "{} bytes: {}", err.len(), &err[..2000]);
    assert!(!one.join("m").exists() && !two.join("m").exists());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn threads_are_bounded_and_the_error_names_the_option() {
    let d = scratch("threads");
    fs::write(
        d.join("sw.toml"),
        "base = \"paper\"\nduration = 0.2\n[vary]\n\"object.mass\" = { grid = [1.0] }\n",
    )
    .expect("write");
    for n in ["100000", "1025"] {
        refused_within(
            &d,
            &["sweep", "sw.toml", "--threads", n, "--out", "o"],
            5,
            &[&format!("--threads {n}"), "at most 1024"],
        );
        assert!(!d.join("o").exists());
    }
    // The largest count runs.
    ok(&tandem(
        &d,
        &[
            "sweep",
            "sw.toml",
            "--threads",
            "1024",
            "--out",
            "o",
            "--no-figures",
        ],
    ));
    let _ = fs::remove_dir_all(&d);
}
