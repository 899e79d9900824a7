//! The output chart of SPEC-spatial S5: six coordinates of the object pose for the iBLF
//! controller, with exact rates and the chart Jacobian.
//!
//! $$
//! x_1 = \begin{bmatrix} p_{WO} - c \\ \varphi \end{bmatrix},\qquad
//! \varphi = \operatorname{Log}(R_{ref}^\top R_{WO}) \in \mathbb R^3,\ |\varphi| \le \pi,
//! $$
//!
//! with `c` (m) and `R_ref` fixed (the scenario's box centre and reference orientation; the
//! planar paper has `c = 0`, `R_ref = I`). `x_1` is in metres and radians, so the output bounds
//! `|x_1j| < k_cj` of SPEC §3.3 apply to all six components.
//!
//! # Rates (derivation)
//! Write `R_rel = R_refᵀ R_WO = Exp(φ)`. With world-axes `ω` (`Ṙ_WO = [ω] R_WO`) and `R_ref`
//! constant, `R_relᵀ Ṙ_rel = R_WOᵀ Ṙ_WO = [R_WOᵀ ω]`: the body angular velocity. The
//! **right** Jacobian of [`so3`] is defined by `Exp(φ + δ) = Exp(φ) Exp(J_r(φ) δ + O(δ²))`, so
//! `d/dt Exp(φ(t)) = Exp(φ) [J_r(φ) φ̇]`, i.e. `R_WOᵀ ω = J_r(φ) φ̇` and
//!
//! $$ \dot\varphi = J_r(\varphi)^{-1} R_{WO}^\top \omega
//! = J_l(\varphi)^{-1} R_{ref}^\top \omega, $$
//!
//! the second form by `J_l(φ) = Exp(φ) J_r(φ)` (so `J_l⁻¹ = J_r⁻¹ R_relᵀ`). The right
//! Jacobian pairs with the body velocity, the left one with the velocity in `R_ref` axes
//! `ω_r = R_refᵀ ω`; pairing `J_r⁻¹` with world-axes `ω` would be wrong. `x_1`'s
//! position part has rate `v`, so `ẋ_1 = E V_WO` with `V_WO = [v; ω]` and the 6 × 6 chart
//! Jacobian
//!
//! $$ E = \begin{bmatrix} I & 0 \\ 0 & B \end{bmatrix},\quad
//! B = J_l(\varphi)^{-1} R_{ref}^\top = J_r(\varphi)^{-1} R_{WO}^\top,\qquad
//! E^{-1} = \begin{bmatrix} I & 0 \\ 0 & R_{ref} J_l(\varphi) \end{bmatrix}. $$
//!
//! **Second derivative.** Write `A = J_l⁻¹(φ)`. Differentiating the right form gives three terms,
//! `φ̈ = J_r⁻¹ R_WOᵀ ω̇ + (d/dt J_r⁻¹) R_WOᵀ ω + J_r⁻¹ (d/dt R_WOᵀ) ω`, and the last one
//! vanishes identically for world-axes `ω`: `(d/dt R_WOᵀ) ω = −R_WOᵀ [ω] ω = 0`. With the
//! left form and `R_ref` constant, `φ̈ = A ω̇_r + Ȧ ω_r` (`ω̇_r = R_refᵀ ω̇`), and `Ė` has the one
//! nonzero block `Ḃ = Ȧ R_refᵀ`, so `ẍ_1 = E V̇ + Ė V`. From
//! `J_l⁻¹(φ) = I − ½[φ] + d(θ²)[φ]²` with `d(s) = (1 − (θ/2)cot(θ/2))/θ²`, `s = θ² = |φ|²`:
//!
//! $$ \dot A = -\tfrac12[\dot\varphi]_\times +
//! d\,\big([\dot\varphi]_\times [\varphi]_\times + [\varphi]_\times [\dot\varphi]_\times\big) +
//! 2\,d'(s)\,(\varphi\cdot\dot\varphi)\,[\varphi]_\times^2, $$
//! $$ d'(s) = \frac{u^2/\sin^2 u + u\cot u - 2}{2\theta^4},\quad u = \theta/2,
//! \qquad d'(s) = \sum_{k\ge1} k\,\frac{|B_{2k+2}|}{(2k+2)!}\, s^{k-1} =
//! \tfrac1{720} + \tfrac{2 s}{30240} + \dots $$
//!
//! (`d` and `d'` of `s`, not of `θ`, so both are even and smooth at 0). Below
//! [`so3::SERIES_THRESHOLD`] (1 rad) both come from the Bernoulli series (11 terms; the
//! tail is `< 1e-16` relative at 1 rad); above, from the closed forms, whose numerator cancels
//! at most about 2.5 digits (at 1 rad; one digit by 2 rad, none at π). Both are regular up to
//! `θ < 2π`, and `J_l` is regular for every `θ < 2π`, so `E`, `E⁻¹`, `Ė` stay finite up to and at
//! `θ = π`.
//!
//! # The chart's edge
//! `Log` is discontinuous at `θ = π` (`φ` jumps to `−φ`), so the chart covers `|φ| < π`. Every
//! function returns finite values for finite input (never NaN, never a panic), and reports
//! `margin = π − |φ|` and `at_edge = margin ≤ edge_eps` ([`DEFAULT_EDGE_EPS`] = 0.01 rad by
//! default) so the caller sees it. A bound `k_c,rot < π` (SPEC-spatial S5) keeps a working
//! controller far from it. In the inverse maps a `φ` with `|φ| > π` is outside the chart: the
//! pose is still `R_ref Exp(φ)` (any vector is a rotation), but the Jacobians are evaluated at
//! the saturated `φ_s = π φ/|φ|` (finite, not exact) and `at_edge` is set.
//!
//! # Dynamics in chart coordinates (SPEC (14) "in these coordinates")
//! `M V̇ + h = F` (object-level inertia `M`, bias `h`, wrench `F`, all in twist coordinates)
//! becomes, with `V̇ = E⁻¹(ẍ_1 − Ė V)` and premultiplied by `E⁻ᵀ` (power-conjugate wrench
//! `F_x = E⁻ᵀ F`, so `F_x · ẋ_1 = F · V`):
//!
//! $$ M_x \ddot x_1 + h_x = F_x,\qquad M_x = E^{-\top} M E^{-1},\quad
//!   h_x = E^{-\top}\big(h - M E^{-1}\dot E V\big), $$
//!
//! the analogue of SPEC §2.1's Cartesian dynamics with `J = E`. A chart-space command `F_x`
//! maps back to the object wrench `F = Eᵀ F_x`. See [`ChartJacobian::dynamics`].
//!
//! The same functions serve the measured object state and a desired/reference pose sample.
//!
//! [`so3`]: crate::geometry::so3
//! [`so3::SERIES_THRESHOLD`]: crate::geometry::so3::SERIES_THRESHOLD

