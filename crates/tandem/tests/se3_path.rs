//! Desired SE(3) paths (`tandem::reference::spatial::path`): analytic derivatives against
//! finite differences, the SPEC-spatial S6 values, the geodesic, the spline's interpolation and
//! C² continuity, the chart reach, bad input, finiteness under random input, no allocation.
//!
//! Finite differences are the 4th-order central stencil
//! $f'(t) \approx \frac{-f(t+2h) + 8f(t+h) - 8f(t-h) + f(t-2h)}{12h}$, whose truncation error is
//! at most $\frac{h^4}{30}\max|f^{(5)}|$ and whose rounding error is about
//! $\frac{18}{12}\varepsilon\max|f|/h$. Each tolerance below is twice the sum, from a bound on
//! $f^{(5)}$ (closed form for the circle and the quintic), or, for the spline, as stated there.
//! The measured worst errors are printed (`--nocapture`).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::{UnitQuaternion, Vector3, Vector6};
use proptest::prelude::*;
use tandem::ModelError;
use tandem::geometry::so3;
use tandem::reference::spatial::path::{
    AxisFrame, CircleParams, Se3Path, Se3Sample, Se3Spline, Se3Waypoint, chart_rates, chart_x1,
    left_jacobian_rates,
};

// ---------------------------------------------------------------------------------------------
// Counting allocator (as tests/alloc.rs)
// ---------------------------------------------------------------------------------------------

#[path = "support/counting.rs"]
mod counting;
use counting::count;

#[global_allocator]
static A: counting::Counting = counting::Counting;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

const EPS: f64 = f64::EPSILON;

fn fd4(f: impl Fn(f64) -> Vector3<f64>, t: f64, h: f64) -> Vector3<f64> {
    (f(t - 2.0 * h) - f(t + 2.0 * h) + (f(t + h) - f(t - h)) * 8.0) / (12.0 * h)
}

/// World-axes angular velocity by differencing $\xi(s) = \mathrm{Log}(R(t+s)R(t)^T)$
/// ($\xi(0) = 0$, $\xi'(0) = \omega$).
fn fd4_omega(path: &Se3Path, t: f64, h: f64) -> Vector3<f64> {
    let r0 = path.sample(t).r;
    fd4(|s| so3::log_quat(&(path.sample(s).r * r0.inverse())), t, h)
}

/// Tolerance of a 4th-order stencil: `b5` bounds the 5th derivative of the differenced
/// function, `scale` its magnitude.
fn tol4(h: f64, b5: f64, scale: f64) -> f64 {
    2.0 * (h.powi(4) / 30.0 * b5 + 1.5 * EPS * scale / h)
}

/// Worst error of each checked derivative, for the report.
#[derive(Default, Debug)]
struct Worst {
    v: f64,
    a: f64,
    j: f64,
    w: f64,
    wd: f64,
    wdd: f64,
    /// Largest error / tolerance over all checks.
    ratio: f64,
}

impl Worst {
    fn put(
        slot: &mut f64,
        ratio: &mut f64,
        what: &str,
        t: f64,
        fd: Vector3<f64>,
        an: Vector3<f64>,
        tol: f64,
    ) {
        let e = (fd - an).amax();
        *ratio = ratio.max(e / tol);
        assert!(
            e <= tol,
            "{what} at t = {t}: fd {fd:?} vs analytic {an:?}, error {e:e} > tol {tol:e}"
        );
        *slot = slot.max(e);
    }
}

/// Derivative bounds for [`check_all`]: `p[n]` bounds $|p^{(n)}|$, `w[n]` bounds the n-th
/// derivative of ω (n = 0 is ω itself) and `xi5` the 5th derivative of ξ.
struct Bounds {
    p: [f64; 8],
    w: [f64; 8],
    xi5: f64,
}

fn check_all(path: &Se3Path, t: f64, h: f64, b: &Bounds, worst: &mut Worst) {
    let s = path.sample(t);
    let pos = |f: fn(&Se3Sample) -> Vector3<f64>| move |x: f64| f(&path.sample(x));
    Worst::put(
        &mut worst.v,
        &mut worst.ratio,
        "v",
        t,
        fd4(pos(|s| s.p), t, h),
        s.v,
        tol4(h, b.p[5], b.p[0]),
    );
    Worst::put(
        &mut worst.a,
        &mut worst.ratio,
        "a",
        t,
        fd4(pos(|s| s.v), t, h),
        s.a,
        tol4(h, b.p[6], b.p[1]),
    );
    Worst::put(
        &mut worst.j,
        &mut worst.ratio,
        "j",
        t,
        fd4(pos(|s| s.a), t, h),
        s.j,
        tol4(h, b.p[7], b.p[2]),
    );
    // ξ is a rotation vector of magnitude ≤ |ω| 2h.
    Worst::put(
        &mut worst.w,
        &mut worst.ratio,
        "ω",
        t,
        fd4_omega(path, t, h),
        s.w,
        tol4(h, b.xi5, PI),
    );
    Worst::put(
        &mut worst.wd,
        &mut worst.ratio,
        "ω̇",
        t,
        fd4(pos(|s| s.w), t, h),
        s.wd,
        tol4(h, b.w[5], b.w[0]),
    );
    Worst::put(
        &mut worst.wdd,
        &mut worst.ratio,
        "ω̈",
        t,
        fd4(pos(|s| s.wd), t, h),
        s.wdd,
        tol4(h, b.w[6], b.w[1]),
    );
}

fn quat(axis: Vector3<f64>, angle: f64) -> UnitQuaternion<f64> {
    so3::exp_quat(&(axis.normalize() * angle))
}

fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    so3::log_quat(&(a.inverse() * b)).norm()
}

fn param_of(e: ModelError) -> String {
    match e {
        ModelError::Invalid { param, .. } => param,
        other => panic!("unexpected {other:?}"),
    }
}

/// A tilted, fast circle with a large oscillation about a body axis.
fn tilted_circle(frame: AxisFrame) -> CircleParams {
    let e1 = Vector3::new(1.0, 1.0, 0.5).normalize();
    let e2 = e1.cross(&Vector3::z()).normalize();
    CircleParams {
        center: Vector3::new(0.1, -0.2, 0.4),
        radius: 0.3,
        omega: 1.3,
        phase: 0.4,
        plane_x: e1,
        plane_y: e2,
        r0: quat(Vector3::new(0.3, -0.5, 0.8), 1.1),
        axis: Vector3::new(-0.2, 0.9, 0.4).normalize(),
        axis_frame: frame,
        amplitude: 0.8,
        omega_rot: 2.1,
        phase_rot: -0.3,
    }
}

