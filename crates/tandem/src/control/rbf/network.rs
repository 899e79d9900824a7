//! The RBF network `f̂ = Ŵᵀ S(Z)` with the discretised weight update (44): [`RbfNetwork`],
//! [`NnUpdate`], [`NnTick`]; the per-tick dispatch to the kernels of [`super::kernels`].

use nalgebra::{DMatrix, SVector};

use crate::error::{ModelError, positive};

use super::basis::{Rbf, RbfWorkspace, outer_into};
#[cfg(target_arch = "x86_64")]
use super::kernels::BLOCK512;
use super::kernels::{BLOCK, Kernel, kernel_read, kernel_tick};
#[cfg(target_arch = "x86_64")]
use super::kernels::{avx2, avx512};
use super::{Aligned, MAX_NODES, MAX_OUTPUTS, batched};

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
    pub(crate) w: Aligned,
    /// The weight-pass kernel (chosen once, at construction; see [`Kernel`]).
    pub(crate) kernel: Kernel,
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
