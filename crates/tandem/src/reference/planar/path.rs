//! Desired object trajectories $x_d(t) = (x, y, \theta)$ with analytic derivatives up to third
//! order.
//!
//! $$x_d(t), \quad \dot x_d(t), \quad \ddot x_d(t), \quad \dddot x_d(t)$$
//!
//! Step 2 of the control tick (SPEC §3) evaluates the desired object path and its derivatives
//! analytically, never by finite differences: the admittance generator (paper (16)–(21)) offsets
//! $x_d$, the iBLF law (paper (31)–(35)) needs $\dot x_r$ and, through $\dot\alpha$, $\ddot x_r$;
//! the jerk is there for anything that differentiates once more (a feed-forward, a computed-torque
//! baseline). Data flow: `t → (x_d, ẋ_d, ẍ_d, x⃛_d)`.
//!
//! Four shapes, all built through validating constructors that name the offending parameter
//! ([`ModelError`]) and all sampled without allocation:
//!
//! | shape | constructor | smoothness |
//! |---|---|---|
//! | circle, constant θ (the paper's path, Section V) | [`Path::circle`], [`Path::paper`] | $C^\infty$ |
//! | rest-to-rest quintic between two poses | [`Path::point_to_point`] | $C^2$ (jerk jumps at both ends) |
//! | Gerono lemniscate (figure eight), constant θ | [`Path::lemniscate`] | $C^\infty$ |
//! | clamped cubic spline through timed waypoints | [`Path::spline`] | $C^2$ inside, $C^1$ at the ends |
//!
//! [`Path::max_abs`] gives the largest $|x_{d,j}|$ reached over $[0, t_{end}]$ (analytic for all
//! four shapes), used to check that the output constraint $k_c$ of the iBLF (SPEC §3.3) lies
//! above the path's reach.
//!
//! The paper's path is $x_d = (0.2 \cos 0.1t,\ 0.2 \sin 0.1t,\ 0)$ (SPEC §4: the paper's text
//! says radius 0.1; its formula, used here, gives 0.2).
//!
//! Units: m, m, rad and their time derivatives (SI, see the crate's `notation` module).
//!
//! # References
//! 1. The paper, Section V-A (desired trajectory).
//! 2. SPEC §3 (control tick, step 2) and §4 (paper scenario).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::{Vector2, Vector3};

use crate::error::{ModelError, positive};

/// The desired object pose and its first three time derivatives at one instant.
///
/// Each field is a 3-vector `(x, y, θ)`: pose in m, m, rad; then m/s, rad/s; m/s², rad/s²;
/// m/s³, rad/s³.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathSample {
    /// Pose $x_d = (x, y, \theta)$ [m, m, rad].
    pub p: Vector3<f64>,
    /// Velocity $\dot x_d$ [m/s, m/s, rad/s].
    pub v: Vector3<f64>,
    /// Acceleration $\ddot x_d$ [m/s², m/s², rad/s²].
    pub a: Vector3<f64>,
    /// Jerk $\dddot x_d$ [m/s³, m/s³, rad/s³].
    pub j: Vector3<f64>,
}

impl PathSample {
    /// A pose held still: all derivatives zero.
    pub fn hold(p: Vector3<f64>) -> Self {
        PathSample {
            p,
            v: Vector3::zeros(),
            a: Vector3::zeros(),
            j: Vector3::zeros(),
        }
    }
}

/// A desired object trajectory. Build it with the validating constructors ([`Path::circle`],
/// [`Path::point_to_point`], [`Path::lemniscate`], [`Path::spline`], [`Path::paper`]); sample
/// it with [`Path::sample`].
#[derive(Clone, Debug, PartialEq)]
pub enum Path {
    /// Circle at constant angular rate, constant orientation.
    Circle(Circle),
    /// Rest-to-rest quintic between two poses.
    PointToPoint(PointToPoint),
    /// Gerono lemniscate (figure eight), constant orientation.
    Lemniscate(Lemniscate),
    /// Clamped cubic spline through timed waypoints.
    Spline(Spline),
}

impl Path {
    /// The paper's path (Section V, SPEC §4): centre (0, 0), radius 0.2 m, ω = 0.1 rad/s,
    /// phase 0, θ = 0.
    pub fn paper() -> Path {
        Path::Circle(Circle {
            center: Vector2::zeros(),
            radius: 0.2,
            omega: 0.1,
            phase: 0.0,
            theta: 0.0,
        })
    }

    /// A circle; see [`Circle::new`].
    pub fn circle(
        center: Vector2<f64>,
        radius: f64,
        omega: f64,
        phase: f64,
        theta: f64,
    ) -> Result<Path, ModelError> {
        Circle::new(center, radius, omega, phase, theta).map(Path::Circle)
    }

    /// A rest-to-rest quintic; see [`PointToPoint::new`].
    pub fn point_to_point(
        from: Vector3<f64>,
        to: Vector3<f64>,
        t0: f64,
        duration: f64,
    ) -> Result<Path, ModelError> {
        PointToPoint::new(from, to, t0, duration).map(Path::PointToPoint)
    }

    /// A Gerono lemniscate; see [`Lemniscate::new`].
    pub fn lemniscate(
        center: Vector2<f64>,
        size: f64,
        omega: f64,
        phase: f64,
        theta: f64,
    ) -> Result<Path, ModelError> {
        Lemniscate::new(center, size, omega, phase, theta).map(Path::Lemniscate)
    }

    /// A clamped cubic spline through `(t_k, pose_k)`; see [`Spline::new`].
    pub fn spline(waypoints: &[(f64, Vector3<f64>)]) -> Result<Path, ModelError> {
        Spline::new(waypoints).map(Path::Spline)
    }

    /// Pose and derivatives at time `t` \[s\]. No allocation.
    #[inline]
    pub fn sample(&self, t: f64) -> PathSample {
        match self {
            Path::Circle(c) => c.sample(t),
            Path::PointToPoint(p) => p.sample(t),
            Path::Lemniscate(l) => l.sample(t),
            Path::Spline(s) => s.sample(t),
        }
    }

