//! The rotation group SO(3): hat/vee, exponential and logarithm, and the right and left
//! Jacobians with their inverses, accurate over the whole range `0 ≤ θ ≤ π`.
//!
//! With `φ ∈ ℝ³` a rotation vector, `θ = |φ|` its angle (rad) and `[φ]` the skew matrix
//! (`[φ] x = φ × x`):
//!
//! ```text
//! Exp(φ)  = I + a [φ] + b [φ]²                      a = sin θ / θ,  b = (1 − cos θ) / θ²
//! J_r(φ)  = I − b [φ] + c [φ]²                      c = (θ − sin θ) / θ³
//! J_l(φ)  = I + b [φ] + c [φ]²  = J_r(−φ) = J_r(φ)ᵀ
//! J_r⁻¹(φ) = I + ½ [φ] + d [φ]²                     d = (1 − (θ/2) cot(θ/2)) / θ²
//! J_l⁻¹(φ) = I − ½ [φ] + d [φ]²
//! ```
//!
//! `J_r` is the right Jacobian: `Exp(φ + δ) ≈ Exp(φ) Exp(J_r(φ) δ)`, so for `R(t) = Exp(φ(t))`
//! the body angular velocity is `ω_B = Rᵀ ω = J_r(φ) φ̇`; the left Jacobian gives the world
//! (spatial) one, `ω = J_l(φ) φ̇`. `J_r` is singular only at `θ = 2π`; `Log` returns `θ ≤ π`.
//!
//! Numerics: `b` is evaluated as `2 sin²(θ/2)/θ²` (no cancellation); `c` and `d` cancel
//! catastrophically for small `θ` and are evaluated by their Taylor series below
//! [`SERIES_THRESHOLD`] (1 rad, where the closed forms lose at most one digit); `a`, `b` by
//! theirs below `1e-4`. `d` uses `cot(θ/2)`, regular at `θ = π`
//! (the form `(1 + cos θ)/(2θ sin θ)` is `0/0` there). `Log` goes through the quaternion
//! (Shepperd's method picks the largest of `w, x, y, z`, so the antipodal case `θ → π`, where the
//! skew part of `R` vanishes, is read from the symmetric part), then
//! `φ = 2 atan2(|v|, w) v/|v|` with `w ≥ 0`, accurate to an ulp in absolute angle for all `θ`.

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Below this angle (rad) the coefficients `c` and `d` come from their Taylor series.
pub const SERIES_THRESHOLD: f64 = 1.0;

/// Below this angle (rad) the coefficients `a`, `b` come from their Taylor series.
const SMALL: f64 = 1e-4;

/// The skew-symmetric matrix `[w]` with `[w] x = w × x`.
#[inline]
pub fn hat(w: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0)
}

/// The vector of the skew part of `m`: `vee([w]) = w`; for a general `m`, the vector of
/// `(m − mᵀ)/2`.
#[inline]
pub fn vee(m: &Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
}

/// `(a, b) = (sin θ/θ, (1 − cos θ)/θ²)` from `θ²` and `θ`.
#[inline]
fn coeff_ab(t2: f64, t: f64) -> (f64, f64) {
    if t < SMALL {
        // sin θ/θ = 1 − θ²/6 + θ⁴/120 − …, (1 − cos θ)/θ² = 1/2 − θ²/24 + θ⁴/720 − …
        (
            1.0 - t2 / 6.0 * (1.0 - t2 / 20.0),
            0.5 - t2 / 24.0 * (1.0 - t2 / 30.0),
        )
    } else {
        let (s, c) = (0.5 * t).sin_cos();
        // sin θ = 2 s c; 1 − cos θ = 2 s².
        (2.0 * s * c / t, 2.0 * s * s / t2)
    }
}

/// `c = (θ − sin θ)/θ³`; series `Σ_k (−1)^k θ^{2k}/(2k+3)!` (to `θ¹⁶/19!`; the next term is
/// `< 2e-20` at `θ = 1`) below [`SERIES_THRESHOLD`].
#[inline]
fn coeff_c(t2: f64, t: f64) -> f64 {
    if t < SERIES_THRESHOLD {
        c_series(t2)
    } else {
        // At θ ≥ 1, θ − sin θ ≥ 0.158 θ: at most one digit cancels.
        (t - t.sin()) / (t2 * t)
    }
}

