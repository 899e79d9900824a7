//! The C ABI called from Rust as C would call it (issue 23, "Bad input"): each bad call returns
//! its status with a message naming the argument, changes nothing, and the next valid call
//! works; the C tick equals the Rust `Standalone` tick bit for bit.

use std::ffi::{CStr, CString};
use std::ptr::{null, null_mut};

use tandem_cli::scenario::standalone::{self, Standalone};
use tandem_cli::scenario::{self, EMBEDDED, Scenario};
use tandem_ffi::TandemStatus::*;
use tandem_ffi::*;

fn last_error() -> String {
    // SAFETY: tandem_last_error never returns NULL and the string lives until the next failure.
    unsafe { CStr::from_ptr(tandem_last_error()) }
        .to_str()
        .unwrap()
        .to_string()
}

/// `st` is `want` and the message contains `needle`.
#[track_caller]
fn expect(st: TandemStatus, want: TandemStatus, needle: &str) {
    let msg = last_error();
    assert_eq!(st, want, "message: {msg}");
    assert!(msg.contains(needle), "{msg:?} does not contain {needle:?}");
}

/// A controller through the C ABI with its start state.
struct C {
    h: *mut TandemController,
    q: Vec<f64>,
    qd: Vec<f64>,
    w: Vec<f64>,
    dt: f64,
}

impl C {
    fn preset(name: &str, law: Option<&str>) -> C {
        let name = CString::new(name).unwrap();
        let law = law.map(|l| CString::new(l).unwrap());
        let mut h = null_mut();
        let st = tandem_controller_new_preset(
            name.as_ptr(),
            law.as_ref().map_or(null(), |l| l.as_ptr()),
            &mut h,
        );
        assert_eq!(st, TANDEM_OK, "{}", last_error());
        let (mut nq, mut na, mut wd, mut dt) = (0, 0, 0, 0.0);
        assert_eq!(tandem_n_q(h, &mut nq), TANDEM_OK);
        assert_eq!(tandem_n_arms(h, &mut na), TANDEM_OK);
        assert_eq!(tandem_wrench_dim(h, &mut wd), TANDEM_OK);
        assert_eq!(tandem_control_period(h, &mut dt), TANDEM_OK);
        let (mut q, mut qd, mut w) = (vec![0.0; nq], vec![0.0; nq], vec![0.0; na * wd]);
        let st = tandem_start_state(
            h,
            q.as_mut_ptr(),
            nq,
            qd.as_mut_ptr(),
            nq,
            w.as_mut_ptr(),
            na * wd,
        );
        assert_eq!(st, TANDEM_OK);
        C { h, q, qd, w, dt }
    }

    fn start(&self, t: f64, q: &[f64], qd: &[f64], w: &[f64]) -> TandemStatus {
        tandem_start(
            self.h,
            t,
            q.as_ptr(),
            q.len(),
            qd.as_ptr(),
            qd.len(),
            w.as_ptr(),
            w.len(),
        )
    }

    fn tick(&self, t: f64, q: &[f64], qd: &[f64], w: &[f64], tau: &mut [f64]) -> TandemStatus {
        tandem_tick(
            self.h,
            t,
            q.as_ptr(),
            q.len(),
            qd.as_ptr(),
            qd.len(),
            w.as_ptr(),
            w.len(),
            tau.as_mut_ptr(),
            tau.len(),
        )
    }

    fn vector(&self, name: &str) -> Vec<f64> {
        let n = CString::new(name).unwrap();
        let mut len = 0;
        assert_eq!(
            tandem_record_vector(self.h, n.as_ptr(), null_mut(), 0, &mut len),
            TANDEM_OK
        );
        let mut v = vec![0.0; len];
        let st = tandem_record_vector(self.h, n.as_ptr(), v.as_mut_ptr(), len, null_mut());
        assert_eq!(st, TANDEM_OK, "{}", last_error());
        v
    }
}

impl Drop for C {
    fn drop(&mut self) {
        assert_eq!(tandem_controller_free(self.h), TANDEM_OK);
    }
}

fn rust(name: &str, law: Option<&str>) -> Standalone {
    let e = EMBEDDED.iter().find(|e| e.name == name).unwrap();
    let src = scenario::embedded_source(e);
    let law = law.map(|l| scenario::ControllerChoice::parse(l).unwrap());
    match scenario::parse(&src).unwrap() {
        Scenario::Planar(p) => standalone::planar(&p, &src, law).unwrap(),
        Scenario::Spatial(p) => standalone::spatial(&p, &src, law).unwrap(),
    }
}