    /// Componentwise $\max_{t \in [0, t_{end}]} |x_{d,j}(t)|$ [m, m, rad], computed
    /// analytically (exact up to rounding) for every shape.
    ///
    /// Used to check that the iBLF bound $k_c$ (SPEC §3.3) is above the path's reach.
    /// `t_end = +∞` asks for the whole path; `t_end ≤ 0` (or NaN) gives $|x_d(0)|$.
    pub fn max_abs(&self, t_end: f64) -> Vector3<f64> {
        let t_end = if t_end > 0.0 { t_end } else { 0.0 };
        match self {
            Path::Circle(c) => c.max_abs(t_end),
            Path::PointToPoint(p) => p.max_abs(t_end),
            Path::Lemniscate(l) => l.max_abs(t_end),
            Path::Spline(s) => s.max_abs(t_end),
        }
    }
}

impl From<Circle> for Path {
    fn from(c: Circle) -> Path {
        Path::Circle(c)
    }
}
impl From<PointToPoint> for Path {
    fn from(p: PointToPoint) -> Path {
        Path::PointToPoint(p)
    }
}
impl From<Lemniscate> for Path {
    fn from(l: Lemniscate) -> Path {
        Path::Lemniscate(l)
    }
}
impl From<Spline> for Path {
    fn from(s: Spline) -> Path {
        Path::Spline(s)
    }
}

// ---------------------------------------------------------------------------------------------
// Circle
// ---------------------------------------------------------------------------------------------

/// Circle at constant angular rate with constant orientation:
/// $p(t) = c + r(\cos\varphi, \sin\varphi)$, $\varphi = \omega t + \varphi_0$, $\theta$ constant.
#[derive(Clone, Debug, PartialEq)]
pub struct Circle {
    center: Vector2<f64>,
    radius: f64,
    omega: f64,
    phase: f64,
    theta: f64,
}

impl Circle {
    /// Validate and build.
    ///
    /// - `center` \[m\]: finite (`circle.center[i]`);
    /// - `radius` \[m\]: finite and > 0 (`circle.radius`); a still pose is
    ///   [`Path::point_to_point`] with `from == to`;
    /// - `omega` \[rad/s\]: finite, any sign (positive is counter-clockwise), zero allowed
    ///   (`circle.omega`);
    /// - `phase` $\varphi_0$ \[rad\], `theta` \[rad\]: finite (`circle.phase`, `circle.theta`).
    pub fn new(
        center: Vector2<f64>,
        radius: f64,
        omega: f64,
        phase: f64,
        theta: f64,
    ) -> Result<Self, ModelError> {
        finite("circle.center[0]", center.x)?;
        finite("circle.center[1]", center.y)?;
        positive("circle.radius", radius)?;
        rate("circle.omega", omega, radius, 1.0)?;
        phase_angle("circle.phase", phase)?;
        finite("circle.theta", theta)?;
        Ok(Circle {
            center,
            radius,
            omega,
            phase,
            theta,
        })
    }
    /// Centre \[m\].
    pub fn center(&self) -> Vector2<f64> {
        self.center
    }
    /// Radius \[m\].
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Angular rate ω \[rad/s\].
    pub fn omega(&self) -> f64 {
        self.omega
    }
    /// Phase $\varphi_0$ at t = 0 \[rad\].
    pub fn phase(&self) -> f64 {
        self.phase
    }
    /// Constant orientation θ \[rad\].
    pub fn theta(&self) -> f64 {
        self.theta
    }

    /// Pose and derivatives at `t` \[s\].
    #[inline]
    pub fn sample(&self, t: f64) -> PathSample {
        let (s, c) = crate::math::trig::sin_cos(self.omega * t + self.phase);
        let r = self.radius;
        let rw = r * self.omega;
        let rw2 = rw * self.omega;
        let rw3 = rw2 * self.omega;
        PathSample {
            p: Vector3::new(self.center.x + r * c, self.center.y + r * s, self.theta),
            v: Vector3::new(-rw * s, rw * c, 0.0),
            a: Vector3::new(-rw2 * c, -rw2 * s, 0.0),
            j: Vector3::new(rw3 * s, -rw3 * c, 0.0),
        }
    }

