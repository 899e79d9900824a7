//! Constrained closed-chain dynamics (the default plant), SPEC §2.4.
//!
//! Generalised coordinates `s = (q_1, …, q_m, x_o)`. Each grasp is the holonomic constraint
//! `φ_i = p_E,i(q_i) − p_o − R(θ) r_i = 0` with Jacobian `A_i = [J_e,i | −J_i(x_o)]`. With the
//! block-diagonal inertia `𝕄 = diag(M_1, …, M_m, M_o)` and bias `h`:
//!
//! $$𝕄 \ddot s + h = Q + A^\top λ, \qquad A\ddot s + \dot A \dot s = −2ω_b \dot φ − ω_b^2 φ$$
//!
//! (Baumgarte drift control, critically damped). The multipliers `λ_i` are the grasp forces
//! `F_i` — the force the object exerts on end-effector `i`, as its sensor reads it — so arm `i`
//! obeys (1) and the object obeys (10)–(11): `M_o ẍ_o + C_o ẋ_o + G_o = −Σ J_iᵀ F_i − F_d`.
//!
//! Solved by the Schur complement of the KKT system: with the unconstrained accelerations
//! `a_0 = 𝕄⁻¹(Q − h)`, `K = A 𝕄⁻¹ Aᵀ = diag(J_e,i M_i⁻¹ J_e,iᵀ) + 𝐉 M_o⁻¹ 𝐉ᵀ` (2m × 2m, `𝐉` the
//! stacked grasp Jacobians), `K λ = −Ȧṡ − A a_0 − 2ω_b φ̇ − ω_b² φ`, then `s̈ = a_0 + 𝕄⁻¹Aᵀλ`.
//! Each arm's `M_i` is factored once per evaluation; no allocation.
//!
//! Two implementations of these equations, selected once per plant ([`Algorithm`](super::Algorithm)):
//! * two or three arms of 2, 3 or 4 links each (all alike; the paper's pair among them): every
//!   block is a fixed-size value on the stack — per arm a [`FixedArm`] kernel (2-link arms: the
//!   SPEC §2.1 closed forms from one `sin_cos` per link, [`TwoLinkArm`](crate::dynamics::planar::TwoLinkArm),
//!   `M_i⁻¹ = adj(M_i)/det M_i`; 3- and 4-link arms: [`FixedLinkArm`](crate::dynamics::planar::FixedLinkArm),
//!   the general algorithm in `SMatrix` values with one Cholesky of `M_i`), `K` a 4×4 or 6×6
//!   `SMatrix` factored once a state as `L D Lᵀ` ([`ldl_in_place`]: no square roots, and the
//!   solves for each torque by multiplications), `M_o⁻¹` and `C_o` as diagonals;
//! * the general algorithm on the workspace's dynamic-size buffers, for any arms.
//!
//! `tests/plant.rs` holds the two equal to round-off at random states.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

use super::{Kernel, Plant, PlantInput, PlantWorkspace};
use crate::dynamics::planar::{ArmSolve, FixedArm};
use crate::math::linalg::{
    cholesky_in_place, cholesky_solve_in_place, ldl_in_place, ldl_solve_in_place,
};

/// Relative regularisation of a singular grasp-space matrix: `K + ε tr(K) I`.
const K_REG: f64 = 1e-10;

#[inline]
fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

/// The state part of the fixed-size constrained derivative of `M` arms of `N` links
/// (`NK = 2M`): every quantity of [`Plant::derivative`] that the input `(τ, F_d)` does not
/// enter — per arm `M_i⁻¹` (or its factor) and bias ([`ArmSolve`]), `Y_i = M_i⁻¹ J_e,iᵀ`,
/// `J_e,i`, `d_i`, the grasp right-hand side's state terms, the factored `K`; the object's
/// `C_o ẋ_o`. The torque part ([`Plant::derivative`]'s `a_0`, `K λ = rhs`, `s̈`) reads it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FixedState<const N: usize, const M: usize, const NK: usize> {
    solve: [ArmSolve<N>; M],
    y_blk: [SMatrix<f64, N, 2>; M],
    j: [SMatrix<f64, 2, N>; M],
    d: [Vector2<f64>; M],
    /// `−J̇_i ẋ_o … = −(J̇_e,i q̇_i + R r_i θ̇²)`, `2ω_b φ̇_i`, `ω_b² φ_i`: the right-hand side's
    /// state terms in the order they are subtracted.
    neg_bias: [Vector2<f64>; M],
    damp: [Vector2<f64>; M],
    stiff: [Vector2<f64>; M],
    /// `C_o ẋ_o` (diagonal `C_o`).
    c_xd: Vector3<f64>,
    /// `K = L D Lᵀ` (regularised if it had to be): unit `L` below the diagonal, `D` on it.
    k: SMatrix<f64, NK, NK>,
    /// `1 / D_j`, for the input part's solves.
    k_inv_d: [f64; NK],
    /// Smallest pivot ratio of `K`'s factorisation (0 when regularised).
    pivot: f64,
    /// Whether `K` needed regularisation.
    regularised: bool,
}

