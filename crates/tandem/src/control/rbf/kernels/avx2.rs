//! AVX2 builds of the kernels: the same operations in the same order as the portable ones,
//! so the same bits. Register `r` of a block holds lanes `4r..4r+4`; the `S` value of each lane
//! (node `i / M`) is put in place by one `vpermd` with a precomputed index.
//!
//! Written to build on the first MSRV (1.85; now 1.89): the entry points are `unsafe fn` with
//! `#[target_feature]`, and the bodies are `#[inline(always)]` helpers without features (so
//! every intrinsic call is `unsafe` on every toolchain) that inline into them. No closures:
//! they would not inherit the target feature on 1.85.

use super::{BLOCK, MAX_LANES, MAX_OUTPUTS, reduce, s_tail};
use std::arch::x86_64::{
    __m256d, __m256i, _mm256_add_pd, _mm256_castpd_si256, _mm256_castsi256_pd, _mm256_fmadd_pd,
    _mm256_fnmadd_pd, _mm256_loadu_pd, _mm256_loadu_si256, _mm256_mul_pd,
    _mm256_permutevar8x32_epi32, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
    _mm256_sub_pd,
};

/// `acc + x·y`: two roundings, or one FMA if `FMA`.
///
/// # Safety
/// The CPU must support AVX2 (and FMA if `FMA`).
#[inline(always)]
unsafe fn mul_add<const FMA: bool>(x: __m256d, y: __m256d, acc: __m256d) -> __m256d {
    // SAFETY: caller's contract.
    unsafe {
        if FMA {
            _mm256_fmadd_pd(x, y, acc)
        } else {
            _mm256_add_pd(acc, _mm256_mul_pd(x, y))
        }
    }
}

/// Per-register constants and accumulators of one pass.
struct Regs<const M: usize> {
    /// `e_j`, `c_j` of each lane.
    e: [__m256d; M],
    c: [__m256d; M],
    /// 32-bit permutation that spreads the block's 4 `S` values over the lanes.
    idx: [__m256i; M],
    acc: [__m256d; M],
    n2: [__m256d; M],
}

/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn regs<const M: usize>(e: &[f64; M], c: &[f64; M]) -> Regs<M> {
    const { assert!(M >= 1 && M <= MAX_OUTPUTS) };
    // SAFETY: every load reads a local array of the right size; AVX2 (caller's contract).
    unsafe {
        let zero = _mm256_setzero_pd();
        let mut r = Regs {
            e: [zero; M],
            c: [zero; M],
            idx: [_mm256_castpd_si256(zero); M],
            acc: [zero; M],
            n2: [zero; M],
        };
        for q in 0..M {
            let mut ev = [0.0; BLOCK];
            let mut cv = [0.0; BLOCK];
            let mut iv = [0i32; 2 * BLOCK];
            for t in 0..BLOCK {
                let i = BLOCK * q + t;
                ev[t] = e[i % M];
                cv[t] = c[i % M];
                let node = (i / M) as i32;
                iv[2 * t] = 2 * node;
                iv[2 * t + 1] = 2 * node + 1;
            }
            r.e[q] = _mm256_loadu_pd(ev.as_ptr());
            r.c[q] = _mm256_loadu_pd(cv.as_ptr());
            r.idx[q] = _mm256_loadu_si256(iv.as_ptr().cast());
        }
        r
    }
}

/// Lanes of `v` in order, then [`reduce`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn sums<const M: usize>(v: &[__m256d; M]) -> [f64; M] {
    let mut l = [0.0; MAX_LANES];
    for (q, chunk) in l.chunks_exact_mut(BLOCK).take(M).enumerate() {
        // SAFETY: `chunk` holds exactly BLOCK = 4 f64; AVX2 (caller's contract).
        unsafe { _mm256_storeu_pd(chunk.as_mut_ptr(), v[q]) };
    }
    reduce(&l)
}

/// Load 4 lanes.
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn load(x: &[f64]) -> __m256d {
    assert!(x.len() >= BLOCK);
    // SAFETY: bounds checked above (unaligned load); AVX2 (caller's contract).
    unsafe { _mm256_loadu_pd(x.as_ptr()) }
}

