//! One controller tick through Rust (`Standalone::tick`, unchecked, and `Standalone::try_tick`,
//! checked) and through the C ABI (`tandem_tick`: the same checks, `catch_unwind`, raw
//! pointers), on the dual-UR5 and the planar paper scenarios with the NN law. Each feeds the
//! start state with the time advancing one control period per tick. Issue 23 asks the C tick to
//! be within 5 % of the Rust tick (docs/performance.md, "C ABI").
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use tandem_cli::scenario::standalone::{self, Standalone};
use tandem_cli::scenario::{self, EMBEDDED, Scenario};
use tandem_ffi::*;

fn rust(name: &str) -> Standalone {
    let e = EMBEDDED.iter().find(|e| e.name == name).unwrap();
    let src = scenario::embedded_source(e);
    match scenario::parse(&src).unwrap() {
        Scenario::Planar(p) => standalone::planar(&p, &src, None).unwrap(),
        Scenario::Spatial(p) => standalone::spatial(&p, &src, None).unwrap(),
    }
}

fn bench(c: &mut Criterion) {
    for name in ["dual-ur5", "paper"] {
        let s0 = rust(name);
        let (q, qd, w) = (
            s0.start.q.clone(),
            s0.start.qd.clone(),
            s0.start.wrenches.clone(),
        );
        let h = s0.control_period;
        let mut tau = vec![0.0; s0.n_q];

        let mut s = rust(name);
        s.start(0.0, &q, &qd, &w);
        let mut k = 0u64;
        c.bench_function(&format!("ffi/{name}/rust_tick"), |b| {
            b.iter(|| {
                s.tick(black_box(k as f64 * h), &q, &qd, &w, &mut tau);
                k += 1;
                black_box(tau[0])
            })
        });

        let mut s = rust(name);
        s.start(0.0, &q, &qd, &w);
        let mut k = 0u64;
        c.bench_function(&format!("ffi/{name}/rust_try_tick"), |b| {
            b.iter(|| {
                s.try_tick(black_box(k as f64 * h), &q, &qd, &w, &mut tau)
                    .unwrap();
                k += 1;
                black_box(tau[0])
            })
        });

        let cname = std::ffi::CString::new(name).unwrap();
        let mut hc: *mut TandemController = std::ptr::null_mut();
        assert_eq!(
            tandem_controller_new_preset(cname.as_ptr(), std::ptr::null(), &mut hc),
            TandemStatus::TANDEM_OK
        );
        let (nq, nw) = (q.len(), w.len());
        assert_eq!(
            tandem_start(hc, 0.0, q.as_ptr(), nq, qd.as_ptr(), nq, w.as_ptr(), nw),
            TandemStatus::TANDEM_OK
        );
        let mut k = 0u64;
        c.bench_function(&format!("ffi/{name}/c_tick"), |b| {
            b.iter(|| {
                let st = tandem_tick(
                    hc,
                    black_box(k as f64 * h),
                    q.as_ptr(),
                    nq,
                    qd.as_ptr(),
                    nq,
                    w.as_ptr(),
                    nw,
                    tau.as_mut_ptr(),
                    nq,
                );
                k += 1;
                black_box((st, tau[0]))
            })
        });
        tandem_controller_free(hc);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
