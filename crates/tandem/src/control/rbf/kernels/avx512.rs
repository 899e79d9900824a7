//! AVX-512 builds of the kernels ([`Kernel::Avx512`], AVX-512F with its fused multiply-adds).
//! Blocks of [`BLOCK512`] = 8 nodes (`8M` weights, `M` registers); lane `i` of a block is node
//! `i / M`, output `i % M`, and the `S` value of each lane is put in place by one `vpermpd`.
//! Two sets of accumulators (even and odd blocks) halve the FMA latency chain; every sum is
//! reduced in the fixed order of [`reduce512`], so the kernel is deterministic, but its lane
//! order and its FMAs differ from [`Kernel::Portable`] (agreement within the tolerance of the
//! determinism policy, not bits).
//!
//! The AVX-512 intrinsics and the `avx512f` target feature are stable since Rust 1.89 (the
//! workspace MSRV).

use super::{MAX_OUTPUTS, reduce512};
use std::arch::x86_64::{
    __m512d, __m512i, _mm512_add_pd, _mm512_fmadd_pd, _mm512_fnmadd_pd, _mm512_loadu_epi64,
    _mm512_loadu_pd, _mm512_mul_pd, _mm512_permutexvar_pd, _mm512_set1_pd, _mm512_setzero_pd,
    _mm512_storeu_pd,
};

/// Nodes per block (one AVX-512 register of `S`).
const B: usize = super::BLOCK512;
/// Lanes of the largest block.
const LANES: usize = B * MAX_OUTPUTS;

/// Per-register constants and the two accumulator sets of one pass.
struct Regs<const M: usize> {
    e: [__m512d; M],
    c: [__m512d; M],
    /// Permutation that spreads the block's 8 `S` values over the lanes of register `q`.
    idx: [__m512i; M],
    acc: [[__m512d; M]; 2],
    n2: [[__m512d; M]; 2],
}

/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
unsafe fn regs<const M: usize>(e: &[f64; M], c: &[f64; M]) -> Regs<M> {
    const { assert!(M >= 1 && M <= MAX_OUTPUTS) };
    // SAFETY: every load reads a local array of 8 elements; AVX-512F (caller's contract).
    unsafe {
        let zero = _mm512_setzero_pd();
        let mut r = Regs {
            e: [zero; M],
            c: [zero; M],
            idx: [_mm512_loadu_epi64([0i64; B].as_ptr()); M],
            acc: [[zero; M]; 2],
            n2: [[zero; M]; 2],
        };
        for q in 0..M {
            let mut ev = [0.0; B];
            let mut cv = [0.0; B];
            let mut iv = [0i64; B];
            for t in 0..B {
                let i = B * q + t;
                ev[t] = e[i % M];
                cv[t] = c[i % M];
                iv[t] = (i / M) as i64;
            }
            r.e[q] = _mm512_loadu_pd(ev.as_ptr());
            r.c[q] = _mm512_loadu_pd(cv.as_ptr());
            r.idx[q] = _mm512_loadu_epi64(iv.as_ptr());
        }
        r
    }
}

/// The two accumulator sets added lane by lane, then the lanes in order, then
/// [`reduce512`].
///
/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
unsafe fn sums<const M: usize>(v: &[[__m512d; M]; 2]) -> [f64; M] {
    let mut l = [0.0; LANES];
    for (q, chunk) in l.chunks_exact_mut(B).take(M).enumerate() {
        // SAFETY: `chunk` holds exactly 8 f64; AVX-512F (caller's contract).
        unsafe { _mm512_storeu_pd(chunk.as_mut_ptr(), _mm512_add_pd(v[0][q], v[1][q])) };
    }
    reduce512(&l)
}

/// Load 8 lanes.
///
/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
pub(crate) unsafe fn load(x: &[f64]) -> __m512d {
    assert!(x.len() >= B);
    // SAFETY: bounds checked above (unaligned load); AVX-512F (caller's contract).
    unsafe { _mm512_loadu_pd(x.as_ptr()) }
}

/// Store 8 lanes.
///
/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
pub(crate) unsafe fn store(x: &mut [f64], v: __m512d) {
    assert!(x.len() >= B);
    // SAFETY: bounds checked above (unaligned store); AVX-512F (caller's contract).
    unsafe { _mm512_storeu_pd(x.as_mut_ptr(), v) }
}

