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
//! weights start at 0; `Q = M(Z)·I` is a scalar (see [`crate::control::law::switching`]), and `Θ_j` is a
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
pub mod basis;
mod batched;
mod factors;
pub mod kernels;
pub mod network;
pub mod structured;

pub use basis::{Rbf, RbfWorkspace};
pub use batched::DEPTH as BATCH_DEPTH;
pub use kernels::{KERNEL_ENV, Kernel};
pub use network::{NnTick, NnUpdate, RbfNetwork};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ModelError;
    use nalgebra::{DMatrix, SVector};

    use super::kernels::detect_amd;
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