/// Bounds for a circle sampled over `|t| ≤ t_max`. The magnitudes `p[0..3]`, `w[0..2]` (the
/// `scale` of the differenced function) carry the factor `1 + |angle|max`: `sin ψ` of a
/// rounded `ψ = ωt + ψ0` is off by up to `ε |ψ|`.
fn circle_bounds(c: &CircleParams, t_max: f64) -> Bounds {
    let mut b = Bounds {
        p: [0.0; 8],
        w: [0.0; 8],
        xi5: 0.0,
    };
    let kp = 2.0 + c.omega * t_max + c.phase.abs();
    let kw = 2.0 + c.omega_rot * t_max + c.phase_rot.abs();
    b.p[0] = c.center.amax() + c.radius * kp;
    for n in 1..8 {
        b.p[n] = c.radius * c.omega.powi(n as i32) * if n < 3 { kp } else { 1.0 };
    }
    // ω^(n) = θ^(n+1) a, |θ^(n)| ≤ A Ωⁿ; ξ(s) = (θ(t+s) − θ(t)) a_W, ξ⁽⁵⁾ = θ⁽⁵⁾ a.
    for n in 0..8 {
        b.w[n] = c.amplitude * c.omega_rot.powi(n as i32 + 1) * if n < 2 { kw } else { 1.0 };
    }
    b.xi5 = c.amplitude * c.omega_rot.powi(5);
    b
}

// ---------------------------------------------------------------------------------------------
// Circle
// ---------------------------------------------------------------------------------------------

#[test]
fn circle_derivatives_match_finite_differences() {
    // h = 1e-3: truncation (h⁴/30) ρω⁸ ≈ 8e-14 at most, rounding 1.5 ε/h ≈ 3e-13.
    let h = 1e-3;
    for frame in [AxisFrame::World, AxisFrame::Body] {
        let c = tilted_circle(frame);
        let path = Se3Path::circle(&c).unwrap();
        let b = circle_bounds(&c, 9.3);
        let mut worst = Worst::default();
        for i in 0..200 {
            check_all(&path, -3.0 + 0.0613 * i as f64, h, &b, &mut worst);
        }
        eprintln!("circle {frame:?}: worst |fd − analytic| {worst:?}");
    }
    // The S6 path itself (slow: ω = 0.105, so tighter in absolute terms).
    let c = CircleParams::spec_s6();
    let path = Se3Path::spec_s6();
    let b = circle_bounds(&c, 60.0);
    let mut worst = Worst::default();
    for i in 0..200 {
        check_all(&path, 0.3 * i as f64, 1e-2, &b, &mut worst);
    }
    eprintln!("S6: worst |fd − analytic| {worst:?}");
}

#[test]
fn body_and_world_axis_forms() {
    // Body: R = R0 Exp(θ a_B); world: R = Exp(θ a_W) R0. Same path when a_W = R0 a_B.
    let cb = tilted_circle(AxisFrame::Body);
    let body = Se3Path::circle(&cb).unwrap();
    let mut cw = cb;
    cw.axis_frame = AxisFrame::World;
    cw.axis = cb.r0 * cb.axis;
    let world = Se3Path::circle(&cw).unwrap();
    let mut worst: f64 = 0.0;
    for i in 0..100 {
        let t = 0.137 * i as f64;
        let theta = cb.amplitude * (cb.omega_rot * t + cb.phase_rot).sin();
        let want_b = cb.r0 * quat(cb.axis, theta);
        let want_w = quat(cw.axis, theta) * cw.r0;
        let (sb, sw) = (body.sample(t), world.sample(t));
        worst = worst
            .max(angle_between(&sb.r, &want_b))
            .max(angle_between(&sw.r, &want_w))
            .max(angle_between(&sb.r, &sw.r));
        assert!((sb.w - sw.w).amax() < 1e-15);
        // ω is along the world axis.
        assert!(sb.w.cross(&cw.axis).amax() < 1e-15);
    }
    eprintln!("body/world forms: worst angle {worst:e}");
    assert!(worst < 1e-15);
}

#[test]
fn spec_s6_values_by_hand() {
    let path = Se3Path::spec_s6();
    let w = TAU / 60.0;
    let amp = 10f64.to_radians();
    // t = 0: on the +x side of the circle, R = I, pitching up at rate A·2ω about +y.
    let s = path.sample(0.0);
    assert_eq!(s.p, Vector3::new(0.1, 0.0, 0.3));
    assert!((s.v - Vector3::new(0.0, 0.1 * w, 0.0)).amax() < 1e-18);
    assert!((s.a - Vector3::new(-0.1 * w * w, 0.0, 0.0)).amax() < 1e-18);
    assert!((s.j - Vector3::new(0.0, -0.1 * w.powi(3), 0.0)).amax() < 1e-18);
    assert_eq!(s.r, UnitQuaternion::identity());
    assert!((s.w - Vector3::new(0.0, amp * 2.0 * w, 0.0)).amax() < 1e-18);
    assert!(s.wd.amax() < 1e-18);
    assert!((s.wdd - Vector3::new(0.0, -amp * 8.0 * w.powi(3), 0.0)).amax() < 1e-18);
    // t = 15 s: a quarter turn (ωt = π/2): on the +y side; pitch 10° sin(π) = 0, turning back.
    let s = path.sample(15.0);
    assert!((s.p - Vector3::new(0.0, 0.1, 0.3)).amax() < 1e-17);
    assert!((s.v - Vector3::new(-0.1 * w, 0.0, 0.0)).amax() < 1e-18);
    assert!(angle_between(&s.r, &UnitQuaternion::identity()) < 1e-16);
    assert!((s.w - Vector3::new(0.0, -amp * 2.0 * w, 0.0)).amax() < 1e-18);
    // t = 7.5 s: ωt = π/4, pitch at its peak +10° about world y, at rest in rotation.
    let s = path.sample(7.5);
    let h = 0.1 / 2f64.sqrt();
    assert!((s.p - Vector3::new(h, h, 0.3)).amax() < 1e-16);
    let phi = so3::log_quat(&s.r);
    assert!(
        (phi - Vector3::new(0.0, amp, 0.0)).amax() < 1e-16,
        "{phi:?}"
    );
    // cos of the rounded π/2 is 6e-17, times A·2ω = 0.037.
    assert!(s.w.amax() < 1e-17);
    assert!((s.wd - Vector3::new(0.0, -amp * 4.0 * w * w, 0.0)).amax() < 1e-18);
    // A pitch about +y tips the object's x axis down (−z).
    let x = s.r * Vector3::x();
    assert!((x - Vector3::new(amp.cos(), 0.0, -amp.sin())).amax() < 1e-16);
    // Reach in the S5 chart about the centre and R_ref = R(0) = I: 0.1 m, 0.1 m, 0; 10° about
    // y exactly.
    let c = Vector3::new(0.0, 0.0, 0.3);
    let m = path.max_abs(&c, &UnitQuaternion::identity(), 60.0);
    assert_eq!(m, Vector6::new(0.1, 0.1, 0.0, 0.0, amp, 0.0));
    let m = path.max_abs(&c, &UnitQuaternion::identity(), f64::INFINITY);
    assert_eq!(m, Vector6::new(0.1, 0.1, 0.0, 0.0, amp, 0.0));
    // Only the first 7.5 s: x from 0.1 down to 0.0707, y up to 0.0707, pitch up to 10°.
    let m = path.max_abs(&c, &UnitQuaternion::identity(), 7.5);
    assert!(
        (m - Vector6::new(0.1, h, 0.0, 0.0, amp, 0.0)).amax() < 1e-16,
        "{m:?}"
    );
}