use nalgebra::{Isometry3, Matrix3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};

use crate::reference::spatial::PoseSample;

/// `(φ, φ̇, φ̈, J_l⁻¹(φ), d/dt J_l⁻¹)` of a pose sample in a chart.
type Angles = (
    Vector3<f64>,
    Vector3<f64>,
    Vector3<f64>,
    Matrix3<f64>,
    Matrix3<f64>,
);
use crate::geometry::motion::{ang, lin, stack};
use crate::geometry::so3;
use crate::geometry::so3::{SERIES_THRESHOLD, hat};

/// Default width (rad) of the band `π − edge_eps ≤ |φ| ≤ π` reported as the chart's edge.
pub const DEFAULT_EDGE_EPS: f64 = 1e-2;

/// The output chart: fixed centre `c` and reference orientation `R_ref`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chart {
    /// `c`: centre of the constraint box, world axes, m.
    pub c: Vector3<f64>,
    /// `R_ref` (`R_WRef`): the fixed reference orientation, as a unit quaternion.
    pub r_ref: UnitQuaternion<f64>,
    /// Width of the edge band, rad: `at_edge` is set when `π − |φ| ≤ edge_eps`.
    pub edge_eps: f64,
}

impl Default for Chart {
    fn default() -> Self {
        Self::identity()
    }
}

/// The chart Jacobian `E = blkdiag(I, B)`, its rate `Ė = blkdiag(0, Ḃ)` and its inverse
/// `E⁻¹ = blkdiag(I, B⁻¹)`, stored by their 3 × 3 rotational blocks.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartJacobian {
    /// `B = J_l(φ)⁻¹ R_refᵀ = J_r(φ)⁻¹ R_WOᵀ`: `φ̇ = B ω`, rad/s per rad/s.
    pub b: Matrix3<f64>,
    /// `Ḃ = (d/dt J_l⁻¹) R_refᵀ` along `φ̇`, 1/s.
    pub b_dot: Matrix3<f64>,
    /// `B⁻¹ = R_ref J_l(φ) = R_WO J_r(φ)`: `ω = B⁻¹ φ̇`.
    pub b_inv: Matrix3<f64>,
}

