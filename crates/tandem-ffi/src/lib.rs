//! tandem's controller behind a C ABI (issue 23): a scenario's controller, built exactly as
//! `tandem run` builds it ([`tandem_cli::scenario::standalone`]), started and ticked by a C or
//! C++ loop with plain `double` arrays. The header is `include/tandem.h`, generated from this
//! file by cbindgen (`cbindgen.toml`; `tests/header.rs` fails when it is stale).
//!
//! Every function returns a [`TandemStatus`]; the message of the last failed call on a thread
//! is [`tandem_last_error`]. No panic crosses the boundary: each entry point runs inside
//! [`std::panic::catch_unwind`] and a panic becomes [`TandemStatus::TANDEM_ERR_PANIC`] (the
//! handle is then refused until [`tandem_reset`]). The checks are the standalone controller's
//! ([`Standalone::try_start`], [`Standalone::try_tick`]), the same as the Python `Controller`.
//!
//! This crate is the one place in tandem with `unsafe`: dereferencing the caller's pointers,
//! each checked for null and paired with its length, in `slice`, `slice_mut` and `text`.

// The entry points are C functions: their pointer contract is the header's (a live handle,
// arrays of the length passed), which C callers cannot be made to acknowledge with `unsafe`;
// every pointer is checked for NULL before use. Rust callers are this crate's tests and bench.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use tandem_cli::scenario::standalone::{self, InputError, Standalone};
use tandem_cli::scenario::{self, ControllerChoice, EMBEDDED, Scenario, Source};

/// What a call did: `TANDEM_OK`, or why it failed (the message: `tandem_last_error()`).
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TandemStatus {
    /// Success.
    TANDEM_OK = 0,
    /// A pointer argument (the handle, an array, a string) was NULL.
    TANDEM_ERR_NULL = 1,
    /// An array's length is not the one expected (`n_q`, `n_arms * wrench_dim`, a record's
    /// length), or an output buffer is too short.
    TANDEM_ERR_LENGTH = 2,
    /// NaN or infinity in a measurement or a time.
    TANDEM_ERR_NON_FINITE = 3,
    /// The scenario text does not parse or does not validate (the message names the field and
    /// the line), or its controller cannot be built.
    TANDEM_ERR_SCENARIO = 4,
    /// A name argument is not known (a law, a preset, a record entry) or not UTF-8.
    TANDEM_ERR_ARGUMENT = 5,
    /// A tick whose time is not after the previous tick (the first tick may be at the start's
    /// time).
    TANDEM_ERR_TIME = 6,
    /// The call does not fit the handle's state: a tick before `tandem_start` (or after
    /// `tandem_reset`), or any call on a handle whose earlier call panicked (reset it).
    TANDEM_ERR_STATE = 7,
    /// A panic inside tandem was caught (a bug: please report the message).
    TANDEM_ERR_PANIC = 8,
}

use TandemStatus::*;

/// A scenario's controller: opaque, made by `tandem_controller_new` or
/// `tandem_controller_new_preset`, freed by `tandem_controller_free`.
pub struct TandemController {
    /// The parsed scenario, kept for `tandem_reset`.
    scenario: Scenario,
    /// Its text and name, kept for `tandem_reset`.
    src: Source,
    /// The law asked for (`None`: the scenario's).
    law: Option<ControllerChoice>,
    /// The controller.
    inner: Standalone,
    /// An earlier call panicked: the state may be half-updated; refused until reset.
    poisoned: bool,
}

