//! `tandem_tick` allocates nothing (issue 23; STYLE habit 5): a counting global allocator
//! around ticks of the dual-UR5 and paper NN controllers through the C ABI, after a warm-up.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use tandem_ffi::TandemStatus::TANDEM_OK;
use tandem_ffi::*;

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator, counting.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static A: Counting = Counting;

#[test]
fn tandem_tick_allocates_nothing() {
    for name in [c"dual-ur5", c"paper", c"dual-franka"] {
        let mut h = std::ptr::null_mut();
        assert_eq!(
            tandem_controller_new_preset(name.as_ptr(), std::ptr::null(), &mut h),
            TANDEM_OK
        );
        let (mut nq, mut na, mut wd, mut dt) = (0, 0, 0, 0.0);
        tandem_n_q(h, &mut nq);
        tandem_n_arms(h, &mut na);
        tandem_wrench_dim(h, &mut wd);
        tandem_control_period(h, &mut dt);
        let nw = na * wd;
        let (mut q, mut qd, mut w, mut tau) =
            (vec![0.0; nq], vec![0.0; nq], vec![0.0; nw], vec![0.0; nq]);
        let st = tandem_start_state(
            h,
            q.as_mut_ptr(),
            nq,
            qd.as_mut_ptr(),
            nq,
            w.as_mut_ptr(),
            nw,
        );
        assert_eq!(st, TANDEM_OK);
        assert_eq!(
            tandem_start(h, 0.0, q.as_ptr(), nq, qd.as_ptr(), nq, w.as_ptr(), nw),
            TANDEM_OK
        );
        let mut tick = |k: usize| {
            let qk: [f64; 1] = [1e-4 * (k as f64).sin()];
            q[0] += qk[0];
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
            assert_eq!(st, TANDEM_OK);
        };
        for k in 0..10 {
            tick(k);
        }
        let before = ALLOCS.load(Ordering::Relaxed);
        for k in 10..310 {
            tick(k);
        }
        let n = ALLOCS.load(Ordering::Relaxed) - before;
        assert_eq!(n, 0, "{name:?}: {n} allocations in 300 ticks");
        // The counter counts: a refused tick writes its message (allocating, off the
        // real-time path).
        let before = ALLOCS.load(Ordering::Relaxed);
        let st = tandem_tick(
            h,
            0.0,
            q.as_ptr(),
            nq,
            qd.as_ptr(),
            nq,
            w.as_ptr(),
            nw,
            tau.as_mut_ptr(),
            nq,
        );
        assert_eq!(st, TandemStatus::TANDEM_ERR_TIME);
        assert!(ALLOCS.load(Ordering::Relaxed) > before);
        assert_eq!(tandem_controller_free(h), TANDEM_OK);
    }
}