/// Store 4 lanes.
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn store(x: &mut [f64], v: __m256d) {
    assert!(x.len() >= BLOCK);
    // SAFETY: bounds checked above (unaligned store); AVX2 (caller's contract).
    unsafe { _mm256_storeu_pd(x.as_mut_ptr(), v) }
}

/// `S` of each lane of register `q`.
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn spread(sv: __m256d, idx: __m256i) -> __m256d {
    // SAFETY: AVX2 (caller's contract).
    unsafe { _mm256_castsi256_pd(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(sv), idx)) }
}

/// One block of the fused pass (`wb.len() ≥ 4M`): per lane `acc += old·S`,
/// `w = e·old − c·S`, `n2 += w·w`.
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn tick_block<const M: usize, const OUT: bool, const NORM: bool, const FMA: bool>(
    wb: &mut [f64],
    sv: __m256d,
    r: &mut Regs<M>,
) {
    for (q, wq) in wb.chunks_exact_mut(BLOCK).take(M).enumerate() {
        // SAFETY: AVX2 (caller's contract).
        unsafe {
            let sq = spread(sv, r.idx[q]);
            let old = load(wq);
            if OUT {
                r.acc[q] = mul_add::<FMA>(old, sq, r.acc[q]);
            }
            let new = if FMA {
                _mm256_fnmadd_pd(r.c[q], sq, _mm256_mul_pd(r.e[q], old))
            } else {
                _mm256_sub_pd(_mm256_mul_pd(r.e[q], old), _mm256_mul_pd(r.c[q], sq))
            };
            store(wq, new);
            if NORM {
                r.n2[q] = mul_add::<FMA>(new, new, r.n2[q]);
            }
        }
    }
}