/// The chart coordinates of a pose sample with their rates and Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartSample {
    /// `x_1 = (p_WO − c, φ)`, (m, rad).
    pub x1: Vector6<f64>,
    /// `ẋ_1 = (v, φ̇) = E V`, (m/s, rad/s).
    pub x1_dot: Vector6<f64>,
    /// `ẍ_1 = (v̇, φ̈) = E V̇ + Ė V`, (m/s², rad/s²).
    pub x1_ddot: Vector6<f64>,
    /// `E`, `Ė`, `E⁻¹` at this sample.
    pub jac: ChartJacobian,
    /// `π − |φ|`, rad (≥ 0 from a pose; negative for an inverse-chart input beyond π).
    pub margin: f64,
    /// `margin ≤ edge_eps`: the chart is near (or past) its discontinuity at `|φ| = π`.
    pub at_edge: bool,
}

impl Chart {
    /// The chart about `c` and `R_ref`, edge band [`DEFAULT_EDGE_EPS`].
    pub fn new(c: Vector3<f64>, r_ref: UnitQuaternion<f64>) -> Self {
        Self {
            c,
            r_ref,
            edge_eps: DEFAULT_EDGE_EPS,
        }
    }

    /// The planar paper's chart: `c = 0`, `R_ref = I`.
    pub fn identity() -> Self {
        Self::new(Vector3::zeros(), UnitQuaternion::identity())
    }

    /// `φ = Log(R_refᵀ R_WO)`, `|φ| ≤ π`, rad.
    #[inline]
    pub fn phi(&self, q_wo: &UnitQuaternion<f64>) -> Vector3<f64> {
        so3::log_quat(&(self.r_ref.inverse() * q_wo))
    }

    /// `x_1 = (p_WO − c, Log(R_refᵀ R_WO))`, (m, rad).
    #[inline]
    pub fn coords(&self, p_wo: &Vector3<f64>, q_wo: &UnitQuaternion<f64>) -> Vector6<f64> {
        stack(&(p_wo - self.c), &self.phi(q_wo))
    }

