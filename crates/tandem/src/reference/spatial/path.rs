//! Desired object poses in SE(3), $X_{WO,d}(t) = (p_d(t), R_d(t))$, with analytic derivatives:
//! $p, \dot p, \ddot p, \dddot p$ and $R, \omega, \dot\omega, \ddot\omega$.
//!
//! The spatial counterpart of [`crate::reference::planar::path`]: step 2 of the control tick (SPEC §3, on
//! six outputs as SPEC-spatial S5 says) evaluates the desired pose and its rates analytically,
//! never by finite differences. Data flow: `t → (p, v, a, j, R, ω, ω̇, ω̈)`.
//!
//! **Conventions** (SPEC-spatial S1): world frame `W`; `R_AB` maps B-coordinates to A, so
//! $R = R_{WO,d}$; $\omega$ is the angular velocity **in world axes**,
//! $\dot R = [\omega]_\times R$, and $\dot\omega, \ddot\omega$ are its plain time derivatives
//! (world axes are fixed, so no transport term); stacked twists are **linear first**,
//! $[v; \omega]$ ([`Se3Sample::twist`]). Quaternions are nalgebra's `UnitQuaternion`
//! (`w, x, y, z`). SI units (m, rad, s).
//!
//! Three shapes, all built through validating constructors that name the offending parameter
//! (`path.omega`, `path.waypoints[3].r`, … as [`ModelError`]), all sampled without allocation:
//!
//! | shape | constructor | smoothness |
//! |---|---|---|
//! | circle + orientation oscillation (S6) | [`Se3Path::circle`], [`Se3Path::spec_s6`] | $C^\infty$ |
//! | rest-to-rest quintic along the geodesic | [`Se3Path::point_to_point`] | $C^2$ (jerk, $\ddot\omega$ jump at the ends) |
//! | clamped cubic spline through timed poses | [`Se3Path::spline`] | $C^2$ in $p$ and in $R$ ($\omega, \dot\omega$ continuous) inside |
//!
//! # 1. Circle with an orientation oscillation ([`Se3Circle`])
//!
//! $$p(t) = c + \rho\,(\cos\psi\, e_1 + \sin\psi\, e_2), \qquad \psi = \omega t + \psi_0,$$
//! $$\dot p = \rho\omega(-\sin\psi\, e_1 + \cos\psi\, e_2),\quad
//!   \ddot p = -\omega^2 (p - c),\quad \dddot p = -\omega^2 \dot p,$$
//! with $e_1, e_2$ orthonormal (default the horizontal $x$, $y$). The orientation turns by
//! $\theta(t) = A \sin(\Omega t + \chi_0)$ about a fixed unit axis. **World-axis form** (the
//! default, [`AxisFrame::World`]): the axis $a_W$ is fixed in the world and the rotation is
//! applied on the left,
//! $$R(t) = \mathrm{Exp}(\theta(t)\, a_W)\, R_0, \qquad \omega = \dot\theta\, a_W,\
//!   \dot\omega = \ddot\theta\, a_W,\ \ddot\omega = \dddot\theta\, a_W .$$
//! **Body-axis form** ([`AxisFrame::Body`]): the axis $a_B$ is fixed in the object (given in
//! $R_0$'s axes) and $R(t) = R_0\,\mathrm{Exp}(\theta a_B)$. Since
//! $R_0 \mathrm{Exp}(\theta a_B) = \mathrm{Exp}(\theta R_0 a_B) R_0$ the two are the same family
//! with $a_W = R_0 a_B$: the body form is converted to the world form at construction, and
//! both give the formulas above. With $R_0 = I$ they coincide: SPEC-spatial S6 ("a rotation of
//! $10° \sin 2\omega t$ about world y", $R_{WO} = I$ at $t = 0$) is
//! $p = (0, 0, 0.3) + 0.1(\cos\omega t, \sin\omega t, 0)$, $\omega = 2\pi/60$,
//! $R = \mathrm{Exp}(10°\sin(2\omega t)\,\hat y)$ ([`Se3Path::spec_s6`]).
//!
//! # 2. Point to point along the geodesic ([`Se3PointToPoint`])
//!
//! $s(\tau) = 10\tau^3 - 15\tau^4 + 6\tau^5$, $\tau = (t - t_0)/T$ (the planar time law),
//! $$p = p_A + s\,(p_B - p_A), \qquad R = R_A\,\mathrm{Exp}(s\,\varphi_{AB}),\quad
//!   \varphi_{AB} = \mathrm{Log}(R_A^T R_B),\ |\varphi_{AB}| < \pi - 10^{-6}.$$
//! The axis $\varphi_{AB}$ is fixed in the body and is an eigenvector of
//! $\mathrm{Exp}(s\varphi_{AB})$, so with $u = R_A \varphi_{AB}$ (world axes)
//! $\omega = \dot s\, u$, $\dot\omega = \ddot s\, u$, $\ddot\omega = \dddot s\, u$.
//!
//! # 3. Waypoint spline ([`Se3Spline`]): the orientation scheme
//!
//! Position: a clamped cubic spline per axis (the planar [`crate::reference::planar::path::Spline`]).
//! Orientation: **one chart for the whole path**, centred at the first waypoint,
//! $$R(t) = R_c\,\mathrm{Exp}(\varphi(t)), \qquad R_c = R_0,\quad
//!   \varphi_k = \mathrm{Log}(R_c^T R_k),\ |\varphi_k| \le \pi - 10^{-6},$$
//! and $\varphi(t)$ the clamped cubic spline through $(t_k, \varphi_k)$ (C², zero rate at both
//! ends). Since $\mathrm{Exp}$ is smooth everywhere, $R(t)$ is $C^2$ wherever $\varphi$ is
//! (also if the spline overshoots $|\varphi| = \pi$ between waypoints). With the left Jacobian
//! $J_l(\varphi) = I + b[\varphi] + c[\varphi]^2$, $b = (1 - \cos\theta)/\theta^2$,
//! $c = (\theta - \sin\theta)/\theta^3$, $\theta = |\varphi|$
//! ($\tfrac{d}{dt}\mathrm{Exp}(\varphi) = [J_l\dot\varphi]\,\mathrm{Exp}(\varphi)$):
//! $$\omega = R_c\, J_l(\varphi)\dot\varphi,\quad
//!   \dot\omega = R_c(\dot J_l\dot\varphi + J_l\ddot\varphi),\quad
//!   \ddot\omega = R_c(\ddot J_l\dot\varphi + 2\dot J_l\ddot\varphi + J_l\dddot\varphi)$$
//! ($R_c$ is constant, so no $R$-derivatives appear; equivalently the body rate is
//! $\omega_B = J_r(\varphi)\dot\varphi$ and $\omega = R\,\omega_B$ since $J_l = \mathrm{Exp}(\varphi) J_r$).
//! $J_l\dot\varphi = \dot\varphi + b\,g + c\,h$ with $g = \varphi\times\dot\varphi$,
//! $h = \varphi\times g$, and $b, c$ are functions of $u = \theta^2 = \varphi\cdot\varphi$
//! (smooth in $t$ even where $\varphi$ passes through 0, unlike $\theta$), differentiated
//! exactly by the chain rule ([`left_jacobian_rates`]). $b(u), c(u)$ and their first two
//! $u$-derivatives come from their power series $\sum (-1)^k u^k/(2k+2)!$,
//! $\sum (-1)^k u^k/(2k+3)!$ (Horner with derivatives; 16 terms for $\theta \le \pi$, 30 up
//! to $\theta = 2\pi$; the largest term is below 2.3, so at most one digit is lost, and the
//! truncation is below 1e-22 and 1e-35),
//! and from the closed forms above $2\pi$ (where they no longer cancel).
//!
//! Why this scheme: it is exactly differentiable with a few cross products (no matrix
//! exponentials of Bézier control rotations, no numeric differentiation), $C^2$ in rotation
//! by construction, passes through every waypoint, starts and ends at rest, and its chart is
//! the iBLF output chart of SPEC-spatial S5 when $R_{ref} = R_0$ (the default "desired
//! orientation at $t = 0$"), so the reach in that chart is a closed form. Its limitation:
//! every waypoint must lie within $\pi - 10^{-6}$ of the first one (a longer rotation needs
//! several paths); the cumulative B-spline of Kim et al. has no such limit but is $C^2$ only
//! through control rotations it does not interpolate.
//!
//! # The output chart ([`chart_x1`], [`chart_rates`], [`Se3Path::max_abs`])
//!
//! [`chart_rates`] turns a sample into the S5 output coordinates $x_1 = (p - c, \varphi)$ and
//! their exact first three time derivatives (the planar [`crate::reference::planar::path::PathSample`]'s
//! role for the six-output iBLF), through $J_l^{-1}$ and the derivatives of $J_l$.
//!
//! [`Se3Path::max_abs`] gives $\max_{t\in[0,t_{end}]} |x_{1j}(t)|$ for $x_1 = (p - c,\ \mathrm{Log}(R_{ref}^T R))$
//! (SPEC-spatial S5), used to check the iBLF bounds $k_c$:
//! * position: closed form for all three shapes (circle: $|d_j + \rho_j\cos(\psi - \beta_j)|$
//!   over the angle range; quintic: monotone; spline: the derivative's roots per segment);
//! * orientation: closed form when $R_{ref}$ lies on the path's own one-parameter family
//!   (circle: $R_{ref} = \mathrm{Exp}(\theta_r a_W) R_0$, which includes $R(0)$; quintic: on
//!   the geodesic, which includes $R_A$ and $R_B$; spline: $R_{ref} = R_0$), up to a
//!   documented $2\delta$ margin for $R_{ref}$ off the family by $\delta \le 10^{-9}$ rad;
//! * otherwise a rigorous dense sampling: at $N$ points with spacing $\Delta$, the geodesic
//!   angle $|\varphi|$ is $|\omega|$-Lipschitz and, while $|\varphi| < \pi$,
//!   $|\dot\varphi_j| \le \|J_r^{-1}(\varphi)\|\,|\omega| \le (\pi/2)|\omega|$, so
//!   $|\varphi_j| \le \max_k|\varphi_j(t_k)| + (\pi/2)\,\omega_{max}\Delta/2$; if a sample comes
//!   within $\omega_{max}\Delta/2$ of $\pi$ the chart may wrap and the bound is $\pi$ (true for
//!   every rotation vector). $N$ is a constant (4096 per circle period or quintic, 1024 per
//!   spline segment): every loop is bounded whatever the input magnitudes.
//!
//! # Numerics
//! * Never NaN from validated input: constructors reject non-finite values, non-unit axes and
//!   quaternions (tolerance 1e-9, then renormalised), and any rate whose highest derivative
//!   would overflow (naming the field, as the planar hardening does).
//! * Huge or non-finite `t`: the circle's two angles $\omega t + \psi_0$ and
//!   $\Omega t + \chi_0$ are formed once per sample and every derivative uses the same
//!   `sin_cos`, so pose and rates stay consistent; if either product is not finite ($t = \pm\infty$,
//!   NaN, or $|t| \gtrsim 10^{308}/\omega$) both angles fall back to their phases (the pose at
//!   $t = 0$). The quintic and the spline hold their end poses ($t$ NaN holds the start).
//!   Phases are limited to [`MAX_PHASE`] (1e9 rad) as in the planar paths.
//! * Angles near 0: `Exp` through [`exp_quat`] (series below 1e-4), $b, c$ by series.
//!
//! # Example
//!
//! ```
//! use tandem::nalgebra::{UnitQuaternion, Vector3};
//! use tandem::reference::spatial::path::{Se3Path, chart_rates};
//!
//! let path = Se3Path::spec_s6();
//! let s = path.sample(15.0); // a quarter lap: on the +y side, pitch back through 0
//! assert!((s.p - Vector3::new(0.0, 0.1, 0.3)).norm() < 1e-15);
//! // The S5 chart about the path's centre and R_ref = R(0) = I, and its reach.
//! let (c, r_ref) = (Vector3::new(0.0, 0.0, 0.3), UnitQuaternion::identity());
//! let [x1, x1_dot, _, _] = chart_rates(&s, &c, &r_ref);
//! assert!((x1_dot[4] - s.w.y).abs() < 1e-15); // φ̇ = ω about a fixed axis through φ = 0
//! let reach = path.max_abs(&c, &r_ref, 60.0);
//! assert_eq!(reach[4], 10f64.to_radians());
//! # let _ = x1;
//! ```
//!
//! # References
//! 1. SPEC-spatial S1 (conventions), S5 (output chart), S6 (the dual-UR5 path).
//! 2. SPEC §3 (control tick, step 2); the planar paths in [`crate::reference::planar::path`].
//! 3. J. Solà, J. Deray, D. Atchuthan, *A micro Lie theory for state estimation in robotics*,
//!    2018 (right/left Jacobians of SO(3)).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::{UnitQuaternion, Vector3, Vector6};