impl<const N: usize, const M: usize, const NK: usize> Default for FixedState<N, M, NK> {
    fn default() -> Self {
        FixedState {
            solve: [ArmSolve {
                m: SMatrix::zeros(),
                inv_diag: SVector::zeros(),
                bias: SVector::zeros(),
                g: SVector::zeros(),
            }; M],
            y_blk: [SMatrix::zeros(); M],
            j: [SMatrix::zeros(); M],
            d: [Vector2::zeros(); M],
            neg_bias: [Vector2::zeros(); M],
            damp: [Vector2::zeros(); M],
            stiff: [Vector2::zeros(); M],
            c_xd: Vector3::zeros(),
            k: SMatrix::zeros(),
            k_inv_d: [0.0; NK],
            pivot: 0.0,
            regularised: false,
        }
    }
}

/// The kept state part of [`Plant::derivative_keep`], one variant per fixed-size kernel
/// (`L{links}A{arms}`, as [`Kernel`]); `None` for the general algorithm or before any keep.
#[derive(Clone, Debug)]
pub(crate) enum Kept {
    None,
    L2A2(Box<FixedState<2, 2, 4>>),
    L2A3(Box<FixedState<2, 3, 6>>),
    L3A2(Box<FixedState<3, 2, 4>>),
    L3A3(Box<FixedState<3, 3, 6>>),
    L4A2(Box<FixedState<4, 2, 4>>),
    L4A3(Box<FixedState<4, 3, 6>>),
}

impl Kept {
    /// The empty slot of a plant's kernel.
    pub(crate) fn for_kernel(k: &Kernel) -> Kept {
        match k {
            Kernel::L2A2(_) => Kept::L2A2(Box::default()),
            Kernel::L2A3(_) => Kept::L2A3(Box::default()),
            Kernel::L3A2(_) => Kept::L3A2(Box::default()),
            Kernel::L3A3(_) => Kept::L3A3(Box::default()),
            Kernel::L4A2(_) => Kept::L4A2(Box::default()),
            Kernel::L4A3(_) => Kept::L4A3(Box::default()),
            Kernel::General => Kept::None,
        }
    }
}

/// How [`Plant::derivative`]'s fixed-size path treats the kept state part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Compute the state part, do not keep it.
    Fresh,
    /// Compute the state part and keep it (with `y`).
    Keep,
    /// Use the kept state part if it is of this `y` (bit for bit), else as `Fresh`.
    Reuse,
    /// As `Keep`, but only the grasp forces (and the diagnostics): no accelerations.
    KeepForces,
}