/// [`super::kernel_tick`] on AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn tick<const M: usize, const OUT: bool>(
    w: &mut [f64],
    s: &[f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 (caller's contract).
    unsafe { tick_body::<M, OUT, false>(w, s, e, c) }
}

/// [`tick`] with FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn tick_fma<const M: usize, const OUT: bool>(
    w: &mut [f64],
    s: &[f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 and FMA (caller's contract).
    unsafe { tick_body::<M, OUT, true>(w, s, e, c) }
}

/// The body of [`tick`] and [`tick_fma`].
///
/// # Safety
/// The CPU must support AVX2 (and FMA if `FMA`).
#[inline(always)]
unsafe fn tick_body<const M: usize, const OUT: bool, const FMA: bool>(
    w: &mut [f64],
    s: &[f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 (caller's contract).
    unsafe {
        let mut r = regs(e, c);
        let full = s.len() / BLOCK;
        let (w_full, w_tail) = w.split_at_mut(full * BLOCK * M);
        for (wb, sb) in w_full
            .chunks_exact_mut(BLOCK * M)
            .zip(s.chunks_exact(BLOCK))
        {
            tick_block::<M, OUT, true, FMA>(wb, load(sb), &mut r);
        }
        if !w_tail.is_empty() {
            let mut tmp = [0.0; MAX_LANES];
            tmp[..w_tail.len()].copy_from_slice(w_tail);
            tick_block::<M, OUT, true, FMA>(&mut tmp, load(&s_tail(s)), &mut r);
            w_tail.copy_from_slice(&tmp[..w_tail.len()]);
        }
        (sums(&r.acc), sums(&r.n2))
    }
}

/// Fused tick on a grid basis: `S = A ⊗ B` formed block by block (`a_i · b[4k..4k+4]`,
/// stored into `s` if `STORE`) and consumed at once by the same block update as [`tick`].
///
/// # Safety
/// The CPU must support AVX2. Panics unless `b.len() % 4 == 0`,
/// `s.len() = a.len()·b.len()` and `w.len() = s.len()·M`.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn tick_grid<const M: usize, const NORM: bool, const STORE: bool>(
    w: &mut [f64],
    a: &[f64],
    b: &[f64],
    s: &mut [f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 (caller's contract).
    unsafe { tick_grid_body::<M, NORM, STORE, false>(w, a, b, s, e, c) }
}

/// [`tick_grid`] with FMA.
///
/// # Safety
/// As [`tick_grid`], and the CPU must support FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn tick_grid_fma<const M: usize, const NORM: bool, const STORE: bool>(
    w: &mut [f64],
    a: &[f64],
    b: &[f64],
    s: &mut [f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 and FMA (caller's contract).
    unsafe { tick_grid_body::<M, NORM, STORE, true>(w, a, b, s, e, c) }
}

/// The body of [`tick_grid`] and [`tick_grid_fma`].
///
/// # Safety
/// As [`tick_grid`] (and FMA if `FMA`).
#[inline(always)]
unsafe fn tick_grid_body<const M: usize, const NORM: bool, const STORE: bool, const FMA: bool>(
    w: &mut [f64],
    a: &[f64],
    b: &[f64],
    s: &mut [f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    let nb = b.len();
    assert!(nb.is_multiple_of(BLOCK) && s.len() == a.len() * nb && w.len() == s.len() * M);
    // SAFETY: AVX2 (caller's contract).
    unsafe {
        let mut r = regs(e, c);
        let rows = w.chunks_exact_mut(nb * M).zip(s.chunks_exact_mut(nb));
        for ((w_row, s_row), &ai) in rows.zip(a) {
            let av = _mm256_set1_pd(ai);
            let blocks = w_row
                .chunks_exact_mut(BLOCK * M)
                .zip(s_row.chunks_exact_mut(BLOCK));
            for ((wb, sb), bb) in blocks.zip(b.chunks_exact(BLOCK)) {
                // S = a_i · b_j, the product `eval_into` forms.
                let sv = _mm256_mul_pd(av, load(bb));
                if STORE {
                    store(sb, sv);
                }
                tick_block::<M, true, NORM, FMA>(wb, sv, &mut r);
            }
        }
        (sums(&r.acc), sums(&r.n2))
    }
}

/// One read-only block: `acc += w·S` (if `OUT`), `n2 += w·w` (if `NORM`).
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn read_block<const M: usize, const OUT: bool, const NORM: bool, const FMA: bool>(
    wb: &[f64],
    sv: __m256d,
    r: &mut Regs<M>,
) {
    for (q, wq) in wb.chunks_exact(BLOCK).take(M).enumerate() {
        // SAFETY: AVX2 (caller's contract).
        unsafe {
            let x = load(wq);
            if OUT {
                r.acc[q] = mul_add::<FMA>(x, spread(sv, r.idx[q]), r.acc[q]);
            }
            if NORM {
                r.n2[q] = mul_add::<FMA>(x, x, r.n2[q]);
            }
        }
    }
}

/// [`super::kernel_read`] on AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn read<const M: usize, const OUT: bool, const NORM: bool>(
    w: &[f64],
    s: &[f64],
    n_nodes: usize,
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 (caller's contract).
    unsafe { read_body::<M, OUT, NORM, false>(w, s, n_nodes) }
}

/// [`read`] with FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn read_fma<const M: usize, const OUT: bool, const NORM: bool>(
    w: &[f64],
    s: &[f64],
    n_nodes: usize,
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 and FMA (caller's contract).
    unsafe { read_body::<M, OUT, NORM, true>(w, s, n_nodes) }
}

/// The body of [`read`] and [`read_fma`].
///
/// # Safety
/// The CPU must support AVX2 (and FMA if `FMA`).
#[inline(always)]
unsafe fn read_body<const M: usize, const OUT: bool, const NORM: bool, const FMA: bool>(
    w: &[f64],
    s: &[f64],
    n_nodes: usize,
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX2 (caller's contract).
    unsafe {
        let mut r = regs(&[0.0; M], &[0.0; M]);
        let zero = _mm256_setzero_pd();
        let full = n_nodes / BLOCK;
        let (w_full, w_tail) = w.split_at(full * BLOCK * M);
        for (b, wb) in w_full.chunks_exact(BLOCK * M).enumerate() {
            let sv = if OUT {
                load(&s[b * BLOCK..(b + 1) * BLOCK])
            } else {
                zero
            };
            read_block::<M, OUT, NORM, FMA>(wb, sv, &mut r);
        }
        if !w_tail.is_empty() {
            let mut tmp = [0.0; MAX_LANES];
            tmp[..w_tail.len()].copy_from_slice(w_tail);
            let sv = if OUT { load(&s_tail(s)) } else { zero };
            read_block::<M, OUT, NORM, FMA>(&tmp, sv, &mut r);
        }
        (sums(&r.acc), sums(&r.n2))
    }
}
