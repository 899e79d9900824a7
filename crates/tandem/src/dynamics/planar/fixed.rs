//! Fixed-size evaluation paths of the planar arm for the constrained plant's hot path: the
//! [`FixedArm`] trait (an arm's [`ArmBlock`] on the stack), implemented by
//! [`TwoLinkArm`](super::TwoLinkArm) (closed forms) and [`FixedLinkArm`] (the general algorithm
//! for `N = 3, 4` in fixed-size types); the two-arm SSE2 code is in `pair.rs`.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

use super::general::perp;

/// An arm's block of the constrained plant's Schur-complement solve (SPEC §2.4), in fixed-size
/// types: what [`Plant::derivative`](crate::plant::planar::Plant::derivative) needs of arm `i` at one
/// state, computed by [`FixedArm::block`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmBlock<const N: usize> {
    /// Unconstrained acceleration `a_0 = M⁻¹(τ − C q̇ − G)`, rad/s².
    pub a0: SVector<f64, N>,
    /// `Y = M⁻¹ J_eᵀ`, N × 2.
    pub y: SMatrix<f64, N, 2>,
    /// `J_e Y = J_e M⁻¹ J_eᵀ`, the arm's diagonal block of the grasp-space matrix `K`.
    pub k: Matrix2<f64>,
    /// End-effector Jacobian `J_e`, 2 × N, m/rad.
    pub j: SMatrix<f64, 2, N>,
    /// End-effector position, m.
    pub p_ee: Vector2<f64>,
    /// End-effector velocity, m/s.
    pub v_ee: Vector2<f64>,
    /// `J̇_e q̇`, m/s².
    pub jdot_qdot: Vector2<f64>,
}

/// What the torque-dependent part of an arm's block needs of its state: the torque enters
/// (1) only through `a_0 = M⁻¹(τ − C q̇ − G)` (SPEC §2.4), so this is `M⁻¹` (or its Cholesky
/// factor) and the bias, kept from [`FixedArm::state_block`] for [`FixedArm::a0`].
/// Each kernel says how it fills the fields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmSolve<const N: usize> {
    /// [`TwoLinkArm`](super::TwoLinkArm) and 3-link [`FixedLinkArm`]: `M⁻¹ = adj M / det M`; 4-link: the
    /// Cholesky factor `L` of `M = L Lᵀ` (lower triangle).
    pub m: SMatrix<f64, N, N>,
    /// 4-link [`FixedLinkArm`]: `1 / L_ii` (zeros otherwise).
    pub inv_diag: SVector<f64, N>,
    /// [`TwoLinkArm`](super::TwoLinkArm): `C q̇`; [`FixedLinkArm`]: the whole bias `C q̇ + G`, N m.
    pub bias: SVector<f64, N>,
    /// [`TwoLinkArm`](super::TwoLinkArm): `G` (zeros for [`FixedLinkArm`]), N m.
    pub g: SVector<f64, N>,
}