use crate::error::{ModelError, positive};
use crate::geometry::so3::{exp_quat, left_jacobian_inv, log_quat};
use crate::reference::planar::path::MAX_PHASE;
use crate::reference::planar::path::{Path, Spline};

/// Smallest distance (rad) from π allowed for a geodesic angle $|\varphi_{AB}|$ or a waypoint's
/// chart angle $|\mathrm{Log}(R_c^T R_k)|$: at π the rotation vector's sign is undefined.
pub const PI_MARGIN: f64 = 1e-6;

/// Tolerance on the norm of unit axes and unit quaternions given as input (`|n − 1| ≤ 1e-9`);
/// accepted values are renormalised.
pub const UNIT_TOL: f64 = 1e-9;

/// Largest distance (rad) of $R_{ref}$ from a path's own rotation family for which
/// [`Se3Path::max_abs`] uses the closed form (with a margin of twice the distance).
const FAMILY_TOL: f64 = 1e-9;

/// Samples of the rigorous orientation bound: per circle period or quintic move.
const N_SAMPLES: usize = 4096;
/// Samples of the rigorous orientation bound: per spline segment.
const N_SAMPLES_SEGMENT: usize = 1024;

// ---------------------------------------------------------------------------------------------
// Sample
// ---------------------------------------------------------------------------------------------

/// The desired object pose $X_{WO,d}$ and its rates at one instant, all in world axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se3Sample {
    /// Position $p_{WO}$ \[m\].
    pub p: Vector3<f64>,
    /// Velocity $\dot p$ \[m/s\].
    pub v: Vector3<f64>,
    /// Acceleration $\ddot p$ \[m/s²\].
    pub a: Vector3<f64>,
    /// Jerk $\dddot p$ \[m/s³\].
    pub j: Vector3<f64>,
    /// Orientation $R_{WO}$ (maps object coordinates to world).
    pub r: UnitQuaternion<f64>,
    /// Angular velocity $\omega$, world axes ($\dot R = [\omega]_\times R$) \[rad/s\].
    pub w: Vector3<f64>,
    /// $\dot\omega$, world axes \[rad/s²\].
    pub wd: Vector3<f64>,
    /// $\ddot\omega$, world axes \[rad/s³\].
    pub wdd: Vector3<f64>,
}

impl Se3Sample {
    /// A pose held still: all rates zero.
    pub fn hold(p: Vector3<f64>, r: UnitQuaternion<f64>) -> Self {
        Se3Sample {
            p,
            v: Vector3::zeros(),
            a: Vector3::zeros(),
            j: Vector3::zeros(),
            r,
            w: Vector3::zeros(),
            wd: Vector3::zeros(),
            wdd: Vector3::zeros(),
        }
    }
    /// Twist $[v; \omega]$ (linear first, world axes) [m/s, rad/s].
    pub fn twist(&self) -> Vector6<f64> {
        stack(&self.v, &self.w)
    }
    /// Its derivative $[\dot v; \dot\omega]$ [m/s², rad/s²].
    pub fn twist_dot(&self) -> Vector6<f64> {
        stack(&self.a, &self.wd)
    }
    /// Its second derivative $[\ddot v; \ddot\omega]$ [m/s³, rad/s³].
    pub fn twist_ddot(&self) -> Vector6<f64> {
        stack(&self.j, &self.wdd)
    }
}