/// One block of the fused pass (`wb.len() ≥ 8M`) into accumulator set `SET`: per lane
/// `acc += old·S`, `w = e·old − c·S` (one FMA), `n2 += w·w` (if `NORM`).
///
/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
unsafe fn tick_block<const M: usize, const OUT: bool, const NORM: bool, const SET: usize>(
    wb: &mut [f64],
    sv: __m512d,
    r: &mut Regs<M>,
) {
    for (q, wq) in wb.chunks_exact_mut(B).take(M).enumerate() {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            let sq = _mm512_permutexvar_pd(r.idx[q], sv);
            let old = load(wq);
            if OUT {
                r.acc[SET][q] = _mm512_fmadd_pd(old, sq, r.acc[SET][q]);
            }
            let new = _mm512_fnmadd_pd(r.c[q], sq, _mm512_mul_pd(r.e[q], old));
            store(wq, new);
            if NORM {
                r.n2[SET][q] = _mm512_fmadd_pd(new, new, r.n2[SET][q]);
            }
        }
    }
}

/// [`super::kernel_tick`] on AVX-512.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn tick<const M: usize, const OUT: bool>(
    w: &mut [f64],
    s: &[f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX-512F (caller's contract).
    unsafe {
        let mut r = regs(e, c);
        let pairs = s.len() / (2 * B);
        let (w_pairs, w_rest) = w.split_at_mut(pairs * 2 * B * M);
        let (s_pairs, s_rest) = s.split_at(pairs * 2 * B);
        for (wp, sp) in w_pairs
            .chunks_exact_mut(2 * B * M)
            .zip(s_pairs.chunks_exact(2 * B))
        {
            let (w0, w1) = wp.split_at_mut(B * M);
            tick_block::<M, OUT, true, 0>(w0, load(sp), &mut r);
            tick_block::<M, OUT, true, 1>(w1, load(&sp[B..]), &mut r);
        }
        if !s_rest.is_empty() {
            // At most one full block and a partial one, through zero-padded copies.
            let mut tmp = [0.0; 2 * LANES];
            tmp[..w_rest.len()].copy_from_slice(w_rest);
            let mut sb = [0.0; 2 * B];
            sb[..s_rest.len()].copy_from_slice(s_rest);
            let (t0, t1) = tmp.split_at_mut(B * M);
            tick_block::<M, OUT, true, 0>(t0, load(&sb), &mut r);
            if s_rest.len() > B {
                tick_block::<M, OUT, true, 1>(t1, load(&sb[B..]), &mut r);
            }
            w_rest.copy_from_slice(&tmp[..w_rest.len()]);
        }
        (sums(&r.acc), sums(&r.n2))
    }
}

/// Registers of spread `B` values a grid pass keeps (`6 KB` on the stack): the tail `B`
/// is taken in chunks of at most `SPREAD / M` blocks.
const SPREAD: usize = 96;

/// One block of the grid pass (`wb.len() ≥ 8M`) into row accumulator set `SET`: per lane
/// `racc += old·b` (the row's `a_i` is applied once per row), `w = e·old − (c·a_i)·b`,
/// `n2 += w·w` (if `NORM`). `bs` holds the block's `b` values spread over the lanes.
///
/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
unsafe fn grid_block<const M: usize, const NORM: bool, const SET: usize>(
    wb: &mut [f64],
    bs: &[__m512d],
    ca: &[__m512d; M],
    racc: &mut [[__m512d; M]; 2],
    r: &mut Regs<M>,
) {
    for (q, wq) in wb.chunks_exact_mut(B).take(M).enumerate() {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            let old = load(wq);
            racc[SET][q] = _mm512_fmadd_pd(old, bs[q], racc[SET][q]);
            let new = _mm512_fnmadd_pd(ca[q], bs[q], _mm512_mul_pd(r.e[q], old));
            store(wq, new);
            if NORM {
                r.n2[SET][q] = _mm512_fmadd_pd(new, new, r.n2[SET][q]);
            }
        }
    }
}