    /// The inverse chart: `X_WO = (c + x_p, R_ref Exp(φ))` for any `x_1` (every `φ` is a
    /// rotation; `|φ| < π` gives back the same `x_1` under [`Chart::coords`]).
    #[inline]
    pub fn pose(&self, x1: &Vector6<f64>) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(self.c + lin(x1)),
            self.r_ref * so3::exp_quat(&ang(x1)),
        )
    }

    /// `E`, `Ė` and `E⁻¹` at `φ` moving with `φ̇` (at the saturated `π φ/|φ|` if `|φ| > π`,
    /// see the module doc).
    pub fn jacobian(&self, phi: &Vector3<f64>, phi_dot: &Vector3<f64>) -> ChartJacobian {
        let phi = saturate(phi);
        let (a, a_dot) = jl_inv_and_rate(&phi, phi_dot);
        let rr = self.r_ref.to_rotation_matrix().into_inner();
        ChartJacobian {
            b: a * rr.transpose(),
            b_dot: a_dot * rr.transpose(),
            b_inv: rr * so3::left_jacobian(&phi),
        }
    }

    /// The chart applied to a pose sample (the measured object, or a desired/reference pose):
    /// `x_1`, `ẋ_1 = (v, φ̇)`, `ẍ_1 = (v̇, φ̈)`, `E`, `Ė`, `E⁻¹`, and the edge indicator.
    /// `(p, R, V, V̇) → (x_1, ẋ_1, ẍ_1, E, Ė)`.
    pub fn sample(&self, s: &PoseSample) -> ChartSample {
        let (phi, phi_dot, phi_ddot, a, a_dot) = self.angles(s);
        let rr = self.r_ref.to_rotation_matrix().into_inner();
        let jac = ChartJacobian {
            b: a * rr.transpose(),
            b_dot: a_dot * rr.transpose(),
            b_inv: rr * so3::left_jacobian(&phi),
        };
        // |Log| ≤ π exactly; the rounded angle may exceed π by an ulp.
        let margin = (std::f64::consts::PI - phi.norm()).max(0.0);
        ChartSample {
            x1: stack(&(s.p - self.c), &phi),
            x1_dot: stack(&s.v(), &phi_dot),
            x1_ddot: stack(&s.v_dot(), &phi_ddot),
            jac,
            margin,
            at_edge: !(margin > self.edge_eps),
        }
    }

    /// `(x_1, ẋ_1, ẍ_1)` of [`Chart::sample`] alone, the same bits, without the chart Jacobian
    /// (for a sample whose Jacobian is not used, e.g. the controller's reference: this skips
    /// `J_l(φ)` and three 3 × 3 products).
    pub fn coordinates(&self, s: &PoseSample) -> (Vector6<f64>, Vector6<f64>, Vector6<f64>) {
        let (phi, phi_dot, phi_ddot, _, _) = self.angles(s);
        (
            stack(&(s.p - self.c), &phi),
            stack(&s.v(), &phi_dot),
            stack(&s.v_dot(), &phi_ddot),
        )
    }

    /// `(φ, φ̇, φ̈, J_l⁻¹(φ), d/dt J_l⁻¹)` of a sample (shared by [`Chart::sample`] and
    /// [`Chart::coordinates`]).
    #[inline(always)]
    fn angles(&self, s: &PoseSample) -> Angles {
        // φ from the relative quaternion (Log: accurate at 0 and π).
        let q_ref_inv = self.r_ref.inverse();
        let phi = so3::log_quat(&(q_ref_inv * s.q));
        // Angular velocity and acceleration in R_ref axes.
        let w_r = q_ref_inv * s.w();
        let wd_r = q_ref_inv * s.w_dot();
        // φ̇ = J_l⁻¹ ω_r, φ̈ = J_l⁻¹ ω̇_r + (d/dt J_l⁻¹) ω_r.
        let a = so3::left_jacobian_inv(&phi);
        let phi_dot = a * w_r;
        let a_dot = jl_inv_rate(&phi, &phi_dot);
        let phi_ddot = a * wd_r + a_dot * w_r;
        (phi, phi_dot, phi_ddot, a, a_dot)
    }

    /// The inverse map: the pose sample (pose, twist, twist rate) whose chart coordinates are
    /// `(x_1, ẋ_1, ẍ_1)`: `X = pose(x_1)`, `V = E⁻¹ ẋ_1`, `V̇ = E⁻¹(ẍ_1 − Ė V)`. Also returns
    /// the chart sample it corresponds to (its `at_edge` flags `|φ| > π − edge_eps`).
    pub fn inverse(
        &self,
        x1: &Vector6<f64>,
        x1_dot: &Vector6<f64>,
        x1_ddot: &Vector6<f64>,
    ) -> (PoseSample, ChartSample) {
        let phi = ang(x1);
        let jac = self.jacobian(&phi, &ang(x1_dot));
        let twist = jac.twist_from_chart(x1_dot);
        let twist_dot = jac.twist_rate_from_chart(x1_ddot, &twist);
        let x = self.pose(x1);
        let margin = std::f64::consts::PI - phi.norm();
        (
            PoseSample {
                p: x.translation.vector,
                q: x.rotation,
                twist,
                twist_dot,
            },
            ChartSample {
                x1: *x1,
                x1_dot: *x1_dot,
                x1_ddot: *x1_ddot,
                jac,
                margin,
                at_edge: !(margin > self.edge_eps),
            },
        )
    }
}

#[allow(non_snake_case)]
impl ChartJacobian {
    /// `E = blkdiag(I, B)` (6 × 6): `ẋ_1 = E V`.
    pub fn e(&self) -> Matrix6<f64> {
        blkdiag(&Matrix3::identity(), &self.b)
    }

    /// `Ė = blkdiag(0, Ḃ)` (6 × 6): `ẍ_1 = E V̇ + Ė V`.
    pub fn e_dot(&self) -> Matrix6<f64> {
        blkdiag(&Matrix3::zeros(), &self.b_dot)
    }

    /// `E⁻¹ = blkdiag(I, B⁻¹)` (6 × 6): `V = E⁻¹ ẋ_1`.
    pub fn e_inv(&self) -> Matrix6<f64> {
        blkdiag(&Matrix3::identity(), &self.b_inv)
    }

