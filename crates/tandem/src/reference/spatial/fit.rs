//! The object-level reference pose (SPEC-spatial S5 "Admittance", SPEC §3.1): the pose that best
//! fits the arms' reference tool poses through the grasps, with its exact twist and twist rate.
//!
//! Arm `i`'s admittance generator gives a reference tool pose `X_WTi` (frame `T_i`, welded to the
//! grasp frame `G_i` of the object, `X_OGi` fixed) with twist `[v_Ti; ω_Ti]` and twist rate. Each
//! one is a full object pose candidate `X_WO,i = X_WTi X_OGi⁻¹` ([`candidate`]). With weights
//! `ŵ_i ≥ 0`, `Σ ŵ_i = 1` (equal by default) the fit is:
//!
//! **Orientation: the normalised hemisphere-aligned quaternion mean.**
//!
//! $$ s = \sum_i \hat w_i\,\sigma_i\, q_i,\qquad \bar q = s/|s|,\qquad
//!   q_i = q_{WTi} \otimes q_{OGi}^{-1},\quad \sigma_i = \operatorname{sign}(q_i\cdot q_{hint}), $$
//!
//! the unit `q` minimising `Σ ŵ_i |q − σ_i q_i|²` (expand: `= 2 − 2 q·s`), i.e. the weighted
//! L2 mean in the quaternion metric `|q − q_i| = 2 sin(θ_i/4)` (`θ_i` the angle from `q̄` to
//! candidate `i`). It agrees with the chordal (Frobenius, eigenvector) and the geodesic
//! (Karcher) means to second order in the candidates' spread, and for two equally weighted
//! candidates it is exactly the midpoint of the geodesic between them (a normalised sum of two
//! unit quaternions is their slerp midpoint). `q_hint` (the previous fit, or the desired
//! orientation) only picks the signs: it must not depend on the grasps' labels.
//!
//! **Position: least squares over the grasp points, given `R̄`.**
//!
//! $$ \bar p = \arg\min_p \sum_i \hat w_i\,|p + \bar R\, p_{OGi} - p_{WTi}|^2 =
//! \bar p_T - \bar R\,\bar r,\qquad
//!   \bar p_T = \sum_i \hat w_i\, p_{WTi},\quad \bar r = \sum_i \hat w_i\, p_{OGi}, $$
//!
//! the translation step of a Procrustes fit (as the planar [`grasp::fit_pose`]: `p = x̄ − R r̄`).
//! With two symmetric grasps it is the midpoint of the tool points, so a symmetric squeeze
//! cancels, as SPEC §3.1 asks.
//!
//! **Why not Procrustes/Kabsch on the points for the rotation:** two grasp points (the spatial
//! scenario's) leave the rotation about the line through them undetermined, and the points
//! ignore the rotational admittance of each arm. The tool references carry full orientations;
//! a quaternion mean of the candidates is defined for any number of grasps ≥ 1. **Why not the
//! chordal eigenvector or the Karcher mean:** their rates need the derivative of an eigenvector
//! or of an iteration; the normalised sum has closed-form first and second derivatives:
//!
//! **Exact rates.** With `q̇_i = ½ ω_Ti ⊗ q_i` (world axes, the grasp is fixed) and
//! `q̈_i = ½ ω̇_Ti ⊗ q_i − ¼ |ω_Ti|² q_i`, `ṡ`, `s̈` are the weighted sums; `n = |s|`,
//! `ṅ = q̄·ṡ`, `n̈ = q̄̇·ṡ + q̄·s̈`;
//!
//! $$ \dot{\bar q} = (\dot s - \bar q\,\dot n)/n,\qquad
//!    \ddot{\bar q} = (\ddot s - 2\dot{\bar q}\,\dot n - \bar q\,\ddot n)/n, $$
//! $$ \bar\omega = 2\operatorname{vec}(\dot{\bar q}\otimes\bar q^*),\qquad
//!    \dot{\bar\omega} = 2\operatorname{vec}(\ddot{\bar q}\otimes\bar q^*) $$
//!
//! (the term `q̄̇ ⊗ q̄̇*` is real). With `ρ = R̄ r̄` (`ρ̇ = ω̄ × ρ`):
//! `v̄ = Σ ŵ_i v_Ti − ω̄ × ρ`, `v̄̇ = Σ ŵ_i v̇_Ti − ω̄̇ × ρ − ω̄ × (ω̄ × ρ)`.
//!
//! **Consistent candidates** (all from one object pose through exact grasps, the rigid case):
//! `q_i = q`, so `s = ±q`, `q̄ = ±q`, `q̄̇ = ±q̇` (`q·q̇ = 0`), `ω̄ = ω`; `p̄_T = p + R r̄`, so
//! `p̄ = p`, and the rates follow: the fit returns the pose, twist and twist rate to round-off.
//!
//! **Invariances.** Relabelling grasps permutes the sums (invariant to round-off). A change of
//! world frame `X_W'W` applied to the tool references and the hint maps the fit by the same
//! transform (`s ↦ q_W'W ⊗ s`, `p̄ ↦ X_W'W p̄`, twists rotated).
//!
//! **Conditions.** The signs `σ_i` take each candidate the short way from the hint (always
//! possible: a rotation angle is ≤ π). While every candidate is within 90° (rotation angle)
//! of the hint, the aligned quaternions are within 45° of the hint in ℝ⁴, hence within 90° of
//! each other (`σ_i q_i · σ_j q_j ≥ 0`): the signs are those of the candidates' mutual shortest
//! arcs, constant along a motion, and the fit is smooth. Candidates farther apart still give a
//! well-defined, finite fit, but one that depends on the hint; a candidate crossing 180° from
//! the hint flips its sign and the fit jumps there (the rates are exact wherever the signs are
//! constant). [`Fit::spread`] (the largest angle from `q̄` to a sign-aligned candidate) shows
//! how close that is: > π/2 means the candidates disagree by more than any sane admittance
//! offset (SPEC's are millimetres and degrees). If the aligned quaternions
//! nearly cancel (`|s| < 1e-6`, [`Fit::degenerate`]) the rotation is `s/|s|` (or the hint if
//! `s = 0`) and the rates are computed with `n = max(|s|, 1e-6)`: finite, not exact. Weights
//! that are negative or not finite count as 0; if they sum to 0, equal weights are used. No
//! grasp at all (empty slices) returns the hint at rest, degenerate. Never NaN for finite input.
//!
//! **No maximum number of grasps:** the fit is a streaming sum over the caller's slices
//! (`n = min(x_og.len(), tools.len())`); nothing is stored, nothing allocated.
//!
//! [`grasp::fit_pose`]: crate::model::planar::grasp::fit_pose