#[test]
fn c_tick_equals_the_rust_tick_bit_for_bit() {
    for (name, law) in [
        ("paper", None),
        ("dual-ur5", None),
        ("dual-ur5", Some("pd-gravity")),
        ("dual-ur5", Some("ctc")),
    ] {
        let c = C::preset(name, law);
        let mut r = rust(name, law);
        assert_eq!(r.start.q, c.q);
        assert_eq!(r.start.wrenches, c.w);
        let (mut tc, mut tr) = (vec![0.0; c.q.len()], vec![0.0; c.q.len()]);
        assert_eq!(c.start(0.0, &c.q, &c.qd, &c.w), TANDEM_OK);
        r.start(0.0, &c.q, &c.qd, &c.w);
        // A held measurement with a small perturbation that grows, so the law has work to do.
        for k in 0..200 {
            let t = k as f64 * c.dt;
            let q: Vec<f64> = c.q.iter().map(|v| v + 1e-4 * (k as f64).sin()).collect();
            assert_eq!(c.tick(t, &q, &c.qd, &c.w, &mut tc), TANDEM_OK);
            r.tick(t, &q, &c.qd, &c.w, &mut tr);
            assert!(
                tc.iter().zip(&tr).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{name} {law:?} tick {k}: {tc:?} vs {tr:?}"
            );
        }
        let z1: Vec<f64> = r
            .record_vectors()
            .iter()
            .find(|(k, _)| *k == "z1")
            .unwrap()
            .1
            .to_vec();
        assert_eq!(c.vector("z1"), z1);
        let mut qs = 0.0;
        let qn = CString::new("Q").unwrap();
        assert_eq!(tandem_record_scalar(c.h, qn.as_ptr(), &mut qs), TANDEM_OK);
        assert_eq!(qs, r.record_scalars()[0].1);
    }
}

#[test]
fn null_pointers_are_named() {
    let c = C::preset("paper", None);
    let n = c.q.len();
    let mut tau = vec![0.0; n];
    expect(
        tandem_tick(
            null_mut(),
            0.0,
            c.q.as_ptr(),
            n,
            c.qd.as_ptr(),
            n,
            c.w.as_ptr(),
            c.w.len(),
            tau.as_mut_ptr(),
            n,
        ),
        TANDEM_ERR_NULL,
        "tandem_tick: controller is NULL",
    );
    expect(
        tandem_start(
            c.h,
            0.0,
            c.q.as_ptr(),
            n,
            null(),
            n,
            c.w.as_ptr(),
            c.w.len(),
        ),
        TANDEM_ERR_NULL,
        "qd is NULL",
    );
    assert_eq!(c.start(0.0, &c.q, &c.qd, &c.w), TANDEM_OK);
    expect(
        tandem_tick(
            c.h,
            0.0,
            c.q.as_ptr(),
            n,
            c.qd.as_ptr(),
            n,
            null(),
            c.w.len(),
            tau.as_mut_ptr(),
            n,
        ),
        TANDEM_ERR_NULL,
        "wrenches is NULL",
    );
    expect(
        tandem_tick(
            c.h,
            0.0,
            c.q.as_ptr(),
            n,
            c.qd.as_ptr(),
            n,
            c.w.as_ptr(),
            c.w.len(),
            null_mut(),
            n,
        ),
        TANDEM_ERR_NULL,
        "tau is NULL",
    );
    expect(tandem_n_q(c.h, null_mut()), TANDEM_ERR_NULL, "out is NULL");
    expect(
        tandem_controller_new(null(), null(), &mut null_mut()),
        TANDEM_ERR_NULL,
        "toml is NULL",
    );
    expect(
        tandem_controller_new_preset(c"paper".as_ptr(), null(), null_mut()),
        TANDEM_ERR_NULL,
        "out is NULL",
    );
    expect(
        tandem_reset(null_mut()),
        TANDEM_ERR_NULL,
        "controller is NULL",
    );
    // Freeing NULL is nothing.
    assert_eq!(tandem_controller_free(null_mut()), TANDEM_OK);
    // The handle still works.
    assert_eq!(c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau), TANDEM_OK);
}