#[inline]
fn c_series(t2: f64) -> f64 {
    {
        // Horner in θ², highest order first: 1/(2k+3)! with alternating signs, k = 8 … 0.
        const K: [f64; 9] = [
            1.0 / 6.0,
            -1.0 / 120.0,
            1.0 / 5_040.0,
            -1.0 / 362_880.0,
            1.0 / 39_916_800.0,
            -1.0 / 6_227_020_800.0,
            1.0 / 1_307_674_368_000.0,
            -1.0 / 355_687_428_096_000.0,
            1.0 / 121_645_100_408_832_000.0,
        ];
        let mut s = 0.0;
        for k in K.iter().rev() {
            s = s * t2 + k;
        }
        s
    }
}

/// `d = (1 − (θ/2) cot(θ/2))/θ² = Σ_{k≥1} |B_2k| θ^{2k−2}/(2k)!` (Bernoulli numbers:
/// `1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600 + …`, to `θ²²`; the next term is `< 4e-21` at
/// `θ = 1`) below [`SERIES_THRESHOLD`].
#[inline]
fn coeff_d(t2: f64, t: f64) -> f64 {
    if t < SERIES_THRESHOLD {
        d_series(t2)
    } else {
        // At θ ≥ 1, 1 − (θ/2)cot(θ/2) ≥ 0.08: at most about one digit cancels.
        let (s, c) = (0.5 * t).sin_cos();
        (1.0 - 0.5 * t * c / s) / t2
    }
}

#[inline]
fn d_series(t2: f64) -> f64 {
    {
        const K: [f64; 12] = [
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
        let mut s = 0.0;
        for k in K.iter().rev() {
            s = s * t2 + k;
        }
        s
    }
}

/// `I + α [φ] + β [φ]²`, with `[φ]² = φ φᵀ − θ² I`.
#[inline]
fn i_plus(phi: &Vector3<f64>, t2: f64, alpha: f64, beta: f64) -> Matrix3<f64> {
    let (x, y, z) = (phi.x, phi.y, phi.z);
    let d = 1.0 - beta * t2;
    Matrix3::new(
        d + beta * x * x,
        beta * x * y - alpha * z,
        beta * x * z + alpha * y,
        beta * x * y + alpha * z,
        d + beta * y * y,
        beta * y * z - alpha * x,
        beta * x * z - alpha * y,
        beta * y * z + alpha * x,
        d + beta * z * z,
    )
}

/// `Exp(φ) = I + (sin θ/θ)[φ] + ((1 − cos θ)/θ²)[φ]²` (Rodrigues), as a rotation matrix.
#[inline]
pub fn exp(phi: &Vector3<f64>) -> Rotation3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (a, b) = coeff_ab(t2, t);
    Rotation3::from_matrix_unchecked(i_plus(phi, t2, a, b))
}

/// `Exp(φ)` as a unit quaternion `(cos(θ/2), sin(θ/2) φ/θ)`, with the series `sin(θ/2)/θ =
/// 1/2 − θ²/48 + θ⁴/3840` for small `θ`.
#[inline]
pub fn exp_quat(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (k, w) = if t < SMALL {
        (0.5 - t2 / 48.0 * (1.0 - t2 / 80.0), 1.0 - t2 / 8.0)
    } else {
        let (s, c) = (0.5 * t).sin_cos();
        (s / t, c)
    };
    UnitQuaternion::new_unchecked(Quaternion::new(w, k * phi.x, k * phi.y, k * phi.z))
}