thread_local! {
    /// The message of the last failed call on this thread (NUL-terminated).
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// A failed call: its status and message.
struct Failure(TandemStatus, String);

type Res<T> = Result<T, Failure>;

fn fail<T>(status: TandemStatus, msg: impl Into<String>) -> Res<T> {
    Err(Failure(status, msg.into()))
}

/// The status of an input check.
fn input_failure(e: InputError) -> Failure {
    let status = match e {
        InputError::Length { .. } => TANDEM_ERR_LENGTH,
        InputError::NonFinite { .. } | InputError::Time { .. } => TANDEM_ERR_NON_FINITE,
        InputError::TimeBack { .. } => TANDEM_ERR_TIME,
        InputError::NotStarted => {
            return Failure(
                TANDEM_ERR_STATE,
                "tandem_tick before tandem_start: call tandem_start(h, t0, q, ..., wrenches, ...) \
                 first (e.g. with tandem_start_state())"
                    .into(),
            );
        }
        _ => TANDEM_ERR_ARGUMENT,
    };
    Failure(status, e.to_string())
}

/// Run `f` with panics caught; record the message of a failure on this thread.
fn guard(func: &str, f: impl FnOnce() -> Res<()>) -> TandemStatus {
    let r = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let what = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(Failure(
                TANDEM_ERR_PANIC,
                format!("{func}: panic inside tandem (a bug): {what}"),
            ))
        }
    };
    match r {
        Ok(()) => TANDEM_OK,
        Err(Failure(status, msg)) => {
            let c = CString::new(msg.replace('\0', " ")).unwrap_or_default();
            // `try_with`: no panic even during the thread's teardown (the message is lost).
            let _ = LAST_ERROR.try_with(|e| *e.borrow_mut() = c);
            status
        }
    }
}

/// The handle behind `h`, unless NULL or poisoned; marked poisoned while `f` runs, so that a
/// panic inside leaves it refused.
fn with_handle(
    func: &str,
    h: *mut TandemController,
    f: impl FnOnce(&mut TandemController) -> Res<()>,
) -> TandemStatus {
    guard(func, || {
        // SAFETY: the caller passes a handle from `tandem_controller_new*` not yet freed, used
        // by one thread at a time (the header's contract); NULL is refused.
        let Some(h) = (unsafe { h.as_mut() }) else {
            return fail(TANDEM_ERR_NULL, format!("{func}: controller is NULL"));
        };
        if h.poisoned {
            return fail(
                TANDEM_ERR_STATE,
                format!(
                    "{func}: an earlier call on this controller panicked; call tandem_reset first"
                ),
            );
        }
        h.poisoned = true;
        let r = f(h);
        h.poisoned = false;
        r
    })
}

