//! Time integration of first-order systems `ẏ = f(t, y)`: fixed-step classic RK4 for the plant
//! and an adaptive, error-controlled Dormand–Prince 5(4) for validation (SPEC §2.4,
//! "Integration").
//!
//! # The problem
//!
//! ```text
//! ẏ = f(t, y),   y ∈ ℝⁿ stored as a flat slice &[f64]
//! ```
//!
//! A system implements [`OdeSystem`]: `dim()` gives `n`, `deriv(t, y, dy)` writes `f(t, y)` into
//! `dy`. `deriv` takes `&mut self` so the system can use its own preallocated scratch (mass matrix,
//! KKT buffers, …) and never allocates.
//!
//! **Zero-order hold.** The integrators know nothing about inputs. Between two control ticks the
//! control input `u` is a field of the system that stays constant; the simulation loop writes the
//! new `u` at a tick and then integrates over the tick interval. A closure can be wrapped with
//! [`FnSystem`].
//!
//! # Classic RK4 ([`Rk4`]) — \[1, II.1\]
//!
//! ```text
//! k₁ = f(t,       y)
//! k₂ = f(t + h/2, y + h/2 · k₁)
//! k₃ = f(t + h/2, y + h/2 · k₂)
//! k₄ = f(t + h,   y + h · k₃)
//! y ← y + h/6 · (k₁ + 2k₂ + 2k₃ + k₄)          local error O(h⁵), global error O(h⁴)
//! ```
//!
//! Four evaluations per step; the stage buffers are allocated once in [`Rk4::new`]. Between two
//! control ticks `Δt` apart a caller does `n` sub-steps of `h = Δt / n` with
//! [`Rk4::substeps`] (the input held by the system all along). RK4 does not check for non-finite
//! values (it is the hot path): the simulation checks the state after the tick and records an
//! event.
//!
//! # Dormand–Prince 5(4) ([`DormandPrince`]) — \[2\], \[1, II.5\]
//!
//! Seven stages `kᵢ = f(t + cᵢ h, y + h Σⱼ aᵢⱼ kⱼ)`; the 5th-order solution is
//! `y₁ = y + h Σ bᵢ kᵢ` (local extrapolation) and `y₁ − ŷ₁ = h Σ eᵢ kᵢ` (with `eᵢ = bᵢ − b̂ᵢ`,
//! `ŷ₁` the embedded 4th-order solution) estimates the local error of the 4th-order formula.
//! Because `b = a₇` and `c₇ = 1`, `k₇ = f(t + h, y₁)` is the next step's `k₁` (FSAL: *first same
//! as last*), so an accepted step costs six evaluations.
//!
//! Error norm \[1, II.4\], with `sc_i = atol + rtol · max(|y_i|, |y₁_i|)`:
//!
//! ```text
//! err = sqrt( (1/n) Σᵢ ( (h Σⱼ eⱼ kⱼ)_i / sc_i )² )          the step is accepted iff err ≤ 1
//! ```
//!
//! Step-size controller: the PI controller of DOPRI5 \[1\], \[3\], \[4, IV.2\], with
//! `safety = 0.9`, growth limited to `[0.2, 10]` per step and `β = 0.04` by default
//! ([`DormandPrince::with_pi_beta`]; `β = 0` gives the classic integral controller
//! `h_new = h · safety · err^(−1/5)`):
//!
//! ```text
//! accepted:  h_new = h · clamp( safety · err^(−(1/5 − 0.75 β)) · err_prev^β,  0.2, 10 ),
//!            err_prev ← max(err, 1e-4);  no growth right after a rejection
//! rejected:  h_new = h · max( safety · err^(−(1/5 − 0.75 β)),  0.2 )
//! ```
//!
//! The starting step is chosen by the algorithm of \[1, II.4, "Starting step size"\] (one extra
//! evaluation), unless [`DormandPrince::with_initial_step`] fixes it or a previous call left a
//! proposal (see [`DormandPrince::integrate`]). A step that would leave a sliver before `t₁` is
//! stretched to land on it, and the last step ends at `t₁` exactly.
//!
//! **Failure is a typed error, never a panic** ([`IntegrateError`]): a trial step that produces a
//! non-finite value is rejected and retried with a step five times smaller; if the step size falls
//! below `10 ε · max(|t|, |t₁|)` the integrator gives up with
//! [`IntegrateError::NonFinite`] (if the last trial was non-finite) or
//! [`IntegrateError::StepSizeUnderflow`]. A non-finite initial state or initial derivative is
//! reported at once. On every error `y` holds the last accepted state, at the `t` the error
//! reports.
//!
//! No allocation happens in [`Rk4::step`], [`Rk4::substeps`] or [`DormandPrince::integrate`]:
//! all buffers are sized by the constructors.
//!
//! # References
//!
//! 1. E. Hairer, S. P. Nørsett, G. Wanner, *Solving Ordinary Differential Equations I: Nonstiff
//!    Problems*, 2nd ed., Springer, 1993, and its DOPRI5 code.
//! 2. J. R. Dormand, P. J. Prince, "A family of embedded Runge–Kutta formulae", *J. Comput. Appl.
//!    Math.* 6 (1980) 19–26.
//! 3. K. Gustafsson, "Control theoretic techniques for stepsize selection in explicit Runge–Kutta
//!    methods", *ACM TOMS* 17 (1991) 533–554.
//! 4. E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II: Stiff and
//!    Differential-Algebraic Problems*, 2nd ed., Springer, 1996.

use std::ops::AddAssign;

use thiserror::Error;

use crate::error::{ModelError, non_negative, positive};

/// A first-order system `ẏ = f(t, y)` on a flat state slice.
///
/// Any input (control torque, disturbance) is a field of the implementor, held constant while an
/// integrator runs (zero-order hold); see the [module docs](self).
pub trait OdeSystem {
    /// State dimension `n`; `y` and `dy` passed to [`deriv`](Self::deriv) have this length.
    fn dim(&self) -> usize;

    /// Write `f(t, y)` into `dy` (length [`dim`](Self::dim)). Must not allocate in the hot path;
    /// may use scratch held by `self`. A non-finite output is allowed (the adaptive integrator
    /// reports it), a panic is not.
    fn deriv(&mut self, t: f64, y: &[f64], dy: &mut [f64]);
}

/// Adapter turning a closure `f(t, y, dy)` into an [`OdeSystem`] of dimension `dim`.
///
/// ```
/// # use tandem::math::integrate::{FnSystem, Rk4};
/// // ẏ = −y, y(0) = 1: 10 sub-steps of RK4 over one control tick of 0.1 s.
/// let mut sys = FnSystem::new(1, |_t: f64, y: &[f64], dy: &mut [f64]| dy[0] = -y[0]);
/// let mut rk4 = Rk4::new(1);
/// let mut y = [1.0];
/// let t = rk4.substeps(&mut sys, 0.0, &mut y, 0.1, 10);
/// assert_eq!(t, 0.1);
/// assert!((y[0] - (-0.1f64).exp()).abs() < 1e-10); // ≈ t h⁴/120 = 8e-12
/// ```
#[derive(Clone, Debug)]
pub struct FnSystem<F> {
    dim: usize,
    f: F,
}

