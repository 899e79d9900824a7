//! The batched weight update ([`super::Kernel::Batched`]): the exact update of (44) applied
//! [`DEPTH`] ticks at a time, so that most ticks only *read* the weights.
//!
//! # Why
//!
//! The fused pass reads and writes every weight each tick (96 KB each way for the paper
//! network); on the project's machine it is bound by the L2 read-modify-write rate
//! (`docs/performance.md`, "Roofline"). A read-only pass over the same bytes takes about half
//! as long. The update is linear in `Ŵ`, so it can be deferred exactly.
//!
//! # The algebra
//!
//! With the stored weights `V`, a per-output factor `D_j` and `p ≤ DEPTH` pending terms
//! `(g_m, A_m, B_m)`, the network's weights are
//!
//! $$ \hat W_j = D_j V_j - \sum_{m<p} g_{mj}\, A_m \otimes B_m . $$
//!
//! * **Output** (41), `S = A ⊗ B`: `f̂_j = D_j (V_jᵀS) − Σ_m g_mj (A_m·A)(B_m·B)`, since
//!   `(A_m ⊗ B_m)·(A ⊗ B) = (A_m·A)(B_m·B)`: one read-only pass over `V`, plus the held terms'
//!   products with `S`, which are products of per-input dot products (`Π_i f_{m,i}·f_i`, a few
//!   operations a factor for all terms at once).
//! * **Update** (44), exact for held inputs (module docs of [`super`]):
//!   `Ŵ_j ← e_j Ŵ_j − c_j S` becomes `D_j ← e_j D_j`, `g_mj ← e_j g_mj`, and a new term
//!   `(c_j, A, B)`: no pass over `V`.
//! * **Flush**, when `p = DEPTH` (at the start of the next tick, fused with its output pass) or
//!   on demand ([`super::RbfNetwork::flush`]): `V_j ← D_j V_j − Σ_m g_mj A_m ⊗ B_m`, `D = 1`,
//!   `p = 0`: one read-modify-write pass every `DEPTH` ticks.
//!
//! This is the same map as the fused tick in exact arithmetic; in floating point the rounding
//! differs (products regrouped, the decay applied as a product of factors), and the results
//! agree with the portable reference within the determinism policy's relative `1e-12` (test
//! `every_available_kernel_agrees_with_the_portable_reference`). The flush schedule depends on
//! the tick count only, so a run is bitwise reproducible.
//!
//! The passes are AVX-512F (the kernel is offered only where the CPU has it) and handle a grid
//! basis whose tail length `n_b` is a multiple of 8; other bases use the direct kernel.
//!
//! # Single precision
//!
//! [`super::Kernel::BatchedF32`] runs the same algebra on an `f32` copy of `V` that the kernel
//! owns while the controller ticks ([`Batch32`]): every pass moves half the bytes (48 KB for the
//! paper network, the size of an L1 data cache) and does its arithmetic on 16 lanes. `D`, the
//! `g_m`, the held terms' products with `S` and the final sums stay `f64`. The network's own `f64`
//! weights are brought up to date on [`super::RbfNetwork::flush`]; until then they are stale,
//! and the accessors that read them refuse ([`super::RbfNetwork::is_stale`]).

use super::{Aligned, MAX_OUTPUTS};

/// Ticks whose updates are held before they are applied to the stored weights. The flush's
/// arithmetic per tick does not depend on it (one multiply-add a weight a tick); its memory
/// traffic per tick falls as `1/DEPTH`, while the held `B_m`, scaled by the `g_m` at the flush
/// (`G_m`, `DEPTH · n_b · M` values: 24 KB at 16 for the paper, half that in `f32`), must stay
/// in L1 during the flush. Measured
/// (`docs/performance.md`): at 16 the `f64` flush took 6.8 µs on the Xeon VM (session 5,
/// before `G_m`), of which the read-modify-write of the weights alone would be 1.6 µs; the
/// flushing tick now takes 4.8 µs (`f64`) and 2.6 µs (`f32`) on the EPYC VM (session 7,
/// "Session 7: the flush"); at 32 the `f64` pass went from
/// 1.16 to 1.51 µs on the EPYC VM (48 KB of `B_m` no longer fit L1) and `f32` did not gain.
pub const DEPTH: usize = 16;
// The `f32` read alternates its direction with the pending count; an even depth keeps the
// alternation across flush cycles.
const _: () = assert!(DEPTH.is_multiple_of(2));

/// Lanes of one AVX-512 register of `f64`.
const LANE: usize = 8;

/// A tick's basis on a grid: `A`, `B`, the per-input factors `f` (all inputs, level after
/// level) and where each input's factors start (`offsets`, as in [`super::Rbf`]).
pub(super) type Basis<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [usize]);

/// The held update, whatever the store: the factor `D`, and the terms `(g_m, A_m)` with the
/// per-input factors of `A_m ⊗ B_m` (the stores keep `B_m` spread over the weight lanes).
#[derive(Debug, Clone, PartialEq)]
struct Terms<const M: usize> {
    n_a: usize,
    n_b: usize,
    n_f: usize,
    /// Pending terms `p`.
    p: usize,
    /// `D_j`.
    d: [f64; M],
    /// `g_mj`.
    g: [[f64; M]; DEPTH],
    /// `A_m`, `n_a` each, if the store keeps them in `f64` (`Batch`; `Batch32` keeps its own
    /// `f32` copy, which its flush uses, and this is empty).
    a: Vec<f64>,
    /// The factors of term `m`, level-major: `fs[l·DEPTH + m]` is factor `l` of term `m`
    /// (so that one register holds a factor of 8 terms).
    fs: Vec<f64>,
}

impl<const M: usize> Terms<M> {
    fn new(n_a: usize, n_b: usize, n_f: usize, keep_a: bool) -> Self {
        assert!((1..=MAX_OUTPUTS).contains(&M));
        Self {
            n_a,
            n_b,
            n_f,
            p: 0,
            d: [1.0; M],
            g: [[0.0; M]; DEPTH],
            a: vec![0.0; if keep_a { DEPTH * n_a } else { 0 }],
            fs: vec![0.0; DEPTH * n_f],
        }
    }

    fn clear(&mut self) {
        self.p = 0;
        self.d = [1.0; M];
    }

    /// `Ŵ[n] = D_j v(n) − Σ_m g_mj A_m[i] B_m[k]` (node `n / M = i·n_b + k`, output
    /// `j = n % M`; `a(m, i)` is `A_m[i]`, `b(m, k)` is `B_m[k]`) into `out`, in plain scalar
    /// code (for inspection).
    fn materialize(
        &self,
        v: impl Fn(usize) -> f64,
        a: impl Fn(usize, usize) -> f64,
        b: impl Fn(usize, usize) -> f64,
        out: &mut [f64],
    ) {
        let (na, nb) = (self.n_a, self.n_b);
        assert_eq!(out.len(), na * nb * M);
        for (n, o) in out.iter_mut().enumerate() {
            let (node, j) = (n / M, n % M);
            let (i, k) = (node / nb, node % nb);
            let mut x = self.d[j] * v(n);
            for m in 0..self.p {
                x -= self.g[m][j] * a(m, i) * b(m, k);
            }
            *o = x;
        }
    }