    fn max_abs(&self, t_end: f64) -> Vector3<f64> {
        let (lo, hi) = angle_range(self.omega, self.phase, t_end);
        Vector3::new(
            max_abs_cos(self.center.x, self.radius, lo, hi),
            max_abs_cos(self.center.y, self.radius, lo - FRAC_PI_2, hi - FRAC_PI_2),
            self.theta.abs(),
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Point to point
// ---------------------------------------------------------------------------------------------

/// Rest-to-rest motion between two poses with the quintic time law
/// $s(\tau) = 10\tau^3 - 15\tau^4 + 6\tau^5$, $\tau = (t - t_0)/T$:
/// $p = p_{from} + s(\tau)(p_{to} - p_{from})$; zero velocity and acceleration at both ends.
///
/// Holds `from` for $t \le t_0$ and `to` for $t \ge t_0 + T$. The jerk jumps from 0 to
/// $60 \Delta p/T^3$ at both ends (a quintic cannot do better; velocity and acceleration are
/// continuous). Every component moves monotonically.
#[derive(Clone, Debug, PartialEq)]
pub struct PointToPoint {
    from: Vector3<f64>,
    to: Vector3<f64>,
    t0: f64,
    duration: f64,
}

impl PointToPoint {
    /// Validate and build: `from`, `to` finite (`point_to_point.from[j]`, `.to[j]`), `t0` \[s\]
    /// finite (`point_to_point.t0`), `duration` T \[s\] finite and > 0
    /// (`point_to_point.duration`).
    pub fn new(
        from: Vector3<f64>,
        to: Vector3<f64>,
        t0: f64,
        duration: f64,
    ) -> Result<Self, ModelError> {
        for j in 0..3 {
            finite(&format!("point_to_point.from[{j}]"), from[j])?;
            finite(&format!("point_to_point.to[{j}]"), to[j])?;
        }
        finite("point_to_point.t0", t0)?;
        positive("point_to_point.duration", duration)?;
        // The jerk at the ends is 60 Δp / T³ (and t0 + T must be a time).
        let dp = (to - from).amax();
        if !(60.0 * dp / duration.powi(3)).is_finite() || !(t0 + duration).is_finite() {
            return Err(ModelError::invalid(
                "point_to_point.duration",
                duration,
                "is so short (for this distance) that the path's derivatives overflow",
            ));
        }
        Ok(PointToPoint {
            from,
            to,
            t0,
            duration,
        })
    }
    /// Start pose [m, m, rad].
    pub fn from(&self) -> Vector3<f64> {
        self.from
    }
    /// End pose [m, m, rad].
    pub fn to(&self) -> Vector3<f64> {
        self.to
    }
    /// Start time $t_0$ \[s\].
    pub fn t0(&self) -> f64 {
        self.t0
    }
    /// Duration T \[s\].
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// Pose and derivatives at `t` \[s\]. Exactly `from` for $t \le t_0$ and exactly `to` once
    /// $\tau \ge 1$, with zero derivatives.
    #[inline]
    pub fn sample(&self, t: f64) -> PathSample {
        let tau = (t - self.t0) / self.duration;
        if tau >= 1.0 {
            return PathSample::hold(self.to);
        }
        if tau.is_nan() || tau <= 0.0 {
            // Also catches NaN t: hold the start.
            return PathSample::hold(self.from);
        }
        // s and its τ-derivatives, in Horner form.
        let s = tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau));
        let s1 = 30.0 * tau * tau * (1.0 + tau * (-2.0 + tau));
        let s2 = 60.0 * tau * (1.0 + tau * (-3.0 + 2.0 * tau));
        let s3 = 60.0 * (1.0 + tau * (-6.0 + 6.0 * tau));
        let d = self.to - self.from;
        let inv_t = 1.0 / self.duration;
        PathSample {
            // lerp = from (1 − s) + to s: exact at both ends.
            p: self.from.lerp(&self.to, s),
            v: d * (s1 * inv_t),
            a: d * (s2 * inv_t * inv_t),
            j: d * (s3 * inv_t * inv_t * inv_t),
        }
    }

    fn max_abs(&self, t_end: f64) -> Vector3<f64> {
        // Each component is monotone in t, so |p_j| peaks at an end of [0, t_end].
        self.sample(0.0).p.abs().sup(&self.sample(t_end).p.abs())
    }
}

// ---------------------------------------------------------------------------------------------
// Lemniscate
// ---------------------------------------------------------------------------------------------

/// Lemniscate of Gerono (figure eight) at constant rate, constant orientation:
/// $p(t) = c + a(\sin\varphi,\ \sin\varphi\cos\varphi)$, $\varphi = \omega t + \varphi_0$.
///
/// Gerono rather than Bernoulli because its coordinates are plain sinusoids
/// ($y = c_y + \tfrac{a}{2}\sin 2\varphi$), so every derivative and the reach are closed forms.
/// The curve is $2a$ wide and $a$ high, crosses itself at the centre (at $\varphi = 0, \pi$) and
/// the x-coordinate runs at rate ω, the y-coordinate at 2ω.
#[derive(Clone, Debug, PartialEq)]
pub struct Lemniscate {
    center: Vector2<f64>,
    size: f64,
    omega: f64,
    phase: f64,
    theta: f64,
}

impl Lemniscate {
    /// Validate and build: `center` \[m\] finite (`lemniscate.center[i]`); `size` a \[m\] finite
    /// and > 0 (`lemniscate.size`, half-width of the figure eight); `omega` \[rad/s\], `phase`
    /// \[rad\] and `theta` \[rad\] finite.
    pub fn new(
        center: Vector2<f64>,
        size: f64,
        omega: f64,
        phase: f64,
        theta: f64,
    ) -> Result<Self, ModelError> {
        finite("lemniscate.center[0]", center.x)?;
        finite("lemniscate.center[1]", center.y)?;
        positive("lemniscate.size", size)?;
        rate("lemniscate.omega", omega, size, 4.0)?;
        phase_angle("lemniscate.phase", phase)?;
        finite("lemniscate.theta", theta)?;
        Ok(Lemniscate {
            center,
            size,
            omega,
            phase,
            theta,
        })
    }
    /// Centre (crossing point) \[m\].
    pub fn center(&self) -> Vector2<f64> {
        self.center
    }
    /// Half-width a \[m\].
    pub fn size(&self) -> f64 {
        self.size
    }
    /// Rate ω \[rad/s\].
    pub fn omega(&self) -> f64 {
        self.omega
    }
    /// Phase $\varphi_0$ at t = 0 \[rad\].
    pub fn phase(&self) -> f64 {
        self.phase
    }
    /// Constant orientation θ \[rad\].
    pub fn theta(&self) -> f64 {
        self.theta
    }

    /// Pose and derivatives at `t` \[s\].
    #[inline]
    pub fn sample(&self, t: f64) -> PathSample {
        let phi = self.omega * t + self.phase;
        let [(s1, c1), (s2, c2)] = crate::math::trig::sin_cos2(phi, 2.0 * phi);
        let a = self.size;
        let w = self.omega;
        let aw = a * w;
        let aw2 = aw * w;
        let aw3 = aw2 * w;
        PathSample {
            p: Vector3::new(
                self.center.x + a * s1,
                self.center.y + 0.5 * a * s2,
                self.theta,
            ),
            v: Vector3::new(aw * c1, aw * c2, 0.0),
            a: Vector3::new(-aw2 * s1, -2.0 * aw2 * s2, 0.0),
            j: Vector3::new(-aw3 * c1, -4.0 * aw3 * c2, 0.0),
        }
    }