/// Fused tick on a grid basis, `S = A ⊗ B` never formed node by node: the tail values
/// `b` are spread over the lanes once per tick (one `vpermpd` per register, reused by every
/// row), each row `i` accumulates `Σ_k w_k b_k` and applies `a_i` once at its end, and the
/// update uses `(c_j a_i)·b_k = c_j S_k`: three arithmetic operations per register of
/// weights. `S` is stored into `s` only if `STORE`.
///
/// # Safety
/// The CPU must support AVX-512F. Panics unless `b.len() % 8 == 0`,
/// `s.len() = a.len()·b.len()` and `w.len() = s.len()·M`.
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn tick_grid<const M: usize, const NORM: bool, const STORE: bool>(
    w: &mut [f64],
    a: &[f64],
    b: &[f64],
    s: &mut [f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    let nb = b.len();
    assert!(nb.is_multiple_of(B) && s.len() == a.len() * nb && w.len() == s.len() * M);
    // SAFETY: AVX-512F (caller's contract); `spread` is written before it is read.
    unsafe {
        let mut r = regs(e, c);
        let zero = _mm512_setzero_pd();
        let mut spread = [zero; SPREAD];
        // Blocks of 8 tail values per chunk (at least one; an even count where possible).
        let chunk_blocks = (SPREAD / M).max(1);
        let blocks = nb / B;
        let mut k0 = 0;
        while k0 < blocks {
            let k1 = (k0 + chunk_blocks).min(blocks);
            for k in k0..k1 {
                let bv = load(&b[k * B..]);
                for q in 0..M {
                    spread[(k - k0) * M + q] = _mm512_permutexvar_pd(r.idx[q], bv);
                }
            }
            let n_blk = k1 - k0;
            for (i, &ai) in a.iter().enumerate() {
                let av = _mm512_set1_pd(ai);
                let mut ca = [zero; M];
                for (x, &cq) in ca.iter_mut().zip(&r.c) {
                    *x = _mm512_mul_pd(cq, av);
                }
                let mut racc = [[zero; M]; 2];
                let row = &mut w[(i * nb + k0 * B) * M..(i * nb + k1 * B) * M];
                let (pairs, rest) = row.split_at_mut(n_blk / 2 * 2 * B * M);
                for (p, wp) in pairs.chunks_exact_mut(2 * B * M).enumerate() {
                    let (w0, w1) = wp.split_at_mut(B * M);
                    let bs = &spread[2 * p * M..(2 * p + 2) * M];
                    grid_block::<M, NORM, 0>(w0, &bs[..M], &ca, &mut racc, &mut r);
                    grid_block::<M, NORM, 1>(w1, &bs[M..], &ca, &mut racc, &mut r);
                }
                if !rest.is_empty() {
                    let bs = &spread[(n_blk - 1) * M..n_blk * M];
                    grid_block::<M, NORM, 0>(rest, bs, &ca, &mut racc, &mut r);
                }
                for q in 0..M {
                    let row_sum = _mm512_add_pd(racc[0][q], racc[1][q]);
                    r.acc[0][q] = _mm512_fmadd_pd(av, row_sum, r.acc[0][q]);
                }
                if STORE {
                    // S = a_i · b_j, the product `eval_into` forms.
                    for k in k0..k1 {
                        let sv = _mm512_mul_pd(av, load(&b[k * B..]));
                        store(&mut s[i * nb + k * B..], sv);
                    }
                }
            }
            k0 = k1;
        }
        (sums(&r.acc), sums(&r.n2))
    }
}

/// One read-only block: `acc += w·S` (if `OUT`), `n2 += w·w` (if `NORM`).
///
/// # Safety
/// The CPU must support AVX-512F.
#[inline(always)]
unsafe fn read_block<const M: usize, const OUT: bool, const NORM: bool, const SET: usize>(
    wb: &[f64],
    sv: __m512d,
    r: &mut Regs<M>,
) {
    for (q, wq) in wb.chunks_exact(B).take(M).enumerate() {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            let x = load(wq);
            if OUT {
                let sq = _mm512_permutexvar_pd(r.idx[q], sv);
                r.acc[SET][q] = _mm512_fmadd_pd(x, sq, r.acc[SET][q]);
            }
            if NORM {
                r.n2[SET][q] = _mm512_fmadd_pd(x, x, r.n2[SET][q]);
            }
        }
    }
}

/// [`super::kernel_read`] on AVX-512.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn read<const M: usize, const OUT: bool, const NORM: bool>(
    w: &[f64],
    s: &[f64],
    n_nodes: usize,
) -> ([f64; M], [f64; M]) {
    // SAFETY: AVX-512F (caller's contract).
    unsafe {
        let mut r = regs(&[0.0; M], &[0.0; M]);
        let zero = _mm512_setzero_pd();
        let pairs = n_nodes / (2 * B);
        let (w_pairs, w_rest) = w.split_at(pairs * 2 * B * M);
        for (p, wp) in w_pairs.chunks_exact(2 * B * M).enumerate() {
            let (s0, s1) = if OUT {
                let sp = &s[p * 2 * B..(p + 1) * 2 * B];
                (load(sp), load(&sp[B..]))
            } else {
                (zero, zero)
            };
            read_block::<M, OUT, NORM, 0>(wp, s0, &mut r);
            read_block::<M, OUT, NORM, 1>(&wp[B * M..], s1, &mut r);
        }
        if !w_rest.is_empty() {
            let mut tmp = [0.0; 2 * LANES];
            tmp[..w_rest.len()].copy_from_slice(w_rest);
            let mut sb = [0.0; 2 * B];
            if OUT {
                let lo = pairs * 2 * B;
                sb[..n_nodes - lo].copy_from_slice(&s[lo..n_nodes]);
            }
            read_block::<M, OUT, NORM, 0>(&tmp, load(&sb), &mut r);
            if n_nodes - pairs * 2 * B > B {
                read_block::<M, OUT, NORM, 1>(&tmp[B * M..], load(&sb[B..]), &mut r);
            }
        }
        (sums(&r.acc), sums(&r.n2))
    }
}