#[test]
fn huge_and_non_finite_times_stay_finite_and_consistent() {
    let path = Se3Path::circle(&tilted_circle(AxisFrame::Body)).unwrap();
    let at0 = path.sample(0.0);
    for t in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e308, -1e308] {
        let s = path.sample(t);
        assert_eq!(s, at0, "t = {t}");
    }
    for t in [1e9, 1e15, 1e300, -1e200, 123456789.123] {
        let s = path.sample(t);
        assert!(finite_sample(&s), "t = {t}");
        // Still on the circle and consistent: a = −ω² (p − c).
        let c = tilted_circle(AxisFrame::Body);
        assert!(((s.p - c.center).norm() - c.radius).abs() < 1e-15);
        assert!((s.a + (s.p - c.center) * c.omega * c.omega).amax() < 1e-15);
    }
}

// ---------------------------------------------------------------------------------------------
// Point to point
// ---------------------------------------------------------------------------------------------

fn p2p() -> (
    Se3Path,
    [Vector3<f64>; 2],
    [UnitQuaternion<f64>; 2],
    f64,
    f64,
) {
    let pa = Vector3::new(0.1, -0.2, 0.3);
    let pb = Vector3::new(-0.3, 0.25, 0.5);
    let ra = quat(Vector3::new(0.2, 0.7, -0.3), 0.9);
    let rb = quat(Vector3::new(-0.6, 0.1, 0.5), 2.2);
    let (t0, dur) = (0.5, 2.0);
    let path = Se3Path::point_to_point(pa, ra, pb, rb, t0, dur).unwrap();
    (path, [pa, pb], [ra, rb], t0, dur)
}

#[test]
fn point_to_point_derivatives_match_finite_differences() {
    let (path, [pa, pb], _, t0, dur) = p2p();
    let Se3Path::PointToPoint(pp) = &path else {
        unreachable!()
    };
    let angle = pp.phi_ab().norm();
    // |s^(n)| on [0,1] (time law in τ): 1, 1.875, 5.78, 60, 360, 720, 720 (s⁽⁶⁾ = 0, use the
    // next nonzero as a safe bound), scaled by 1/Tⁿ.
    let sb = [1.0, 1.875, 5.78, 60.0, 360.0, 720.0, 720.0, 720.0];
    let dp = (pb - pa).amax();
    let mut b = Bounds {
        p: [0.0; 8],
        w: [0.0; 8],
        xi5: 0.0,
    };
    // Rounding of the time law is ε times the sum of its |Horner terms| (31, 120, 360, 780 for
    // s … s⁽³⁾), not ε times its value: those sums are the `scale`s of p, v, a.
    let abs_terms = [31.0, 120.0, 360.0, 780.0];
    for n in 0..8 {
        b.p[n] = dp * if n < 3 { abs_terms[n] } else { sb[n] } / dur.powi(n as i32);
        // ω^(n) = s^(n+1) R_A φ.
        b.w[n] = if n + 1 < 8 {
            angle * if n < 2 { abs_terms[n + 1] } else { sb[n + 1] } / dur.powi(n as i32 + 1)
        } else {
            0.0
        };
    }
    b.p[0] = 1.0 + dp * abs_terms[0];
    // ξ(s') = (s(t + s') − s(t)) R_A φ: ξ⁽⁵⁾ = s⁽⁵⁾ R_A φ.
    b.xi5 = angle * 720.0 / dur.powi(5);
    let h = 1e-3;
    let mut worst = Worst::default();
    // Inside the move, the stencil (±2h) away from the jerk jumps at t0 and t0 + T.
    for i in 1..100 {
        let t = t0 + dur * i as f64 / 100.0;
        check_all(&path, t, h, &b, &mut worst);
    }
    // Holds.
    for t in [-1.0, t0 - 0.01, t0 + dur + 0.01, 10.0] {
        check_all(&path, t, h, &b, &mut worst);
    }
    eprintln!("point to point: worst |fd − analytic| {worst:?}");
}

#[test]
fn point_to_point_rests_at_the_ends_and_follows_the_geodesic() {
    let (path, [pa, pb], [ra, rb], t0, dur) = p2p();
    let Se3Path::PointToPoint(pp) = &path else {
        unreachable!()
    };
    assert_eq!(path.sample(t0), Se3Sample::hold(pa, ra));
    assert_eq!(path.sample(-5.0), Se3Sample::hold(pa, ra));
    assert_eq!(path.sample(f64::NAN), Se3Sample::hold(pa, ra));
    // B as stored: the given rotation, with the quaternion sign the move arrives at.
    let rb_stored = pp.to().1;
    assert!(angle_between(&rb_stored, &rb) < 1e-16);
    assert_eq!(path.sample(t0 + dur), Se3Sample::hold(pb, rb_stored));
    assert_eq!(path.sample(f64::INFINITY), Se3Sample::hold(pb, rb_stored));
    // Just inside the ends the rates go to zero continuously.
    let s = path.sample(t0 + 1e-9);
    assert!(s.v.amax() < 1e-16 && s.w.amax() < 1e-16 && s.a.amax() < 1e-8);
    let s = path.sample(t0 + dur - 1e-9);
    assert!((s.p - pb).amax() < 1e-16 && angle_between(&s.r, &rb) < 1e-15);
    // |s''| ≤ 60 (1 − τ) near τ = 1: |ω̇| ≤ 60 |φ| (1e-9/T) / T² ≈ 2e-8.
    assert!(s.v.amax() < 1e-16 && s.w.amax() < 1e-16 && s.wd.amax() < 1e-7);
    // On the geodesic: R_Aᵀ R(t) = Exp(s(t) φ_AB), angle s|φ| about the fixed axis.
    let phi = pp.phi_ab();
    let axis = phi.normalize();
    let mut worst: f64 = 0.0;
    for i in 0..=200 {
        let t = t0 + dur * i as f64 / 200.0;
        let [s, s1, _, _] = pp.time_law(t);
        let rel = so3::log_quat(&(ra.inverse() * path.sample(t).r));
        // Angle s|φ|, and no component off the axis (absolute, so no division by a tiny angle).
        worst = worst.max((rel.norm() - s * phi.norm()).abs());
        worst = worst.max((rel - axis * rel.dot(&axis)).amax());
        // ω = ṡ R_A φ.
        assert!((path.sample(t).w - (ra * phi) * s1).amax() < 1e-15);
    }
    eprintln!("geodesic: worst angle/axis deviation {worst:e}");
    assert!(worst < 1e-15);
    // Peak rate at the midpoint: 15/8 φ/T.
    let s = path.sample(t0 + dur / 2.0);
    assert!((s.w.norm() - 1.875 * phi.norm() / dur).abs() < 1e-15);
    assert!(s.wd.amax() < 1e-15);
}

// ---------------------------------------------------------------------------------------------
// Spline
// ---------------------------------------------------------------------------------------------