/// The `n` doubles at `p` (the argument `arg`); NULL is refused.
fn slice<'a>(arg: &str, p: *const f64, n: usize) -> Res<&'a [f64]> {
    if p.is_null() {
        return fail(TANDEM_ERR_NULL, format!("{arg} is NULL"));
    }
    // SAFETY: not NULL; the caller promises `n` readable doubles at `p` (the header's
    // contract for every array/length pair).
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// The `n` writable doubles at `p` (the argument `arg`); NULL is refused.
fn slice_mut<'a>(arg: &str, p: *mut f64, n: usize) -> Res<&'a mut [f64]> {
    if p.is_null() {
        return fail(TANDEM_ERR_NULL, format!("{arg} is NULL"));
    }
    // SAFETY: as `slice`, writable, and not aliasing the inputs (the header's contract).
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// The NUL-terminated UTF-8 string at `p` (the argument `arg`); NULL is refused.
fn text<'a>(arg: &str, p: *const c_char) -> Res<&'a str> {
    if p.is_null() {
        return fail(TANDEM_ERR_NULL, format!("{arg} is NULL"));
    }
    // SAFETY: not NULL; the caller passes a NUL-terminated string.
    let s = unsafe { CStr::from_ptr(p) };
    s.to_str()
        .map_err(|e| Failure(TANDEM_ERR_ARGUMENT, format!("{arg}: not valid UTF-8 ({e})")))
}

/// A law's name, NULL for the scenario's.
fn law_arg(p: *const c_char) -> Res<Option<ControllerChoice>> {
    if p.is_null() {
        return Ok(None);
    }
    let l = text("law", p)?;
    ControllerChoice::parse(l)
        .map(Some)
        .map_err(|m| Failure(TANDEM_ERR_ARGUMENT, m.replace("(or None", "(or NULL")))
}

/// Write `v` through `out` (the argument `arg`).
fn put<T>(arg: &str, out: *mut T, v: T) -> Res<()> {
    if out.is_null() {
        return fail(TANDEM_ERR_NULL, format!("{arg} is NULL"));
    }
    // SAFETY: not NULL; the caller passes a writable `T`.
    unsafe { out.write(v) };
    Ok(())
}

/// The standalone controller of a scenario (every check of `tandem run`).
fn build(sc: &Scenario, src: &Source, law: Option<ControllerChoice>) -> Res<Standalone> {
    let scenario_err = |e: scenario::ScenarioError| Failure(TANDEM_ERR_SCENARIO, e.to_string());
    // A bad TANDEM_KERNEL is refused before anything is built, as the command line does.
    tandem::control::rbf::Kernel::from_env()
        .map_err(|e| Failure(TANDEM_ERR_SCENARIO, format!("environment variable {e}")))?;
    match sc {
        Scenario::Planar(p) => standalone::planar(p, src, law),
        Scenario::Spatial(p) => standalone::spatial(p, src, law),
    }
    .map_err(scenario_err)
}

/// Parse `src`, build its controller and hand out a handle through `out`.
fn create(src: Source, law: Option<ControllerChoice>, out: *mut *mut TandemController) -> Res<()> {
    if out.is_null() {
        return fail(TANDEM_ERR_NULL, "out is NULL");
    }
    // SAFETY: not NULL; the caller passes a writable pointer. NULL until success.
    unsafe { out.write(std::ptr::null_mut()) };
    let mut src = src;
    let sc = scenario::parse(&src).map_err(|e| Failure(TANDEM_ERR_SCENARIO, e.to_string()))?;
    if let Some(n) = sc.name() {
        src.name = n.to_string();
    }
    let inner = build(&sc, &src, law)?;
    let h = Box::new(TandemController {
        scenario: sc,
        src,
        law,
        inner,
        poisoned: false,
    });
    // SAFETY: as above.
    unsafe { out.write(Box::into_raw(h)) };
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Creating and freeing.

/// Create the controller of a scenario given as TOML text (the format of
/// `tandem scenario show paper`, planar or spatial), built exactly as `tandem run` builds it.
/// `law` is `"nn"`, `"pd"`, `"pd-gravity"`, `"ctc"`, or NULL for the scenario's. Relative paths
/// in the text (a URDF) are relative to the current folder. On success `*out` is the handle
/// (free it with `tandem_controller_free`); on failure `*out` is NULL and the message names the
/// field and the line. Planar and spatial scenarios alike; a torque replay is refused.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_controller_new(
    toml: *const c_char,
    law: *const c_char,
    out: *mut *mut TandemController,
) -> TandemStatus {
    guard("tandem_controller_new", || {
        if !out.is_null() {
            // SAFETY: not NULL; the caller passes a writable pointer.
            unsafe { out.write(std::ptr::null_mut()) };
        }
        let t = text("toml", toml)?;
        let law = law_arg(law)?;
        let src = Source {
            name: "scenario".into(),
            display: "scenario text".into(),
            text: t.strip_prefix('\u{feff}').unwrap_or(t).to_string(),
            dir: std::env::current_dir().unwrap_or_else(|_| PathBuf::from(".")),
            file: None,
        };
        create(src, law, out)
    })
}

/// Create the controller of an embedded scenario (`"paper"`, `"push"`, `"lemniscate"`,
/// `"dual-ur5"`, `"dual-franka"`: `tandem scenario list`) with `law` as in
/// `tandem_controller_new`.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_controller_new_preset(
    name: *const c_char,
    law: *const c_char,
    out: *mut *mut TandemController,
) -> TandemStatus {
    guard("tandem_controller_new_preset", || {
        if !out.is_null() {
            // SAFETY: not NULL; the caller passes a writable pointer.
            unsafe { out.write(std::ptr::null_mut()) };
        }
        let n = text("name", name)?;
        let law = law_arg(law)?;
        let Some(e) = EMBEDDED.iter().find(|e| e.name == n) else {
            let names: Vec<&str> = EMBEDDED.iter().map(|e| e.name).collect();
            return fail(
                TANDEM_ERR_ARGUMENT,
                format!(
                    "name = {n:?}: not an embedded scenario (one of {})",
                    names.join(", ")
                ),
            );
        };
        create(scenario::embedded_source(e), law, out)
    })
}

/// Free a controller (NULL: nothing to do). The handle is invalid afterwards.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_controller_free(h: *mut TandemController) -> TandemStatus {
    guard("tandem_controller_free", || {
        if !h.is_null() {
            // SAFETY: a handle from `tandem_controller_new*`, freed once (the caller's
            // contract).
            drop(unsafe { Box::from_raw(h) });
        }
        Ok(())
    })
}

