//! Integral barrier Lyapunov function (iBLF) backstepping, step 1: paper (24)–(32).
//!
//! Per component `j` (index dropped below), with bound `k = k_cj > 0`, reference `x_r`,
//! output `x_1` and `z = z_1 = x_1 − x_r`:
//!
//! $$
//! g(x) = \frac{k^2}{k^2 - x^2},\qquad
//! V_1 = \int_0^{z} \sigma\, g(x_r + \sigma)\,d\sigma \quad (27),
//! $$
//! $$
//! \rho(z, x_r) = \frac{1}{z}\int_0^{z} g(x_r + s)\,ds
//!   = \frac{k}{2z}\ln\frac{(k + x_1)(k - x_r)}{(k - x_1)(k + x_r)} \quad (29),
//! \qquad \rho(0, x_r) = g(x_r) \quad (30),
//! $$
//! $$
//! \alpha = -\kappa_1 z + \rho\,\dot x_r\,\frac{k^2 - x_1^2}{k^2} \quad (31),\qquad
//! \dot V_1 = -\kappa_1 g(x_1) z_1^2 + g(x_1)\, z_1 z_2 \quad (32),\quad z_2 = x_2 - \alpha .
//! $$
//!
//! The paper writes `x_d` for the reference; here (SPEC §3.1) it is the admittance output `x_r`.
//!
//! **SPEC §3.3 erratum applied:** (28), (31), (32) print `k² − x_d²`; the derivation of `V̇1`
//! gives the current output, `k² − x_1²`, which is what (31) uses here. Proof of (32) as
//! implemented: `∂V1/∂z = z g(x_1)` and `∂V1/∂x_r = z (g(x_1) − ρ)`, so
//! `V̇1 = z g(x_1) x_2 − z ρ ẋ_r`; put `x_2 = z_2 + α` with (31) and the `ρ ẋ_r` terms cancel.
//!
//! # Closed forms used
//!
//! With `a = k + x_r`, `b = k − x_r`, `u = z/a`, `w = −z/b` (both `> −1` inside the box),
//! partial fractions `g(x_r + s) = (k/2)[1/(b − s) + 1/(a + s)]` give
//!
//! * `ρ = (k/(2z))·[ln(1+u) − ln(1+w)]`: the two logarithms have opposite signs, so there is
//!   no cancellation; `log1p` keeps full relative accuracy.
//! * `∂ρ/∂x_r = k²(x_r + x_1) / ((k² − x_r²)(k² − x_1²))` (no cancellation other than the exact
//!   zero at `x_1 = −x_r`), and `∂ρ/∂z = (g(x_1) − ρ)/z`.
//! * `V1 = −(k²/2) ln((k² − x_1²)/(k² − x_r²)) − x_r z ρ = (k/2)[a φ(u) + b φ(w)]` with
//!   `φ(u) = u − ln(1+u) ≥ 0`: two non-negative terms, evaluated in the second form.
//!
//! # Series near `z = 0` and the switch point
//!
//! `(g(x_1) − ρ)/z` cancels as `z → 0`, and every form is `0/0` at `z = 0`. For
//! `|z| ≤ τ·min(a, b)` with `τ = 1/8` all three values come from the Taylor series
//! `g(x_r + s) = (k/2) Σ sⁿ [pⁿ⁺¹ + (−1)ⁿ qⁿ⁺¹]`, `p = 1/b`, `q = 1/a`, integrated term by term:
//! `ρ = (k/2) Σ Eₙ₊₁ zⁿ/(n+1)`, `V1 = (k/2) Σ Eₙ₊₁ zⁿ⁺²/(n+2)`, where the coefficient `E_m`
//! (`m = n + 1`) is `p^m + q^m` for even `n` and `D_m = p^m − q^m` for odd `n`. `D_m` is formed
//! without cancellation from
//! `D_1 = 2x_r·p·q`, `D_{m+1} = p D_m + q^m D_1`, so `∂ρ/∂z` keeps its accuracy even when
//! `x_r ≈ 0` (the θ axis of the paper's path). The error analysis that fixes `τ` and the
//! number of terms `N = 21`:
//!
//! * truncation: terms shrink by at least `τ` each, the first omitted one is
//!   `≤ 2τ^N/(N+1) ≈ 1e-20` of `ρ` and `≤ 2τ^{N−1} ≈ 2e-18` of the scale `(k/2)·max(p,q)²`
//!   of `∂ρ/∂z`; the sum stops earlier once the terms fall below `1e-17` of that scale (small
//!   `z`, the usual case, needs only a few terms);
//! * closed form just outside: `(g − ρ)/z` loses about `3/τ²·ε ≈ 200ε` relative to the scale of
//!   `∂ρ/∂z` in the worst (symmetric) case, `φ(u)` loses `≤ 2ε/τ`; `ρ` itself loses nothing.
//!
//! Measured at the switch over `x_r ∈ (−k, k)`: `ρ` agrees to 5e-16 relative and `∂ρ/∂z` to
//! 7e-15 of its scale (tested to 1e-12); at `z = 0` exactly `ρ = k²/((k − x_r)(k + x_r))`, the
//! limit (30).
//!
//! # Saturation (SPEC §3.3)
//!
//! The free functions ([`rho`], [`alpha`], [`alpha_dot`], [`v1`], [`barrier_gain`]) require
//! `|x_1| < k` and `|x_r| < k`; outside they return meaningless or non-finite values. The
//! controller uses [`IblfAxis::eval`] / [`Iblf::eval`], which never return NaN or ∞: `x_1` and
//! `x_r` are clamped to `±(1 − δ)k` (default margin `δ = ` [`DEFAULT_BARRIER_MARGIN`] `= 1e-6`,
//! where `g ≈ 5·10⁵`), the clamped variable is held (its time derivative is taken as 0, so `α̇`
//! stays the exact derivative of the saturated `α`), non-finite inputs are replaced by 0, and
//! the returned [`Saturation`] flags say what happened so the caller records an event.

use nalgebra::SVector;

use crate::error::{ModelError, positive};

/// Default barrier margin `δ`: saturated evaluation clamps `x_1`, `x_r` to `±(1 − δ)k_c`.
///
/// At the clamp `g(x_1) = 1/(δ(2 − δ)) ≈ 5·10⁵`: large, finite, and still pointing back inside.
pub const DEFAULT_BARRIER_MARGIN: f64 = 1e-6;

