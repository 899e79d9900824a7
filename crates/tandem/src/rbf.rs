//! Gaussian RBF basis (8) and the adaptive network (41), (44).
//!
//! $$
//! s_k(Z) = \exp\!\Big(-\frac{\lVert Z - \mu_k\rVert^2}{\vartheta^2}\Big)\quad (8),\qquad
//! \hat f_j(Z) = \hat W_j^{\mathsf T} S(Z)\quad (41),\qquad
//! \dot{\hat W}_j = -\Theta_j\big(Q\,S(Z)\,z_{2j} + \sigma_j \hat W_j\big)\quad (44).
//! $$
//!
//! SPEC §3.4: the paper's `2^12` centres "evenly distributed in [−1, 1]" are the grid
//! `{−1, 1}^12` over the 12 inputs `Z = [x_1, x_2, α, α̇]`, "variance 50" is `ϑ² = 50`, the
//! weights start at 0; `Q = M(Z)·I` is a scalar (see [`crate::switching`]), and `Θ_j` is a
//! positive scalar per output. One width `ϑ` is shared by all nodes.
//!
//! # Grid centres and node ordering
//!
//! A grid has, per input `i`, levels `c_{i,0..n_i}`; its centres are the Cartesian product.
//! Node `k` is the multi-index `(l_0, …, l_{N−1})` in **row-major order: the last input varies
//! fastest**, `k = ((l_0 n_1 + l_1) n_2 + l_2)…`, which is the Kronecker convention, so
//! `S(Z) = f_0 ⊗ f_1 ⊗ … ⊗ f_{N−1}` with `f_i[l] = exp(−(Z_i − c_{i,l})²/ϑ²)`.
//! [`Rbf::to_general`] lists the same centres in the same order, so the two forms agree node for
//! node. The Kronecker form costs `Σ n_i` exponentials (24 for the paper grid instead of 4096)
//! and one multiply per node: the inputs are split into a head and a tail whose partial
//! products `A`, `B` have about `√N_s` entries each, and `S = A ⊗ B` is an outer product.
//!
//! # Adaptive network: exact discretisation of (44)
//!
//! With `S`, `Q`, `z_2` held over one control period `h` (zero-order hold), (44) is linear with
//! constant coefficients and its exact solution is
//!
//! $$
//! \hat W_j \leftarrow e^{-\Theta_j\sigma_j h}\,\hat W_j -
//!   \frac{1 - e^{-\Theta_j\sigma_j h}}{\sigma_j}\,Q\,S\,z_{2j}.
//! $$
//!
//! To first order in `h` this is the Euler step `Ŵ − hΘ(QSz_2 + σŴ)`; unlike Euler it is
//! unconditionally stable (the decay factor is in `(0, 1)` for every `h`) and exact for held
//! inputs. `1 − e^{−x}` is formed with `expm1`.
//!
//! # Storage and the fused tick
//!
//! `Ŵ` (`N_s × M`) is stored **interleaved by node** (node-major, `w[k·M + j]`), so one
//! forward pass over memory (96 KB for the paper) serves every output. The tick
//! ([`RbfNetwork::tick`]) reads each weight once, adds its contribution to `f̂_j` (with the
//! weights *before* the update, as the continuous law evaluates both at the same instant),
//! writes the updated weight and adds its square to `‖Ŵ_j‖²`, all in that one pass, with no
//! allocation. [`RbfNetwork::tick_at`] on a grid also forms `S = A ⊗ B` inside that pass.
//!
//! The kernels work on blocks of 4 nodes (`4M` weights, `M` AVX2 registers; 8 nodes for
//! AVX-512); each lane keeps its own partial sums, reduced per output in a fixed order at the
//! end. So results are bitwise reproducible, identical between the output-only, update-only and
//! fused paths of a kernel, and identical between the portable and the AVX2 code (no FMA, so the
//! rounding is the same). The FMA kernels (`avx2fma`, `avx512` and `batched`; the default
//! where the CPU has AVX-512F is one of the last two, by vendor) agree with them within the
//! tolerance of the determinism policy ([`Kernel`], `docs/performance.md`); `batched-f32`, which
//! keeps the weights in single precision, within its own. This is the only `unsafe` in the
//! module: the SIMD intrinsics and the call into a `#[target_feature]` function after
//! detection.
//!
//! # The batched update
//!
//! The update is linear in `Ŵ`, so [`Kernel::Batched`] holds it for [`BATCH_DEPTH`] ticks as
//! a factor and rank-one terms `(g_m, A_m, B_m)` and applies them in one pass: most controller
//! ticks then only read the weights (`f̂` with the held terms added through
//! `(A_m ⊗ B_m)·(A ⊗ B) = (A_m·A)(B_m·B)`). Same map, other rounding; see the `batched`
//! module. While terms are held, the accessors that read the stored weights panic
//! ([`RbfNetwork::pending`], [`RbfNetwork::flush`], [`RbfNetwork::weights_now`]). The weights
//! start on a 64-byte boundary, so no AVX-512 load straddles two cache lines.
//!
use nalgebra::{DMatrix, DVector, SVector};

use crate::error::{ModelError, positive};

mod batched;
mod factors;
pub use batched::DEPTH as BATCH_DEPTH;

/// Largest number of outputs of an [`RbfNetwork`].
pub const MAX_OUTPUTS: usize = 8;

/// Largest number of nodes accepted (a guard against typos such as 10 levels × 12 inputs).
pub const MAX_NODES: usize = 1 << 24;

/// A zero-initialised buffer (of `f64`, or `f32` for the single-precision store of
/// [`Kernel::BatchedF32`]) whose first element is 64-byte aligned (a cache line and an AVX-512
/// register: aligned loads never straddle two lines). Over-allocates by one register.
#[derive(Debug)]
pub(crate) struct Aligned<T = f64> {
    buf: Vec<T>,
    off: usize,
    len: usize,
}

impl<T: Copy + Default> Aligned<T> {
    /// `len` zeros.
    pub(crate) fn zeros(len: usize) -> Self {
        let spare = 64 / std::mem::size_of::<T>() - 1;
        let buf = vec![T::default(); len + spare];
        let off = buf.as_ptr().align_offset(64).min(spare);
        Self { buf, off, len }
    }
}

impl<T> AsRef<[T]> for Aligned<T> {
    #[inline(always)]
    fn as_ref(&self) -> &[T] {
        &self.buf[self.off..self.off + self.len]
    }
}

impl<T> AsMut<[T]> for Aligned<T> {
    #[inline(always)]
    fn as_mut(&mut self) -> &mut [T] {
        &mut self.buf[self.off..self.off + self.len]
    }
}

impl<T: Copy + Default> Clone for Aligned<T> {
    /// A new aligned buffer with the same values (a derived clone could lose the alignment).
    fn clone(&self) -> Self {
        let mut c = Self::zeros(self.len);
        c.as_mut().copy_from_slice(self.as_ref());
        c
    }
}

impl<T: PartialEq> PartialEq for Aligned<T> {
    fn eq(&self, other: &Self) -> bool {
        self.as_ref() == other.as_ref()
    }
}

/// Where the centres come from.
#[derive(Debug, Clone, PartialEq)]
enum Centres {
    /// Per-input levels; node order as in the module docs.
    Grid {
        /// All levels, input after input.
        levels: Vec<f64>,
        /// Input `i` owns `levels[offsets[i]..offsets[i + 1]]`.
        offsets: Vec<usize>,
        /// Inputs `0..split` form the head product `A`, the rest the tail `B`.
        split: usize,
        /// `len(A)`, `len(B)`; `n_a · n_b = N_s`.
        n_a: usize,
        n_b: usize,
        /// The input of every level (`offsets[i] ≤ l < offsets[i + 1]` gives `i`), as the
        /// vector exponentials' gather indices.
        input_of: Vec<i64>,
        /// Whether every input has exactly two levels (the paper's grid): `‖S‖²`'s per-input
        /// sums then take one multiply-add a pair.
        two_levels: bool,
    },
    /// Explicit centres, node-major (`centres[k * n_in + i] = μ_k,i`).
    General { centres: Vec<f64> },
}

/// A Gaussian RBF basis (8): `N_s` centres in `R^{N_in}` and a common width `ϑ²`. Immutable.
#[derive(Debug, Clone, PartialEq)]
pub struct Rbf {
    centres: Centres,
    width2: f64,
    inv_width2: f64,
    n_in: usize,
    n_nodes: usize,
    /// Use the AVX2 build of the outer product (detected once, at construction).
    avx2: bool,
}

/// Scratch memory and the output `S(Z)` of [`Rbf::eval_into`]; sized once by
/// [`Rbf::workspace`], reused every tick.
#[derive(Debug, Clone, PartialEq)]
pub struct RbfWorkspace {
    /// Per-input factors `f_i`, input after input (grid only).
    f: Vec<f64>,
    /// Head and tail partial products (grid only).
    a: Vec<f64>,
    b: Vec<f64>,
    /// Ping-pong buffer for building `A` and `B`.
    t: Vec<f64>,
    /// `S(Z)`, length `N_s`.
    s: Vec<f64>,
    /// `‖S‖²` of the last evaluation.
    s_norm2: f64,
}

impl RbfWorkspace {
    /// `S(Z)` from the last [`Rbf::eval_into`] (length `N_s`, node order of the module docs).
    #[inline]
    pub fn s(&self) -> &[f64] {
        &self.s
    }

    /// `‖S(Z)‖²` from the last [`Rbf::eval_into`].
    #[inline]
    pub fn s_norm2(&self) -> f64 {
        self.s_norm2
    }

    /// Store `S(Z)` and `‖S(Z)‖²` computed outside [`Rbf::eval_into`] (the fixed-size per-axis
    /// kernel of [`crate::rbf_structured`], which produces the same bits).
    #[inline]
    pub(crate) fn store(&mut self, s: &[f64], s_norm2: f64) {
        self.s.copy_from_slice(s);
        self.s_norm2 = s_norm2;
    }
}

impl Rbf {
    /// Grid centres: `levels[i]` lists the levels of input `i` (node order: last input
    /// fastest), width `ϑ² = width2 > 0`.
    pub fn grid(levels: &[Vec<f64>], width2: f64) -> Result<Self, ModelError> {
        positive("width2", width2)?;
        if levels.is_empty() {
            return Err(ModelError::geometry(
                "rbf.levels",
                "needs at least one input",
            ));
        }
        let mut flat = Vec::new();
        let mut offsets = vec![0];
        let mut n_nodes: usize = 1;
        for (i, li) in levels.iter().enumerate() {
            if li.is_empty() {
                return Err(ModelError::geometry(
                    format!("rbf.levels[{i}]"),
                    "needs at least one level",
                ));
            }
            if let Some(&bad) = li.iter().find(|c| !c.is_finite()) {
                return Err(ModelError::invalid(
                    format!("rbf.levels[{i}]"),
                    bad,
                    "must be finite",
                ));
            }
            n_nodes = n_nodes
                .checked_mul(li.len())
                .filter(|&n| n <= MAX_NODES)
                .ok_or_else(|| {
                    ModelError::geometry("rbf.levels", format!("more than {MAX_NODES} nodes"))
                })?;
            flat.extend_from_slice(li);
            offsets.push(flat.len());
        }
        // Split so that the head product is as close to √N_s as possible.
        let (mut split, mut n_a, mut best) = (0, 1, n_nodes as f64);
        let mut prod = 1usize;
        for (i, li) in levels.iter().enumerate() {
            prod *= li.len();
            let dist = ((prod as f64).ln() - 0.5 * (n_nodes as f64).ln()).abs();
            if dist < best {
                (split, n_a, best) = (i + 1, prod, dist);
            }
        }
        let two_levels = offsets.iter().enumerate().all(|(i, &o)| o == 2 * i);
        let input_of = (0..levels.len())
            .flat_map(|i| std::iter::repeat_n(i as i64, offsets[i + 1] - offsets[i]))
            .collect();
        Ok(Self {
            centres: Centres::Grid {
                levels: flat,
                offsets,
                split,
                n_a,
                n_b: n_nodes / n_a,
                input_of,
                two_levels,
            },
            width2,
            inv_width2: 1.0 / width2,
            n_in: levels.len(),
            n_nodes,
            avx2: detect_avx2(),
        })
    }