/// Back to the controller as built (adaptive weights zeroed, admittance at rest, no record):
/// call `tandem_start` again before `tandem_tick`. Also clears a handle refused after a panic.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_reset(h: *mut TandemController) -> TandemStatus {
    guard("tandem_reset", || {
        // SAFETY: as in `with_handle` (a poisoned handle is what reset is for).
        let Some(h) = (unsafe { h.as_mut() }) else {
            return fail(TANDEM_ERR_NULL, "tandem_reset: controller is NULL");
        };
        h.inner = build(&h.scenario, &h.src, h.law)?;
        h.poisoned = false;
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Sizes and the start state.

/// Joints, all arms: the length of `q`, `qd` and `tau`.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_n_q(h: *mut TandemController, out: *mut usize) -> TandemStatus {
    with_handle("tandem_n_q", h, |h| put("out", out, h.inner.n_q))
}

/// Arms.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_n_arms(h: *mut TandemController, out: *mut usize) -> TandemStatus {
    with_handle("tandem_n_arms", h, |h| put("out", out, h.inner.n_arms))
}

/// Wrench channels per arm: 2 planar (the object's force on the end effector, world axes, N),
/// 6 spatial (the object's wrench `[fx, fy, fz, tx, ty, tz]` on the tool, about the tool
/// origin, in tool axes, N and N m). `wrenches` holds `n_arms * wrench_dim` values, arm by arm.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_wrench_dim(h: *mut TandemController, out: *mut usize) -> TandemStatus {
    with_handle("tandem_wrench_dim", h, |h| {
        put("out", out, h.inner.wrench_dim)
    })
}

/// The scenario's control period, s: tick once per period.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_control_period(h: *mut TandemController, out: *mut f64) -> TandemStatus {
    with_handle("tandem_control_period", h, |h| {
        put("out", out, h.inner.control_period)
    })
}