use nalgebra::{Isometry3, Quaternion, UnitQuaternion, Vector3};

use super::sample::{PoseSample, pure};
use crate::geometry::motion::stack;

/// Below this `|s|` (weights normalised to sum 1, so `|s| ≤ 1`) the fit is flagged degenerate.
pub const DEGENERATE_NORM: f64 = 1e-6;

/// The fitted object reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// `X_WO,r` with its twist and twist rate (world axes, at the object origin). The
    /// quaternion is on the hint's side (`q̄ · q_hint ≥ 0`), not necessarily `w ≥ 0`: it is
    /// continuous along a run whose hint is.
    pub sample: PoseSample,
    /// Largest angle from the fitted orientation to a sign-aligned candidate, rad (`≤ π` while
    /// every candidate is within 180° of the fit; up to `2π` for a candidate taken the long way).
    pub spread: f64,
    /// `|s| < DEGENERATE_NORM` or no grasp: the orientation and its rates are not meaningful.
    pub degenerate: bool,
    /// Number of grasps used, `min(x_og.len(), tools.len())`.
    pub n: usize,
}

/// The object pose candidate of one tool reference through its grasp: `X_WO = X_WT X_OG⁻¹`,
/// `ω_O = ω_T`, `v_O = v_T + ω × d`, `v̇_O = v̇_T + ω̇ × d + ω × (ω × d)` with `d = p_WO − p_WT`.
pub fn candidate(tool: &PoseSample, x_og: &Isometry3<f64>) -> PoseSample {
    let x = tool.pose() * x_og.inverse();
    let p = x.translation.vector;
    let d = p - tool.p;
    let (w, wd) = (tool.w(), tool.w_dot());
    PoseSample {
        p,
        q: x.rotation,
        twist: stack(&(tool.v() + w.cross(&d)), &w),
        twist_dot: stack(&(tool.v_dot() + wd.cross(&d) + w.cross(&w.cross(&d))), &wd),
    }
}

/// The fit with equal weights; see the module doc. `x_og[i]` is `X_OGi`, `tools[i]` arm `i`'s
/// reference tool pose sample; `hint` picks the quaternion signs.
pub fn fit(x_og: &[Isometry3<f64>], tools: &[PoseSample], hint: &UnitQuaternion<f64>) -> Fit {
    fit_impl(x_og, tools, |_| 1.0, hint, true)
}

/// [`fit`] without the spread (the controller's tick needs only the sample: this skips a
/// second pass of quaternion products and an `atan2` per tool). The sample is the same bits;
/// `None` where [`fit`] reports `degenerate`.
pub fn fit_sample(
    x_og: &[Isometry3<f64>],
    tools: &[PoseSample],
    hint: &UnitQuaternion<f64>,
) -> Option<PoseSample> {
    let f = fit_impl(x_og, tools, |_| 1.0, hint, false);
    (!f.degenerate).then_some(f.sample)
}

/// The fit with weights `weights[i]` (relative; missing entries count as 0).
pub fn fit_weighted(
    x_og: &[Isometry3<f64>],
    tools: &[PoseSample],
    weights: &[f64],
    hint: &UnitQuaternion<f64>,
) -> Fit {
    fit_impl(
        x_og,
        tools,
        |i| weights.get(i).copied().unwrap_or(0.0),
        hint,
        true,
    )
}