fn stack(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// The iBLF output chart of SPEC-spatial S5 at one sample:
/// $x_1 = (p - c,\ \mathrm{Log}(R_{ref}^T R))$, linear first [m, rad].
pub fn chart_x1(s: &Se3Sample, c: &Vector3<f64>, r_ref: &UnitQuaternion<f64>) -> Vector6<f64> {
    stack(&(s.p - c), &log_quat(&(r_ref.inverse() * s.r)))
}

/// The desired output in the S5 chart and its first three time derivatives,
/// $[x_1, \dot x_1, \ddot x_1, \dddot x_1]$ with $x_1 = (p - c,\ \varphi)$,
/// $\varphi = \mathrm{Log}(R_{ref}^T R)$, linear first [m, rad; /s, /s², /s³].
///
/// With $Q = R_{ref}^T R = \mathrm{Exp}(\varphi)$, $\dot Q = [\omega_r] Q$ where
/// $\omega_r = R_{ref}^T\omega$, so $\omega_r = J_l(\varphi)\dot\varphi$ and, differentiating
/// ([`left_jacobian_rates`] is linear in its last argument),
/// $$\dot\varphi = J_l^{-1}\omega_r,\quad
///   \ddot\varphi = J_l^{-1}(\dot\omega_r - \dot J_l\dot\varphi),\quad
///   \dddot\varphi = J_l^{-1}(\ddot\omega_r - \ddot J_l\dot\varphi - 2\dot J_l\ddot\varphi)$$
/// (exact; $J_l^{-1}$ is regular for $|\varphi| \le \pi$, which `Log` guarantees). The chart
/// itself jumps where $R$ crosses the half turn from $R_{ref}$ (SPEC-spatial S5 keeps
/// $|\varphi| < k_{c} < \pi$). No allocation.
pub fn chart_rates(
    s: &Se3Sample,
    c: &Vector3<f64>,
    r_ref: &UnitQuaternion<f64>,
) -> [Vector6<f64>; 4] {
    let ref_inv = r_ref.inverse();
    let phi = log_quat(&(ref_inv * s.r));
    let (w, wd, wdd) = (ref_inv * s.w, ref_inv * s.wd, ref_inv * s.wdd);
    let jl_inv = left_jacobian_inv(&phi);
    let bc = bc_with_derivatives(phi.norm_squared());
    let z = Vector3::zeros();
    let d1 = jl_inv * w;
    let d2 = jl_inv * (wd - left_jacobian_rates_with(&bc, &phi, &d1, &z, &z)[1]);
    let d3 = jl_inv * (wdd - left_jacobian_rates_with(&bc, &phi, &d1, &d2, &z)[2]);
    [
        stack(&(s.p - c), &phi),
        stack(&s.v, &d1),
        stack(&s.a, &d2),
        stack(&s.j, &d3),
    ]
}

// ---------------------------------------------------------------------------------------------
// Path
// ---------------------------------------------------------------------------------------------

/// A desired SE(3) trajectory. Build it with [`Se3Path::circle`], [`Se3Path::spec_s6`],
/// [`Se3Path::point_to_point`] or [`Se3Path::spline`]; sample it with [`Se3Path::sample`].
#[derive(Clone, Debug, PartialEq)]
pub enum Se3Path {
    /// Circle with an orientation oscillation about a fixed axis.
    Circle(Se3Circle),
    /// Rest-to-rest quintic on the straight line and the rotation geodesic.
    PointToPoint(Se3PointToPoint),
    /// Clamped cubic spline through timed poses (one rotation-vector chart).
    Spline(Se3Spline),
}

impl Se3Path {
    /// The SPEC-spatial S6 path: $p = (0, 0, 0.3) + 0.1(\cos\omega t, \sin\omega t, 0)$ m,
    /// $\omega = 2\pi/60$ s⁻¹, $R = \mathrm{Exp}(10° \sin(2\omega t)\,\hat y)$ (world y, $R_0 = I$).
    pub fn spec_s6() -> Se3Path {
        Se3Path::Circle(
            Se3Circle::new(&CircleParams::spec_s6()).expect("the S6 parameters are valid"),
        )
    }

    /// A circle with an orientation oscillation; see [`Se3Circle::new`].
    pub fn circle(params: &CircleParams) -> Result<Se3Path, ModelError> {
        Se3Circle::new(params).map(Se3Path::Circle)
    }

    /// A rest-to-rest move from pose A to pose B; see [`Se3PointToPoint::new`].
    pub fn point_to_point(
        p_from: Vector3<f64>,
        r_from: UnitQuaternion<f64>,
        p_to: Vector3<f64>,
        r_to: UnitQuaternion<f64>,
        t0: f64,
        duration: f64,
    ) -> Result<Se3Path, ModelError> {
        Se3PointToPoint::new(p_from, r_from, p_to, r_to, t0, duration).map(Se3Path::PointToPoint)
    }

    /// A clamped cubic spline through timed poses; see [`Se3Spline::new`].
    pub fn spline(waypoints: &[Se3Waypoint]) -> Result<Se3Path, ModelError> {
        Se3Spline::new(waypoints).map(Se3Path::Spline)
    }

    /// Pose and rates at time `t` \[s\]. No allocation.
    #[inline]
    pub fn sample(&self, t: f64) -> Se3Sample {
        match self {
            Se3Path::Circle(c) => c.sample(t),
            Se3Path::PointToPoint(p) => p.sample(t),
            Se3Path::Spline(s) => s.sample(t),
        }
    }

    /// Componentwise $\max_{t \in [0, t_{end}]} |x_{1j}(t)|$ of the output chart
    /// $x_1 = (p - c, \mathrm{Log}(R_{ref}^T R))$ (see [`chart_x1`]), linear first [m, rad]:
    /// closed form where available, otherwise a rigorous upper bound from bounded sampling
    /// (see the module doc). `t_end = +∞` asks for the whole path; `t_end ≤ 0` (or NaN) gives
    /// $|x_1(0)|$. Allocates (set-up use only).
    pub fn max_abs(
        &self,
        c: &Vector3<f64>,
        r_ref: &UnitQuaternion<f64>,
        t_end: f64,
    ) -> Vector6<f64> {
        let t_end = if t_end > 0.0 { t_end } else { 0.0 };
        let r_ref = UnitQuaternion::new_normalize(r_ref.into_inner());
        match self {
            Se3Path::Circle(x) => x.max_abs(c, &r_ref, t_end),
            Se3Path::PointToPoint(x) => x.max_abs(c, &r_ref, t_end),
            Se3Path::Spline(x) => x.max_abs(c, &r_ref, t_end),
        }
    }
}

impl From<Se3Circle> for Se3Path {
    fn from(c: Se3Circle) -> Se3Path {
        Se3Path::Circle(c)
    }
}
impl From<Se3PointToPoint> for Se3Path {
    fn from(p: Se3PointToPoint) -> Se3Path {
        Se3Path::PointToPoint(p)
    }
}
impl From<Se3Spline> for Se3Path {
    fn from(s: Se3Spline) -> Se3Path {
        Se3Path::Spline(s)
    }
}

// ---------------------------------------------------------------------------------------------
// Circle
// ---------------------------------------------------------------------------------------------

/// In which axes the oscillation axis of a [`CircleParams`] is given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AxisFrame {
    /// Fixed in the world: $R(t) = \mathrm{Exp}(\theta(t) a_W) R_0$.
    #[default]
    World,
    /// Fixed in the object, in $R_0$'s axes: $R(t) = R_0 \mathrm{Exp}(\theta(t) a_B)$
    /// (the same as world axis $a_W = R_0 a_B$).
    Body,
}

/// Parameters of a [`Se3Circle`] (plain data; validated by [`Se3Circle::new`]). The default is
/// the SPEC-spatial S6 path ([`CircleParams::spec_s6`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleParams {
    /// Centre $c$ \[m\] (`path.center[j]`).
    pub center: Vector3<f64>,
    /// Radius $\rho > 0$ \[m\] (`path.radius`).
    pub radius: f64,
    /// Angular rate $\omega > 0$ along the circle \[rad/s\] (`path.omega`); the sense of travel
    /// is from `plane_x` towards `plane_y`.
    pub omega: f64,
    /// Phase $\psi_0$ at t = 0 \[rad\], $|\psi_0| \le$ [`MAX_PHASE`] (`path.phase`).
    pub phase: f64,
    /// First in-plane unit axis $e_1$ (`path.plane_x`).
    pub plane_x: Vector3<f64>,
    /// Second in-plane unit axis $e_2 \perp e_1$ (`path.plane_y`).
    pub plane_y: Vector3<f64>,
    /// Orientation $R_0$ about which the object oscillates (`path.r0`).
    pub r0: UnitQuaternion<f64>,
    /// Unit oscillation axis $a$ (`path.axis`), in the axes named by `axis_frame`.
    pub axis: Vector3<f64>,
    /// Whether `axis` is in world axes or in $R_0$'s (body) axes.
    pub axis_frame: AxisFrame,
    /// Amplitude $A$, $0 \le A \le \pi - 10^{-6}$ \[rad\] (`path.amplitude`).
    pub amplitude: f64,
    /// Oscillation rate $\Omega > 0$ \[rad/s\] (`path.omega_rot`).
    pub omega_rot: f64,
    /// Oscillation phase $\chi_0$ \[rad\], $|\chi_0| \le$ [`MAX_PHASE`] (`path.phase_rot`).
    pub phase_rot: f64,
}

impl CircleParams {
    /// SPEC-spatial S6: centre (0, 0, 0.3) m, radius 0.1 m, ω = 2π/60 s⁻¹ in the horizontal
    /// x–y plane, $R_0 = I$, 10° about world y at Ω = 2ω, both phases 0.
    pub fn spec_s6() -> Self {
        let omega = TAU / 60.0;
        CircleParams {
            center: Vector3::new(0.0, 0.0, 0.3),
            radius: 0.1,
            omega,
            phase: 0.0,
            plane_x: Vector3::x(),
            plane_y: Vector3::y(),
            r0: UnitQuaternion::identity(),
            axis: Vector3::y(),
            axis_frame: AxisFrame::World,
            amplitude: 10f64.to_radians(),
            omega_rot: 2.0 * omega,
            phase_rot: 0.0,
        }
    }
}