    /// The paper's basis (SPEC §3.4): 12 inputs × levels `{−1, 1}` → 4096 nodes, `ϑ² = 50`.
    pub fn paper() -> Self {
        Self::grid(&vec![vec![-1.0, 1.0]; 12], 50.0).expect("the paper grid is valid")
    }

    /// General centres: row `k` of `centres` (`N_s × N_in`) is `μ_k`; width `ϑ² = width2`.
    pub fn general(centres: &DMatrix<f64>, width2: f64) -> Result<Self, ModelError> {
        positive("width2", width2)?;
        let (n_nodes, n_in) = centres.shape();
        if n_nodes == 0 || n_in == 0 || n_nodes > MAX_NODES {
            return Err(ModelError::geometry(
                "rbf.centres",
                format!("shape {n_nodes} × {n_in}: needs 1..={MAX_NODES} nodes and ≥ 1 input"),
            ));
        }
        if let Some(&bad) = centres.iter().find(|c| !c.is_finite()) {
            return Err(ModelError::invalid("rbf.centres", bad, "must be finite"));
        }
        // Node-major copy so that one centre is contiguous.
        let mut flat = Vec::with_capacity(n_nodes * n_in);
        for k in 0..n_nodes {
            flat.extend(centres.row(k).iter());
        }
        Ok(Self {
            centres: Centres::General { centres: flat },
            width2,
            inv_width2: 1.0 / width2,
            n_in,
            n_nodes,
            avx2: detect_avx2(),
        })
    }

    /// The same basis with explicit centres, in the same node order (a grid is expanded).
    pub fn to_general(&self) -> Self {
        let mut m = DMatrix::zeros(self.n_nodes, self.n_in);
        let mut mu = vec![0.0; self.n_in];
        for k in 0..self.n_nodes {
            self.centre_into(k, &mut mu);
            m.row_mut(k).copy_from_slice(&mu);
        }
        Self::general(&m, self.width2).expect("centres of a valid basis are valid")
    }

    /// Writes centre `μ_k` into `out` (length `N_in`).
    ///
    /// # Panics
    /// If `k ≥ N_s` or `out.len() != N_in`.
    pub fn centre_into(&self, k: usize, out: &mut [f64]) {
        assert!(
            k < self.n_nodes && out.len() == self.n_in,
            "rbf: centre index or length"
        );
        match &self.centres {
            Centres::Grid {
                levels, offsets, ..
            } => {
                // Row-major multi-index: peel the last (fastest) input first.
                let mut rest = k;
                for i in (0..self.n_in).rev() {
                    let n = offsets[i + 1] - offsets[i];
                    out[i] = levels[offsets[i] + rest % n];
                    rest /= n;
                }
            }
            Centres::General { centres } => {
                out.copy_from_slice(&centres[k * self.n_in..(k + 1) * self.n_in]);
            }
        }
    }

    /// Number of inputs `N_in`.
    pub fn n_inputs(&self) -> usize {
        self.n_in
    }

    /// Number of nodes `N_s`.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Width `ϑ²`.
    pub fn width2(&self) -> f64 {
        self.width2
    }

    /// `(c_0, c_1, 1/ϑ²)` if this is a grid of four inputs with the same two levels
    /// `[c_0, c_1]` each (the per-axis network's basis): the case of the fixed-size kernel of
    /// [`crate::rbf_structured`], which reproduces [`Rbf::eval_into`] bit for bit.
    pub(crate) fn two_level_four_input(&self) -> Option<(f64, f64, f64)> {
        match &self.centres {
            Centres::Grid {
                levels,
                offsets,
                split,
                ..
            } if self.n_in == 4
                && *split == 2
                && offsets.as_slice() == [0, 2, 4, 6, 8]
                && levels.chunks_exact(2).all(|l| l == &levels[..2]) =>
            {
                Some((levels[0], levels[1], self.inv_width2))
            }
            _ => None,
        }
    }

    /// `(len A, len B)`, the head and tail lengths of a grid basis (`None` for general
    /// centres).
    pub(crate) fn grid_dims(&self) -> Option<(usize, usize)> {
        match &self.centres {
            Centres::Grid { n_a, n_b, .. } => Some((*n_a, *n_b)),
            Centres::General { .. } => None,
        }
    }

    /// Where each input's factors start in [`RbfWorkspace`]'s factor buffer: input `i` owns
    /// `offsets[i]..offsets[i + 1]` (`None` for general centres).
    pub(crate) fn grid_offsets(&self) -> Option<&[usize]> {
        match &self.centres {
            Centres::Grid { offsets, .. } => Some(offsets),
            Centres::General { .. } => None,
        }
    }

    /// Whether the Kronecker fast path is used.
    pub fn is_grid(&self) -> bool {
        matches!(self.centres, Centres::Grid { .. })
    }

    /// Buffers for [`Rbf::eval_into`] (the only allocation; do it at set-up).
    pub fn workspace(&self) -> RbfWorkspace {
        let (nf, na, nb) = match &self.centres {
            Centres::Grid {
                levels, n_a, n_b, ..
            } => (levels.len(), *n_a, *n_b),
            Centres::General { .. } => (0, 0, 0),
        };
        RbfWorkspace {
            f: vec![0.0; nf],
            a: vec![0.0; na],
            b: vec![0.0; nb],
            t: vec![0.0; na.max(nb)],
            s: vec![0.0; self.n_nodes],
            s_norm2: 0.0,
        }
    }

    /// `S(Z)` into `ws.s()` (and `‖S‖²` into `ws.s_norm2()`); no allocation.
    ///
    /// Grid: Kronecker form (`Σ n_i` exponentials, one multiply per node). General centres:
    /// the direct sum of (8), one exponential per node.
    ///
    /// # Panics
    /// If `z.len() != N_in` or `ws` was made for another basis.
    pub fn eval_into(&self, z: &[f64], ws: &mut RbfWorkspace) {
        if self.eval_factors(z, ws) {
            // S = A ⊗ B: one multiply per node.
            outer_into(&ws.a, &ws.b, &mut ws.s, self.avx2);
        }
    }

    /// Grid: the factors `f_i`, the partial products `A`, `B` and `‖S‖²` into `ws`, returning
    /// `true` (S itself is left to the caller). General centres: all of `S`, returning `false`.
    fn eval_factors(&self, z: &[f64], ws: &mut RbfWorkspace) -> bool {
        self.eval_factors_with(z, ws, false)
    }

    /// [`Rbf::eval_factors`]; if `wide` (an AVX-512 kernel, on a CPU that has AVX-512F), the
    /// exponentials eight at a time and `A`, `B` a register at a time (module `factors`).
    fn eval_factors_with(&self, z: &[f64], ws: &mut RbfWorkspace, wide: bool) -> bool {
        assert_eq!(z.len(), self.n_in, "rbf: input length");
        assert_eq!(ws.s.len(), self.n_nodes, "rbf: workspace size");
        match &self.centres {
            Centres::Grid {
                levels,
                offsets,
                split,
                input_of,
                two_levels,
                ..
            } => {
                let (na, nb) = (ws.a.len(), ws.b.len());
                let wide = cfg!(target_arch = "x86_64") && wide;
                #[cfg(target_arch = "x86_64")]
                if wide {
                    // SAFETY: `wide` only for an AVX-512 kernel, stored only after
                    // `Kernel::check_available` found AVX-512F.
                    unsafe {
                        factors::gaussians(z, levels, input_of, self.inv_width2, &mut ws.f);
                        factors::kron(&ws.f, offsets, 0, *split, &mut ws.a, &mut ws.t[..na]);
                        factors::kron(
                            &ws.f,
                            offsets,
                            *split,
                            self.n_in,
                            &mut ws.b,
                            &mut ws.t[..nb],
                        );
                    }
                }
                // f_i[l] = exp(−(Z_i − c_{i,l})²/ϑ²) for every input and level.
                let mut fn2 = 1.0;
                if wide && *two_levels {
                    // The loop below's sums for two levels, in its order
                    // (`0 + f_0²` is `f_0²`), without its inner loop.
                    for p in ws.f.chunks_exact(2) {
                        fn2 *= p[0] * p[0] + p[1] * p[1];
                    }
                } else {
                    for i in 0..self.n_in {
                        let (lo, hi) = (offsets[i], offsets[i + 1]);
                        let mut n2 = 0.0;
                        for (f, &c) in ws.f[lo..hi].iter_mut().zip(&levels[lo..hi]) {
                            if !wide {
                                let d = z[i] - c;
                                *f = (-(d * d) * self.inv_width2).exp();
                            }
                            n2 += *f * *f;
                        }
                        fn2 *= n2;
                    }
                }
                if !wide {
                    // A = f_0 ⊗ … ⊗ f_{split−1}, B = f_split ⊗ … ⊗ f_{N−1}.
                    kron_into(&ws.f, offsets, 0, *split, &mut ws.a, &mut ws.t[..na]);
                    kron_into(
                        &ws.f,
                        offsets,
                        *split,
                        self.n_in,
                        &mut ws.b,
                        &mut ws.t[..nb],
                    );
                }
                // ‖A ⊗ B‖² = Π‖f_i‖².
                ws.s_norm2 = fn2;
                true
            }
            Centres::General { centres } => {
                let s = &mut ws.s;
                naive(centres, self.n_in, self.inv_width2, z, s);
                ws.s_norm2 = s.iter().map(|v| v * v).sum();
                false
            }
        }
    }

    /// `S(Z)` by the direct definition (8), one exponential per node, for either kind of
    /// centres (the reference the Kronecker form is tested against). No allocation.
    ///
    /// # Panics
    /// If `z.len() != N_in` or `s.len() != N_s`.
    pub fn eval_naive_into(&self, z: &[f64], s: &mut [f64]) {
        assert!(
            z.len() == self.n_in && s.len() == self.n_nodes,
            "rbf: lengths"
        );
        match &self.centres {
            Centres::General { centres } => naive(centres, self.n_in, self.inv_width2, z, s),
            Centres::Grid { .. } => {
                let mut mu = [0.0; 64];
                assert!(
                    self.n_in <= mu.len(),
                    "rbf: naive grid path supports ≤ 64 inputs"
                );
                for (k, sk) in s.iter_mut().enumerate() {
                    self.centre_into(k, &mut mu[..self.n_in]);
                    let d2: f64 = z.iter().zip(&mu).map(|(a, b)| (a - b) * (a - b)).sum();
                    *sk = (-d2 * self.inv_width2).exp();
                }
            }
        }
    }

    /// Allocating form of [`Rbf::eval_into`].
    pub fn eval(&self, z: &[f64]) -> DVector<f64> {
        let mut ws = self.workspace();
        self.eval_into(z, &mut ws);
        DVector::from_vec(ws.s)
    }
}

/// Kronecker product of the factors of inputs `from..to` into `out` (length `Π n_i`), the last
/// input varying fastest. Built forward, ping-ponging between `out` and `tmp` (same length).
fn kron_into(
    f: &[f64],
    offsets: &[usize],
    from: usize,
    to: usize,
    out: &mut [f64],
    tmp: &mut [f64],
) {
    // Start in whichever buffer makes the last factor land in `out`.
    let (mut src, mut dst) = if (to - from).is_multiple_of(2) {
        (&mut *out, &mut *tmp)
    } else {
        (&mut *tmp, &mut *out)
    };
    src[0] = 1.0;
    let mut len = 1;
    for i in from..to {
        let fi = &f[offsets[i]..offsets[i + 1]];
        let n = fi.len();
        if let &[f0, f1] = fi {
            // Two levels (the paper's grid): unrolled.
            for (&v, row) in src[..len].iter().zip(dst.chunks_exact_mut(2)) {
                row[0] = v * f0;
                row[1] = v * f1;
            }
        } else {
            for (&v, row) in src[..len].iter().zip(dst.chunks_exact_mut(n)) {
                for (o, &fl) in row.iter_mut().zip(fi) {
                    *o = v * fl;
                }
            }
        }
        len *= n;
        std::mem::swap(&mut src, &mut dst);
    }
    debug_assert_eq!(len, src.len());
}

/// `s[i·n_b + j] = a[i]·b[j]`.
fn outer_into(a: &[f64], b: &[f64], s: &mut [f64], avx2: bool) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is true only if the CPU reported AVX2 (`detect_avx2`).
        unsafe { outer_avx2(a, b, s) };
        return;
    }
    let _ = avx2;
    outer_portable(a, b, s);
}

