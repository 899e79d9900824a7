//! `S(Z)`'s grid factors for the AVX-512 kernels: the exponentials of (8) eight at a time, and
//! the Kronecker products `A`, `B` a register at a time.
//!
//! * [`exp`] replaces 24 calls to the C library's `exp` (the paper's grid) by three register
//!   evaluations. It is not the library's function, so the factors differ from the portable
//!   reference's by an ulp or two; the AVX-512 kernels are within the determinism policy's
//!   tolerance, not bit-identical, so this is theirs to take (tested against `f64::exp`).
//! * [`kron`] forms the same products in the same order as `super::basis::kron_into`, so its bits
//!   are the same: the tail inputs whose levels multiply to 8 (the last three of the paper's
//!   grid) vary inside a register, and every register is its prefix product times those
//!   inputs' lane patterns, multiplied in input order.

#![cfg(target_arch = "x86_64")]

use std::arch::x86_64::{
    __m512d, __mmask8, _mm512_and_si512, _mm512_fmadd_pd, _mm512_fnmadd_pd,
    _mm512_mask_i64gather_pd, _mm512_mask_storeu_pd, _mm512_maskz_loadu_epi64,
    _mm512_maskz_loadu_pd, _mm512_max_pd, _mm512_min_pd, _mm512_mul_pd, _mm512_permutex2var_pd,
    _mm512_permutexvar_pd, _mm512_roundscale_pd, _mm512_scalef_pd, _mm512_set_epi64,
    _mm512_set1_epi64, _mm512_set1_pd, _mm512_setzero_pd, _mm512_srlv_epi64, _mm512_storeu_pd,
    _mm512_sub_pd,
};

/// Lanes of an AVX-512 register of `f64`.
const LANE: usize = 8;

/// `e^x` on 8 lanes: `x = k ln 2 + r` with `k = round(x / ln 2)` and `|r| ≤ ln 2 / 2`
/// (Cody–Waite, `ln 2` in two parts), `e^r` by its Taylor polynomial to degree 13 (truncation
/// below `5e-18` relative) in Horner form with fused multiply-adds, and `2^k e^r` by
/// `vscalefpd`, which gives 0 for very negative `x`, `+∞` for very positive `x`, and keeps
/// NaN. Measured against `f64::exp` (test `vector_exp_is_within_two_ulps`): within 2 ulps.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn exp(x: __m512d) -> __m512d {
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    // ln 2 = LN2_HI + LN2_LO, LN2_HI with its low 11 bits clear (k·LN2_HI exact for |k| < 2^11).
    const LN2_HI: f64 = 0.693_147_180_369_123_8;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    // 1/n! for n = 13 down to 0.
    const C: [f64; 14] = [
        1.0 / 6_227_020_800.0,
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ];
    // Below −746 the result is 0 and above 710 it is +∞ anyway; the clamp keeps `k` small
    // enough for `k·LN2_HI` to be exact, and ±∞ out of the reduction (∞ − ∞). `max`/`min`
    // return their second operand when either is NaN, so NaN passes through.
    let x = _mm512_max_pd(_mm512_set1_pd(-746.0), x);
    let x = _mm512_min_pd(_mm512_set1_pd(710.0), x);
    // k = round(x / ln 2) (imm 0x08: to nearest, exceptions suppressed).
    let k = _mm512_roundscale_pd::<0x08>(_mm512_mul_pd(x, _mm512_set1_pd(LOG2E)));
    let r = _mm512_fnmadd_pd(k, _mm512_set1_pd(LN2_HI), x);
    let r = _mm512_fnmadd_pd(k, _mm512_set1_pd(LN2_LO), r);
    let mut p = _mm512_set1_pd(C[0]);
    for &c in &C[1..] {
        p = _mm512_fmadd_pd(p, r, _mm512_set1_pd(c));
    }
    _mm512_scalef_pd(p, k)
}