impl Default for CircleParams {
    fn default() -> Self {
        CircleParams::spec_s6()
    }
}

/// Circle at constant rate with an orientation oscillation about a fixed axis
/// (module doc, section 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Se3Circle {
    center: Vector3<f64>,
    radius: f64,
    omega: f64,
    phase: f64,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    r0: UnitQuaternion<f64>,
    /// Oscillation axis in world axes, $a_W$.
    axis_w: Vector3<f64>,
    amplitude: f64,
    omega_rot: f64,
    phase_rot: f64,
}

impl Se3Circle {
    /// Validate and build. Errors name the field (see [`CircleParams`]): non-finite values;
    /// `radius`, `omega`, `omega_rot` not > 0; `amplitude` outside `[0, π − 1e-6]`; phases
    /// beyond [`MAX_PHASE`]; `plane_x`, `plane_y`, `axis`, `r0` not of unit norm (± 1e-9) or
    /// `plane_y` not orthogonal to `plane_x` (± 1e-9); rates whose third derivatives
    /// ($\rho\omega^3$, $A\Omega^3$) overflow.
    pub fn new(p: &CircleParams) -> Result<Self, ModelError> {
        finite_vec("path.center", &p.center)?;
        positive("path.radius", p.radius)?;
        positive("path.omega", p.omega)?;
        no_overflow("path.omega", p.omega, p.radius * p.omega.powi(3))?;
        phase_angle("path.phase", p.phase)?;
        let e1 = unit_vec("path.plane_x", &p.plane_x)?;
        let e2 = unit_vec("path.plane_y", &p.plane_y)?;
        let d = e1.dot(&e2);
        if d.abs() > UNIT_TOL {
            return Err(ModelError::invalid(
                "path.plane_y",
                d,
                "must be orthogonal to path.plane_x (the value is their dot product)",
            ));
        }
        // Exactly orthonormal from here on (Gram–Schmidt on an already 1e-9-orthogonal pair).
        let e2 = (e2 - e1 * e1.dot(&e2)).normalize();
        let r0 = unit_quat("path.r0", &p.r0)?;
        let axis = unit_vec("path.axis", &p.axis)?;
        let axis_w = match p.axis_frame {
            AxisFrame::World => axis,
            AxisFrame::Body => (r0 * axis).normalize(),
        };
        let a = p.amplitude;
        if !(a.is_finite() && (0.0..=PI - PI_MARGIN).contains(&a)) {
            return Err(ModelError::invalid(
                "path.amplitude",
                a,
                "must be finite, >= 0 and <= π − 1e-6 rad",
            ));
        }
        positive("path.omega_rot", p.omega_rot)?;
        no_overflow("path.omega_rot", p.omega_rot, a * p.omega_rot.powi(3))?;
        phase_angle("path.phase_rot", p.phase_rot)?;
        Ok(Se3Circle {
            center: p.center,
            radius: p.radius,
            omega: p.omega,
            phase: p.phase,
            e1,
            e2,
            r0,
            axis_w,
            amplitude: a,
            omega_rot: p.omega_rot,
            phase_rot: p.phase_rot,
        })
    }

    /// Centre $c$ \[m\].
    pub fn center(&self) -> Vector3<f64> {
        self.center
    }
    /// Radius $\rho$ \[m\].
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Rate ω along the circle \[rad/s\].
    pub fn omega(&self) -> f64 {
        self.omega
    }
    /// In-plane axes $(e_1, e_2)$ (orthonormal).
    pub fn plane(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.e1, self.e2)
    }
    /// Central orientation $R_0$.
    pub fn r0(&self) -> UnitQuaternion<f64> {
        self.r0
    }
    /// Oscillation axis in world axes $a_W$ (for [`AxisFrame::Body`], $R_0 a_B$).
    pub fn axis_world(&self) -> Vector3<f64> {
        self.axis_w
    }
    /// Amplitude A \[rad\].
    pub fn amplitude(&self) -> f64 {
        self.amplitude
    }
    /// Oscillation rate Ω \[rad/s\].
    pub fn omega_rot(&self) -> f64 {
        self.omega_rot
    }

    /// The angles $(\psi, \chi) = (\omega t + \psi_0, \Omega t + \chi_0)$ both from the same t;
    /// if either is not finite, both from t = 0.
    #[inline]
    fn angles(&self, t: f64) -> (f64, f64) {
        let psi = self.omega * t + self.phase;
        let chi = self.omega_rot * t + self.phase_rot;
        if psi.is_finite() && chi.is_finite() {
            (psi, chi)
        } else {
            (self.phase, self.phase_rot)
        }
    }

    /// Pose and rates at `t` \[s\]; see the module doc for non-finite or huge `t`.
    #[inline]
    pub fn sample(&self, t: f64) -> Se3Sample {
        let (psi, chi) = self.angles(t);
        let (s, c) = psi.sin_cos();
        let (r, w) = (self.radius, self.omega);
        let (rw, rw2, rw3) = (r * w, r * w * w, r * w * w * w);
        let (e1, e2) = (&self.e1, &self.e2);
        let (sx, cx) = chi.sin_cos();
        let (a, om) = (self.amplitude, self.omega_rot);
        let theta = a * sx;
        let theta1 = a * om * cx;
        let theta2 = -a * om * om * sx;
        let theta3 = -a * om * om * om * cx;
        Se3Sample {
            p: self.center + e1 * (r * c) + e2 * (r * s),
            v: e2 * (rw * c) - e1 * (rw * s),
            a: -(e1 * (rw2 * c) + e2 * (rw2 * s)),
            j: e1 * (rw3 * s) - e2 * (rw3 * c),
            r: exp_quat(&(self.axis_w * theta)) * self.r0,
            w: self.axis_w * theta1,
            wd: self.axis_w * theta2,
            wdd: self.axis_w * theta3,
        }
    }

    fn max_abs(&self, c: &Vector3<f64>, r_ref: &UnitQuaternion<f64>, t_end: f64) -> Vector6<f64> {
        // Position: p_j − c_j = d_j + ρ_j cos(ψ − β_j), ρ_j cos β_j = ρ e1_j, ρ_j sin β_j = ρ e2_j.
        // The ends are evaluated exactly as `sample` does (an angle of 1e8 rad minus β would
        // round differently); the interior extrema |d_j ± ρ_j| are exact.
        let (lo, hi) = angle_range(self.omega, self.phase, t_end);
        let d = self.center - c;
        let (first, last) = (self.sample(0.0), self.sample(t_end));
        let mut out = Vector6::zeros();
        for j in 0..3 {
            let amp = self.radius * self.e1[j].hypot(self.e2[j]);
            let beta = self.e2[j].atan2(self.e1[j]);
            out[j] = (first.p[j] - c[j])
                .abs()
                .max((last.p[j] - c[j]).abs())
                .max(interior_max_abs_cos(d[j], amp, lo - beta, hi - beta));
        }
        // Orientation: R_ref = Exp(θ_r a) R0 (δ-close) gives φ = (θ − θ_r) R0ᵀ a.
        let v = log_quat(&(r_ref * self.r0.inverse()));
        let theta_r = v.dot(&self.axis_w);
        let fam = exp_quat(&(self.axis_w * theta_r)) * self.r0;
        let delta = log_quat(&(fam.inverse() * r_ref)).norm();
        let (lo, hi) = angle_range(self.omega_rot, self.phase_rot, t_end);
        // θ − θ_r = −θ_r + A cos(χ − π/2); the ends as `sample` evaluates them.
        let theta_at = |t: f64| self.amplitude * self.angles(t).1.sin();
        let m = (theta_at(0.0) - theta_r)
            .abs()
            .max((theta_at(t_end) - theta_r).abs())
            .max(interior_max_abs_cos(
                -theta_r,
                self.amplitude,
                lo - FRAC_PI_2,
                hi - FRAC_PI_2,
            ));
        if delta <= FAMILY_TOL && m + 2.0 * delta < PI - PI_MARGIN {
            let a_b = self.r0.inverse() * self.axis_w;
            for j in 0..3 {
                out[3 + j] = a_b[j].abs() * m + 2.0 * delta;
            }
        } else {
            // One period of the oscillation visits every orientation of the path.
            let t1 = t_end.min(TAU / self.omega_rot);
            let w_max = self.amplitude * self.omega_rot;
            let b = sampled_rotation_bound(|t| self.sample(t).r, r_ref, 0.0, t1, w_max, N_SAMPLES);
            out.fixed_rows_mut::<3>(3).copy_from(&b);
        }
        out
    }
}

// ---------------------------------------------------------------------------------------------
// Point to point
// ---------------------------------------------------------------------------------------------