/// An arm with a fixed link count `N` whose constrained-plant block ([`ArmBlock`]) is computed
/// entirely on the stack: [`TwoLinkArm`](super::TwoLinkArm) (`N = 2`, SPEC §2.1 closed forms) and
/// [`FixedLinkArm`] (`N = 3, 4`, the general algorithm in fixed-size types).
///
/// The block splits into a state part ([`state_block`](Self::state_block): everything but
/// `a_0`) and the torque part ([`a0`](Self::a0)), so that the plant can evaluate two torques at
/// one state ([`Plant::derivative_reusing`](crate::plant::planar::Plant::derivative_reusing)) with
/// one state part; [`block`](Self::block) is the two together, bit for bit the same values.
pub trait FixedArm<const N: usize>: Copy {
    /// The block at `(q, q̇)` with gravity `g` except `a_0` (left zero), and what
    /// [`a0`](Self::a0) needs; `None` if `M` is not positive definite.
    fn state_block(&self, q: [f64; N], qd: [f64; N], g: f64) -> Option<(ArmBlock<N>, ArmSolve<N>)>;
    /// `a_0 = M⁻¹(τ − C q̇ − G)` of (1) with `F = 0` (SPEC §2.4) from the state's
    /// [`ArmSolve`], in the same floating-point operations as [`block`](Self::block).
    fn a0(&self, s: &ArmSolve<N>, tau: [f64; N]) -> SVector<f64, N>;
    /// [`state_block`](Self::state_block) of two arms at once, the same values bit for bit
    /// (`None` if either `M` is not positive definite); by default one after the other.
    #[inline(always)]
    fn state_block_pair(
        arms: [&Self; 2],
        q: [[f64; N]; 2],
        qd: [[f64; N]; 2],
        g: f64,
    ) -> Option<[(ArmBlock<N>, ArmSolve<N>); 2]> {
        Some([
            arms[0].state_block(q[0], qd[0], g)?,
            arms[1].state_block(q[1], qd[1], g)?,
        ])
    }
    /// The block at `(q, q̇, τ)` with gravity `g`; `None` if `M` is not positive definite.
    #[inline(always)]
    fn block(&self, q: [f64; N], qd: [f64; N], tau: [f64; N], g: f64) -> Option<ArmBlock<N>> {
        let (mut b, s) = self.state_block(q, qd, g)?;
        b.a0 = self.a0(&s, tau);
        Some(b)
    }
}

/// The general n-link algorithms of this module (kinematics, composite-rigid-body `M`,
/// Christoffel `C`, `G`, Cholesky of `M`) for a fixed link count `N`: arrays and `SMatrix`
/// values on the stack, loops of constant trip count (unrolled, no bounds checks): the sums
/// of [`Arm::kinematics`](super::Arm::kinematics) and `M` of [`Arm::general_dynamics`](super::Arm::general_dynamics) in the same order (`M` filled
/// as a symmetric matrix from the lever arms `c_k − P_i`), the bias `C q̇ + G` in O(n²)
/// without forming `C` (`C q̇ = Σ_k m_k J_{c_k}ᵀ J̇_{c_k} q̇`, the Christoffel form), then
/// `a_0` and `M⁻¹ J_eᵀ` together: for `N = 3` by the closed-form inverse `adj M / det M` (a
/// short dependency chain: one division; the tick of two 3-link arms is latency-bound), else
/// by one Cholesky of `M` and the substitutions (by reciprocal pivots). Equal to the general
/// algorithm up to round-off. Built by [`Arm::fixed`](super::Arm::fixed) (`N = 3, 4` in the plant);
/// [`FixedLinkArm::kinematics_gravity`] is the controller's part of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedLinkArm<const N: usize> {
    pub(crate) base: Vector2<f64>,
    pub(crate) base_angle: f64,
    pub(crate) m: [f64; N],
    pub(crate) l: [f64; N],
    pub(crate) lc: [f64; N],
    pub(crate) inertia: [f64; N],
}

/// The absolute link angles `φ_k = base + Σ_{i≤k} q_i` and rates `φ̇_k = Σ_{i≤k} q̇_i` (the
/// running sums of [`Arm::kinematics`](super::Arm::kinematics), in its order) and the link directions
/// `u_k = (cos φ_k, sin φ_k)`, two links at a time by [`crate::math::trig::sin_cos2`] (the same
/// bits as one [`crate::math::trig::sin_cos`] a link, for about half the instructions; an odd last
/// link takes both lanes).
#[inline(always)]
pub(crate) fn link_dirs<const N: usize>(
    base_angle: f64,
    q: &[f64; N],
    qd: &[f64; N],
) -> ([f64; N], [Vector2<f64>; N]) {
    let mut phi = [0.0; N];
    let mut phid = [0.0; N];
    let (mut a, mut ad) = (base_angle, 0.0);
    for k in 0..N {
        a += q[k];
        ad += qd[k];
        phi[k] = a;
        phid[k] = ad;
    }
    let mut u = [Vector2::zeros(); N];
    let mut k = 0;
    while k < N {
        let k2 = if k + 1 < N { k + 1 } else { k };
        let [(s0, c0), (s1, c1)] = crate::math::trig::sin_cos2(phi[k], phi[k2]);
        u[k] = Vector2::new(c0, s0);
        u[k2] = Vector2::new(c1, s1);
        k += 2;
    }
    (phid, u)
}