#[inline(always)]
fn outer_portable(a: &[f64], b: &[f64], s: &mut [f64]) {
    for (row, &ai) in s.chunks_exact_mut(b.len()).zip(a) {
        for (sk, &bj) in row.iter_mut().zip(b) {
            *sk = ai * bj;
        }
    }
}

/// [`outer_portable`] compiled for AVX2 (element-wise products: the same bits).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn outer_avx2(a: &[f64], b: &[f64], s: &mut [f64]) {
    outer_portable(a, b, s);
}

/// Direct evaluation of (8) with node-major centres.
fn naive(centres: &[f64], n_in: usize, inv_width2: f64, z: &[f64], s: &mut [f64]) {
    for (sk, mu) in s.iter_mut().zip(centres.chunks_exact(n_in)) {
        let d2: f64 = z.iter().zip(mu).map(|(a, b)| (a - b) * (a - b)).sum();
        *sk = (-d2 * inv_width2).exp();
    }
}

/// Discretised update law (44) for `M` outputs: `Θ_j`, `σ_j` and the period `h` folded into
/// `decay_j = e^{−Θ_j σ_j h}` and `gain_j = (1 − decay_j)/σ_j`. Validated, immutable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NnUpdate<const M: usize> {
    theta: SVector<f64, M>,
    sigma: SVector<f64, M>,
    h: f64,
    decay: [f64; M],
    gain: [f64; M],
}

impl<const M: usize> NnUpdate<M> {
    /// `Θ_j > 0`, `σ_j > 0`, `h > 0`; errors name `theta[j]`, `sigma[j]`, `h`.
    pub fn new(theta: SVector<f64, M>, sigma: SVector<f64, M>, h: f64) -> Result<Self, ModelError> {
        positive("h", h)?;
        for j in 0..M {
            positive(&format!("theta[{j}]"), theta[j])?;
            positive(&format!("sigma[{j}]"), sigma[j])?;
        }
        Ok(Self::from_validated(theta, sigma, h))
    }

    /// The folding of [`NnUpdate::new`] without the checks (no allocation).
    fn from_validated(theta: SVector<f64, M>, sigma: SVector<f64, M>, h: f64) -> Self {
        let (mut decay, mut gain) = ([0.0; M], [0.0; M]);
        for j in 0..M {
            let x = theta[j] * sigma[j] * h;
            decay[j] = (-x).exp();
            // (1 − e^{−x})/σ without cancellation for small x.
            gain[j] = -(-x).exp_m1() / sigma[j];
        }
        Self {
            theta,
            sigma,
            h,
            decay,
            gain,
        }
    }

    /// Adaptation gains `Θ_j`.
    pub fn theta(&self) -> &SVector<f64, M> {
        &self.theta
    }

    /// Leakage `σ_j`.
    pub fn sigma(&self) -> &SVector<f64, M> {
        &self.sigma
    }

    /// Control period `h`, s.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// `e^{−Θ_j σ_j h}`.
    pub fn decay(&self) -> [f64; M] {
        self.decay
    }

    /// `(1 − e^{−Θ_j σ_j h})/σ_j` (→ `Θ_j h` as `σ_j → 0`).
    pub fn gain(&self) -> [f64; M] {
        self.gain
    }
}

/// Result of one fused tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NnTick<const M: usize> {
    /// `f̂_j = Ŵ_jᵀ S` (41) with the weights before the update.
    pub f_hat: SVector<f64, M>,
    /// `‖Ŵ_j‖` after the update.
    pub w_norm: SVector<f64, M>,
}

/// The adaptive RBF network: weights `Ŵ` (`N_s × M`, zero at start, SPEC §3.4) and the fused
/// output + update tick. `M` is the number of outputs (3 for the object scheme, 2 per arm),
/// `1 ≤ M ≤` [`MAX_OUTPUTS`].
#[derive(Debug, Clone, PartialEq)]
pub struct RbfNetwork<const M: usize> {
    n_nodes: usize,
    /// Node-major: `w[k·M + j]` is node `k`, output `j`; 64-byte aligned.
    w: Aligned,
    /// The weight-pass kernel (chosen once, at construction; see [`Kernel`]).
    kernel: Kernel,
    /// `(n_a, n_b, n_f)` of the grid basis the network was made for
    /// ([`RbfNetwork::for_basis`]): the head and tail lengths, and the number of factors.
    grid: Option<(usize, usize, usize)>,
    /// The held updates of [`Kernel::Batched`] and [`Kernel::BatchedF32`] (and the latter's
    /// `f32` store); `None` with the other kernels.
    batch: Option<batched::Held<M>>,
}

impl<const M: usize> RbfNetwork<M> {
    /// `N_s` nodes, all weights 0.
    pub fn new(n_nodes: usize) -> Result<Self, ModelError> {
        if n_nodes == 0 || n_nodes > MAX_NODES || M == 0 || M > MAX_OUTPUTS {
            return Err(ModelError::geometry(
                "rbf_network",
                format!(
                    "{n_nodes} nodes × {M} outputs: needs 1..={MAX_NODES} nodes and \
                     1..={MAX_OUTPUTS} outputs"
                ),
            ));
        }
        Ok(Self {
            n_nodes,
            w: Aligned::zeros(n_nodes * M),
            kernel: Kernel::from_env()?,
            grid: None,
            batch: None,
        })
    }

    /// The weight-pass kernel in use.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Use `kernel` from now on; an error (listing the kernels this CPU can run) if the CPU
    /// lacks it. The weights are kept.
    pub fn set_kernel(&mut self, kernel: Kernel) -> Result<(), ModelError> {
        kernel.check_available()?;
        self.flush();
        self.kernel = kernel;
        self.batch = match (kernel, self.grid) {
            (Kernel::Batched, Some((na, nb, nf))) => batched::Held::new(false, na, nb, nf),
            (Kernel::BatchedF32, Some((na, nb, nf))) => batched::Held::new(true, na, nb, nf),
            _ => None,
        };
        Ok(())
    }

    /// A zero network sized for `rbf`. On a grid basis with [`Kernel::Batched`] this also
    /// allocates the batch buffers (about `16 · (n_a + n_b(M + 1))` values; with
    /// [`Kernel::BatchedF32`] also the `f32` copy of the weights).
    pub fn for_basis(rbf: &Rbf) -> Result<Self, ModelError> {
        let mut net = Self::new(rbf.n_nodes())?;
        net.grid = rbf
            .grid_dims()
            .zip(rbf.grid_offsets())
            .map(|((na, nb), off)| (na, nb, off[off.len() - 1]));
        let kernel = net.kernel;
        net.set_kernel(kernel)?;
        Ok(net)
    }

    /// Updates held by [`Kernel::Batched`] or [`Kernel::BatchedF32`] and not yet applied to the
    /// stored weights (`0` with the other kernels). The accessors that read the weights ([`RbfNetwork::weights`],
    /// [`RbfNetwork::weight`], [`RbfNetwork::weights_matrix`], [`RbfNetwork::output`],
    /// [`RbfNetwork::norms`]) need the stored weights up to date ([`RbfNetwork::is_stale`]
    /// false, which also covers [`Kernel::BatchedF32`]'s `f32` store): call
    /// [`RbfNetwork::flush`] first.
    pub fn pending(&self) -> usize {
        self.batch.as_ref().map_or(0, batched::Held::pending)
    }

    /// Whether the stored `f64` weights are not `Ŵ` now: updates are pending, or
    /// ([`Kernel::BatchedF32`]) the weights live in the kernel's `f32` store. The accessors
    /// that read the weights need `false`: call [`RbfNetwork::flush`] first.
    pub fn is_stale(&self) -> bool {
        self.batch.as_ref().is_some_and(batched::Held::stale)
    }

    /// Apply the updates [`Kernel::Batched`] holds (or bring back the `f32` weights of
    /// [`Kernel::BatchedF32`]), so that the stored weights are `Ŵ` (a no-op with the other
    /// kernels, or when nothing is held). No allocation.
    pub fn flush(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if let Some(b) = &mut self.batch {
            // SAFETY: a batch exists only with `Kernel::Batched` or `Kernel::BatchedF32`, which
            // are stored only after `Kernel::check_available` found AVX-512F on this CPU.
            unsafe { b.flush(self.w.as_mut()) };
        }
    }

    /// Panics if the stored weights are stale (see [`RbfNetwork::is_stale`]).
    #[track_caller]
    fn assert_flushed(&self) {
        assert!(
            !self.is_stale(),
            "rbf_network: {} weight updates are pending (kernel `{}`); call flush() before \
             reading the weights",
            self.pending(),
            self.kernel
        );
    }

    /// Number of nodes `N_s`.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// `Ŵ`, node-major: `w[k·M + j]` is node `k`, output `j` (length `N_s·M`).
    ///
    /// # Panics
    /// If the stored weights are stale ([`RbfNetwork::is_stale`]; call [`RbfNetwork::flush`]
    /// first).
    #[track_caller]
    pub fn weights(&self) -> &[f64] {
        self.assert_flushed();
        self.w.as_ref()
    }