/// Rest-to-rest move from pose A to pose B (module doc, section 2): quintic time law, straight
/// line in position, rotation geodesic in orientation. Holds A for $t \le t_0$ and B for
/// $t \ge t_0 + T$.
#[derive(Clone, Debug, PartialEq)]
pub struct Se3PointToPoint {
    p_from: Vector3<f64>,
    r_from: UnitQuaternion<f64>,
    p_to: Vector3<f64>,
    r_to: UnitQuaternion<f64>,
    /// $\varphi_{AB} = \mathrm{Log}(R_A^T R_B)$, in A's axes \[rad\].
    phi: Vector3<f64>,
    /// $u = R_A \varphi_{AB}$, world axes \[rad\].
    u_w: Vector3<f64>,
    t0: f64,
    duration: f64,
}

impl Se3PointToPoint {
    /// Validate and build. Errors name the field: `path.p_from[j]`, `path.p_to[j]` finite;
    /// `path.r_from`, `path.r_to` finite unit quaternions (± 1e-9); `path.t0` finite;
    /// `path.duration` finite and > 0, and not so short that the jerk
    /// ($60|\Delta p|/T^3$, $60|\varphi_{AB}|/T^3$) overflows; `path.r_to` also if the geodesic
    /// angle $|\mathrm{Log}(R_A^T R_B)| \ge \pi - 10^{-6}$ (its direction is then ambiguous).
    pub fn new(
        p_from: Vector3<f64>,
        r_from: UnitQuaternion<f64>,
        p_to: Vector3<f64>,
        r_to: UnitQuaternion<f64>,
        t0: f64,
        duration: f64,
    ) -> Result<Self, ModelError> {
        finite_vec("path.p_from", &p_from)?;
        finite_vec("path.p_to", &p_to)?;
        let r_from = unit_quat("path.r_from", &r_from)?;
        let r_to = unit_quat("path.r_to", &r_to)?;
        finite("path.t0", t0)?;
        positive("path.duration", duration)?;
        let phi = log_quat(&(r_from.inverse() * r_to));
        let angle = phi.norm();
        if !(angle < PI - PI_MARGIN) {
            return Err(ModelError::invalid(
                "path.r_to",
                angle,
                "is (nearly) a half turn from path.r_from: the geodesic angle must be < π − 1e-6 rad",
            ));
        }
        let big = (p_to - p_from).amax().max(angle);
        if !(60.0 * big / duration.powi(3)).is_finite() || !(t0 + duration).is_finite() {
            return Err(ModelError::invalid(
                "path.duration",
                duration,
                "is so short (for this distance) that the path's derivatives overflow",
            ));
        }
        // The same rotation, with the quaternion sign the move arrives at (q and −q are one
        // rotation; `Log` takes the short way, w ≥ 0): the samples' quaternions are continuous.
        let r_to = same_sign(&r_to, &(r_from * exp_quat(&phi)));
        Ok(Se3PointToPoint {
            p_from,
            r_from,
            p_to,
            r_to,
            phi,
            u_w: r_from * phi,
            t0,
            duration,
        })
    }

    /// Start pose $(p_A, R_A)$.
    pub fn from(&self) -> (Vector3<f64>, UnitQuaternion<f64>) {
        (self.p_from, self.r_from)
    }
    /// End pose $(p_B, R_B)$.
    pub fn to(&self) -> (Vector3<f64>, UnitQuaternion<f64>) {
        (self.p_to, self.r_to)
    }
    /// Geodesic rotation vector $\varphi_{AB} = \mathrm{Log}(R_A^T R_B)$ in A's axes \[rad\].
    pub fn phi_ab(&self) -> Vector3<f64> {
        self.phi
    }
    /// Start time $t_0$ \[s\].
    pub fn t0(&self) -> f64 {
        self.t0
    }
    /// Duration T \[s\].
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// The time law $s(\tau(t))$ and its first three time derivatives, clamped outside the
    /// move ($s = 0$ before, $1$ after, rates 0).
    #[inline]
    pub fn time_law(&self, t: f64) -> [f64; 4] {
        let tau = (t - self.t0) / self.duration;
        if tau >= 1.0 {
            return [1.0, 0.0, 0.0, 0.0];
        }
        if tau.is_nan() || tau <= 0.0 {
            return [0.0; 4];
        }
        let inv_t = 1.0 / self.duration;
        [
            tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau)),
            30.0 * tau * tau * (1.0 + tau * (-2.0 + tau)) * inv_t,
            60.0 * tau * (1.0 + tau * (-3.0 + 2.0 * tau)) * inv_t * inv_t,
            60.0 * (1.0 + tau * (-6.0 + 6.0 * tau)) * inv_t * inv_t * inv_t,
        ]
    }

    /// Pose and rates at `t` \[s\]: exactly A (as given, renormalised) for $t \le t_0$ or NaN,
    /// exactly B once $\tau \ge 1$, with zero rates. B's quaternion is the given one or its
    /// negative (the same rotation), whichever the move arrives at, so the samples'
    /// quaternions are continuous in t.
    #[inline]
    pub fn sample(&self, t: f64) -> Se3Sample {
        let tau = (t - self.t0) / self.duration;
        if tau >= 1.0 {
            return Se3Sample::hold(self.p_to, self.r_to);
        }
        if tau.is_nan() || tau <= 0.0 {
            return Se3Sample::hold(self.p_from, self.r_from);
        }
        let [s, s1, s2, s3] = self.time_law(t);
        let d = self.p_to - self.p_from;
        Se3Sample {
            p: self.p_from.lerp(&self.p_to, s),
            v: d * s1,
            a: d * s2,
            j: d * s3,
            r: self.r_from * exp_quat(&(self.phi * s)),
            w: self.u_w * s1,
            wd: self.u_w * s2,
            wdd: self.u_w * s3,
        }
    }

    fn max_abs(&self, c: &Vector3<f64>, r_ref: &UnitQuaternion<f64>, t_end: f64) -> Vector6<f64> {
        let first = self.sample(0.0);
        let last = self.sample(t_end);
        let mut out = Vector6::zeros();
        // Position: every component is monotone in t.
        for j in 0..3 {
            out[j] = (first.p[j] - c[j]).abs().max((last.p[j] - c[j]).abs());
        }
        // Orientation: R_ref = R_A Exp(s_r φ) (δ-close) gives φ_chart = (s − s_r) φ, and s is
        // monotone in t.
        let phi2 = self.phi.norm_squared();
        let v = log_quat(&(self.r_from.inverse() * r_ref));
        let s_r = if phi2 > 0.0 {
            v.dot(&self.phi) / phi2
        } else {
            0.0
        };
        let fam = self.r_from * exp_quat(&(self.phi * s_r));
        let delta = log_quat(&(fam.inverse() * r_ref)).norm();
        let (s0, s1) = (self.time_law(0.0)[0], self.time_law(t_end)[0]);
        let m = (s0 - s_r).abs().max((s1 - s_r).abs());
        let angle = self.phi.norm();
        if delta <= FAMILY_TOL && m * angle + 2.0 * delta < PI - PI_MARGIN {
            for j in 0..3 {
                out[3 + j] = self.phi[j].abs() * m + 2.0 * delta;
            }
        } else {
            let lo = self.t0.max(0.0);
            let hi = (self.t0 + self.duration).min(t_end);
            let w_max = 1.875 * angle / self.duration;
            let mut b = chart_abs(&first.r, r_ref).sup(&chart_abs(&last.r, r_ref));
            if hi > lo {
                b = b.sup(&sampled_rotation_bound(
                    |t| self.sample(t).r,
                    r_ref,
                    lo,
                    hi,
                    w_max,
                    N_SAMPLES,
                ));
            }
            out.fixed_rows_mut::<3>(3).copy_from(&b);
        }
        out
    }
}

// ---------------------------------------------------------------------------------------------
// Spline
// ---------------------------------------------------------------------------------------------

/// One timed pose of a [`Se3Spline`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se3Waypoint {
    /// Time $t_k$ \[s\].
    pub t: f64,
    /// Position $p_k$ \[m\].
    pub p: Vector3<f64>,
    /// Orientation $R_k$.
    pub r: UnitQuaternion<f64>,
}

/// Clamped cubic spline through timed poses (module doc, section 3): position per axis,
/// orientation as a spline of the rotation vector in the chart $R = R_0 \mathrm{Exp}(\varphi)$.
/// Holds the first pose for $t \le t_0$ and the last for $t \ge t_{n-1}$.
#[derive(Clone, Debug, PartialEq)]
pub struct Se3Spline {
    /// Position spline through $(t_k, p_k)$.
    pos: Spline,
    /// Rotation-vector spline through $(t_k, \varphi_k)$.
    rot: Spline,
    /// Waypoints as given (quaternions renormalised).
    waypoints: Vec<Se3Waypoint>,
    /// Chart rotation vectors $\varphi_k = \mathrm{Log}(R_0^T R_k)$ \[rad\].
    phi: Vec<Vector3<f64>>,
    /// Chart centre $R_c = R_0$.
    r_c: UnitQuaternion<f64>,
}