/// Series region: `|z| ≤ SERIES_RATIO · min(k + x_r, k − x_r)` (τ in the module docs).
const SERIES_RATIO: f64 = 0.125;
/// Number of series terms `N` (n = 0..N−1, N odd so the terms after n = 0 come in pairs); see
/// the module docs for the error analysis.
const SERIES_TERMS: usize = 21;
/// `INV[i] = 1/i` (`INV[0]` unused), computed at compile time.
const INV: [f64; SERIES_TERMS + 2] = {
    let mut t = [0.0; SERIES_TERMS + 2];
    let mut i = 1;
    while i < SERIES_TERMS + 2 {
        t[i] = 1.0 / i as f64;
        i += 1;
    }
    t
};
/// `NI[n] = n/(n+1)`.
const NI: [f64; SERIES_TERMS + 1] = {
    let mut t = [0.0; SERIES_TERMS + 1];
    let mut n = 1;
    while n <= SERIES_TERMS {
        t[n] = n as f64 / (n + 1) as f64;
        n += 1;
    }
    t
};

/// Barrier gain `g(x_1) = k²/(k² − x_1²)`, evaluated as `k²/((k − x_1)(k + x_1))`.
///
/// It is the weight in the control law (42) and in `V̇1` (32). Requires `|x_1| < k`.
#[inline]
pub fn barrier_gain(x1: f64, k: f64) -> f64 {
    k * k / ((k - x1) * (k + x1))
}

/// `ρ` of (29) with its partial derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RhoPartials {
    /// `ρ(z, x_r)`, dimensionless.
    pub rho: f64,
    /// `∂ρ/∂z`, 1/m.
    pub d_z: f64,
    /// `∂ρ/∂x_r`, 1/m.
    pub d_xr: f64,
}

/// `ρ(z, x_r)` of (29): the mean of `g` over `[x_r, x_r + z]`; `g(x_r)` exactly at `z = 0` (30).
///
/// Accurate to a few ulps for all `|x_r| < k`, `|x_r + z| < k` (series near `z = 0`, `log1p`
/// closed form elsewhere; see the module docs).
#[inline]
pub fn rho(z: f64, x_r: f64, k: f64) -> f64 {
    rho_core(z, x_r, k).rho
}

/// `ρ`, `∂ρ/∂z` and `∂ρ/∂x_r` at `(z, x_r)`; see [`rho`].
///
/// `∂ρ/∂z` is accurate to ~1e-14 of its natural scale `k/(k − |x_r|)²` (relative accuracy is
/// impossible only near its zero, where `g(x_1) = ρ`);
/// `∂ρ/∂x_r = k²(x_r + x_1)/((k² − x_r²)(k² − x_1²))` to a few ulps relative.
#[inline]
pub fn rho_partials(z: f64, x_r: f64, k: f64) -> RhoPartials {
    rho_core(z, x_r, k).partials()
}

/// iBLF value `V1` of (27) (one component, with `x_r` for `x_d`), in closed form:
/// `V1 = −(k²/2) ln((k² − x_1²)/(k² − x_r²)) − x_r z ρ`, evaluated as
/// `(k/2)[(k + x_r) φ(z/(k + x_r)) + (k − x_r) φ(−z/(k − x_r))]`, `φ(u) = u − ln(1 + u)`,
/// and by series near `z = 0`. Units m² (per unit of `g`, dimensionless).
#[inline]
pub fn v1(z: f64, x_r: f64, k: f64) -> f64 {
    let r = rho_core(z, x_r, k);
    if r.series {
        r.v1
    } else {
        let (a, b) = (k + x_r, k - x_r);
        0.5 * k * (a * phi(z / a) + b * phi(-z / b))
    }
}

/// Virtual control `α` of (31) with the SPEC §3.3 erratum (`x_1`, not `x_d`):
/// `α = −κ1 z + ρ(z, x_r) ẋ_r (k² − x_1²)/k²`, `z = x_1 − x_r`.
///
/// Units: m/s (or rad/s). Requires `|x_1| < k`, `|x_r| < k` (see [`IblfAxis`] otherwise).
#[inline]
pub fn alpha(x1: f64, x_r: f64, xr_dot: f64, kappa1: f64, k: f64) -> f64 {
    let z = x1 - x_r;
    let r = rho_core(z, x_r, k);
    let h = (k - x1) * (k + x1) / (k * k);
    -kappa1 * z + r.rho * xr_dot * h
}

/// Exact time derivative of [`alpha`] along `ẋ_1 = x_2`, by the chain rule:
///
/// `α̇ = −κ1 ż + ẍ_r ρ h + ẋ_r (ρ̇ h + ρ ḣ)`, with `ż = x_2 − ẋ_r`,
/// `ρ̇ = ∂ρ/∂z · ż + ∂ρ/∂x_r · ẋ_r`, `h = (k² − x_1²)/k²`, `ḣ = −2 x_1 x_2 / k²`.
///
/// Units: m/s² (or rad/s²). Requires `|x_1| < k`, `|x_r| < k`.
#[inline]
pub fn alpha_dot(
    x1: f64,
    x2: f64,
    x_r: f64,
    xr_dot: f64,
    xr_ddot: f64,
    kappa1: f64,
    k: f64,
) -> f64 {
    let (_, b_dot) = barrier_term(x1, x_r, xr_dot, xr_ddot, k, x2, xr_dot);
    -kappa1 * (x2 - xr_dot) + b_dot
}

/// The barrier feed-forward term of (31), `b = ρ ẋ_r h` with `h = (k² − x_1²)/k²`, and its
/// time derivative, when `x_1` moves at `x1_dot` and `x_r` at `xr_rate` inside ρ and `h`
/// (equal to `x_2`, `ẋ_r` normally; 0 for a clamped, held variable). `ẋ_r` and `ẍ_r` are the
/// raw multipliers.
#[inline]
fn barrier_term(
    x1: f64,
    x_r: f64,
    xr_dot: f64,
    xr_ddot: f64,
    k: f64,
    x1_dot: f64,
    xr_rate: f64,
) -> (f64, f64) {
    let r = rho_core(x1 - x_r, x_r, k);
    let kk = k * k;
    // h = 1/g(x1) = (k² − x1²)/k², ḣ = −2 x1 ẋ1 / k².
    let h = (k - x1) * (k + x1) / kk;
    let h_dot = -2.0 * x1 * x1_dot / kk;
    // ρ̇ = ∂ρ/∂z ż + ∂ρ/∂x_r ẋ_r along the (held) trajectory.
    let rho_dot = r.d_z * (x1_dot - xr_rate) + r.d_xr * xr_rate;
    let b = r.rho * xr_dot * h;
    let b_dot = xr_ddot * r.rho * h + xr_dot * (rho_dot * h + r.rho * h_dot);
    (b, b_dot)
}

/// Internal result of one ρ evaluation: value, partials, and `V1` when the series was used.
#[derive(Debug, Clone, Copy)]
struct RhoCore {
    rho: f64,
    d_z: f64,
    d_xr: f64,
    v1: f64,
    series: bool,
}

impl RhoCore {
    #[inline]
    fn partials(self) -> RhoPartials {
        RhoPartials {
            rho: self.rho,
            d_z: self.d_z,
            d_xr: self.d_xr,
        }
    }
}

