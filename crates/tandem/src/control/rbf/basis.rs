//! The RBF basis `S(Z)` of (36)–(37): Gaussian nodes on a grid (evaluated as a Kronecker
//! product of per-input factors) or at general centres, with its workspace.

use nalgebra::{DMatrix, DVector};

use crate::error::{ModelError, positive};

use super::MAX_NODES;
use super::factors;
use super::kernels::detect_avx2;

/// Where the centres come from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Centres {
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
    pub(crate) avx2: bool,
}

/// Scratch memory and the output `S(Z)` of [`Rbf::eval_into`]; sized once by
/// [`Rbf::workspace`], reused every tick.
#[derive(Debug, Clone, PartialEq)]
pub struct RbfWorkspace {
    /// Per-input factors `f_i`, input after input (grid only).
    pub(crate) f: Vec<f64>,
    /// Head and tail partial products (grid only).
    pub(crate) a: Vec<f64>,
    pub(crate) b: Vec<f64>,
    /// Ping-pong buffer for building `A` and `B`.
    pub(crate) t: Vec<f64>,
    /// `S(Z)`, length `N_s`.
    pub(crate) s: Vec<f64>,
    /// `‖S‖²` of the last evaluation.
    pub(crate) s_norm2: f64,
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
    /// kernel of [`crate::control::rbf::structured`], which produces the same bits).
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
    /// [`crate::control::rbf::structured`], which reproduces [`Rbf::eval_into`] bit for bit.
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
    pub(crate) fn eval_factors_with(&self, z: &[f64], ws: &mut RbfWorkspace, wide: bool) -> bool {
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
pub(crate) fn kron_into(
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
pub(crate) fn outer_into(a: &[f64], b: &[f64], s: &mut [f64], avx2: bool) {
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