    /// The output (41) from the stored weights' part `v_j = V_jᵀS`:
    /// `f̂_j = D_j v_j − Σ_m g_mj (A_m ⊗ B_m)·S`, where the held terms' products with
    /// `S = f_0 ⊗ … ⊗ f_{N−1}` are products of the per-input dot products,
    /// `(A_m ⊗ B_m)·S = Π_i f_{m,i}·f_i`: a few operations a factor, for all terms at once.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn outputs(&self, v: [f64; M], f: &[f64], offsets: &[usize]) -> [f64; M] {
        // SAFETY: AVX-512F (caller's contract).
        let s = unsafe { avx512::held_products(&self.fs, f, offsets) };
        let mut out = [0.0; M];
        for (j, o) in out.iter_mut().enumerate() {
            let mut x = self.d[j] * v[j];
            for (gm, sm) in self.g[..self.p].iter().zip(&s) {
                x -= gm[j] * sm;
            }
            *o = x;
        }
        out
    }

    /// The update (44), deferred: `D ← e D`, `g_m ← e g_m`, and the new term `(c, A, B)`.
    /// Returns the new term's index. Panics if `DEPTH` terms are already held.
    fn push(&mut self, (a, _, f, _): Basis<'_>, e: &[f64; M], c: &[f64; M]) -> usize {
        let (na, p) = (self.n_a, self.p);
        assert!(p < DEPTH && f.len() == self.n_f);
        for (fs_l, &fl) in self.fs.chunks_exact_mut(DEPTH).zip(f) {
            fs_l[p] = fl;
        }
        for j in 0..M {
            self.d[j] *= e[j];
        }
        for gm in &mut self.g[..p] {
            for j in 0..M {
                gm[j] *= e[j];
            }
        }
        self.g[p] = *c;
        if !self.a.is_empty() {
            self.a[p * na..(p + 1) * na].copy_from_slice(a);
        }
        self.p += 1;
        p
    }
}

/// The held update of [`super::Kernel::Batched`] (stored weights `f64`, in the network) or of
/// [`super::Kernel::BatchedF32`] (stored weights `f32`, in the kernel), with buffers sized once,
/// at set-up.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Held<const M: usize> {
    F64(Batch<M>),
    F32(Batch32<M>),
}

impl<const M: usize> Held<M> {
    /// Buffers for a grid basis with head length `n_a` and tail length `n_b`, or `None` if the
    /// passes do not handle it (`f64`: `n_b % 8 ≠ 0`; `f32`: `n_b % 16 ≠ 0`).
    pub(super) fn new(single: bool, n_a: usize, n_b: usize, n_f: usize) -> Option<Self> {
        if single {
            n_b.is_multiple_of(LANE32)
                .then(|| Held::F32(Batch32::new(n_a, n_b, n_f)))
        } else {
            n_b.is_multiple_of(LANE)
                .then(|| Held::F64(Batch::new(n_a, n_b, n_f)))
        }
    }

    fn terms(&self) -> &Terms<M> {
        match self {
            Held::F64(b) => &b.t,
            Held::F32(b) => &b.t,
        }
    }

    /// Whether the buffers fit a basis with these head and tail lengths and factors.
    pub(super) fn fits(&self, n_a: usize, n_b: usize, n_f: usize) -> bool {
        let t = self.terms();
        t.n_a == n_a && t.n_b == n_b && t.n_f == n_f
    }

    /// Pending terms.
    pub(super) fn pending(&self) -> usize {
        self.terms().p
    }

    /// Whether the network's `f64` weights are not `Ŵ`: terms are pending, or (single
    /// precision) the weights live in the kernel's `f32` store.
    pub(super) fn stale(&self) -> bool {
        match self {
            Held::F64(b) => b.t.p > 0,
            Held::F32(b) => b.live,
        }
    }

    /// Forget the pending terms and the `f32` store (the network's weights were overwritten).
    pub(super) fn clear(&mut self) {
        match self {
            Held::F64(b) => b.t.clear(),
            Held::F32(b) => {
                b.t.clear();
                b.live = false;
            }
        }
    }

    /// `Ŵ` from the network's stored `w` (or the kernel's `f32` store), into `out`; nothing
    /// is changed.
    pub(super) fn materialize(&self, w: &[f64], out: &mut [f64]) {
        assert_eq!(w.len(), out.len());
        // `B_m[k]` is entry `k·M` of the spread `B_m`.
        match self {
            Held::F64(h) => {
                let row = h.t.n_b * M;
                let bs = h.bs.as_ref();
                let na = h.t.n_a;
                let a = |m: usize, i: usize| h.t.a[m * na + i];
                h.t.materialize(|n| w[n], a, |m, k| bs[m * row + k * M], out);
            }
            Held::F32(h) => {
                let row = h.t.n_b * M;
                let bs = h.bs.as_ref();
                let b = |m: usize, k: usize| f64::from(bs[m * row + k * M]);
                // `A_m` as the flush will apply it: the `f32` copy.
                let na = h.t.n_a;
                let a = |m: usize, i: usize| f64::from(h.a32[m * na + i]);
                if h.live {
                    h.t.materialize(|n| f64::from(h.v.as_ref()[n]), a, b, out);
                } else {
                    h.t.materialize(|n| w[n], a, b, out);
                }
            }
        }
    }

    /// Make the network's `w` hold `Ŵ` (no-op if it does).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    pub(super) unsafe fn flush(&mut self, w: &mut [f64]) {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            match self {
                Held::F64(b) => b.flush(w),
                Held::F32(b) => b.flush(w),
            }
        }
    }

    /// One tick: `f̂` with the weights before the update, then the update deferred. `basis`
    /// is this tick's `S` on the grid; `e`, `c` the decay and the coefficient of `S` in (44).
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics if the lengths do not match the buffers.
    #[cfg(target_arch = "x86_64")]
    pub(super) unsafe fn tick(
        &mut self,
        w: &mut [f64],
        basis: Basis<'_>,
        e: &[f64; M],
        c: &[f64; M],
    ) -> [f64; M] {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            match self {
                Held::F64(h) => h.tick(w, basis, e, c),
                Held::F32(h) => h.tick(w, basis, e, c),
            }
        }
    }
}

/// The `f64` store: the network's own weights, and the held `B_m` spread over the weight
/// lanes.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Batch<const M: usize> {
    t: Terms<M>,
    /// `B_m` spread over the weight lanes: `n_b·M` each, entry `k·M + j` is `B_m[k]`.
    bs: Aligned,
    /// This tick's `B`, spread the same way.
    cur: Aligned,
    /// The flush's scaled terms `G_m = g_m ⊙ B_m`, spread as `bs` (formed at each flush).
    gb: Aligned,
    /// The spread as permutes: register `r` of `cur` is lanes `spread[r]` of `B[first[r]..]`
    /// (`B` copied into `b8`, padded by a register).
    spread: Vec<[u64; LANE]>,
    first: Vec<usize>,
    b8: Vec<f64>,
}

impl<const M: usize> Batch<M> {
    /// Buffers for a grid basis with head length `n_a` and tail length `n_b` (`n_b % 8 == 0`).
    fn new(n_a: usize, n_b: usize, n_f: usize) -> Self {
        assert!(n_b.is_multiple_of(LANE));
        Self {
            t: Terms::new(n_a, n_b, n_f, true),
            bs: Aligned::zeros(DEPTH * n_b * M),
            cur: Aligned::zeros(n_b * M),
            gb: Aligned::zeros(DEPTH * n_b * M),
            spread: (0..n_b * M / LANE)
                .map(|r| std::array::from_fn(|t| ((LANE * r + t) / M - LANE * r / M) as u64))
                .collect(),
            first: (0..n_b * M / LANE).map(|r| LANE * r / M).collect(),
            b8: vec![0.0; n_b + LANE],
        }
    }