fn test_waypoints() -> Vec<Se3Waypoint> {
    let r0 = quat(Vector3::new(0.1, 0.2, 0.9), 0.5);
    let rel = [
        Vector3::zeros(),
        Vector3::new(0.4, -0.3, 0.2),
        Vector3::new(1.2, 0.5, -0.4),
        // Through (near) the chart's origin and out the other side.
        Vector3::new(-0.01, 0.02, 0.0),
        Vector3::new(-1.5, 1.9, 0.8),
        Vector3::new(-0.5, 0.3, 2.5),
    ];
    let times = [0.0, 0.7, 1.5, 1.9, 3.0, 3.8];
    let pos = [
        Vector3::new(0.0, 0.0, 0.3),
        Vector3::new(0.1, 0.05, 0.35),
        Vector3::new(0.15, -0.1, 0.25),
        Vector3::new(0.05, -0.12, 0.2),
        Vector3::new(-0.2, 0.1, 0.3),
        Vector3::new(-0.1, 0.0, 0.4),
    ];
    (0..6)
        .map(|k| Se3Waypoint {
            t: times[k],
            p: pos[k],
            r: r0 * so3::exp_quat(&rel[k]),
        })
        .collect()
}

/// The sample just left of `t` (one ulp below; `t > 0`).
fn left_of(t: f64) -> f64 {
    f64::from_bits(t.to_bits() - 1)
}

#[test]
fn spline_passes_through_waypoints_and_is_c2() {
    let wps = test_waypoints();
    let path = Se3Path::spline(&wps).unwrap();
    let mut worst_wp: f64 = 0.0;
    for w in &wps {
        let s = path.sample(w.t);
        assert_eq!(s.p, w.p, "position at t = {}", w.t);
        worst_wp = worst_wp.max(angle_between(&s.r, &w.r));
    }
    eprintln!("spline: worst waypoint orientation error {worst_wp:e} rad");
    assert!(worst_wp < 2e-16 * 8.0);
    // Left and right limits at the interior knots: one ulp of t apart, so the difference is
    // the next derivative times ~4e-16 s plus rounding — far below 1e-9 relative.
    let (mut wp, mut wv, mut wa, mut ww, mut wwd, mut wr) = (0f64, 0f64, 0f64, 0f64, 0f64, 0f64);
    for w in &wps[1..wps.len() - 1] {
        let (l, r) = (path.sample(left_of(w.t)), path.sample(w.t));
        let rel = |a: Vector3<f64>, b: Vector3<f64>| (a - b).amax() / (1.0 + b.amax());
        wp = wp.max(rel(l.p, r.p));
        wv = wv.max(rel(l.v, r.v));
        wa = wa.max(rel(l.a, r.a));
        ww = ww.max(rel(l.w, r.w));
        wwd = wwd.max(rel(l.wd, r.wd));
        // |ω| · 1 ulp of t plus the rounding of two Exp and a product (≈ 4 ε).
        let dr = angle_between(&l.r, &r.r);
        assert!(dr < 2e-15, "orientation jump {dr:e}");
        wr = wr.max(dr);
        // The jerk and ω̈ do jump (a cubic spline is only C²): not continuity, just a
        // sanity check that the knots are real knots.
    }
    eprintln!(
        "spline knots: relative jumps p {wp:e}, v {wv:e}, a {wa:e}, R {wr:e} rad, ω {ww:e}, ω̇ {wwd:e}"
    );
    for e in [wp, wv, wa, ww, wwd] {
        assert!(e < 1e-9);
    }
    // Starts and ends at rest, holds outside.
    // (The stored quaternions are the given ones renormalised: within an ulp.)
    let Se3Path::Spline(sp) = &path else {
        unreachable!()
    };
    let (first, last) = (&sp.waypoints()[0], &sp.waypoints()[wps.len() - 1]);
    assert!(angle_between(&first.r, &wps[0].r) < 1e-16);
    assert_eq!(path.sample(-1.0), Se3Sample::hold(first.p, first.r));
    assert_eq!(path.sample(f64::NAN), Se3Sample::hold(first.p, first.r));
    assert_eq!(path.sample(99.0), Se3Sample::hold(last.p, last.r));
    let s = path.sample(1e-12);
    assert!(s.v.amax() < 1e-10 && s.w.amax() < 1e-10);
    let s = path.sample(left_of(last.t));
    assert!(s.v.amax() < 1e-12 && s.w.amax() < 1e-12);
}

#[test]
fn spline_derivatives_match_finite_differences() {
    let wps = test_waypoints();
    let path = Se3Path::spline(&wps).unwrap();
    // Inside a segment p is a cubic: p⁽⁴⁾ = 0, so the stencil is exact for v, a, j up to
    // rounding (b.p[5..] = 0). ω is analytic inside a segment but its 5th-and-higher
    // derivatives have no closed bound: estimate |ω⁽ⁿ⁾| ≤ |ω̈|max kⁿ⁻² with the rate
    // k = 2(|φ̇|max + 1/h_min), h_min = 0.4 s the shortest segment — the time scale on which
    // φ's cubic changes, and |φ̇| the one on which J_l(φ) does. This is an estimate, not a
    // proof: the measured errors (printed, with their largest fraction of the tolerance) sit
    // well below the resulting tolerances.
    let mut b = Bounds {
        p: [0.0; 8],
        w: [0.0; 8],
        xi5: 0.0,
    };
    let (mut mv, mut ma, mut mw, mut mwd, mut mwdd) = (0f64, 0f64, 0f64, 0f64, 0f64);
    let mut mphid: f64 = 0.0;
    let Se3Path::Spline(sp) = &path else {
        unreachable!()
    };
    for i in 0..=3800 {
        let t = i as f64 * 1e-3;
        let s = path.sample(t);
        mv = mv.max(s.v.amax());
        ma = ma.max(s.a.amax());
        mw = mw.max(s.w.norm());
        mwd = mwd.max(s.wd.norm());
        mwdd = mwdd.max(s.wdd.norm());
        mphid = mphid.max(sp.chart_sample(t)[1].norm());
    }
    let hmin = 0.4;
    let k = 2.0 * (mphid + 1.0 / hmin);
    // Rounding scale: the cubic's Horner terms can exceed the value they sum to; 4× the
    // value's bound covers them (|c1| + |2c2 τ| + |3c3 τ²| here).
    b.p[0] = 1.0;
    b.p[1] = mv * 4.0;
    b.p[2] = ma * 4.0;
    b.w[0] = mw * 1.1;
    b.w[1] = mwd * 1.1;
    b.w[5] = mwdd * k.powi(3);
    b.w[6] = mwdd * k.powi(4);
    b.xi5 = mwdd * k.powi(2);
    // h = 3e-4: ω's high derivatives are large on the short segments (φ turns by ~1 rad in
    // 0.4 s), so a smaller step than the circle's; rounding 1.5 ε · 20 / h ≈ 2e-11.
    let h = 3e-4;
    let mut worst = Worst::default();
    for i in 0..380 {
        let t = 0.01 * i as f64 + 0.003;
        if wps.iter().any(|w| (w.t - t).abs() <= 2.5 * h) {
            continue;
        }
        check_all(&path, t, h, &b, &mut worst);
    }
    eprintln!("spline: worst |fd − analytic| {worst:?} (ω̈ bound {mwdd:.3}, k = {k:.2})");
}