    /// `Ŵ` in the layout of [`RbfNetwork::weights`], whether or not updates are pending:
    /// borrowed when none are, else computed into a new buffer (allocates; the stored weights
    /// and the flush schedule are not changed, so inspecting a run does not perturb it).
    pub fn weights_now(&self) -> std::borrow::Cow<'_, [f64]> {
        match &self.batch {
            Some(b) if b.stale() => {
                let mut out = vec![0.0; self.w.as_ref().len()];
                b.materialize(self.w.as_ref(), &mut out);
                std::borrow::Cow::Owned(out)
            }
            _ => std::borrow::Cow::Borrowed(self.w.as_ref()),
        }
    }

    /// Mutable `Ŵ` in the layout of [`RbfNetwork::weights`] (e.g. to restore a checkpoint);
    /// applies pending updates first.
    pub fn weights_mut(&mut self) -> &mut [f64] {
        self.flush();
        self.w.as_mut()
    }

    /// Weight `Ŵ[k, j]` (node `k`, output `j`).
    ///
    /// # Panics
    /// If `k ≥ N_s` or `j ≥ M`, or if updates are pending.
    #[track_caller]
    pub fn weight(&self, k: usize, j: usize) -> f64 {
        assert!(k < self.n_nodes && j < M, "rbf_network: index");
        self.assert_flushed();
        self.w.as_ref()[k * M + j]
    }

    /// Load `Ŵ` from the layout of [`RbfNetwork::weights`].
    pub fn set_weights(&mut self, w: &[f64]) -> Result<(), ModelError> {
        if w.len() != self.w.as_ref().len() {
            return Err(ModelError::geometry(
                "rbf_network.weights",
                format!("length {} ≠ {} nodes × {M}", w.len(), self.n_nodes),
            ));
        }
        self.w.as_mut().copy_from_slice(w);
        if let Some(b) = &mut self.batch {
            b.clear();
        }
        Ok(())
    }

    /// `Ŵ` as an `N_s × M` matrix (allocates).
    ///
    /// # Panics
    /// If updates are pending.
    #[track_caller]
    pub fn weights_matrix(&self) -> DMatrix<f64> {
        self.assert_flushed();
        DMatrix::from_row_slice(self.n_nodes, M, self.w.as_ref())
    }

    /// All weights back to 0 (pending updates dropped).
    pub fn reset(&mut self) {
        self.w.as_mut().fill(0.0);
        if let Some(b) = &mut self.batch {
            b.clear();
        }
    }

    /// `f̂_j = Ŵ_jᵀ S` (41), without updating.
    ///
    /// # Panics
    /// If `s.len() != N_s`, or if updates are pending.
    #[track_caller]
    pub fn output(&self, s: &[f64]) -> SVector<f64, M> {
        assert_eq!(s.len(), self.n_nodes, "rbf_network: S length");
        self.assert_flushed();
        SVector::from(self.dispatch_read::<true, false>(s).0)
    }

    /// `‖Ŵ_j‖` per output.
    ///
    /// # Panics
    /// If updates are pending.
    #[track_caller]
    pub fn norms(&self) -> SVector<f64, M> {
        self.assert_flushed();
        SVector::from(self.dispatch_read::<false, true>(&[]).1.map(f64::sqrt))
    }

    /// The update (44) alone (exact discretisation, see the module docs); returns `‖Ŵ_j‖`
    /// after it.
    ///
    /// # Panics
    /// If `s.len() != N_s`.
    pub fn update(
        &mut self,
        s: &[f64],
        q: f64,
        z2: &SVector<f64, M>,
        upd: &NnUpdate<M>,
    ) -> SVector<f64, M> {
        assert_eq!(s.len(), self.n_nodes, "rbf_network: S length");
        self.flush();
        let c = coefficients(q, z2, upd);
        SVector::from(
            self.dispatch_tick::<false>(s, &upd.decay, &c)
                .1
                .map(f64::sqrt),
        )
    }

    /// Fused tick: `f̂_j = Ŵ_jᵀ S` with the weights before the update, then
    /// `Ŵ_j ← e^{−Θσh} Ŵ_j − ((1 − e^{−Θσh})/σ) Q S z_2j`, and `‖Ŵ_j‖` after it, in one pass
    /// over the weights. `(S, Q, z_2) → (f̂, ‖Ŵ‖)`, `Ŵ` updated in place; no allocation.
    ///
    /// # Panics
    /// If `s.len() != N_s`.
    #[inline]
    pub fn tick(
        &mut self,
        s: &[f64],
        q: f64,
        z2: &SVector<f64, M>,
        upd: &NnUpdate<M>,
    ) -> NnTick<M> {
        assert_eq!(s.len(), self.n_nodes, "rbf_network: S length");
        self.flush();
        let c = coefficients(q, z2, upd);
        let (acc, n2) = self.dispatch_tick::<true>(s, &upd.decay, &c);
        NnTick {
            f_hat: SVector::from(acc),
            w_norm: SVector::from(n2.map(f64::sqrt)),
        }
    }

    /// `S(Z)` (left in `ws.s()`) and the fused [`RbfNetwork::tick`], for the NN input `z`.
    ///
    /// On a grid basis with AVX2 the outer product `S = A ⊗ B` is formed block by block inside
    /// the weight pass instead of in a separate pass (same products, same bits as
    /// [`Rbf::eval_into`] followed by [`RbfNetwork::tick`]). No allocation.
    ///
    /// # Panics
    /// On size mismatches between `rbf`, `ws`, `z` and the network.
    #[inline]
    pub fn tick_at(
        &mut self,
        rbf: &Rbf,
        z: &[f64],
        ws: &mut RbfWorkspace,
        q: f64,
        z2: &SVector<f64, M>,
        upd: &NnUpdate<M>,
    ) -> NnTick<M> {
        let (acc, n2) = self.tick_at_impl::<true, true>(rbf, z, ws, q, z2, upd);
        NnTick {
            f_hat: SVector::from(acc),
            w_norm: SVector::from(n2.map(f64::sqrt)),
        }
    }

    /// As [`RbfNetwork::tick_at`] but returns only `f̂` (the norms are not accumulated: one
    /// multiply-add per weight less). A caller that needs `‖Ŵ_j‖` every tick can carry it by the
    /// exact recurrence `‖Ŵ'_j‖² = e_j²‖Ŵ_j‖² − 2 e_j c_j f̂_j + c_j²‖S‖²` (`e = decay`,
    /// `c_j = gain_j Q z2_j`, `‖S‖²` from [`RbfWorkspace::s_norm2`]) and refresh it now and then
    /// with [`RbfNetwork::norms`].
    ///
    /// Unlike [`RbfNetwork::tick_at`], `ws.s()` is **not** kept on the fused grid path (storing
    /// `S` is a quarter of the pass's memory traffic): only `ws.s_norm2()` is valid afterwards.
    /// No allocation.
    #[inline]
    pub fn tick_at_outputs(
        &mut self,
        rbf: &Rbf,
        z: &[f64],
        ws: &mut RbfWorkspace,
        q: f64,
        z2: &SVector<f64, M>,
        upd: &NnUpdate<M>,
    ) -> SVector<f64, M> {
        SVector::from(self.tick_at_impl::<false, false>(rbf, z, ws, q, z2, upd).0)
    }

    /// The body of [`RbfNetwork::tick_at`] and [`RbfNetwork::tick_at_outputs`]: `(f̂, ‖Ŵ‖²)`,
    /// the norms accumulated only if `NORM` (on the SIMD grid path; the fallback always has
    /// them), `S` stored into `ws` only if `STORE` (on the SIMD grid path; the fallback always
    /// stores it).
    #[inline]
    fn tick_at_impl<const NORM: bool, const STORE: bool>(
        &mut self,
        rbf: &Rbf,
        z: &[f64],
        ws: &mut RbfWorkspace,
        q: f64,
        z2: &SVector<f64, M>,
        upd: &NnUpdate<M>,
    ) -> ([f64; M], [f64; M]) {
        assert_eq!(rbf.n_nodes(), self.n_nodes, "rbf_network: basis size");
        let c = coefficients(q, z2, upd);
        // Grid: the factors, `A`, `B` and ‖S‖²; general centres: all of `S`.
        let wide = matches!(
            self.kernel,
            Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32
        );
        let grid = rbf.eval_factors_with(z, ws, wide);
        #[cfg(target_arch = "x86_64")]
        if grid
            && !NORM
            && !STORE
            && let Some(batch) = &mut self.batch
            && let Some(offsets) = rbf.grid_offsets()
            && batch.fits(ws.a.len(), ws.b.len(), ws.f.len())
        {
            // SAFETY: a batch exists only with `Kernel::Batched` or `Kernel::BatchedF32`,
            // stored only after `Kernel::check_available` found AVX-512F on this CPU.
            let f = unsafe {
                batch.tick(
                    self.w.as_mut(),
                    (&ws.a, &ws.b, &ws.f, offsets),
                    &upd.decay,
                    &c,
                )
            };
            return (f, [0.0; M]);
        }
        self.flush();
        #[cfg(target_arch = "x86_64")]
        if grid {
            let nb = ws.b.len();
            let (w, a, b, s, e) = (self.w.as_mut(), &ws.a, &ws.b, &mut ws.s, &upd.decay);
            // SAFETY: a kernel is stored only after `Kernel::check_available` found its
            // features on this CPU.
            unsafe {
                match self.kernel {
                    Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32
                        if nb.is_multiple_of(BLOCK512) =>
                    {
                        return avx512::tick_grid::<M, NORM, STORE>(w, a, b, s, e, &c);
                    }
                    Kernel::Avx2Fma if nb.is_multiple_of(BLOCK) => {
                        return avx2::tick_grid_fma::<M, NORM, STORE>(w, a, b, s, e, &c);
                    }
                    Kernel::Avx2 if nb.is_multiple_of(BLOCK) => {
                        return avx2::tick_grid::<M, NORM, STORE>(w, a, b, s, e, &c);
                    }
                    _ => {}
                }
            }
        }
        if grid {
            // S = A ⊗ B, then the separate pass (the same bits as the fused one).
            outer_into(&ws.a, &ws.b, &mut ws.s, rbf.avx2);
        }
        self.dispatch_tick::<true>(&ws.s, &upd.decay, &c)
    }

    #[inline]
    fn dispatch_tick<const OUT: bool>(
        &mut self,
        s: &[f64],
        e: &[f64; M],
        c: &[f64; M],
    ) -> ([f64; M], [f64; M]) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: a kernel is stored only after `Kernel::check_available` found its features.
        match self.kernel {
            Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32 => {
                return unsafe { avx512::tick::<M, OUT>(self.w.as_mut(), s, e, c) };
            }
            Kernel::Avx2 => return unsafe { avx2::tick::<M, OUT>(self.w.as_mut(), s, e, c) },
            Kernel::Avx2Fma => {
                return unsafe { avx2::tick_fma::<M, OUT>(self.w.as_mut(), s, e, c) };
            }
            Kernel::Portable => {}
        }
        kernel_tick::<M, OUT>(self.w.as_mut(), s, e, c)
    }

    #[inline]
    fn dispatch_read<const OUT: bool, const NORM: bool>(&self, s: &[f64]) -> ([f64; M], [f64; M]) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `dispatch_tick`.
        match self.kernel {
            Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32 => {
                return unsafe { avx512::read::<M, OUT, NORM>(self.w.as_ref(), s, self.n_nodes) };
            }
            Kernel::Avx2 => {
                return unsafe { avx2::read::<M, OUT, NORM>(self.w.as_ref(), s, self.n_nodes) };
            }
            Kernel::Avx2Fma => {
                return unsafe { avx2::read_fma::<M, OUT, NORM>(self.w.as_ref(), s, self.n_nodes) };
            }
            Kernel::Portable => {}
        }
        kernel_read::<M, OUT, NORM>(self.w.as_ref(), s, self.n_nodes)
    }
}

/// `c_j = gain_j · Q · z2_j`, the coefficient of `S` in the update.
#[inline]
fn coefficients<const M: usize>(q: f64, z2: &SVector<f64, M>, upd: &NnUpdate<M>) -> [f64; M] {
    std::array::from_fn(|j| upd.gain[j] * q * z2[j])
}

/// Whether the AVX2 kernels may run on this CPU.
fn detect_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Name of the environment variable that forces a weight-pass kernel.
pub const KERNEL_ENV: &str = "TANDEM_KERNEL";

/// The weight-pass kernel of [`RbfNetwork`], chosen once at set-up (never one the CPU lacks).
///
/// Determinism policy (`docs/performance.md`): the same binary on the same machine with the
/// same kernel gives bitwise-identical runs. [`Kernel::Portable`] and [`Kernel::Avx2`] use the
/// same IEEE operations in the same order and give the same bits (results pinned to bits are
/// pinned to them). [`Kernel::Avx2Fma`] fuses `acc + w·S`, `e·w − c·S` and `n2 + w²` into
/// single-rounding FMAs, and [`Kernel::Avx512`] also regroups the grid pass (`(c a_i)·b`,
/// `a_i Σ b w`): each weight update differs by at most a few ulps per tick. [`Kernel::Batched`]
/// applies the same exact update 16 ticks at a time (the decay as a running product, the
/// outputs of held terms through dot products of the factors). The AVX-512 kernels also
/// evaluate `S(Z)`'s exponentials with their own vector `exp` (within 1 ulp). The results agree
/// with the portable reference to a relative tolerance (tested: `1e-12` on the weights and
/// outputs after 1000 ticks of the paper network). [`Kernel::BatchedF32`] stores the weights in
/// single precision and has its own tolerance (tested: `2e-6`). The default is the fastest
/// double-precision kernel the CPU has ([`Kernel::default_for_cpu`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Plain Rust, any CPU; the reference.
    Portable,
    /// AVX2, no FMA: bit-identical to [`Kernel::Portable`]. The default where available.
    Avx2,
    /// AVX2 with FMA: faster, not bit-identical (within the stated tolerance).
    Avx2Fma,
    /// AVX-512F (512-bit registers, fused multiply-adds, blocks of 8 nodes): not
    /// bit-identical (within the stated tolerance).
    Avx512,
    /// AVX-512F with the update of [`RbfNetwork::tick_at_outputs`] held and applied
    /// [`BATCH_DEPTH`] ticks at a time (module `batched`: exact algebra, a read-only pass on
    /// most ticks): not bit-identical (within the stated tolerance). The default on Intel CPUs
    /// with AVX-512F ([`Kernel::default_for_cpu`]). Its other passes are those of
    /// [`Kernel::Avx512`].
    Batched,
    /// [`Kernel::Batched`] with the weights kept in **single precision** (`f32`) while the
    /// controller runs: half the bytes of every pass, `f32` arithmetic in the passes, `f64`
    /// for the decay, the terms' coefficients and the final sums. Not within the `f64`
    /// kernels' tolerance: its own, stated and tested (`docs/performance.md`). Opt-in.
    BatchedF32,
}

impl Kernel {
    /// Every kernel, in order of preference for bit-identity.
    pub const ALL: [Kernel; 6] = [
        Kernel::Portable,
        Kernel::Avx2,
        Kernel::Avx2Fma,
        Kernel::Avx512,
        Kernel::Batched,
        Kernel::BatchedF32,
    ];