    /// `ẋ_1 = E V`.
    #[inline]
    pub fn chart_rate(&self, twist: &Vector6<f64>) -> Vector6<f64> {
        stack(&lin(twist), &(self.b * ang(twist)))
    }

    /// `ẍ_1 = E V̇ + Ė V`.
    #[inline]
    pub fn chart_accel(&self, twist: &Vector6<f64>, twist_dot: &Vector6<f64>) -> Vector6<f64> {
        stack(
            &lin(twist_dot),
            &(self.b * ang(twist_dot) + self.b_dot * ang(twist)),
        )
    }

    /// `V = E⁻¹ ẋ_1`.
    #[inline]
    pub fn twist_from_chart(&self, x1_dot: &Vector6<f64>) -> Vector6<f64> {
        stack(&lin(x1_dot), &(self.b_inv * ang(x1_dot)))
    }

    /// `V̇ = E⁻¹ (ẍ_1 − Ė V)`.
    #[inline]
    pub fn twist_rate_from_chart(
        &self,
        x1_ddot: &Vector6<f64>,
        twist: &Vector6<f64>,
    ) -> Vector6<f64> {
        stack(
            &lin(x1_ddot),
            &(self.b_inv * (ang(x1_ddot) - self.b_dot * ang(twist))),
        )
    }

    /// A wrench `F = [f; τ]` as the chart's generalised force `F_x = E⁻ᵀ F = [f; B⁻ᵀ τ]`
    /// (`F_x · ẋ_1 = F · V`).
    #[inline]
    pub fn wrench_to_chart(&self, f: &Vector6<f64>) -> Vector6<f64> {
        stack(&lin(f), &(self.b_inv.transpose() * ang(f)))
    }

    /// A chart generalised force back to the wrench: `F = Eᵀ F_x = [f_x; Bᵀ τ_x]`.
    #[inline]
    pub fn wrench_from_chart(&self, f_x: &Vector6<f64>) -> Vector6<f64> {
        stack(&lin(f_x), &(self.b.transpose() * ang(f_x)))
    }

    /// Object dynamics `M V̇ + h = F` in chart coordinates, `M_x ẍ_1 + h_x = E⁻ᵀ F`:
    /// returns `(M_x, h_x) = (E⁻ᵀ M E⁻¹, E⁻ᵀ (h − M E⁻¹ Ė V))` for the inertia `M` (6 × 6,
    /// kg and kg m²), the bias `h` (Coriolis, damping, gravity; N, N m) and the twist `V`.
    pub fn dynamics(
        &self,
        M: &Matrix6<f64>,
        h: &Vector6<f64>,
        twist: &Vector6<f64>,
    ) -> (Matrix6<f64>, Vector6<f64>) {
        let ei = self.e_inv();
        let m_x = ei.transpose() * M * ei;
        // E⁻¹ Ė V = [0; B⁻¹ Ḃ ω].
        let eiedv = stack(&Vector3::zeros(), &(self.b_inv * (self.b_dot * ang(twist))));
        let h_x = self.wrench_to_chart(&(h - M * eiedv));
        (m_x, h_x)
    }
}

/// `blkdiag(a, b)`.
fn blkdiag(a: &Matrix3<f64>, b: &Matrix3<f64>) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(a);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(b);
    m
}

/// `φ` if `|φ| ≤ π`, else `π φ/|φ|` (finite for every finite input).
#[inline]
fn saturate(phi: &Vector3<f64>) -> Vector3<f64> {
    let t = phi.norm();
    if t > std::f64::consts::PI && t.is_finite() {
        phi * (std::f64::consts::PI / t)
    } else if t.is_finite() {
        *phi
    } else {
        // Overflowed norm of a finite vector (|φ| > 1e154): rescale first.
        let m = phi.amax();
        let u = phi / m;
        u * (std::f64::consts::PI / u.norm())
    }
}

/// `(J_l⁻¹(φ), d/dt J_l⁻¹(φ))` along `φ̇`.
#[inline]
fn jl_inv_and_rate(phi: &Vector3<f64>, phi_dot: &Vector3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    (so3::left_jacobian_inv(phi), jl_inv_rate(phi, phi_dot))
}