    /// Apply the pending terms to `w` (no-op if none).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn flush(&mut self, w: &mut [f64]) {
        if self.t.p > 0 {
            // SAFETY: AVX-512F (caller's contract).
            unsafe { avx512::apply::<M, false>(w, self, &[], self.t.p) };
            self.t.clear();
        }
    }

    /// [`Held::tick`] on the `f64` store.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn tick(
        &mut self,
        w: &mut [f64],
        basis: Basis<'_>,
        e: &[f64; M],
        c: &[f64; M],
    ) -> [f64; M] {
        let (na, nb) = (self.t.n_a, self.t.n_b);
        let (a, b, f, offsets) = basis;
        assert!(a.len() == na && b.len() == nb && w.len() == na * nb * M);
        self.b8[..nb].copy_from_slice(b);
        // SAFETY: AVX-512F (caller's contract).
        unsafe { avx512::spread_rows(&self.b8, &self.spread, &self.first, self.cur.as_mut()) };
        // SAFETY: AVX-512F (caller's contract).
        let out = unsafe {
            if self.t.p == DEPTH {
                // Flush fused with this tick's output pass: f̂ = V'ᵀ S.
                let out = avx512::apply::<M, true>(w, self, a, DEPTH);
                self.t.clear();
                out
            } else {
                let v = avx512::read::<M>(w, a, self.cur.as_ref(), nb);
                self.t.outputs(v, f, offsets)
            }
        };
        let p = self.t.push(basis, e, c);
        let row_len = nb * M;
        self.bs.as_mut()[p * row_len..(p + 1) * row_len].copy_from_slice(self.cur.as_ref());
        out
    }
}

/// Lanes of one AVX-512 register of `f32`.
const LANE32: usize = 16;

/// The `f32` store of [`super::Kernel::BatchedF32`]: the weights `V` in single precision
/// (authoritative while `live`; the network's `f64` weights are then stale), and the held
/// `A_m`, `B_m` in single precision for the flush.
///
/// The passes compute in `f32` (the column sums, the flush's term sums) and reduce the outputs
/// in `f64`; `D` and the `g_m` stay `f64` and are rounded once a pass. The flush applies the
/// decay as `v − ((1 − D) v + t)`, with `1 − D` and the terms' sum `t` each formed before they
/// meet `v`, so that a decay or an increment small against `v` is not lost to the rounding of
/// `D·v` (`1 − D` is about `2.4e-5` for the paper's tuned gains, 400 `f32` ulps of 1).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Batch32<const M: usize> {
    t: Terms<M>,
    /// `V`, `n_a·n_b·M` values, the layout of the network's weights.
    v: Aligned<f32>,
    /// Whether `v` holds the weights (else the network's `f64` weights do).
    live: bool,
    /// `A_m` in `f32`, `n_a` each.
    a32: Vec<f32>,
    /// This tick's `A` in `f32`, on a flushing tick (else it is in `a32`'s next slot).
    cur_a: Vec<f32>,
    /// `B_m` spread over the weight lanes, in `f32`: `n_b·M` each, entry `k·M + j` is `B_m[k]`.
    bs: Aligned<f32>,
    /// This tick's `B`, spread the same way, on a flushing tick (else it is in `bs`' next
    /// slot).
    cur: Aligned<f32>,
    /// The flush's scaled terms `G_m = g_m ⊙ B_m`, spread as `bs` (formed at each flush).
    gb: Aligned<f32>,
    /// This tick's `B` in `f32`, padded by a register.
    b32: Vec<f32>,
    /// The spread as permutes: register `r` of `cur` is lanes `spread[r]` of `b32[first[r]..]`.
    spread: Vec<[u32; LANE32]>,
    first: Vec<usize>,
}

impl<const M: usize> Batch32<M> {
    /// Buffers for a grid basis with head length `n_a` and tail length `n_b` (`n_b % 16 == 0`).
    fn new(n_a: usize, n_b: usize, n_f: usize) -> Self {
        assert!(n_b.is_multiple_of(LANE32));
        Self {
            t: Terms::new(n_a, n_b, n_f, false),
            v: Aligned::zeros(n_a * n_b * M),
            live: false,
            a32: vec![0.0; DEPTH * n_a],
            cur_a: vec![0.0; n_a],
            bs: Aligned::zeros(DEPTH * n_b * M),
            cur: Aligned::zeros(n_b * M),
            gb: Aligned::zeros(DEPTH * n_b * M),
            b32: vec![0.0; n_b + LANE32],
            // Entry `e = 16r + t` of a spread row is `B[e / M]`. A register's entries start at
            // `k = 16r / M` and span fewer than 16 / M + 1 consecutive `k`; from the 8-block
            // holding the first, `first[r] = 8⌊16r / 8M⌋`, they lie in that block and the next
            // (offset < 8 + 16/M + 1 ≤ 16 for M ≥ 3; M = 1, 2 start on a block). Lane `t` takes
            // offset `o` from the first block (`o < 8`) or `o − 8` from the second (`16 + o − 8`
            // in the two-source permute).
            spread: (0..n_b * M / LANE32)
                .map(|r| {
                    let f0 = LANE32 * r / M / 8 * 8;
                    std::array::from_fn(|t| {
                        let o = (LANE32 * r + t) / M - f0;
                        assert!(o < 16, "spread offset");
                        (if o < 8 { o } else { o + 8 }) as u32
                    })
                })
                .collect(),
            first: (0..n_b * M / LANE32)
                .map(|r| LANE32 * r / M / 8 * 8)
                .collect(),
        }
    }

    /// Make `v` hold the weights, from the network's `w` (rounded to `f32`) if it does not.
    fn load(&mut self, w: &[f64]) {
        if !self.live {
            for (v, &x) in self.v.as_mut().iter_mut().zip(w) {
                *v = x as f32;
            }
            self.live = true;
        }
    }