    /// The name `TANDEM_KERNEL` accepts: `portable`, `avx2`, `avx2fma`, `avx512`, `batched`,
    /// `batched-f32`.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Portable => "portable",
            Kernel::Avx2 => "avx2",
            Kernel::Avx2Fma => "avx2fma",
            Kernel::Avx512 => "avx512",
            Kernel::Batched => "batched",
            Kernel::BatchedF32 => "batched-f32",
        }
    }

    /// Whether this CPU can run the kernel.
    pub fn is_available(self) -> bool {
        match self {
            Kernel::Portable => true,
            Kernel::Avx2 => detect_avx2(),
            Kernel::Avx2Fma => detect_avx2() && detect_fma(),
            Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32 => detect_avx512f(),
        }
    }

    /// Whether the kernel gives the same bits as [`Kernel::Portable`].
    pub fn is_bit_identical_to_portable(self) -> bool {
        !matches!(
            self,
            Kernel::Avx2Fma | Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32
        )
    }

    /// The default: the fastest double-precision kernel the CPU has. With AVX-512F that is
    /// `batched` on Intel's cores, where a read-only pass over the weights takes about a third
    /// of a read-modify-write pass, and `avx512` on AMD's, where both take the same time and
    /// the batched flush's arithmetic does not pay (measured: `docs/performance.md`). Else AVX2
    /// (bit-identical to the reference), else portable. The vendor is read from `cpuid`, so
    /// the choice is fixed for a machine. [`Kernel::BatchedF32`] is never the default: it
    /// changes the precision of the stored weights.
    pub fn default_for_cpu() -> Kernel {
        if Kernel::Batched.is_available() {
            if detect_amd() {
                Kernel::Avx512
            } else {
                Kernel::Batched
            }
        } else if Kernel::Avx2.is_available() {
            Kernel::Avx2
        } else {
            Kernel::Portable
        }
    }

    /// `Ok` if the CPU can run the kernel, else an error naming [`KERNEL_ENV`] and listing the
    /// kernels it can run.
    pub fn check_available(self) -> Result<Kernel, ModelError> {
        if self.is_available() {
            Ok(self)
        } else {
            Err(ModelError::geometry(
                KERNEL_ENV,
                format!(
                    "kernel `{}` needs CPU features this machine lacks; available: {}",
                    self.name(),
                    Self::available_list()
                ),
            ))
        }
    }

    /// A kernel by name; an unknown name, or one this CPU cannot run, is an error that names
    /// [`KERNEL_ENV`] and lists the valid (available) names.
    pub fn parse(name: &str) -> Result<Kernel, ModelError> {
        let name = name.trim();
        match Self::ALL.into_iter().find(|k| k.name() == name) {
            Some(k) => k.check_available(),
            None => Err(ModelError::geometry(
                KERNEL_ENV,
                format!(
                    "unknown kernel `{name}`; valid: {} (available on this CPU: {})",
                    Self::ALL.map(Kernel::name).join(", "),
                    Self::available_list()
                ),
            )),
        }
    }

    /// The kernel `TANDEM_KERNEL` forces, or [`Kernel::default_for_cpu`] if it is unset or empty.
    pub fn from_env() -> Result<Kernel, ModelError> {
        match std::env::var(KERNEL_ENV) {
            Ok(v) if !v.trim().is_empty() => Self::parse(&v),
            _ => Ok(Self::default_for_cpu()),
        }
    }

    fn available_list() -> String {
        Self::ALL
            .into_iter()
            .filter(|k| k.is_available())
            .map(Kernel::name)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Whether the AVX-512 kernels may run on this CPU (AVX-512F; its FMAs are part of it).
fn detect_avx512f() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether `cpuid` names AMD as the vendor.
fn detect_amd() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `cpuid` leaf 0 exists on every x86_64 CPU (the vendor string).
        #[allow(unused_unsafe)]
        let r = unsafe { std::arch::x86_64::__cpuid(0) };
        let mut v = [0u8; 12];
        v[..4].copy_from_slice(&r.ebx.to_le_bytes());
        v[4..8].copy_from_slice(&r.edx.to_le_bytes());
        v[8..].copy_from_slice(&r.ecx.to_le_bytes());
        &v == b"AuthenticAMD"
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the CPU has FMA.
fn detect_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

// ---- kernels ------------------------------------------------------------------------------
//
// A block is BLOCK = 4 consecutive nodes, i.e. 4·M consecutive weights (node-major). Lane
// i ∈ [0, 4M) of a block is weight i: node i / M, output i % M. Every sum runs per lane and is
// reduced per output in the fixed order of `reduce`, so all kernels (fused, output-only,
// update-only; portable and AVX2, where lane 4r + t is lane t of register r) produce the same
// bits.

/// Nodes per block (one AVX2 register of `S`).
const BLOCK: usize = 4;
/// Lanes of the largest block.
const MAX_LANES: usize = BLOCK * MAX_OUTPUTS;

/// Per-output sums of the lanes: `(v[j] + v[2M + j]) + (v[M + j] + v[3M + j])`.
#[inline(always)]
fn reduce<const M: usize>(v: &[f64; MAX_LANES]) -> [f64; M] {
    // Plain loops here and below: the kernels that inline these are `target_feature`
    // functions, where `array::from_fn`'s closure is called, not inlined.
    let mut out = [0.0; M];
    for (j, o) in out.iter_mut().enumerate() {
        *o = (v[j] + v[2 * M + j]) + (v[M + j] + v[3 * M + j]);
    }
    out
}

/// Nodes per block of the AVX-512 kernel (one register of `S`).
#[cfg(target_arch = "x86_64")]
const BLOCK512: usize = 8;

/// Per-output sums of the 8 node lanes of an AVX-512 block (lane `t·M + j` is node `t`,
/// output `j`), in the fixed order `((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7))`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn reduce512<const M: usize>(v: &[f64; BLOCK512 * MAX_OUTPUTS]) -> [f64; M] {
    let mut out = [0.0; M];
    for (j, o) in out.iter_mut().enumerate() {
        let l = |t: usize| v[t * M + j];
        *o = ((l(0) + l(4)) + (l(2) + l(6))) + ((l(1) + l(5)) + (l(3) + l(7)));
    }
    out
}

/// `S` of the last, partial block, zero-padded (the padding lanes then add exact zeros).
#[inline(always)]
fn s_tail(s: &[f64]) -> [f64; BLOCK] {
    let lo = s.len() / BLOCK * BLOCK;
    let mut out = [0.0; BLOCK];
    out[..s.len() - lo].copy_from_slice(&s[lo..]);
    out
}

/// `e_j`, `c_j` spread over the lanes of a block.
#[inline(always)]
fn lane_pattern<const M: usize>(v: &[f64; M]) -> [f64; MAX_LANES] {
    let mut out = [0.0; MAX_LANES];
    for (i, o) in out[..BLOCK * M].iter_mut().enumerate() {
        *o = v[i % M];
    }
    out
}

/// One block of the fused pass: per lane `acc += old·S`, `w = e·old − c·S`, `n2 += w·w`
/// (plain IEEE operations in this order, no FMA).
#[inline(always)]
fn tick_block<const M: usize, const OUT: bool>(
    wb: &mut [f64],
    sb: &[f64; BLOCK],
    ep: &[f64; MAX_LANES],
    cp: &[f64; MAX_LANES],
    acc: &mut [f64; MAX_LANES],
    n2: &mut [f64; MAX_LANES],
) {
    for (i, w) in wb.iter_mut().enumerate().take(BLOCK * M) {
        let s = sb[i / M];
        let old = *w;
        if OUT {
            acc[i] += old * s;
        }
        let new = ep[i] * old - cp[i] * s;
        *w = new;
        n2[i] += new * new;
    }
}