/// The unit quaternion of a rotation matrix by Shepperd's method: the largest of
/// `4w² = 1 + tr R`, `4x² = 1 + 2R₀₀ − tr R`, … is taken from the diagonal and the other three
/// components from the off-diagonal sums and differences, so every branch divides by a number
/// ≥ 1/2. Returned with `w ≥ 0`.
pub fn quat_from_matrix(r: &Matrix3<f64>) -> UnitQuaternion<f64> {
    let tr = r[(0, 0)] + r[(1, 1)] + r[(2, 2)];
    let d = [tr, r[(0, 0)], r[(1, 1)], r[(2, 2)]];
    let mut k = 0;
    for i in 1..4 {
        if d[i] > d[k] {
            k = i;
        }
    }
    let q = match k {
        0 => {
            let s = 2.0 * (1.0 + tr).sqrt(); // 4w
            Quaternion::new(
                0.25 * s,
                (r[(2, 1)] - r[(1, 2)]) / s,
                (r[(0, 2)] - r[(2, 0)]) / s,
                (r[(1, 0)] - r[(0, 1)]) / s,
            )
        }
        1 => {
            let s = 2.0 * (1.0 + 2.0 * r[(0, 0)] - tr).max(0.0).sqrt(); // 4x
            Quaternion::new(
                (r[(2, 1)] - r[(1, 2)]) / s,
                0.25 * s,
                (r[(0, 1)] + r[(1, 0)]) / s,
                (r[(0, 2)] + r[(2, 0)]) / s,
            )
        }
        2 => {
            let s = 2.0 * (1.0 + 2.0 * r[(1, 1)] - tr).max(0.0).sqrt(); // 4y
            Quaternion::new(
                (r[(0, 2)] - r[(2, 0)]) / s,
                (r[(0, 1)] + r[(1, 0)]) / s,
                0.25 * s,
                (r[(1, 2)] + r[(2, 1)]) / s,
            )
        }
        _ => {
            let s = 2.0 * (1.0 + 2.0 * r[(2, 2)] - tr).max(0.0).sqrt(); // 4z
            Quaternion::new(
                (r[(1, 0)] - r[(0, 1)]) / s,
                (r[(0, 2)] + r[(2, 0)]) / s,
                (r[(1, 2)] + r[(2, 1)]) / s,
                0.25 * s,
            )
        }
    };
    let q = if q.w < 0.0 { -q } else { q };
    // Renormalise: removes the O(ε) error of a not-quite-orthogonal input.
    let n = q.norm();
    if n > 0.0 && n.is_finite() {
        UnitQuaternion::new_unchecked(q / n)
    } else {
        UnitQuaternion::identity()
    }
}

/// `Log(q)`: the rotation vector `φ` (`|φ| ≤ π`) with `Exp(φ) = q`, from the hemisphere
/// `w ≥ 0`: `φ = 2 atan2(|v|, w) v/|v|`, with `atan(x)/x = 1 − x²/3 + x⁴/5` for `|v|/w < 1e-4`.
/// At exactly `θ = π` either of `±φ` is a correct answer; the one from `w = +0` is returned.
#[inline]
pub fn log_quat(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = q.quaternion();
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm();
    let k = if s < SMALL * w {
        let x2 = (s / w) * (s / w);
        2.0 / w * (1.0 - x2 / 3.0 * (1.0 - 0.6 * x2))
    } else {
        2.0 * s.atan2(w) / s
    };
    v * k
}

/// `Log(R)`: the rotation vector `φ` (`|φ| ≤ π`) with `Exp(φ) = R`, through
/// [`quat_from_matrix`] and [`log_quat`]; robust at `θ → 0` and `θ → π`.
#[inline]
pub fn log(r: &Rotation3<f64>) -> Vector3<f64> {
    log_quat(&quat_from_matrix(r.matrix()))
}

/// Right Jacobian `J_r(φ) = I − ((1 − cos θ)/θ²)[φ] + ((θ − sin θ)/θ³)[φ]²`.
#[inline]
pub fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (_, b) = coeff_ab(t2, t);
    i_plus(phi, t2, -b, coeff_c(t2, t))
}

/// Left Jacobian `J_l(φ) = I + ((1 − cos θ)/θ²)[φ] + ((θ − sin θ)/θ³)[φ]² = J_r(φ)ᵀ`.
#[inline]
pub fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let (_, b) = coeff_ab(t2, t);
    i_plus(phi, t2, b, coeff_c(t2, t))
}

/// Inverse right Jacobian `J_r⁻¹(φ) = I + ½[φ] + ((1 − (θ/2)cot(θ/2))/θ²)[φ]²` (`θ < 2π`).
#[inline]
pub fn right_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    i_plus(phi, t2, 0.5, coeff_d(t2, t))
}