impl<F: FnMut(f64, &[f64], &mut [f64])> FnSystem<F> {
    /// Wrap `f`, which writes `f(t, y)` into its third argument, as a system of dimension `dim`.
    pub fn new(dim: usize, f: F) -> Self {
        Self { dim, f }
    }
}

impl<F: FnMut(f64, &[f64], &mut [f64])> OdeSystem for FnSystem<F> {
    fn dim(&self) -> usize {
        self.dim
    }
    fn deriv(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        (self.f)(t, y, dy)
    }
}

/// Index of the first non-finite entry of `v`, if any.
fn first_non_finite(v: &[f64]) -> Option<usize> {
    v.iter().position(|x| !x.is_finite())
}

// ---------------------------------------------------------------------------------------------
// RK4
// ---------------------------------------------------------------------------------------------

/// Classic fixed-step fourth-order Runge–Kutta with stage buffers allocated at construction.
///
/// The plant's integrator: deterministic, four evaluations per step, no allocation, no checks
/// beyond slice lengths (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct Rk4 {
    /// Stage derivatives `k₁ … k₄`, each of length `n`.
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    /// Stage argument `y + h aᵢⱼ kⱼ`, length `n`.
    y_stage: Vec<f64>,
}

impl Rk4 {
    /// Integrator for systems of dimension `dim` (the only allocation).
    pub fn new(dim: usize) -> Self {
        Self {
            k1: vec![0.0; dim],
            k2: vec![0.0; dim],
            k3: vec![0.0; dim],
            k4: vec![0.0; dim],
            y_stage: vec![0.0; dim],
        }
    }

    /// State dimension this integrator was built for.
    pub fn dim(&self) -> usize {
        self.k1.len()
    }

    /// One RK4 step of size `h` from `(t, y)`; `y` is overwritten with `y(t + h)`.
    ///
    /// `(t, y, h)` → `y(t + h)`; four calls to `sys.deriv`, at `t`, `t + h/2` (twice), `t + h`.
    ///
    /// # Panics
    /// If `y.len()` or `sys.dim()` differs from [`dim`](Self::dim) (a programming error).
    pub fn step<S: OdeSystem + ?Sized>(&mut self, sys: &mut S, t: f64, y: &mut [f64], h: f64) {
        self.check_dims(sys, y);
        self.step_unchecked(sys, t, y, h);
    }

    /// `n` RK4 sub-steps of size `h = dt / n` from `(t, y)`, i.e. one control tick of length `dt`
    /// with the input held by `sys` (zero-order hold). Returns the end time `t + dt`.
    ///
    /// Sub-step `i` starts at `t + i·h` (computed, not accumulated, so no drift in `t`).
    /// Equivalent to `n` calls of [`step`](Self::step), bit for bit.
    ///
    /// # Panics
    /// If `n == 0`, or on a dimension mismatch as in [`step`](Self::step).
    pub fn substeps<S: OdeSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        y: &mut [f64],
        dt: f64,
        n: usize,
    ) -> f64 {
        assert!(n > 0, "Rk4::substeps: n must be at least 1");
        self.check_dims(sys, y);
        let h = dt / n as f64;
        // The common planar states on fixed-size arrays (`FIXED_DIMS`): the same operations,
        // unrolled, without the loops' bookkeeping and alias checks.
        match y.len() {
            14 => {
                self.substeps_fixed::<S, 14>(sys, t, y, h, n);
                return t + dt;
            }
            18 => {
                self.substeps_fixed::<S, 18>(sys, t, y, h, n);
                return t + dt;
            }
            _ => {}
        }
        for i in 0..n {
            self.step_unchecked(sys, t + i as f64 * h, y, h);
        }
        t + dt
    }

    /// `n` steps of `h` by [`step_fixed`] on a state of dimension `D` (`y.len() == D`, and the
    /// stage buffers' by `check_dims`).
    #[inline(always)]
    fn substeps_fixed<S: OdeSystem + ?Sized, const D: usize>(
        &mut self,
        sys: &mut S,
        t: f64,
        y: &mut [f64],
        h: f64,
        n: usize,
    ) {
        let Self {
            k1,
            k2,
            k3,
            k4,
            y_stage,
        } = self;
        fn fixed<const D: usize>(v: &mut [f64]) -> &mut [f64; D] {
            v.try_into().expect("checked length")
        }
        let (y, k1, k2, k3, k4, y_stage) = (
            fixed::<D>(y),
            fixed::<D>(k1),
            fixed::<D>(k2),
            fixed::<D>(k3),
            fixed::<D>(k4),
            fixed::<D>(y_stage),
        );
        for i in 0..n {
            step_fixed(sys, t + i as f64 * h, y, h, [k1, k2, k3, k4, y_stage]);
        }
    }

    fn check_dims<S: OdeSystem + ?Sized>(&self, sys: &S, y: &[f64]) {
        assert_eq!(
            y.len(),
            self.dim(),
            "Rk4: state length differs from the integrator's dim"
        );
        assert_eq!(
            sys.dim(),
            self.dim(),
            "Rk4: system dim differs from the integrator's dim"
        );
    }

    fn step_unchecked<S: OdeSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        y: &mut [f64],
        h: f64,
    ) {
        let h2 = 0.5 * h;
        let Self {
            k1,
            k2,
            k3,
            k4,
            y_stage,
        } = self;
        // k1 = f(t, y)
        sys.deriv(t, y, k1);
        // k2 = f(t + h/2, y + h/2 k1)
        for ((s, &yi), &k) in y_stage.iter_mut().zip(y.iter()).zip(k1.iter()) {
            *s = yi + h2 * k;
        }
        sys.deriv(t + h2, y_stage, k2);
        // k3 = f(t + h/2, y + h/2 k2)
        for ((s, &yi), &k) in y_stage.iter_mut().zip(y.iter()).zip(k2.iter()) {
            *s = yi + h2 * k;
        }
        sys.deriv(t + h2, y_stage, k3);
        // k4 = f(t + h, y + h k3)
        for ((s, &yi), &k) in y_stage.iter_mut().zip(y.iter()).zip(k3.iter()) {
            *s = yi + h * k;
        }
        sys.deriv(t + h, y_stage, k4);
        // y ← y + h/6 (k1 + 2 k2 + 2 k3 + k4)
        let h6 = h / 6.0;
        for ((((yi, &a), &b), &c), &d) in y
            .iter_mut()
            .zip(k1.iter())
            .zip(k2.iter())
            .zip(k3.iter())
            .zip(k4.iter())
        {
            *yi += h6 * (a + 2.0 * (b + c) + d);
        }
    }
}

/// The state dimensions [`Rk4::substeps`] runs on fixed-size arrays ([`step_fixed`]): two
/// 2-link arms and the object, `(q, x_o, q̇, ẋ_o)` of 4 + 3 + 4 + 3 (the paper), and 18 (two
/// 3-link arms, or three 2-link arms).
#[cfg(test)]
const FIXED_DIMS: [usize; 2] = [14, 18];