impl Plant {
    /// State derivative of the constrained plant: reads `(y, input)`, writes `dy` and the grasp
    /// forces / diagnostics in `ws`. Returns `false` if an arm's inertia was not positive
    /// definite (the derivative is then not usable) — never for a validated model.
    ///
    /// A singular grasp-space matrix `K` (arms at singularities that lock the chain) is
    /// regularised (`K + ε tr(K) I`, ε = 1e-10) and counted in `ws.regularised`.
    ///
    /// Dispatches on [`Plant::algorithm`]: the fixed-size path for two 2-link arms (it does not
    /// write `ws.terms`), else [`Plant::derivative_general`]; the two agree to round-off.
    #[inline]
    pub fn derivative(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> bool {
        self.derivative_mode(y, input, ws, dy, Mode::Fresh)
    }

    /// [`Plant::derivative`], and keep its state part (everything the input does not enter:
    /// the arms' `M⁻¹`, biases and Jacobians, the factored grasp-space matrix `K`, …) in `ws`
    /// for [`Plant::derivative_reusing`] at the same state `y` with another input. The
    /// simulation loop evaluates the grasp forces at `(y(t_k), u_{k−1})` this way (SPEC §3
    /// step 1), then the first RK4 stage at `(y(t_k), u_k)`. The general algorithm keeps
    /// nothing.
    #[inline]
    pub fn derivative_keep(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> bool {
        self.derivative_mode(y, input, ws, dy, Mode::Keep)
    }

    /// The grasp forces `λ_i` of [`Plant::derivative_keep`] into `ws.forces` (with
    /// `ws.kkt_pivot` and the `ws.regularised` count), keeping the state part as it does, but
    /// not the accelerations: on the fixed-size paths `dy` and `ws.xdd_o` are left as they
    /// were (the general algorithm writes them, `dy` its scratch). The simulation loop's grasp
    /// forces at `(y(t_k), u_{k−1})` (SPEC §3 step 1) need no more; the same `λ_i`, bit for
    /// bit, as [`Plant::derivative`]. Returns `false` as [`Plant::derivative`] does.
    #[inline]
    pub fn grasp_forces_keep(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> bool {
        self.derivative_mode(y, input, ws, dy, Mode::KeepForces)
    }

    /// [`Plant::derivative`] at a state whose state part the last [`Plant::derivative_keep`]
    /// on `ws` kept: if `y` is that state bit for bit, only the input's part is computed
    /// (`a_0 = M⁻¹(τ − C q̇ − G)`, the right-hand side, `K λ = rhs` by the kept factor, `s̈`),
    /// else everything. The same values, bit for bit, as [`Plant::derivative`] (the same
    /// floating-point operations on the same values), and the same `ws.regularised` count.
    /// `ws` must belong to this plant ([`Plant::workspace`]).
    #[inline]
    pub fn derivative_reusing(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> bool {
        self.derivative_mode(y, input, ws, dy, Mode::Reuse)
    }

    #[inline(always)]
    fn derivative_mode(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
        mode: Mode,
    ) -> bool {
        macro_rules! fixed {
            ($a:expr, $v:ident, $n:literal, $m:literal, $nk:literal) => {{
                let Kept::$v(slot) = &mut ws.kept else {
                    unreachable!("the workspace belongs to another plant")
                };
                let slot: &mut FixedState<$n, $m, $nk> = slot;
                // Each branch its own input part, so that the fresh one's state part stays a
                // local value (in registers), not behind a reference shared with the slot.
                let (forces, xdd_o) = (&mut ws.forces, &mut ws.xdd_o);
                let (kkt_pivot, regularised) = (&mut ws.kkt_pivot, &mut ws.regularised);
                match mode {
                    Mode::Fresh => {
                        let Some(st) = self.state_part($a, y) else {
                            return false;
                        };
                        self.input_part::<_, $n, $m, $nk, true>(
                            $a,
                            &st,
                            y,
                            input,
                            forces,
                            xdd_o,
                            kkt_pivot,
                            regularised,
                            dy,
                        )
                    }
                    Mode::Reuse
                        if ws.kept_valid
                            && ws.kept_y.len() == y.len()
                            && ws
                                .kept_y
                                .iter()
                                .zip(y)
                                .fold(true, |eq, (a, b)| eq & (a.to_bits() == b.to_bits())) =>
                    {
                        self.input_part::<_, $n, $m, $nk, true>(
                            $a,
                            slot,
                            y,
                            input,
                            forces,
                            xdd_o,
                            kkt_pivot,
                            regularised,
                            dy,
                        )
                    }
                    Mode::Keep | Mode::Reuse | Mode::KeepForces => {
                        let Some(st) = self.state_part($a, y) else {
                            ws.kept_valid = false;
                            return false;
                        };
                        let ok = if mode == Mode::KeepForces {
                            self.input_part::<_, $n, $m, $nk, false>(
                                $a,
                                &st,
                                y,
                                input,
                                forces,
                                xdd_o,
                                kkt_pivot,
                                regularised,
                                dy,
                            )
                        } else {
                            self.input_part::<_, $n, $m, $nk, true>(
                                $a,
                                &st,
                                y,
                                input,
                                forces,
                                xdd_o,
                                kkt_pivot,
                                regularised,
                                dy,
                            )
                        };
                        *slot = st;
                        ws.kept_valid = true;
                        let len = ws.kept_y.len();
                        ws.kept_y.copy_from_slice(&y[..len]);
                        ok
                    }
                }
            }};
        }
        match &self.kernel {
            Kernel::L2A2(a) => fixed!(a, L2A2, 2, 2, 4),
            Kernel::L2A3(a) => fixed!(a, L2A3, 2, 3, 6),
            Kernel::L3A2(a) => fixed!(a, L3A2, 3, 2, 4),
            Kernel::L3A3(a) => fixed!(a, L3A3, 3, 3, 6),
            Kernel::L4A2(a) => fixed!(a, L4A2, 4, 2, 4),
            Kernel::L4A3(a) => fixed!(a, L4A3, 4, 3, 6),
            Kernel::General => self.derivative_general(y, input, ws, dy),
        }
    }

    /// The state part of the fixed-size constrained derivative of `M` arms of `N` links each
    /// (`NK = 2M`): the equations of [`Plant::derivative_general`] that the input does not
    /// enter (the same `K` factorisation), with every block in registers — each arm's
    /// [`ArmBlock`](crate::dynamics::planar::ArmBlock) from its [`FixedArm::state_block`], `K` an `NK × NK`
    /// `SMatrix`. Reads `y`; `None` if an arm's `M_i` (or the regularised `K`) is not
    /// positive definite.
    #[inline(always)]
    fn state_part<A: FixedArm<N>, const N: usize, const M: usize, const NK: usize>(
        &self,
        arms: &[A; M],
        y: &[f64],
    ) -> Option<FixedState<N, M, NK>> {
        debug_assert_eq!(2 * M, NK);
        debug_assert_eq!(self.n_q, N * M);
        // y = [q (n), x_o (3), q̇ (n), ẋ_o (3)]; one length check for all the indexing below.
        let n = N * M;
        let y = &y[..2 * n + 6];
        let grasps = &self.grasps[..M];
        let x_o = Vector3::new(y[n], y[n + 1], y[n + 2]);
        let xd_o = Vector3::new(y[2 * n + 3], y[2 * n + 4], y[2 * n + 5]);
        let p_o = Vector2::new(x_o.x, x_o.y);
        let v_o = Vector2::new(xd_o.x, xd_o.y);
        let (sin_th, cos_th) = crate::math::trig::sin_cos(x_o.z);
        let w = self.baumgarte;
        let mi = &self.m_o_inv;

        // Arm i (q_i, q̇_i, x_o, ẋ_o) → M_i⁻¹ and bias (for a0_i = M_i⁻¹(τ_i − C_i q̇_i − G_i)),
        // Y_i = M_i⁻¹ J_e,iᵀ, K_ii = J_e,i Y_i, d_i = (R(θ) r_i)^⊥ (so J_i = [I | d_i]) and
        // the state terms of grasp i's right-hand side −Ȧṡ − A a0 − 2ω_b φ̇ − ω_b² φ.
        let mut solve = [ArmSolve {
            m: SMatrix::<f64, N, N>::zeros(),
            inv_diag: SVector::<f64, N>::zeros(),
            bias: SVector::<f64, N>::zeros(),
            g: SVector::<f64, N>::zeros(),
        }; M];
        let mut y_blk = [SMatrix::<f64, N, 2>::zeros(); M];
        let mut j = [SMatrix::<f64, 2, N>::zeros(); M];
        let mut k_blk = [Matrix2::zeros(); M];
        let mut d = [Vector2::zeros(); M];
        let mut neg_bias = [Vector2::zeros(); M];
        let mut damp = [Vector2::zeros(); M];
        let mut stiff = [Vector2::zeros(); M];
        let q_of = |i: usize| -> [f64; N] { std::array::from_fn(|r| y[N * i + r]) };
        let qd_of = |i: usize| -> [f64; N] { std::array::from_fn(|r| y[n + 3 + N * i + r]) };
        // The arms' blocks two at a time (FixedArm::state_block_pair), the last one alone.
        let mut blocks = [None; M];
        let mut i = 0;
        while i < M {
            if i + 1 < M {
                let [p, q] = A::state_block_pair(
                    [&arms[i], &arms[i + 1]],
                    [q_of(i), q_of(i + 1)],
                    [qd_of(i), qd_of(i + 1)],
                    self.g,
                )?;
                (blocks[i], blocks[i + 1]) = (Some(p), Some(q));
                i += 2;
            } else {
                blocks[i] = Some(arms[i].state_block(q_of(i), qd_of(i), self.g)?);
                i += 1;
            }
        }
        for i in 0..M {
            let (blk, s) = blocks[i].expect("every arm's block is set above");
            solve[i] = s;
            y_blk[i] = blk.y;
            j[i] = blk.j;
            k_blk[i] = blk.k;
            // R(θ) r_i once; the grasp point, J_i ẋ_o and J̇_i ẋ_o = −R r_i θ̇² from it.
            let r = grasps[i].r;
            let rw = Vector2::new(cos_th * r.x - sin_th * r.y, sin_th * r.x + cos_th * r.y);
            d[i] = perp(rw);
            let phi = blk.p_ee - (p_o + rw);
            let phid = blk.v_ee - (v_o + d[i] * xd_o.z);
            let bias = blk.jdot_qdot + rw * (xd_o.z * xd_o.z);
            neg_bias[i] = -bias;
            damp[i] = 2.0 * w * phid;
            stiff[i] = w * w * phi;
        }
        // K = diag(K_ii) + 𝐉 M_o⁻¹ 𝐉ᵀ; with diagonal M_o⁻¹ its (i, j) block is
        // diag(m_x, m_y) + (m_θ d_i) d_jᵀ.
        let mut k = SMatrix::<f64, NK, NK>::zeros();
        for i in 0..M {
            for jj in 0..M {
                let mut blk = (mi.z * d[i]) * d[jj].transpose();
                blk[(0, 0)] += mi.x;
                blk[(1, 1)] += mi.y;
                if i == jj {
                    blk = k_blk[i] + blk;
                }
                k.fixed_view_mut::<2, 2>(2 * i, 2 * jj).copy_from(&blk);
            }
        }
        // K = L D Lᵀ in place (regularised if K is singular), square-root free: the general
        // path's Cholesky up to round-off, with a shorter dependency chain.
        let k_copy = k;
        let mut k_inv_d = [0.0; NK];
        let (pivot, regularised) = match ldl_in_place(&mut k, NK, &mut k_inv_d) {
            Ok(p) => (p, false),
            Err(_) => {
                let trace = k_copy.trace();
                k = k_copy;
                for dd in 0..NK {
                    k[(dd, dd)] += K_REG * trace.max(f64::MIN_POSITIVE);
                }
                if ldl_in_place(&mut k, NK, &mut k_inv_d).is_err() {
                    return None;
                }
                (0.0, true)
            }
        };
        Some(FixedState {
            solve,
            y_blk,
            j,
            d,
            neg_bias,
            damp,
            stiff,
            c_xd: self.c_o.component_mul(&xd_o),
            k,
            k_inv_d,
            pivot,
            regularised,
        })
    }

    /// The input part of the fixed-size constrained derivative on a state part `st` of `y`:
    /// `a0_i = M_i⁻¹(τ_i − C_i q̇_i − G_i)` ([`FixedArm::a0`]), the object's
    /// `a0_o = M_o⁻¹(−F_d − C_o ẋ_o − G_o)`, `K λ = −Ȧṡ − A a0 − 2ω_b φ̇ − ω_b² φ` by the
    /// factor of `K`, then `q̈_i = a0_i + Y_i λ_i`, `ẍ_o = a0_o − M_o⁻¹ Σ J_iᵀ λ_i`. Writes
    /// `dy`, `forces` (`λ_i`), `xdd_o`, `kkt_pivot`, and counts a regularised `K` in
    /// `regularised`; without `ACC`, only `forces`, `kkt_pivot` and `regularised` (the
    /// accelerations are not formed).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn input_part<
        A: FixedArm<N>,
        const N: usize,
        const M: usize,
        const NK: usize,
        const ACC: bool,
    >(
        &self,
        arms: &[A; M],
        st: &FixedState<N, M, NK>,
        y: &[f64],
        input: &PlantInput,
        forces: &mut [Vector2<f64>],
        xdd_o: &mut Vector3<f64>,
        kkt_pivot: &mut f64,
        regularised: &mut u64,
        dy: &mut [f64],
    ) -> bool {
        let n = N * M;
        let (y, dy) = (&y[..2 * n + 6], &mut dy[..2 * n + 6]);
        let tau = &input.tau[..n];
        let forces = &mut forces[..M];
        let mi = &self.m_o_inv;
        let xd_o = Vector3::new(y[2 * n + 3], y[2 * n + 4], y[2 * n + 5]);

        // Object (ẋ_o, F_d) → unconstrained acceleration a0_o = M_o⁻¹(−F_d − C_o ẋ_o − G_o).
        let a0_o = mi.component_mul(&(-input.f_d - st.c_xd - self.object.G_o));
        let a0_o_xy = Vector2::new(a0_o.x, a0_o.y);

        // Arm i: a0_i, then grasp i's right-hand side.
        let mut a0 = [SVector::<f64, N>::zeros(); M];
        let mut rhs = SVector::<f64, NK>::zeros();
        for i in 0..M {
            let o = N * i;
            a0[i] = arms[i].a0(&st.solve[i], std::array::from_fn(|r| tau[o + r]));
            let ja0 = st.j[i] * a0[i] - (a0_o_xy + st.d[i] * a0_o.z);
            let rh = st.neg_bias[i] - ja0 - st.damp[i] - st.stiff[i];
            rhs[2 * i] = rh.x;
            rhs[2 * i + 1] = rh.y;
        }
        // K λ = rhs by the factor of K; λ into rhs.
        *kkt_pivot = st.pivot;
        if st.regularised {
            *regularised += 1;
        }
        ldl_solve_in_place(&st.k, &st.k_inv_d, NK, rhs.as_mut_slice());
        if !ACC {
            for (i, f) in forces.iter_mut().enumerate() {
                *f = Vector2::new(rhs[2 * i], rhs[2 * i + 1]);
            }
            return true;
        }

        // Accelerations: q̈_i = a0_i + Y_i λ_i; ẍ_o = a0_o − M_o⁻¹ Σ J_iᵀ λ_i.
        dy[..n].copy_from_slice(&y[n + 3..2 * n + 3]);
        dy[n..n + 3].copy_from_slice(xd_o.as_slice());
        let mut f_sum = Vector3::zeros();
        for i in 0..M {
            let lam = Vector2::new(rhs[2 * i], rhs[2 * i + 1]);
            forces[i] = lam;
            f_sum += Vector3::new(lam.x, lam.y, st.d[i].dot(&lam));
            let qdd = a0[i] + st.y_blk[i] * lam;
            dy[n + 3 + N * i..n + 3 + N * (i + 1)].copy_from_slice(qdd.as_slice());
        }
        let xdd = a0_o - mi.component_mul(&f_sum);
        *xdd_o = xdd;
        dy[2 * n + 3..].copy_from_slice(xdd.as_slice());
        true
    }

    /// The general constrained derivative (any arms, any joint counts) on the workspace's
    /// dynamic-size buffers: the contract of [`Plant::derivative`], and it also leaves each
    /// arm's terms in `ws.terms`. [`Plant::derivative`] runs it unless the plant has a
    /// fixed-size path; public so that tests hold the two equal.
    pub fn derivative_general(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> bool {
        let n = self.n_q;
        let m = self.arms.len();
        let (q, x_o, qd, xd_o) = self.split(y);
        let rot = crate::math::trig::rotation2(x_o.z);
        let p_o = nalgebra::Vector2::new(x_o.x, x_o.y);
        let w = self.baumgarte;
        let obj = &self.object;

        // Object: unconstrained acceleration a0_o = M_o⁻¹(−F_d − C_o ẋ_o − G_o).
        let a0_o = obj.M_o_inv * (-input.f_d - obj.C_o * xd_o - obj.G_o);

        ws.k.fill(0.0);
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let dof = arm.dof();
            let (qi, qdi) = (&q[off..off + dof], &qd[off..off + dof]);
            let t = &mut ws.terms[i];
            // Arm terms (q, q̇) → M, C, G, J_e, J̇_e q̇.
            arm.dynamics(qi, qdi, self.g, t);
            // a0_i = M_i⁻¹(τ_i − C q̇ − G).
            let a0 = &mut ws.a0[off..off + dof];
            for r in 0..dof {
                let mut b = input.tau[off + r] - t.G[r];
                for c in 0..dof {
                    b -= t.C[(r, c)] * qdi[c];
                }
                a0[r] = b;
            }
            t.chol.copy_from(&t.M);
            if cholesky_in_place(&mut t.chol, dof).is_err() {
                return false;
            }
            cholesky_solve_in_place(&t.chol, dof, a0);
            // Y_i = M_i⁻¹ J_e,iᵀ (dof × 2), K_ii += J_e,i Y_i.
            let y_i = &mut ws.minv_jt[i];
            for c in 0..2 {
                let mut col = y_i.column_mut(c);
                for r in 0..dof {
                    col[r] = t.J[(c, r)];
                }
                cholesky_solve_in_place(&t.chol, dof, col.as_mut_slice());
            }
            for a in 0..2 {
                for b in 0..2 {
                    let mut s = 0.0;
                    for r in 0..dof {
                        s += t.J[(a, r)] * y_i[(r, b)];
                    }
                    ws.k[(2 * i + a, 2 * i + b)] += s;
                }
            }
            // Constraint terms of grasp i.
            // R(θ) r_i once; J_i, the grasp point and J̇_i ẋ_o = −R r_i θ̇² from it.
            let rw = rot * self.grasps[i].r;
            let jg = crate::model::planar::grasp::Grasp::jacobian_from_arm(rw);
            ws.grasp_j[i] = jg;
            let phi = t.p_ee - (p_o + rw);
            let phid = t.v_ee - jg * xd_o;
            let bias = t.jdot_qdot + rw * (xd_o.z * xd_o.z);
            let mut ja0 = jg * (-a0_o);
            for r in 0..dof {
                ja0.x += t.J[(0, r)] * a0[r];
                ja0.y += t.J[(1, r)] * a0[r];
            }
            let rhs = -bias - ja0 - 2.0 * w * phid - w * w * phi;
            ws.rhs[2 * i] = rhs.x;
            ws.rhs[2 * i + 1] = rhs.y;
        }
        // K += 𝐉 M_o⁻¹ 𝐉ᵀ.
        for i in 0..m {
            let ji_minv = ws.grasp_j[i] * obj.M_o_inv;
            for j in 0..m {
                let blk = ji_minv * ws.grasp_j[j].transpose();
                for a in 0..2 {
                    for b in 0..2 {
                        ws.k[(2 * i + a, 2 * j + b)] += blk[(a, b)];
                    }
                }
            }
        }
        // Solve K λ = rhs (λ into ws.rhs).
        let nk = 2 * m;
        let mut trace = 0.0;
        for d in 0..nk {
            trace += ws.k[(d, d)];
        }
        ws.k_copy.copy_from(&ws.k);
        match cholesky_in_place(&mut ws.k, nk) {
            Ok(p) => ws.kkt_pivot = p,
            Err(_) => {
                ws.k.copy_from(&ws.k_copy);
                for d in 0..nk {
                    ws.k[(d, d)] += K_REG * trace.max(f64::MIN_POSITIVE);
                }
                ws.regularised += 1;
                ws.kkt_pivot = 0.0;
                if cholesky_in_place(&mut ws.k, nk).is_err() {
                    return false;
                }
            }
        }
        let k = &ws.k;
        cholesky_solve_in_place(k, nk, &mut ws.rhs);

        // Accelerations: q̈_i = a0_i + Y_i λ_i; ẍ_o = a0_o − M_o⁻¹ Σ J_iᵀ λ_i.
        dy[..n].copy_from_slice(qd);
        dy[n..n + 3].copy_from_slice(xd_o.as_slice());
        let mut f_sum = Vector3::zeros();
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let dof = arm.dof();
            let lam = nalgebra::Vector2::new(ws.rhs[2 * i], ws.rhs[2 * i + 1]);
            ws.forces[i] = lam;
            f_sum += ws.grasp_j[i].transpose() * lam;
            let y_i = &ws.minv_jt[i];
            for r in 0..dof {
                dy[n + 3 + off + r] = ws.a0[off + r] + y_i[(r, 0)] * lam.x + y_i[(r, 1)] * lam.y;
            }
        }
        let xdd = a0_o - obj.M_o_inv * f_sum;
        ws.xdd_o = xdd;
        dy[2 * n + 3..].copy_from_slice(xdd.as_slice());
        true
    }
}