/// `f[l] = e^{−(z_{i(l)} − c_l)² / ϑ²}` for every level `l` (input `i(l) = input_of[l]`), with
/// the argument formed as the portable path forms it. Each register's `z_{i(l)}` is gathered by
/// the precomputed indices and its levels loaded as they lie, and the result stored in place
/// (the last register masked): no lane is written by a scalar store and read back as a vector,
/// which stalls store forwarding.
///
/// # Safety
/// The CPU must support AVX-512F. Panics unless `levels`, `input_of` and `f` have one length
/// and every `input_of[l] < z.len()`.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn gaussians(
    z: &[f64],
    levels: &[f64],
    input_of: &[i64],
    inv_width2: f64,
    f: &mut [f64],
) {
    let n = f.len();
    assert!(levels.len() == n && input_of.len() == n);
    // One branch for all indices (an `all` closure is not inlined here: a call an index).
    let mut in_bounds = true;
    for &i in input_of {
        in_bounds &= (i as u64) < z.len() as u64;
    }
    assert!(in_bounds, "gaussians: an input index is out of range");
    // Up to 16 inputs sit in two registers, and a two-source permute selects each lane's
    // input (a gather, the fallback, waits on eight loads a register).
    let nz = z.len();
    let (z_lo, z_hi) = if nz <= 2 * LANE {
        let m_lo = if nz >= LANE {
            0xff
        } else {
            ((1u32 << nz) - 1) as u8
        };
        let m_hi = if nz >= 2 * LANE {
            0xff
        } else {
            ((1u32 << nz.saturating_sub(LANE)) - 1) as u8
        };
        // SAFETY: AVX-512F (caller's contract); the masks cover `z[..nz]` only.
        unsafe {
            (
                _mm512_maskz_loadu_pd(m_lo, z.as_ptr()),
                _mm512_maskz_loadu_pd(m_hi, z.as_ptr().add(nz.min(LANE))),
            )
        }
    } else {
        (_mm512_setzero_pd(), _mm512_setzero_pd())
    };
    let mut l0 = 0;
    while l0 < n {
        let len = LANE.min(n - l0);
        let mask: __mmask8 = if len == LANE { 0xff } else { (1u8 << len) - 1 };
        // SAFETY: AVX-512F (caller's contract); lanes `l0 .. l0 + len` of the three slices are
        // in bounds, the others masked off; the gathered indices are `< z.len()` (assert).
        unsafe {
            let idx = _mm512_maskz_loadu_epi64(mask, input_of.as_ptr().add(l0).cast());
            let zl = if nz <= 2 * LANE {
                _mm512_permutex2var_pd(z_lo, idx, z_hi)
            } else {
                _mm512_mask_i64gather_pd::<8>(_mm512_setzero_pd(), mask, idx, z.as_ptr().cast())
            };
            let cl = _mm512_maskz_loadu_pd(mask, levels.as_ptr().add(l0));
            let d = _mm512_sub_pd(zl, cl);
            let arg = _mm512_mul_pd(
                _mm512_mul_pd(_mm512_mul_pd(d, d), _mm512_set1_pd(-1.0)),
                _mm512_set1_pd(inv_width2),
            );
            _mm512_mask_storeu_pd(f.as_mut_ptr().add(l0), mask, exp(arg));
        }
        l0 += len;
    }
}