/// `w` if finite and positive, else 0.
#[inline]
fn clean(w: f64) -> f64 {
    if w.is_finite() && w > 0.0 { w } else { 0.0 }
}

fn fit_impl(
    x_og: &[Isometry3<f64>],
    tools: &[PoseSample],
    weight: impl Fn(usize) -> f64,
    hint: &UnitQuaternion<f64>,
    with_spread: bool,
) -> Fit {
    let n = x_og.len().min(tools.len());
    if n == 0 {
        return Fit {
            sample: PoseSample::at_rest(Vector3::zeros(), *hint),
            spread: 0.0,
            degenerate: true,
            n,
        };
    }
    // Weights normalised to sum 1 (the largest first, so the sum cannot overflow).
    let w_max = (0..n).map(|i| clean(weight(i))).fold(0.0, f64::max);
    let (scale, uniform) = if w_max > 0.0 {
        let sum: f64 = (0..n).map(|i| clean(weight(i)) / w_max).sum();
        (1.0 / (w_max * sum), false)
    } else {
        (1.0 / n as f64, true)
    };
    let w_of = |i: usize| {
        if uniform {
            scale
        } else {
            // w/(w_max Σ) computed as (w/w_max)/Σ: no overflow.
            clean(weight(i)) / w_max * (w_max * scale)
        }
    };
    let h = hint.quaternion();

    // Weighted sums: tool points and their rates, grasp points, aligned quaternions and rates.
    let (mut p_t, mut v_t, mut a_t, mut r_bar) = (
        Vector3::zeros(),
        Vector3::zeros(),
        Vector3::zeros(),
        Vector3::zeros(),
    );
    let (mut s, mut s_d, mut s_dd) = (
        Quaternion::new(0.0, 0.0, 0.0, 0.0),
        Quaternion::new(0.0, 0.0, 0.0, 0.0),
        Quaternion::new(0.0, 0.0, 0.0, 0.0),
    );
    for i in 0..n {
        let wi = w_of(i);
        let t = &tools[i];
        p_t += t.p * wi;
        v_t += t.v() * wi;
        a_t += t.v_dot() * wi;
        r_bar += x_og[i].translation.vector * wi;
        let qi = aligned(t, &x_og[i], h);
        let (om, om_d) = (t.w(), t.w_dot());
        // q̇ = ½ ω ⊗ q, q̈ = ½ ω̇ ⊗ q − ¼ |ω|² q (world-axes ω).
        let qd = pure(&om) * qi * 0.5;
        let qdd = pure(&om_d) * qi * 0.5 - qi * (0.25 * om.norm_squared());
        s += qi * wi;
        s_d += qd * wi;
        s_dd += qdd * wi;
    }

    // q̄ = s/|s| and its first two derivatives.
    let ns = s.norm();
    let degenerate = !(ns >= DEGENERATE_NORM);
    let u = if ns > 0.0 && ns.is_finite() {
        s / ns
    } else {
        *h
    };
    let nn = if degenerate { DEGENERATE_NORM } else { ns };
    let n_d = u.dot(&s_d);
    let u_d = (s_d - u * n_d) / nn;
    let n_dd = u_d.dot(&s_d) + u.dot(&s_dd);
    let u_dd = (s_dd - u_d * (2.0 * n_d) - u * n_dd) / nn;
    let w_bar = (u_d * u.conjugate()).imag() * 2.0;
    let w_bar_d = (u_dd * u.conjugate()).imag() * 2.0;
    let q_bar = UnitQuaternion::new_unchecked(u);

    // Position: least squares over the grasp points given R̄; ρ = R̄ r̄ rides on the object.
    let rho = q_bar * r_bar;
    let p = p_t - rho;
    let v = v_t - w_bar.cross(&rho);
    let a = a_t - w_bar_d.cross(&rho) - w_bar.cross(&w_bar.cross(&rho));

    // Spread: the largest angle from q̄ to an aligned candidate (second pass, no storage).
    let mut spread: f64 = 0.0;
    for i in (0..n).filter(|_| with_spread) {
        let rel = u.conjugate() * aligned(&tools[i], &x_og[i], h);
        spread = spread.max(2.0 * rel.imag().norm().atan2(rel.w));
    }

    Fit {
        sample: PoseSample {
            p,
            q: q_bar,
            twist: stack(&v, &w_bar),
            twist_dot: stack(&a, &w_bar_d),
        },
        spread,
        degenerate,
        n,
    }
}

/// `σ_i q_i` with `q_i = q_WT ⊗ q_OG⁻¹` and `σ_i = ±1` so that `σ_i q_i · q_hint ≥ 0`.
#[inline]
fn aligned(tool: &PoseSample, x_og: &Isometry3<f64>, h: &Quaternion<f64>) -> Quaternion<f64> {
    let qi = *(tool.q * x_og.rotation.inverse()).quaternion();
    if qi.dot(h) < 0.0 { -qi } else { qi }
}