/// `φ(u) = u − ln(1 + u)` (only called with `|u|` large enough, or on the other side of the
/// switch where its absolute error is negligible; see the module docs).
#[inline]
fn phi(u: f64) -> f64 {
    u - u.ln_1p()
}

/// ρ, ∂ρ/∂z, ∂ρ/∂x_r (and V1 in the series region) at `(z, x_r)`.
///
/// Everything is a function of `a = k + x_r`, `b = k − x_r` and `z` (`k ± x1` are formed as
/// `a + z`, `b − z`), so the series and the closed form see the same numbers.
#[inline]
fn rho_core(z: f64, x_r: f64, k: f64) -> RhoCore {
    let (a, b) = (k + x_r, k - x_r);
    let (c, d) = (a + z, b - z);
    // ∂ρ/∂x_r = k²(x_r + x1)/((k² − x_r²)(k² − x1²)) — sum of inputs, no cancellation.
    let d_xr = k * k * (2.0 * x_r + z) / ((a * b) * (c * d));
    if z.abs() <= SERIES_RATIO * a.min(b) {
        let (rho, d_z, v1) = series(z, x_r, k, a, b);
        RhoCore {
            rho,
            d_z,
            d_xr,
            v1,
            series: true,
        }
    } else {
        let (rho, d_z) = closed(z, k, a, b, c, d);
        RhoCore {
            rho,
            d_z,
            d_xr,
            v1: f64::NAN,
            series: false,
        }
    }
}

/// Closed forms of ρ and ∂ρ/∂z (`a = k + x_r`, `b = k − x_r`, `c = k + x1`, `d = k − x1`).
#[inline]
fn closed(z: f64, k: f64, a: f64, b: f64, c: f64, d: f64) -> (f64, f64) {
    // (29) as ρ = (k/(2z))[ln(1 + z/a) − ln(1 − z/b)]: opposite signs, no cancellation.
    let rho = 0.5 * k / z * ((z / a).ln_1p() - (-z / b).ln_1p());
    // ∂ρ/∂z = (g(x1) − ρ)/z.
    let g1 = k * k / (d * c);
    (rho, (g1 - rho) / z)
}

/// Taylor series of ρ, ∂ρ/∂z and V1 around `z = 0` (valid for `|z| ≤ τ min(a, b)`).
#[inline]
fn series(z: f64, x_r: f64, k: f64, a: f64, b: f64) -> (f64, f64, f64) {
    let (p, q) = (1.0 / b, 1.0 / a);
    // m = 1: D_1 = p − q = 2 x_r p q (exact form of 1/b − 1/a).
    let d1 = 2.0 * x_r * p * q;
    // State for n = 1 (m = n + 1 = 2): p^m, q^m, D_m = (p + q) D_1, z^(n−1).
    let mut st = Series {
        p,
        q,
        d1,
        z,
        d_m: (p + q) * d1,
        p_m: p * p,
        q_m: q * q,
        zp: 1.0,
        rho: 0.0,
        d_z: 0.0,
        v: 0.0,
    };
    // Stop once the next terms are below 1e-17 of the scale (k/2)(p² + q²) of ∂ρ/∂z (the
    // terms of ρ and V1 are then smaller still, relative to theirs).
    let stop = 1e-17 * (p * p + q * q);
    // Pairs (odd n: E = D_m; even n + 1: E = p^m + q^m), so no branch on the parity.
    let mut n = 1;
    while n < SERIES_TERMS {
        st.term(n, st.d_m);
        st.term(n + 1, st.p_m + st.q_m);
        n += 2;
        if (st.p_m + st.q_m) * st.zp.abs() <= stop {
            break;
        }
    }
    let half_k = 0.5 * k;
    // n = 0: (k/2)(p + q) = k²/(ab) = g(x_r), written exactly as in `barrier_gain`.
    let c0 = k * k / (b * a);
    let rho = c0 + half_k * st.rho;
    let d_z = half_k * st.d_z;
    let v1 = z * z * (0.5 * c0 + half_k * st.v);
    (rho, d_z, v1)
}

/// Running state of [`series`] (without the factor `k/2`).
struct Series {
    p: f64,
    q: f64,
    d1: f64,
    z: f64,
    /// `D_m`, `p^m`, `q^m` for `m = n + 1`, and `z^(n−1)`.
    d_m: f64,
    p_m: f64,
    q_m: f64,
    zp: f64,
    /// Partial sums of ρ, ∂ρ/∂z and V1/z² (terms n ≥ 1).
    rho: f64,
    d_z: f64,
    v: f64,
}

impl Series {
    /// Add term `n` with coefficient `e = E_{n+1}`, then advance `m`:
    /// `D_{m+1} = p D_m + q^m D_1`, `p^{m+1}`, `q^{m+1}`, `zⁿ`.
    #[inline(always)]
    fn term(&mut self, n: usize, e: f64) {
        // ∂ρ/∂z: n E z^(n−1)/(n+1); ρ: E zⁿ/(n+1); V1/z²: E zⁿ/(n+2).
        let ez = e * self.zp;
        self.d_z += ez * NI[n];
        let ez = ez * self.z;
        self.rho += ez * INV[n + 1];
        self.v += ez * INV[n + 2];
        self.d_m = self.p * self.d_m + self.q_m * self.d1;
        self.p_m *= self.p;
        self.q_m *= self.q;
        self.zp *= self.z;
    }
}

/// What the saturated evaluation had to do. All `false` is the normal case.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Saturation {
    /// `|x_1| > (1 − δ)k`: the output was clamped (a constraint-violation event).
    pub x1: bool,
    /// `|x_r| > (1 − δ)k`: the reference was clamped.
    pub x_r: bool,
    /// An input was NaN/∞, or an output overflowed; the offending value was replaced by 0.
    pub non_finite: bool,
}

impl Saturation {
    /// Whether anything was clamped or replaced.
    #[inline]
    pub fn any(&self) -> bool {
        self.x1 || self.x_r || self.non_finite
    }
}

/// Step-1 quantities for one component, from [`IblfAxis::eval`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisEval {
    /// `z_1 = x_1 − x_r` from the raw (unclamped) signals, m.
    pub z1: f64,
    /// `α` of (31), m/s.
    pub alpha: f64,
    /// `α̇`, the exact time derivative of the (saturated) `α`, m/s².
    pub alpha_dot: f64,
    /// `g(x_1) = k²/(k² − x_1²)` at the clamped `x_1`, dimensionless (≤ `1/(δ(2 − δ))`).
    pub gain: f64,
    /// What was clamped.
    pub saturation: Saturation,
}

/// One constrained component: bound `k_c`, gain `κ1`, barrier margin `δ`. Validated, immutable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IblfAxis {
    k_c: f64,
    kappa1: f64,
    margin: f64,
    /// `(1 − δ) k_c`.
    limit: f64,
}