/// `out = f_from ⊗ … ⊗ f_{to−1}` (the last input varying fastest), the same products in the
/// same order as `super::basis::kron_into`, hence the same bits; `tmp` as long as `out`.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn kron(
    f: &[f64],
    offsets: &[usize],
    from: usize,
    to: usize,
    out: &mut [f64],
    tmp: &mut [f64],
) {
    // The tail inputs whose levels multiply to exactly one register.
    let mut split = to;
    let mut lanes = 1;
    while split > from && lanes < LANE {
        lanes *= offsets[split] - offsets[split - 1];
        split -= 1;
    }
    if lanes != LANE || out.len() < LANE {
        super::basis::kron_into(f, offsets, from, to, out, tmp);
        return;
    }
    let regs = out.len() / LANE;
    // A prefix of exactly one register (the paper's grid: three inputs of two levels before
    // the tail's three) is formed in a register too, below; else by `kron_into`.
    // (Every prefix input a power of two, their product exactly one register: the lane
    // patterns and the masked loads below rely on both.)
    let mut prefix_in_register = regs == LANE;
    let mut plen = 1usize;
    for i in from..split {
        let n = offsets[i + 1] - offsets[i];
        prefix_in_register &= n.is_power_of_two();
        plen = plen.saturating_mul(n);
    }
    prefix_in_register &= plen == LANE;
    // The prefix products (one a register), by `kron_into` itself in two eighths of `tmp`.
    let (prefix, rest) = tmp.split_at_mut(regs);
    if !prefix_in_register {
        super::basis::kron_into(f, offsets, from, split, prefix, &mut rest[..regs]);
    }
    let prefix = &*prefix;
    // SAFETY: AVX-512F (caller's contract); every access in bounds (`regs·8 = out.len()`).
    unsafe {
        // The inputs' lane patterns: lane `t` holds the level of input `i` that index `t` has,
        // `(t / stride) % n`. The levels of the tail multiply to 8, so every `n` and `stride`
        // is a power of two: `(t >> log2 stride) & (n − 1)`, formed in registers (lanes built
        // in memory would stall the load that reads them back).
        let iota = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
        let mut pattern = [_mm512_setzero_pd(); LANE];
        let mut stride = LANE;
        for (i, pat) in (split..to).zip(&mut pattern) {
            let n = offsets[i + 1] - offsets[i];
            stride /= n;
            let idx = _mm512_and_si512(
                _mm512_srlv_epi64(iota, _mm512_set1_epi64(stride.trailing_zeros().into())),
                _mm512_set1_epi64(n as i64 - 1),
            );
            let levels = _mm512_maskz_loadu_pd(((1u32 << n) - 1) as u8, f.as_ptr().add(offsets[i]));
            *pat = _mm512_permutexvar_pd(idx, levels);
        }
        if prefix_in_register {
            // Lane `r` of `pv` is prefix product `r`: `1·f_from[l]` (exact, as `kron_into`
            // starts from 1), then times each further prefix input's lane pattern, in order.
            let mut pv = _mm512_set1_pd(1.0);
            let mut stride = LANE;
            for i in from..split {
                let n = offsets[i + 1] - offsets[i];
                stride /= n;
                let idx = _mm512_and_si512(
                    _mm512_srlv_epi64(iota, _mm512_set1_epi64(stride.trailing_zeros().into())),
                    _mm512_set1_epi64(n as i64 - 1),
                );
                let levels =
                    _mm512_maskz_loadu_pd(((1u32 << n) - 1) as u8, f.as_ptr().add(offsets[i]));
                pv = _mm512_mul_pd(pv, _mm512_permutexvar_pd(idx, levels));
            }
            match to - split {
                1 => tail_products_of::<1>(pv, &pattern, out),
                2 => tail_products_of::<2>(pv, &pattern, out),
                3 => tail_products_of::<3>(pv, &pattern, out),
                n => {
                    for r in 0..LANE {
                        let mut x = _mm512_permutexvar_pd(_mm512_set1_epi64(r as i64), pv);
                        for &pat in &pattern[..n] {
                            x = _mm512_mul_pd(x, pat);
                        }
                        _mm512_storeu_pd(out.as_mut_ptr().add(r * LANE), x);
                    }
                }
            }
            return;
        }
        // A constant pattern count for the usual tails (three inputs of two levels, and so
        // on), so that the patterns stay in registers and the loop is unrolled.
        match to - split {
            1 => tail_products::<1>(prefix, &pattern, out),
            2 => tail_products::<2>(prefix, &pattern, out),
            3 => tail_products::<3>(prefix, &pattern, out),
            n => {
                for (r, &pr) in prefix.iter().enumerate() {
                    let mut x = _mm512_set1_pd(pr);
                    for &pat in &pattern[..n] {
                        x = _mm512_mul_pd(x, pat);
                    }
                    _mm512_storeu_pd(out.as_mut_ptr().add(r * LANE), x);
                }
            }
        }
    }
}