impl Se3Spline {
    /// Validate and build. Errors name the field: at least 2 waypoints (`path.waypoints`);
    /// every time finite and strictly increasing (`path.waypoints[k].t`, also when two times
    /// are so close that the derivatives overflow); positions finite (`path.waypoints[k].p[j]`);
    /// orientations finite unit quaternions (± 1e-9) within the chart,
    /// $|\mathrm{Log}(R_0^T R_k)| \le \pi - 10^{-6}$ (`path.waypoints[k].r`).
    pub fn new(waypoints: &[Se3Waypoint]) -> Result<Self, ModelError> {
        let n = waypoints.len();
        if n < 2 {
            return Err(ModelError::invalid(
                "path.waypoints",
                n as f64,
                "need at least 2 waypoints",
            ));
        }
        let mut wps = Vec::with_capacity(n);
        for (k, w) in waypoints.iter().enumerate() {
            finite(&format!("path.waypoints[{k}].t"), w.t)?;
            if k > 0 && w.t <= waypoints[k - 1].t {
                return Err(ModelError::invalid(
                    format!("path.waypoints[{k}].t"),
                    w.t,
                    format!(
                        "times must increase strictly (waypoints[{}].t = {})",
                        k - 1,
                        waypoints[k - 1].t
                    ),
                ));
            }
            finite_vec(&format!("path.waypoints[{k}].p"), &w.p)?;
            let r = unit_quat(&format!("path.waypoints[{k}].r"), &w.r)?;
            wps.push(Se3Waypoint { t: w.t, p: w.p, r });
        }
        let r_c = wps[0].r;
        let mut phi = Vec::with_capacity(n);
        for k in 0..n {
            let w = wps[k];
            let f = if k == 0 {
                Vector3::zeros()
            } else {
                log_quat(&(r_c.inverse() * w.r))
            };
            if !(f.norm() <= PI - PI_MARGIN) {
                return Err(ModelError::invalid(
                    format!("path.waypoints[{k}].r"),
                    f.norm(),
                    "is outside the chart: its angle from waypoints[0].r must be <= π − 1e-6 rad",
                ));
            }
            phi.push(f);
            // Quaternion sign continuous along the path (the spline arrives at R_c Exp(φ_k)).
            let at = r_c * exp_quat(&f);
            let w = &mut wps[k];
            w.r = same_sign(&w.r, &at);
        }
        let rename = |e: ModelError| match e {
            ModelError::Invalid {
                param,
                value,
                reason,
            } => ModelError::Invalid {
                param: param.replace("spline.waypoints", "path.waypoints"),
                value,
                reason,
            },
            other => other,
        };
        let pts: Vec<(f64, Vector3<f64>)> = wps.iter().map(|w| (w.t, w.p)).collect();
        let pos = Spline::new(&pts).map_err(rename)?;
        let fts: Vec<(f64, Vector3<f64>)> = wps.iter().zip(&phi).map(|(w, f)| (w.t, *f)).collect();
        let rot = Spline::new(&fts).map_err(rename)?;
        // ω̈ is a polynomial of degree 3 in (φ̇, φ̈, φ⃛) with coefficients ≤ 1 + 4|φ|² (|φ| ≤ the
        // segment's bound): require a generous product of the segment bounds to be finite.
        for k in 0..n - 1 {
            let h = wps[k + 1].t - wps[k].t;
            let Some(s) = segment_midpoint(&rot, wps[k].t, wps[k + 1].t) else {
                return Err(ModelError::invalid(
                    format!("path.waypoints[{}].t", k + 1),
                    wps[k + 1].t,
                    "is too close to the previous waypoint to be resolved",
                ));
            };
            let b1 = s.v.norm() + s.a.norm() * h + s.j.norm() * h * h;
            let b0 = s.p.norm() + b1 * h;
            let g =
                (1.0 + b0) * (1.0 + b1) * (1.0 + s.a.norm() + s.j.norm() * h) * (1.0 + s.j.norm());
            if !(1e3 * g * g * g).is_finite() {
                return Err(ModelError::invalid(
                    format!("path.waypoints[{}].t", k + 1),
                    wps[k + 1].t,
                    "is so close to the previous waypoint (for this rotation) that the path's derivatives overflow",
                ));
            }
        }
        Ok(Se3Spline {
            pos,
            rot,
            waypoints: wps,
            phi,
            r_c,
        })
    }

    /// An upper bound on $|\dot\varphi|$ over segment `k`: each component of $\dot\varphi$ is
    /// the quadratic $\dot\varphi_j(t_k) + \ddot\varphi_j(t_k)\tau + \dddot\varphi_j\tau^2/2$,
    /// whose largest magnitude on $[0, h_k]$ is at an end or at its vertex.
    fn rate_bound(&self, k: usize) -> f64 {
        let (ta, tb) = (self.waypoints[k].t, self.waypoints[k + 1].t);
        let Some(s) = segment_midpoint(&self.rot, ta, tb) else {
            return f64::INFINITY;
        };
        // About the midpoint: σ ∈ [−h/2, h/2] (the derivatives at a knot would be the hold's).
        let r = 0.5 * (tb - ta);
        let mut sq = 0.0;
        for j in 0..3 {
            let (c0, c1, c2) = (s.v[j], s.a[j], 0.5 * s.j[j]);
            let q = |x: f64| (c0 + (c1 + c2 * x) * x).abs();
            let mut m = q(-r).max(q(r));
            if c2 != 0.0 {
                let x = -c1 / (2.0 * c2);
                if x > -r && x < r {
                    m = m.max(q(x));
                }
            }
            sq += m * m;
        }
        // Rounded up a little (the coefficients carry rounding of the spline solve).
        sq.sqrt() * (1.0 + 1e-9)
    }

    /// Whether $|\varphi(t)| < $ `limit` on $[0, t_{end}]$, rigorously: per segment, 64
    /// samples of $|\varphi|$ plus the Lipschitz reach $\max|\dot\varphi|\,\Delta/2$.
    fn chart_angle_below(&self, t_end: f64, limit: f64) -> bool {
        let mut ok =
            self.rot.sample(0.0).p.norm() < limit && self.rot.sample(t_end).p.norm() < limit;
        for k in 0..self.waypoints.len() - 1 {
            let (ta, tb) = (self.waypoints[k].t, self.waypoints[k + 1].t);
            let (lo, hi) = (ta.max(0.0), tb.min(t_end));
            if hi <= lo {
                continue;
            }
            let w_max = self.rate_bound(k);
            const N: usize = 64;
            let reach = w_max * (hi - lo) / (2.0 * N as f64) * (1.0 + 1e-12);
            for i in 0..=N {
                let t = if i == N {
                    hi
                } else {
                    lo + (hi - lo) * (i as f64 / N as f64)
                };
                ok &= self.rot.sample(t).p.norm() + reach < limit;
            }
        }
        ok
    }

    /// The waypoints (quaternions renormalised, and negated where needed so that the
    /// samples' quaternions are continuous in t; the same rotations).
    pub fn waypoints(&self) -> &[Se3Waypoint] {
        &self.waypoints
    }
    /// Chart rotation vectors $\varphi_k = \mathrm{Log}(R_0^T R_k)$ \[rad\].
    pub fn chart_phi(&self) -> &[Vector3<f64>] {
        &self.phi
    }

    /// The chart coordinate $\varphi(t)$ and its first three time derivatives (the raw
    /// rotation-vector spline, holds included).
    #[inline]
    pub fn chart_sample(&self, t: f64) -> [Vector3<f64>; 4] {
        let s = self.rot.sample(t);
        [s.p, s.v, s.a, s.j]
    }

    /// Pose and rates at `t` \[s\]. Exactly the first waypoint for $t \le t_0$ (or NaN) and
    /// the last for $t \ge t_{n-1}$, with zero rates. No allocation.
    #[inline]
    pub fn sample(&self, t: f64) -> Se3Sample {
        let first = &self.waypoints[0];
        let last = &self.waypoints[self.waypoints.len() - 1];
        if t >= last.t {
            return Se3Sample::hold(last.p, last.r);
        }
        if t.is_nan() || t <= first.t {
            return Se3Sample::hold(first.p, first.r);
        }
        let ps = self.pos.sample(t);
        let f = self.rot.sample(t);
        let [w, wd, wdd] = left_jacobian_rates(&f.p, &f.v, &f.a, &f.j);
        Se3Sample {
            p: ps.p,
            v: ps.v,
            a: ps.a,
            j: ps.j,
            r: self.r_c * exp_quat(&f.p),
            w: self.r_c * w,
            wd: self.r_c * wd,
            wdd: self.r_c * wdd,
        }
    }