    fn max_abs(&self, t_end: f64) -> Vector3<f64> {
        let (lo, hi) = angle_range(self.omega, self.phase, t_end);
        Vector3::new(
            max_abs_cos(self.center.x, self.size, lo - FRAC_PI_2, hi - FRAC_PI_2),
            max_abs_cos(
                self.center.y,
                0.5 * self.size,
                2.0 * lo - FRAC_PI_2,
                2.0 * hi - FRAC_PI_2,
            ),
            self.theta.abs(),
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Spline
// ---------------------------------------------------------------------------------------------

/// Cubic spline through timed waypoints $(t_k, x_k)$, $k = 0 \dots n-1$, in all three
/// coordinates, **clamped with zero end velocity**.
///
/// Clamped rather than natural so that the path starts and ends at rest: holding the end poses
/// outside $[t_0, t_{n-1}]$ then keeps the velocity continuous. Inside, the spline is $C^2$
/// (value, slope and curvature continuous at every knot); at the two ends the acceleration jumps
/// to the held value 0 (a cubic spline cannot also clamp it). The jerk is piecewise constant.
///
/// The knot second derivatives $m_k$ solve the usual tridiagonal system (strictly diagonally
/// dominant, so the Thomas algorithm needs no pivoting), once at construction; each segment is
/// then stored as power-basis coefficients in $\tau = t - t_k$. Sampling is a binary search over
/// the knots plus a Horner evaluation: no allocation.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline {
    /// Knot times $t_0 < \dots < t_{n-1}$ \[s\].
    knots: Vec<f64>,
    /// Segment k: $x(t) = c_0 + c_1\tau + c_2\tau^2 + c_3\tau^3$, $\tau = t - t_k$.
    coef: Vec<[Vector3<f64>; 4]>,
    /// Last waypoint, held for $t \ge t_{n-1}$.
    end: Vector3<f64>,
}

impl Spline {
    /// Validate and build from `(t_k, pose_k)` pairs (`t` \[s\], pose [m, m, rad]).
    ///
    /// Errors name the field: at least 2 waypoints (`spline.waypoints`), every time finite and
    /// strictly greater than the previous one (`spline.waypoints[k].t`), every pose component
    /// finite (`spline.waypoints[k].pose[j]`).
    pub fn new(waypoints: &[(f64, Vector3<f64>)]) -> Result<Self, ModelError> {
        let n = waypoints.len();
        if n < 2 {
            return Err(ModelError::invalid(
                "spline.waypoints",
                n as f64,
                "need at least 2 waypoints",
            ));
        }
        for (k, (t, pose)) in waypoints.iter().enumerate() {
            finite(&format!("spline.waypoints[{k}].t"), *t)?;
            if k > 0 && *t <= waypoints[k - 1].0 {
                return Err(ModelError::invalid(
                    format!("spline.waypoints[{k}].t"),
                    *t,
                    format!(
                        "times must increase strictly (waypoints[{}].t = {})",
                        k - 1,
                        waypoints[k - 1].0
                    ),
                ));
            }
            for j in 0..3 {
                finite(&format!("spline.waypoints[{k}].pose[{j}]"), pose[j])?;
            }
        }

        let knots: Vec<f64> = waypoints.iter().map(|w| w.0).collect();
        let y: Vec<Vector3<f64>> = waypoints.iter().map(|w| w.1).collect();
        let h: Vec<f64> = knots.windows(2).map(|w| w[1] - w[0]).collect();
        // Secant slopes d_k = (y_{k+1} − y_k)/h_k.
        let d: Vec<Vector3<f64>> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();

        // Tridiagonal system for the knot second derivatives m_k (sub, diag, sup, rhs):
        //   row 0:    2h_0 m_0 + h_0 m_1                       = 6 (d_0 − v_start),  v_start = 0
        //   row k:    h_{k−1} m_{k−1} + 2(h_{k−1}+h_k) m_k + h_k m_{k+1} = 6 (d_k − d_{k−1})
        //   row n−1:  h_{n−2} m_{n−2} + 2h_{n−2} m_{n−1}       = 6 (v_end − d_{n−2}), v_end = 0
        let mut sub = vec![0.0; n];
        let mut diag = vec![0.0; n];
        let mut sup = vec![0.0; n];
        let mut rhs = vec![Vector3::zeros(); n];
        diag[0] = 2.0 * h[0];
        sup[0] = h[0];
        rhs[0] = d[0] * 6.0;
        for k in 1..n - 1 {
            sub[k] = h[k - 1];
            diag[k] = 2.0 * (h[k - 1] + h[k]);
            sup[k] = h[k];
            rhs[k] = (d[k] - d[k - 1]) * 6.0;
        }
        sub[n - 1] = h[n - 2];
        diag[n - 1] = 2.0 * h[n - 2];
        rhs[n - 1] = -d[n - 2] * 6.0;

        // Thomas algorithm: forward elimination, back substitution.
        for k in 1..n {
            let w = sub[k] / diag[k - 1];
            diag[k] -= w * sup[k - 1];
            let r = rhs[k - 1] * w;
            rhs[k] -= r;
        }
        let mut m = vec![Vector3::zeros(); n];
        m[n - 1] = rhs[n - 1] / diag[n - 1];
        for k in (0..n - 1).rev() {
            m[k] = (rhs[k] - m[k + 1] * sup[k]) / diag[k];
        }

        // Power-basis coefficients per segment.
        let coef = (0..n - 1)
            .map(|k| {
                let hk = h[k];
                [
                    y[k],
                    d[k] - (m[k] * 2.0 + m[k + 1]) * (hk / 6.0),
                    m[k] * 0.5,
                    (m[k + 1] - m[k]) / (6.0 * hk),
                ]
            })
            .collect();
        let coef: Vec<[Vector3<f64>; 4]> = coef;
        if let Some(k) = coef
            .iter()
            .position(|c| c.iter().any(|v| !v.iter().all(|x| x.is_finite())))
        {
            return Err(ModelError::invalid(
                format!("spline.waypoints[{}].t", k + 1),
                knots[k + 1],
                "is so close to the previous waypoint (for this pose change) that the path's derivatives overflow",
            ));
        }
        Ok(Spline {
            knots,
            coef,
            end: y[n - 1],
        })
    }

    /// Knot times \[s\].
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// Pose and derivatives at `t` \[s\]; holds the first pose for $t \le t_0$ and the last for
    /// $t \ge t_{n-1}$ (zero derivatives there). Passes through the waypoints exactly.
    #[inline]
    pub fn sample(&self, t: f64) -> PathSample {
        let n = self.knots.len();
        if t >= self.knots[n - 1] {
            return PathSample::hold(self.end);
        }
        if t.is_nan() || t <= self.knots[0] {
            return PathSample::hold(self.coef[0][0]);
        }
        // Segment k with t_k <= t < t_{k+1}.
        let k = self.knots.partition_point(|&tk| tk <= t) - 1;
        self.eval_segment(k, t - self.knots[k])
    }

    /// Segment `k` at local time `tau` (no hold logic).
    #[inline]
    fn eval_segment(&self, k: usize, tau: f64) -> PathSample {
        let [c0, c1, c2, c3] = &self.coef[k];
        PathSample {
            p: c0 + (c1 + (c2 + c3 * tau) * tau) * tau,
            v: c1 + (c2 * 2.0 + c3 * (3.0 * tau)) * tau,
            a: c2 * 2.0 + c3 * (6.0 * tau),
            j: c3 * 6.0,
        }
    }

    fn max_abs(&self, t_end: f64) -> Vector3<f64> {
        // Ends of [0, t_end] (covers the hold regions), then per segment the ends of its part of
        // [0, t_end] and the real roots of the derivative quadratic inside it.
        let mut best = self.sample(0.0).p.abs().sup(&self.sample(t_end).p.abs());
        for (k, seg) in self.coef.iter().enumerate() {
            let lo = (self.knots[k].max(0.0)) - self.knots[k];
            let hi = self.knots[k + 1].min(t_end) - self.knots[k];
            if hi <= lo {
                continue;
            }
            for tau in [lo, hi] {
                best = best.sup(&self.eval_segment(k, tau).p.abs());
            }
            for j in 0..3 {
                // x'(τ) = c1 + 2 c2 τ + 3 c3 τ² = 0, stable quadratic formula.
                let (qa, qb, qc) = (3.0 * seg[3][j], 2.0 * seg[2][j], seg[1][j]);
                let disc = qb * qb - 4.0 * qa * qc;
                if disc < 0.0 {
                    continue;
                }
                let q = -0.5 * (qb + qb.signum() * disc.sqrt());
                for tau in [q / qa, qc / q] {
                    if tau > lo && tau < hi {
                        let x = seg[0][j] + (seg[1][j] + (seg[2][j] + seg[3][j] * tau) * tau) * tau;
                        best[j] = best[j].max(x.abs());
                    }
                }
            }
        }
        best
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// Check `value` is finite, naming `param` otherwise.
fn finite(param: &str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ModelError::invalid(param, value, "must be finite"))
    }
}

/// Range `[lo, hi]` of the angle $\omega t + \varphi_0$ over $t \in [0, t_{end}]$.
fn angle_range(omega: f64, phase: f64, t_end: f64) -> (f64, f64) {
    // ω = 0 with t_end = ∞ would give NaN.
    let last = if omega == 0.0 {
        phase
    } else {
        omega * t_end + phase
    };
    (phase.min(last), phase.max(last))
}

/// Largest |angle| \[rad\] a periodic path accepts for its phase: beyond it the rounding step
/// of an `f64` angle exceeds 1e-7 rad, so the phase is no longer an angle (reduce it mod 2π).
pub const MAX_PHASE: f64 = 1e9;

/// Check a periodic path's angular rate: finite, with the jerk `amp·ω³` (its largest
/// derivative, times `gain`) finite too.
fn rate(param: &str, omega: f64, amp: f64, gain: f64) -> Result<f64, ModelError> {
    finite(param, omega)?;
    if !(gain * amp * omega.abs().powi(3)).is_finite() {
        return Err(ModelError::invalid(
            param,
            omega,
            "is so large that the path's derivatives overflow",
        ));
    }
    Ok(omega)
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

/// $\max_{\psi \in [lo, hi]} |c + A\cos\psi|$: the ends of the range and the extrema of cos
/// (multiples of π) inside it, in closed form (no loop over the angle's magnitude).
fn max_abs_cos(c: f64, amp: f64, lo: f64, hi: f64) -> f64 {
    // A full turn, an infinite / NaN range, or angles too large to resolve π (their rounding
    // step exceeds 1e-3 rad): both extremes are (or may be) reached.
    const RESOLVED: f64 = 1e12;
    if !(hi - lo < TAU) || !(lo.abs().max(hi.abs()) < RESOLVED) {
        return c.abs() + amp.abs();
    }
    let mut m = (c + amp * lo.cos()).abs().max((c + amp * hi.cos()).abs());
    // At most two multiples of π in a range shorter than 2π: k0 π and (k0 + 1) π.
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
    use proptest::prelude::*;

    const EPS: f64 = f64::EPSILON;

    /// Central-difference check of one derivative.
    ///
    /// $\frac{f(t+\delta) - f(t-\delta)}{2\delta} = f'(t) + \frac{\delta^2}{6} f'''(\xi)$, so the
    /// truncation error is at most $\delta^2 \max|f'''| / 6$; rounding adds about
    /// $\varepsilon \max|f| / \delta$. `next_bound` bounds $|f'''|$ (the derivative two orders
    /// above the one differenced), `scale` bounds $|f|$. The tolerance is twice the sum.
    fn assert_fd(
        what: &str,
        t: f64,
        delta: f64,
        (f_minus, f_plus): (Vector3<f64>, Vector3<f64>),
        df: Vector3<f64>,
        next_bound: f64,
        scale: f64,
    ) {
        let fd = (f_plus - f_minus) / (2.0 * delta);
        let tol = 2.0 * (delta * delta / 6.0 * next_bound + 4.0 * EPS * scale / delta);
        for j in 0..3 {
            assert!(
                (fd[j] - df[j]).abs() <= tol,
                "{what} at t={t}, comp {j}: fd {} vs analytic {} (tol {tol:e})",
                fd[j],
                df[j]
            );
        }
    }

    /// Check v, a, j against central differences of p, v, a at `t`. `bounds[n]` bounds the n-th
    /// derivative of every component (n = 0..=5).
    fn check_derivatives(path: &Path, t: f64, delta: f64, bounds: [f64; 6]) {
        let m = path.sample(t - delta);
        let c = path.sample(t);
        let p = path.sample(t + delta);
        assert_fd("v", t, delta, (m.p, p.p), c.v, bounds[3], bounds[0]);
        assert_fd("a", t, delta, (m.v, p.v), c.a, bounds[4], bounds[1]);
        assert_fd("j", t, delta, (m.a, p.a), c.j, bounds[5], bounds[2]);
    }

    #[test]
    fn paper_circle_values() {
        let path = Path::paper();
        let s = path.sample(0.0);
        assert_eq!(s.p, Vector3::new(0.2, 0.0, 0.0));
        assert!((s.v - Vector3::new(0.0, 0.02, 0.0)).norm() < 1e-17);
        let t = 5.0 * PI; // quarter turn at ω = 0.1
        let s = path.sample(t);
        assert!((s.p - Vector3::new(0.0, 0.2, 0.0)).norm() < 1e-15);
        assert!((s.a - Vector3::new(0.0, -0.002, 0.0)).norm() < 1e-17);
    }

    #[test]
    fn circle_derivatives_match_finite_differences() {
        let (r, w) = (0.3, 2.0);
        let path = Path::circle(Vector2::new(0.1, -0.2), r, w, 0.4, 0.7).unwrap();
        // |p^(n) − centre| ≤ r ωⁿ; |p| ≤ |c| + r + |θ|.
        let scale0 = 0.3 + r + 0.7;
        let b = [
            scale0,
            r * w,
            r * w.powi(2),
            r * w.powi(3),
            r * w.powi(4),
            r * w.powi(5),
        ];
        for i in 0..50 {
            check_derivatives(&path, -1.0 + 0.173 * i as f64, 1e-4, b);
        }
    }

    #[test]
    fn lemniscate_derivatives_match_finite_differences() {
        let (a, w) = (0.25, 1.5);
        let path = Path::lemniscate(Vector2::new(0.05, 0.1), a, w, 0.3, -0.2).unwrap();
        // x^(n) ≤ a ωⁿ, y^(n) ≤ (a/2)(2ω)ⁿ: the y bound dominates for n ≥ 1.
        let bn = |n: i32| 0.5 * a * (2.0 * w).powi(n);
        let b = [0.1 + a + 0.2, bn(1), bn(2), bn(3), bn(4), bn(5)];
        for i in 0..50 {
            check_derivatives(&path, -1.0 + 0.191 * i as f64, 1e-4, b);
        }
    }

    #[test]
    fn lemniscate_is_a_figure_eight() {
        let a = 0.3;
        let path = Path::lemniscate(Vector2::new(0.1, 0.2), a, 1.0, 0.0, 0.0).unwrap();
        // Crosses the centre at φ = 0 and φ = π; x extreme ±a at φ = ±π/2 with y at centre.
        assert!((path.sample(0.0).p - Vector3::new(0.1, 0.2, 0.0)).norm() < 1e-16);
        assert!((path.sample(PI).p - Vector3::new(0.1, 0.2, 0.0)).norm() < 1e-15);
        assert!((path.sample(FRAC_PI_2).p - Vector3::new(0.1 + a, 0.2, 0.0)).norm() < 1e-15);
        // Max height a/2 at φ = π/4.
        assert!((path.sample(PI / 4.0).p.y - (0.2 + a / 2.0)).abs() < 1e-15);
    }

    #[test]
    fn point_to_point_derivatives_match_finite_differences() {
        let from = Vector3::new(0.1, -0.2, 0.3);
        let to = Vector3::new(-0.3, 0.25, -0.5);
        let (t0, dur) = (0.5, 2.0);
        let path = Path::point_to_point(from, to, t0, dur).unwrap();
        // |s^(n)| on [0,1]: s' ≤ 1.875, s'' ≤ 5.78, s''' ≤ 60, s'''' ≤ 360, s''''' = 720; scaled by
        // |Δ|/Tⁿ.
        let dmax = (to - from).amax();
        let sb = [1.0, 1.875, 5.78, 60.0, 360.0, 720.0];
        let mut b = [0.0; 6];
        for n in 0..6 {
            b[n] = dmax * sb[n] / dur.powi(n as i32);
        }
        b[0] = 0.5; // |p| bound
        let delta = 1e-4;
        // Inside the motion, away from the jerk jumps at t0 and t0 + T.
        for i in 1..40 {
            let t = t0 + dur * i as f64 / 40.0;
            check_derivatives(&path, t, delta, b);
        }
        // In the hold regions everything is zero.
        for t in [-1.0, t0 - 0.01, t0 + dur + 0.01, 10.0] {
            check_derivatives(&path, t, delta, b);
        }
    }

    #[test]
    fn quintic_endpoints_exact() {
        let from = Vector3::new(0.1, -0.2, 0.3);
        let to = Vector3::new(-0.3, 0.25, -0.5);
        let path = Path::point_to_point(from, to, 1.0, 4.0).unwrap();
        assert_eq!(path.sample(1.0), PathSample::hold(from));
        assert_eq!(path.sample(0.0), PathSample::hold(from));
        assert_eq!(path.sample(5.0), PathSample::hold(to));
        assert_eq!(path.sample(7.0), PathSample::hold(to));
        // Just inside the ends: the velocity and acceleration go to zero continuously.
        let s = path.sample(1.0 + 1e-9);
        assert!(s.v.norm() < 1e-15 && s.a.norm() < 1e-8);
        let s = path.sample(5.0 - 1e-9);
        assert!((s.p - to).norm() < 1e-15 && s.v.norm() < 1e-15 && s.a.norm() < 1e-8);
        // Midpoint: s(1/2) = 1/2, zero acceleration, peak speed 15/8 Δ/T.
        let s = path.sample(3.0);
        assert!((s.p - (from + to) / 2.0).norm() < 1e-16);
        assert!(s.a.norm() < 1e-16);
        assert!((s.v - (to - from) * (1.875 / 4.0)).norm() < 1e-16);
    }

    fn test_waypoints() -> Vec<(f64, Vector3<f64>)> {
        vec![
            (0.0, Vector3::new(0.0, 0.0, 0.0)),
            (0.7, Vector3::new(0.1, 0.05, 0.2)),
            (1.5, Vector3::new(0.15, -0.1, 0.1)),
            (1.9, Vector3::new(0.05, -0.12, -0.3)),
            (3.0, Vector3::new(-0.2, 0.1, 0.0)),
        ]
    }

    #[test]
    fn spline_passes_through_waypoints_and_is_c2() {
        let wps = test_waypoints();
        let Path::Spline(sp) = Path::spline(&wps).unwrap() else {
            unreachable!()
        };
        for (t, pose) in &wps {
            assert_eq!(sp.sample(*t).p, *pose, "waypoint at t={t}");
        }
        // Left and right limits at interior knots from the two segments' polynomials.
        for k in 1..wps.len() - 1 {
            let h = wps[k].0 - wps[k - 1].0;
            let left = sp.eval_segment(k - 1, h);
            let right = sp.eval_segment(k, 0.0);
            // Values are O(1e-1), slopes O(1), curvatures O(10): relative 1e-13 covers the
            // rounding of the Thomas solve and the power basis.
            assert!((left.p - right.p).amax() < 1e-14, "C0 at knot {k}");
            assert!((left.v - right.v).amax() < 1e-13, "C1 at knot {k}");
            assert!((left.a - right.a).amax() < 1e-12, "C2 at knot {k}");
        }
        // Clamped: zero end velocity from inside.
        let n = wps.len();
        assert!(sp.eval_segment(0, 0.0).v.amax() < 1e-15);
        assert!(sp.eval_segment(n - 2, wps[n - 1].0 - wps[n - 2].0).v.amax() < 1e-13);
        // Holds outside.
        assert_eq!(sp.sample(-1.0), PathSample::hold(wps[0].1));
        assert_eq!(sp.sample(10.0), PathSample::hold(wps[n - 1].1));
    }

    #[test]
    fn spline_derivatives_match_finite_differences() {
        let wps = test_waypoints();
        let path = Path::spline(&wps).unwrap();
        // Bounds from the coefficients (dense sampling of |a| and |j| suffices: jerk is
        // piecewise constant and the fourth derivative is zero inside a segment, so the FD of a
        // is exact up to rounding).
        let mut b = [0.3_f64, 0.0, 0.0, 0.0, 0.0, 0.0];
        for i in 0..=3000 {
            let s = path.sample(i as f64 * 1e-3);
            b[1] = b[1].max(s.v.amax());
            b[2] = b[2].max(s.a.amax());
            b[3] = b[3].max(s.j.amax());
        }
        b[1] *= 1.01;
        b[2] *= 1.01;
        let delta = 1e-4;
        for i in 0..300 {
            let t = 0.0105 * i as f64;
            // Skip points whose stencil straddles a knot (the jerk jumps there).
            if wps.iter().any(|w| (w.0 - t).abs() <= 1.5 * delta) {
                continue;
            }
            check_derivatives(&path, t, delta, b);
        }
    }

    #[test]
    fn two_point_spline_is_the_cubic_hermite() {
        let a = Vector3::new(0.1, 0.2, 0.3);
        let b = Vector3::new(-0.1, 0.4, 0.0);
        let path = Path::spline(&[(1.0, a), (3.0, b)]).unwrap();
        for i in 0..=20 {
            let u = i as f64 / 20.0;
            let s = 3.0 * u * u - 2.0 * u * u * u;
            let want = a + (b - a) * s;
            assert!((path.sample(1.0 + 2.0 * u).p - want).amax() < 1e-15);
        }
    }

    /// Dense-sampling reference for `max_abs`.
    fn sampled_max(path: &Path, t_end: f64, n: usize) -> Vector3<f64> {
        let mut m = Vector3::zeros();
        for i in 0..=n {
            m = m.sup(&path.sample(t_end * i as f64 / n as f64).p.abs());
        }
        m
    }

    #[test]
    fn max_abs_matches_dense_sampling() {
        let paths = [
            (Path::paper(), 90.0),
            (Path::paper(), 10.0),
            (
                Path::circle(Vector2::new(0.05, -0.3), 0.2, -0.7, 1.0, -0.4).unwrap(),
                3.0,
            ),
            (
                Path::circle(Vector2::new(0.05, -0.3), 0.2, 0.0, 1.0, 0.1).unwrap(),
                3.0,
            ),
            (
                Path::lemniscate(Vector2::new(-0.1, 0.02), 0.2, 0.8, 0.3, 0.2).unwrap(),
                2.5,
            ),
            (
                Path::lemniscate(Vector2::new(-0.1, 0.02), 0.2, 0.8, 0.3, 0.2).unwrap(),
                50.0,
            ),
            (
                Path::point_to_point(
                    Vector3::new(0.1, -0.2, 0.3),
                    Vector3::new(-0.3, 0.1, -0.1),
                    0.5,
                    2.0,
                )
                .unwrap(),
                1.7,
            ),
            (
                Path::point_to_point(
                    Vector3::new(0.1, -0.2, 0.3),
                    Vector3::new(-0.3, 0.1, -0.1),
                    -0.5,
                    2.0,
                )
                .unwrap(),
                5.0,
            ),
            (Path::spline(&test_waypoints()).unwrap(), 3.0),
            (Path::spline(&test_waypoints()).unwrap(), 1.2),
        ];
        for (path, t_end) in &paths {
            let exact = path.max_abs(*t_end);
            let n = 200_000;
            let sampled = sampled_max(path, *t_end, n);
            // Sampling can only miss the peak, by at most ½ max|ẍ| (Δt/2)² near a smooth extremum
            // (≤ 1e-9 here) — or by a kink at a sampled end, which is exact.
            for j in 0..3 {
                assert!(
                    exact[j] >= sampled[j] - 1e-15,
                    "{path:?}: {exact} < {sampled}"
                );
                assert!(
                    exact[j] - sampled[j] < 1e-8,
                    "{path:?} comp {j}: {exact} vs {sampled}"
                );
            }
        }
        // Whole path and the paper's bound k_c = 0.35.
        assert_eq!(
            Path::paper().max_abs(f64::INFINITY),
            Vector3::new(0.2, 0.2, 0.0)
        );
        assert!(Path::paper().max_abs(90.0).iter().all(|&m| m < 0.35));
    }

    #[test]
    fn max_abs_is_closed_form_for_huge_angles() {
        // Issue "validate never returns for a phase of 1e20": the loop stopped advancing.
        for (lo, hi) in [
            (1e20, 1e20 + 1.0),
            (-1e308, -1e308),
            (9.223372036854776e18, 9.223372036854776e18),
            (1e12, 1e12 + 1.0),
        ] {
            assert_eq!(max_abs_cos(0.1, 0.2, lo, hi), 0.1 + 0.2 + 0.0);
        }
        // Resolved ranges: exact extrema, both multiples of π checked.
        assert_eq!(max_abs_cos(0.0, 1.0, 3.0, 3.5), 1.0);
        assert_eq!(max_abs_cos(0.5, 1.0, -0.1, 0.1), 1.5);
        assert!((max_abs_cos(0.0, 1.0, 0.5, 1.0) - 0.5f64.cos()).abs() < 1e-15);
        assert_eq!(max_abs_cos(0.2, 1.0, 3.0, 3.5 + PI), 1.2);
        assert_eq!(max_abs_cos(-0.2, 1.0, 3.0, 3.5 + PI), 1.2);
        assert_eq!(max_abs_cos(0.2, 1.0, -0.1, PI + 0.1), 1.2);
        for phase in [1e20, -1e308, 9.223372036854776e18, 1e9 + 1.0] {
            let e = Circle::new(Vector2::zeros(), 0.2, 0.1, phase, 0.0).expect_err("phase");
            assert!(e.to_string().contains("circle.phase"), "{e}");
            let e = Lemniscate::new(Vector2::zeros(), 0.2, 0.1, phase, 0.0).expect_err("phase");
            assert!(e.to_string().contains("lemniscate.phase"), "{e}");
        }
        let e = Circle::new(Vector2::zeros(), 0.2, 1e308, 0.0, 0.0).expect_err("omega");
        assert!(e.to_string().contains("circle.omega"), "{e}");
        let e = PointToPoint::new(Vector3::zeros(), Vector3::repeat(1.0), 0.0, 1e-110)
            .expect_err("too short");
        assert!(e.to_string().contains("point_to_point.duration"), "{e}");
        let w = [(0.0, Vector3::zeros()), (1e-110, Vector3::repeat(1.0))];
        let e = Spline::new(&w).expect_err("too close");
        assert!(e.to_string().contains("spline.waypoints[1].t"), "{e}");
    }

    #[test]
    fn constructors_name_the_bad_parameter() {
        let name = |e: ModelError| match e {
            ModelError::Invalid { param, .. } => param,
            other => panic!("unexpected {other:?}"),
        };
        let z2 = Vector2::zeros();
        let z3 = Vector3::zeros();
        assert_eq!(
            name(Path::circle(z2, 0.0, 1.0, 0.0, 0.0).unwrap_err()),
            "circle.radius"
        );
        assert_eq!(
            name(Path::circle(z2, 0.1, f64::NAN, 0.0, 0.0).unwrap_err()),
            "circle.omega"
        );
        assert_eq!(
            name(Path::circle(Vector2::new(0.0, f64::INFINITY), 0.1, 1.0, 0.0, 0.0).unwrap_err()),
            "circle.center[1]"
        );
        assert_eq!(
            name(Path::lemniscate(z2, -1.0, 1.0, 0.0, 0.0).unwrap_err()),
            "lemniscate.size"
        );
        assert_eq!(
            name(Path::point_to_point(z3, z3, 0.0, 0.0).unwrap_err()),
            "point_to_point.duration"
        );
        assert_eq!(
            name(Path::point_to_point(z3, Vector3::new(0.0, 0.0, f64::NAN), 0.0, 1.0).unwrap_err()),
            "point_to_point.to[2]"
        );
        assert_eq!(
            name(Path::spline(&[(0.0, z3)]).unwrap_err()),
            "spline.waypoints"
        );
        assert_eq!(
            name(Path::spline(&[(0.0, z3), (0.0, z3)]).unwrap_err()),
            "spline.waypoints[1].t"
        );
        assert_eq!(
            name(Path::spline(&[(0.0, z3), (f64::NAN, z3)]).unwrap_err()),
            "spline.waypoints[1].t"
        );
        assert_eq!(
            name(Path::spline(&[(0.0, z3), (1.0, Vector3::new(f64::NAN, 0.0, 0.0))]).unwrap_err()),
            "spline.waypoints[1].pose[0]"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

        /// Random waypoints: the spline interpolates them and is C² at every interior knot.
        #[test]
        fn spline_interpolates_and_is_c2(
            steps in proptest::collection::vec((0.05f64..2.0, -1.0f64..1.0, -1.0f64..1.0, -3.0f64..3.0), 2..12)
        ) {
            let mut t = -0.3;
            let wps: Vec<(f64, Vector3<f64>)> = steps
                .iter()
                .map(|&(dt, x, y, th)| {
                    t += dt;
                    (t, Vector3::new(x, y, th))
                })
                .collect();
            let Path::Spline(sp) = Path::spline(&wps).unwrap() else { unreachable!() };
            let hmin = steps.iter().map(|s| s.0).fold(f64::INFINITY, f64::min);
            for (t, pose) in &wps {
                prop_assert_eq!(sp.sample(*t).p, *pose);
            }
            // Curvature scales like |Δy|/h² ≤ 6/hmin², slope like 2/hmin: relative 1e-12.
            for k in 1..wps.len() - 1 {
                let left = sp.eval_segment(k - 1, wps[k].0 - wps[k - 1].0);
                let right = sp.eval_segment(k, 0.0);
                prop_assert!((left.p - right.p).amax() < 1e-12);
                prop_assert!((left.v - right.v).amax() < 1e-12 * 2.0 / hmin);
                prop_assert!((left.a - right.a).amax() < 1e-12 * 6.0 / (hmin * hmin));
            }
        }
    }
}