/// `out`'s register `r` = lane `r` of `pv` times the first `P` lane patterns, in order (the
/// products of [`kron`] with its prefix in a register).
///
/// # Safety
/// The CPU must support AVX-512F; `out.len() ≥ 64`.
#[inline(always)]
unsafe fn tail_products_of<const P: usize>(
    pv: __m512d,
    pattern: &[__m512d; LANE],
    out: &mut [f64],
) {
    assert!(P <= LANE && out.len() >= LANE * LANE);
    // SAFETY: AVX-512F (caller's contract); register `r < 8` is in bounds by the assert.
    unsafe {
        for r in 0..LANE {
            let mut x = _mm512_permutexvar_pd(_mm512_set1_epi64(r as i64), pv);
            for pat in &pattern[..P] {
                x = _mm512_mul_pd(x, *pat);
            }
            _mm512_storeu_pd(out.as_mut_ptr().add(r * LANE), x);
        }
    }
}

/// `out`'s register `r` = `prefix[r]` times the first `P` lane patterns, in order (the
/// products of [`kron`]).
///
/// # Safety
/// The CPU must support AVX-512F; `out.len() ≥ 8·prefix.len()`.
#[inline(always)]
unsafe fn tail_products<const P: usize>(
    prefix: &[f64],
    pattern: &[__m512d; LANE],
    out: &mut [f64],
) {
    assert!(P <= LANE && out.len() >= LANE * prefix.len());
    // SAFETY: AVX-512F (caller's contract); register `r` is in bounds by the assert.
    unsafe {
        for (r, &pr) in prefix.iter().enumerate() {
            let mut x = _mm512_set1_pd(pr);
            for pat in &pattern[..P] {
                x = _mm512_mul_pd(x, *pat);
            }
            _mm512_storeu_pd(out.as_mut_ptr().add(r * LANE), x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::arch::x86_64::_mm512_loadu_pd;

    fn avx512() -> bool {
        std::arch::is_x86_feature_detected!("avx512f")
    }

    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    fn exp8(x: [f64; 8]) -> [f64; 8] {
        let mut out = [0.0; 8];
        // SAFETY: only called after `avx512()`; 8 lanes each way.
        unsafe { _mm512_storeu_pd(out.as_mut_ptr(), exp(_mm512_loadu_pd(x.as_ptr()))) };
        out
    }

    #[test]
    fn vector_exp_is_within_two_ulps() {
        if !avx512() {
            return;
        }
        let mut worst = 0;
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        for k in 0..200_000 {
            let mut x = [0.0; 8];
            for v in &mut x {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let u = (s >> 11) as f64 / (1u64 << 53) as f64;
                // Mostly the Gaussians' range (−2, 0], then down to underflow.
                *v = if k % 4 == 0 { -745.0 * u } else { -2.0 * u };
            }
            for (a, b) in exp8(x).iter().zip(x.map(f64::exp)) {
                // Subnormal results: compare absolutely (one subnormal ulp is 5e-324).
                let d = if b < f64::MIN_POSITIVE {
                    ((a - b).abs() / 4.9e-324) as u64
                } else {
                    ulps(*a, b)
                };
                worst = worst.max(d);
            }
        }
        eprintln!("vector exp: worst {worst} ulps against f64::exp");
        assert!(worst <= 2, "worst {worst} ulps");
        // Edges: 0, −0, ±∞, NaN, the underflow threshold, large positive.
        let e = exp8([
            0.0,
            -0.0,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NAN,
            -746.0,
            -1e300,
            800.0,
        ]);
        assert_eq!(e[..2], [1.0, 1.0]);
        assert_eq!(e[2], 0.0);
        assert_eq!(e[3], f64::INFINITY);
        assert!(e[4].is_nan());
        assert_eq!(e[5..7], [0.0, 0.0]);
        assert_eq!(e[7], f64::INFINITY);
    }

    /// The register-wide Kronecker product gives the bits of `kron_into`, for grids with and
    /// without a tail of 8 lanes (the others fall back).
    #[test]
    fn register_kron_equals_the_scalar_kron_bitwise() {
        if !avx512() {
            return;
        }
        // One-register prefixes (formed in a register): the paper's halves, other shapes of
        // eight before a tail of one to four inputs; and longer prefixes (`kron_into`).
        let grids: [&[usize]; 14] = [
            &[2, 2, 2, 2, 2, 2],
            &[2, 4, 2, 2, 2],
            &[8, 2, 2, 2],
            &[2, 1, 4, 2, 2, 2],
            &[2, 2, 2, 4, 2],
            &[2, 2, 2, 8],
            &[4, 2, 1, 2, 2, 2, 1],
            &[4, 2, 2, 2, 2, 2],
            &[2, 2, 2],
            &[4, 2],
            &[3, 8],
            &[2, 3, 4, 2],
            &[3, 3],
            &[2, 2, 1, 2, 2],
        ];
        let mut s = 7u64;
        for levels in grids {
            let mut offsets = vec![0];
            for n in levels {
                offsets.push(offsets.last().unwrap() + n);
            }
            let f: Vec<f64> = (0..offsets[levels.len()])
                .map(|_| {
                    s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                    0.1 + (s >> 11) as f64 / (1u64 << 53) as f64
                })
                .collect();
            let len: usize = levels.iter().product();
            let (mut a, mut t) = (vec![0.0; len], vec![0.0; len]);
            let (mut b, mut u) = (vec![0.0; len], vec![0.0; len]);
            // SAFETY: AVX-512F checked above.
            unsafe { kron(&f, &offsets, 0, levels.len(), &mut a, &mut t) };
            crate::control::rbf::basis::kron_into(&f, &offsets, 0, levels.len(), &mut b, &mut u);
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{levels:?}"
            );
        }
    }

    #[test]
    fn vector_gaussians_match_the_scalar_ones() {
        if !avx512() {
            return;
        }
        let levels = [-1.0, 1.0, -1.0, 0.0, 0.5, 1.0, -2.0, 2.0, 0.0, 0.3, 0.7];
        let offsets = [0, 2, 6, 8, 11];
        let z = [0.3, -0.7, 1e200, f64::NAN];
        let input_of = [0, 0, 1, 1, 1, 1, 2, 2, 3, 3, 3];
        // Guard values beyond the slice: the masked tail must not write them.
        let mut buf = [7.0; 13];
        let f = &mut buf[..11];
        // SAFETY: AVX-512F checked above.
        unsafe { gaussians(&z, &levels, &input_of, 1.0 / 3.0, f) };
        for i in 0..4 {
            for l in offsets[i]..offsets[i + 1] {
                let d = z[i] - levels[l];
                let e = (-(d * d) * (1.0 / 3.0)).exp();
                assert!(ulps(f[l], e) <= 2 || (f[l].is_nan() && e.is_nan()), "{l}");
            }
        }
        assert_eq!(f[6..8], [0.0, 0.0]);
        assert_eq!(buf[11..], [7.0, 7.0]);
    }

    /// Every input count picks its inputs right: up to 8 (one register), 9 to 16 (the
    /// two-source permute) and beyond (the gather), with 1 to 3 levels an input.
    #[test]
    fn vector_gaussians_pick_each_levels_input_for_any_input_count() {
        if !avx512() {
            return;
        }
        for n_in in [1, 3, 8, 9, 12, 16, 17, 24] {
            let counts: Vec<usize> = (0..n_in).map(|i| 1 + (i * 7) % 3).collect();
            let input_of: Vec<i64> = counts
                .iter()
                .enumerate()
                .flat_map(|(i, &c)| std::iter::repeat_n(i as i64, c))
                .collect();
            let levels: Vec<f64> = (0..input_of.len()).map(|l| -1.0 + 0.1 * l as f64).collect();
            let z: Vec<f64> = (0..n_in).map(|i| 0.37 * i as f64 - 2.0).collect();
            let mut f = vec![0.0; levels.len()];
            // SAFETY: AVX-512F checked above; every index `< n_in`.
            unsafe { gaussians(&z, &levels, &input_of, 0.5, &mut f) };
            for (l, (&i, &c)) in input_of.iter().zip(&levels).enumerate() {
                let d = z[i as usize] - c;
                let e = (-(d * d) * 0.5).exp();
                assert!(
                    ulps(f[l], e) <= 2,
                    "{n_in} inputs, level {l}: {} vs {e}",
                    f[l]
                );
            }
        }
    }
}