/// [`Rk4::step_unchecked`] on arrays of a dimension known at compile time: the same
/// floating-point operations in the same order (so the same bits), the element loops unrolled.
/// `buf` holds `k₁ … k₄` and the stage argument.
#[inline(always)]
fn step_fixed<S: OdeSystem + ?Sized, const D: usize>(
    sys: &mut S,
    t: f64,
    y: &mut [f64; D],
    h: f64,
    buf: [&mut [f64; D]; 5],
) {
    let [k1, k2, k3, k4, y_stage] = buf;
    let h2 = 0.5 * h;
    // The element loops on local copies (which nothing else can alias, so they pair up in
    // vector registers), each result stored once.
    let y0 = *y;
    let stage = |k: &[f64; D], c: f64| -> [f64; D] { std::array::from_fn(|j| y0[j] + c * k[j]) };
    // k1 = f(t, y)
    sys.deriv(t, y, k1);
    // k2 = f(t + h/2, y + h/2 k1)
    *y_stage = stage(k1, h2);
    sys.deriv(t + h2, y_stage, k2);
    // k3 = f(t + h/2, y + h/2 k2)
    *y_stage = stage(k2, h2);
    sys.deriv(t + h2, y_stage, k3);
    // k4 = f(t + h, y + h k3)
    *y_stage = stage(k3, h);
    sys.deriv(t + h, y_stage, k4);
    // y ← y + h/6 (k1 + 2 k2 + 2 k3 + k4)
    let h6 = h / 6.0;
    let (a, b, c, d) = (*k1, *k2, *k3, *k4);
    *y = std::array::from_fn(|j| y0[j] + h6 * (a[j] + 2.0 * (b[j] + c[j]) + d[j]));
}

// ---------------------------------------------------------------------------------------------
// Dormand–Prince 5(4)
// ---------------------------------------------------------------------------------------------

// Butcher tableau of DOPRI5 [2], [1, II.5]. c6 = c7 = 1.
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
// Row 7 = the 5th-order weights b (a72 = 0, b7 = 0).
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
// e = b − b̂ (b̂ the embedded 4th-order weights); e2 = 0.
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

// Step-size controller constants of DOPRI5 [1].
const SAFETY: f64 = 0.9;
/// Smallest allowed ratio `h_new / h`.
const FAC_MIN: f64 = 0.2;
/// Largest allowed ratio `h_new / h`.
const FAC_MAX: f64 = 10.0;
/// Default PI-controller gain β.
const BETA_DEFAULT: f64 = 0.04;
/// Default bound on the number of trial steps per call.
const MAX_STEPS_DEFAULT: usize = 100_000;

/// Work counters of one [`DormandPrince::integrate`] call (diffsol / DOPRI5 style).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected trial steps (error too large or non-finite).
    pub rejected: usize,
    /// Calls to [`OdeSystem::deriv`].
    pub evaluations: usize,
}

impl AddAssign for Stats {
    fn add_assign(&mut self, rhs: Self) {
        self.accepted += rhs.accepted;
        self.rejected += rhs.rejected;
        self.evaluations += rhs.evaluations;
    }
}

/// Why [`DormandPrince::integrate`] stopped before `t₁`. On every variant the state slice holds
/// the last accepted state, at the time `t` carried by the variant (or `t₀`).
#[derive(Clone, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum IntegrateError {
    /// The state slice or the system has the wrong length.
    #[error("dimension mismatch: integrator built for {expected}, got {found} ({what})")]
    DimensionMismatch {
        /// Dimension the integrator was built for.
        expected: usize,
        /// Dimension received.
        found: usize,
        /// `"state"` or `"system"`.
        what: &'static str,
    },
    /// `t₀` or `t₁` is not finite.
    #[error("invalid time span [{t0}, {t1}]")]
    InvalidSpan {
        /// Start time.
        t0: f64,
        /// End time.
        t1: f64,
    },
    /// A non-finite value in the state or derivative that smaller steps could not avoid.
    #[error("non-finite value at t = {t} (component {index:?}), last step tried h = {h}")]
    NonFinite {
        /// Time of the last accepted state.
        t: f64,
        /// Last trial step size (0 if the initial state or derivative is non-finite).
        h: f64,
        /// First offending state component, when one could be identified.
        index: Option<usize>,
    },
    /// The step size fell below `10 ε · max(|t|, |t₁|)` (a singularity, or a tolerance too tight).
    #[error("step size underflow at t = {t}: h = {h}")]
    StepSizeUnderflow {
        /// Time of the last accepted state.
        t: f64,
        /// Step size at which the integrator gave up.
        h: f64,
    },
    /// More trial steps than [`DormandPrince::with_max_steps`] allows.
    #[error("more than {max_steps} steps; stopped at t = {t}")]
    TooManySteps {
        /// Time of the last accepted state.
        t: f64,
        /// The limit that was hit.
        max_steps: usize,
    },
}

/// Adaptive Dormand–Prince 5(4) with FSAL, a PI step-size controller and exact landing on the end
/// time. For validation runs; see the [module docs](self) for the method.
///
/// ```
/// # use tandem::math::integrate::{DormandPrince, FnSystem};
/// // Harmonic oscillator ẍ = −x over one period.
/// let mut sys = FnSystem::new(2, |_t: f64, y: &[f64], dy: &mut [f64]| {
///     dy[0] = y[1];
///     dy[1] = -y[0];
/// });
/// let mut dp = DormandPrince::new(2, 1e-10, 1e-12).unwrap();
/// let mut y = [1.0, 0.0];
/// let stats = dp.integrate(&mut sys, 0.0, std::f64::consts::TAU, &mut y).unwrap();
/// assert!((y[0] - 1.0).abs() < 1e-8 && y[1].abs() < 1e-8);
/// assert!(stats.accepted > 0);
/// ```
#[derive(Clone, Debug)]
pub struct DormandPrince {
    /// Relative tolerance (≥ 0).
    rtol: f64,
    /// Absolute tolerance (> 0), in the state's units.
    atol: f64,
    /// Largest step magnitude.
    h_max: f64,
    /// Fixed starting step magnitude, if set.
    h_init: Option<f64>,
    /// PI gain β.
    beta: f64,
    /// Bound on trial steps per call.
    max_steps: usize,
    /// Step-size proposal (magnitude) left by the last successful call.
    h_next: Option<f64>,
    /// Counters of the last call.
    stats: Stats,
    /// Stage derivatives k₁ … k₇ (k₇ becomes k₁ on acceptance: FSAL).
    k: [Vec<f64>; 7],
    /// Stage argument.
    y_stage: Vec<f64>,
    /// Candidate 5th-order solution y₁.
    y_new: Vec<f64>,
}

impl DormandPrince {
    /// Integrator for systems of dimension `dim` with tolerances `rtol ≥ 0` and `atol > 0`
    /// (finite). The only allocation.
    ///
    /// `atol` must be positive so the error scale `atol + rtol·|y|` never vanishes when a
    /// component crosses zero. A `rtol` below about `1e-14` cannot be met in double precision
    /// and ends in [`IntegrateError::StepSizeUnderflow`] or [`IntegrateError::TooManySteps`].
    pub fn new(dim: usize, rtol: f64, atol: f64) -> Result<Self, ModelError> {
        non_negative("rtol", rtol)?;
        positive("atol", atol)?;
        let buf = || vec![0.0; dim];
        Ok(Self {
            rtol,
            atol,
            h_max: f64::INFINITY,
            h_init: None,
            beta: BETA_DEFAULT,
            max_steps: MAX_STEPS_DEFAULT,
            h_next: None,
            stats: Stats::default(),
            k: std::array::from_fn(|_| buf()),
            y_stage: buf(),
            y_new: buf(),
        })
    }

