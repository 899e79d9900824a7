//! Tick latency over many ticks (issue 23: "what a real-time loop can expect"), from C and from
//! Rust, interleaved: the NN controller of `dual-ur5` (and of the planar `paper`) built twice,
//! one ticked through the C ABI (`tandem_tick`: checks, `catch_unwind`, raw pointers), the
//! other from Rust (`Standalone::tick`, unchecked), in alternating blocks of 1000 ticks so that the machine's load falls on
//! both alike. Each call is timed with `Instant::now()` around it (its own cost, some 20–40
//! ns, is in every number). Both are fed the scenario's start state held, the time advancing
//! one control period per tick. Prints the median, p99, p99.9 and max per path and the C/Rust
//! ratios of the medians and means.
//!
//! `cargo run --release -p tandem-ffi --example latency [N]` (N ticks per path, default 10^6)
//!
//! A loaded, shared machine without real-time scheduling shows its scheduler in the tail: the
//! max is the machine's, the median is the controller's.
use std::ffi::CString;
use std::time::Instant;

use tandem_cli::scenario::standalone::{self, Standalone};
use tandem_cli::scenario::{self, EMBEDDED, Scenario};
use tandem_ffi::*;

/// Median, p99, p99.9, max (µs) and mean (µs) of `ns`.
fn stats(ns: &mut [u32]) -> [f64; 5] {
    let mean = ns.iter().map(|&v| v as f64).sum::<f64>() / ns.len() as f64 / 1e3;
    ns.sort_unstable();
    let p = |f: f64| ns[((ns.len() as f64 * f) as usize).min(ns.len() - 1)] as f64 / 1e3;
    [
        p(0.5),
        p(0.99),
        p(0.999),
        *ns.last().unwrap() as f64 / 1e3,
        mean,
    ]
}

fn print(label: &str, s: &[f64; 5], n: usize) {
    println!(
        "{label:<34} n = {n:>8}  median {:>6.2} µs  p99 {:>6.2} µs  p99.9 {:>6.2} µs  max {:>8.1} µs  mean {:>6.2} µs",
        s[0], s[1], s[2], s[3], s[4]
    );
}

fn rust(name: &str) -> Standalone {
    let e = EMBEDDED.iter().find(|e| e.name == name).unwrap();
    let src = scenario::embedded_source(e);
    match scenario::parse(&src).unwrap() {
        Scenario::Planar(p) => standalone::planar(&p, &src, None).unwrap(),
        Scenario::Spatial(p) => standalone::spatial(&p, &src, None).unwrap(),
    }
}

fn run(name: &str, n: usize) {
    let mut s = rust(name);
    let (q, qd, w) = (
        s.start.q.clone(),
        s.start.qd.clone(),
        s.start.wrenches.clone(),
    );
    let dt = s.control_period;
    let (nq, nw) = (q.len(), w.len());
    let (mut tau_c, mut tau_r) = (vec![0.0; nq], vec![0.0; nq]);
    let (mut ns_c, mut ns_r) = (vec![0u32; n], vec![0u32; n]);

    let cname = CString::new(name).unwrap();
    let mut h: *mut TandemController = std::ptr::null_mut();
    let st = tandem_controller_new_preset(cname.as_ptr(), std::ptr::null(), &mut h);
    assert_eq!(st, TandemStatus::TANDEM_OK);
    let st = tandem_start(h, 0.0, q.as_ptr(), nq, qd.as_ptr(), nq, w.as_ptr(), nw);
    assert_eq!(st, TandemStatus::TANDEM_OK);
    s.try_start(0.0, &q, &qd, &w).unwrap();

    const BLOCK: usize = 1000;
    for (b, start) in (0..n).step_by(BLOCK).enumerate() {
        let end = (start + BLOCK).min(n);
        for pass in 0..2 {
            // Alternate which path goes first in each block.
            if (pass + b) % 2 == 0 {
                for k in start..end {
                    let t0 = Instant::now();
                    let st = tandem_tick(
                        h,
                        k as f64 * dt,
                        q.as_ptr(),
                        nq,
                        qd.as_ptr(),
                        nq,
                        w.as_ptr(),
                        nw,
                        tau_c.as_mut_ptr(),
                        nq,
                    );
                    ns_c[k] = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
                    debug_assert_eq!(st, TandemStatus::TANDEM_OK);
                }
            } else {
                for k in start..end {
                    let t0 = Instant::now();
                    s.tick(k as f64 * dt, &q, &qd, &w, &mut tau_r);
                    ns_r[k] = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
                }
            }
        }
        assert_eq!(tau_c, tau_r, "the two paths agree bit for bit");
    }
    let mut ev = TandemEvents::default();
    tandem_events(h, &mut ev);
    let mut q_sw = 0.0;
    tandem_record_scalar(h, c"Q".as_ptr(), &mut q_sw);
    tandem_controller_free(h);
    println!("{name} NN, start state held for {n} ticks: at the end Q = {q_sw:.3}; events {ev:?}");
    let (c, r) = (stats(&mut ns_c), stats(&mut ns_r));
    print(&format!("{name} NN, C ABI tandem_tick"), &c, n);
    print(&format!("{name} NN, Rust Standalone::tick"), &r, n);
    println!(
        "{name} NN, C / Rust: median {:.3}, mean {:.3}",
        c[0] / r[0],
        c[4] / r[4]
    );
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("N: a number of ticks"))
        .unwrap_or(1_000_000);
    run("dual-ur5", n);
    run("paper", n);
}