#[test]
fn wrong_lengths_non_finite_and_time_are_refused_and_change_nothing() {
    let c = C::preset("dual-ur5", None);
    let n = c.q.len();
    let mut tau = vec![7.0; n];
    // Before start.
    expect(
        c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau),
        TANDEM_ERR_STATE,
        "tandem_tick before tandem_start",
    );
    assert!(tau.iter().all(|&v| v == 0.0), "safe output: zeros");
    expect(
        c.start(0.0, &c.q[..n - 1], &c.qd, &c.w),
        TANDEM_ERR_LENGTH,
        &format!("q: expected length {n}, got {}", n - 1),
    );
    expect(
        c.start(0.0, &c.q, &c.qd, &c.w[..11]),
        TANDEM_ERR_LENGTH,
        "wrenches: expected length 12, got 11",
    );
    let mut bad = c.q.clone();
    bad[1] = f64::NAN;
    expect(
        c.start(0.0, &bad, &c.qd, &c.w),
        TANDEM_ERR_NON_FINITE,
        "q[1] = NaN: every value must be finite",
    );
    expect(
        c.start(f64::INFINITY, &c.q, &c.qd, &c.w),
        TANDEM_ERR_NON_FINITE,
        "t = inf: must be finite",
    );
    // The rejected starts did not start it.
    expect(
        c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau),
        TANDEM_ERR_STATE,
        "before tandem_start",
    );
    assert_eq!(c.start(0.0, &c.q, &c.qd, &c.w), TANDEM_OK);

    // A reference run without any bad call.
    let r = C::preset("dual-ur5", None);
    assert_eq!(r.start(0.0, &r.q, &r.qd, &r.w), TANDEM_OK);
    let mut tau_r = vec![0.0; n];

    let mut w_inf = c.w.clone();
    w_inf[7] = f64::INFINITY;
    tau.fill(7.0);
    expect(
        c.tick(0.0, &c.q, &c.qd, &w_inf, &mut tau),
        TANDEM_ERR_NON_FINITE,
        "wrenches[1, 1] = inf: every value must be finite",
    );
    assert!(tau.iter().all(|&v| v == 0.0), "safe output: zeros");
    expect(
        c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau[..n - 1]),
        TANDEM_ERR_LENGTH,
        &format!("tau: expected length {n}, got {}", n - 1),
    );
    expect(
        c.tick(f64::NAN, &c.q, &c.qd, &c.w, &mut tau),
        TANDEM_ERR_NON_FINITE,
        "t = NaN: must be finite",
    );
    for k in 0..3 {
        let t = k as f64 * c.dt;
        assert_eq!(
            c.tick(t, &c.q, &c.qd, &c.w, &mut tau),
            TANDEM_OK,
            "{}",
            last_error()
        );
        assert_eq!(r.tick(t, &r.q, &r.qd, &r.w, &mut tau_r), TANDEM_OK);
        assert_eq!(tau, tau_r, "tick {k}: the refused calls changed nothing");
    }
    let t_last = 2.0 * c.dt;
    expect(
        c.tick(t_last, &c.q, &c.qd, &c.w, &mut tau),
        TANDEM_ERR_TIME,
        "time went back (the previous tick was at",
    );
    expect(
        c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau),
        TANDEM_ERR_TIME,
        "time went back",
    );
    let t = 3.0 * c.dt;
    assert_eq!(c.tick(t, &c.q, &c.qd, &c.w, &mut tau), TANDEM_OK);
    assert_eq!(r.tick(t, &r.q, &r.qd, &r.w, &mut tau_r), TANDEM_OK);
    assert_eq!(tau, tau_r);
    assert_eq!(c.vector("z1"), r.vector("z1"));

    // Record reads: a short buffer, an unknown name.
    let mut short = [0.0; 5];
    expect(
        tandem_record_vector(c.h, c"z1".as_ptr(), short.as_mut_ptr(), 5, null_mut()),
        TANDEM_ERR_LENGTH,
        "out: z1 has 6 values, n_out = 5",
    );
    expect(
        tandem_record_vector(c.h, c"zz".as_ptr(), short.as_mut_ptr(), 5, null_mut()),
        TANDEM_ERR_ARGUMENT,
        "not a record vector (one of x_hat",
    );
    assert_eq!(c.vector("internal").len(), 12);
    let mut v = 0.0;
    expect(
        tandem_record_scalar(c.h, c"nope".as_ptr(), &mut v),
        TANDEM_ERR_ARGUMENT,
        "not a record scalar (one of Q, margin, angle_error, barrier_hit",
    );
    assert_eq!(
        tandem_record_scalar(c.h, c"barrier_hit".as_ptr(), &mut v),
        TANDEM_OK
    );
    assert!(v == 0.0 || v == 1.0);

    // Reset: back to as built, start needed again, the same first tick as a fresh one.
    assert_eq!(tandem_reset(c.h), TANDEM_OK);
    expect(
        c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau),
        TANDEM_ERR_STATE,
        "before tandem_start",
    );
    let f = C::preset("dual-ur5", None);
    assert_eq!(c.start(0.0, &c.q, &c.qd, &c.w), TANDEM_OK);
    assert_eq!(f.start(0.0, &f.q, &f.qd, &f.w), TANDEM_OK);
    assert_eq!(c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau), TANDEM_OK);
    assert_eq!(f.tick(0.0, &f.q, &f.qd, &f.w, &mut tau_r), TANDEM_OK);
    assert_eq!(tau, tau_r);
    let mut ev = TandemEvents::default();
    assert_eq!(tandem_events(c.h, &mut ev), TANDEM_OK);
}