impl<const N: usize> FixedArm<N> for FixedLinkArm<N> {
    /// The general algorithm in fixed-size types; keeps the bias `C q̇ + G` and `M⁻¹` (3 links)
    /// or the Cholesky factor of `M` (4 links).
    #[inline(always)]
    fn state_block(&self, q: [f64; N], qd: [f64; N], g: f64) -> Option<(ArmBlock<N>, ArmSolve<N>)> {
        // Forward pass (as `Arm::kinematics`): joint points, COMs and their velocities.
        // `acc[k]` = J̇_{c_k} q̇ + (0, g): the COM's velocity-product acceleration plus gravity
        // as an upward base acceleration (as in `Arm::rnea`).
        let mut points = [Vector2::zeros(); N];
        let mut com = [Vector2::zeros(); N];
        let mut acc = [Vector2::zeros(); N];
        let (phids, us) = link_dirs(self.base_angle, &q, &qd);
        let (mut p, mut pd) = (self.base, Vector2::zeros());
        let mut jdq = Vector2::zeros();
        let up_g = Vector2::new(0.0, g);
        for k in 0..N {
            let (phid, u) = (phids[k], us[k]);
            let up = perp(u);
            let w2 = phid * phid;
            points[k] = p;
            com[k] = p + self.lc[k] * u;
            acc[k] = jdq - (self.lc[k] * w2) * u + up_g;
            p += self.l[k] * u;
            pd += self.l[k] * phid * up;
            jdq -= self.l[k] * phid * phid * u;
        }
        let mut j = SMatrix::<f64, 2, N>::zeros();
        for i in 0..N {
            j.set_column(i, &perp(p - points[i]));
        }
        // M (the sums of `Arm::general_dynamics`, same order, filled as a symmetric matrix from
        // the lever arms r_ki = c_k − P_i) and the bias C q̇ + G without forming C: the columns
        // of J_{c_k} are r_ki^⊥, so (C q̇)_i = Σ_{k≥i} m_k r_ki^⊥ · (J̇_{c_k} q̇) (the Christoffel
        // form C = Σ_k m_k J_{c_k}ᵀ J̇_{c_k} of the module docs) and G_i = Σ_{k≥i} m_k r_ki^⊥ · (0, g).
        let mut r = [[Vector2::zeros(); N]; N];
        for k in 0..N {
            for i in 0..=k {
                r[k][i] = com[k] - points[i];
            }
        }
        let mut mm = SMatrix::<f64, N, N>::zeros();
        // The right-hand sides J_eᵀ (N × 2) and the bias C q̇ + G (a_0's is τ − bias: [`Self::a0`]).
        let mut rhs = SMatrix::<f64, N, 2>::zeros();
        let mut bias_v = SVector::<f64, N>::zeros();
        for i in 0..N {
            for jj in i..N {
                let mut mij = 0.0;
                for k in jj..N {
                    mij += self.m[k] * r[k][i].dot(&r[k][jj]) + self.inertia[k];
                }
                mm[(i, jj)] = mij;
                mm[(jj, i)] = mij;
            }
            let mut bias = 0.0;
            for k in i..N {
                bias += self.m[k] * perp(r[k][i]).dot(&acc[k]);
            }
            bias_v[i] = bias;
            rhs[(i, 0)] = j[(0, i)];
            rhs[(i, 1)] = j[(1, i)];
        }
        let mut solve = ArmSolve {
            m: SMatrix::zeros(),
            inv_diag: SVector::zeros(),
            bias: bias_v,
            g: SVector::zeros(),
        };
        if N == 3 {
            // a0 = M⁻¹(τ − C q̇ − G) and Y = M⁻¹ J_eᵀ with the closed-form inverse
            // M⁻¹ = adj M / det M (one division, independent products: a short dependency
            // chain, where the Cholesky's is three square roots and divisions long). M is
            // positive definite iff its leading minors M_00, M_00 M_11 − M_01², det M are
            // (Sylvester), as the Cholesky would find.
            let (m00, m01, m02) = (mm[(0, 0)], mm[(0, 1)], mm[(0, 2)]);
            let (m11, m12, m22) = (mm[(1, 1)], mm[(1, 2)], mm[(2, 2)]);
            let c00 = m11 * m22 - m12 * m12;
            let c01 = m02 * m12 - m01 * m22;
            let c02 = m01 * m12 - m02 * m11;
            let c11 = m00 * m22 - m02 * m02;
            let c12 = m01 * m02 - m00 * m12;
            let c22 = m00 * m11 - m01 * m01;
            let det = m00 * c00 + m01 * c01 + m02 * c02;
            if !(m00 > 0.0 && c22 > 0.0 && det > 0.0 && det.is_finite()) {
                return None;
            }
            let inv = 1.0 / det;
            let mut m_inv = SMatrix::<f64, N, N>::zeros();
            for (r, c, v) in [
                (0, 0, c00),
                (0, 1, c01),
                (0, 2, c02),
                (1, 1, c11),
                (1, 2, c12),
                (2, 2, c22),
            ] {
                m_inv[(r, c)] = v * inv;
                m_inv[(c, r)] = v * inv;
            }
            rhs = m_inv * rhs;
            solve.m = m_inv;
        } else {
            // Y = M⁻¹ J_eᵀ (and a0 = M⁻¹(τ − C q̇ − G) in `a0`): one Cholesky M = L Lᵀ (the
            // steps of `cholesky_in_place`), then both substitutions on each right-hand side.
            let mut lo = mm;
            let mut inv_diag = [0.0; N];
            for jj in 0..N {
                let mut dd = lo[(jj, jj)];
                for k in 0..jj {
                    dd -= lo[(jj, k)] * lo[(jj, k)];
                }
                if !(dd > 0.0) || !dd.is_finite() {
                    return None;
                }
                let ljj = dd.sqrt();
                lo[(jj, jj)] = ljj;
                inv_diag[jj] = 1.0 / ljj;
                for i in (jj + 1)..N {
                    let mut sum = lo[(i, jj)];
                    for k in 0..jj {
                        sum -= lo[(i, k)] * lo[(jj, k)];
                    }
                    lo[(i, jj)] = sum / ljj;
                }
            }
            for c in 0..2 {
                cholesky_substitute(&lo, &inv_diag, rhs.column_mut(c).as_mut_slice());
            }
            solve.m = lo;
            solve.inv_diag = SVector::from(inv_diag);
        }
        let y: SMatrix<f64, N, 2> = rhs;
        let mut kb = Matrix2::zeros();
        for a in 0..2 {
            for b in 0..2 {
                let mut sum = 0.0;
                for rr in 0..N {
                    sum += j[(a, rr)] * y[(rr, b)];
                }
                kb[(a, b)] = sum;
            }
        }
        let blk = ArmBlock {
            a0: SVector::zeros(),
            y,
            k: kb,
            j,
            p_ee: p,
            v_ee: pd,
            jdot_qdot: jdq,
        };
        Some((blk, solve))
    }