/// Where the scenario's run starts, into the caller's buffers: `q`, `qd` (`n_q` each; at rest)
/// and `wrenches` (`n_arms * wrench_dim`): what the wrist sensors read holding the object on
/// the start pose with zero torque (the readings `tandem run` starts its controller with).
#[unsafe(no_mangle)]
pub extern "C" fn tandem_start_state(
    h: *mut TandemController,
    q: *mut f64,
    nq: usize,
    qd: *mut f64,
    nqd: usize,
    wrenches: *mut f64,
    nw: usize,
) -> TandemStatus {
    with_handle("tandem_start_state", h, |h| {
        let s = &h.inner.start;
        let q = slice_mut("q", q, nq)?;
        let qd = slice_mut("qd", qd, nqd)?;
        let w = slice_mut("wrenches", wrenches, nw)?;
        standalone::check_len("q", q, s.q.len()).map_err(input_failure)?;
        standalone::check_len("qd", qd, s.qd.len()).map_err(input_failure)?;
        standalone::check_len("wrenches", w, s.wrenches.len()).map_err(input_failure)?;
        q.copy_from_slice(&s.q);
        qd.copy_from_slice(&s.qd);
        w.copy_from_slice(&s.wrenches);
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// The loop.

/// Start (or restart) at time `t` (s) with the first readings: `q` (rad) and `qd` (rad/s),
/// `n_q` each, stacked over arms in the scenario's order; `wrenches`, `n_arms * wrench_dim`
/// (see `tandem_wrench_dim`). The admittance starts at rest with its wrench filters at the
/// expected wrenches; adaptive weights are kept (`tandem_reset` zeroes them). On an error
/// (NULL, a wrong length, NaN or infinity: the message names the argument and the index)
/// nothing changed.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_start(
    h: *mut TandemController,
    t: f64,
    q: *const f64,
    nq: usize,
    qd: *const f64,
    nqd: usize,
    wrenches: *const f64,
    nw: usize,
) -> TandemStatus {
    with_handle("tandem_start", h, |h| {
        let q = slice("q", q, nq)?;
        let qd = slice("qd", qd, nqd)?;
        let w = slice("wrenches", wrenches, nw)?;
        h.inner.try_start(t, q, qd, w).map_err(input_failure)
    })
}

/// One control tick at time `t` (s) with this period's readings (as `tandem_start`): the joint
/// torques (N m, `n_q`) into `tau`, the tick's internals into the record
/// (`tandem_record_vector`). Call once per control period from the start's time on, the first
/// tick at the start's time itself; `t` must advance. Never writes NaN; allocates nothing.
///
/// On an error (NULL, a wrong length, NaN or infinity in a reading, a time that does not
/// advance, a tick before `tandem_start`) the controller and its record are unchanged, and
/// `tau`, when it is a buffer of `n_q`, holds zeros (the controller's safe output, as for a
/// tick whose estimate is not finite): a loop that sends `tau` whatever the status never sends
/// stale or NaN torques. The next valid call works.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_tick(
    h: *mut TandemController,
    t: f64,
    q: *const f64,
    nq: usize,
    qd: *const f64,
    nqd: usize,
    wrenches: *const f64,
    nw: usize,
    tau: *mut f64,
    ntau: usize,
) -> TandemStatus {
    with_handle("tandem_tick", h, |h| {
        let tau = slice_mut("tau", tau, ntau)?;
        let r = (|| {
            let q = slice("q", q, nq)?;
            let qd = slice("qd", qd, nqd)?;
            let w = slice("wrenches", wrenches, nw)?;
            h.inner.try_tick(t, q, qd, w, tau).map_err(input_failure)
        })();
        if r.is_err() && tau.len() == h.inner.n_q {
            tau.fill(0.0);
        }
        r
    })
}

// ---------------------------------------------------------------------------------------------
// The record.

/// The last tick's vector `name` into `out` (`n_out` doubles; NULL with `n_out` 0 to ask only
/// its length), its length into `*len` (when `len` is not NULL). Names (3 values planar, 6
/// spatial, in the output chart): `x_hat`, `xd_hat` (pose and rate estimated from the
/// encoders), `x_d`, `x_r`, `xd_r` (desired, admittance reference), `z1`, `z2`, `alpha`,
/// `alpha_dot`, `wrench` (the object wrench commanded), `w_norm` (NN weight norms); spatial
/// also `internal` (`n_arms * 6`: each arm's internal wrench, world axes). `n_out` shorter than
/// the length is an error; longer is fine (the rest is left as it was).
#[unsafe(no_mangle)]
pub extern "C" fn tandem_record_vector(
    h: *mut TandemController,
    name: *const c_char,
    out: *mut f64,
    n_out: usize,
    len: *mut usize,
) -> TandemStatus {
    with_handle("tandem_record_vector", h, |h| {
        let n = text("name", name)?;
        let copy = |v: &mut dyn FnMut(&mut [f64]), m: usize| -> Res<()> {
            if !len.is_null() {
                put("len", len, m)?;
            }
            if out.is_null() && n_out == 0 {
                return Ok(());
            }
            let o = slice_mut("out", out, n_out)?;
            if o.len() < m {
                return fail(
                    TANDEM_ERR_LENGTH,
                    format!("out: {name} has {m} values, n_out = {}", o.len(), name = n),
                );
            }
            v(&mut o[..m]);
            Ok(())
        };
        if let Some((_, v)) = h.inner.record_vectors().into_iter().find(|(k, _)| *k == n) {
            return copy(&mut |o| o.copy_from_slice(v), v.len());
        }
        if n == "internal"
            && let Some(int) = h.inner.record_internal()
        {
            return copy(
                &mut |o| {
                    for (chunk, w) in o.chunks_exact_mut(6).zip(int) {
                        chunk.copy_from_slice(w.as_slice());
                    }
                },
                int.len() * 6,
            );
        }
        let mut names: Vec<&str> = h.inner.record_vectors().iter().map(|(k, _)| *k).collect();
        if h.inner.record_internal().is_some() {
            names.push("internal");
        }
        fail(
            TANDEM_ERR_ARGUMENT,
            format!(
                "name = {n:?}: not a record vector (one of {})",
                names.join(", ")
            ),
        )
    })
}

/// The last tick's scalar `name` into `*out`: `Q` (NN switching value, 1 for other laws),
/// `margin` (output-bound margin of the estimate), spatial `angle_error`; and the flags as 0 or
/// 1: `barrier_hit`, `torque_clipped`, `non_finite`.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_record_scalar(
    h: *mut TandemController,
    name: *const c_char,
    out: *mut f64,
) -> TandemStatus {
    with_handle("tandem_record_scalar", h, |h| {
        let n = text("name", name)?;
        let scalars = h.inner.record_scalars();
        let flags = h.inner.record_flags();
        let v = scalars
            .iter()
            .find(|(k, _)| *k == n)
            .map(|(_, v)| *v)
            .or_else(|| {
                flags
                    .iter()
                    .find(|(k, _)| *k == n)
                    .map(|(_, b)| f64::from(u8::from(*b)))
            });
        match v {
            Some(v) => put("out", out, v),
            None => {
                let names: Vec<&str> = scalars
                    .iter()
                    .map(|(k, _)| *k)
                    .chain(flags.iter().map(|(k, _)| *k))
                    .collect();
                fail(
                    TANDEM_ERR_ARGUMENT,
                    format!(
                        "name = {n:?}: not a record scalar (one of {})",
                        names.join(", ")
                    ),
                )
            }
        }
    })
}