#[test]
fn bad_names_and_scenarios_are_refused() {
    let mut h = null_mut();
    expect(
        tandem_controller_new_preset(c"dual-ur5".as_ptr(), c"lqr".as_ptr(), &mut h),
        TANDEM_ERR_ARGUMENT,
        "law = \"lqr\": must be one of nn, pd, pd-gravity, ctc (or NULL",
    );
    assert!(h.is_null());
    expect(
        tandem_controller_new_preset(c"dual-ur6".as_ptr(), null(), &mut h),
        TANDEM_ERR_ARGUMENT,
        "not an embedded scenario (one of paper, push, lemniscate, dual-ur5, dual-franka, dual-ur5-grip)",
    );
    // TOML that does not parse: the message has the line.
    let broken = c"[run]\nduration = 5\ncontrol_period = \n";
    expect(
        tandem_controller_new(broken.as_ptr(), null(), &mut h),
        TANDEM_ERR_SCENARIO,
        "line 3",
    );
    assert!(h.is_null());
    // A field of the wrong type: the message names the field.
    let paper = EMBEDDED.iter().find(|e| e.name == "paper").unwrap().text;
    let bad = paper.replacen("[run]", "[run]\ncontrol_period = \"fast\"", 1);
    let bad = CString::new(bad).unwrap();
    let st = tandem_controller_new(bad.as_ptr(), null(), &mut h);
    let msg = last_error();
    assert_eq!(st, TANDEM_ERR_SCENARIO, "{msg}");
    assert!(
        msg.contains("control_period") && msg.contains("line"),
        "{msg}"
    );
    // Not UTF-8.
    expect(
        tandem_controller_new(c"\xff\xfe".as_ptr(), null(), &mut h),
        TANDEM_ERR_ARGUMENT,
        "toml: not valid UTF-8",
    );
    // And a valid call after all of these works: from text, with a law.
    let good = CString::new(paper).unwrap();
    assert_eq!(
        tandem_controller_new(good.as_ptr(), c"pd".as_ptr(), &mut h),
        TANDEM_OK,
        "{}",
        last_error()
    );
    let mut nq = 0;
    assert_eq!(tandem_n_q(h, &mut nq), TANDEM_OK);
    assert_eq!(nq, 4);
    assert_eq!(tandem_controller_free(h), TANDEM_OK);
}

#[test]
fn panics_are_caught_and_the_handle_is_refused_until_reset() {
    expect(
        panic_for_tests(),
        TANDEM_ERR_PANIC,
        "panic inside tandem (a bug): a test panic",
    );
    let c = C::preset("paper", None);
    poison_for_tests(c.h);
    let mut tau = vec![0.0; c.q.len()];
    expect(
        c.start(0.0, &c.q, &c.qd, &c.w),
        TANDEM_ERR_STATE,
        "an earlier call on this controller panicked",
    );
    assert_eq!(tandem_reset(c.h), TANDEM_OK);
    assert_eq!(c.start(0.0, &c.q, &c.qd, &c.w), TANDEM_OK);
    assert_eq!(c.tick(0.0, &c.q, &c.qd, &c.w, &mut tau), TANDEM_OK);
}

#[test]
fn status_names_and_version() {
    // SAFETY: static NUL-terminated strings.
    let name = |s| {
        unsafe { CStr::from_ptr(tandem_status_name(s)) }
            .to_str()
            .unwrap()
    };
    assert_eq!(name(TANDEM_OK), "TANDEM_OK");
    assert_eq!(name(TANDEM_ERR_NON_FINITE), "TANDEM_ERR_NON_FINITE");
    let v = unsafe { CStr::from_ptr(tandem_version()) }
        .to_str()
        .unwrap();
    assert_eq!(v, env!("CARGO_PKG_VERSION"));
}

/// A handle is `Send`: moved to another thread, it works there.
#[test]
fn a_handle_moves_between_threads() {
    struct Moved(*mut TandemController);
    // SAFETY: the handle is used by one thread at a time (the header's contract).
    unsafe impl Send for Moved {}
    let mut h = null_mut();
    assert_eq!(
        tandem_controller_new_preset(c"paper".as_ptr(), null(), &mut h),
        TANDEM_OK
    );
    let m = Moved(h);
    let n = std::thread::spawn(move || {
        let m = m;
        let mut n = 0;
        assert_eq!(tandem_n_q(m.0, &mut n), TANDEM_OK);
        n
    })
    .join()
    .unwrap();
    assert_eq!(n, 4);
    assert_eq!(tandem_controller_free(h), TANDEM_OK);
}