    /// On x86-64 the two arms in the two lanes of SSE2 registers (module `pair`): every operation
    /// of [`state_block`](FixedArm::state_block) once for both, in the same order (elsewhere
    /// the trait's default, one arm after the other).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn state_block_pair(
        arms: [&Self; 2],
        q: [[f64; N]; 2],
        qd: [[f64; N]; 2],
        g: f64,
    ) -> Option<[(ArmBlock<N>, ArmSolve<N>); 2]> {
        super::pair::fixed_state_block_pair(arms, q, qd, g)
    }

    /// `τ − bias`, then `M⁻¹` (3 links) or the two substitutions (4 links).
    #[inline(always)]
    fn a0(&self, s: &ArmSolve<N>, tau: [f64; N]) -> SVector<f64, N> {
        let mut b = SVector::<f64, N>::from_fn(|i, _| tau[i] - s.bias[i]);
        if N == 3 {
            s.m * b
        } else {
            let inv_diag: [f64; N] = std::array::from_fn(|i| s.inv_diag[i]);
            cholesky_substitute(&s.m, &inv_diag, b.as_mut_slice());
            b
        }
    }
}

/// `x = L⁻ᵀ L⁻¹ b` in place: `L z = b`, then `Lᵀ x = z`, by the reciprocal pivots `inv_diag`
/// (`1 / L_ii`) of the lower-triangular `L` (the substitutions of [`FixedLinkArm`]'s Cholesky).
#[inline(always)]
pub(crate) fn cholesky_substitute<const N: usize>(
    lo: &SMatrix<f64, N, N>,
    inv_diag: &[f64; N],
    b: &mut [f64],
) {
    for i in 0..N {
        let mut sum = b[i];
        for k in 0..i {
            sum -= lo[(i, k)] * b[k];
        }
        b[i] = sum * inv_diag[i];
    }
    for i in (0..N).rev() {
        let mut sum = b[i];
        for k in (i + 1)..N {
            sum -= lo[(k, i)] * b[k];
        }
        b[i] = sum * inv_diag[i];
    }
}