impl IblfAxis {
    /// `k_c > 0`, `κ1 > 0`, default margin [`DEFAULT_BARRIER_MARGIN`].
    pub fn new(k_c: f64, kappa1: f64) -> Result<Self, ModelError> {
        Self::with_margin(k_c, kappa1, DEFAULT_BARRIER_MARGIN)
    }

    /// As [`IblfAxis::new`] with margin `δ ∈ [1e-12, 0.5]` (clamp at `±(1 − δ)k_c`; the lower
    /// limit keeps `k_c − |x_1|` far above rounding, so `g ≤ 5·10¹¹`).
    pub fn with_margin(k_c: f64, kappa1: f64, margin: f64) -> Result<Self, ModelError> {
        Self::named(k_c, kappa1, margin, "k_c", "kappa1")
    }

    fn named(
        k_c: f64,
        kappa1: f64,
        margin: f64,
        k_name: &str,
        kappa_name: &str,
    ) -> Result<Self, ModelError> {
        positive(k_name, k_c)?;
        positive(kappa_name, kappa1)?;
        if !((1e-12..=0.5).contains(&margin)) {
            return Err(ModelError::invalid(
                "barrier_margin",
                margin,
                "must be in [1e-12, 0.5]",
            ));
        }
        Ok(Self {
            k_c,
            kappa1,
            margin,
            limit: (1.0 - margin) * k_c,
        })
    }

    /// Bound `k_c`, m.
    pub fn k_c(&self) -> f64 {
        self.k_c
    }

    /// Gain `κ1`, 1/s.
    pub fn kappa1(&self) -> f64 {
        self.kappa1
    }

    /// Margin `δ`: the clamp is at `±(1 − δ)k_c`.
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// `z_1`, `α`, `α̇`, `g(x_1)` with barrier saturation; never NaN or ∞.
    ///
    /// `(x_1, x_2, x_r, ẋ_r, ẍ_r) → (z_1, α, α̇, g)`. Inside the margin this is exactly
    /// [`alpha`], [`alpha_dot`], [`barrier_gain`]. A clamped variable is held at the clamp
    /// (its rate counts as 0 inside ρ and `h`), so `α` stays continuous and `α̇` is its exact
    /// derivative; the `−κ1 z` term keeps the raw `z`.
    #[inline]
    pub fn eval(&self, x1: f64, x2: f64, x_r: f64, xr_dot: f64, xr_ddot: f64) -> AxisEval {
        let mut sat = Saturation::default();
        // NaN → 0; ±∞ is kept for x1, x_r (the clamp below maps it to the bound).
        let x1 = nan_to_zero(x1, &mut sat);
        let x_r = nan_to_zero(x_r, &mut sat);
        let x2 = finite_or_zero(x2, &mut sat);
        let xr_dot = finite_or_zero(xr_dot, &mut sat);
        let xr_ddot = finite_or_zero(xr_ddot, &mut sat);
        // Clamp to ±(1 − δ)k; a clamped variable is held (rate 0 inside ρ and h).
        let lim = self.limit;
        sat.x1 = x1.abs() > lim;
        sat.x_r = x_r.abs() > lim;
        let x1c = x1.clamp(-lim, lim);
        let xrc = x_r.clamp(-lim, lim);
        let x1c_dot = if sat.x1 { 0.0 } else { x2 };
        let xrc_dot = if sat.x_r { 0.0 } else { xr_dot };
        let (b, b_dot) = barrier_term(x1c, xrc, xr_dot, xr_ddot, self.k_c, x1c_dot, xrc_dot);
        // (31) with the raw z1 and ż1 = x2 − ẋ_r.
        let z1 = x1 - x_r;
        let alpha = -self.kappa1 * z1 + b;
        let alpha_dot = -self.kappa1 * (x2 - xr_dot) + b_dot;
        let gain = barrier_gain(x1c, self.k_c);
        AxisEval {
            z1: finite_or_zero(z1, &mut sat),
            alpha: finite_or_zero(alpha, &mut sat),
            alpha_dot: finite_or_zero(alpha_dot, &mut sat),
            gain,
            saturation: sat,
        }
    }
}

/// `v`, or 0 with the `non_finite` flag set if `v` is NaN.
#[inline]
fn nan_to_zero(v: f64, sat: &mut Saturation) -> f64 {
    if v.is_nan() {
        sat.non_finite = true;
        0.0
    } else {
        if v.is_infinite() {
            sat.non_finite = true;
        }
        v
    }
}

/// `v`, or 0 with the `non_finite` flag set if `v` is NaN or ±∞.
#[inline]
fn finite_or_zero(v: f64, sat: &mut Saturation) -> f64 {
    if v.is_finite() {
        v
    } else {
        sat.non_finite = true;
        0.0
    }
}

/// Step-1 quantities for `N` components, from [`Iblf::eval`]. `Copy`, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IblfEval<const N: usize> {
    /// `z_1 = x_1 − x_r` (raw), m / rad.
    pub z1: SVector<f64, N>,
    /// `α` of (31), m/s / rad/s.
    pub alpha: SVector<f64, N>,
    /// `α̇`, m/s² / rad/s².
    pub alpha_dot: SVector<f64, N>,
    /// `g(x_1)` per component (the barrier weight of (42)), dimensionless.
    pub gain: SVector<f64, N>,
    /// Per-component saturation flags.
    pub saturation: [Saturation; N],
}

impl<const N: usize> IblfEval<N> {
    /// Whether any component was clamped or sanitised.
    #[inline]
    pub fn any_saturated(&self) -> bool {
        self.saturation.iter().any(Saturation::any)
    }

    /// `z_2 = x_2 − α` (23).
    #[inline]
    pub fn z2(&self, x2: &SVector<f64, N>) -> SVector<f64, N> {
        x2 - self.alpha
    }
}

/// Step 1 of the backstepping for `N` components (3 for the object `(x, y, θ)`, 2 for a planar
/// end-effector). Validated, immutable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iblf<const N: usize> {
    axes: [IblfAxis; N],
}

/// The object scheme's three components `(x, y, θ)`.
pub type Iblf3 = Iblf<3>;

impl<const N: usize> Iblf<N> {
    /// Bounds `k_c` and gains `κ1` (all `> 0`), default barrier margin. Errors name
    /// `k_c[j]` / `kappa1[j]`.
    pub fn new(k_c: SVector<f64, N>, kappa1: SVector<f64, N>) -> Result<Self, ModelError> {
        Self::with_margin(k_c, kappa1, DEFAULT_BARRIER_MARGIN)
    }