    /// Limit the step magnitude to `h_max > 0` (default: unlimited, i.e. the span `|t₁ − t₀|`).
    pub fn with_h_max(mut self, h_max: f64) -> Result<Self, ModelError> {
        if h_max.is_nan() || h_max <= 0.0 {
            return Err(ModelError::invalid(
                "h_max",
                h_max,
                "must be > 0 (may be +inf)",
            ));
        }
        self.h_max = h_max;
        Ok(self)
    }

    /// Start every call with step magnitude `h0 > 0` (finite) instead of the automatic choice.
    pub fn with_initial_step(mut self, h0: f64) -> Result<Self, ModelError> {
        self.h_init = Some(positive("h0", h0)?);
        Ok(self)
    }

    /// PI-controller gain `β ∈ [0, 0.1]` (default 0.04, as DOPRI5). `β = 0` is the classic
    /// integral (I) controller.
    pub fn with_pi_beta(mut self, beta: f64) -> Result<Self, ModelError> {
        if !(0.0..=0.1).contains(&beta) {
            return Err(ModelError::invalid("beta", beta, "must be in [0, 0.1]"));
        }
        self.beta = beta;
        Ok(self)
    }

    /// At most `max_steps` trial steps (accepted + rejected) per call (default 100 000).
    pub fn with_max_steps(mut self, max_steps: usize) -> Self {
        self.max_steps = max_steps;
        self
    }

    /// State dimension this integrator was built for.
    pub fn dim(&self) -> usize {
        self.y_new.len()
    }

    /// Counters of the last [`integrate`](Self::integrate) call, including a failed one.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Step-size proposal carried over to the next call, if any (see
    /// [`integrate`](Self::integrate)).
    pub fn next_step_size(&self) -> Option<f64> {
        self.h_next
    }

    /// Forget the carried-over step-size proposal: the next call chooses its starting step from
    /// scratch, exactly as a fresh integrator would.
    pub fn reset(&mut self) {
        self.h_next = None;
    }

