//! `sin` and `cos` of one angle together, inlined: the trigonometry of every step, planar and
//! spatial — each revolute joint's angle in a kinematic pass, the object's angle, the planar
//! rotations ([`rotation2`]), the reference paths and the sinusoidal disturbance.
//!
//! Why tandem's own: the library call is an out-of-line function of ~110 instructions that the
//! compiler can neither inline nor overlap with its neighbours, and it was 14 % of the 90 s
//! paper run (`docs/performance.md`, session 7). These ~40 instructions are inlined, so the
//! five angles of a constrained derivative run side by side. The same operations (no fused
//! multiply-add) give the same bits on every x86-64 and AArch64 machine, whatever its libm, for
//! every angle on the polynomial path (finite, nonzero, `|x| < 1e5`).
//!
//! Cody–Waite reduction `x = k π/2 + r`, `|r| ≤ π/4 (1 + 2⁻⁴⁰)`, with `π/2` split in three
//! 33-bit parts (so `k · part` is exact for `|k| < 2²⁰`), then the fdlibm minimax kernels
//! (`__kernel_sin`, `__kernel_cos`, degree 13 and 14) and the quadrant of `k`.
//!
//! **Accuracy: an absolute error within `2⁻⁵²` of the C library's values** (tested over 400 000
//! angles and every quadrant edge), so at most 2 ulp where `|value| ≥ ½`. It is not correctly
//! rounded, and near the zeros of `sin` and `cos` away from the origin (`sin(100π)`, say) the
//! *relative* error of the tiny result is larger, because the reduction drops fdlibm's tail
//! term: the absolute error stays below `2⁻⁵²`, which is what a rotation or a link direction
//! needs. Outside `|x| < 1e5` (and for ±0, NaN or ±∞) it falls back to `f64::sin_cos`. About 40
//! instructions instead of ~110 for the library call.

// The kernel constants are fdlibm's published decimals, kept verbatim.
#![allow(clippy::excessive_precision)]

const S1: f64 = -1.666_666_666_666_663_243_48e-1;
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

const C1: f64 = 4.166_666_666_666_660_190_37e-2;
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
const C5: f64 = 2.087_572_321_298_174_827_90e-9;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// `2/π`.
const INV_PIO2: f64 = std::f64::consts::FRAC_2_PI;
/// `π/2` in three parts of 33 significant bits each (fdlibm's `pio2_1`, `pio2_2`, `pio2_3`).
const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
const PIO2_3: f64 = 2.022_266_248_711_166_455_80e-21;