    fn max_abs(&self, c: &Vector3<f64>, r_ref: &UnitQuaternion<f64>, t_end: f64) -> Vector6<f64> {
        let mut out = Vector6::zeros();
        // Position: the spline through p_k − c is the spline through p_k, shifted.
        let shifted: Vec<(f64, Vector3<f64>)> =
            self.waypoints.iter().map(|w| (w.t, w.p - c)).collect();
        if let Ok(sp) = Spline::new(&shifted) {
            out.fixed_rows_mut::<3>(0)
                .copy_from(&Path::Spline(sp).max_abs(t_end));
        } else {
            // Unreachable for validated waypoints and a finite c; stay rigorous anyway.
            out.fixed_rows_mut::<3>(0).fill(f64::INFINITY);
        }
        // Orientation: R_ref = R_0 (δ-close): φ_chart = φ(t) while |φ| < π.
        let delta = log_quat(&(r_ref.inverse() * self.r_c)).norm();
        if delta <= FAMILY_TOL && self.chart_angle_below(t_end, PI - PI_MARGIN - 2.0 * delta) {
            let m = Path::Spline(self.rot.clone()).max_abs(t_end);
            for j in 0..3 {
                out[3 + j] = m[j] + 2.0 * delta;
            }
            return out;
        }
        let first = self.sample(0.0);
        let last = self.sample(t_end);
        let mut b = chart_abs(&first.r, r_ref).sup(&chart_abs(&last.r, r_ref));
        for k in 0..self.waypoints.len() - 1 {
            let (ta, tb) = (self.waypoints[k].t, self.waypoints[k + 1].t);
            let (lo, hi) = (ta.max(0.0), tb.min(t_end));
            if hi <= lo {
                continue;
            }
            // |ω| = |J_l φ̇| ≤ |φ̇| (‖J_l‖ ≤ 1), and φ̇ is a quadratic on the segment.
            let w_max = self.rate_bound(k);
            b = b.sup(&sampled_rotation_bound(
                |t| self.sample(t).r,
                r_ref,
                lo,
                hi,
                w_max,
                N_SAMPLES_SEGMENT,
            ));
        }
        out.fixed_rows_mut::<3>(3).copy_from(&b);
        out
    }
}

// ---------------------------------------------------------------------------------------------
// Left Jacobian along a curve
// ---------------------------------------------------------------------------------------------

/// $w = J_l(\varphi)\dot\varphi$ and its first two time derivatives $\dot w, \ddot w$ along a
/// curve $\varphi(t)$ given by $(\varphi, \dot\varphi, \ddot\varphi, \dddot\varphi)$: the world
/// angular velocity of $\mathrm{Exp}(\varphi(t))$ and its rates (module doc, section 3).
///
/// Exact up to rounding for every $\varphi$ (series for $|\varphi| \le 2\pi$, closed forms
/// beyond). Every argument is a 3-vector in the same axes; so are the results.
pub fn left_jacobian_rates(
    phi: &Vector3<f64>,
    d1: &Vector3<f64>,
    d2: &Vector3<f64>,
    d3: &Vector3<f64>,
) -> [Vector3<f64>; 3] {
    left_jacobian_rates_with(&bc_with_derivatives(phi.norm_squared()), phi, d1, d2, d3)
}

/// [`left_jacobian_rates`] with the coefficients `bc = bc_with_derivatives(|φ|²)` given.
#[inline]
fn left_jacobian_rates_with(
    bc: &[f64; 6],
    phi: &Vector3<f64>,
    d1: &Vector3<f64>,
    d2: &Vector3<f64>,
    d3: &Vector3<f64>,
) -> [Vector3<f64>; 3] {
    // Rates of u = |φ|².
    let u1 = 2.0 * phi.dot(d1);
    let u2 = 2.0 * (d1.norm_squared() + phi.dot(d2));
    let [b, b_u, b_uu, c, c_u, c_uu] = *bc;
    let (b1, b2) = (b_u * u1, b_uu * u1 * u1 + b_u * u2);
    let (c1, c2) = (c_u * u1, c_uu * u1 * u1 + c_u * u2);
    // g = φ × φ̇, h = φ × g and their rates (φ̇ × φ̇ = 0).
    let g = phi.cross(d1);
    let g1 = phi.cross(d2);
    let g2 = d1.cross(d2) + phi.cross(d3);
    let h = phi.cross(&g);
    let h1 = d1.cross(&g) + phi.cross(&g1);
    let h2 = d2.cross(&g) + d1.cross(&g1) * 2.0 + phi.cross(&g2);
    [
        d1 + g * b + h * c,
        d2 + g * b1 + g1 * b + h * c1 + h1 * c,
        d3 + g * b2 + g1 * (2.0 * b1) + g2 * b + h * c2 + h1 * (2.0 * c1) + h2 * c,
    ]
}

/// Number of series terms for $b(u)$, $c(u)$.
const N_SERIES: usize = 30;

/// $a_k = (-1)^k / (2k + m)!$, $k = 0 \dots N-1$.
const fn alternating_inverse_factorials(m: usize) -> [f64; N_SERIES] {
    let mut a = [0.0; N_SERIES];
    let mut f = 1.0;
    let mut i = 2;
    while i <= m {
        f *= i as f64;
        i += 1;
    }
    a[0] = 1.0 / f;
    let mut k = 1;
    while k < N_SERIES {
        a[k] = -a[k - 1] / (((2 * k + m - 1) * (2 * k + m)) as f64);
        k += 1;
    }
    a
}

/// $b(u) = (1 - \cos\theta)/\theta^2 = \sum_k (-1)^k u^k/(2k+2)!$.
const B_SERIES: [f64; N_SERIES] = alternating_inverse_factorials(2);
/// $c(u) = (\theta - \sin\theta)/\theta^3 = \sum_k (-1)^k u^k/(2k+3)!$.
const C_SERIES: [f64; N_SERIES] = alternating_inverse_factorials(3);

/// Below this $u = \theta^2$ ($\theta \le 2\pi$) the series are used.
const SERIES_U: f64 = 4.0 * PI * PI;

/// Terms enough for $u \le \pi^2$ ($\theta \le \pi$, every chart value): the first omitted
/// terms are below 1e-22.
const N_SERIES_PI: usize = 16;

/// A power series and its first two derivatives at `u` (Horner).
#[inline]
fn horner2(a: &[f64], u: f64) -> [f64; 3] {
    let (mut p, mut dp, mut ddp) = (0.0, 0.0, 0.0);
    for k in a.iter().rev() {
        ddp = ddp * u + 2.0 * dp;
        dp = dp * u + p;
        p = p * u + k;
    }
    [p, dp, ddp]
}

/// $[b, b', b'', c, c', c'']$ with $' = d/du$, $u = \theta^2 \ge 0$.
#[inline]
fn bc_with_derivatives(u: f64) -> [f64; 6] {
    if u <= PI * PI {
        let [b, b1, b2] = horner2(&B_SERIES[..N_SERIES_PI], u);
        let [c, c1, c2] = horner2(&C_SERIES[..N_SERIES_PI], u);
        return [b, b1, b2, c, c1, c2];
    }
    if u <= SERIES_U {
        let [b, b1, b2] = horner2(&B_SERIES, u);
        let [c, c1, c2] = horner2(&C_SERIES, u);
        return [b, b1, b2, c, c1, c2];
    }
    // θ > 2π: closed forms through θ-derivatives, f'(u) = f_θ/(2θ),
    // f''(u) = (θ f_θθ − f_θ)/(4θ³).
    let t = u.sqrt();
    let (s, co) = t.sin_cos();
    let (t2, t3, t4, t5) = (u, u * t, u * u, u * u * t);
    let omc = 1.0 - co;
    let tms = t - s;
    let b = omc / t2;
    let b_t = s / t2 - 2.0 * omc / t3;
    let b_tt = co / t2 - 4.0 * s / t3 + 6.0 * omc / t4;
    let c = tms / t3;
    let c_t = omc / t3 - 3.0 * tms / t4;
    let c_tt = s / t3 - 6.0 * omc / t4 + 12.0 * tms / t5;
    [
        b,
        b_t / (2.0 * t),
        (t * b_tt - b_t) / (4.0 * t3),
        c,
        c_t / (2.0 * t),
        (t * c_tt - c_t) / (4.0 * t3),
    ]
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// The spline's sample at the midpoint of segment `[ta, tb]`, if that midpoint is strictly
/// inside it (the planar spline holds its first value at the first knot, so the derivatives
/// of a segment are read inside it).
fn segment_midpoint(
    sp: &Spline,
    ta: f64,
    tb: f64,
) -> Option<crate::reference::planar::path::PathSample> {
    let tm = ta + 0.5 * (tb - ta);
    (tm > ta && tm < tb).then(|| sp.sample(tm))
}

/// `q` or `−q` (the same rotation), whichever is on `near`'s side of the quaternion sphere.
fn same_sign(q: &UnitQuaternion<f64>, near: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if q.coords.dot(&near.coords) < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        *q
    }
}