/// Inverse left Jacobian `J_l⁻¹(φ) = I − ½[φ] + ((1 − (θ/2)cot(θ/2))/θ²)[φ]²` (`θ < 2π`).
#[inline]
pub fn left_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    i_plus(phi, t2, -0.5, coeff_d(t2, t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::random::SplitMix64;

    fn unit(rng: &mut SplitMix64) -> Vector3<f64> {
        loop {
            let v = Vector3::from_fn(|_, _| rng.range(-1.0, 1.0));
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }

    /// Reference `Exp` through nalgebra's axis-angle constructor.
    fn exp_ref(phi: &Vector3<f64>) -> Matrix3<f64> {
        Rotation3::new(*phi).into_inner()
    }

    /// The angles the brief asks for, plus a spread.
    fn angles() -> Vec<f64> {
        let mut a = vec![
            0.0,
            1e-300,
            1e-12,
            1e-8,
            1e-6,
            1e-4,
            0.29999,
            0.3,
            0.99999,
            1.0,
            1.00001,
            2.0,
            3.0,
            std::f64::consts::PI - 1e-6,
            std::f64::consts::PI - 1e-9,
            std::f64::consts::PI - 1e-12,
            std::f64::consts::PI,
        ];
        for k in 0..40 {
            a.push(std::f64::consts::PI * k as f64 / 40.0);
        }
        a
    }

    #[test]
    fn exp_matches_axis_angle_and_is_orthogonal() {
        let mut rng = SplitMix64(1);
        for t in angles() {
            for _ in 0..10 {
                let phi = unit(&mut rng) * t;
                let r = exp(&phi).into_inner();
                assert!((r - exp_ref(&phi)).abs().max() < 1e-15, "θ = {t}");
                let e = (r.transpose() * r - Matrix3::identity()).abs().max();
                assert!(e < 2e-15, "θ = {t}: {e:e}");
                let rq = exp_quat(&phi).to_rotation_matrix().into_inner();
                assert!((r - rq).abs().max() < 1e-15, "θ = {t}");
            }
        }
    }

    #[test]
    fn exp_log_round_trip_including_near_zero_and_pi() {
        // log(exp(φ)) = φ to an ulp of the angle (|φ| < π), and exp(log(R)) = R; at θ = π the
        // sign of φ is free.
        let mut rng = SplitMix64(2);
        let mut worst: f64 = 0.0;
        for t in angles() {
            for _ in 0..20 {
                let phi = unit(&mut rng) * t;
                let r = exp(&phi);
                let back = log(&r);
                let err = if t > std::f64::consts::PI - 1e-6 {
                    // Near π: the rotation fixes φ only up to sign when θ = π exactly, and the
                    // matrix rounds the angle at 1e-16 absolute.
                    (back - phi).norm().min((back + phi).norm())
                } else {
                    (back - phi).norm()
                };
                worst = worst.max(err);
                assert!(err < 2e-15, "θ = {t}: |log(exp φ) − φ| = {err:e}");
                let rr = exp(&back).into_inner();
                assert!((rr - r.matrix()).abs().max() < 1e-15, "θ = {t}");
                // The quaternion route too.
                let bq = log_quat(&exp_quat(&phi));
                let eq = (bq - phi).norm().min(if t >= std::f64::consts::PI - 1e-12 {
                    (bq + phi).norm()
                } else {
                    f64::INFINITY
                });
                assert!(eq < 2e-15, "θ = {t}: quaternion route {eq:e}");
            }
        }
        // Relative accuracy at tiny angles.
        for t in [1e-12, 1e-6] {
            let phi = Vector3::new(0.6, -0.8, 0.0) * t;
            let back = log(&exp(&phi));
            assert!((back - phi).norm() < 1e-15 * t, "θ = {t}");
        }
        assert!(worst < 2e-15);
    }

    #[test]
    fn log_of_exact_half_turns() {
        // Antipodal case: R = 2 n nᵀ − I has a zero skew part; the axis comes from the
        // symmetric part.
        let mut rng = SplitMix64(3);
        for _ in 0..100 {
            let n = unit(&mut rng);
            let r = 2.0 * n * n.transpose() - Matrix3::identity();
            let phi = log(&Rotation3::from_matrix_unchecked(r));
            assert!((phi.norm() - std::f64::consts::PI).abs() < 1e-15);
            let e = (phi / std::f64::consts::PI - n)
                .norm()
                .min((phi / std::f64::consts::PI + n).norm());
            assert!(e < 1e-15, "axis error {e:e}");
        }
        for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
            let r = 2.0 * axis * axis.transpose() - Matrix3::identity();
            let phi = log(&Rotation3::from_matrix_unchecked(r));
            assert!((phi.abs() - axis * std::f64::consts::PI).norm() < 1e-15);
        }
    }

    /// Central difference of `Exp` composed on the right: `Log(Exp(φ)ᵀ Exp(φ + h e_k)) / h`.
    fn fd_right(phi: &Vector3<f64>, h: f64) -> Matrix3<f64> {
        let r0 = exp(phi);
        Matrix3::from_fn(|i, k| {
            let mut e = Vector3::zeros();
            e[k] = h;
            let rp = r0.inverse() * exp(&(phi + e));
            let rm = r0.inverse() * exp(&(phi - e));
            (log(&rp)[i] - log(&rm)[i]) / (2.0 * h)
        })
    }

    fn fd_left(phi: &Vector3<f64>, h: f64) -> Matrix3<f64> {
        let r0 = exp(phi);
        Matrix3::from_fn(|i, k| {
            let mut e = Vector3::zeros();
            e[k] = h;
            let rp = exp(&(phi + e)) * r0.inverse();
            let rm = exp(&(phi - e)) * r0.inverse();
            (log(&rp)[i] - log(&rm)[i]) / (2.0 * h)
        })
    }

    #[test]
    fn jacobians_match_finite_differences() {
        // Central differences with h = 1e-5: truncation O(h²) ≈ 1e-10, rounding ε/h ≈ 1e-11.
        let mut rng = SplitMix64(4);
        let h = 1e-5;
        for t in [
            0.0, 1e-12, 1e-6, 0.01, 0.3, 0.9999, 1.0, 1.0001, 2.0, 2.9, 3.1,
        ] {
            for _ in 0..5 {
                let phi = unit(&mut rng) * t;
                let jr = right_jacobian(&phi);
                let jl = left_jacobian(&phi);
                assert!((jr - fd_right(&phi, h)).abs().max() < 2e-9, "J_r θ = {t}");
                assert!((jl - fd_left(&phi, h)).abs().max() < 2e-9, "J_l θ = {t}");
                assert!((jl - jr.transpose()).abs().max() < 1e-16);
                let jri = right_jacobian_inv(&phi);
                let jli = left_jacobian_inv(&phi);
                assert!(
                    (jr * jri - Matrix3::identity()).abs().max() < 1e-15,
                    "θ = {t}"
                );
                assert!(
                    (jl * jli - Matrix3::identity()).abs().max() < 1e-15,
                    "θ = {t}"
                );
                // Exp(φ) = J_l(φ) J_r(φ)⁻¹ ... the identity J_l = Exp(φ) J_r.
                let r = exp(&phi).into_inner();
                assert!((jl - r * jr).abs().max() < 1e-15);
            }
        }
    }

    #[test]
    fn inverse_jacobian_regular_at_pi() {
        let phi = Vector3::new(0.0, 0.0, std::f64::consts::PI);
        let jri = right_jacobian_inv(&phi);
        let jr = right_jacobian(&phi);
        assert!((jr * jri - Matrix3::identity()).abs().max() < 1e-15);
        assert!(jri.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn series_and_closed_forms_agree_at_the_switch() {
        // Both forms at the same θ on either side of the switch: the series is exact to 1e-20
        // there, so the difference is the closed form's rounding (about one lost digit, 5e-15).
        for t in [SERIES_THRESHOLD, 0.9, 1.1] {
            let t2 = t * t;
            let c_closed = (t - t.sin()) / (t2 * t);
            assert!(
                (c_series(t2) - c_closed).abs() < 5e-15 * c_closed,
                "c at {t}"
            );
            let (s, c) = (0.5 * t).sin_cos();
            let d_closed = (1.0 - 0.5 * t * c / s) / t2;
            assert!(
                (d_series(t2) - d_closed).abs() < 5e-15 * d_closed,
                "d at {t}: {:e}",
                (d_series(t2) - d_closed) / d_closed
            );
        }
        let t: f64 = SMALL;
        let (a0, b0) = coeff_ab(t * t * (1.0 - 1e-12), t * (1.0f64 - 1e-12).sqrt());
        let (a1, b1) = coeff_ab(t * t, t);
        assert!((a0 - a1).abs() < 1e-15 && (b0 - b1).abs() < 1e-15);
    }

    #[test]
    fn hat_vee() {
        let w = Vector3::new(1.0, -2.0, 3.0);
        let x = Vector3::new(0.3, 0.1, -0.7);
        assert_eq!(hat(&w) * x, w.cross(&x));
        assert_eq!(vee(&hat(&w)), w);
    }
}