#[test]
fn left_jacobian_rates_match_so3_and_finite_differences() {
    // w = J_l(φ) φ̇ against so3::left_jacobian, and ẇ, ẅ against 4th-order differences of w
    // and ẇ along φ(t) = φ0 + φ1 t + φ2 t² + φ3 t³, over curves through the origin, near π,
    // near and beyond 2π (where the closed forms take over).
    let curves = [
        (Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.3, -0.2, 0.5)),
        (Vector3::new(1e-9, 0.0, 0.0), Vector3::new(-1e-8, 0.7, 0.1)),
        (Vector3::new(0.5, -1.0, 2.5), Vector3::new(0.2, 0.1, -0.4)),
        (Vector3::new(3.0, 0.5, 1.0), Vector3::new(1.0, -0.3, 0.2)),
        (Vector3::new(6.0, 0.5, -1.0), Vector3::new(0.3, 0.8, 0.2)),
        (Vector3::new(9.0, 2.0, -1.0), Vector3::new(-0.5, 0.2, 0.7)),
    ];
    let (p2, p3) = (Vector3::new(0.4, -0.3, 0.2), Vector3::new(-0.1, 0.2, 0.15));
    let h = 1e-3;
    let (mut e0, mut e1, mut e2): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for (p0, p1) in curves {
        let phi = |t: f64| p0 + p1 * t + p2 * (t * t) + p3 * (t * t * t);
        let d1 = |t: f64| p1 + p2 * (2.0 * t) + p3 * (3.0 * t * t);
        let d2 = |t: f64| p2 * 2.0 + p3 * (6.0 * t);
        let d3 = |_t: f64| p3 * 6.0;
        let rates = |t: f64| left_jacobian_rates(&phi(t), &d1(t), &d2(t), &d3(t));
        for i in 0..21 {
            let t = -0.5 + 0.05 * i as f64;
            let [w, wd, wdd] = rates(t);
            let want = so3::left_jacobian(&phi(t)) * d1(t);
            e0 = e0.max((w - want).amax());
            // ω's Taylor coefficients here are O(1)–O(10): tolerance 1e-9 covers h⁴/30 · 1e3
            // truncation and 1.5 ε · 10 / h rounding with a margin.
            e1 = e1.max((fd4(|s| rates(s)[0], t, h) - wd).amax());
            e2 = e2.max((fd4(|s| rates(s)[1], t, h) - wdd).amax());
        }
    }
    eprintln!("J_l rates: |w − J_l φ̇| {e0:e}, ẇ fd {e1:e}, ẅ fd {e2:e}");
    assert!(e0 < 1e-14);
    assert!(e1 < 1e-9 && e2 < 1e-9);
}