    /// Apply the pending terms to `v` and widen it into `w`, which holds the weights again.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn flush(&mut self, w: &mut [f64]) {
        if self.live {
            if self.t.p > 0 {
                // SAFETY: AVX-512F (caller's contract).
                unsafe { avx512f32::apply::<M, false>(self, self.t.p) };
                self.t.clear();
            }
            for (x, &v) in w.iter_mut().zip(self.v.as_ref()) {
                *x = f64::from(v);
            }
            self.live = false;
        }
    }

    /// [`Held::tick`] on the `f32` store.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn tick(
        &mut self,
        w: &mut [f64],
        basis: Basis<'_>,
        e: &[f64; M],
        c: &[f64; M],
    ) -> [f64; M] {
        let (na, nb) = (self.t.n_a, self.t.n_b);
        let (a, b, f, offsets) = basis;
        assert!(a.len() == na && b.len() == nb && w.len() == na * nb * M);
        self.load(w);
        let (p, row_len) = (self.t.p, nb * M);
        // This tick's `A` and spread `B` are written straight into the term slot `p` they
        // will fill, except on a flushing tick (the flush reads every slot): there into
        // `cur_a` and `cur`, copied into slot 0 after it.
        let (a_dst, b_dst) = if p < DEPTH {
            (
                &mut self.a32[p * na..(p + 1) * na],
                &mut self.bs.as_mut()[p * row_len..(p + 1) * row_len],
            )
        } else {
            (&mut self.cur_a[..], self.cur.as_mut())
        };
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            avx512f32::narrow(b, &mut self.b32[..nb]);
            avx512f32::narrow(a, a_dst);
            avx512f32::spread_rows(&self.b32, &self.spread, &self.first, b_dst);
        }
        // SAFETY: AVX-512F (caller's contract).
        let out = unsafe {
            if p == DEPTH {
                let out = avx512f32::apply::<M, true>(self, DEPTH);
                self.t.clear();
                out
            } else {
                // Odd ticks of a flush cycle read the rows backwards: the flush and the even
                // ticks read them forwards, so that a pass starts where the last one ended.
                let v = self.v.as_ref();
                let a32 = &self.a32[p * na..(p + 1) * na];
                let cur = &self.bs.as_ref()[p * row_len..(p + 1) * row_len];
                let v = if p % 2 == 1 {
                    avx512f32::read::<M, true>(v, a32, cur, nb)
                } else {
                    avx512f32::read::<M, false>(v, a32, cur, nb)
                };
                self.t.outputs(v, f, offsets)
            }
        };
        let q = self.t.push(basis, e, c);
        if p == DEPTH {
            self.bs.as_mut()[q * row_len..(q + 1) * row_len].copy_from_slice(self.cur.as_ref());
            self.a32[q * na..(q + 1) * na].copy_from_slice(&self.cur_a);
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::super::kernels::avx512::store;
    use super::super::kernels::reduce512;
    use super::{Batch, DEPTH, LANE, MAX_OUTPUTS};
    use std::arch::x86_64::{
        __m512d, _mm512_fmadd_pd, _mm512_fnmadd_pd, _mm512_loadu_pd, _mm512_loadu_si512,
        _mm512_maskz_loadu_pd, _mm512_mul_pd, _mm512_permutexvar_pd, _mm512_set1_pd,
        _mm512_setzero_pd, _mm512_storeu_pd,
    };

    /// The lane patterns of a spread row: lane `t` of register `q` is output `(8q + t) % m`
    /// (for `q < m`; register `q + m` repeats register `q`).
    const fn lane_outputs(m: usize) -> [[u64; LANE]; MAX_OUTPUTS] {
        let mut pat = [[0; LANE]; MAX_OUTPUTS];
        let mut e = 0;
        while e < LANE * MAX_OUTPUTS {
            pat[e / LANE][e % LANE] = (e % m) as u64;
            e += 1;
        }
        pat
    }

    /// `v_j` spread over register `q`'s lanes: lane `t` holds `v[(8q + t) % M]` (a masked
    /// load and a permute; no scalar stores read back as a register).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn spread<const M: usize>(v: &[f64; M], q: usize) -> __m512d {
        const { assert!(M >= 1 && M <= MAX_OUTPUTS) };
        let idx = &const { lane_outputs(M) }[q % M];
        // SAFETY: `M ≤ 8` values at `v` (the mask); 8 indices; AVX-512F (caller's contract).
        unsafe {
            let x = _mm512_maskz_loadu_pd(((1u32 << M) - 1) as u8, v.as_ptr());
            _mm512_permutexvar_pd(_mm512_loadu_si512(idx.as_ptr().cast()), x)
        }
    }

    /// The `M` lane patterns of `v` ([`spread`] for `q < M`).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn spreads<const M: usize>(v: &[f64; M]) -> [__m512d; M] {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            let mut x = [_mm512_setzero_pd(); M];
            for (q, xq) in x.iter_mut().enumerate() {
                *xq = spread(v, q);
            }
            x
        }
    }

    /// Per-output sums of `M` registers (lane `8q + t` is output `(8q + t) % M`), in the fixed
    /// order of [`reduce512`].
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn sums<const M: usize>(v: &[__m512d; M]) -> [f64; M] {
        let mut l = [0.0; LANE * MAX_OUTPUTS];
        for (chunk, &x) in l.chunks_exact_mut(LANE).zip(v) {
            // SAFETY: `chunk` holds 8 f64; AVX-512F (caller's contract).
            unsafe { store(chunk, x) };
        }
        reduce512(&l)
    }

    /// `cur` = `B` spread over the weight lanes, a register at a time: register `r` is lanes
    /// `idx[r]` of the 8 values of `b8` from `first[r]` (one load and one permute).
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `cur.len() = 8·idx.len()`, `first` is as
    /// long as `idx` and `b8` holds 8 values from every `first[r]`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn spread_rows(
        b8: &[f64],
        idx: &[[u64; LANE]],
        first: &[usize],
        cur: &mut [f64],
    ) {
        assert!(cur.len() == LANE * idx.len() && first.len() == idx.len());
        for ((c, ix), &f0) in cur.chunks_exact_mut(LANE).zip(idx).zip(first) {
            let src = &b8[f0..f0 + LANE];
            // SAFETY: 8 lanes each, in bounds by the slicing; AVX-512F (caller's contract).
            unsafe {
                let i = _mm512_loadu_si512(ix.as_ptr().cast());
                let x = _mm512_permutexvar_pd(i, _mm512_loadu_pd(src.as_ptr()));
                _mm512_storeu_pd(c.as_mut_ptr(), x);
            }
        }
    }

    /// `s_m = Π_i Σ_{l ∈ input i} fs[l·DEPTH + m]·f[l]` for all `DEPTH` terms at once (the
    /// lanes are terms; lanes of terms not held are computed and ignored).
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `fs.len() = DEPTH·f.len()` and `offsets`
    /// ends at `f.len()`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn held_products(fs: &[f64], f: &[f64], offsets: &[usize]) -> [f64; DEPTH] {
        const { assert!(DEPTH == 2 * LANE) };
        let nf = f.len();
        assert!(
            fs.len() == DEPTH * nf && offsets.first() == Some(&0) && offsets.last() == Some(&nf)
        );
        // Two registers of 8 terms; per input `d = Σ_l fs_l·f_l` in level order from zero
        // (fused multiply-adds, as `f64::mul_add`), then `s *= d`: the operations of the plain
        // loop, without its bounds checks and loop bookkeeping.
        // SAFETY: AVX-512F (caller's contract); `l < hi ≤ nf`, so `fs[l·DEPTH .. l·DEPTH + 16]`
        // and `f[l]` are in bounds.
        unsafe {
            let (mut s0, mut s1) = (_mm512_set1_pd(1.0), _mm512_set1_pd(1.0));
            let (fp, fsp) = (f.as_ptr(), fs.as_ptr());
            let mut l = 0;
            for &end in &offsets[1..] {
                let hi = end.min(nf);
                let (mut d0, mut d1) = (_mm512_setzero_pd(), _mm512_setzero_pd());
                while l < hi {
                    let fl = _mm512_set1_pd(*fp.add(l));
                    d0 = _mm512_fmadd_pd(ld(fsp, l * DEPTH), fl, d0);
                    d1 = _mm512_fmadd_pd(ld(fsp, l * DEPTH + LANE), fl, d1);
                    l += 1;
                }
                s0 = _mm512_mul_pd(s0, d0);
                s1 = _mm512_mul_pd(s1, d1);
            }
            let mut s = [0.0; DEPTH];
            store(&mut s[..LANE], s0);
            store(&mut s[LANE..], s1);
            s
        }
    }

    /// Load 8 lanes at `p + o` (no bounds check).
    ///
    /// # Safety
    /// `p + o .. p + o + 8` in bounds; the CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn ld(p: *const f64, o: usize) -> __m512d {
        // SAFETY: the caller's contract.
        unsafe { _mm512_loadu_pd(p.add(o)) }
    }

    /// Registers of column sums the output pass keeps (a row of the paper network: 64 nodes
    /// × 3 outputs = 24 registers).
    const COLS: usize = 24;

    /// Columns `r0·8 .. (r0 + N)·8` of the output pass: per register `t`, the column sums
    /// `c_t = Σ_i a_i V[i, ·]` (one broadcast a row, one fused multiply-add and one load a
    /// register; the `N` sums are independent chains), then `out[q] += c_t·B` for the lane
    /// pattern `q = (r0 + t) % M` of register `r0 + t`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; `(r0 + N)·8 ≤ row_len`, `w` holds `a.len()` rows.
    #[inline(always)]
    unsafe fn read_cols<const M: usize, const N: usize>(
        w: *const f64,
        a: &[f64],
        cur: *const f64,
        row_len: usize,
        r0: usize,
        out: &mut [__m512d; M],
    ) {
        // SAFETY: AVX-512F and bounds (the caller's contract).
        unsafe {
            let mut c = [_mm512_setzero_pd(); N];
            for (i, &ai) in a.iter().enumerate() {
                let av = _mm512_set1_pd(ai);
                let row = w.add(i * row_len + r0 * LANE);
                for (t, ct) in c.iter_mut().enumerate() {
                    *ct = _mm512_fmadd_pd(av, ld(row, t * LANE), *ct);
                }
            }
            for (t, ct) in c.iter().enumerate() {
                let q = (r0 + t) % M;
                out[q] = _mm512_fmadd_pd(*ct, ld(cur, (r0 + t) * LANE), out[q]);
            }
        }
    }

    /// The output pass: `f̂_j = Σ_k B[k] Σ_i a_i V[i, k, j]`, read only. `cur` is `B` spread
    /// over the weight lanes (entry `k·M + j` is `B[k]`). The row sums are taken first, in
    /// [`COLS`] registers, so each weight costs one load and one fused multiply-add and `B`
    /// is used once a column, not once a weight.
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `cur.len() = nb·M`, `nb % 8 = 0` and
    /// `w.len() = a.len()·nb·M`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn read<const M: usize>(
        w: &[f64],
        a: &[f64],
        cur: &[f64],
        nb: usize,
    ) -> [f64; M] {
        let row_len = nb * M;
        assert!(nb.is_multiple_of(LANE) && cur.len() == row_len && w.len() == a.len() * row_len);
        let regs = row_len / LANE;
        // SAFETY: AVX-512F (caller's contract); `read_cols` stays inside rows of `row_len`
        // values (`r0 + N ≤ regs`) and `cur`, by the assert.
        unsafe {
            let mut out = [_mm512_setzero_pd(); M];
            let mut r0 = 0;
            while r0 + COLS <= regs {
                read_cols::<M, COLS>(w.as_ptr(), a, cur.as_ptr(), row_len, r0, &mut out);
                r0 += COLS;
            }
            while r0 + LANE <= regs {
                read_cols::<M, LANE>(w.as_ptr(), a, cur.as_ptr(), row_len, r0, &mut out);
                r0 += LANE;
            }
            while r0 < regs {
                read_cols::<M, 1>(w.as_ptr(), a, cur.as_ptr(), row_len, r0, &mut out);
                r0 += 1;
            }
            sums(&out)
        }
    }

    /// Registers of a row the flush takes at once.
    const FLUSH_COLS: usize = 6;

    /// Rows the flush takes at once: each load of a scaled term row `G_m` feeds `FLUSH_ROWS`
    /// fused multiply-adds (with `FLUSH_COLS = 6`: 12 weights' registers, the `M` factors of
    /// `D`, 2 coefficients, the loaded operand and the rows' output sums fit the 32 AVX-512
    /// registers; 2 × 12 and 1 × 12 measured slower, `docs/performance.md`, session 7).
    const FLUSH_ROWS: usize = 2;

    /// `G_m = g_m ⊙ B_m` for the `p` held terms, spread over the weight lanes as `B_m` is
    /// (the `f64` twin of `avx512f32::scale_terms`).
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `p ≤ DEPTH`, `row_len % 8 = 0` and `bs`
    /// and `gb` hold `DEPTH` rows of `row_len`.
    #[target_feature(enable = "avx512f")]
    unsafe fn scale_terms<const M: usize>(
        bs: &[f64],
        g: &[[f64; M]; DEPTH],
        p: usize,
        row_len: usize,
        gb: &mut [f64],
    ) {
        assert!(
            p <= DEPTH
                && row_len.is_multiple_of(LANE)
                && bs.len() == DEPTH * row_len
                && gb.len() == DEPTH * row_len
        );
        for ((bm, gm), gbm) in bs
            .chunks_exact(row_len)
            .zip(g)
            .zip(gb.chunks_exact_mut(row_len))
            .take(p)
        {
            // SAFETY: AVX-512F (caller's contract); 8 lanes a register, inside the rows of
            // `row_len` values by the `chunks_exact`.
            unsafe {
                let gv = spreads(gm);
                for (r, (b, o)) in bm
                    .chunks_exact(LANE)
                    .zip(gbm.chunks_exact_mut(LANE))
                    .enumerate()
                {
                    let x = _mm512_mul_pd(gv[r % M], ld(b.as_ptr(), 0));
                    _mm512_storeu_pd(o.as_mut_ptr(), x);
                }
            }
        }
    }

    /// The flush of registers `r0 .. r0 + N` of rows `i .. i + R` (`r0 % M = 0`, so register
    /// `r0 + t` has the lane pattern `t % M`): `v = D·w`; for each term `v −= a_{m,i}·G_m`
    /// (the `R·N` registers as independent chains; a load of `G_m` feeds the `R` rows);
    /// stored; if `OUT`, `racc[r][t % M] += v·B` for row `i + r`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; every offset in bounds (the caller's checks).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    unsafe fn flush_cols<const M: usize, const OUT: bool, const R: usize, const N: usize>(
        wp: *mut f64,
        batch: &Batch<M>,
        i: usize,
        r0: usize,
        p: usize,
        d: &[__m512d; M],
        racc: &mut [[__m512d; M]; R],
    ) {
        let (na, row_len) = (batch.t.n_a, batch.t.n_b * M);
        let off = |t: usize| (r0 + t) * LANE;
        // SAFETY: AVX-512F and bounds (the caller's contract).
        unsafe {
            let mut v = [[_mm512_setzero_pd(); N]; R];
            for (r, v_r) in v.iter_mut().enumerate() {
                let row = wp.add((i + r) * row_len);
                for (t, vt) in v_r.iter_mut().enumerate() {
                    *vt = _mm512_mul_pd(d[t % M], ld(row, off(t)));
                }
            }
            let (gb, am) = (batch.gb.as_ref().as_ptr(), batch.t.a.as_ptr());
            for m in 0..p {
                let mut am_i = [_mm512_setzero_pd(); R];
                for (r, x) in am_i.iter_mut().enumerate() {
                    *x = _mm512_set1_pd(*am.add(m * na + i + r));
                }
                let gm = gb.add(m * row_len);
                for t in 0..N {
                    let x = ld(gm, off(t));
                    for (ar, v_r) in am_i.iter().zip(v.iter_mut()) {
                        v_r[t] = _mm512_fnmadd_pd(*ar, x, v_r[t]);
                    }
                }
            }
            let cp = batch.cur.as_ref().as_ptr();
            for (r, (v_r, racc_r)) in v.iter().zip(racc.iter_mut()).enumerate() {
                let row = wp.add((i + r) * row_len);
                for (t, vt) in v_r.iter().enumerate() {
                    _mm512_storeu_pd(row.add(off(t)), *vt);
                    if OUT {
                        racc_r[t % M] = _mm512_fmadd_pd(*vt, ld(cp, off(t)), racc_r[t % M]);
                    }
                }
            }
        }
    }

    /// Rows `i .. i + R` of the flush, a row's registers [`FLUSH_COLS`] at a time (or `M`,
    /// if `M` does not divide it); if `OUT`, `out += a_i·(V'[i]·B)` for each row.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; every offset in bounds (the caller's checks).
    #[inline(always)]
    unsafe fn flush_rows<const M: usize, const OUT: bool, const R: usize>(
        wp: *mut f64,
        batch: &Batch<M>,
        a: &[f64],
        i: usize,
        p: usize,
        d: &[__m512d; M],
        out: &mut [__m512d; M],
    ) {
        let regs = batch.t.n_b * M / LANE;
        // SAFETY: AVX-512F and bounds (the caller's contract); `r0 + N ≤ regs`.
        unsafe {
            let mut racc = [[_mm512_setzero_pd(); M]; R];
            let mut r0 = 0;
            if FLUSH_COLS.is_multiple_of(M) {
                while r0 + FLUSH_COLS <= regs {
                    flush_cols::<M, OUT, R, FLUSH_COLS>(wp, batch, i, r0, p, d, &mut racc);
                    r0 += FLUSH_COLS;
                }
            }
            while r0 < regs {
                flush_cols::<M, OUT, R, M>(wp, batch, i, r0, p, d, &mut racc);
                r0 += M;
            }
            if OUT {
                for (r, racc_r) in racc.iter().enumerate() {
                    let av = _mm512_set1_pd(*a.as_ptr().add(i + r));
                    for q in 0..M {
                        out[q] = _mm512_fmadd_pd(av, racc_r[q], out[q]);
                    }
                }
            }
        }
    }

    /// The flush pass: `V ← D V − Σ_{m<p} g_m A_m ⊗ B_m`, and, if `OUT`, `f̂ = V'ᵀ(A ⊗ B)`
    /// with the new weights (`a` is this tick's `A`, `batch.cur` its spread `B`).
    ///
    /// The scaled rows `G_m = g_m ⊙ B_m` are formed first ([`scale_terms`], 24 KB for the
    /// paper, in L1 with the `A_m`); then rows stream in order, [`FLUSH_ROWS`] at a time, a
    /// row [`FLUSH_COLS`] registers at a time (or `M`, if `M` does not divide it).
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `p ≤ DEPTH`, `w.len() = n_a·n_b·M` and,
    /// if `OUT`, `a.len() = n_a`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn apply<const M: usize, const OUT: bool>(
        w: &mut [f64],
        batch: &mut Batch<M>,
        a: &[f64],
        p: usize,
    ) -> [f64; M] {
        let (na, nb) = (batch.t.n_a, batch.t.n_b);
        let row_len = nb * M;
        assert!(
            p <= DEPTH
                && nb.is_multiple_of(LANE)
                && w.len() == na * row_len
                && batch.t.a.len() == DEPTH * na
                && batch.bs.as_ref().len() == DEPTH * row_len
                && batch.gb.as_ref().len() == DEPTH * row_len
                && batch.cur.as_ref().len() == row_len
                && (!OUT || a.len() == na)
        );
        // SAFETY: AVX-512F (caller's contract); the lengths are checked there.
        unsafe { scale_terms(batch.bs.as_ref(), &batch.t.g, p, row_len, batch.gb.as_mut()) };
        let batch = &*batch;
        let wp = w.as_mut_ptr();
        // SAFETY: AVX-512F (caller's contract); offsets: rows `i + r < na`, registers
        // `r0 + N ≤ regs`, term `m < p ≤ DEPTH`: in bounds by the assert.
        unsafe {
            let d = spreads(&batch.t.d);
            let mut out = [_mm512_setzero_pd(); M];
            let mut i = 0;
            while i + FLUSH_ROWS <= na {
                flush_rows::<M, OUT, FLUSH_ROWS>(wp, batch, a, i, p, &d, &mut out);
                i += FLUSH_ROWS;
            }
            while i < na {
                flush_rows::<M, OUT, 1>(wp, batch, a, i, p, &d, &mut out);
                i += 1;
            }
            if OUT { sums(&out) } else { [0.0; M] }
        }
    }
}