    /// Integrate `y` from `t0` to `t1` (either direction), landing exactly on `t1`.
    ///
    /// `(sys, t0, y(t0))` → `y(t1)` in place, with every local error estimate `err ≤ 1` in the
    /// norm of the [module docs](self). Returns the work counters ([`Stats`]).
    ///
    /// `k₁ = f(t0, y)` is evaluated afresh on every call, because the system's held input may have
    /// changed since the previous call (a control tick). The starting step is, in order of
    /// preference: the fixed [`with_initial_step`](Self::with_initial_step), the proposal left by
    /// the previous successful call (consecutive ticks then need no restart; [`reset`](Self::reset)
    /// forgets it), or the automatic choice of \[1, II.4\]. `t0 == t1` returns at once.
    ///
    /// # Errors
    /// See [`IntegrateError`]; on error `y` holds the last accepted state. Never panics.
    pub fn integrate<S: OdeSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t0: f64,
        t1: f64,
        y: &mut [f64],
    ) -> Result<Stats, IntegrateError> {
        self.stats = Stats::default();
        let n = self.dim();
        if y.len() != n {
            return Err(IntegrateError::DimensionMismatch {
                expected: n,
                found: y.len(),
                what: "state",
            });
        }
        if sys.dim() != n {
            return Err(IntegrateError::DimensionMismatch {
                expected: n,
                found: sys.dim(),
                what: "system",
            });
        }
        if !(t0.is_finite() && t1.is_finite()) {
            return Err(IntegrateError::InvalidSpan { t0, t1 });
        }
        if let Some(i) = first_non_finite(y) {
            return Err(IntegrateError::NonFinite {
                t: t0,
                h: 0.0,
                index: Some(i),
            });
        }
        if t0 == t1 {
            return Ok(self.stats);
        }
        let dir = if t1 > t0 { 1.0 } else { -1.0 };

        // k₁ = f(t0, y0); a non-finite derivative at an accepted point cannot be cured by smaller
        // steps.
        sys.deriv(t0, y, &mut self.k[0]);
        self.stats.evaluations += 1;
        if let Some(i) = first_non_finite(&self.k[0]) {
            return Err(IntegrateError::NonFinite {
                t: t0,
                h: 0.0,
                index: Some(i),
            });
        }

        // Starting step magnitude h (sign carried by dir).
        let h_max = self.h_max.min((t1 - t0).abs());
        let mut h = match self.h_init.or(self.h_next) {
            Some(h0) => h0.min(h_max),
            None => self.initial_step(sys, t0, y, dir, h_max),
        };

        let mut t = t0;
        let mut err_prev = 1e-4_f64;
        let mut last_rejected = false;
        let mut non_finite: Option<Option<usize>> = None;
        let expo1 = 0.2 - 0.75 * self.beta;
        loop {
            // Land on t1: take the remainder if it is within 1 % of h (no sliver left over).
            let remaining = (t1 - t).abs();
            let last = 1.01 * h >= remaining;

            // Give up: step too small (a final remainder below it is still taken), or too many
            // trials.
            let h_min = 10.0 * f64::EPSILON * t.abs().max(t1.abs());
            if !last && (h.is_nan() || h <= h_min) {
                self.h_next = None;
                return Err(match non_finite {
                    Some(index) => IntegrateError::NonFinite { t, h, index },
                    None => IntegrateError::StepSizeUnderflow { t, h },
                });
            }
            if self.stats.accepted + self.stats.rejected >= self.max_steps {
                self.h_next = None;
                return Err(IntegrateError::TooManySteps {
                    t,
                    max_steps: self.max_steps,
                });
            }
            let h_try = if last { remaining } else { h };
            let t_new = if last { t1 } else { t + dir * h_try };

            // (t, y, k₁, h) → (y₁, k₂…k₇, err)
            let err = self.trial_step(sys, t, y, dir * h_try, t_new);

            if !err.is_finite() || first_non_finite(&self.y_new).is_some() {
                // Non-finite trial: reject with the largest shrink, remember why.
                non_finite = Some(self.find_non_finite());
                self.stats.rejected += 1;
                last_rejected = true;
                h = h_try * FAC_MIN;
                continue;
            }
            non_finite = None;
            let fac11 = err.powf(expo1);
            if err <= 1.0 {
                // Accepted: PI controller, fac = h / h_new.
                let fac =
                    (fac11 / err_prev.powf(self.beta) / SAFETY).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
                err_prev = err.max(1e-4);
                let mut h_new = h_try / fac;
                if last_rejected {
                    h_new = h_new.min(h_try);
                }
                y.copy_from_slice(&self.y_new);
                // FSAL: k₇ = f(t_new, y₁) is the next k₁.
                self.k.swap(0, 6);
                t = t_new;
                self.stats.accepted += 1;
                last_rejected = false;
                if last {
                    // The last step may have been shortened to land: keep the larger proposal.
                    self.h_next = Some(h_new.max(h));
                    return Ok(self.stats);
                }
                h = h_new.min(h_max);
            } else {
                // Rejected: shrink, at most by FAC_MIN.
                self.stats.rejected += 1;
                last_rejected = true;
                h = h_try / (fac11 / SAFETY).min(1.0 / FAC_MIN);
            }
        }
    }

    /// Starting step magnitude \[1, II.4\]: from `‖y0‖`, `‖f0‖` and a difference estimate of `‖ÿ‖`,
    /// aiming at a local error of 0.01 for a 5th-order local error. One evaluation.
    /// Reads `k[0] = f(t0, y0)`; uses `y_stage`, `k[1]` as scratch.
    fn initial_step<S: OdeSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t0: f64,
        y0: &[f64],
        dir: f64,
        h_max: f64,
    ) -> f64 {
        let (atol, rtol) = (self.atol, self.rtol);
        let n = y0.len().max(1) as f64;
        let f0 = &self.k[0];
        let (mut d0, mut d1) = (0.0, 0.0);
        for (&yi, &fi) in y0.iter().zip(f0.iter()) {
            let sc = atol + rtol * yi.abs();
            d0 += (yi / sc).powi(2);
            d1 += (fi / sc).powi(2);
        }
        let (d0, d1) = ((d0 / n).sqrt(), (d1 / n).sqrt());
        let h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        }
        .min(h_max);
        // Explicit Euler probe: f1 = f(t0 + h0, y0 + h0 f0).
        for ((s, &yi), &fi) in self.y_stage.iter_mut().zip(y0.iter()).zip(f0.iter()) {
            *s = yi + dir * h0 * fi;
        }
        sys.deriv(t0 + dir * h0, &self.y_stage, &mut self.k[1]);
        self.stats.evaluations += 1;
        let mut d2 = 0.0;
        for ((&yi, &fi), &gi) in y0.iter().zip(self.k[0].iter()).zip(self.k[1].iter()) {
            let sc = atol + rtol * yi.abs();
            d2 += ((gi - fi) / sc).powi(2);
        }
        let d2 = (d2 / n).sqrt() / h0;
        // f64::max drops a NaN d2 (non-finite probe): fall back on d1.
        let d12 = d1.max(d2);
        let h1 = if d12 <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / d12).powf(1.0 / 5.0)
        };
        let h = (100.0 * h0).min(h1).min(h_max);
        if h.is_finite() && h > 0.0 { h } else { h0 }
    }

    /// One Dormand–Prince trial step of signed size `h` from `(t, y)` with `k[0] = f(t, y)`.
    /// Writes `k[1..7]`, `y_new = y₁` (`k[6] = f(t_new, y₁)`) and returns the error norm `err`
    /// (NaN or ∞ if something is non-finite). Six evaluations.
    fn trial_step<S: OdeSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        y: &[f64],
        h: f64,
        t_new: f64,
    ) -> f64 {
        let n = y.len();
        let [k1, k2, k3, k4, k5, k6, k7] = &mut self.k;
        let (ys, yn) = (&mut self.y_stage[..n], &mut self.y_new[..n]);
        // Re-slice to n so the optimiser can drop bounds checks in the indexed loops below.
        let (k1, k2, k3, k4, k5, k6, k7) = (
            &mut k1[..n],
            &mut k2[..n],
            &mut k3[..n],
            &mut k4[..n],
            &mut k5[..n],
            &mut k6[..n],
            &mut k7[..n],
        );

        for i in 0..n {
            ys[i] = y[i] + h * (A21 * k1[i]);
        }
        sys.deriv(t + C2 * h, ys, k2);
        for i in 0..n {
            ys[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        sys.deriv(t + C3 * h, ys, k3);
        for i in 0..n {
            ys[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        sys.deriv(t + C4 * h, ys, k4);
        for i in 0..n {
            ys[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        sys.deriv(t + C5 * h, ys, k5);
        for i in 0..n {
            ys[i] =
                y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        }
        sys.deriv(t_new, ys, k6); // c6 = 1
        for i in 0..n {
            yn[i] =
                y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i]);
        }
        sys.deriv(t_new, yn, k7); // c7 = 1, FSAL
        self.stats.evaluations += 6;

        if n == 0 {
            return 0.0;
        }
        // err = rms( h Σ eⱼ kⱼ / (atol + rtol max(|y|, |y₁|)) )
        let mut sum = 0.0;
        for i in 0..n {
            let e =
                h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            let sc = self.atol + self.rtol * y[i].abs().max(yn[i].abs());
            sum += (e / sc) * (e / sc);
        }
        (sum / n as f64).sqrt()
    }

    /// After a non-finite trial: the first non-finite component of y₁, else of a stage derivative.
    fn find_non_finite(&self) -> Option<usize> {
        first_non_finite(&self.y_new)
            .or_else(|| self.k[1..].iter().find_map(|k| first_non_finite(k)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Harmonic oscillator ẋ = v, v̇ = −ω² x with its exact solution.
    struct Oscillator {
        omega: f64,
    }
    impl OdeSystem for Oscillator {
        fn dim(&self) -> usize {
            2
        }
        fn deriv(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            dy[0] = y[1];
            dy[1] = -self.omega * self.omega * y[0];
        }
    }
    impl Oscillator {
        /// Exact solution from x(0) = 1, v(0) = 0.
        fn exact(&self, t: f64) -> [f64; 2] {
            let w = self.omega;
            [(w * t).cos(), -w * (w * t).sin()]
        }
    }

    /// ẏ = −y², y(0) = 1 ⇒ y = 1 / (1 + t).
    fn riccati() -> FnSystem<impl FnMut(f64, &[f64], &mut [f64])> {
        FnSystem::new(1, |_t: f64, y: &[f64], dy: &mut [f64]| dy[0] = -y[0] * y[0])
    }

    /// Pendulum θ̈ = −(g/l) sin θ.
    fn pendulum() -> FnSystem<impl FnMut(f64, &[f64], &mut [f64])> {
        FnSystem::new(2, |_t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = y[1];
            dy[1] = -9.8 * y[0].sin();
        })
    }

    fn rk4_run<S: OdeSystem>(sys: &mut S, y0: &[f64], t_end: f64, n: usize) -> Vec<f64> {
        let mut rk4 = Rk4::new(y0.len());
        let mut y = y0.to_vec();
        rk4.substeps(sys, 0.0, &mut y, t_end, n);
        y
    }

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    /// Linear test equation: one RK4 step multiplies y by the stability polynomial
    /// R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 (checks the tableau, to round-off).
    #[test]
    fn rk4_step_is_the_stability_polynomial() {
        let lambda = -1.7;
        let mut sys = FnSystem::new(1, move |_t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = lambda * y[0]
        });
        let mut rk4 = Rk4::new(1);
        for &h in &[0.01, 0.1, 0.5, 1.0] {
            let mut y = [1.0];
            rk4.step(&mut sys, 0.0, &mut y, h);
            let z: f64 = lambda * h;
            let r = 1.0 + z + z * z / 2.0 + z.powi(3) / 6.0 + z.powi(4) / 24.0;
            assert!(
                (y[0] - r).abs() <= 4.0 * f64::EPSILON,
                "h = {h}: {} vs {r}",
                y[0]
            );
        }
    }

    /// Stages are evaluated at t, t + h/2 (twice), t + h; `substeps` equals n calls of `step`.
    #[test]
    fn rk4_substeps_match_steps_bitwise() {
        let mut times = Vec::new();
        let mut sys = FnSystem::new(2, |t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = y[1] + t.sin();
            dy[1] = -y[0] * y[1].cos();
        });
        let (mut a, mut b) = ([0.3, -0.2], [0.3, -0.2]);
        let mut rk4 = Rk4::new(2);
        let t_end = rk4.substeps(&mut sys, 1.0, &mut a, 0.25, 5);
        assert_eq!(t_end, 1.25);
        let h = 0.25 / 5.0;
        for i in 0..5 {
            rk4.step(&mut sys, 1.0 + i as f64 * h, &mut b, h);
        }
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));

        let mut rec = FnSystem::new(1, |t: f64, _y: &[f64], dy: &mut [f64]| {
            times.push(t);
            dy[0] = 0.0;
        });
        rk4 = Rk4::new(1);
        rk4.step(&mut rec, 2.0, &mut [0.0], 0.5);
        assert_eq!(times, vec![2.0, 2.25, 2.25, 2.5]);
    }

    /// The fixed-size paths of `substeps` (dimensions `FIXED_DIMS`) equal the slice path of
    /// `step`, bit for bit, on a coupled nonlinear system with time-dependent terms.
    #[test]
    fn rk4_fixed_dim_substeps_match_steps_bitwise() {
        for dim in FIXED_DIMS {
            let f = |t: f64, y: &[f64], dy: &mut [f64]| {
                let n = y.len();
                for j in 0..n {
                    dy[j] = y[(j + 1) % n].sin() - 0.3 * y[j] * y[(j + 5) % n]
                        + (t * (j + 1) as f64).cos();
                }
            };
            let mut sys = FnSystem::new(dim, f);
            let y0: Vec<f64> = (0..dim).map(|j| 0.1 * j as f64 - 0.45).collect();
            let (mut a, mut b) = (y0.clone(), y0);
            let mut rk4 = Rk4::new(dim);
            let t_end = rk4.substeps(&mut sys, 0.7, &mut a, 0.3, 7);
            assert_eq!(t_end, 1.0);
            let h = 0.3 / 7.0;
            for i in 0..7 {
                rk4.step(&mut sys, 0.7 + i as f64 * h, &mut b, h);
            }
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b));
            // And the stage times of the fixed path.
            let mut times = Vec::new();
            let mut rec = FnSystem::new(dim, |t: f64, _y: &[f64], dy: &mut [f64]| {
                times.push(t);
                dy.fill(1.0);
            });
            let mut y = vec![0.0; dim];
            rk4.substeps(&mut rec, 2.0, &mut y, 0.5, 1);
            assert_eq!(times, vec![2.0, 2.25, 2.25, 2.5]);
            assert!(y.iter().all(|&v| v == 0.5));
        }
    }

    /// Global errors at the end time for n, 2n, 4n, … steps.
    fn errors_by_halving(mut run: impl FnMut(usize) -> f64, n0: usize, levels: usize) -> Vec<f64> {
        (0..levels).map(|l| run(n0 << l)).collect()
    }

    /// Assert that halving the step divides the global error by `2^p`: every ratio within
    /// `2^p ± margin`, and the ratios do not drift away from `2^p` (asymptotic regime).
    fn assert_order(name: &str, errs: &[f64], p: i32, margin: f64) {
        let target = 2f64.powi(p);
        let ratios: Vec<f64> = errs.windows(2).map(|w| w[0] / w[1]).collect();
        let e: Vec<String> = errs.iter().map(|e| format!("{e:.3e}")).collect();
        println!("{name}: errors {e:?}, ratios {ratios:.4?} (expect {target})");
        for r in &ratios {
            assert!(
                (r - target).abs() < margin,
                "{name}: ratio {r} is not {target} ± {margin}"
            );
        }
        for w in ratios.windows(2) {
            assert!(
                (w[1] - target).abs() <= (w[0] - target).abs() + 0.05,
                "{name}: {ratios:?}"
            );
        }
        assert!(
            *errs.last().unwrap() > 1e-11,
            "{name}: error too close to round-off"
        );
    }

    /// Fourth-order convergence of RK4, printed and asserted.
    ///
    /// The global error is `e(h) = C h⁴ + D h⁵ + …`, so `e(h)/e(h/2) = 16 (1 + D h/(2C) + …)`.
    /// Each case starts at a step where the printed ratios have settled (deviation ≤ 3 %, then
    /// halving with h: it is that O(h) term) and stops while the error is still > 1e-11, far above
    /// the accumulated round-off (~1e-14) and the reference error (≤ 5e-14). We assert
    /// `|ratio − 16| < 0.8`, an observed order `4 ± 0.07`; a wrong stage weight or node drops the
    /// order to ≤ 3 (ratio ≤ 8), so the margin separates right from wrong by a factor of 10.
    #[test]
    fn rk4_is_fourth_order() {
        // Harmonic oscillator ω = 2 over [0, 10] against the exact solution. Error measured as the
        // distance in (ωx, v), where the exact orbit is a circle: it is then a smooth function of
        // the amplitude and phase errors, and the ratios are clean.
        let w = 2.0;
        let exact = Oscillator { omega: w }.exact(10.0);
        let errs = errors_by_halving(
            |n| {
                let y = rk4_run(&mut Oscillator { omega: w }, &[1.0, 0.0], 10.0, n);
                (w * (y[0] - exact[0])).hypot(y[1] - exact[1])
            },
            200,
            4,
        );
        assert_order("RK4 harmonic oscillator", &errs, 4, 0.8);

        // Nonlinear: ẏ = −y², exact y = 1/(1+t), over [0, 4].
        let errs = errors_by_halving(
            |n| (rk4_run(&mut riccati(), &[1.0], 4.0, n)[0] - 0.2).abs(),
            64,
            3,
        );
        assert_order("RK4 y' = -y^2", &errs, 4, 0.8);

        // Nonlinear: pendulum θ₀ = 1 rad over [0, 3] against DP5 at rtol = atol = 1e-14 (which
        // agrees with 40 000 fixed DP5 steps to 5e-14).
        let mut dp = DormandPrince::new(2, 1e-14, 1e-14).unwrap();
        let mut reference = [1.0, 0.0];
        dp.integrate(&mut pendulum(), 0.0, 3.0, &mut reference)
            .unwrap();
        let errs = errors_by_halving(
            |n| {
                let y = rk4_run(&mut pendulum(), &[1.0, 0.0], 3.0, n);
                (y[0] - reference[0]).hypot(y[1] - reference[1])
            },
            400,
            3,
        );
        assert_order("RK4 pendulum vs DP5", &errs, 4, 0.8);
    }

    /// `n` fixed DP5 steps (FSAL chained) over `[0, t1]`, bypassing the controller.
    fn dp5_fixed<S: OdeSystem>(sys: &mut S, y0: &[f64], t1: f64, n: usize) -> Vec<f64> {
        let h = t1 / n as f64;
        let mut dp = DormandPrince::new(y0.len(), 0.0, 1.0).unwrap();
        let mut y = y0.to_vec();
        sys.deriv(0.0, &y, &mut dp.k[0]);
        for i in 0..n {
            let t = i as f64 * h;
            dp.trial_step(sys, t, &y, h, t + h);
            y.copy_from_slice(&dp.y_new);
            dp.k.swap(0, 6);
        }
        y
    }

    /// ẏ = y cos t, y(0) = 1 ⇒ y = exp(sin t) (nonlinear in t, entire: clean asymptotics).
    fn exp_sin() -> FnSystem<impl FnMut(f64, &[f64], &mut [f64])> {
        FnSystem::new(1, |t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = y[0] * t.cos()
        })
    }

    /// The DP5 tableau: one step on ẏ = λy multiplies y by the stability polynomial
    /// `1 + z + … + z⁵/120 + z⁶/600` (to round-off); with fixed steps the global error on
    /// ẏ = y cos t falls by 2⁵ = 32 per halving (5th order: checks the nonlinear order conditions
    /// of b), and the local error estimate `h Σ eⱼkⱼ` by 2⁵ per halving (it estimates the local
    /// error of the 4th-order embedded formula, O(h⁵): checks e). Margin ±1.6 = observed order
    /// ± 0.07, chosen like the RK4 test's (printed ratios deviate by ≤ 0.7).
    #[test]
    fn dp5_tableau_order_and_error_estimator() {
        let lambda = -0.9;
        let mut lin = FnSystem::new(1, move |_t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = lambda * y[0]
        });
        let mut dp = DormandPrince::new(1, 0.0, 1.0).unwrap();
        for &h in &[0.05, 0.3, 1.0] {
            let y = [1.0];
            lin.deriv(0.0, &y, &mut dp.k[0]);
            dp.trial_step(&mut lin, 0.0, &y, h, h);
            let z: f64 = lambda * h;
            let r = 1.0
                + z
                + z * z / 2.0
                + z.powi(3) / 6.0
                + z.powi(4) / 24.0
                + z.powi(5) / 120.0
                + z.powi(6) / 600.0;
            assert!((dp.y_new[0] - r).abs() < 4.0 * f64::EPSILON, "h = {h}");
        }

        let t1: f64 = 7.3;
        let exact = t1.sin().exp();
        let errs = errors_by_halving(
            |n| (dp5_fixed(&mut exp_sin(), &[1.0], t1, n)[0] - exact).abs(),
            64,
            3,
        );
        assert_order("DP5 fixed-step y' = y cos t", &errs, 5, 1.6);

        // atol = 1, rtol = 0 ⇒ err = |h Σ eⱼ kⱼ| for this scalar problem.
        let est: Vec<f64> = [0.1, 0.05, 0.025]
            .iter()
            .map(|&h| {
                let mut sys = exp_sin();
                let y = [1.0];
                sys.deriv(0.0, &y, &mut dp.k[0]);
                dp.trial_step(&mut sys, 0.0, &y, h, h)
            })
            .collect();
        let ratios: Vec<f64> = est.windows(2).map(|w| w[0] / w[1]).collect();
        println!("DP5 local error estimate {est:?}, ratios {ratios:.3?} (expect 32)");
        for r in ratios {
            assert!((r - 32.0).abs() < 1.6, "{r}");
        }
    }

    /// DP5 meets its tolerance on the oscillator. The controller bounds the *local* error per
    /// step by `tol`; on this neutrally stable problem the phase error then accumulates linearly in
    /// time, so the global error is `≈ c · tol` per period. We assert `< 3 tol` after one period
    /// and `< 5 · 3 tol` after five (printed: ≈ 2 tol per period), and that the error shrinks with
    /// the tolerance (tolerance proportionality).
    #[test]
    fn dp5_meets_tolerance_on_oscillator() {
        for periods in [1.0, 5.0] {
            let t_end = periods * std::f64::consts::TAU;
            let mut prev = f64::INFINITY;
            for &tol in &[1e-6, 1e-8, 1e-10, 1e-12] {
                let mut sys = Oscillator { omega: 1.0 };
                let mut dp = DormandPrince::new(2, tol, tol).unwrap();
                let mut y = [1.0, 0.0];
                let stats = dp.integrate(&mut sys, 0.0, t_end, &mut y).unwrap();
                let err = max_abs_diff(&y, &sys.exact(t_end));
                println!(
                    "oscillator, {periods} periods, tol {tol:e}: err {err:.3e} ({:.2} tol), {stats:?}",
                    err / tol
                );
                assert!(err < periods * 3.0 * tol, "tol {tol}: err {err}");
                assert!(err < prev);
                prev = err;
                assert_eq!(stats.evaluations, 2 + 6 * (stats.accepted + stats.rejected));
            }
        }
    }

    /// DP5 meets its tolerance on problems with known solutions: ẏ = −y² and the time-varying
    /// ẏ = y cos t (y = exp(sin t)); the end point is hit exactly (the last evaluation is at t1).
    #[test]
    fn dp5_meets_tolerance_on_exact_solutions() {
        for &tol in &[1e-6, 1e-9, 1e-12] {
            let mut dp = DormandPrince::new(1, tol, tol).unwrap();
            let mut y = [1.0];
            dp.integrate(&mut riccati(), 0.0, 9.0, &mut y).unwrap();
            let e1 = (y[0] - 0.1).abs() / 0.1;

            let t1 = 7.3;
            let mut t_max = f64::NEG_INFINITY;
            let mut sys = FnSystem::new(1, |t: f64, y: &[f64], dy: &mut [f64]| {
                t_max = t_max.max(t);
                dy[0] = y[0] * t.cos();
            });
            let mut y = [1.0];
            dp.reset();
            let stats = dp.integrate(&mut sys, 0.0, t1, &mut y).unwrap();
            let exact = t1.sin().exp();
            let e2 = (y[0] - exact).abs() / exact;
            println!(
                "tol {tol:e}: riccati rel err {e1:.2e}, exp(sin t) rel err {e2:.2e}, {stats:?}"
            );
            // Observed ≤ 2.8 tol (relative); a few tol is what local control gives on a short span.
            assert!(e1 < 5.0 * tol && e2 < 5.0 * tol);
            assert_eq!(
                t_max, t1,
                "never evaluated beyond t1, and lands on it exactly"
            );
        }
    }

    /// Backward integration and the carried-over step proposal.
    #[test]
    fn dp5_backward_and_warm_start() {
        let mut dp = DormandPrince::new(1, 1e-10, 1e-12).unwrap();
        let mut y = [0.2];
        dp.integrate(&mut riccati(), 4.0, 0.0, &mut y).unwrap();
        assert!((y[0] - 1.0).abs() < 1e-8, "{}", y[0]);

        // Ten "control ticks" of 0.1 s: after the first, no start-up evaluation is spent.
        let mut dp = DormandPrince::new(2, 1e-9, 1e-9).unwrap();
        let mut sys = Oscillator { omega: 1.0 };
        let mut y = [1.0, 0.0];
        for i in 0..10 {
            let s = dp
                .integrate(&mut sys, i as f64 * 0.1, (i + 1) as f64 * 0.1, &mut y)
                .unwrap();
            let startup = if i == 0 { 1 } else { 0 };
            assert_eq!(s.evaluations, 1 + startup + 6 * (s.accepted + s.rejected));
        }
        assert!(max_abs_diff(&y, &sys.exact(1.0)) < 1e-8);
        assert!(dp.next_step_size().is_some());
    }

    /// A stiff-ish transient, ẏ = −λ (y − cos t) − sin t with λ = 1000, y(0) = 2 (exact
    /// y = cos t + e^{−λt}). A forced first step of 0.5 s is rejected several times, the controller
    /// recovers through the transient, then runs at the explicit stability limit (|hλ| ≈ 3.3)
    /// where steps keep being rejected and recovered. The answer still meets the tolerance.
    #[test]
    fn dp5_controller_rejects_and_recovers_on_stiff_transient() {
        let lambda = 1000.0;
        let mut sys = FnSystem::new(1, move |t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = -lambda * (y[0] - t.cos()) - t.sin();
        });
        let tol = 1e-6;
        let mut dp = DormandPrince::new(1, tol, tol)
            .unwrap()
            .with_initial_step(0.5)
            .unwrap();
        let mut y = [2.0];
        let t1 = 2.0;
        let stats = dp.integrate(&mut sys, 0.0, t1, &mut y).unwrap();
        let exact = t1.cos() + (-lambda * t1).exp();
        let err = (y[0] - exact).abs();
        println!("stiff transient: err {err:.2e}, {stats:?}");
        assert!(
            stats.rejected >= 4,
            "the 0.5 s first step needs several rejections"
        );
        assert!(err < 10.0 * tol);
        // Stability-limited: about λ·t1/3.3 ≈ 600 accepted steps, far from h → 0.
        assert!(stats.accepted > 300 && stats.accepted < 2000, "{stats:?}");
    }

    /// Non-finite derivatives are typed errors, never panics; `y` keeps the last accepted state.
    #[test]
    fn dp5_reports_non_finite() {
        // NaN at the start: reported at once.
        let mut sys = FnSystem::new(2, |_t: f64, _y: &[f64], dy: &mut [f64]| {
            dy[0] = 0.0;
            dy[1] = f64::NAN;
        });
        let mut dp = DormandPrince::new(2, 1e-8, 1e-8).unwrap();
        let mut y = [1.0, 2.0];
        let e = dp.integrate(&mut sys, 0.0, 1.0, &mut y).unwrap_err();
        assert_eq!(
            e,
            IntegrateError::NonFinite {
                t: 0.0,
                h: 0.0,
                index: Some(1)
            }
        );
        assert_eq!(y, [1.0, 2.0]);

        // NaN beyond t = 0.5: steps shrink onto 0.5, then the error names the time and component.
        let mut sys = FnSystem::new(2, |t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = -y[0];
            dy[1] = if t > 0.5 { f64::NAN } else { 1.0 };
        });
        let mut y = [1.0, 0.0];
        match dp.integrate(&mut sys, 0.0, 1.0, &mut y) {
            Err(IntegrateError::NonFinite { t, index, .. }) => {
                println!("non-finite at t = {t}, index {index:?}, {:?}", dp.stats());
                assert!((t - 0.5).abs() < 1e-12, "{t}");
                assert_eq!(index, Some(1));
                assert!((y[0] - (-t).exp()).abs() < 1e-7 && (y[1] - t).abs() < 1e-7);
            }
            other => panic!("expected NonFinite, got {other:?}"),
        }

        // Non-finite initial state.
        let mut y = [f64::INFINITY, 0.0];
        assert!(matches!(
            dp.integrate(&mut sys, 0.0, 1.0, &mut y),
            Err(IntegrateError::NonFinite { index: Some(0), .. })
        ));
    }

    /// A finite-time blow-up (ẏ = y², y(0) = 1, singular at t = 1) ends in a step-size underflow
    /// just before t = 1; bad arguments are typed errors.
    #[test]
    fn dp5_reports_underflow_and_bad_arguments() {
        let mut sys = FnSystem::new(1, |_t: f64, y: &[f64], dy: &mut [f64]| dy[0] = y[0] * y[0]);
        let mut dp = DormandPrince::new(1, 1e-8, 1e-8).unwrap();
        let mut y = [1.0];
        match dp.integrate(&mut sys, 0.0, 2.0, &mut y) {
            Err(IntegrateError::StepSizeUnderflow { t, h }) => {
                println!(
                    "blow-up: underflow at t = {t}, h = {h:e}, y = {:e}, {:?}",
                    y[0],
                    dp.stats()
                );
                // The numerical blow-up lags or leads the exact one by the accumulated error.
                assert!((t - 1.0).abs() < 1e-6, "{t}");
            }
            other => panic!("expected StepSizeUnderflow, got {other:?}"),
        }
        let mut dp = dp.with_max_steps(10);
        let mut y = [1.0];
        assert!(matches!(
            dp.integrate(&mut sys, 0.0, 2.0, &mut y),
            Err(IntegrateError::TooManySteps { max_steps: 10, .. })
        ));
        assert_eq!(dp.stats().accepted + dp.stats().rejected, 10);

        let mut y = [1.0, 2.0];
        assert!(matches!(
            dp.integrate(&mut sys, 0.0, 1.0, &mut y),
            Err(IntegrateError::DimensionMismatch {
                expected: 1,
                found: 2,
                what: "state"
            })
        ));
        let mut y = [1.0];
        assert!(matches!(
            dp.integrate(&mut sys, 0.0, f64::NAN, &mut y),
            Err(IntegrateError::InvalidSpan { .. })
        ));
        assert_eq!(
            dp.integrate(&mut sys, 1.0, 1.0, &mut y),
            Ok(Stats::default())
        );
        // A span below the step-size floor at large t is still taken, in one step.
        let (t0, t1) = (1e6, 1e6 + 1e-9);
        let s = dp.integrate(&mut sys, t0, t1, &mut y).unwrap();
        assert_eq!(s.accepted, 1);
        assert!((y[0] - 1.0 / (1.0 - (t1 - t0))).abs() < 1e-15);

        assert!(
            matches!(DormandPrince::new(1, -1.0, 1e-6), Err(ModelError::Invalid { ref param, .. }) if param == "rtol")
        );
        assert!(
            matches!(DormandPrince::new(1, 1e-6, 0.0), Err(ModelError::Invalid { ref param, .. }) if param == "atol")
        );
        assert!(
            DormandPrince::new(1, 1e-6, 1e-6)
                .unwrap()
                .with_pi_beta(0.5)
                .is_err()
        );
        assert!(
            DormandPrince::new(1, 1e-6, 1e-6)
                .unwrap()
                .with_h_max(f64::NAN)
                .is_err()
        );
    }

    /// The I controller (β = 0) also works, and both controllers are deterministic.
    #[test]
    fn dp5_integral_controller_and_determinism() {
        let run = |beta: f64| {
            let mut dp = DormandPrince::new(2, 1e-9, 1e-9)
                .unwrap()
                .with_pi_beta(beta)
                .unwrap();
            let mut y = [2.5, 0.0];
            let s = dp.integrate(&mut pendulum(), 0.0, 5.0, &mut y).unwrap();
            (y, s)
        };
        let (a, sa) = run(0.0);
        let (b, sb) = run(0.04);
        let (c, sc) = run(0.04);
        println!("pendulum: I {sa:?}, PI {sb:?}");
        assert!(max_abs_diff(&a, &b) < 1e-7);
        assert_eq!((b.map(f64::to_bits), sb), (c.map(f64::to_bits), sc));
    }
}