    /// As [`Iblf::new`] with a barrier margin `δ ∈ [1e-12, 0.5]`.
    pub fn with_margin(
        k_c: SVector<f64, N>,
        kappa1: SVector<f64, N>,
        margin: f64,
    ) -> Result<Self, ModelError> {
        let mut axes = [IblfAxis {
            k_c: 1.0,
            kappa1: 1.0,
            margin,
            limit: 1.0,
        }; N];
        for (j, axis) in axes.iter_mut().enumerate() {
            *axis = IblfAxis::named(
                k_c[j],
                kappa1[j],
                margin,
                &format!("k_c[{j}]"),
                &format!("kappa1[{j}]"),
            )?;
        }
        Ok(Self { axes })
    }

    /// Per-component parameters.
    pub fn axes(&self) -> &[IblfAxis; N] {
        &self.axes
    }

    /// `(x_1, x_2, x_r, ẋ_r, ẍ_r) → (z_1, α, α̇, g(x_1), flags)` per component, with barrier
    /// saturation; see [`IblfAxis::eval`]. No allocation.
    #[inline]
    pub fn eval(
        &self,
        x1: &SVector<f64, N>,
        x2: &SVector<f64, N>,
        x_r: &SVector<f64, N>,
        xr_dot: &SVector<f64, N>,
        xr_ddot: &SVector<f64, N>,
    ) -> IblfEval<N> {
        let mut out = IblfEval {
            z1: SVector::zeros(),
            alpha: SVector::zeros(),
            alpha_dot: SVector::zeros(),
            gain: SVector::zeros(),
            saturation: [Saturation::default(); N],
        };
        for (j, axis) in self.axes.iter().enumerate() {
            let e = axis.eval(x1[j], x2[j], x_r[j], xr_dot[j], xr_ddot[j]);
            out.z1[j] = e.z1;
            out.alpha[j] = e.alpha;
            out.alpha_dot[j] = e.alpha_dot;
            out.gain[j] = e.gain;
            out.saturation[j] = e.saturation;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    // ---- reference tools ----------------------------------------------------------------

    /// Neumaier-compensated sum.
    #[derive(Default)]
    struct Sum {
        s: f64,
        c: f64,
    }
    impl Sum {
        fn add(&mut self, x: f64) {
            let t = self.s + x;
            if self.s.abs() >= x.abs() {
                self.c += (self.s - t) + x;
            } else {
                self.c += (x - t) + self.s;
            }
            self.s = t;
        }
        fn value(&self) -> f64 {
            self.s + self.c
        }
    }

    /// 5-point Gauss–Legendre on [lo, hi] (nodes and weights from their closed forms).
    fn gl5(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
        let r = (10.0f64 / 7.0).sqrt();
        let x1 = (5.0 - 2.0 * r).sqrt() / 3.0;
        let x2 = (5.0 + 2.0 * r).sqrt() / 3.0;
        let s70 = 70.0f64.sqrt();
        let w0 = 128.0 / 225.0;
        let w1 = (322.0 + 13.0 * s70) / 900.0;
        let w2 = (322.0 - 13.0 * s70) / 900.0;
        let (m, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        h * (w0 * f(m)
            + w1 * (f(m - h * x1) + f(m + h * x1))
            + w2 * (f(m - h * x2) + f(m + h * x2)))
    }

    /// Adaptive Gauss–Legendre with compensated accumulation of the accepted panels.
    fn quad(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, rtol: f64) -> f64 {
        fn rec(
            f: &dyn Fn(f64) -> f64,
            lo: f64,
            hi: f64,
            whole: f64,
            tol: f64,
            depth: u32,
            acc: &mut Sum,
        ) {
            let mid = 0.5 * (lo + hi);
            let (l, r) = (gl5(f, lo, mid), gl5(f, mid, hi));
            // GL5 is 10th order: the error of l + r is about |l + r − whole|/1024. Stop at
            // the tolerance or at the rounding floor, whichever is larger.
            let diff = (l + r - whole).abs();
            if depth > 50 || diff <= tol.max(64.0 * f64::EPSILON * (l.abs() + r.abs())) {
                acc.add(l);
                acc.add(r);
            } else {
                rec(f, lo, mid, l, 0.5 * tol, depth + 1, acc);
                rec(f, mid, hi, r, 0.5 * tol, depth + 1, acc);
            }
        }
        let whole = gl5(f, lo, hi);
        let mut acc = Sum::default();
        rec(
            f,
            lo,
            hi,
            whole,
            rtol * whole.abs().max(1e-300),
            0,
            &mut acc,
        );
        acc.value()
    }

    /// ρ as the mean of g over [x_r, x_r + z], by quadrature in s with k − x = b − s.
    fn rho_quad(z: f64, x_r: f64, k: f64) -> f64 {
        let (a, b) = (k + x_r, k - x_r);
        let g = |s: f64| k * k / ((b - s) * (a + s));
        quad(&g, 0.0, z, 1e-13) / z
    }

    /// V1 = ∫_0^z σ g(x_r + σ) dσ by quadrature.
    fn v1_quad(z: f64, x_r: f64, k: f64) -> f64 {
        let (a, b) = (k + x_r, k - x_r);
        let f = |s: f64| s * k * k / ((b - s) * (a + s));
        quad(&f, 0.0, z, 1e-13)
    }

    /// Fourth-order central difference of f at t with step h.
    fn d4(f: &dyn Fn(f64) -> f64, t: f64, h: f64) -> f64 {
        (f(t - 2.0 * h) - 8.0 * f(t - h) + 8.0 * f(t + h) - f(t + 2.0 * h)) / (12.0 * h)
    }

    /// A smooth test signal: c + a sin(ω t + φ), with its first two derivatives.
    #[derive(Debug, Clone, Copy)]
    struct Sine {
        c: f64,
        a: f64,
        w: f64,
        p: f64,
    }
    impl Sine {
        fn x(&self, t: f64) -> f64 {
            self.c + self.a * (self.w * t + self.p).sin()
        }
        fn v(&self, t: f64) -> f64 {
            self.a * self.w * (self.w * t + self.p).cos()
        }
        fn acc(&self, t: f64) -> f64 {
            -self.a * self.w * self.w * (self.w * t + self.p).sin()
        }
    }

    /// Bound k, reference x_r(t), error z(t) (x1 = x_r + z): |x_r| ≤ 0.8k, |z| ≤ 0.15k.
    fn traj() -> impl Strategy<Value = (f64, Sine, Sine)> {
        (
            0.05f64..2.0,
            -0.4f64..0.4,
            0.0f64..0.4,
            0.1f64..3.0,
            0.0f64..6.3,
            0.0f64..0.15,
            0.1f64..5.0,
            0.0f64..6.3,
        )
            .prop_map(|(k, c, a, w, p, az, wz, pz)| {
                let r = Sine {
                    c: c * k,
                    a: a * k,
                    w,
                    p,
                };
                let e = Sine {
                    c: 0.0,
                    a: az * k,
                    w: wz,
                    p: pz,
                };
                (k, r, e)
            })
    }

    fn grid_xr_x1(k: f64) -> Vec<(f64, f64)> {
        let fr = [-0.95, -0.7, -0.3, -1e-9, 0.0, 1e-7, 0.2, 0.5, 0.9];
        let f1 = [
            -0.999, -0.9, -0.5, -0.1, -1e-3, 0.0, 1e-6, 0.05, 0.3, 0.7, 0.97, 0.999,
        ];
        let mut v = Vec::new();
        for &r in &fr {
            for &o in &f1 {
                v.push((r * k, o * k));
            }
        }
        v
    }

    // ---- ρ ------------------------------------------------------------------------------

    #[test]
    fn rho_at_zero_is_the_limit_30_exactly() {
        for k in [0.35, 1.0, 7.5] {
            for f in [-0.99, -0.5, -0.1, 0.0, 0.123, 0.6, 0.9999] {
                let x_r = f * k;
                assert_eq!(rho(0.0, x_r, k), barrier_gain(x_r, k));
                assert_eq!(rho(-0.0, x_r, k), barrier_gain(x_r, k));
                let p = rho_partials(0.0, x_r, k);
                // ∂ρ/∂z(0) = g'(x_r)/2, ∂ρ/∂x_r(0) = g'(x_r), g' = 2k²x/(k² − x²)².
                let ab = (k - x_r) * (k + x_r);
                let gp = 2.0 * k * k * x_r / (ab * ab);
                assert!((p.d_z - 0.5 * gp).abs() <= 1e-14 * (1.0 + gp.abs()));
                assert!((p.d_xr - gp).abs() <= 1e-14 * (1.0 + gp.abs()));
            }
        }
    }

    #[test]
    fn rho_tiny_z_matches_the_limit() {
        let k = 0.35;
        for f in [-0.9, -0.2, 0.0, 0.4, 0.95] {
            let x_r = f * k;
            let g = barrier_gain(x_r, k);
            let ab = (k - x_r) * (k + x_r);
            let gp = 2.0 * k * k * x_r / (ab * ab);
            // To first order ρ = g + g' z/2; the next term, g'' z²/6, is below 1e-16 here.
            for z in [1e-300, -1e-200, 1e-16, -1e-12] {
                let r = rho(z, x_r, k);
                let want = g + 0.5 * gp * z;
                assert!(
                    ((r - want) / g).abs() <= 2.0 * f64::EPSILON,
                    "{z} {x_r} {r} {want}"
                );
            }
        }
    }

    #[test]
    fn series_and_closed_form_agree_at_the_switch() {
        let mut worst_rho = 0.0f64;
        let mut worst_dz = 0.0f64;
        for k in [0.35, 1.0, 3.0] {
            for i in 0..=200 {
                let x_r = (-0.999 + 1.998 * i as f64 / 200.0) * k;
                let (a, b) = (k + x_r, k - x_r);
                for sign in [1.0, -1.0] {
                    let z = sign * SERIES_RATIO * a.min(b);
                    let (rs, dzs, _) = series(z, x_r, k, a, b);
                    let (rc, dzc) = closed(z, k, a, b, a + z, b - z);
                    worst_rho = worst_rho.max(((rs - rc) / rc).abs());
                    // ∂ρ/∂z relative to its natural scale (k/2)·max(p, q)².
                    let scale = 0.5 * k / (a.min(b) * a.min(b));
                    let d = ((dzs - dzc) / scale).abs();
                    worst_dz = worst_dz.max(d);
                }
            }
        }
        eprintln!("switch point: rho rel diff {worst_rho:.2e}, d_z scaled diff {worst_dz:.2e}");
        assert!(worst_rho <= 1e-12);
        assert!(worst_dz <= 1e-12);
    }

    #[test]
    fn rho_matches_quadrature_of_the_mean_of_g() {
        let mut worst = 0.0f64;
        for k in [0.35, 1.0] {
            for (x_r, x1) in grid_xr_x1(k) {
                let z = x1 - x_r;
                if z == 0.0 {
                    continue;
                }
                let want = rho_quad(z, x_r, k);
                let got = rho(z, x_r, k);
                // The reference itself is ill-conditioned near the pole: allow for it.
                let cond = 1.0 + k / (k - x1.abs()).min(k - x_r.abs());
                let rel = ((got - want) / want).abs();
                worst = worst.max(rel / cond);
                assert!(
                    rel <= 1e-14 * cond,
                    "x_r {x_r} x1 {x1}: {got} vs {want} ({rel:e})"
                );
            }
        }
        eprintln!("rho vs quadrature: worst rel/cond {worst:.2e}");
    }

    #[test]
    fn rho_matches_the_papers_formula_29_away_from_zero() {
        let k = 0.35;
        for (x_r, x1) in grid_xr_x1(k) {
            let z = x1 - x_r;
            if z.abs() < 0.01 * k {
                continue;
            }
            let lit = k / (2.0 * z) * ((k + x1) * (k - x_r) / ((k - x1) * (k + x_r))).ln();
            let got = rho(z, x_r, k);
            assert!(((got - lit) / lit).abs() <= 1e-12, "{x_r} {x1}");
        }
    }

    proptest! {
        #[test]
        fn rho_partials_match_finite_differences(
            k in 0.05f64..3.0,
            fr in -0.9f64..0.9,
            f1 in -0.9f64..0.9,
        ) {
            let (x_r, x1) = (fr * k, f1 * k);
            let z = x1 - x_r;
            let p = rho_partials(z, x_r, k);
            let h = 1e-3 * k;
            let fd_z = d4(&|zz| rho(zz, x_r, k), z, h);
            let fd_r = d4(&|rr| rho(z, rr, k), x_r, h);
            // Scale: (k/2)/min(k − |x|)² bounds both partials' natural size.
            let m = (k - x_r.abs()).min(k - x1.abs());
            let scale = 0.5 * k / (m * m);
            prop_assert!((p.d_z - fd_z).abs() <= 1e-7 * scale, "{} {}", p.d_z, fd_z);
            prop_assert!((p.d_xr - fd_r).abs() <= 1e-7 * scale, "{} {}", p.d_xr, fd_r);
        }
    }

    // ---- α, α̇ ---------------------------------------------------------------------------

    /// α̇ against a 4th-order central difference of α along a smooth trajectory.
    ///
    /// Tolerance: with h = 1e-3 s and frequencies ≤ 5 rad/s the truncation error is
    /// h⁴|α⁽⁵⁾|/30 ≲ 1e-12·5⁵ ≈ 3e-9 of the scale and the rounding error ≈ 1.5ε|α|/h ≈ 3e-13·|α|;
    /// 1e-6 of the term scale (sum of the magnitudes of α̇'s terms) leaves a wide margin.
    fn check_alpha_dot(k: f64, r: Sine, e: Sine, kappa1: f64, t: f64) -> Result<(), TestCaseError> {
        let x_r = |t: f64| r.x(t);
        let x1 = |t: f64| r.x(t) + e.x(t);
        let a_of_t = |t: f64| alpha(x1(t), x_r(t), r.v(t), kappa1, k);
        let fd = d4(&a_of_t, t, 1e-3);
        let x2 = r.v(t) + e.v(t);
        let exact = alpha_dot(x1(t), x2, x_r(t), r.v(t), r.acc(t), kappa1, k);
        let g = barrier_gain(x1(t), k);
        let rp = rho_partials(x1(t) - x_r(t), x_r(t), k);
        let scale = kappa1 * e.v(t).abs()
            + (r.acc(t) * rp.rho / g).abs()
            + r.v(t).abs() * (rp.d_z * e.v(t) + rp.d_xr * r.v(t)).abs() / g
            + r.v(t).abs() * rp.rho * 2.0 * (x1(t) * x2).abs() / (k * k)
            + 1e-12;
        prop_assert!(
            (fd - exact).abs() <= 1e-6 * scale,
            "fd {fd} exact {exact} scale {scale}"
        );
        Ok(())
    }

    proptest! {
        #[test]
        fn alpha_dot_matches_finite_differences(
            (k, r, e) in traj(),
            kappa1 in 0.1f64..30.0,
            t in 0.0f64..10.0,
        ) {
            check_alpha_dot(k, r, e, kappa1, t)?;
        }
    }

    /// The paper's object path (x_r = 0.2 cos 0.1t, 0.2 sin 0.1t, 0; k = 0.35, κ1 = (15, 20, 15))
    /// with a decaying start error, reporting the worst error of α̇ against the difference.
    #[test]
    fn alpha_dot_on_the_paper_path() {
        let k = 0.35;
        let mut worst = 0.0f64;
        for (axis, kappa1) in [(0usize, 15.0), (1, 20.0), (2, 15.0)] {
            let r = |t: f64| match axis {
                0 => (
                    0.2 * (0.1 * t).cos(),
                    -0.02 * (0.1 * t).sin(),
                    -0.002 * (0.1 * t).cos(),
                ),
                1 => (
                    0.2 * (0.1 * t).sin(),
                    0.02 * (0.1 * t).cos(),
                    -0.002 * (0.1 * t).sin(),
                ),
                _ => (0.0, 0.0, 0.0),
            };
            // z(t) = 0.01 e^{−3t} cos(5t) + 1e-4 sin(7t).
            let e = |t: f64| {
                let d = (-3.0 * t).exp();
                (
                    0.01 * d * (5.0 * t).cos() + 1e-4 * (7.0 * t).sin(),
                    0.01 * d * (-3.0 * (5.0 * t).cos() - 5.0 * (5.0 * t).sin())
                        + 7e-4 * (7.0 * t).cos(),
                )
            };
            for i in 0..400 {
                let t = 0.01 * i as f64;
                let a = |t: f64| alpha(r(t).0 + e(t).0, r(t).0, r(t).1, kappa1, k);
                let fd = d4(&a, t, 1e-3);
                let (x_r, v, acc) = r(t);
                let exact = alpha_dot(x_r + e(t).0, v + e(t).1, x_r, v, acc, kappa1, k);
                let rel = (fd - exact).abs() / (exact.abs() + kappa1 * e(t).1.abs() + 1e-9);
                worst = worst.max(rel);
            }
        }
        eprintln!("alpha_dot vs 4th-order difference on the paper path: worst rel {worst:.1e}");
        assert!(worst <= 1e-6);
    }

    #[test]
    fn alpha_uses_x1_in_the_barrier_factor() {
        // SPEC §3.3 erratum: (k² − x1²), not (k² − x_r²).
        let (k, x_r, x1, v, kap) = (0.35, 0.1, 0.2, 0.3, 5.0);
        let z = x1 - x_r;
        let want = -kap * z + rho(z, x_r, k) * v * (k * k - x1 * x1) / (k * k);
        assert!((alpha(x1, x_r, v, kap, k) - want).abs() <= 1e-15);
    }

    // ---- V1 -----------------------------------------------------------------------------

    #[test]
    fn v1_matches_quadrature_and_the_log_form() {
        let mut worst = 0.0f64;
        for k in [0.35, 1.0] {
            for (x_r, x1) in grid_xr_x1(k) {
                let z = x1 - x_r;
                let got = v1(z, x_r, k);
                if z == 0.0 {
                    assert_eq!(got, 0.0);
                    continue;
                }
                let want = v1_quad(z, x_r, k);
                let cond = 1.0 + k / (k - x1.abs()).min(k - x_r.abs());
                let rel = ((got - want) / want).abs();
                worst = worst.max(rel / cond);
                assert!(rel <= 1e-14 * cond, "x_r {x_r} x1 {x1}: {got} vs {want}");
                // The brief's form cancels for small z; check it where it does not.
                if z.abs() > 0.05 * k {
                    let log_form = -0.5 * k * k * ((k * k - x1 * x1) / (k * k - x_r * x_r)).ln()
                        - x_r * z * rho(z, x_r, k);
                    assert!(((log_form - got) / got).abs() <= 1e-10);
                }
                // z²/2 < V1 (25), since g ≥ 1.
                assert!(got > 0.5 * z * z * (1.0 - 1e-15));
            }
        }
        eprintln!("V1 vs quadrature: worst rel/cond {worst:.2e}");
    }

    #[test]
    fn v1_series_and_closed_form_agree_at_the_switch() {
        let k = 0.35;
        for i in 0..=100 {
            let x_r = (-0.99 + 1.98 * i as f64 / 100.0) * k;
            let (a, b) = (k + x_r, k - x_r);
            for sign in [1.0, -1.0] {
                let z = sign * SERIES_RATIO * a.min(b);
                let (_, _, vs) = series(z, x_r, k, a, b);
                let vc = 0.5 * k * (a * phi(z / a) + b * phi(-z / b));
                assert!(((vs - vc) / vc).abs() <= 1e-13, "{x_r}: {vs} {vc}");
            }
        }
    }

    proptest! {
        /// Along smooth x_r(t), x1(t): V̇1 by finite differences equals (32) with the x1
        /// erratum, and ∂V1/∂z = z g(x1), ∂V1/∂x_r = z (g(x1) − ρ).
        #[test]
        fn v1_derivative_is_32(
            (k, r, e) in traj(),
            kappa1 in 0.1f64..30.0,
            t in 0.0f64..10.0,
        ) {
            let x_r = r.x(t);
            let z = e.x(t);
            let x1 = x_r + z;
            let x2 = r.v(t) + e.v(t);
            let g = barrier_gain(x1, k);
            let rh = rho(z, x_r, k);
            // Partials.
            let h = 1e-4 * k;
            let dz = d4(&|zz| v1(zz, x_r, k), z, h);
            let dr = d4(&|rr| v1(z, rr, k), x_r, h);
            let m = (k - x_r.abs()).min(k - x1.abs());
            let scale = k * k / m;
            prop_assert!((dz - z * g).abs() <= 1e-8 * scale, "{dz} {}", z * g);
            prop_assert!((dr - z * (g - rh)).abs() <= 1e-8 * scale, "{dr} {}", z * (g - rh));
            // Time derivative along the trajectory vs (32).
            let v_of_t = |t: f64| v1(e.x(t), r.x(t), k);
            let fd = d4(&v_of_t, t, 1e-3);
            let a = alpha(x1, x_r, r.v(t), kappa1, k);
            let z2 = x2 - a;
            let v32 = -kappa1 * g * z * z + g * z * z2;
            let scale = g * z.abs() * (kappa1 * z.abs() + z2.abs()) + 1e-15;
            prop_assert!((fd - v32).abs() <= 1e-6 * scale, "fd {fd} (32) {v32}");
        }
    }

    // ---- saturation ---------------------------------------------------------------------

    #[test]
    fn eval_inside_the_margin_is_the_free_functions() {
        let ax = IblfAxis::new(0.35, 15.0).unwrap();
        let (x1, x2, x_r, v, acc) = (0.19, -0.02, 0.2, 0.01, -0.002);
        let e = ax.eval(x1, x2, x_r, v, acc);
        assert_eq!(e.saturation, Saturation::default());
        assert_eq!(e.z1, x1 - x_r);
        assert_eq!(e.alpha, alpha(x1, x_r, v, 15.0, 0.35));
        assert_eq!(e.alpha_dot, alpha_dot(x1, x2, x_r, v, acc, 15.0, 0.35));
        assert_eq!(e.gain, barrier_gain(x1, 0.35));
    }

    #[test]
    fn saturated_alpha_dot_is_the_derivative_of_saturated_alpha() {
        // x1 beyond the (coarse) clamp for the whole window: held at the clamp.
        let ax = IblfAxis::with_margin(1.0, 3.0, 0.1).unwrap();
        let r = Sine {
            c: 0.2,
            a: 0.3,
            w: 1.3,
            p: 0.4,
        };
        let e = Sine {
            c: 1.2,
            a: 0.05,
            w: 2.0,
            p: 1.0,
        };
        for i in 0..50 {
            let t = 0.1 * i as f64;
            let ev = |t: f64| ax.eval(r.x(t) + e.x(t), r.v(t) + e.v(t), r.x(t), r.v(t), r.acc(t));
            let now = ev(t);
            assert!(now.saturation.x1 && !now.saturation.x_r);
            let fd = d4(&|t| ev(t).alpha, t, 1e-4);
            assert!((fd - now.alpha_dot).abs() <= 1e-7 * (1.0 + now.alpha_dot.abs()));
            assert_eq!(now.gain, barrier_gain(0.9, 1.0));
        }
    }

    fn wild() -> impl Strategy<Value = f64> {
        prop_oneof![
            -2.0f64..2.0,
            -1e6f64..1e6,
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(f64::MAX),
            Just(-f64::MAX),
            Just(0.35),
            Just(-0.35),
            Just(0.35 * (1.0 - DEFAULT_BARRIER_MARGIN)),
        ]
    }

    proptest! {
        #[test]
        fn saturation_never_yields_nan(
            x1 in wild(), x2 in wild(), x_r in wild(), v in wild(), acc in wild(),
        ) {
            let ax = IblfAxis::new(0.35, 15.0).unwrap();
            let e = ax.eval(x1, x2, x_r, v, acc);
            prop_assert!(e.z1.is_finite() && e.alpha.is_finite() && e.alpha_dot.is_finite());
            prop_assert!(e.gain.is_finite() && e.gain >= 1.0);
            prop_assert!(e.gain <= 1.0 / (DEFAULT_BARRIER_MARGIN * (2.0 - DEFAULT_BARRIER_MARGIN)) * 1.000001);
            let lim = 0.35 * (1.0 - DEFAULT_BARRIER_MARGIN);
            if x1.is_finite() {
                prop_assert_eq!(e.saturation.x1, x1.abs() > lim);
            }
            if x_r.is_finite() {
                prop_assert_eq!(e.saturation.x_r, x_r.abs() > lim);
            }
            let all_finite = [x1, x2, x_r, v, acc].iter().all(|x| x.is_finite());
            if !all_finite {
                prop_assert!(e.saturation.non_finite);
            }
        }
    }

    // ---- vector form --------------------------------------------------------------------

    #[test]
    fn vector_form_equals_the_scalar_axes() {
        let k_c = Vector3::new(0.35, 0.35, 0.35);
        let k1 = Vector3::new(15.0, 20.0, 15.0);
        let ib = Iblf3::new(k_c, k1).unwrap();
        let x1 = Vector3::new(0.19, 0.4, -0.01);
        let x2 = Vector3::new(0.0, 0.1, -0.2);
        let xr = Vector3::new(0.2, 0.0, 0.0);
        let vr = Vector3::new(0.0, 0.02, 0.0);
        let ar = Vector3::new(-0.002, 0.0, 0.0);
        let out = ib.eval(&x1, &x2, &xr, &vr, &ar);
        for j in 0..3 {
            let e = IblfAxis::new(k_c[j], k1[j])
                .unwrap()
                .eval(x1[j], x2[j], xr[j], vr[j], ar[j]);
            assert_eq!(out.z1[j], e.z1);
            assert_eq!(out.alpha[j], e.alpha);
            assert_eq!(out.alpha_dot[j], e.alpha_dot);
            assert_eq!(out.gain[j], e.gain);
            assert_eq!(out.saturation[j], e.saturation);
        }
        assert!(out.saturation[1].x1 && out.any_saturated());
        assert_eq!(out.z2(&x2), x2 - out.alpha);
    }

    #[test]
    fn validation_names_the_component() {
        let e = Iblf3::new(Vector3::new(0.35, 0.0, 0.35), Vector3::repeat(1.0)).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "k_c[1]"));
        let e = Iblf3::new(Vector3::repeat(0.35), Vector3::new(1.0, 1.0, -1.0)).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "kappa1[2]"));
        assert!(IblfAxis::with_margin(1.0, 1.0, 0.0).is_err());
        assert!(IblfAxis::with_margin(1.0, 1.0, 1e-13).is_err());
        assert!(IblfAxis::with_margin(1.0, 1.0, 0.6).is_err());
        assert!(IblfAxis::with_margin(1.0, 1.0, f64::NAN).is_err());
    }
}