/// The passes of the `f32` store: as those of `avx512`, on 16 lanes of `f32`.
#[cfg(target_arch = "x86_64")]
mod avx512f32 {
    use super::{Batch32, DEPTH, LANE32, MAX_OUTPUTS};
    use std::arch::x86_64::{
        __m512, _mm256_loadu_ps, _mm256_storeu_ps, _mm512_add_ps, _mm512_castps256_ps512,
        _mm512_cvtpd_ps, _mm512_fmadd_ps, _mm512_loadu_pd, _mm512_loadu_ps, _mm512_loadu_si512,
        _mm512_maskz_loadu_pd, _mm512_mul_ps, _mm512_permutex2var_ps, _mm512_permutexvar_ps,
        _mm512_set1_ps, _mm512_setzero_ps, _mm512_storeu_ps, _mm512_sub_ps,
    };

    /// `dst = src` rounded to `f32`, 8 values a register.
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless the lengths are equal.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn narrow(src: &[f64], dst: &mut [f32]) {
        assert_eq!(src.len(), dst.len());
        let body = src.len() / 8 * 8;
        for (s, d) in src[..body]
            .chunks_exact(8)
            .zip(dst[..body].chunks_exact_mut(8))
        {
            // SAFETY: 8 values each way; AVX-512F (caller's contract).
            unsafe {
                let x = _mm512_cvtpd_ps(_mm512_loadu_pd(s.as_ptr()));
                _mm256_storeu_ps(d.as_mut_ptr(), x);
            }
        }
        for (s, d) in src[body..].iter().zip(&mut dst[body..]) {
            *d = *s as f32;
        }
    }

