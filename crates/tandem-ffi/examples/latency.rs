//! Tick latency over many ticks (issue 23: "what a real-time loop can expect"): the dual-UR5
//! NN controller ticked N times (default 10^6) on its start state held, through the C ABI
//! (`tandem_tick`) and from Rust (`Standalone::try_tick`), each call timed with
//! `Instant::now()` around it; prints the median, p99, p99.9 and max per path.
//!
//! `cargo run --release -p tandem-ffi --example latency [N]`
//!
//! A loaded, shared machine without real-time scheduling shows its scheduler in the tail: the
//! max is the machine's, the median is the controller's.
use std::time::Instant;

use tandem_cli::scenario::standalone;
use tandem_cli::scenario::{self, EMBEDDED, Scenario};
use tandem_ffi::*;

fn percentiles(label: &str, ns: &mut [u32]) {
    ns.sort_unstable();
    let p = |f: f64| ns[((ns.len() as f64 * f) as usize).min(ns.len() - 1)] as f64 / 1e3;
    println!(
        "{label:<28} n = {:>8}  median {:>7.2} µs  p99 {:>7.2} µs  p99.9 {:>7.2} µs  max {:>8.1} µs",
        ns.len(),
        p(0.5),
        p(0.99),
        p(0.999),
        *ns.last().unwrap() as f64 / 1e3
    );
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("N: a number of ticks"))
        .unwrap_or(1_000_000);
    let e = EMBEDDED.iter().find(|e| e.name == "dual-ur5").unwrap();
    let src = scenario::embedded_source(e);
    let Scenario::Spatial(sc) = scenario::parse(&src).unwrap() else {
        unreachable!()
    };
    let mut s = standalone::spatial(&sc, &src, None).unwrap();
    let (q, qd, w) = (
        s.start.q.clone(),
        s.start.qd.clone(),
        s.start.wrenches.clone(),
    );
    let dt = s.control_period;
    let (nq, nw) = (q.len(), w.len());
    let mut tau = vec![0.0; nq];
    let mut ns = vec![0u32; n];

    // Through the C ABI.
    let mut h: *mut TandemController = std::ptr::null_mut();
    let st = tandem_controller_new_preset(c"dual-ur5".as_ptr(), std::ptr::null(), &mut h);
    assert_eq!(st, TandemStatus::TANDEM_OK);
    let st = tandem_start(h, 0.0, q.as_ptr(), nq, qd.as_ptr(), nq, w.as_ptr(), nw);
    assert_eq!(st, TandemStatus::TANDEM_OK);
    for (k, slot) in ns.iter_mut().enumerate() {
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
            tau.as_mut_ptr(),
            nq,
        );
        *slot = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        debug_assert_eq!(st, TandemStatus::TANDEM_OK);
    }
    tandem_controller_free(h);
    percentiles("dual-ur5 NN, C ABI", &mut ns);

    // From Rust.
    s.try_start(0.0, &q, &qd, &w).unwrap();
    for (k, slot) in ns.iter_mut().enumerate() {
        let t0 = Instant::now();
        let r = s.try_tick(k as f64 * dt, &q, &qd, &w, &mut tau);
        *slot = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        debug_assert!(r.is_ok());
    }
    percentiles("dual-ur5 NN, Rust try_tick", &mut ns);
}
