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
//!   SPEC §2.1 closed forms from one `sin_cos` per link, [`TwoLinkArm`](crate::arm::TwoLinkArm),
//!   `M_i⁻¹ = adj(M_i)/det M_i`; 3- and 4-link arms: [`FixedLinkArm`](crate::arm::FixedLinkArm),
//!   the general algorithm in `SMatrix` values with one Cholesky of `M_i`), `K` a 4×4 or 6×6
//!   `SMatrix` factored by the same in-place Cholesky, `M_o⁻¹` and `C_o` as diagonals;
//! * the general algorithm on the workspace's dynamic-size buffers, for any arms.
//!
//! `tests/plant.rs` holds the two equal to round-off at random states.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

use super::{Kernel, Plant, PlantInput, PlantWorkspace};
use crate::arm::FixedArm;
use crate::linalg::{cholesky_in_place, cholesky_solve_in_place};

/// Relative regularisation of a singular grasp-space matrix: `K + ε tr(K) I`.
const K_REG: f64 = 1e-10;

#[inline]
fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
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
        match &self.kernel {
            Kernel::L2A2(a) => self.derivative_fixed::<_, 2, 2, 4>(a, y, input, ws, dy),
            Kernel::L2A3(a) => self.derivative_fixed::<_, 2, 3, 6>(a, y, input, ws, dy),
            Kernel::L3A2(a) => self.derivative_fixed::<_, 3, 2, 4>(a, y, input, ws, dy),
            Kernel::L3A3(a) => self.derivative_fixed::<_, 3, 3, 6>(a, y, input, ws, dy),
            Kernel::L4A2(a) => self.derivative_fixed::<_, 4, 2, 4>(a, y, input, ws, dy),
            Kernel::L4A3(a) => self.derivative_fixed::<_, 4, 3, 6>(a, y, input, ws, dy),
            Kernel::General => self.derivative_general(y, input, ws, dy),
        }
    }

    /// The fixed-size constrained derivative of `M` arms of `N` links each (`NK = 2M`): the
    /// equations and outputs of [`Plant::derivative_general`] (the same `K` factorisation), with
    /// every block in registers — each arm's [`ArmBlock`](crate::arm::ArmBlock) from its [`FixedArm`] kernel, `K` an
    /// `NK × NK` `SMatrix`. Reads `(y, input)`; writes `dy`, `ws.forces`, `ws.xdd_o`,
    /// `ws.kkt_pivot`, `ws.regularised`.
    #[inline]
    fn derivative_fixed<A: FixedArm<N>, const N: usize, const M: usize, const NK: usize>(
        &self,
        arms: &[A; M],
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> bool {
        debug_assert_eq!(2 * M, NK);
        debug_assert_eq!(self.n_q, N * M);
        // y = [q (n), x_o (3), q̇ (n), ẋ_o (3)]; one length check for all the indexing below.
        let n = N * M;
        let (y, dy) = (&y[..2 * n + 6], &mut dy[..2 * n + 6]);
        let tau = &input.tau[..n];
        let (forces, grasps) = (&mut ws.forces[..M], &self.grasps[..M]);
        let x_o = Vector3::new(y[n], y[n + 1], y[n + 2]);
        let xd_o = Vector3::new(y[2 * n + 3], y[2 * n + 4], y[2 * n + 5]);
        let p_o = Vector2::new(x_o.x, x_o.y);
        let v_o = Vector2::new(xd_o.x, xd_o.y);
        let (sin_th, cos_th) = x_o.z.sin_cos();
        let w = self.baumgarte;
        let mi = &self.m_o_inv;

        // Object (ẋ_o, F_d) → unconstrained acceleration a0_o = M_o⁻¹(−F_d − C_o ẋ_o − G_o).
        let a0_o =
            mi.component_mul(&(-input.f_d - self.c_o.component_mul(&xd_o) - self.object.G_o));
        let a0_o_xy = Vector2::new(a0_o.x, a0_o.y);

        // Arm i (q_i, q̇_i, τ_i, x_o, ẋ_o) → a0_i = M_i⁻¹(τ_i − C_i q̇_i − G_i),
        // Y_i = M_i⁻¹ J_e,iᵀ, K_ii = J_e,i Y_i, d_i = (R(θ) r_i)^⊥ (so J_i = [I | d_i]) and
        // grasp i's right-hand side −Ȧṡ − A a0 − 2ω_b φ̇ − ω_b² φ.
        let mut a0 = [SVector::<f64, N>::zeros(); M];
        let mut y_blk = [SMatrix::<f64, N, 2>::zeros(); M];
        let mut k_blk = [Matrix2::zeros(); M];
        let mut d = [Vector2::zeros(); M];
        let mut rhs = SVector::<f64, NK>::zeros();
        for i in 0..M {
            let o = N * i;
            let blk = match arms[i].block(
                std::array::from_fn(|r| y[o + r]),
                std::array::from_fn(|r| y[n + 3 + o + r]),
                std::array::from_fn(|r| tau[o + r]),
                self.g,
            ) {
                Some(b) => b,
                None => return false,
            };
            a0[i] = blk.a0;
            y_blk[i] = blk.y;
            k_blk[i] = blk.k;
            // R(θ) r_i once; the grasp point, J_i ẋ_o and J̇_i ẋ_o = −R r_i θ̇² from it.
            let r = grasps[i].r;
            let rw = Vector2::new(cos_th * r.x - sin_th * r.y, sin_th * r.x + cos_th * r.y);
            d[i] = perp(rw);
            let phi = blk.p_ee - (p_o + rw);
            let phid = blk.v_ee - (v_o + d[i] * xd_o.z);
            let bias = blk.jdot_qdot + rw * (xd_o.z * xd_o.z);
            let ja0 = blk.j * a0[i] - (a0_o_xy + d[i] * a0_o.z);
            let rh = -bias - ja0 - 2.0 * w * phid - w * w * phi;
            rhs[2 * i] = rh.x;
            rhs[2 * i + 1] = rh.y;
        }
        // K = diag(K_ii) + 𝐉 M_o⁻¹ 𝐉ᵀ; with diagonal M_o⁻¹ its (i, j) block is
        // diag(m_x, m_y) + (m_θ d_i) d_jᵀ.
        let mut k = SMatrix::<f64, NK, NK>::zeros();
        for i in 0..M {
            for j in 0..M {
                let mut blk = (mi.z * d[i]) * d[j].transpose();
                blk[(0, 0)] += mi.x;
                blk[(1, 1)] += mi.y;
                if i == j {
                    blk = k_blk[i] + blk;
                }
                k.fixed_view_mut::<2, 2>(2 * i, 2 * j).copy_from(&blk);
            }
        }
        // K λ = rhs by the in-place Cholesky (regularised if K is singular); λ into rhs.
        let k_copy = k;
        match cholesky_in_place(&mut k, NK) {
            Ok(p) => ws.kkt_pivot = p,
            Err(_) => {
                let trace = k_copy.trace();
                k = k_copy;
                for dd in 0..NK {
                    k[(dd, dd)] += K_REG * trace.max(f64::MIN_POSITIVE);
                }
                ws.regularised += 1;
                ws.kkt_pivot = 0.0;
                if cholesky_in_place(&mut k, NK).is_err() {
                    return false;
                }
            }
        }
        cholesky_solve_in_place(&k, NK, rhs.as_mut_slice());

        // Accelerations: q̈_i = a0_i + Y_i λ_i; ẍ_o = a0_o − M_o⁻¹ Σ J_iᵀ λ_i.
        dy[..n].copy_from_slice(&y[n + 3..2 * n + 3]);
        dy[n..n + 3].copy_from_slice(xd_o.as_slice());
        let mut f_sum = Vector3::zeros();
        for i in 0..M {
            let lam = Vector2::new(rhs[2 * i], rhs[2 * i + 1]);
            forces[i] = lam;
            f_sum += Vector3::new(lam.x, lam.y, d[i].dot(&lam));
            let qdd = a0[i] + y_blk[i] * lam;
            dy[n + 3 + N * i..n + 3 + N * (i + 1)].copy_from_slice(qdd.as_slice());
        }
        let xdd = a0_o - mi.component_mul(&f_sum);
        ws.xdd_o = xdd;
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
        let rot = nalgebra::Rotation2::new(x_o.z);
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
            let jg = crate::grasp::Grasp::jacobian_from_arm(rw);
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