    /// `cur` = `B` spread over the weight lanes, a register at a time: register `r` is lanes
    /// `idx[r]` of the two 8-value blocks of `b32` at `first[r]` and `first[r] + 8` (two loads
    /// and one two-source permute). The blocks are those [`narrow`] just stored, whole, so each
    /// load is forwarded from one store (a 16-value load across two or three of them, as an
    /// unaligned one would be, waits for the stores to reach the cache).
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `cur.len() = 16·idx.len()`, `first` is as
    /// long as `idx` and `b32` holds 16 values from every `first[r]`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn spread_rows(
        b32: &[f32],
        idx: &[[u32; LANE32]],
        first: &[usize],
        cur: &mut [f32],
    ) {
        assert!(cur.len() == LANE32 * idx.len() && first.len() == idx.len());
        for ((c, ix), &f0) in cur.chunks_exact_mut(LANE32).zip(idx).zip(first) {
            let src = &b32[f0..f0 + LANE32];
            // SAFETY: 16 lanes in two halves of 8, in bounds by the slicing; AVX-512F (caller's
            // contract).
            unsafe {
                let i = _mm512_loadu_si512(ix.as_ptr().cast());
                let lo = _mm512_castps256_ps512(_mm256_loadu_ps(src.as_ptr()));
                let hi = _mm512_castps256_ps512(_mm256_loadu_ps(src.as_ptr().add(8)));
                _mm512_storeu_ps(c.as_mut_ptr(), _mm512_permutex2var_ps(lo, i, hi));
            }
        }
    }

    /// The lane patterns of a spread row: lane `t` of register `q` is output `(16q + t) % m`
    /// (for `q < m`; register `q + m` repeats register `q`).
    const fn lane_outputs(m: usize) -> [[u32; LANE32]; MAX_OUTPUTS] {
        let mut pat = [[0; LANE32]; MAX_OUTPUTS];
        let mut e = 0;
        while e < LANE32 * MAX_OUTPUTS {
            pat[e / LANE32][e % LANE32] = (e % m) as u32;
            e += 1;
        }
        pat
    }

    /// `v_j` rounded to `f32` and spread over register `q`'s lanes: lane `t` holds
    /// `v[(16q + t) % M]` (a masked load, a conversion and a permute; no scalar stores read
    /// back as a register).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn spread<const M: usize>(v: &[f64; M], q: usize) -> __m512 {
        const { assert!(M >= 1 && M <= MAX_OUTPUTS) };
        let idx = &const { lane_outputs(M) }[q % M];
        // SAFETY: `M ≤ 8` values at `v` (the mask); 16 indices; AVX-512F (caller's contract).
        unsafe {
            let x = _mm512_maskz_loadu_pd(((1u32 << M) - 1) as u8, v.as_ptr());
            let x = _mm512_castps256_ps512(_mm512_cvtpd_ps(x));
            _mm512_permutexvar_ps(_mm512_loadu_si512(idx.as_ptr().cast()), x)
        }
    }

    /// The `M` lane patterns of `v` ([`spread`] for `q < M`).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn spreads<const M: usize>(v: &[f64; M]) -> [__m512; M] {
        // SAFETY: AVX-512F (caller's contract).
        unsafe {
            let mut x = [_mm512_setzero_ps(); M];
            for (q, xq) in x.iter_mut().enumerate() {
                *xq = spread(v, q);
            }
            x
        }
    }

    /// Load 16 lanes at `p + o` (no bounds check).
    ///
    /// # Safety
    /// `p + o .. p + o + 16` in bounds; the CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn ld(p: *const f32, o: usize) -> __m512 {
        // SAFETY: the caller's contract.
        unsafe { _mm512_loadu_ps(p.add(o)) }
    }

    /// Per-output sums in `f64` of `M` registers (lane `16q + t` is output `(16q + t) % M`),
    /// in a fixed order (pairwise).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    unsafe fn sums<const M: usize>(v: &[__m512; M]) -> [f64; M] {
        let mut l = [0.0f32; LANE32 * MAX_OUTPUTS];
        for (chunk, &x) in l.chunks_exact_mut(LANE32).zip(v) {
            // SAFETY: `chunk` holds 16 f32; AVX-512F (caller's contract).
            unsafe { _mm512_storeu_ps(chunk.as_mut_ptr(), x) };
        }
        // Plain loops, not `array::from_fn` closures: inside a `target_feature` function
        // those are not inlined (a call an element, measured 5 % of the pass).
        let mut out = [0.0; M];
        for (j, o) in out.iter_mut().enumerate() {
            let mut x = [0.0f64; LANE32];
            for (t, xt) in x.iter_mut().enumerate() {
                *xt = f64::from(l[t * M + j]);
            }
            let mut n = LANE32;
            while n > 1 {
                n /= 2;
                for t in 0..n {
                    x[t] += x[t + n];
                }
            }
            *o = x[0];
        }
        out
    }

    /// Columns `r0·16 .. (r0 + N)·16` of the output pass (as `avx512::read_cols`), the rows
    /// in reverse order if `REV`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; `(r0 + N)·16 ≤ row_len`, `w` holds `a.len()` rows.
    #[inline(always)]
    unsafe fn read_cols<const M: usize, const N: usize, const REV: bool>(
        w: *const f32,
        a: &[f32],
        cur: *const f32,
        row_len: usize,
        r0: usize,
        out: &mut [__m512; M],
    ) {
        let na = a.len();
        // SAFETY: AVX-512F and bounds (the caller's contract).
        unsafe {
            let mut c = [_mm512_setzero_ps(); N];
            let mut c2 = [_mm512_setzero_ps(); N];
            let mut k = 0;
            while k + 2 <= na {
                let (i, i2) = if REV {
                    (na - 1 - k, na - 2 - k)
                } else {
                    (k, k + 1)
                };
                let av = _mm512_set1_ps(*a.as_ptr().add(i));
                let av2 = _mm512_set1_ps(*a.as_ptr().add(i2));
                let row = w.add(i * row_len + r0 * LANE32);
                let row2 = w.add(i2 * row_len + r0 * LANE32);
                for t in 0..N {
                    c[t] = _mm512_fmadd_ps(av, ld(row, t * LANE32), c[t]);
                    c2[t] = _mm512_fmadd_ps(av2, ld(row2, t * LANE32), c2[t]);
                }
                k += 2;
            }
            if k < na {
                let i = if REV { na - 1 - k } else { k };
                let av = _mm512_set1_ps(*a.as_ptr().add(i));
                let row = w.add(i * row_len + r0 * LANE32);
                for (t, ct) in c.iter_mut().enumerate() {
                    *ct = _mm512_fmadd_ps(av, ld(row, t * LANE32), *ct);
                }
            }
            for t in 0..N {
                c[t] = _mm512_add_ps(c[t], c2[t]);
            }
            for (t, ct) in c.iter().enumerate() {
                let q = (r0 + t) % M;
                out[q] = _mm512_fmadd_ps(*ct, ld(cur, (r0 + t) * LANE32), out[q]);
            }
        }
    }

    /// The output pass, read only: `Σ_k B[k] Σ_i a_i V[i, k, j]` per output, the sums in `f32`
    /// and their final reduction in `f64`; the rows in reverse order if `REV`.
    ///
    /// Passes alternate their direction (`Batch32::tick`): `V` (48 KB for the paper) is as
    /// large as the L1 data cache, so a pass in the same order as the last one finds the
    /// lines it needs first evicted by the ones it needs last; in the other order it starts
    /// with the lines the last pass left in L1.
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `cur.len() = nb·M`, `nb % 16 = 0` and
    /// `w.len() = a.len()·nb·M`.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn read<const M: usize, const REV: bool>(
        w: &[f32],
        a: &[f32],
        cur: &[f32],
        nb: usize,
    ) -> [f64; M] {
        let row_len = nb * M;
        assert!(nb.is_multiple_of(LANE32) && cur.len() == row_len && w.len() == a.len() * row_len);
        let regs = row_len / LANE32;
        // SAFETY: AVX-512F (caller's contract); `read_cols` stays inside rows of `row_len`
        // values (`r0 + N ≤ regs`) and `cur`, by the assert.
        unsafe {
            let mut out = [_mm512_setzero_ps(); M];
            let mut r0 = 0;
            while r0 + 12 <= regs {
                read_cols::<M, 12, REV>(w.as_ptr(), a, cur.as_ptr(), row_len, r0, &mut out);
                r0 += 12;
            }
            while r0 + 4 <= regs {
                read_cols::<M, 4, REV>(w.as_ptr(), a, cur.as_ptr(), row_len, r0, &mut out);
                r0 += 4;
            }
            while r0 < regs {
                read_cols::<M, 1, REV>(w.as_ptr(), a, cur.as_ptr(), row_len, r0, &mut out);
                r0 += 1;
            }
            sums(&out)
        }
    }

    /// Registers of a row the flush takes at once.
    const FLUSH_COLS: usize = 12;

    /// Rows the flush takes at once: each load of a scaled term row `G_m` feeds `FLUSH_ROWS`
    /// fused multiply-adds (with `FLUSH_COLS = 12`: 24 sums, 2 coefficients and the loaded
    /// operand, inside the 32 AVX-512 registers; 4 × 6 measured no faster).
    const FLUSH_ROWS: usize = 2;

    /// `G_m = g_m ⊙ B_m` for the `p` held terms, spread over the weight lanes as `B_m` is:
    /// the flush's rows then need one fused multiply-add a register and term, with no
    /// per-row products of `g_m` and `a_{m,i}` and no `g_m` registers.
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `p ≤ DEPTH`, `row_len % 16 = 0` and
    /// `bs` and `gb` hold `DEPTH` rows of `row_len`.
    #[target_feature(enable = "avx512f")]
    unsafe fn scale_terms<const M: usize>(
        bs: &[f32],
        g: &[[f64; M]; DEPTH],
        p: usize,
        row_len: usize,
        gb: &mut [f32],
    ) {
        assert!(
            p <= DEPTH
                && row_len.is_multiple_of(LANE32)
                && bs.len() == DEPTH * row_len
                && gb.len() == DEPTH * row_len
        );
        for ((bm, gm), gbm) in bs
            .chunks_exact(row_len)
            .zip(g)
            .zip(gb.chunks_exact_mut(row_len))
            .take(p)
        {
            // SAFETY: AVX-512F (caller's contract); 16 lanes a register, inside the rows of
            // `row_len` values by the `chunks_exact`.
            unsafe {
                // `g_m`, rounded to `f32` once, spread over the lanes.
                let gv = spreads(gm);
                for (r, (b, o)) in bm
                    .chunks_exact(LANE32)
                    .zip(gbm.chunks_exact_mut(LANE32))
                    .enumerate()
                {
                    let x = _mm512_mul_ps(gv[r % M], ld(b.as_ptr(), 0));
                    _mm512_storeu_ps(o.as_mut_ptr(), x);
                }
            }
        }
    }

    /// What the flush reads: the held terms' `A_m` and scaled spread `G_m`, this tick's
    /// `A` and spread `B`.
    struct Terms32 {
        na: usize,
        row_len: usize,
        am: *const f32,
        gb: *const f32,
        cur: *const f32,
        cur_a: *const f32,
    }

    /// The flush of registers `r0 .. r0 + N` of rows `i .. i + R` (`r0 % M = 0`, so register
    /// `r0 + t` has the lane pattern `t % M`): the terms' sum `t = Σ_m a_{m,i}·G_m` from zero
    /// (a load of `G_m` feeds the `R` rows), then `v ← v − ((1 − D)·v + t)`; stored; if `OUT`,
    /// `racc[r][t % M] += v·B` for row `i + r`.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; every offset in bounds (the caller's checks).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    unsafe fn flush_cols<const M: usize, const OUT: bool, const R: usize, const N: usize>(
        vp: *mut f32,
        tm: &Terms32,
        i: usize,
        r0: usize,
        p: usize,
        dm: &[__m512; M],
        racc: &mut [[__m512; M]; R],
    ) {
        let (na, row_len) = (tm.na, tm.row_len);
        let off = |t: usize| (r0 + t) * LANE32;
        // SAFETY: AVX-512F and bounds (the caller's contract).
        unsafe {
            let mut acc = [[_mm512_setzero_ps(); N]; R];
            for m in 0..p {
                let mut am = [_mm512_setzero_ps(); R];
                for (r, x) in am.iter_mut().enumerate() {
                    *x = _mm512_set1_ps(*tm.am.add(m * na + i + r));
                }
                let gm = tm.gb.add(m * row_len);
                for t in 0..N {
                    let x = ld(gm, off(t));
                    for (ar, acc_r) in am.iter().zip(acc.iter_mut()) {
                        acc_r[t] = _mm512_fmadd_ps(*ar, x, acc_r[t]);
                    }
                }
            }
            for (r, (acc_r, racc_r)) in acc.iter().zip(racc.iter_mut()).enumerate() {
                let row = vp.add((i + r) * row_len);
                for (t, at) in acc_r.iter().enumerate() {
                    let v = ld(row, off(t));
                    let v = _mm512_sub_ps(v, _mm512_fmadd_ps(dm[t % M], v, *at));
                    _mm512_storeu_ps(row.add(off(t)), v);
                    if OUT {
                        racc_r[t % M] = _mm512_fmadd_ps(v, ld(tm.cur, off(t)), racc_r[t % M]);
                    }
                }
            }
        }
    }

    /// Rows `i .. i + R` of the flush, a row's registers [`FLUSH_COLS`] at a time (or `M`,
    /// if `M` does not divide it); if `OUT`, `out += a_i·(V'[i]·B)` for each row.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; every offset in bounds (the caller's checks).
    #[inline(always)]
    unsafe fn flush_rows<const M: usize, const OUT: bool, const R: usize>(
        vp: *mut f32,
        tm: &Terms32,
        i: usize,
        p: usize,
        dm: &[__m512; M],
        out: &mut [__m512; M],
    ) {
        let regs = tm.row_len / LANE32;
        // SAFETY: AVX-512F and bounds (the caller's contract); `r0 + N ≤ regs`.
        unsafe {
            let mut racc = [[_mm512_setzero_ps(); M]; R];
            let mut r0 = 0;
            if FLUSH_COLS.is_multiple_of(M) {
                while r0 + FLUSH_COLS <= regs {
                    flush_cols::<M, OUT, R, FLUSH_COLS>(vp, tm, i, r0, p, dm, &mut racc);
                    r0 += FLUSH_COLS;
                }
            }
            while r0 < regs {
                flush_cols::<M, OUT, R, M>(vp, tm, i, r0, p, dm, &mut racc);
                r0 += M;
            }
            if OUT {
                for (r, racc_r) in racc.iter().enumerate() {
                    let av = _mm512_set1_ps(*tm.cur_a.add(i + r));
                    for q in 0..M {
                        out[q] = _mm512_fmadd_ps(av, racc_r[q], out[q]);
                    }
                }
            }
        }
    }

    /// The flush pass on the `f32` store: `V ← D V − Σ_{m<p} g_m A_m ⊗ B_m`, and, if `OUT`,
    /// `f̂ = V'ᵀ(A ⊗ B)` with the new weights (this tick's `A`, `B` from `batch.cur_a`,
    /// `batch.cur`).
    ///
    /// The scaled rows `G_m = g_m ⊙ B_m` are formed first ([`scale_terms`], 12 KB for the
    /// paper, in L1 with the `A_m`); then rows stream in order, [`FLUSH_ROWS`] at a time, so
    /// that the pass is `V ← V·diag(D) − Aᵀ G` (`V` the `n_a × n_b·M` store, `A` the `p × n_a`
    /// matrix of the `A_m`, `G` the `p × n_b·M` matrix of the `G_m`; the `f32` store computes it
    /// as `v − ((1 − D)v + t)`), with one load of `G` for every `FLUSH_ROWS` fused multiply-adds.
    ///
    /// # Safety
    /// The CPU must support AVX-512F. Panics unless `p ≤ DEPTH` and the buffers match.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn apply<const M: usize, const OUT: bool>(
        batch: &mut Batch32<M>,
        p: usize,
    ) -> [f64; M] {
        let (na, nb) = (batch.t.n_a, batch.t.n_b);
        let row_len = nb * M;
        assert!(
            p <= DEPTH
                && nb.is_multiple_of(LANE32)
                && batch.v.as_ref().len() == na * row_len
                && batch.a32.len() == DEPTH * na
                && batch.cur_a.len() == na
                && batch.bs.as_ref().len() == DEPTH * row_len
                && batch.gb.as_ref().len() == DEPTH * row_len
                && batch.cur.as_ref().len() == row_len
        );
        // SAFETY: AVX-512F (caller's contract); the lengths are checked there.
        unsafe { scale_terms(batch.bs.as_ref(), &batch.t.g, p, row_len, batch.gb.as_mut()) };
        // `1 − D`, rounded to `f32` once (below), spread over the lanes.
        let mut dm = [0.0; M];
        for (x, &d) in dm.iter_mut().zip(&batch.t.d) {
            *x = 1.0 - d;
        }
        // SAFETY: AVX-512F (caller's contract); offsets: rows `i + r < na`, registers
        // `r0 + N ≤ regs`, term `m < p ≤ DEPTH`: in bounds by the assert. `vp` is the only
        // pointer written through (`v`); the others point into other fields, only read.
        unsafe {
            let dm = spreads(&dm);
            let tm = Terms32 {
                na,
                row_len,
                am: batch.a32.as_ptr(),
                gb: batch.gb.as_ref().as_ptr(),
                cur: batch.cur.as_ref().as_ptr(),
                cur_a: batch.cur_a.as_ptr(),
            };
            let vp = batch.v.as_mut().as_mut_ptr();
            let mut out = [_mm512_setzero_ps(); M];
            let mut i = 0;
            while i + FLUSH_ROWS <= na {
                flush_rows::<M, OUT, FLUSH_ROWS>(vp, &tm, i, p, &dm, &mut out);
                i += FLUSH_ROWS;
            }
            while i < na {
                flush_rows::<M, OUT, 1>(vp, &tm, i, p, &dm, &mut out);
                i += 1;
            }
            if OUT { sums(&out) } else { [0.0; M] }
        }
    }
}