/// End-effector kinematics and gravity torques of an `N`-link arm at one state, in fixed-size
/// types: what the controller's tick needs of a redundant arm (its pose estimate, `J_eᵀ`, and
/// the null-space gravity compensation; SPEC §3 steps 1 and 5). Computed by
/// [`FixedLinkArm::kinematics_gravity`]; the same values, bit for bit, as the matching
/// [`ArmTerms`](super::ArmTerms) fields after [`Arm::kinematics`](super::Arm::kinematics) and [`Arm::general_dynamics`](super::Arm::general_dynamics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedKinematics<const N: usize> {
    /// End-effector Jacobian `J_e`, 2 × N, m/rad.
    pub j: SMatrix<f64, 2, N>,
    /// End-effector position `p_WE`, m.
    pub p_ee: Vector2<f64>,
    /// End-effector velocity `J_e q̇`, m/s.
    pub v_ee: Vector2<f64>,
    /// Gravity torques `G(q)`, N m.
    pub gravity: SVector<f64, N>,
}

impl<const N: usize> FixedLinkArm<N> {
    /// End-effector position, velocity and Jacobian, and the gravity torques
    /// `G_i = g Σ_{k≥i} m_k (c_k − P_i)_x` (module docs; gravity along −y, SPEC §1), at `(q, q̇)`:
    /// one `sin_cos` per link, no `M`, no `C`. The operations of [`Arm::kinematics`](super::Arm::kinematics) and of
    /// `G` in [`Arm::general_dynamics`](super::Arm::general_dynamics), in the same order, so the same bits.
    #[inline]
    pub fn kinematics_gravity(&self, q: [f64; N], qd: [f64; N], g: f64) -> FixedKinematics<N> {
        let mut points = [Vector2::zeros(); N];
        let mut com = [Vector2::zeros(); N];
        let (phids, us) = link_dirs(self.base_angle, &q, &qd);
        let (mut p, mut pd) = (self.base, Vector2::zeros());
        for k in 0..N {
            let (phid, u) = (phids[k], us[k]);
            points[k] = p;
            com[k] = p + self.lc[k] * u;
            p += self.l[k] * u;
            pd += self.l[k] * phid * perp(u);
        }
        let mut j = SMatrix::<f64, 2, N>::zeros();
        let mut gravity = SVector::<f64, N>::zeros();
        for i in 0..N {
            j.set_column(i, &perp(p - points[i]));
            let mut gi = 0.0;
            for k in i..N {
                gi += self.m[k] * (com[k] - points[i]).x;
            }
            gravity[i] = g * gi;
        }
        FixedKinematics {
            j,
            p_ee: p,
            v_ee: pd,
            gravity,
        }
    }
}