/// `(sin x, cos x)`; see the module doc for the method and accuracy.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if !(x.abs() < 1e5) || x == 0.0 {
        // Large, non-finite, or ±0 (whose sign the polynomial would lose).
        return x.sin_cos();
    }
    // Round to nearest by the 1.5·2⁵² trick (exact for |x·2/π| < 2⁵¹; `f64::round` is a
    // library call on baseline x86-64).
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let k = (x * INV_PIO2 + SHIFT) - SHIFT;
    let r = ((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3;
    let z = r * r;
    // sin r = r + r³ (S1 + z (S2 + … + z⁴ S6)).
    let ps = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    let s = r + r * z * (S1 + z * ps);
    // cos r = 1 − z/2 + z² (C1 + … + z⁵ C6), with fdlibm's compensated 1 − z/2.
    let pc = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let c = w + (((1.0 - w) - hz) + z * pc);
    match (k as i64) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// [`sin_cos`] of two angles at once, bit for bit: `[(sin a, cos a), (sin b, cos b)]`. On
/// x86-64 the two run in the lanes of one SSE2 register (part of the baseline, so no run-time
/// check): the same operations in the same order, each lane rounded as the scalar code rounds
/// it, and the quadrant applied by selects and sign flips, which are exact. Half the
/// instructions of two calls, for a 2-link arm's two link angles. Either angle outside the
/// polynomial's range (`|x| ≥ 1e5`, `±0`, NaN, `±∞`) sends both to [`sin_cos`].
#[inline(always)]
pub fn sin_cos2(a: f64, b: f64) -> [(f64, f64); 2] {
    #[cfg(target_arch = "x86_64")]
    {
        if a.abs() < 1e5 && a != 0.0 && b.abs() < 1e5 && b != 0.0 {
            // SAFETY: SSE2 is part of the x86-64 baseline.
            return unsafe { sse2::sin_cos2(a, b) };
        }
    }
    [sin_cos(a), sin_cos(b)]
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    use super::*;
    use std::arch::x86_64::{
        __m128d, _mm_add_epi32, _mm_add_pd, _mm_and_pd, _mm_and_si128, _mm_andnot_pd,
        _mm_castsi128_pd, _mm_cmpeq_epi32, _mm_cvtpd_epi32, _mm_mul_pd, _mm_or_pd, _mm_set_pd,
        _mm_set1_epi32, _mm_set1_pd, _mm_shuffle_epi32, _mm_storeu_pd, _mm_sub_pd, _mm_xor_pd,
    };

    /// `x` in both lanes.
    #[inline(always)]
    fn splat(x: f64) -> __m128d {
        // SAFETY: SSE2 (x86-64 baseline).
        unsafe { _mm_set1_pd(x) }
    }

    /// Two lanes of [`super::sin_cos`]'s polynomial path, `(sin, cos)` with `a` in lane 0 (both
    /// angles finite, nonzero and below `1e5` in magnitude: the caller's check).
    ///
    /// # Safety
    /// SSE2 (always present on x86-64).
    #[inline(always)]
    pub(super) unsafe fn sin_cos2_pd(a: f64, b: f64) -> (__m128d, __m128d) {
        // SAFETY: SSE2 arithmetic on registers.
        unsafe {
            let x = _mm_set_pd(b, a);
            const SHIFT: f64 = 6_755_399_441_055_744.0;
            let k = _mm_sub_pd(
                _mm_add_pd(_mm_mul_pd(x, splat(INV_PIO2)), splat(SHIFT)),
                splat(SHIFT),
            );
            let r = _mm_sub_pd(
                _mm_sub_pd(
                    _mm_sub_pd(x, _mm_mul_pd(k, splat(PIO2_1))),
                    _mm_mul_pd(k, splat(PIO2_2)),
                ),
                _mm_mul_pd(k, splat(PIO2_3)),
            );
            let z = _mm_mul_pd(r, r);
            // ps = S2 + z (S3 + z (S4 + z (S5 + z S6))); s = r + (r z)(S1 + z ps).
            let mut ps = _mm_add_pd(splat(S5), _mm_mul_pd(z, splat(S6)));
            ps = _mm_add_pd(splat(S4), _mm_mul_pd(z, ps));
            ps = _mm_add_pd(splat(S3), _mm_mul_pd(z, ps));
            ps = _mm_add_pd(splat(S2), _mm_mul_pd(z, ps));
            let s = _mm_add_pd(
                r,
                _mm_mul_pd(_mm_mul_pd(r, z), _mm_add_pd(splat(S1), _mm_mul_pd(z, ps))),
            );
            // pc = z (C1 + z (C2 + … + z C6)); c = w + (((1 − w) − hz) + z pc).
            let mut pc = _mm_add_pd(splat(C5), _mm_mul_pd(z, splat(C6)));
            pc = _mm_add_pd(splat(C4), _mm_mul_pd(z, pc));
            pc = _mm_add_pd(splat(C3), _mm_mul_pd(z, pc));
            pc = _mm_add_pd(splat(C2), _mm_mul_pd(z, pc));
            pc = _mm_add_pd(splat(C1), _mm_mul_pd(z, pc));
            pc = _mm_mul_pd(z, pc);
            let hz = _mm_mul_pd(splat(0.5), z);
            let w = _mm_sub_pd(splat(1.0), hz);
            let c = _mm_add_pd(
                w,
                _mm_add_pd(_mm_sub_pd(_mm_sub_pd(splat(1.0), w), hz), _mm_mul_pd(z, pc)),
            );
            // Quadrant q = k mod 4 (k is an integer below 2^16 in magnitude: exact in i32),
            // each lane's i32 copied into both halves of its 64-bit lane for the masks.
            let q = _mm_shuffle_epi32::<0b01_01_00_00>(_mm_cvtpd_epi32(k));
            let lane_mask = |bit: i32, add: i32| {
                let v = _mm_and_si128(_mm_add_epi32(q, _mm_set1_epi32(add)), _mm_set1_epi32(bit));
                _mm_castsi128_pd(_mm_cmpeq_epi32(v, _mm_set1_epi32(bit)))
            };
            // q odd: sin and cos swap; sin negated for q = 2, 3; cos for q = 1, 2.
            let swap = lane_mask(1, 0);
            let sign = splat(-0.0);
            let neg_s = _mm_and_pd(lane_mask(2, 0), sign);
            let neg_c = _mm_and_pd(lane_mask(2, 1), sign);
            let sin = _mm_xor_pd(
                _mm_or_pd(_mm_and_pd(swap, c), _mm_andnot_pd(swap, s)),
                neg_s,
            );
            let cos = _mm_xor_pd(
                _mm_or_pd(_mm_and_pd(swap, s), _mm_andnot_pd(swap, c)),
                neg_c,
            );
            (sin, cos)
        }
    }

    /// [`sin_cos2_pd`] as pairs.
    ///
    /// # Safety
    /// As [`sin_cos2_pd`].
    #[inline(always)]
    pub(super) unsafe fn sin_cos2(a: f64, b: f64) -> [(f64, f64); 2] {
        // SAFETY: the caller's range check; SSE2 stores into local arrays.
        unsafe {
            let (sin, cos) = sin_cos2_pd(a, b);
            let (mut so, mut co) = ([0.0; 2], [0.0; 2]);
            _mm_storeu_pd(so.as_mut_ptr(), sin);
            _mm_storeu_pd(co.as_mut_ptr(), cos);
            [(so[0], co[0]), (so[1], co[1])]
        }
    }
}

/// [`sin_cos2`] as lanes, bit for bit: `(sin, cos)` with `a` in lane 0, `b` in lane 1 (for
/// callers that go on computing in SSE2 lanes).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn sin_cos2_pd(
    a: f64,
    b: f64,
) -> (std::arch::x86_64::__m128d, std::arch::x86_64::__m128d) {
    use std::arch::x86_64::_mm_set_pd;
    if a.abs() < 1e5 && a != 0.0 && b.abs() < 1e5 && b != 0.0 {
        // SAFETY: SSE2 is part of the x86-64 baseline; the range is checked.
        return unsafe { sse2::sin_cos2_pd(a, b) };
    }
    let [(sa, ca), (sb, cb)] = [sin_cos(a), sin_cos(b)];
    // SAFETY: SSE2 (x86-64 baseline).
    unsafe { (_mm_set_pd(sb, sa), _mm_set_pd(cb, ca)) }
}

/// The planar rotation by `theta` from [`sin_cos`]: `[[c, −s], [s, c]]`, the matrix
/// `nalgebra::Rotation2::new` builds from the library's `sin_cos`.
#[inline(always)]
pub fn rotation2(theta: f64) -> nalgebra::Rotation2<f64> {
    let (s, c) = sin_cos(theta);
    nalgebra::Rotation2::from_matrix_unchecked(nalgebra::Matrix2::new(c, -s, s, c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::random::SplitMix64;

    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        // Distance in units of the larger value's ulp (a denormal-safe floor).
        let m = a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
        (a - b).abs() / (m * f64::EPSILON)
    }

    #[test]
    fn the_pair_gives_the_single_angle_bits() {
        let mut rng = SplitMix64(32);
        let bits = |(s, c): (f64, f64)| (s.to_bits(), c.to_bits());
        let check = |a: f64, b: f64| {
            let [pa, pb] = sin_cos2(a, b);
            assert_eq!(bits(pa), bits(sin_cos(a)), "{a}");
            assert_eq!(bits(pb), bits(sin_cos(b)), "{b}");
        };
        for _ in 0..200_000 {
            check(rng.range(-4.0, 4.0), rng.range(-4.0, 4.0));
            check(rng.range(-1e4, 1e4), rng.range(-7.0, 7.0));
        }
        // Every octant boundary k π/4, its two neighbours in f64 and points 1e-9 away, in
        // both lanes against every other; the fallbacks (±0, subnormals, 1e5, NaN, ±∞).
        let mut edge = Vec::new();
        for k in -40..40 {
            let x = k as f64 * std::f64::consts::FRAC_PI_4;
            edge.extend([x, x.next_up(), x.next_down(), x + 1e-9, x - 1e-9]);
        }
        edge.extend([
            0.0,
            -0.0,
            1e-308,
            5e-324,
            -5e-324,
            99_999.0,
            100_000.0,
            -1e10,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ]);
        for &a in &edge {
            for &b in &edge {
                let [pa, pb] = sin_cos2(a, b);
                let same = |p: (f64, f64), x: f64| {
                    let q = sin_cos(x);
                    (p.0.to_bits() == q.0.to_bits() || (p.0.is_nan() && q.0.is_nan()))
                        && (p.1.to_bits() == q.1.to_bits() || (p.1.is_nan() && q.1.is_nan()))
                };
                assert!(same(pa, a) && same(pb, b), "{a}, {b}");
                // The lanes of sin_cos2_pd, its fallbacks included.
                #[cfg(target_arch = "x86_64")]
                {
                    let (sl, cl) = sin_cos2_pd(a, b);
                    let (mut so, mut co) = ([0.0; 2], [0.0; 2]);
                    // SAFETY: SSE2 stores into local arrays.
                    unsafe {
                        std::arch::x86_64::_mm_storeu_pd(so.as_mut_ptr(), sl);
                        std::arch::x86_64::_mm_storeu_pd(co.as_mut_ptr(), cl);
                    }
                    assert!(
                        same((so[0], co[0]), a) && same((so[1], co[1]), b),
                        "{a}, {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn agrees_with_the_library_within_2_pow_minus_52() {
        let mut rng = SplitMix64(31);
        let mut worst: f64 = 0.0;
        let mut check = |x: f64| {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            // Near a zero of sin or cos the relative error of either grows; compare on the
            // absolute scale of 1 there, the standard for trigonometric kernels.
            let es = ulps(s, s0).min((s - s0).abs() / f64::EPSILON);
            let ec = ulps(c, c0).min((c - c0).abs() / f64::EPSILON);
            worst = worst.max(es).max(ec);
        };
        for _ in 0..200_000 {
            check(rng.range(-4.0, 4.0));
            check(rng.range(-1e4, 1e4));
        }
        for k in -40..40 {
            let x = k as f64 * std::f64::consts::FRAC_PI_4;
            for d in [0.0, 1e-300, 1e-16, -1e-16, 1e-9, -1e-9] {
                check(x + d);
            }
        }
        for x in [0.0, -0.0, 1e-308, 5e-324, 99_999.0, 100_000.0, 1e10] {
            check(x);
        }
        // `worst` is the smaller of the ulp distance and the absolute distance in units of
        // 2⁻⁵², so for values of magnitude ≤ 1 this bounds the absolute error by 2⁻⁵².
        assert!(worst <= 1.0, "worst {worst}");
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
        assert_eq!(sin_cos(-0.0).0.to_bits(), (-0.0f64).to_bits());
    }
}