#[test]
fn chart_rates_match_finite_differences() {
    // x_1 = (p − c, Log(R_refᵀ R)) and its rates against 4th-order differences of the lower
    // one, for references off each path's family (no wrap: the angles stay below 2.2 rad).
    // h = 1e-3. φ's derivatives are those of ω through J_l⁻¹ (‖J_l⁻¹‖ ≤ π/2) and its rates:
    // |φ⁽ⁿ⁾| ≲ (π/2) 4ⁿ |ω|max-scale; for the circle |φ⁽⁷⁾| ≲ (π/2)·0.8·2.1⁷·16 ≈ 3.7e3, so
    // truncation h⁴/30 · 3.7e3 ≈ 1.2e-10; rounding 1.5 ε · 3 / h ≈ 1e-12. Tolerance 5e-10
    // (circle, quintic), and 5e-9 for the spline (faster, see its derivative test).
    let circ = Se3Path::circle(&tilted_circle(AxisFrame::Body)).unwrap();
    let (pp, ..) = p2p();
    let sp = Se3Path::spline(&test_waypoints()).unwrap();
    let c = Vector3::new(0.05, 0.0, 0.3);
    let cases = [
        (
            &circ,
            circ.sample(0.3).r * quat(Vector3::new(0.2, 1.0, -0.4), 0.3),
            5e-10,
            0.0,
            6.0,
        ),
        // The chart passes through φ = 0 at t = 0.3 (series branches of J_l⁻¹ and J_l's rates).
        (&circ, circ.sample(0.3).r, 5e-10, 0.25, 0.35),
        (
            &pp,
            quat(Vector3::new(1.0, 0.2, -0.3), 0.4),
            5e-10,
            0.55,
            2.45,
        ),
        (&sp, sp.sample(0.0).r, 5e-9, 0.0, 3.8),
    ];
    let h = 1e-3;
    for (path, r_ref, tol, t_lo, t_hi) in cases {
        let rot = |k: usize| {
            move |t: f64| {
                let x = chart_rates(&path.sample(t), &c, &r_ref)[k];
                Vector3::new(x[3], x[4], x[5])
            }
        };
        let mut worst = [0f64; 3];
        for i in 0..=200 {
            let t = t_lo + (t_hi - t_lo) * i as f64 / 200.0;
            if let Se3Path::Spline(s) = path
                && s.waypoints().iter().any(|w| (w.t - t).abs() <= 2.5 * h)
            {
                continue;
            }
            let x = chart_rates(&path.sample(t), &c, &r_ref);
            // The value is the chart itself.
            let s = path.sample(t);
            assert_eq!(x[0], chart_x1(&s, &c, &r_ref));
            assert_eq!(x[1].fixed_rows::<3>(0), s.v);
            for k in 1..4 {
                let fd = fd4(rot(k - 1), t, h);
                let an = Vector3::new(x[k][3], x[k][4], x[k][5]);
                let e = (fd - an).amax();
                assert!(e < tol, "order {k} at t = {t}: {fd:?} vs {an:?} ({e:e})");
                worst[k - 1] = worst[k - 1].max(e);
            }
        }
        eprintln!(
            "chart rates: worst |fd − analytic| (φ̇, φ̈, φ⃛) = {:e} {:e} {:e}",
            worst[0], worst[1], worst[2]
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Reach in the chart
// ---------------------------------------------------------------------------------------------

/// Dense-sampling reference for `max_abs`.
fn sampled_max(
    path: &Se3Path,
    c: &Vector3<f64>,
    r_ref: &UnitQuaternion<f64>,
    t_end: f64,
    n: usize,
) -> Vector6<f64> {
    let mut m = Vector6::zeros();
    for i in 0..=n {
        let s = path.sample(t_end * i as f64 / n as f64);
        m = m.sup(&chart_x1(&s, c, r_ref).abs());
    }
    m
}

#[test]
fn max_abs_closed_forms_match_dense_sampling() {
    let circ = Se3Path::circle(&tilted_circle(AxisFrame::Body)).unwrap();
    let (pp, ..) = p2p();
    let sp = Se3Path::spline(&test_waypoints()).unwrap();
    let c = Vector3::new(0.02, -0.1, 0.3);
    let cases: Vec<(&Se3Path, UnitQuaternion<f64>, f64)> = vec![
        // R_ref on each path's own family: closed forms.
        (&circ, circ.sample(0.0).r, 10.0),
        (&circ, circ.sample(0.0).r, 1.0),
        (&circ, circ.sample(2.345).r, 3.0),
        (&pp, pp.sample(0.0).r, 5.0),
        (&pp, pp.sample(1.7).r, 2.0),
        (&pp, pp.sample(10.0).r, 10.0),
        (&sp, sp.sample(0.0).r, 3.8),
        (&sp, sp.sample(0.0).r, 1.2),
    ];
    let mut worst: f64 = 0.0;
    for (path, r_ref, t_end) in &cases {
        let exact = path.max_abs(&c, r_ref, *t_end);
        let sampled = sampled_max(path, &c, r_ref, *t_end, 200_000);
        // Sampling can only miss a smooth peak by ½ max|ẍ| (Δt/2)² ≤ 1e-9 here.
        for j in 0..6 {
            assert!(exact[j] >= sampled[j] - 1e-15, "{j}: {exact} < {sampled}");
            assert!(exact[j] - sampled[j] < 1e-8, "{j}: {exact} vs {sampled}");
            worst = worst.max(exact[j] - sampled[j]);
        }
    }
    eprintln!("max_abs closed forms: worst excess over dense sampling {worst:e}");
}

#[test]
fn max_abs_sampled_bound_is_rigorous_and_tight() {
    // R_ref off every family: the sampled bound must lie above the dense maximum and within
    // its Lipschitz margin (π/2) ω_max Δ/2 of it.
    let circ_p = tilted_circle(AxisFrame::World);
    let circ = Se3Path::circle(&circ_p).unwrap();
    let (pp, ..) = p2p();
    let sp = Se3Path::spline(&test_waypoints()).unwrap();
    let c = Vector3::zeros();
    let r_ref = quat(Vector3::new(1.0, 0.2, -0.3), 0.6);
    // The spline's chart angles reach 2.7 rad: a reference 0.6 rad off would bring the path
    // within 2e-6 of a half turn (where π is the right answer); take one 0.15 rad off R_0.
    let r_ref_spline = test_waypoints()[0].r * quat(Vector3::new(0.3, -1.0, 0.2), 0.15);
    let Se3Path::PointToPoint(p2p_inner) = &pp else {
        unreachable!()
    };
    // Quintic: ω_max = 1.875 |φ_AB| / T over the move [0.5, 2.5] (T = 2), 4096 intervals.
    let pp_margin = FRAC_PI_2 * (1.875 * p2p_inner.phi_ab().norm() / 2.0) * 2.0 / 8192.0;
    let cases: [(&Se3Path, UnitQuaternion<f64>, f64, f64); 3] = [
        // (path, t_end, margin = (π/2) ω_max Δ/2 with the library's sample counts)
        (
            &circ,
            r_ref,
            20.0,
            FRAC_PI_2 * circ_p.amplitude * circ_p.omega_rot * (TAU / circ_p.omega_rot) / 8192.0,
        ),
        (&pp, r_ref, 5.0, pp_margin),
        (&sp, r_ref_spline, 3.8, 0.02),
    ];
    for (path, r_ref, t_end, margin) in cases {
        let b = path.max_abs(&c, &r_ref, t_end);
        let dense = sampled_max(path, &c, &r_ref, t_end, 400_000);
        let max_angle = (0..=100_000)
            .map(|i| {
                let s = path.sample(t_end * i as f64 / 100_000.0);
                chart_x1(&s, &c, &r_ref).fixed_rows::<3>(3).norm()
            })
            .fold(0.0, f64::max);
        eprintln!(
            "sampled bound {:?} vs dense {:?} (max angle {max_angle})",
            b.fixed_rows::<3>(3).transpose(),
            dense.fixed_rows::<3>(3).transpose()
        );
        for j in 3..6 {
            assert!(b[j] >= dense[j] - 1e-15, "{j}: {b} < {dense}");
            assert!(
                b[j] - dense[j] <= margin + 1e-9,
                "{j}: {b} vs {dense}, margin {margin}"
            );
        }
    }
    // A reference half a turn away: the chart wraps, every component is bounded by π.
    let far = circ.sample(0.0).r * quat(Vector3::new(0.3, 0.3, 0.9), PI - 0.01);
    let b = circ.max_abs(&c, &far, 20.0);
    for j in 3..6 {
        assert!(b[j] <= PI && b[j] >= sampled_max(&circ, &c, &far, 20.0, 100_000)[j] - 1e-15);
    }
}

// ---------------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------------

#[test]
fn constructors_name_the_bad_parameter() {
    let good = CircleParams::spec_s6();
    let circle_err = |f: &dyn Fn(&mut CircleParams)| {
        let mut p = good;
        f(&mut p);
        param_of(Se3Path::circle(&p).unwrap_err())
    };
    assert_eq!(circle_err(&|p| p.radius = 0.0), "path.radius");
    assert_eq!(circle_err(&|p| p.radius = -0.1), "path.radius");
    assert_eq!(circle_err(&|p| p.omega = 0.0), "path.omega");
    assert_eq!(circle_err(&|p| p.omega = -1.0), "path.omega");
    assert_eq!(circle_err(&|p| p.omega = f64::NAN), "path.omega");
    assert_eq!(circle_err(&|p| p.omega = 1e200), "path.omega");
    assert_eq!(circle_err(&|p| p.omega_rot = 0.0), "path.omega_rot");
    assert_eq!(
        circle_err(&|p| p.center.y = f64::INFINITY),
        "path.center[1]"
    );
    assert_eq!(circle_err(&|p| p.phase = 1e10), "path.phase");
    assert_eq!(circle_err(&|p| p.phase_rot = f64::NAN), "path.phase_rot");
    assert_eq!(circle_err(&|p| p.axis = Vector3::zeros()), "path.axis");
    assert_eq!(
        circle_err(&|p| p.axis = Vector3::new(0.0, 2.0, 0.0)),
        "path.axis"
    );
    assert_eq!(circle_err(&|p| p.axis.x = f64::NAN), "path.axis[0]");
    assert_eq!(
        circle_err(&|p| p.plane_x = Vector3::new(1.0, 0.1, 0.0)),
        "path.plane_x"
    );
    assert_eq!(circle_err(&|p| p.plane_y = Vector3::x()), "path.plane_y");
    assert_eq!(circle_err(&|p| p.amplitude = -0.1), "path.amplitude");
    assert_eq!(circle_err(&|p| p.amplitude = PI), "path.amplitude");
    assert_eq!(
        circle_err(&|p| p.r0 =
            UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(2.0, 0.0, 0.0, 0.0))),
        "path.r0"
    );
    assert_eq!(
        circle_err(&|p| p.r0 =
            UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0))),
        "path.r0"
    );

    let (z, i) = (Vector3::zeros(), UnitQuaternion::identity());
    let p2p_err = |pa: Vector3<f64>, ra: UnitQuaternion<f64>, pb, rb, t0, d| {
        param_of(Se3Path::point_to_point(pa, ra, pb, rb, t0, d).unwrap_err())
    };
    assert_eq!(p2p_err(z, i, z, i, 0.0, 0.0), "path.duration");
    assert_eq!(p2p_err(z, i, z, i, 0.0, -1.0), "path.duration");
    assert_eq!(
        p2p_err(z, i, Vector3::repeat(1.0), i, 0.0, 1e-110),
        "path.duration"
    );
    assert_eq!(p2p_err(z, i, z, i, f64::NAN, 1.0), "path.t0");
    assert_eq!(
        p2p_err(Vector3::new(0.0, f64::NAN, 0.0), i, z, i, 0.0, 1.0),
        "path.p_from[1]"
    );
    assert_eq!(
        p2p_err(z, i, Vector3::new(0.0, 0.0, f64::INFINITY), i, 0.0, 1.0),
        "path.p_to[2]"
    );
    let bad_q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(0.5, 0.0, 0.0, 0.0));
    assert_eq!(p2p_err(z, bad_q, z, i, 0.0, 1.0), "path.r_from");
    assert_eq!(p2p_err(z, i, z, bad_q, 0.0, 1.0), "path.r_to");
    // Geodesic of angle ≥ π − 1e-6: exactly π, and just inside the margin.
    for angle in [PI, PI - 1e-7, PI - 0.5e-6] {
        let rb = quat(Vector3::new(0.2, 0.3, 0.4), angle);
        assert_eq!(p2p_err(z, i, z, rb, 0.0, 1.0), "path.r_to", "angle {angle}");
    }
    assert!(Se3Path::point_to_point(z, i, z, quat(Vector3::z(), PI - 2e-6), 0.0, 1.0).is_ok());

    let wp = |t: f64, p: Vector3<f64>, r: UnitQuaternion<f64>| Se3Waypoint { t, p, r };
    let spl = |w: &[Se3Waypoint]| param_of(Se3Spline::new(w).unwrap_err());
    assert_eq!(spl(&[]), "path.waypoints");
    assert_eq!(spl(&[wp(0.0, z, i)]), "path.waypoints");
    assert_eq!(spl(&[wp(0.0, z, i), wp(0.0, z, i)]), "path.waypoints[1].t");
    assert_eq!(
        spl(&[wp(0.0, z, i), wp(1.0, z, i), wp(0.5, z, i)]),
        "path.waypoints[2].t"
    );
    assert_eq!(
        spl(&[wp(0.0, z, i), wp(f64::NAN, z, i)]),
        "path.waypoints[1].t"
    );
    assert_eq!(
        spl(&[wp(0.0, z, i), wp(1.0, Vector3::new(f64::NAN, 0.0, 0.0), i)]),
        "path.waypoints[1].p[0]"
    );
    assert_eq!(
        spl(&[wp(0.0, z, i), wp(1.0, z, bad_q)]),
        "path.waypoints[1].r"
    );
    assert_eq!(
        spl(&[wp(0.0, z, bad_q), wp(1.0, z, i)]),
        "path.waypoints[0].r"
    );
    // Outside the chart (angle from waypoint 0 ≥ π − 1e-6).
    let half = quat(Vector3::new(1.0, -1.0, 0.3), PI - 1e-7);
    assert_eq!(
        spl(&[
            wp(0.0, z, i),
            wp(1.0, z, quat(Vector3::x(), 1.0)),
            wp(2.0, z, half)
        ]),
        "path.waypoints[2].r"
    );
    // Too close for the rotation (derivatives overflow).
    assert_eq!(
        spl(&[wp(0.0, z, i), wp(1e-110, z, quat(Vector3::x(), 1.0))]),
        "path.waypoints[1].t"
    );
    assert_eq!(
        spl(&[wp(0.0, z, i), wp(1e-110, Vector3::repeat(1.0), i)]),
        "path.waypoints[1].t"
    );
}