/// Portable fused pass: `acc_j = Σ w S` (if `OUT`), `w ← e_j w − c_j S`, `n2_j = Σ w²`.
fn kernel_tick<const M: usize, const OUT: bool>(
    w: &mut [f64],
    s: &[f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    let (ep, cp) = (lane_pattern(e), lane_pattern(c));
    let mut acc = [0.0; MAX_LANES];
    let mut n2 = [0.0; MAX_LANES];
    let full = s.len() / BLOCK;
    let (w_full, w_tail) = w.split_at_mut(full * BLOCK * M);
    for (wb, sb) in w_full
        .chunks_exact_mut(BLOCK * M)
        .zip(s.chunks_exact(BLOCK))
    {
        let sb: &[f64; BLOCK] = sb.try_into().expect("BLOCK lanes");
        tick_block::<M, OUT>(wb, sb, &ep, &cp, &mut acc, &mut n2);
    }
    if !w_tail.is_empty() {
        // Partial block through a zero-padded copy: padding lanes stay exactly 0.
        let mut tmp = [0.0; MAX_LANES];
        tmp[..w_tail.len()].copy_from_slice(w_tail);
        tick_block::<M, OUT>(&mut tmp, &s_tail(s), &ep, &cp, &mut acc, &mut n2);
        w_tail.copy_from_slice(&tmp[..w_tail.len()]);
    }
    (reduce(&acc), reduce(&n2))
}

/// One read-only block: `acc += w·S` (if `OUT`), `n2 += w·w` (if `NORM`).
#[inline(always)]
fn read_block<const M: usize, const OUT: bool, const NORM: bool>(
    wb: &[f64],
    sb: &[f64; BLOCK],
    acc: &mut [f64; MAX_LANES],
    n2: &mut [f64; MAX_LANES],
) {
    for (i, &x) in wb.iter().enumerate().take(BLOCK * M) {
        if OUT {
            acc[i] += x * sb[i / M];
        }
        if NORM {
            n2[i] += x * x;
        }
    }
}

/// Portable read-only pass: `acc_j = Σ w S` (if `OUT`), `n2_j = Σ w²` (if `NORM`).
fn kernel_read<const M: usize, const OUT: bool, const NORM: bool>(
    w: &[f64],
    s: &[f64],
    n_nodes: usize,
) -> ([f64; M], [f64; M]) {
    let mut acc = [0.0; MAX_LANES];
    let mut n2 = [0.0; MAX_LANES];
    let full = n_nodes / BLOCK;
    let (w_full, w_tail) = w.split_at(full * BLOCK * M);
    let zeros = [0.0; BLOCK];
    for (b, wb) in w_full.chunks_exact(BLOCK * M).enumerate() {
        let sb: [f64; BLOCK] = if OUT {
            s[b * BLOCK..(b + 1) * BLOCK]
                .try_into()
                .expect("BLOCK lanes")
        } else {
            zeros
        };
        read_block::<M, OUT, NORM>(wb, &sb, &mut acc, &mut n2);
    }
    if !w_tail.is_empty() {
        let mut tmp = [0.0; MAX_LANES];
        tmp[..w_tail.len()].copy_from_slice(w_tail);
        let sb = if OUT { s_tail(s) } else { zeros };
        read_block::<M, OUT, NORM>(&tmp, &sb, &mut acc, &mut n2);
    }
    (reduce(&acc), reduce(&n2))
}

/// AVX2 builds of the kernels: the same operations in the same order as the portable ones,
/// so the same bits. Register `r` of a block holds lanes `4r..4r+4`; the `S` value of each lane
/// (node `i / M`) is put in place by one `vpermd` with a precomputed index.
///
/// Written to build on the first MSRV (1.85; now 1.89): the entry points are `unsafe fn` with
/// `#[target_feature]`, and the bodies are `#[inline(always)]` helpers without features (so
/// every intrinsic call is `unsafe` on every toolchain) that inline into them. No closures:
/// they would not inherit the target feature on 1.85.
#[cfg(target_arch = "x86_64")]
mod avx2 {
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
    pub(super) unsafe fn tick<const M: usize, const OUT: bool>(
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
    pub(super) unsafe fn tick_fma<const M: usize, const OUT: bool>(
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
    pub(super) unsafe fn tick_grid<const M: usize, const NORM: bool, const STORE: bool>(
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
    pub(super) unsafe fn tick_grid_fma<const M: usize, const NORM: bool, const STORE: bool>(
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
    unsafe fn tick_grid_body<
        const M: usize,
        const NORM: bool,
        const STORE: bool,
        const FMA: bool,
    >(
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
    pub(super) unsafe fn read<const M: usize, const OUT: bool, const NORM: bool>(
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
    pub(super) unsafe fn read_fma<const M: usize, const OUT: bool, const NORM: bool>(
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
}

/// AVX-512 builds of the kernels ([`Kernel::Avx512`], AVX-512F with its fused multiply-adds).
/// Blocks of [`BLOCK512`] = 8 nodes (`8M` weights, `M` registers); lane `i` of a block is node
/// `i / M`, output `i % M`, and the `S` value of each lane is put in place by one `vpermpd`.
/// Two sets of accumulators (even and odd blocks) halve the FMA latency chain; every sum is
/// reduced in the fixed order of [`reduce512`], so the kernel is deterministic, but its lane
/// order and its FMAs differ from [`Kernel::Portable`] (agreement within the tolerance of the
/// determinism policy, not bits).
///
/// The AVX-512 intrinsics and the `avx512f` target feature are stable since Rust 1.89 (the
/// workspace MSRV).
#[cfg(target_arch = "x86_64")]
mod avx512 {
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
    pub(super) unsafe fn load(x: &[f64]) -> __m512d {
        assert!(x.len() >= B);
        // SAFETY: bounds checked above (unaligned load); AVX-512F (caller's contract).
        unsafe { _mm512_loadu_pd(x.as_ptr()) }
    }

    /// Store 8 lanes.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline(always)]
    pub(super) unsafe fn store(x: &mut [f64], v: __m512d) {
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
    pub(super) unsafe fn tick<const M: usize, const OUT: bool>(
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
    pub(super) unsafe fn tick_grid<const M: usize, const NORM: bool, const STORE: bool>(
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
    pub(super) unsafe fn read<const M: usize, const OUT: bool, const NORM: bool>(
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, Vector3};
    use proptest::prelude::*;

    use crate::math::random::SplitMix64 as Rng;

    fn uneven() -> Rbf {
        Rbf::grid(
            &[
                vec![-0.5, 0.7],
                vec![-1.0, 0.0, 2.0],
                vec![-2.0, -1.0, 0.0, 1.0, 2.5],
            ],
            0.8,
        )
        .unwrap()
    }

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn kronecker_equals_the_naive_sum_on_the_paper_grid() {
        let rbf = Rbf::paper();
        assert_eq!((rbf.n_inputs(), rbf.n_nodes()), (12, 4096));
        let general = rbf.to_general();
        let mut ws = rbf.workspace();
        let mut naive = vec![0.0; 4096];
        let mut rng = Rng(7);
        let mut worst = 0.0f64;
        for _ in 0..20 {
            let z: Vec<f64> = (0..12).map(|_| rng.range(-3.0, 3.0)).collect();
            rbf.eval_into(&z, &mut ws);
            general.eval_naive_into(&z, &mut naive);
            worst = worst.max(max_abs_diff(ws.s(), &naive));
            // The general form through eval_into is the naive sum too, in the same order.
            assert_eq!(general.eval(&z).as_slice(), &naive[..]);
            let n2: f64 = naive.iter().map(|v| v * v).sum();
            assert!((ws.s_norm2() - n2).abs() <= 1e-12 * n2);
        }
        eprintln!("paper grid: max |S_kron − S_naive| = {worst:.2e}");
        assert!(worst <= 1e-12);
    }

    #[test]
    fn kronecker_equals_the_naive_sum_on_an_uneven_grid() {
        let rbf = uneven();
        assert_eq!(rbf.n_nodes(), 30);
        let mut ws = rbf.workspace();
        let mut naive = vec![0.0; 30];
        let mut rng = Rng(11);
        for _ in 0..50 {
            let z: Vec<f64> = (0..3).map(|_| rng.range(-3.0, 3.0)).collect();
            rbf.eval_into(&z, &mut ws);
            rbf.eval_naive_into(&z, &mut naive);
            assert!(max_abs_diff(ws.s(), &naive) <= 1e-12);
            rbf.to_general().eval_naive_into(&z, &mut naive);
            assert!(max_abs_diff(ws.s(), &naive) <= 1e-12);
        }
    }

    #[test]
    fn node_order_is_row_major_last_input_fastest() {
        let rbf = uneven();
        let mut mu = [0.0; 3];
        // k = (l0·3 + l1)·5 + l2.
        for (k, want) in [
            (0, [-0.5, -1.0, -2.0]),
            (1, [-0.5, -1.0, -1.0]),
            (5, [-0.5, 0.0, -2.0]),
            (15, [0.7, -1.0, -2.0]),
            (29, [0.7, 2.0, 2.5]),
        ] {
            rbf.centre_into(k, &mut mu);
            assert_eq!(mu, want, "node {k}");
        }
        let p = Rbf::paper();
        let mut mu = [0.0; 12];
        p.centre_into(1, &mut mu);
        assert_eq!(mu[11], 1.0);
        assert!(mu[..11].iter().all(|&c| c == -1.0));
        p.centre_into(2048, &mut mu);
        assert_eq!(mu[0], 1.0);
        assert!(mu[1..].iter().all(|&c| c == -1.0));
    }

    #[test]
    fn paper_basis_near_zero_is_nearly_constant() {
        // SPEC §3.4: with ϑ² = 50 and centres at ±1 every basis is about 0.79 and ‖S‖² ≈ 2535.
        let rbf = Rbf::paper();
        let mut ws = rbf.workspace();
        rbf.eval_into(&[0.0; 12], &mut ws);
        let each = (-12.0f64 / 50.0).exp();
        let norm2 = 4096.0 * (-24.0f64 / 50.0).exp();
        eprintln!("Z = 0: every s_k = {each:.6}, ‖S‖² = {norm2:.3}");
        assert!(ws.s().iter().all(|&v| (v - each).abs() <= 1e-15));
        assert!((ws.s_norm2() - norm2).abs() <= 1e-12 * norm2);
        assert!((norm2 - 2534.6).abs() < 0.1);
        // Near the start of the paper run (x1 ≈ (0.19, 0, 0)), the basis still barely varies.
        let mut z = [0.0; 12];
        z[0] = 0.19;
        rbf.eval_into(&z, &mut ws);
        let (lo, hi) = ws
            .s()
            .iter()
            .fold((f64::MAX, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        eprintln!(
            "Z = (0.19, 0, …): s_k in [{lo:.4}, {hi:.4}], ‖S‖² = {:.1}",
            ws.s_norm2()
        );
        assert!(lo > 0.77 && hi < 0.81);
    }

    /// The reference network: plain N_s × M matrices and the textbook loops.
    fn reference_tick(
        w: &mut DMatrix<f64>,
        s: &[f64],
        q: f64,
        z2: &[f64],
        upd: &NnUpdate<3>,
    ) -> ([f64; 3], [f64; 3]) {
        let mut f = [0.0; 3];
        for j in 0..3 {
            f[j] = (0..s.len()).map(|k| w[(k, j)] * s[k]).sum();
        }
        let (e, g) = (upd.decay(), upd.gain());
        for j in 0..3 {
            for k in 0..s.len() {
                w[(k, j)] = e[j] * w[(k, j)] - g[j] * q * s[k] * z2[j];
            }
        }
        let n = std::array::from_fn(|j| w.column(j).norm());
        (f, n)
    }

    fn random_network(n: usize, rng: &mut Rng) -> RbfNetwork<3> {
        let mut net = RbfNetwork::<3>::new(n).unwrap();
        for w in net.weights_mut() {
            *w = rng.range(-2.0, 2.0);
        }
        net
    }

    fn paper_update() -> NnUpdate<3> {
        NnUpdate::new(
            Vector3::new(120.0, 150.0, 120.0),
            Vector3::repeat(0.001),
            1e-3,
        )
        .unwrap()
    }

    #[test]
    fn fused_tick_equals_output_then_update() {
        let upd = paper_update();
        let mut rng = Rng(3);
        for rbf in [Rbf::paper(), uneven()] {
            let n = rbf.n_nodes();
            let mut ws = rbf.workspace();
            let mut fused = random_network(n, &mut rng);
            let mut sep = fused.clone();
            let mut grid_path = fused.clone();
            let mut reference = fused.weights_matrix();
            for step in 0..20 {
                let z: Vec<f64> = (0..rbf.n_inputs()).map(|_| rng.range(-2.0, 2.0)).collect();
                let q = if step % 3 == 0 { 1.0 } else { rng.next_f64() };
                let z2 = Vector3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.1);
                // tick_at: the grid fast path where it applies.
                let t_grid = grid_path.tick_at(&rbf, &z, &mut ws, q, &z2, &upd);
                let s = ws.s().to_vec();
                let t = fused.tick(&s, q, &z2, &upd);
                let f = sep.output(&s);
                let norms = sep.update(&s, q, &z2, &upd);
                // Same lanes, same order: bitwise equal.
                assert_eq!(t.f_hat, f);
                assert_eq!(t.w_norm, norms);
                assert_eq!(sep.norms(), norms);
                assert_eq!(fused, sep);
                if grid_path.kernel.is_bit_identical_to_portable() {
                    assert_eq!(t, t_grid);
                    assert_eq!(fused.w.as_ref(), grid_path.w.as_ref());
                } else {
                    // The AVX-512 grid pass applies `a_i` once per row and updates with
                    // `(c a_i) b`: other roundings (≤ ½ ulp each) than `c (a_i b)`, so within
                    // a few ulps of the weights (O(1) here) and of the outputs.
                    for j in 0..3 {
                        let scale = 1.0 + t.f_hat[j].abs();
                        assert!((t.f_hat[j] - t_grid.f_hat[j]).abs() <= 1e-12 * scale);
                        assert!((t.w_norm[j] - t_grid.w_norm[j]).abs() <= 1e-12 * scale);
                    }
                    let dw = fused.w.as_ref().iter().zip(grid_path.w.as_ref());
                    assert!(dw.fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) <= 1e-13);
                }
                // Against the textbook loops (different summation order).
                let (fr, nr) = reference_tick(&mut reference, &s, q, z2.as_slice(), &upd);
                for j in 0..3 {
                    assert!((t.f_hat[j] - fr[j]).abs() <= 1e-10 * (1.0 + fr[j].abs()));
                    assert!((t.w_norm[j] - nr[j]).abs() <= 1e-12 * nr[j]);
                }
                let diff = fused.weights_matrix() - &reference;
                assert!(diff.amax() <= 1e-13);
            }
        }
    }

    /// Fused vs separate (bitwise, within each kernel), every kernel vs portable (bitwise for
    /// the bit-identical ones, else within `1e-14` relative: a handful of ticks of FMA rounding
    /// differences, each ≤ ½ ulp ≈ 1.1e-16 of the largest term), for other output counts and
    /// partial last blocks (of 4 and of 8 nodes).
    fn check_m<const M: usize>(n: usize, seed: u64) {
        for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
            check_m_kernel::<M>(n, seed, kernel);
        }
    }

    fn check_m_kernel<const M: usize>(n: usize, seed: u64, kernel: Kernel) {
        let mut rng = Rng(seed);
        let upd = NnUpdate::<M>::new(
            SVector::from_fn(|j, _| 1.0 + j as f64),
            SVector::repeat(0.5),
            1e-2,
        )
        .unwrap();
        let mut a = RbfNetwork::<M>::new(n).unwrap();
        a.set_kernel(kernel).unwrap();
        for w in a.weights_mut() {
            *w = rng.range(-1.0, 1.0);
        }
        let mut b = a.clone();
        b.kernel = Kernel::Portable;
        let mut c = a.clone();
        let mut reference = a.weights_matrix();
        for _ in 0..5 {
            let s: Vec<f64> = (0..n).map(|_| rng.next_f64()).collect();
            let z2 = SVector::<f64, M>::from_fn(|_, _| rng.range(-1.0, 1.0));
            let ta = a.tick(&s, 0.9, &z2, &upd);
            let tb = b.tick(&s, 0.9, &z2, &upd);
            let f = c.output(&s);
            let nc = c.update(&s, 0.9, &z2, &upd);
            assert_eq!(ta.f_hat, f, "{kernel}");
            assert_eq!(ta.w_norm, nc, "{kernel}");
            assert_eq!(a.weights(), c.weights(), "{kernel}");
            assert_eq!(c.norms(), nc, "{kernel}");
            if kernel.is_bit_identical_to_portable() {
                assert_eq!(ta, tb, "{kernel}");
                assert_eq!(a.weights(), b.weights(), "{kernel}");
            } else {
                let scale = 1.0 + tb.f_hat.abs().max() + tb.w_norm.abs().max();
                assert!((ta.f_hat - tb.f_hat).amax() <= 1e-14 * scale, "{kernel}");
                assert!((ta.w_norm - tb.w_norm).amax() <= 1e-14 * scale, "{kernel}");
                let dw = a.weights().iter().zip(b.weights());
                assert!(
                    dw.fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) <= 1e-14,
                    "{kernel}"
                );
            }
            let (e, g) = (upd.decay(), upd.gain());
            for j in 0..M {
                let fr: f64 = (0..n).map(|k| reference[(k, j)] * s[k]).sum();
                assert!((ta.f_hat[j] - fr).abs() <= 1e-12 * (1.0 + fr.abs()));
                for k in 0..n {
                    reference[(k, j)] = e[j] * reference[(k, j)] - g[j] * 0.9 * s[k] * z2[j];
                }
            }
            assert!((a.weights_matrix() - &reference).amax() <= 1e-14);
        }
    }

    #[test]
    fn other_output_counts_and_partial_blocks() {
        check_m::<1>(13, 1);
        check_m::<2>(30, 2);
        check_m::<3>(7, 3);
        check_m::<4>(9, 4);
        check_m::<5>(6, 5);
        check_m::<8>(21, 6);
        check_m::<2>(4096, 7);
        // Blocks of 8 and pairs of them (the AVX-512 kernel): 8, 16 + 1, 16 + 8 + 3.
        check_m::<3>(8, 8);
        check_m::<3>(17, 9);
        check_m::<4>(27, 10);
        check_m::<1>(1, 11);
    }

    #[test]
    fn portable_and_avx2_kernels_agree_bitwise() {
        let rbf = Rbf::paper();
        let mut ws = rbf.workspace();
        let mut rng = Rng(5);
        let upd = paper_update();
        let mut a = random_network(rbf.n_nodes(), &mut rng);
        if a.set_kernel(Kernel::Avx2).is_err() {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        }
        let mut b = a.clone();
        b.kernel = Kernel::Portable;
        let mut rbf_portable = rbf.clone();
        rbf_portable.avx2 = false;
        let mut ws_b = rbf_portable.workspace();
        for _ in 0..5 {
            let z: Vec<f64> = (0..12).map(|_| rng.range(-2.0, 2.0)).collect();
            let z2 = Vector3::new(0.3, -0.2, 0.01);
            let ta = a.tick_at(&rbf, &z, &mut ws, 0.7, &z2, &upd);
            let tb = b.tick_at(&rbf_portable, &z, &mut ws_b, 0.7, &z2, &upd);
            assert_eq!(ta, tb);
            assert_eq!(ws.s(), ws_b.s());
            assert_eq!(a.w.as_ref(), b.w.as_ref());
            assert_eq!(a.output(ws.s()), b.output(ws.s()));
            assert_eq!(a.norms(), b.norms());
        }
    }

    /// Determinism policy: every kernel this CPU can run against the portable reference on
    /// the paper network, 1000 ticks of the fused grid path. Bit-identical kernels must agree
    /// bitwise; FMA kernels within a relative `1e-12` (each FMA saves one rounding of at most
    /// ½ ulp ≈ 1.1e-16 per operation; the decay `e < 1` damps old differences, so they stay
    /// near a few ulps of the largest weight, far below `1e-12`).
    #[test]
    fn every_available_kernel_agrees_with_the_portable_reference() {
        let rbf = Rbf::paper();
        let upd = paper_update();
        for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
            let mut rng = Rng(21);
            let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
            net.set_kernel(kernel).unwrap();
            let mut reference = net.clone();
            reference.set_kernel(Kernel::Portable).unwrap();
            let (mut ws, mut ws_r) = (rbf.workspace(), rbf.workspace());
            let (mut worst_w, mut worst_f) = (0.0f64, 0.0f64);
            for _ in 0..1000 {
                let z: Vec<f64> = (0..12).map(|_| rng.range(-1.5, 1.5)).collect();
                let z2 = Vector3::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), 0.01);
                let t = net.tick_at(&rbf, &z, &mut ws, 0.9, &z2, &upd);
                let tr = reference.tick_at(&rbf, &z, &mut ws_r, 0.9, &z2, &upd);
                if kernel.is_bit_identical_to_portable() {
                    assert_eq!(t, tr, "{kernel}");
                }
                for j in 0..3 {
                    let scale = tr.f_hat.abs().max() + 1e-300;
                    worst_f = worst_f.max((t.f_hat[j] - tr.f_hat[j]).abs() / scale);
                }
            }
            let wmax = reference
                .weights()
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in net.weights().iter().zip(reference.weights()) {
                worst_w = worst_w.max((a - b).abs() / wmax);
            }
            eprintln!("{kernel}: max rel. diff weights {worst_w:.2e}, outputs {worst_f:.2e}");
            if kernel.is_bit_identical_to_portable() {
                assert_eq!(net.weights(), reference.weights(), "{kernel}");
            }
            assert!(worst_w <= 1e-12 && worst_f <= 1e-12, "{kernel}");
        }
    }

    /// The `batched` kernel (updates held `BATCH_DEPTH` ticks, module `batched`) against the
    /// portable fused pass over 1000 controller ticks (`tick_at_outputs`: 62 flushes fused with
    /// an output pass), from random weights, with `Q`, `z2` and the inputs changing every
    /// tick, for 3 outputs on the paper grid and 1, 2 and 8 outputs on a 2 × 4 × 8 grid. Outputs
    /// every tick and the weights (held updates included, `weights_now`) every 7th tick agree
    /// within the policy's relative `1e-12`: the algebra is exact, only the rounding differs
    /// (products regrouped as `(g a_i)·b`, `(A_m·A)(B_m·B)`; the decay as a running product of
    /// factors), a few ulps of the largest weight; the decay keeps old differences from growing.
    #[test]
    fn batched_kernel_agrees_with_the_portable_reference() {
        if !Kernel::Batched.is_available() {
            eprintln!("skipped: no AVX-512F on this CPU");
            return;
        }
        let k = Kernel::Batched;
        check_batched::<3>(&Rbf::paper(), 1000, 41, k, 1e-12);
        let small = Rbf::grid(
            &[vec![-1.0, 1.0], vec![-1.0, 0.0, 0.5, 1.0], vec![0.1; 8]],
            3.0,
        )
        .unwrap();
        check_batched::<1>(&small, 300, 42, k, 1e-12);
        check_batched::<2>(&small, 300, 43, k, 1e-12);
        check_batched::<8>(&small, 300, 44, k, 1e-12);
    }

    /// The single-precision store ([`Kernel::BatchedF32`]) against the portable reference:
    /// its own tolerance, a relative `2e-6` on the outputs (relative to `Σ_k |Ŵ_kj| S_k`, the
    /// scale of their rounding errors) and on the weights (relative to the largest), over up
    /// to 1000 ticks. An `f32` rounding is `6e-8` relative; the passes sum 64-term columns
    /// and 16 terms in `f32`, and a flush adds one rounding of each weight every 16 ticks.
    #[test]
    fn batched_f32_kernel_agrees_with_the_portable_reference_in_single_precision() {
        if !Kernel::BatchedF32.is_available() {
            eprintln!("skipped: no AVX-512F on this CPU");
            return;
        }
        let k = Kernel::BatchedF32;
        check_batched::<3>(&Rbf::paper(), 1000, 51, k, 2e-6);
        // Tail of 16 (the `f32` passes' register): 2 × 4 head, 16 tail levels.
        let small = Rbf::grid(
            &[
                vec![-1.0, 1.0],
                vec![-1.0, 0.0, 0.5, 1.0],
                (0..16).map(|l| -1.0 + 0.125 * l as f64).collect(),
            ],
            3.0,
        )
        .unwrap();
        assert_eq!(small.grid_dims(), Some((8, 16)));
        check_batched::<1>(&small, 300, 52, k, 2e-6);
        check_batched::<2>(&small, 300, 53, k, 2e-6);
        check_batched::<8>(&small, 300, 54, k, 2e-6);
    }

    fn check_batched<const M: usize>(rbf: &Rbf, ticks: usize, seed: u64, kernel: Kernel, tol: f64) {
        let mut rng = Rng(seed);
        let n_in = rbf.n_inputs();
        let upd = NnUpdate::<M>::new(
            SVector::from_fn(|j, _| 100.0 + 10.0 * j as f64),
            SVector::from_fn(|j, _| 0.001 * (1 + j) as f64),
            1e-3,
        )
        .unwrap();
        let mut net = RbfNetwork::<M>::for_basis(rbf).unwrap();
        net.set_kernel(kernel).unwrap();
        let w0: Vec<f64> = (0..rbf.n_nodes() * M)
            .map(|_| rng.range(-2.0, 2.0))
            .collect();
        net.set_weights(&w0).unwrap();
        let mut reference = net.clone();
        reference.set_kernel(Kernel::Portable).unwrap();
        let (mut ws, mut ws_r) = (rbf.workspace(), rbf.workspace());
        let (mut worst_f, mut worst_w, mut max_pending) = (0.0f64, 0.0f64, 0);
        for k in 0..ticks {
            let z: Vec<f64> = (0..n_in).map(|_| rng.range(-1.5, 1.5)).collect();
            let q = if k % 5 == 0 { 1.0 } else { rng.next_f64() };
            let z2 = SVector::<f64, M>::from_fn(|_, _| rng.range(-0.1, 0.1));
            // Single precision is held to the scale its rounding errors have: `Σ_k |Ŵ_kj| S_k`
            // (an output may cancel to far below it); double precision to `|f̂|` itself.
            let scale = if kernel == Kernel::BatchedF32 {
                let s = rbf.eval(&z);
                let w = reference.weights();
                (0..M)
                    .map(|j| (0..s.len()).map(|k| w[k * M + j].abs() * s[k]).sum::<f64>())
                    .fold(0.0, f64::max)
            } else {
                0.0
            };
            let f = net.tick_at_outputs(rbf, &z, &mut ws, q, &z2, &upd);
            let fr = reference.tick_at_outputs(rbf, &z, &mut ws_r, q, &z2, &upd);
            // The AVX-512 kernels' vector `exp` (module `factors`) is within 2 ulps.
            assert!((ws.s_norm2() - ws_r.s_norm2()).abs() <= 1e-14 * ws_r.s_norm2());
            let scale = scale.max(fr.abs().max()) + 1e-300;
            worst_f = worst_f.max((f - fr).abs().max() / scale);
            assert_eq!(net.pending(), k % BATCH_DEPTH + 1, "tick {k}");
            max_pending = max_pending.max(net.pending());
            if k % 7 == 0 {
                let (w, wr) = (net.weights_now(), reference.weights());
                let wmax = wr.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (a, b) in w.iter().zip(wr) {
                    worst_w = worst_w.max((a - b).abs() / wmax);
                }
            }
        }
        // An explicit flush stores what `weights_now` computed, to the store's round-off.
        let held = net.weights_now().into_owned();
        net.flush();
        assert_eq!(net.pending(), 0);
        assert!(!net.is_stale());
        let wmax = held.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let eps = if kernel == Kernel::BatchedF32 {
            1e-6
        } else {
            1e-14
        };
        for (a, b) in net.weights().iter().zip(&held) {
            assert!((a - b).abs() <= eps * wmax);
        }
        eprintln!(
            "{kernel}, M = {M}: max rel. diff outputs {worst_f:.2e}, weights {worst_w:.2e}, \
             pending ≤ {max_pending}"
        );
        assert_eq!(max_pending, BATCH_DEPTH);
        assert!(worst_f <= tol && worst_w <= tol, "{kernel}, M = {M}");
    }

    /// With updates held, the accessors that read the stored weights refuse (a stale read
    /// would be silent data corruption); every mutating entry point applies them first, and
    /// `set_weights`/`reset` drop them. Bases the batched passes do not handle (general
    /// centres, a tail not a multiple of 8) use the direct passes and never hold updates.
    #[test]
    fn batched_kernel_pending_updates_are_never_read_stale() {
        if !Kernel::Batched.is_available() {
            return;
        }
        for kernel in [Kernel::Batched, Kernel::BatchedF32] {
            held_updates_are_never_read_stale(kernel);
        }
    }

    fn held_updates_are_never_read_stale(kernel: Kernel) {
        let rbf = Rbf::paper();
        let upd = paper_update();
        let mut ws = rbf.workspace();
        let z = [0.1; 12];
        let z2 = Vector3::new(0.01, -0.02, 0.03);
        let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        net.set_kernel(kernel).unwrap();
        net.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
        assert_eq!(net.pending(), 1);
        assert!(net.is_stale());
        for read in [
            (|n: &RbfNetwork<3>| {
                let _ = n.weights();
            }) as fn(&RbfNetwork<3>),
            |n| {
                let _ = n.weight(0, 0);
            },
            |n| {
                let _ = n.norms();
            },
            |n| {
                let _ = n.weights_matrix();
            },
        ] {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(&net)));
            let msg = r.unwrap_err();
            let msg = msg.downcast_ref::<String>().unwrap();
            assert!(msg.contains("pending") && msg.contains("flush()"), "{msg}");
        }
        // tick_at (norms wanted) flushes first, then runs the direct pass.
        let mut other = net.clone();
        other.tick_at(&rbf, &z, &mut ws, 1.0, &z2, &upd);
        assert_eq!(other.pending(), 0);
        assert!(!other.is_stale());
        let _ = other.weights();
        // After a flush the weights are readable until the next batched tick, with a full
        // batch held and applied in between too.
        let mut f = net.clone();
        for _ in 0..2 * BATCH_DEPTH + 3 {
            f.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
            assert!(f.is_stale());
        }
        let now = f.weights_now().into_owned();
        f.flush();
        assert!(!f.is_stale());
        let scale = now.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let eps = if kernel == Kernel::BatchedF32 {
            1e-6
        } else {
            1e-14
        };
        assert!(
            f.weights()
                .iter()
                .zip(&now)
                .all(|(a, b)| (a - b).abs() <= eps * scale)
        );
        // weights_mut flushes; set_weights and reset drop.
        let mut m = net.clone();
        let now = m.weights_now().into_owned();
        assert_eq!(m.weights_mut().len(), now.len());
        assert_eq!(m.pending(), 0);
        assert!(!m.is_stale());
        let mut s = net.clone();
        s.set_weights(&vec![0.5; now.len()]).unwrap();
        assert_eq!(s.pending(), 0);
        assert!(!s.is_stale());
        assert!(s.weights().iter().all(|&w| w == 0.5));
        // The next tick works from the weights just set (0.5 is exact in `f32`).
        let mut fresh = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        fresh.set_kernel(Kernel::Portable).unwrap();
        fresh.set_weights(&vec![0.5; now.len()]).unwrap();
        let a = s.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
        let b = fresh.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
        assert!((a - b).abs().max() <= 1e-6 * b.abs().max(), "{a} {b}");
        // Switching kernels keeps the weights: the held terms (and the `f32` store) are
        // brought back first.
        let mut sw = f.clone();
        sw.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
        let before = sw.weights_now().into_owned();
        sw.set_kernel(Kernel::Portable).unwrap();
        assert!(!sw.is_stale() && sw.pending() == 0);
        assert!(
            sw.weights()
                .iter()
                .zip(&before)
                .all(|(a, b)| (a - b).abs() <= eps * scale)
        );
        net.reset();
        assert_eq!(net.pending(), 0);
        assert!(!net.is_stale());
        assert!(net.weights().iter().all(|&w| w == 0.0));
        // Direct passes for the bases the batched passes do not take.
        let odd = Rbf::grid(&[vec![-1.0, 1.0], vec![-1.0, 0.0, 1.0]], 2.0).unwrap();
        for rbf in [odd.clone(), odd.to_general()] {
            let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
            net.set_kernel(kernel).unwrap();
            let mut reference = net.clone();
            reference.set_kernel(Kernel::Avx512).unwrap();
            let (mut ws, mut ws_r) = (rbf.workspace(), rbf.workspace());
            for k in 0..40 {
                let z = [0.01 * k as f64, -0.3];
                let a = net.tick_at_outputs(&rbf, &z, &mut ws, 1.0, &z2, &upd);
                let b = reference.tick_at_outputs(&rbf, &z, &mut ws_r, 1.0, &z2, &upd);
                assert_eq!(a, b);
                assert_eq!(net.pending(), 0);
                assert!(!net.is_stale());
            }
        }
    }

    /// `tick_at_outputs` (no norms, `S` not stored) is the same pass as `tick_at`: the same
    /// outputs and weights, bit for bit, with every kernel; `‖S‖²` is still valid.
    #[test]
    fn outputs_only_tick_equals_the_full_tick_for_every_kernel() {
        let rbf = Rbf::paper();
        let upd = paper_update();
        for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
            let mut rng = Rng(33);
            let mut a = random_network(rbf.n_nodes(), &mut rng);
            a.set_kernel(kernel).unwrap();
            let mut b = a.clone();
            let (mut wa, mut wb) = (rbf.workspace(), rbf.workspace());
            for _ in 0..3 {
                let z: Vec<f64> = (0..12).map(|_| rng.range(-1.5, 1.5)).collect();
                let z2 = Vector3::new(0.3, -0.2, 0.01);
                let t = a.tick_at(&rbf, &z, &mut wa, 0.7, &z2, &upd);
                let f = b.tick_at_outputs(&rbf, &z, &mut wb, 0.7, &z2, &upd);
                assert_eq!(t.f_hat, f, "{kernel}");
                assert_eq!(a.weights(), b.weights(), "{kernel}");
                assert_eq!(wa.s_norm2(), wb.s_norm2(), "{kernel}");
                let s2: f64 = wa.s().iter().map(|v| v * v).sum();
                // ‖S‖² as the product of the factor norms vs the sum over 4096 nodes: a few
                // ulps per operation, 1e-13 relative.
                assert!((s2 - wa.s_norm2()).abs() <= 1e-13 * s2, "{kernel}");
            }
        }
    }

    #[test]
    fn kernel_names_and_errors() {
        for k in Kernel::ALL {
            match Kernel::parse(k.name()) {
                Ok(got) => assert_eq!(got, k),
                Err(e) => {
                    assert!(!k.is_available());
                    assert!(e.to_string().contains(KERNEL_ENV), "{e}");
                }
            }
        }
        let e = Kernel::parse("sse9").unwrap_err().to_string();
        assert!(
            e.contains(KERNEL_ENV)
                && e.contains("portable")
                && e.contains("avx2fma")
                && e.contains("avx512"),
            "{e}"
        );
        // The default is the fastest double-precision kernel this CPU has (AVX-512: by vendor),
        // never the single-precision store.
        let d = Kernel::default_for_cpu();
        assert!(d.is_available() && d != Kernel::BatchedF32);
        let wide = if detect_amd() {
            Kernel::Avx512
        } else {
            Kernel::Batched
        };
        let fastest = [wide, Kernel::Avx2, Kernel::Portable]
            .into_iter()
            .find(|k| k.is_available());
        assert_eq!(Some(d), fastest);
        assert!(Kernel::parse("batched-f32").is_ok() == Kernel::BatchedF32.is_available());
    }

    #[test]
    fn exact_update_solves_the_weight_ode_for_held_inputs() {
        // Ŵ̇ = −Θ(Q S z2 + σŴ) with constant S, Q, z2:
        // Ŵ(t) = e^{−Θσt} Ŵ(0) − (1 − e^{−Θσt}) Q S z2 / σ.
        let rbf = uneven();
        let s = rbf.eval(&[0.3, -0.4, 1.1]);
        let (theta, sigma, h, q) = (
            Vector2::new(120.0, 0.5),
            Vector2::new(0.001, 2.0),
            1e-3,
            0.8,
        );
        let upd = NnUpdate::new(theta, sigma, h).unwrap();
        let z2 = Vector2::new(0.05, -1.5);
        let mut rng = Rng(9);
        let mut net = RbfNetwork::<2>::new(rbf.n_nodes()).unwrap();
        let w0: Vec<f64> = (0..rbf.n_nodes() * 2)
            .map(|_| rng.range(-1.0, 1.0))
            .collect();
        net.set_weights(&w0).unwrap();
        let n = 5000;
        for _ in 0..n {
            net.tick(s.as_slice(), q, &z2, &upd);
        }
        let t = n as f64 * h;
        for k in 0..rbf.n_nodes() {
            for j in 0..2 {
                let x = theta[j] * sigma[j] * t;
                let want = (-x).exp() * w0[k * 2 + j] + (-x).exp_m1() * q * s[k] * z2[j] / sigma[j];
                let got = net.weight(k, j);
                assert!(
                    (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "{k} {j}: {got} {want}"
                );
            }
        }
    }

    #[test]
    fn exact_update_is_euler_to_first_order() {
        let theta = Vector3::new(120.0, 150.0, 120.0);
        let sigma = Vector3::repeat(0.001);
        for h in [1e-3, 1e-4, 1e-5] {
            let upd = NnUpdate::new(theta, sigma, h).unwrap();
            for j in 0..3 {
                // decay = 1 − Θσh + O(h²), gain = Θh + O(h²).
                let x = theta[j] * sigma[j] * h;
                assert!((upd.decay()[j] - (1.0 - x)).abs() <= x * x);
                assert!((upd.gain()[j] - theta[j] * h).abs() <= theta[j] * h * x);
            }
        }
    }

    #[test]
    fn zero_at_start_partial_block_and_layout() {
        let rbf = uneven(); // 30 nodes: the last block of 4 is partial.
        let mut net = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        assert_eq!(net.norms(), Vector3::zeros());
        assert_eq!(net.weights().len(), 90);
        let mut ws = rbf.workspace();
        let upd = paper_update();
        let z2 = Vector3::new(1.0, 2.0, 3.0);
        let t = net.tick_at(&rbf, &[0.1, 0.2, 0.3], &mut ws, 1.0, &z2, &upd);
        assert_eq!(t.f_hat, Vector3::zeros());
        // From zero weights one step gives Ŵ[k, j] = −gain_j Q S_k z2_j, node-major.
        let g = upd.gain();
        for k in 0..30 {
            for j in 0..3 {
                let want = 0.0 * upd.decay()[j] - g[j] * z2[j] * ws.s()[k];
                assert_eq!(net.weights()[k * 3 + j], want);
                assert_eq!(net.weight(k, j), want);
            }
        }
        let m = net.weights_matrix();
        assert_eq!(m.shape(), (30, 3));
        assert_eq!(m[(29, 2)], net.weight(29, 2));
        for j in 0..3 {
            assert!((t.w_norm[j] - m.column(j).norm()).abs() <= 1e-15 * t.w_norm[j]);
        }
        let mut other = RbfNetwork::<3>::for_basis(&rbf).unwrap();
        other.set_weights(net.weights()).unwrap();
        assert_eq!(other.weights(), net.weights());
        net.reset();
        assert_eq!(net.norms(), Vector3::zeros());
    }

    #[test]
    fn validation() {
        let e = NnUpdate::new(Vector3::new(1.0, 0.0, 1.0), Vector3::repeat(0.1), 1e-3).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "theta[1]"));
        let e =
            NnUpdate::new(Vector3::repeat(1.0), Vector3::new(-1.0, 1.0, 1.0), 1e-3).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "sigma[0]"));
        let e = NnUpdate::new(Vector3::repeat(1.0), Vector3::repeat(1.0), 0.0).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "h"));
        let e = Rbf::grid(&[vec![-1.0, 1.0]], 0.0).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "width2"));
        assert!(Rbf::grid(&[vec![-1.0, 1.0], vec![]], 1.0).is_err());
        assert!(Rbf::grid(&[], 1.0).is_err());
        assert!(Rbf::grid(&[vec![f64::NAN]], 1.0).is_err());
        assert!(Rbf::grid(&vec![vec![0.0, 1.0, 2.0, 3.0]; 13], 1.0).is_err());
        assert!(Rbf::general(&DMatrix::from_element(3, 2, f64::INFINITY), 1.0).is_err());
        assert!(Rbf::general(&DMatrix::zeros(0, 2), 1.0).is_err());
        assert!(RbfNetwork::<3>::new(0).is_err());
        assert!(RbfNetwork::<9>::new(4).is_err());
        let mut net = RbfNetwork::<3>::new(4).unwrap();
        assert!(net.set_weights(&[0.0; 11]).is_err());
    }

    proptest! {
        #[test]
        fn basis_values_in_unit_interval_and_general_matches_grid(
            z in proptest::collection::vec(-5.0f64..5.0, 3),
            width2 in 0.1f64..100.0,
        ) {
            let rbf = Rbf::grid(&[vec![-1.0, 1.0], vec![0.0, 0.5, 1.0], vec![-2.0, 2.0]], width2)
                .unwrap();
            let s = rbf.eval(&z);
            prop_assert!(s.iter().all(|&v| (0.0..=1.0).contains(&v)));
            let g = rbf.to_general().eval(&z);
            prop_assert!(max_abs_diff(s.as_slice(), g.as_slice()) <= 1e-14);
        }
    }
}