/// `|Log(R_refᵀ R)|` componentwise.
fn chart_abs(r: &UnitQuaternion<f64>, r_ref: &UnitQuaternion<f64>) -> Vector3<f64> {
    log_quat(&(r_ref.inverse() * r)).abs()
}

/// Rigorous bound on $|\mathrm{Log}(R_{ref}^T R(t))_j|$ over $[t_0, t_1]$ from `n + 1` samples,
/// given $|\omega| \le$ `w_max` there (module doc).
fn sampled_rotation_bound(
    r_at: impl Fn(f64) -> UnitQuaternion<f64>,
    r_ref: &UnitQuaternion<f64>,
    t0: f64,
    t1: f64,
    w_max: f64,
    n: usize,
) -> Vector3<f64> {
    let ref_inv = r_ref.inverse();
    let mut m = Vector3::<f64>::zeros();
    let mut angle: f64 = 0.0;
    for k in 0..=n {
        let t = if k == n {
            t1
        } else {
            t0 + (t1 - t0) * (k as f64 / n as f64)
        };
        let phi = log_quat(&(ref_inv * r_at(t)));
        m = m.sup(&phi.abs());
        angle = angle.max(phi.norm());
    }
    // Half the spacing, rounded up a little.
    let reach = w_max * (t1 - t0) / (2.0 * n as f64) * (1.0 + 1e-12);
    if !(angle + reach < PI) {
        // The chart may wrap between samples: |φ_j| ≤ |φ| ≤ π always.
        return Vector3::repeat(PI);
    }
    (m + Vector3::repeat(FRAC_PI_2 * reach)).inf(&Vector3::repeat(PI))
}

/// Check `value` is finite, naming `param` otherwise.
fn finite(param: &str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ModelError::invalid(param, value, "must be finite"))
    }
}

/// Check every component is finite, naming `param[j]` otherwise.
fn finite_vec(param: &str, v: &Vector3<f64>) -> Result<(), ModelError> {
    for j in 0..3 {
        finite(&format!("{param}[{j}]"), v[j])?;
    }
    Ok(())
}

/// A finite vector of norm 1 ± [`UNIT_TOL`], returned normalised.
fn unit_vec(param: &str, v: &Vector3<f64>) -> Result<Vector3<f64>, ModelError> {
    finite_vec(param, v)?;
    let n = v.norm();
    if !((n - 1.0).abs() <= UNIT_TOL) {
        return Err(ModelError::invalid(
            param,
            n,
            "must be a unit vector (the value is its norm; 1 ± 1e-9 accepted)",
        ));
    }
    Ok(v / n)
}

/// A finite quaternion of norm 1 ± [`UNIT_TOL`], returned renormalised.
fn unit_quat(param: &str, q: &UnitQuaternion<f64>) -> Result<UnitQuaternion<f64>, ModelError> {
    let c = q.quaternion().coords;
    if let Some(x) = c.iter().find(|x| !x.is_finite()) {
        return Err(ModelError::invalid(param, *x, "must be finite"));
    }
    let n = c.norm();
    if !((n - 1.0).abs() <= UNIT_TOL) {
        return Err(ModelError::invalid(
            param,
            n,
            "must be a unit quaternion (the value is its norm; 1 ± 1e-9 accepted)",
        ));
    }
    Ok(UnitQuaternion::new_unchecked(q.quaternion() / n))
}

/// Check a derivative bound is finite, naming the rate `param` otherwise.
fn no_overflow(param: &str, rate: f64, bound: f64) -> Result<(), ModelError> {
    if bound.is_finite() {
        Ok(())
    } else {
        Err(ModelError::invalid(
            param,
            rate,
            "is so large that the path's derivatives overflow",
        ))
    }
}

/// Check a periodic path's phase: finite and at most [`MAX_PHASE`] in magnitude.
fn phase_angle(param: &str, phase: f64) -> Result<f64, ModelError> {
    finite(param, phase)?;
    if phase.abs() > MAX_PHASE {
        return Err(ModelError::invalid(
            param,
            phase,
            "must be at most 1e9 rad in magnitude (a larger angle has no resolution left: reduce it modulo 2π)",
        ));
    }
    Ok(phase)
}

/// Range `[lo, hi]` of the angle $\omega t + \varphi_0$ over $t \in [0, t_{end}]$ (ω > 0).
fn angle_range(omega: f64, phase: f64, t_end: f64) -> (f64, f64) {
    let last = omega * t_end + phase;
    (phase.min(last), phase.max(last))
}

/// $\max |c + A\cos\psi|$ over the multiples of π in $[lo, hi]$ (the interior extrema; 0 if
/// there are none), in closed form as the planar paths' bound: a full turn, an infinite or
/// NaN range, or angles too large to resolve π give $|c| + |A|$. The caller adds the ends.
fn interior_max_abs_cos(c: f64, amp: f64, lo: f64, hi: f64) -> f64 {
    const RESOLVED: f64 = 1e12;
    if !(hi - lo < TAU) || !(lo.abs().max(hi.abs()) < RESOLVED) {
        return c.abs() + amp.abs();
    }
    let mut m: f64 = 0.0;
    let k0 = (lo / PI).ceil();
    for k in [k0, k0 + 1.0] {
        if k * PI <= hi {
            let cos_k = if k.rem_euclid(2.0) == 0.0 { 1.0 } else { -1.0 };
            m = m.max((c + amp * cos_k).abs());
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_and_closed_forms_agree_near_two_pi() {
        // Both forms at θ = 2π ± a little: the series' truncation is < 1e-35 and its rounding
        // ~ 2.3 ε; the closed forms cancel little there. Compared in absolute terms against the
        // size of each coefficient's leading scale.
        for t in [2.0 * PI - 1e-3, 2.0 * PI, 2.0 * PI + 1e-3, 5.0, 4.0] {
            let u = t * t;
            let s = {
                let [b, b1, b2] = horner2(&B_SERIES, u);
                let [c, c1, c2] = horner2(&C_SERIES, u);
                [b, b1, b2, c, c1, c2]
            };
            // Force the closed form.
            let closed = {
                let tt = u.sqrt();
                let (sn, co) = tt.sin_cos();
                let (t2, t3, t4, t5) = (u, u * tt, u * u, u * u * tt);
                let omc = 1.0 - co;
                let tms = tt - sn;
                let b_t = sn / t2 - 2.0 * omc / t3;
                let b_tt = co / t2 - 4.0 * sn / t3 + 6.0 * omc / t4;
                let c_t = omc / t3 - 3.0 * tms / t4;
                let c_tt = sn / t3 - 6.0 * omc / t4 + 12.0 * tms / t5;
                [
                    omc / t2,
                    b_t / (2.0 * tt),
                    (tt * b_tt - b_t) / (4.0 * t3),
                    tms / t3,
                    c_t / (2.0 * tt),
                    (tt * c_tt - c_t) / (4.0 * t3),
                ]
            };
            for i in 0..6 {
                assert!(
                    (s[i] - closed[i]).abs() < 1e-14,
                    "θ = {t}, coefficient {i}: series {} closed {}",
                    s[i],
                    closed[i]
                );
            }
        }
    }

    #[test]
    fn short_series_suffice_up_to_pi() {
        for u in [0.5, 4.0, PI * PI] {
            for a in [&B_SERIES, &C_SERIES] {
                let short = horner2(&a[..N_SERIES_PI], u);
                let long = horner2(a, u);
                for i in 0..3 {
                    assert!(
                        (short[i] - long[i]).abs() < 1e-17,
                        "u = {u}, derivative {i}"
                    );
                }
            }
        }
    }

    #[test]
    fn series_values_at_zero() {
        let [b, b1, b2, c, c1, c2] = bc_with_derivatives(0.0);
        assert_eq!(b, 0.5);
        assert!((b1 + 1.0 / 24.0).abs() < 1e-18);
        assert!((b2 - 2.0 / 720.0).abs() < 1e-18);
        assert!((c - 1.0 / 6.0).abs() < 1e-18);
        assert!((c1 + 1.0 / 120.0).abs() < 1e-18);
        assert!((c2 - 2.0 / 5040.0).abs() < 1e-18);
    }

    #[test]
    fn interior_extrema_closed_form() {
        assert_eq!(interior_max_abs_cos(0.1, 0.2, 1e20, 1e20 + 1.0), 0.1 + 0.2);
        assert_eq!(
            interior_max_abs_cos(0.1, 0.2, 0.0, f64::INFINITY),
            0.1 + 0.2
        );
        assert_eq!(interior_max_abs_cos(0.0, 1.0, 3.0, 3.5), 1.0);
        assert_eq!(interior_max_abs_cos(0.5, 1.0, -0.1, 0.1), 1.5);
        assert_eq!(interior_max_abs_cos(0.5, 1.0, 0.1, 0.2), 0.0);
        assert_eq!(interior_max_abs_cos(0.2, 1.0, -0.1, PI + 0.1), 1.2);
    }
}