/// Event counts since the controller was built (or reset).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TandemEvents {
    /// Ticks with a barrier saturation.
    pub barrier_hits: u64,
    /// Ticks with clipped torques (effort limit, or a non-finite torque replaced).
    pub torque_clips: u64,
    /// Ticks with a non-finite value replaced.
    pub non_finite: u64,
    /// Ticks that could not estimate or distribute (degenerate grasps).
    pub degenerate: u64,
}

/// The event counts into `*out`.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_events(h: *mut TandemController, out: *mut TandemEvents) -> TandemStatus {
    with_handle("tandem_events", h, |h| {
        let e = h.inner.events();
        put(
            "out",
            out,
            TandemEvents {
                barrier_hits: e.barrier_hits,
                torque_clips: e.torque_clips,
                non_finite: e.non_finite,
                degenerate: e.degenerate,
            },
        )
    })
}

// ---------------------------------------------------------------------------------------------
// Errors.

/// The message of the last failed call on this thread (empty if none has failed), a
/// NUL-terminated UTF-8 string owned by tandem: valid until the next failed call on this thread;
/// copy it to keep it. Never NULL. A successful call leaves it as it was.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_last_error() -> *const c_char {
    // Cannot panic: `try_with` (an empty string during the thread's teardown), and nothing
    // holds the cell mutably outside `guard`.
    LAST_ERROR
        .try_with(|e| e.borrow().as_ptr())
        .unwrap_or(c"".as_ptr())
}

/// A status's name (`"TANDEM_ERR_LENGTH"`), a static string.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_status_name(status: TandemStatus) -> *const c_char {
    let s: &'static CStr = match status {
        TANDEM_OK => c"TANDEM_OK",
        TANDEM_ERR_NULL => c"TANDEM_ERR_NULL",
        TANDEM_ERR_LENGTH => c"TANDEM_ERR_LENGTH",
        TANDEM_ERR_NON_FINITE => c"TANDEM_ERR_NON_FINITE",
        TANDEM_ERR_SCENARIO => c"TANDEM_ERR_SCENARIO",
        TANDEM_ERR_ARGUMENT => c"TANDEM_ERR_ARGUMENT",
        TANDEM_ERR_TIME => c"TANDEM_ERR_TIME",
        TANDEM_ERR_STATE => c"TANDEM_ERR_STATE",
        TANDEM_ERR_PANIC => c"TANDEM_ERR_PANIC",
    };
    s.as_ptr()
}

/// tandem's version (`"0.1.0"`), a static string.
#[unsafe(no_mangle)]
pub extern "C" fn tandem_version() -> *const c_char {
    const V: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => c"?",
        };
    V.as_ptr()
}

/// A poisoned handle, for the tests of panic containment: makes the next call on `h` behave
/// as after a caught panic.
#[doc(hidden)]
pub fn poison_for_tests(h: *mut TandemController) {
    // SAFETY: test-only; a live handle.
    if let Some(h) = unsafe { h.as_mut() } {
        h.poisoned = true;
    }
}

/// A panic through the guard, for the tests of panic containment.
#[doc(hidden)]
pub fn panic_for_tests() -> TandemStatus {
    guard("panic_for_tests", || panic!("a test panic"))
}