// ---------------------------------------------------------------------------------------------
// Finiteness under random valid input; no allocation
// ---------------------------------------------------------------------------------------------

fn finite_sample(s: &Se3Sample) -> bool {
    let v = [s.p, s.v, s.a, s.j, s.w, s.wd, s.wdd];
    v.iter().all(|x| x.iter().all(|c| c.is_finite()))
        && s.r.quaternion().coords.iter().all(|c| c.is_finite())
        && (s.r.quaternion().norm() - 1.0).abs() < 1e-12
}

fn unit(v: (f64, f64, f64)) -> Option<Vector3<f64>> {
    let v = Vector3::new(v.0, v.1, v.2);
    let n = v.norm();
    (n > 1e-3).then(|| v / n)
}

fn any_rot() -> impl Strategy<Value = UnitQuaternion<f64>> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0.0f64..3.1)
        .prop_map(|(x, y, z, a)| quat(Vector3::new(x, y, z + 1e-3), a))
}

fn any_point() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn any_time() -> impl Strategy<Value = f64> {
    prop_oneof![
        -10.0f64..100.0,
        -1e12f64..1e12,
        Just(0.0),
        Just(1e300),
        Just(-1e300),
        Just(f64::INFINITY),
        Just(f64::NAN),
    ]
}

/// `max_abs` over `[0, t_end]` is finite, non-negative and above the chart at every sampled
/// time (up to rounding of the chart itself, 1e-12).
fn check_reach(
    path: &Se3Path,
    c: &Vector3<f64>,
    r_ref: &UnitQuaternion<f64>,
    t_end: f64,
    us: &[f64],
) -> Result<(), TestCaseError> {
    let m = path.max_abs(c, r_ref, t_end);
    prop_assert!(m.iter().all(|x| x.is_finite() && *x >= 0.0), "{m:?}");
    for &u in us.iter().chain(&[0.0, 1.0]) {
        let x = chart_x1(&path.sample(u * t_end), c, r_ref).abs();
        for j in 0..6 {
            prop_assert!(
                x[j] <= m[j] + 1e-12,
                "t = {}, {j}: {} > bound {}",
                u * t_end,
                x[j],
                m[j]
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        rng_seed: proptest::test_runner::RngSeed::Fixed(11),
        // Seeded and deterministic: no regression files written next to the tests.
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_circles_are_finite(
        c in (-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0),
        radius in 1e-6f64..10.0,
        omega in 1e-6f64..1e3,
        phase in -1e9f64..1e9,
        e in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        a in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        r0 in any_rot(),
        body in any::<bool>(),
        amplitude in 0.0f64..(PI - 1e-6),
        omega_rot in 1e-6f64..1e3,
        t in proptest::collection::vec(any_time(), 8),
        c_ref in any_point(),
        r_ref in any_rot(),
        us in proptest::collection::vec(0.0f64..1.0, 32),
    ) {
        let (Some(e1), Some(ax)) = (unit(e), unit(a)) else { return Ok(()); };
        let e2 = e1.cross(&Vector3::new(0.3, -0.7, 0.2)).try_normalize(1e-3);
        let Some(e2) = e2 else { return Ok(()); };
        let p = CircleParams {
            center: Vector3::new(c.0, c.1, c.2), radius, omega, phase, plane_x: e1, plane_y: e2,
            r0, axis: ax, axis_frame: if body { AxisFrame::Body } else { AxisFrame::World },
            amplitude, omega_rot, phase_rot: -phase,
        };
        let path = Se3Path::circle(&p).unwrap();
        for &t in &t {
            prop_assert!(finite_sample(&path.sample(t)), "t = {}", t);
        }
        let m = path.max_abs(&Vector3::zeros(), &r0, t[0].abs());
        prop_assert!(m.iter().all(|x| x.is_finite() && *x >= 0.0));
        // The reach bounds the chart, for R_ref = R(0) (closed form) and a random one.
        let t_end = if t[1].abs() < 50.0 { t[1].abs() } else { 7.0 };
        check_reach(&path, &c_ref, &path.sample(0.0).r, t_end, &us)?;
        check_reach(&path, &c_ref, &r_ref, t_end, &us)?;
    }

    #[test]
    fn random_moves_are_finite(
        pa in (-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0),
        pb in (-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0),
        ra in any_rot(),
        rb in any_rot(),
        t0 in -100.0f64..100.0,
        dur in 1e-3f64..1e3,
        t in proptest::collection::vec(any_time(), 8),
        c_ref in any_point(),
        r_ref in any_rot(),
        us in proptest::collection::vec(0.0f64..1.0, 32),
    ) {
        let pa = Vector3::new(pa.0, pa.1, pa.2);
        let pb = Vector3::new(pb.0, pb.1, pb.2);
        let Ok(path) = Se3Path::point_to_point(pa, ra, pb, rb, t0, dur) else {
            // Only a (near) half turn may be refused.
            prop_assert!(angle_between(&ra, &rb) >= PI - 1e-6 - 1e-12);
            return Ok(());
        };
        for &t in &t {
            prop_assert!(finite_sample(&path.sample(t)), "t = {}", t);
        }
        let m = path.max_abs(&Vector3::zeros(), &rb, t[0].abs());
        prop_assert!(m.iter().all(|x| x.is_finite() && *x >= 0.0));
        let t_end = t0.max(0.0) + 2.0 * dur;
        check_reach(&path, &c_ref, &ra, t_end, &us)?;
        check_reach(&path, &c_ref, &r_ref, t_end, &us)?;
    }

    #[test]
    fn random_splines_are_finite(
        steps in proptest::collection::vec(
            (1e-3f64..5.0, (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), (-1.8f64..1.8, -1.8f64..1.8, -1.8f64..1.8)),
            2..10),
        r0 in any_rot(),
        t in proptest::collection::vec(any_time(), 8),
        ts in proptest::collection::vec(0.0f64..1.0, 32),
        c_ref in any_point(),
        r_ref in any_rot(),
    ) {
        let mut tk = -0.5;
        let wps: Vec<Se3Waypoint> = steps.iter().enumerate().map(|(k, &(dt, p, f))| {
            tk += dt;
            let f = if k == 0 { Vector3::zeros() } else { Vector3::new(f.0, f.1, f.2) };
            Se3Waypoint { t: tk, p: Vector3::new(p.0, p.1, p.2), r: r0 * so3::exp_quat(&f) }
        }).collect();
        let path = Se3Path::spline(&wps).unwrap();
        let span = wps[wps.len() - 1].t - wps[0].t;
        for &t in &t {
            prop_assert!(finite_sample(&path.sample(t)), "t = {}", t);
        }
        for &u in &ts {
            let t = wps[0].t + u * span;
            prop_assert!(finite_sample(&path.sample(t)), "t = {}", t);
        }
        let m = path.max_abs(&Vector3::zeros(), &r0, span);
        prop_assert!(m.iter().all(|x| x.is_finite() && *x >= 0.0));
        let t_end = wps[wps.len() - 1].t + 1.0;
        check_reach(&path, &c_ref, &r0, t_end, &ts)?;
        check_reach(&path, &c_ref, &r_ref, t_end, &ts)?;
    }
}

#[test]
fn quaternions_are_continuous_in_t() {
    // q and −q are one rotation; the samples keep one sign along the whole path, holds
    // included (consecutive samples 1 ms apart turn by ≤ 3 mrad: their dot product is ≈ 1).
    let (_, [pa, pb], [ra, rb], t0, dur) = p2p();
    // The same move with B given as −q_B (the same rotation).
    let rb_neg = UnitQuaternion::new_unchecked(-rb.into_inner());
    let flipped = Se3Path::point_to_point(pa, ra, pb, rb_neg, t0, dur).unwrap();
    let mut wps = test_waypoints();
    // Waypoints given with the "other" sign, the last one (held) among them.
    for k in [4, 5] {
        wps[k].r = UnitQuaternion::new_unchecked(-wps[k].r.into_inner());
    }
    let paths = [
        Se3Path::circle(&tilted_circle(AxisFrame::Body)).unwrap(),
        p2p().0,
        flipped,
        Se3Path::spline(&wps).unwrap(),
    ];
    for path in &paths {
        let mut prev = path.sample(-1.0).r;
        let mut worst: f64 = 1.0;
        for i in 0..6000 {
            let q = path.sample(-1.0 + 1e-3 * i as f64).r;
            let d = q.coords.dot(&prev.coords);
            worst = worst.min(d);
            prev = q;
        }
        assert!(worst > 0.99, "quaternion sign flip: min dot {worst}");
    }
}

#[test]
fn the_counter_counts() {
    let n = count(|| {
        let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
        drop(v);
    });
    assert_eq!(n, 1);
}

#[test]
fn sampling_never_allocates() {
    let paths = [
        Se3Path::spec_s6(),
        Se3Path::circle(&tilted_circle(AxisFrame::Body)).unwrap(),
        p2p().0,
        Se3Path::spline(&test_waypoints()).unwrap(),
    ];
    for path in &paths {
        let mut acc = 0.0;
        let start = std::time::Instant::now();
        let n = count(|| {
            for i in 0..10_000 {
                let s = path.sample(std::hint::black_box(-1.0 + 5e-4 * i as f64));
                let x = chart_rates(&s, &Vector3::zeros(), &UnitQuaternion::identity());
                acc += s.p.x + s.r.w + s.wdd.y + x[3][4];
            }
        });
        // Informative only (not asserted): sample + chart_rates per call.
        let ns = start.elapsed().as_nanos() as f64 / 10_000.0;
        let kind = match path {
            Se3Path::Circle(_) => "circle",
            Se3Path::PointToPoint(_) => "point to point",
            Se3Path::Spline(_) => "spline",
        };
        let start = std::time::Instant::now();
        for i in 0..10_000 {
            let s = path.sample(std::hint::black_box(-1.0 + 5e-4 * i as f64));
            acc += s.p.x + s.r.w + s.wdd.y;
        }
        let ns_sample = start.elapsed().as_nanos() as f64 / 10_000.0;
        eprintln!("{kind}: sample {ns_sample:.0} ns, sample + chart_rates {ns:.0} ns");
        assert_eq!(n, 0, "{path:?}");
        assert!(acc.is_finite());
    }
}