/// `d/dt J_l⁻¹(φ) = −½[φ̇] + d ([φ̇][φ] + [φ][φ̇]) + 2 d'(θ²) (φ·φ̇) [φ]²` (module doc).
/// `d/dt J_r⁻¹` is the same with `+½[φ̇]` (`J_r⁻¹(φ) = J_l⁻¹(−φ)`).
#[inline]
pub fn jl_inv_rate(phi: &Vector3<f64>, phi_dot: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let (d, dp) = coeff_d_dprime(t2, t2.sqrt());
    let p = hat(phi);
    let pd = hat(phi_dot);
    let p2 = phi * phi.transpose() - Matrix3::from_diagonal_element(t2);
    pd * -0.5 + (pd * p + p * pd) * d + p2 * (2.0 * dp * phi.dot(phi_dot))
}

/// `|B_{2k+2}|/(2k+2)!`, `k = 0 … 11`: the series of `d(s) = Σ K_k s^k` (as in [`so3`]).
///
/// [`so3`]: crate::geometry::so3
const D_SERIES: [f64; 12] = [
    1.0 / 12.0,
    1.0 / 720.0,
    1.0 / 30_240.0,
    1.0 / 1_209_600.0,
    1.0 / 47_900_160.0,
    691.0 / 1_307_674_368_000.0,
    1.0 / 74_724_249_600.0,
    3_617.0 / 10_670_622_842_880_000.0,
    43_867.0 / 5_109_094_217_170_944_000.0,
    174_611.0 / 802_857_662_698_291_200_000.0,
    77_683.0 / 14_101_100_039_391_805_440_000.0,
    236_364_091.0 / 1_693_824_136_731_743_669_452_800_000.0,
];

/// `(d(s), d'(s))` with `s = θ² = t2`, `θ = t`: `d = (1 − u cot u)/θ²`,
/// `d' = (u²/sin²u + u cot u − 2)/(2θ⁴)`, `u = θ/2`; Bernoulli series below
/// [`SERIES_THRESHOLD`].
#[inline]
pub(crate) fn coeff_d_dprime(t2: f64, t: f64) -> (f64, f64) {
    if t < SERIES_THRESHOLD {
        let mut d = 0.0;
        for k in D_SERIES.iter().rev() {
            d = d * t2 + k;
        }
        let mut dp = 0.0;
        for k in (1..D_SERIES.len()).rev() {
            dp = dp * t2 + k as f64 * D_SERIES[k];
        }
        (d, dp)
    } else {
        let u = 0.5 * t;
        let (s, c) = u.sin_cos();
        let ucot = u * c / s;
        let us = u / s;
        ((1.0 - ucot) / t2, (us * us + ucot - 2.0) / (2.0 * t2 * t2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_and_closed_forms_of_d_prime_agree_at_the_switch() {
        // Where the closed form takes over (θ ≥ 1): the series still converges fast there
        // (term ratio ≈ θ²/4π², tail < 1e-16 relative up to 1.25 rad), the closed form's
        // numerator cancels about 2.5 digits at 1 rad (≈ 3e-14 relative), fewer above.
        for t in [SERIES_THRESHOLD, 1.1, 1.25] {
            let t2 = t * t;
            let u = 0.5 * t;
            let (s, c) = u.sin_cos();
            let dp_closed = ((u / s) * (u / s) + u * c / s - 2.0) / (2.0 * t2 * t2);
            let mut dp = 0.0;
            for k in (1..D_SERIES.len()).rev() {
                dp = dp * t2 + k as f64 * D_SERIES[k];
            }
            let rel = (dp - dp_closed).abs() / dp;
            assert!(rel < 1e-13, "θ = {t}: {rel:e}");
        }
        // d' at 0 is 1/720.
        assert_eq!(coeff_d_dprime(0.0, 0.0).1, 1.0 / 720.0);
    }

    #[test]
    fn d_matches_so3() {
        // J_l⁻¹ rebuilt from this module's d equals so3's.
        for t in [0.0, 1e-9, 0.5, 0.999, 1.0, 2.0, 3.0, std::f64::consts::PI] {
            let phi = Vector3::new(0.48, -0.6, 0.64) * t;
            let (d, _) = coeff_d_dprime(t * t, t);
            let p = hat(&phi);
            let a = Matrix3::identity() - p * 0.5 + p * p * d;
            assert!(
                (a - so3::left_jacobian_inv(&phi)).abs().max() < 1e-15,
                "θ = {t}"
            );
        }
    }
}
