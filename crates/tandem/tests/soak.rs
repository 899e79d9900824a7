//! Soak test (`#[ignore]`d; CI runs it: `cargo test --release -p tandem --test soak --
//! --ignored`): the paper scenario with the tuned NN law for 1000 s, 10⁶ control ticks.
//! Memory stays flat (no allocation at all inside the loop: the log is preallocated at the log
//! period, so its size is fixed before the first tick) and the grasp constraints never drift
//! more than 1e-9 m.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::planar::ControllerParams;
use tandem::model::disturbance::Disturbance;
use tandem::presets;
use tandem::sim::SimParams;

/// Counts allocations and the bytes live (and their peak).
struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grow(n: usize) {
    let live = LIVE.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(live, Ordering::Relaxed);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        grow(l.size());
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        grow(n);
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static A: Counting = Counting;

#[test]
#[ignore = "1000 s simulated (about a minute); CI runs it"]
fn soak_1000_s_memory_flat_and_drift_below_1e_9() {
    let cp = ControllerParams::paper(Law::Nn(NnGains::tuned()));
    let sp = SimParams {
        duration: 1000.0,
        ..SimParams::paper()
    };
    let (sim, _) = presets::paper_simulation(&cp, sp, Disturbance::paper()).expect("builds");
    assert_eq!(sim.total_ticks(), 1_000_000);
    let (allocs0, live0) = (ALLOCS.load(Ordering::Relaxed), LIVE.load(Ordering::Relaxed));
    PEAK.store(live0, Ordering::Relaxed);
    let t0 = std::time::Instant::now();
    let (out, _sim) = sim.run(|_| {});
    let wall = t0.elapsed().as_secs_f64();
    let allocs = ALLOCS.load(Ordering::Relaxed) - allocs0;
    let peak = PEAK.load(Ordering::Relaxed) - live0;
    let rows = out.log.len();
    println!(
        "soak: {} ticks in {wall:.1} s, {rows} log rows, {allocs} allocations and {peak} bytes of \
         growth in the loop, max drift {:.3e} m, min margin {:?}",
        out.ticks, out.max_drift, out.min_margin
    );
    assert!(out.fault.is_none(), "{:?}", out.fault);
    assert_eq!(out.ticks, 1_000_000);
    assert_eq!(rows, 1_000_000 / 30 + 1);
    // Memory flat: nothing allocated while 10⁶ ticks ran.
    assert_eq!(allocs, 0, "allocations inside the loop");
    assert_eq!(peak, 0, "bytes allocated inside the loop");
    assert!(
        out.max_drift < 1e-9,
        "constraint drift {:.3e} m",
        out.max_drift
    );
    let logged = out.log.get("drift").expect("drift column");
    let worst = logged.iter().fold(0.0f64, |m, d| m.max(*d));
    assert!(worst < 1e-9, "logged drift {worst:.3e} m");
    assert!(out.min_margin.is_some_and(|m| m > 0.0));
}
