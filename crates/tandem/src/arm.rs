//! Planar serial arms with revolute joints: kinematics and joint-space dynamics, paper (1)–(4).
//!
//! $$M(q)\ddot q + C(q,\dot q)\dot q + G(q) = \tau + J_e^\top(q) F$$
//!
//! where `F` is the force the object exerts on the end-effector (SPEC §1).
//!
//! Link `k` (0-based) spans joint point `P_k` to `P_{k+1}`, has mass `m_k`, length `l_k`, centre of
//! mass `c_k = P_k + l_{c,k} u(φ_k)` and inertia `I_k` about it; `φ_k = φ_base + Σ_{j≤k} q_j` is its
//! absolute angle and `u(φ) = (cos φ, sin φ)`. `P_0` is the base.
//!
//! # Algorithms (the general n-link case)
//! * kinematics: `J[:, i] = (P_n − P_i)^⊥`, `J̇[:, i] = (Ṗ_n − Ṗ_i)^⊥`, with `v^⊥ = (−v_y, v_x)`;
//!   `J̇ q̇ = −Σ_k l_k u(φ_k) φ̇_k²`.
//! * inertia (composite-rigid-body form): `M_ij = Σ_{k ≥ max(i,j)} m_k (c_k−P_i)·(c_k−P_j) + I_k`.
//! * Coriolis in Christoffel form: `C = Σ_k m_k J_{c_k}ᵀ J̇_{c_k}`, i.e.
//!   `C_ij = Σ_{k ≥ max(i,j)} m_k (c_k − P_i)·(ċ_k − Ṗ_j)`. Because the columns of `J_{c_k}` are
//!   gradients, `J_i·∂_k J_j` is symmetric in `(j, k)`, which makes this exactly the Christoffel
//!   matrix `C_ij = Σ_k Γ_ijk q̇_k`; `Ṁ − 2C = Σ m (J̇ᵀJ − JᵀJ̇)` is then skew (Property 1, (5)).
//! * gravity: `G_i = g Σ_{k≥i} m_k (c_k − P_i)_x` (gravity along −y, SPEC §1).
//! * inverse dynamics: recursive Newton–Euler ([`Arm::rnea`]), O(n), checked against `Mq̈+Cq̇+G`.
//! * forward dynamics: `q̈ = M⁻¹(τ + Jᵀ F − C q̇ − G)` by an in-place Cholesky.
//!
//! The 2-link arm has closed forms (SPEC §2.1, with its errata against the paper's Section V-A:
//! the paper's `C12`, `C21` give a wrong Coriolis vector, its `G1` squares lengths); they are a
//! fast path that the tests hold equal to the general algorithm.
//!
//! # Two evaluation paths
//! * [`ArmTerms`] (`DMatrix` blocks, per-link points, COMs and their velocities), filled by
//!   [`Arm::kinematics`] / [`Arm::dynamics`]: any link count; it serves the energy, RNEA, the
//!   general algorithm and the general plant.
//! * [`TwoLinkArm`] (from [`Arm::two_link`], selected once at construction): the 2-link closed
//!   forms end to end in `Matrix2`/`Vector2` values — link directions from one `sin_cos` per
//!   link ([`TwoLinkArm::pose`]) or from the inverse kinematics without transcendental calls
//!   ([`TwoLinkArm::ik_pose`]), then `M`, `C`, `G`, `J_e`, `J̇_e`, `J̇_e q̇`, `det M` in closed
//!   form ([`TwoLinkArm::terms`]), `M⁻¹` and the Cartesian terms (3)–(4) in closed form. Only
//!   end-effector quantities; the plant's hot paths use it.
//! * [`FixedLinkArm`] (from [`Arm::fixed`], for 3 and 4 links): the general algorithm in
//!   fixed-size arrays and `SMatrix` values, producing the constrained plant's per-arm
//!   [`ArmBlock`] (as [`TwoLinkArm`] does through [`FixedArm`] for 2 links), and the
//!   controller's per-tick `J_e`, end-effector state and `G` ([`FixedLinkArm::kinematics_gravity`]).
//!
//! Cartesian dynamics (3)–(4) for square (2-joint) arms: `M_x = J⁻ᵀ M J⁻¹`,
//! `C_x = J⁻ᵀ (C − M J⁻¹ J̇) J⁻¹` (the paper prints `J⁻ᵀ J̇`; SPEC §2.1), `G_x = J⁻ᵀ G`.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix2xX, SMatrix, SVector, Vector2};
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, non_negative, positive};
use crate::math::linalg::{cholesky_in_place, cholesky_solve_in_place};

/// Standard gravity used by the paper, m/s² (acts along −y).
pub const GRAVITY: f64 = 9.8;

/// One rigid link: plain data, validated by [`Arm::new`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkParams {
    /// Mass `m`, kg (> 0).
    pub mass: f64,
    /// Length `l` between the joint axes, m (> 0).
    pub length: f64,
    /// Distance `l_c` of the centre of mass from the proximal joint along the link, m (≥ 0).
    pub com: f64,
    /// Inertia `I` about the centre of mass, kg m² (≥ 0).
    pub inertia: f64,
}

/// Sign of the elbow angle `q_2` chosen by the analytic inverse kinematics of a 2-link arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Elbow {
    /// `q_2 > 0`.
    Positive,
    /// `q_2 < 0`.
    Negative,
}

impl Elbow {
    fn sign(self) -> f64 {
        match self {
            Elbow::Positive => 1.0,
            Elbow::Negative => -1.0,
        }
    }
}

/// Parameters of one planar arm: plain data, validated by [`Arm::new`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmParams {
    /// Base position `p_WB` in the world, m.
    pub base: [f64; 2],
    /// Base orientation (added to `q_1`), rad.
    #[serde(default)]
    pub base_angle: f64,
    /// Links from the base outwards.
    pub links: Vec<LinkParams>,
    /// Elbow branch for the analytic 2-link inverse kinematics.
    pub elbow: Elbow,
}

impl ArmParams {
    /// The paper's arm (Table I) with `l_c = l/2` (SPEC §2.1), based at `base`.
    pub fn paper(base: [f64; 2], elbow: Elbow) -> Self {
        ArmParams {
            base,
            base_angle: 0.0,
            links: vec![
                LinkParams {
                    mass: 2.0,
                    length: 0.3,
                    com: 0.15,
                    inertia: 0.045,
                },
                LinkParams {
                    mass: 0.85,
                    length: 0.3,
                    com: 0.15,
                    inertia: 0.019,
                },
            ],
            elbow,
        }
    }
}

/// A 2-link arm's fast path: the constants of the SPEC §2.1 closed forms and the geometry its
/// fixed-size kinematics need, computed once by [`Arm::new`] (see [`Arm::two_link`]).
///
/// Every method works on `Matrix2`/`Vector2` values on the stack: no `DMatrix` indexing, no
/// per-link `Vec` stores, at most one `sin_cos` per link ([`TwoLinkArm::pose`]) and none on the
/// inverse-kinematics route ([`TwoLinkArm::ik_pose`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLinkArm {
    base: Vector2<f64>,
    base_angle: f64,
    /// `(sin, cos)` of the base angle.
    base_sc: (f64, f64),
    l1: f64,
    l2: f64,
    /// `p1 = m1 lc1² + m2 (l1² + lc2²) + I1 + I2`, kg m².
    p1: f64,
    /// `p2 = m2 l1 lc2`, kg m².
    p2: f64,
    /// `p3 = m2 lc2² + I2`, kg m².
    p3: f64,
    /// `m1 lc1 + m2 l1`, kg m.
    g1: f64,
    /// `m2 lc2`, kg m.
    g2: f64,
    /// `p3 (p1 − p3)`: `det M = p3 (p1 − p3) − (p2 cos q2)²` without cancellation, kg² m⁴.
    det0: f64,
    /// Elbow sign `±1` of the inverse-kinematics branch.
    elbow: f64,
}

/// Link directions of a 2-link arm at one configuration (the output of
/// [`TwoLinkArm::pose`] or [`TwoLinkArm::ik_pose`]).
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLinkPose {
    /// `u(φ_1) = (cos φ_1, sin φ_1)`, link 1's world direction (`φ_1 = base angle + q_1`).
    pub u1: Vector2<f64>,
    /// `u(φ_2)`, link 2's world direction (`φ_2 = φ_1 + q_2`).
    pub u12: Vector2<f64>,
    /// `cos q_2`.
    pub c2: f64,
    /// `sin q_2`.
    pub s2: f64,
    /// End-effector Jacobian `J_e = [(l_1 u_1 + l_2 u_12)^⊥ | (l_2 u_12)^⊥]`, m/rad.
    pub J: Matrix2<f64>,
}

/// Kinematics and dynamics of a 2-link arm at one state in fixed-size types
/// ([`TwoLinkArm::terms`]); the same quantities as the matching [`ArmTerms`] fields.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLinkTerms {
    /// Joint-space inertia `M(q)`, kg m².
    pub M: Matrix2<f64>,
    /// Christoffel-form Coriolis matrix `C(q, q̇)`, kg m²/s.
    pub C: Matrix2<f64>,
    /// Gravity torques `G(q)`, N m.
    pub G: Vector2<f64>,
    /// End-effector Jacobian `J_e`, m/rad.
    pub J: Matrix2<f64>,
    /// `J̇_e`, m/(rad s).
    pub Jdot: Matrix2<f64>,
    /// `J̇_e q̇`, m/s².
    pub jdot_qdot: Vector2<f64>,
    /// End-effector position `p_WE`, m.
    pub p_ee: Vector2<f64>,
    /// End-effector velocity `J_e q̇`, m/s.
    pub v_ee: Vector2<f64>,
    /// `det M = p3 (p1 − p3) − (p2 cos q2)²` (> 0 for physical parameters), kg² m⁴.
    pub det_M: f64,
}

/// A validated, immutable planar arm.
#[derive(Clone, Debug)]
pub struct Arm {
    name: String,
    base: Vector2<f64>,
    base_angle: f64,
    m: Vec<f64>,
    l: Vec<f64>,
    lc: Vec<f64>,
    inertia: Vec<f64>,
    elbow: Elbow,
    /// The 2-link fast path, selected once here (`None` for other link counts).
    two: Option<TwoLinkArm>,
}

/// An arm's block of the constrained plant's Schur-complement solve (SPEC §2.4), in fixed-size
/// types: what [`Plant::derivative`](crate::plant::Plant::derivative) needs of arm `i` at one
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
    /// [`TwoLinkArm`] and 3-link [`FixedLinkArm`]: `M⁻¹ = adj M / det M`; 4-link: the
    /// Cholesky factor `L` of `M = L Lᵀ` (lower triangle).
    pub m: SMatrix<f64, N, N>,
    /// 4-link [`FixedLinkArm`]: `1 / L_ii` (zeros otherwise).
    pub inv_diag: SVector<f64, N>,
    /// [`TwoLinkArm`]: `C q̇`; [`FixedLinkArm`]: the whole bias `C q̇ + G`, N m.
    pub bias: SVector<f64, N>,
    /// [`TwoLinkArm`]: `G` (zeros for [`FixedLinkArm`]), N m.
    pub g: SVector<f64, N>,
}

/// An arm with a fixed link count `N` whose constrained-plant block ([`ArmBlock`]) is computed
/// entirely on the stack: [`TwoLinkArm`] (`N = 2`, SPEC §2.1 closed forms) and
/// [`FixedLinkArm`] (`N = 3, 4`, the general algorithm in fixed-size types).
///
/// The block splits into a state part ([`state_block`](Self::state_block): everything but
/// `a_0`) and the torque part ([`a0`](Self::a0)), so that the plant can evaluate two torques at
/// one state ([`Plant::derivative_reusing`](crate::plant::Plant::derivative_reusing)) with
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

impl FixedArm<2> for TwoLinkArm {
    /// Closed forms: [`TwoLinkArm::terms`], `M⁻¹ = adj M / det M`; keeps `M⁻¹`, `C q̇`, `G`.
    #[inline(always)]
    fn state_block(&self, q: [f64; 2], qd: [f64; 2], g: f64) -> Option<(ArmBlock<2>, ArmSolve<2>)> {
        let t = self.terms(&self.pose(q), qd, g);
        if !(t.det_M > 0.0) {
            return None;
        }
        let m_inv = t.m_inv();
        let y = m_inv * t.J.transpose();
        let blk = ArmBlock {
            a0: Vector2::zeros(),
            y,
            k: t.J * y,
            j: t.J,
            p_ee: t.p_ee,
            v_ee: t.v_ee,
            jdot_qdot: t.jdot_qdot,
        };
        let s = ArmSolve {
            m: m_inv,
            inv_diag: Vector2::zeros(),
            bias: t.C * Vector2::from(qd),
            g: t.G,
        };
        Some((blk, s))
    }
    /// On x86-64 the two arms in the two lanes of SSE2 registers (module `pair`): every operation
    /// of [`state_block`](FixedArm::state_block) (through [`TwoLinkArm::pose`],
    /// [`TwoLinkArm::terms`] and [`TwoLinkTerms::m_inv`]) once for both, in the same order
    /// (elsewhere the trait's default, one arm after the other).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn state_block_pair(
        arms: [&Self; 2],
        q: [[f64; 2]; 2],
        qd: [[f64; 2]; 2],
        g: f64,
    ) -> Option<[(ArmBlock<2>, ArmSolve<2>); 2]> {
        pair::state_block_pair(arms, q, qd, g)
    }
    /// `M⁻¹ ((τ − C q̇) − G)`.
    #[inline(always)]
    fn a0(&self, s: &ArmSolve<2>, tau: [f64; 2]) -> Vector2<f64> {
        s.m * (Vector2::new(tau[0], tau[1]) - s.bias - s.g)
    }
}

/// [`TwoLinkArm`]'s [`FixedArm::state_block`] of two arms in the two lanes of SSE2 registers
/// (part of the x86-64 baseline): lane 0 the first arm, lane 1 the second. Each lane performs
/// the scalar code's floating-point operations in its order (nalgebra's 2 × 2 products and
/// `dot` are two products and one sum; the sum commutes exactly), so the bits are the same;
/// negations are sign flips, as in the scalar code.
#[cfg(target_arch = "x86_64")]
mod pair {
    use std::arch::x86_64::{
        __m128d, _mm_add_pd, _mm_and_pd, _mm_cmpgt_pd, _mm_cmplt_pd, _mm_div_pd, _mm_movemask_pd,
        _mm_mul_pd, _mm_set_pd, _mm_set1_pd, _mm_setzero_pd, _mm_sqrt_pd, _mm_storeh_pd,
        _mm_storel_pd, _mm_storeu_pd, _mm_sub_pd, _mm_unpackhi_pd, _mm_unpacklo_pd, _mm_xor_pd,
    };
    use std::ops::{Add, Div, Mul, Neg, Sub};

    use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

    use super::{ArmBlock, ArmSolve, FixedLinkArm, TwoLinkArm};

    /// Two `f64` lanes.
    #[derive(Clone, Copy)]
    struct L(__m128d);

    impl L {
        #[inline(always)]
        fn new(a: f64, b: f64) -> L {
            // SAFETY: SSE2 (x86-64 baseline).
            L(unsafe { _mm_set_pd(b, a) })
        }
        #[inline(always)]
        fn splat(x: f64) -> L {
            // SAFETY: SSE2 (x86-64 baseline).
            L(unsafe { _mm_set1_pd(x) })
        }
        #[inline(always)]
        fn of<A>(arms: [&A; 2], f: impl Fn(&A) -> f64) -> L {
            L::new(f(arms[0]), f(arms[1]))
        }
        /// Whether `x > 0` in both lanes (false for NaN, as the scalar comparison).
        #[inline(always)]
        fn both_positive(self) -> bool {
            // SAFETY: SSE2 (x86-64 baseline).
            unsafe { _mm_movemask_pd(_mm_cmpgt_pd(self.0, _mm_setzero_pd())) == 3 }
        }
        /// Whether `0 < x < ∞` in both lanes (`x > 0.0 && x.is_finite()` of each; false for NaN).
        #[inline(always)]
        fn both_positive_finite(self) -> bool {
            // SAFETY: SSE2 (x86-64 baseline).
            unsafe {
                let pos = _mm_cmpgt_pd(self.0, _mm_setzero_pd());
                let fin = _mm_cmplt_pd(self.0, _mm_set1_pd(f64::INFINITY));
                _mm_movemask_pd(_mm_and_pd(pos, fin)) == 3
            }
        }
        /// `√x` per lane (correctly rounded, as `f64::sqrt`).
        #[inline(always)]
        fn sqrt(self) -> L {
            // SAFETY: SSE2 (x86-64 baseline).
            L(unsafe { _mm_sqrt_pd(self.0) })
        }
    }

    macro_rules! op {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl $tr for L {
                type Output = L;
                #[inline(always)]
                fn $f(self, o: L) -> L {
                    // SAFETY: SSE2 (x86-64 baseline).
                    L(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    op!(Add, add, _mm_add_pd);
    op!(Sub, sub, _mm_sub_pd);
    op!(Mul, mul, _mm_mul_pd);
    op!(Div, div, _mm_div_pd);

    impl Neg for L {
        type Output = L;
        #[inline(always)]
        fn neg(self) -> L {
            // SAFETY: SSE2 (x86-64 baseline); flips the sign bit, as scalar negation.
            L(unsafe { _mm_xor_pd(self.0, _mm_set1_pd(-0.0)) })
        }
    }

    /// The lanes `x = (x₀, x₁)`, `y = (y₀, y₁)` as the vectors `(x₀, y₀)`, `(x₁, y₁)`.
    #[inline(always)]
    fn split(x: L, y: L) -> [Vector2<f64>; 2] {
        let (mut a, mut b) = (Vector2::zeros(), Vector2::zeros());
        // SAFETY: SSE2 (x86-64 baseline); unaligned stores into two-element vectors.
        unsafe {
            _mm_storeu_pd(a.as_mut_ptr(), _mm_unpacklo_pd(x.0, y.0));
            _mm_storeu_pd(b.as_mut_ptr(), _mm_unpackhi_pd(x.0, y.0));
        }
        [a, b]
    }

    #[inline(always)]
    pub(super) fn state_block_pair(
        arms: [&TwoLinkArm; 2],
        q: [[f64; 2]; 2],
        qd: [[f64; 2]; 2],
        g: f64,
    ) -> Option<[(ArmBlock<2>, ArmSolve<2>); 2]> {
        let [a, b] = arms;
        // TwoLinkArm::pose: φ_1 = base angle + q_1, φ_2 = φ_1 + q_2 (scalars), one sin_cos2
        // per link of the two arms.
        let phi1 = [a.base_angle + q[0][0], b.base_angle + q[1][0]];
        let phi2 = [phi1[0] + q[0][1], phi1[1] + q[1][1]];
        let (s1, c1) = crate::math::trig::sin_cos2_pd(phi1[0], phi1[1]);
        let (s12, c12) = crate::math::trig::sin_cos2_pd(phi2[0], phi2[1]);
        let (s1, c1, s12, c12) = (L(s1), L(c1), L(s12), L(c12));
        // cos q2 = u_1 · u_12, sin q2 = u_1 × u_12.
        let c2 = c1 * c12 + s1 * s12;
        let s2 = c1 * s12 - s1 * c12;
        // pose_from_dirs: e_2 = l_2 u_12, e = l_1 u_1 + e_2, J = [[−e_y, −e_2y], [e_x, e_2x]].
        let (l1, l2) = (L::of(arms, |r| r.l1), L::of(arms, |r| r.l2));
        let (e2x, e2y) = (l2 * c12, l2 * s12);
        let (ex, ey) = (l1 * c1 + e2x, l1 * s1 + e2y);
        let j = [-ey, -e2y, ex, e2x];
        // terms: w_1 = q̇_1, w_2 = q̇_1 + q̇_2; v_1 = (l_1 w_1) u_1^⊥, v_2 = (l_2 w_2) u_12^⊥.
        let (qd0, qd1) = (L::new(qd[0][0], qd[1][0]), L::new(qd[0][1], qd[1][1]));
        let (w1, w2) = (qd0, qd0 + qd1);
        let (lw1, lw2) = (l1 * w1, l2 * w2);
        let vx = lw1 * -s1 + lw2 * -s12;
        let vy = lw1 * c1 + lw2 * c12;
        // mcg.
        let (p1, p2, p3) = (
            L::of(arms, |r| r.p1),
            L::of(arms, |r| r.p2),
            L::of(arms, |r| r.p3),
        );
        let m12 = p3 + p2 * c2;
        let m00 = p1 + L::splat(2.0) * p2 * c2;
        let h = p2 * s2;
        let c = [-h * qd1, -h * w2, h * qd0, L::splat(0.0)];
        let gl = L::splat(g);
        let g2c = L::of(arms, |r| r.g2) * gl * c12;
        let gv = [L::of(arms, |r| r.g1) * gl * c1 + g2c, g2c];
        let p2c2 = p2 * c2;
        // J̇_e q̇ = −(l_1 w_1 w_1) u_1 − (l_2 w_2 w_2) u_12; p_E = base + l_1 u_1 + l_2 u_12.
        let (aa, bb) = (-(lw1 * w1), lw2 * w2);
        let jdq = [aa * c1 - bb * c12, aa * s1 - bb * s12];
        let p_ee = [
            L::of(arms, |r| r.base.x) + l1 * c1 + l2 * c12,
            L::of(arms, |r| r.base.y) + l1 * s1 + l2 * s12,
        ];
        let det = L::of(arms, |r| r.det0) - p2c2 * p2c2;
        if !det.both_positive() {
            return None;
        }
        // M⁻¹ = [[M_11, −M_01], [−M_10, M_00]] · (1 / det M).
        // SAFETY: SSE2 (x86-64 baseline).
        let inv = L(unsafe { _mm_div_pd(_mm_set1_pd(1.0), det.0) });
        let mi = [p3 * inv, -m12 * inv, -m12 * inv, m00 * inv];
        // Y = M⁻¹ J_eᵀ: Y_rc = M⁻¹_r0 J_c0 + M⁻¹_r1 J_c1; K = J_e Y.
        let y = [
            mi[0] * j[0] + mi[1] * j[1],
            mi[0] * j[2] + mi[1] * j[3],
            mi[2] * j[0] + mi[3] * j[1],
            mi[2] * j[2] + mi[3] * j[3],
        ];
        let k = [
            j[0] * y[0] + j[1] * y[2],
            j[0] * y[1] + j[1] * y[3],
            j[2] * y[0] + j[3] * y[2],
            j[2] * y[1] + j[3] * y[3],
        ];
        // C q̇.
        let bias = [c[0] * qd0 + c[1] * qd1, c[2] * qd0 + c[3] * qd1];

        // Out of the lanes: (x, y) lanes → the first arm's vector (x₀, y₀), the second's
        // (x₁, y₁), one unpack each; a matrix from its columns (nalgebra is column-major).
        let m = |m: [L; 4]| {
            let ([a0, b0], [a1, b1]) = (split(m[0], m[2]), split(m[1], m[3]));
            [
                Matrix2::from_columns(&[a0, a1]),
                Matrix2::from_columns(&[b0, b1]),
            ]
        };
        let ([ya, yb], [ka, kb], [ja, jb], [ma, mb]) = (m(y), m(k), m(j), m(mi));
        let [pa, pb] = split(p_ee[0], p_ee[1]);
        let [va, vb] = split(vx, vy);
        let [da, db] = split(jdq[0], jdq[1]);
        let [ba, bb] = split(bias[0], bias[1]);
        let [ga, gb] = split(gv[0], gv[1]);
        let out = |y, k, j, p_ee, v_ee, jdot_qdot, m, bias, g| {
            (
                ArmBlock {
                    a0: Vector2::zeros(),
                    y,
                    k,
                    j,
                    p_ee,
                    v_ee,
                    jdot_qdot,
                },
                ArmSolve {
                    m,
                    inv_diag: Vector2::zeros(),
                    bias,
                    g,
                },
            )
        };
        Some([
            out(ya, ka, ja, pa, va, da, ma, ba, ga),
            out(yb, kb, jb, pb, vb, db, mb, bb, gb),
        ])
    }

    /// [`FixedLinkArm`]'s [`FixedArm::state_block`](super::FixedArm::state_block) of two arms in
    /// the lanes: the scalar code's loops, each operation once for both arms in its order
    /// (nalgebra's `dot` and the `N × N` by `N × 2` product `M⁻¹ J_eᵀ` as left-to-right sums of
    /// products, as nalgebra's small-matrix `gemv` does them; additions of `0.0` kept, as they
    /// are not no-ops for `−0.0`); `None` when either arm's `M` is not positive definite.
    #[inline(always)]
    pub(super) fn fixed_state_block_pair<const N: usize>(
        arms: [&FixedLinkArm<N>; 2],
        q: [[f64; N]; 2],
        qd: [[f64; N]; 2],
        g: f64,
    ) -> Option<[(ArmBlock<N>, ArmSolve<N>); 2]> {
        let zero = L::splat(0.0);
        // link_dirs: the running sums (the angles as scalars, per arm; the rates in lanes),
        // then each link's direction of the two arms by one sin_cos2 (the same bits as
        // sin_cos of each angle, as the scalar code's).
        let mut phi = [[0.0; N]; 2];
        for (s, (arm, qs)) in [(arms[0], &q[0]), (arms[1], &q[1])].into_iter().enumerate() {
            let mut a = arm.base_angle;
            for k in 0..N {
                a += qs[k];
                phi[s][k] = a;
            }
        }
        let mut phids = [zero; N];
        let mut ad = zero;
        for k in 0..N {
            ad = ad + L::new(qd[0][k], qd[1][k]);
            phids[k] = ad;
        }
        // Forward pass: joint points, COMs, acc_k = J̇_{c_k} q̇ + (0, g).
        let mut pts = [[zero; 2]; N];
        let mut com = [[zero; 2]; N];
        let mut acc = [[zero; 2]; N];
        let (mut px, mut py) = (L::of(arms, |r| r.base.x), L::of(arms, |r| r.base.y));
        let (mut pdx, mut pdy) = (zero, zero);
        let (mut jx, mut jy) = (zero, zero);
        let gl = L::splat(g);
        for k in 0..N {
            let (s, c) = crate::math::trig::sin_cos2_pd(phi[0][k], phi[1][k]);
            let (s, c) = (L(s), L(c));
            let phid = phids[k];
            let (lc, l) = (L::of(arms, |r| r.lc[k]), L::of(arms, |r| r.l[k]));
            let w2 = phid * phid;
            pts[k] = [px, py];
            com[k] = [px + lc * c, py + lc * s];
            let t = lc * w2;
            acc[k] = [(jx - t * c) + zero, (jy - t * s) + gl];
            px = px + l * c;
            py = py + l * s;
            let lp = l * phid;
            pdx = pdx + lp * -s;
            pdy = pdy + lp * c;
            let lpp = lp * phid;
            jx = jx - lpp * c;
            jy = jy - lpp * s;
        }
        // J_e columns perp(p − P_i); r_ki = c_k − P_i.
        let mut j = [[zero; N]; 2];
        for i in 0..N {
            j[0][i] = -(py - pts[i][1]);
            j[1][i] = px - pts[i][0];
        }
        let mut r = [[[zero; 2]; N]; N];
        for k in 0..N {
            for i in 0..=k {
                r[k][i] = [com[k][0] - pts[i][0], com[k][1] - pts[i][1]];
            }
        }
        let mut mm = [[zero; N]; N];
        let mut rhs = [[zero; 2]; N];
        let mut bias_v = [zero; N];
        for i in 0..N {
            for jj in i..N {
                let mut mij = zero;
                for k in jj..N {
                    let (m, ine) = (L::of(arms, |a| a.m[k]), L::of(arms, |a| a.inertia[k]));
                    let dot = r[k][i][0] * r[k][jj][0] + r[k][i][1] * r[k][jj][1];
                    mij = mij + (m * dot + ine);
                }
                mm[i][jj] = mij;
                mm[jj][i] = mij;
            }
            let mut bias = zero;
            for k in i..N {
                let m = L::of(arms, |a| a.m[k]);
                let dot = -r[k][i][1] * acc[k][0] + r[k][i][0] * acc[k][1];
                bias = bias + m * dot;
            }
            bias_v[i] = bias;
            rhs[i] = [j[0][i], j[1][i]];
        }
        let mut sm = [[zero; N]; N];
        let mut inv_diag = [zero; N];
        if N == 3 {
            // Closed-form inverse adj M / det M, Sylvester's minors.
            let (m00, m01, m02) = (mm[0][0], mm[0][1], mm[0][2]);
            let (m11, m12, m22) = (mm[1][1], mm[1][2], mm[2][2]);
            let c00 = m11 * m22 - m12 * m12;
            let c01 = m02 * m12 - m01 * m22;
            let c02 = m01 * m12 - m02 * m11;
            let c11 = m00 * m22 - m02 * m02;
            let c12 = m01 * m02 - m00 * m12;
            let c22 = m00 * m11 - m01 * m01;
            let det = m00 * c00 + m01 * c01 + m02 * c02;
            if !(m00.both_positive() && c22.both_positive() && det.both_positive_finite()) {
                return None;
            }
            let inv = L::splat(1.0) / det;
            for (rr, cc, v) in [
                (0, 0, c00),
                (0, 1, c01),
                (0, 2, c02),
                (1, 1, c11),
                (1, 2, c12),
                (2, 2, c22),
            ] {
                sm[rr][cc] = v * inv;
                sm[cc][rr] = v * inv;
            }
            // M⁻¹ J_eᵀ: nalgebra's gemv, y = col_0 x_0, then y += col_k x_k.
            let mut y = [[zero; 2]; N];
            for cc in 0..2 {
                for rr in 0..N {
                    let mut sum = sm[rr][0] * rhs[0][cc];
                    for k in 1..N {
                        sum = sum + sm[rr][k] * rhs[k][cc];
                    }
                    y[rr][cc] = sum;
                }
            }
            rhs = y;
        } else {
            // Cholesky M = L Lᵀ (upper triangle left as M's), then both substitutions.
            let mut lo = mm;
            for jj in 0..N {
                let mut dd = lo[jj][jj];
                for k in 0..jj {
                    dd = dd - lo[jj][k] * lo[jj][k];
                }
                if !dd.both_positive_finite() {
                    return None;
                }
                let ljj = dd.sqrt();
                lo[jj][jj] = ljj;
                inv_diag[jj] = L::splat(1.0) / ljj;
                for i in (jj + 1)..N {
                    let mut sum = lo[i][jj];
                    for k in 0..jj {
                        sum = sum - lo[i][k] * lo[jj][k];
                    }
                    lo[i][jj] = sum / ljj;
                }
            }
            for cc in 0..2 {
                let mut b = [zero; N];
                for i in 0..N {
                    b[i] = rhs[i][cc];
                }
                for i in 0..N {
                    let mut sum = b[i];
                    for k in 0..i {
                        sum = sum - lo[i][k] * b[k];
                    }
                    b[i] = sum * inv_diag[i];
                }
                for i in (0..N).rev() {
                    let mut sum = b[i];
                    for k in (i + 1)..N {
                        sum = sum - lo[k][i] * b[k];
                    }
                    b[i] = sum * inv_diag[i];
                }
                for i in 0..N {
                    rhs[i][cc] = b[i];
                }
            }
            sm = lo;
        }
        let y = rhs;
        let mut kb = [[zero; 2]; 2];
        for a in 0..2 {
            for b in 0..2 {
                let mut sum = zero;
                for rr in 0..N {
                    sum = sum + j[a][rr] * y[rr][b];
                }
                kb[a][b] = sum;
            }
        }

        // Out of the lanes: each lane stored straight into its arm's field.
        let zb = || {
            (
                ArmBlock {
                    a0: SVector::zeros(),
                    y: SMatrix::zeros(),
                    k: Matrix2::zeros(),
                    j: SMatrix::zeros(),
                    p_ee: Vector2::zeros(),
                    v_ee: Vector2::zeros(),
                    jdot_qdot: Vector2::zeros(),
                },
                ArmSolve {
                    m: SMatrix::zeros(),
                    inv_diag: SVector::zeros(),
                    bias: SVector::zeros(),
                    g: SVector::zeros(),
                },
            )
        };
        let (mut oa, mut ob) = (zb(), zb());
        #[inline(always)]
        fn put(x: L, a: &mut f64, b: &mut f64) {
            // SAFETY: SSE2 (x86-64 baseline); stores of one lane each into an `f64`.
            unsafe {
                _mm_storel_pd(a, x.0);
                _mm_storeh_pd(b, x.0);
            }
        }
        for rr in 0..N {
            for cc in 0..2 {
                put(y[rr][cc], &mut oa.0.y[(rr, cc)], &mut ob.0.y[(rr, cc)]);
                put(j[cc][rr], &mut oa.0.j[(cc, rr)], &mut ob.0.j[(cc, rr)]);
            }
            for cc in 0..N {
                put(sm[rr][cc], &mut oa.1.m[(rr, cc)], &mut ob.1.m[(rr, cc)]);
            }
            if N != 3 {
                put(inv_diag[rr], &mut oa.1.inv_diag[rr], &mut ob.1.inv_diag[rr]);
            }
            put(bias_v[rr], &mut oa.1.bias[rr], &mut ob.1.bias[rr]);
        }
        for rr in 0..2 {
            for cc in 0..2 {
                put(kb[rr][cc], &mut oa.0.k[(rr, cc)], &mut ob.0.k[(rr, cc)]);
            }
        }
        put(px, &mut oa.0.p_ee.x, &mut ob.0.p_ee.x);
        put(py, &mut oa.0.p_ee.y, &mut ob.0.p_ee.y);
        put(pdx, &mut oa.0.v_ee.x, &mut ob.0.v_ee.x);
        put(pdy, &mut oa.0.v_ee.y, &mut ob.0.v_ee.y);
        put(jx, &mut oa.0.jdot_qdot.x, &mut ob.0.jdot_qdot.x);
        put(jy, &mut oa.0.jdot_qdot.y, &mut ob.0.jdot_qdot.y);
        Some([oa, ob])
    }
}

/// The general n-link algorithms of this module (kinematics, composite-rigid-body `M`,
/// Christoffel `C`, `G`, Cholesky of `M`) for a fixed link count `N`: arrays and `SMatrix`
/// values on the stack, loops of constant trip count (unrolled, no bounds checks): the sums
/// of [`Arm::kinematics`] and `M` of [`Arm::general_dynamics`] in the same order (`M` filled
/// as a symmetric matrix from the lever arms `c_k − P_i`), the bias `C q̇ + G` in O(n²)
/// without forming `C` (`C q̇ = Σ_k m_k J_{c_k}ᵀ J̇_{c_k} q̇`, the Christoffel form), then
/// `a_0` and `M⁻¹ J_eᵀ` together: for `N = 3` by the closed-form inverse `adj M / det M` (a
/// short dependency chain: one division; the tick of two 3-link arms is latency-bound), else
/// by one Cholesky of `M` and the substitutions (by reciprocal pivots). Equal to the general
/// algorithm up to round-off. Built by [`Arm::fixed`] (`N = 3, 4` in the plant);
/// [`FixedLinkArm::kinematics_gravity`] is the controller's part of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedLinkArm<const N: usize> {
    base: Vector2<f64>,
    base_angle: f64,
    m: [f64; N],
    l: [f64; N],
    lc: [f64; N],
    inertia: [f64; N],
}

/// The absolute link angles `φ_k = base + Σ_{i≤k} q_i` and rates `φ̇_k = Σ_{i≤k} q̇_i` (the
/// running sums of [`Arm::kinematics`], in its order) and the link directions
/// `u_k = (cos φ_k, sin φ_k)`, two links at a time by [`crate::math::trig::sin_cos2`] (the same
/// bits as one [`crate::math::trig::sin_cos`] a link, for about half the instructions; an odd last
/// link takes both lanes).
#[inline(always)]
fn link_dirs<const N: usize>(
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
        pair::fixed_state_block_pair(arms, q, qd, g)
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
fn cholesky_substitute<const N: usize>(
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
/// [`ArmTerms`] fields after [`Arm::kinematics`] and [`Arm::general_dynamics`].
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
    /// one `sin_cos` per link, no `M`, no `C`. The operations of [`Arm::kinematics`] and of
    /// `G` in [`Arm::general_dynamics`], in the same order, so the same bits.
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

/// Per-arm scratch and results of one evaluation (the arm's part of the workspace).
///
/// Sized once by [`Arm::terms`]; filled by [`Arm::kinematics`] and [`Arm::dynamics`].
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct ArmTerms {
    /// Joint-space inertia `M(q)`, n × n, kg m².
    pub M: DMatrix<f64>,
    /// Christoffel-form Coriolis matrix `C(q, q̇)`, n × n, kg m²/s.
    pub C: DMatrix<f64>,
    /// Gravity torques `G(q)`, n, N m.
    pub G: DVector<f64>,
    /// End-effector Jacobian `J_e(q)`, 2 × n, m/rad.
    pub J: Matrix2xX<f64>,
    /// Its time derivative `J̇_e`, 2 × n.
    pub Jdot: Matrix2xX<f64>,
    /// `J̇_e q̇`, m/s².
    pub jdot_qdot: Vector2<f64>,
    /// End-effector position `p_WE`, m.
    pub p_ee: Vector2<f64>,
    /// End-effector velocity, m/s.
    pub v_ee: Vector2<f64>,
    /// Joint points `P_0 … P_n` (base first, end-effector last), m.
    pub points: Vec<Vector2<f64>>,
    points_dot: Vec<Vector2<f64>>,
    com: Vec<Vector2<f64>>,
    com_dot: Vec<Vector2<f64>>,
    phi: Vec<f64>,
    phi_dot: Vec<f64>,
    /// `u(φ_k) = (cos φ_k, sin φ_k)` per link.
    u: Vec<Vector2<f64>>,
    rnea_f: Vec<Vector2<f64>>,
    rnea_a: Vec<Vector2<f64>>,
    pub(crate) chol: DMatrix<f64>,
}

/// Cartesian-space dynamics (3)–(4) of a square arm.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug)]
pub struct Cartesian {
    /// `M_x = J⁻ᵀ M J⁻¹`, kg.
    pub M_x: Matrix2<f64>,
    /// `C_x = J⁻ᵀ (C − M J⁻¹ J̇) J⁻¹`, kg/s.
    pub C_x: Matrix2<f64>,
    /// `G_x = J⁻ᵀ G`, N.
    pub G_x: Vector2<f64>,
    /// `J⁻¹`, rad/m.
    pub J_inv: Matrix2<f64>,
}

/// Why the analytic inverse kinematics failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IkFailure {
    /// The point is farther than `l1 + l2` or nearer than `|l1 − l2|` from the base.
    OutOfReach {
        /// Distance from the base, m.
        distance: f64,
        /// Reachable annulus, m.
        min: f64,
        /// Reachable annulus, m.
        max: f64,
    },
    /// Analytic IK exists for 2-link arms only.
    NotTwoLink,
}

#[inline]
fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

#[inline]
fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

impl Arm {
    /// Validate `params` (masses and lengths > 0, `0 ≤ l_c ≤ l`, inertias ≥ 0); `name` (e.g.
    /// `arms[0]`) prefixes every error's parameter path.
    pub fn new(name: &str, params: &ArmParams) -> Result<Self, ModelError> {
        if params.links.is_empty() {
            return Err(ModelError::geometry(
                format!("{name}.links"),
                "an arm needs at least one link",
            ));
        }
        for (k, v) in params.base.iter().enumerate() {
            if !v.is_finite() {
                return Err(ModelError::invalid(
                    format!("{name}.base[{k}]"),
                    *v,
                    "must be finite",
                ));
            }
        }
        if !params.base_angle.is_finite() {
            return Err(ModelError::invalid(
                format!("{name}.base_angle"),
                params.base_angle,
                "must be finite",
            ));
        }
        let n = params.links.len();
        let (mut m, mut l, mut lc, mut inertia) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for (k, link) in params.links.iter().enumerate() {
            let p = |f: &str| format!("{name}.links[{k}].{f}");
            m.push(positive(&p("mass"), link.mass)?);
            l.push(positive(&p("length"), link.length)?);
            let c = non_negative(&p("com"), link.com)?;
            if c > link.length {
                return Err(ModelError::invalid(
                    p("com"),
                    c,
                    format!("must not exceed the link length {}", link.length),
                ));
            }
            lc.push(c);
            inertia.push(non_negative(&p("inertia"), link.inertia)?);
        }
        let base = Vector2::new(params.base[0], params.base[1]);
        let two = (n == 2).then(|| {
            let p1 = m[0] * lc[0] * lc[0]
                + m[1] * (l[0] * l[0] + lc[1] * lc[1])
                + inertia[0]
                + inertia[1];
            let p3 = m[1] * lc[1] * lc[1] + inertia[1];
            TwoLinkArm {
                base,
                base_angle: params.base_angle,
                base_sc: crate::math::trig::sin_cos(params.base_angle),
                l1: l[0],
                l2: l[1],
                p1,
                p2: m[1] * l[0] * lc[1],
                p3,
                g1: m[0] * lc[0] + m[1] * l[0],
                g2: m[1] * lc[1],
                det0: p3 * (p1 - p3),
                elbow: params.elbow.sign(),
            }
        });
        Ok(Arm {
            name: name.to_string(),
            base,
            base_angle: params.base_angle,
            m,
            l,
            lc,
            inertia,
            elbow: params.elbow,
            two,
        })
    }

    /// The name given at construction (e.g. `arms[0]`).
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.l.len()
    }
    /// Base position, m.
    pub fn base(&self) -> Vector2<f64> {
        self.base
    }
    /// Sum of link lengths (the reach), m.
    pub fn reach(&self) -> f64 {
        self.l.iter().sum()
    }
    /// Link lengths, m.
    pub fn lengths(&self) -> &[f64] {
        &self.l
    }
    /// Elbow branch.
    pub fn elbow(&self) -> Elbow {
        self.elbow
    }

    /// Allocate the per-arm scratch (once, outside any loop).
    pub fn terms(&self) -> ArmTerms {
        let n = self.dof();
        ArmTerms {
            M: DMatrix::zeros(n, n),
            C: DMatrix::zeros(n, n),
            G: DVector::zeros(n),
            J: Matrix2xX::zeros(n),
            Jdot: Matrix2xX::zeros(n),
            jdot_qdot: Vector2::zeros(),
            p_ee: Vector2::zeros(),
            v_ee: Vector2::zeros(),
            points: vec![Vector2::zeros(); n + 1],
            points_dot: vec![Vector2::zeros(); n + 1],
            com: vec![Vector2::zeros(); n],
            com_dot: vec![Vector2::zeros(); n],
            phi: vec![0.0; n],
            phi_dot: vec![0.0; n],
            u: vec![Vector2::zeros(); n],
            rnea_f: vec![Vector2::zeros(); n + 1],
            rnea_a: vec![Vector2::zeros(); n + 1],
            chol: DMatrix::zeros(n, n),
        }
    }

    /// End-effector position only (no scratch), m.
    pub fn forward_kinematics(&self, q: &[f64]) -> Vector2<f64> {
        let mut p = self.base;
        let mut phi = self.base_angle;
        for (k, &lk) in self.l.iter().enumerate() {
            phi += q[k];
            let (s, c) = crate::math::trig::sin_cos(phi);
            p += lk * Vector2::new(c, s);
        }
        p
    }

    /// Kinematics: joint points, COMs and their velocities, `J_e`, `J̇_e`, `J̇_e q̇`,
    /// end-effector position and velocity. Reads `(q, q̇)`; writes the kinematic fields of `t`.
    pub fn kinematics(&self, q: &[f64], qd: &[f64], t: &mut ArmTerms) {
        // The same body with the link count a constant for 2–4 links (unrolled loops).
        match self.dof() {
            2 => self.kinematics_n(2, q, qd, t),
            3 => self.kinematics_n(3, q, qd, t),
            4 => self.kinematics_n(4, q, qd, t),
            n => self.kinematics_n(n, q, qd, t),
        }
    }

    #[inline(always)]
    fn kinematics_n(&self, n: usize, q: &[f64], qd: &[f64], t: &mut ArmTerms) {
        debug_assert!(q.len() >= n && qd.len() >= n);
        let (q, qd) = (&q[..n], &qd[..n]);
        // One length check per buffer; then the loops index in range by construction.
        let (lc, l) = (&self.lc[..n], &self.l[..n]);
        let (phis, phi_dots, us) = (&mut t.phi[..n], &mut t.phi_dot[..n], &mut t.u[..n]);
        let (com, com_dot) = (&mut t.com[..n], &mut t.com_dot[..n]);
        let (points, points_dot) = (&mut t.points[..n + 1], &mut t.points_dot[..n + 1]);
        // Forward pass: absolute angles, joint points, COMs and their velocities.
        let mut phi = self.base_angle;
        let mut phid = 0.0;
        points[0] = self.base;
        points_dot[0] = Vector2::zeros();
        let mut jdq = Vector2::zeros();
        for k in 0..n {
            phi += q[k];
            phid += qd[k];
            phis[k] = phi;
            phi_dots[k] = phid;
            let (sk, ck) = crate::math::trig::sin_cos(phi);
            let u = Vector2::new(ck, sk);
            us[k] = u;
            let up = perp(u);
            com[k] = points[k] + lc[k] * u;
            com_dot[k] = points_dot[k] + lc[k] * phid * up;
            points[k + 1] = points[k] + l[k] * u;
            points_dot[k + 1] = points_dot[k] + l[k] * phid * up;
            jdq -= l[k] * phid * phid * u;
        }
        let pe = points[n];
        let ve = points_dot[n];
        let jm = &mut t.J.as_mut_slice()[..2 * n];
        let jdm = &mut t.Jdot.as_mut_slice()[..2 * n];
        for i in 0..n {
            let c = perp(pe - points[i]);
            jm[2 * i] = c.x;
            jm[2 * i + 1] = c.y;
            let cd = perp(ve - points_dot[i]);
            jdm[2 * i] = cd.x;
            jdm[2 * i + 1] = cd.y;
        }
        t.p_ee = pe;
        t.v_ee = ve;
        t.jdot_qdot = jdq;
    }

    /// Kinematics plus `M`, `C`, `G` (2-link closed forms when the arm has two links).
    /// Reads `(q, q̇, g)`; writes every field of `t`.
    pub fn dynamics(&self, q: &[f64], qd: &[f64], g: f64, t: &mut ArmTerms) {
        self.kinematics(q, qd, t);
        if let Some(k) = self.two {
            self.two_link_dynamics(&k, qd, g, t);
        } else {
            self.general_dynamics(g, t);
        }
    }

    /// The general algorithm for `M`, `C`, `G` (after [`Arm::kinematics`]); exposed so tests can
    /// compare it with the 2-link closed forms.
    ///
    /// For 3 and 4 links it runs a copy of the loops with the link count a constant (unrolled,
    /// no bounds checks; the same operations in the same order, so the same bits).
    pub fn general_dynamics(&self, g: f64, t: &mut ArmTerms) {
        match self.dof() {
            3 => self.general_dynamics_n::<3>(g, t),
            4 => self.general_dynamics_n::<4>(g, t),
            _ => self.general_dynamics_dyn(g, t),
        }
    }

    /// [`Arm::general_dynamics`] with the link count `N` a constant: one length check per
    /// buffer, then fixed-trip loops.
    #[inline]
    fn general_dynamics_n<const N: usize>(&self, g: f64, t: &mut ArmTerms) {
        let (m, inertia) = (&self.m[..N], &self.inertia[..N]);
        let (com, com_dot) = (&t.com[..N], &t.com_dot[..N]);
        let (points, points_dot) = (&t.points[..N], &t.points_dot[..N]);
        let mm = &mut t.M.as_mut_slice()[..N * N];
        let cc = &mut t.C.as_mut_slice()[..N * N];
        let gg = &mut t.G.as_mut_slice()[..N];
        // Lever arms c_k − P_i once; M_ji is M_ij (the same products, summed in the same
        // order), so only j ≥ i is summed.
        let mut r = [[Vector2::zeros(); N]; N];
        for k in 0..N {
            for i in 0..=k {
                r[k][i] = com[k] - points[i];
            }
        }
        for i in 0..N {
            for j in 0..N {
                let mut mij = 0.0;
                let mut cij = 0.0;
                for k in i.max(j)..N {
                    if j >= i {
                        mij += m[k] * r[k][i].dot(&r[k][j]) + inertia[k];
                    }
                    cij += m[k] * r[k][i].dot(&(com_dot[k] - points_dot[j]));
                }
                if j >= i {
                    mm[i + N * j] = mij;
                    mm[j + N * i] = mij;
                }
                cc[i + N * j] = cij;
            }
            let mut gi = 0.0;
            for k in i..N {
                gi += m[k] * r[k][i].x;
            }
            gg[i] = g * gi;
        }
    }

    fn general_dynamics_dyn(&self, g: f64, t: &mut ArmTerms) {
        let n = self.dof();
        for i in 0..n {
            for j in 0..n {
                let mut mij = 0.0;
                let mut cij = 0.0;
                for k in i.max(j)..n {
                    let ri = t.com[k] - t.points[i];
                    let rj = t.com[k] - t.points[j];
                    mij += self.m[k] * ri.dot(&rj) + self.inertia[k];
                    cij += self.m[k] * ri.dot(&(t.com_dot[k] - t.points_dot[j]));
                }
                t.M[(i, j)] = mij;
                t.C[(i, j)] = cij;
            }
            let mut gi = 0.0;
            for k in i..n {
                gi += self.m[k] * (t.com[k].x - t.points[i].x);
            }
            t.G[i] = g * gi;
        }
    }

    fn two_link_dynamics(&self, k: &TwoLinkArm, qd: &[f64], g: f64, t: &mut ArmTerms) {
        // SPEC §2.1 closed forms. The link directions u1 = u(q1), u12 = u(q1 + q2) come from
        // the kinematics pass: cos q2 = u1·u12, sin q2 = u1 × u12 (no further trigonometry).
        let (u1, u12) = (t.u[0], t.u[1]);
        let (m, c, gv) = k.mcg(u1.dot(&u12), cross(u1, u12), u1.x, u12.x, [qd[0], qd[1]], g);
        t.M.copy_from(&m);
        t.C.copy_from(&c);
        t.G.copy_from(&gv);
    }

    /// Recursive Newton–Euler inverse dynamics: `τ = M q̈ + C q̇ + G − J_eᵀ F_ext`, where
    /// `F_ext` is the force the environment (the object) exerts on the end-effector.
    /// Reads `(q, q̇, q̈, F_ext, g)`; writes `tau` (n) and the kinematic fields of `t`.
    pub fn rnea(
        &self,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        f_ext: Vector2<f64>,
        g: f64,
        t: &mut ArmTerms,
        tau: &mut [f64],
    ) {
        let n = self.dof();
        self.kinematics(q, qd, t);
        // Forward: joint-point accelerations, gravity as an upward base acceleration.
        t.rnea_a[0] = Vector2::new(0.0, g);
        let mut phidd = 0.0;
        for k in 0..n {
            phidd += qdd[k];
            let u = t.u[k];
            let w2 = t.phi_dot[k] * t.phi_dot[k];
            t.rnea_a[k + 1] = t.rnea_a[k] + self.l[k] * (perp(u) * phidd - u * w2);
        }
        // Backward: force f_k on link k from link k−1 and moment n_k about P_k.
        t.rnea_f[n] = -f_ext;
        let mut n_next = 0.0;
        let mut phidd_k = qdd.iter().take(n).sum::<f64>();
        for k in (0..n).rev() {
            let u = t.u[k];
            let w2 = t.phi_dot[k] * t.phi_dot[k];
            let a_c = t.rnea_a[k] + self.lc[k] * (perp(u) * phidd_k - u * w2);
            let ma = self.m[k] * a_c;
            let f_k = ma + t.rnea_f[k + 1];
            let n_k = self.inertia[k] * phidd_k
                + cross(t.com[k] - t.points[k], ma)
                + n_next
                + cross(t.points[k + 1] - t.points[k], t.rnea_f[k + 1]);
            t.rnea_f[k] = f_k;
            tau[k] = n_k;
            n_next = n_k;
            phidd_k -= qdd[k];
        }
    }

    /// Forward dynamics `q̈ = M⁻¹(τ + J_eᵀ F_ext − C q̇ − G)` (after [`Arm::dynamics`]).
    /// Returns `Err(joint)` if `M` is not positive definite (non-physical parameters).
    pub fn forward_dynamics(
        &self,
        qd: &[f64],
        tau: &[f64],
        f_ext: Vector2<f64>,
        t: &mut ArmTerms,
        qdd: &mut [f64],
    ) -> Result<(), usize> {
        let n = self.dof();
        for i in 0..n {
            let mut b = tau[i] + t.J[(0, i)] * f_ext.x + t.J[(1, i)] * f_ext.y - t.G[i];
            for j in 0..n {
                b -= t.C[(i, j)] * qd[j];
            }
            qdd[i] = b;
        }
        t.chol.copy_from(&t.M);
        cholesky_in_place(&mut t.chol, n)?;
        cholesky_solve_in_place(&t.chol, n, qdd);
        Ok(())
    }

    /// Analytic inverse kinematics of a 2-link arm on its elbow branch: joint angles that put
    /// the end-effector at `p_WE`.
    pub fn inverse_kinematics(&self, p_we: Vector2<f64>) -> Result<[f64; 2], IkFailure> {
        match &self.two {
            Some(k) => k.inverse_kinematics(p_we),
            None => Err(IkFailure::NotTwoLink),
        }
    }

    /// The fixed-size kernel of an `N`-link arm ([`FixedLinkArm`]), `None` unless the arm has
    /// exactly `N` links.
    pub fn fixed<const N: usize>(&self) -> Option<FixedLinkArm<N>> {
        (self.dof() == N).then(|| {
            let arr = |v: &[f64]| std::array::from_fn(|k| v[k]);
            FixedLinkArm {
                base: self.base,
                base_angle: self.base_angle,
                m: arr(&self.m),
                l: arr(&self.l),
                lc: arr(&self.lc),
                inertia: arr(&self.inertia),
            }
        })
    }

    /// The 2-link fast path (fixed-size kinematics and dynamics), `None` unless the arm has
    /// exactly two links. Selected once at construction.
    pub fn two_link(&self) -> Option<&TwoLinkArm> {
        self.two.as_ref()
    }

    /// Cartesian dynamics (3)–(4) of a square (2-joint) arm after [`Arm::dynamics`];
    /// `None` when the arm is not square or `J_e` is singular (|det J| < `min_det`).
    pub fn cartesian(&self, t: &ArmTerms, min_det: f64) -> Option<Cartesian> {
        if self.dof() != 2 {
            return None;
        }
        let m2 = |a: &DMatrix<f64>| Matrix2::new(a[(0, 0)], a[(0, 1)], a[(1, 0)], a[(1, 1)]);
        let j = Matrix2::new(t.J[(0, 0)], t.J[(0, 1)], t.J[(1, 0)], t.J[(1, 1)]);
        let jd = Matrix2::new(
            t.Jdot[(0, 0)],
            t.Jdot[(0, 1)],
            t.Jdot[(1, 0)],
            t.Jdot[(1, 1)],
        );
        cartesian_2x2(
            &j,
            &m2(&t.M),
            &m2(&t.C),
            &jd,
            &Vector2::new(t.G[0], t.G[1]),
            min_det,
        )
    }

    /// Smallest singular value of `J_e` after [`Arm::kinematics`] (2 × n), m/rad.
    pub fn min_singular_value(&self, t: &ArmTerms) -> f64 {
        // Eigenvalues of the 2×2 J Jᵀ.
        let mut a = 0.0;
        let mut b = 0.0;
        let mut d = 0.0;
        for i in 0..self.dof() {
            let (x, y) = (t.J[(0, i)], t.J[(1, i)]);
            a += x * x;
            b += x * y;
            d += y * y;
        }
        let tr = a + d;
        let disc = ((a - d) * (a - d) + 4.0 * b * b).sqrt();
        (0.5 * (tr - disc)).max(0.0).sqrt()
    }

    /// Kinetic and potential energy of the arm after [`Arm::dynamics`], J.
    pub fn energy(&self, qd: &[f64], g: f64, t: &ArmTerms) -> (f64, f64) {
        let n = self.dof();
        let mut ke = 0.0;
        for i in 0..n {
            for j in 0..n {
                ke += 0.5 * qd[i] * t.M[(i, j)] * qd[j];
            }
        }
        let pe = (0..n).map(|k| self.m[k] * g * t.com[k].y).sum();
        (ke, pe)
    }
}

/// Cartesian dynamics (3)–(4) from 2×2 joint-space terms: `M_x = J⁻ᵀ M J⁻¹`,
/// `C_x = J⁻ᵀ (C − M J⁻¹ J̇) J⁻¹`, `G_x = J⁻ᵀ G` (SPEC §2.1); `None` when |det J| < `min_det`.
#[inline]
fn cartesian_2x2(
    j: &Matrix2<f64>,
    m: &Matrix2<f64>,
    c: &Matrix2<f64>,
    jd: &Matrix2<f64>,
    g: &Vector2<f64>,
    min_det: f64,
) -> Option<Cartesian> {
    let det = j.determinant();
    if !(det.abs() >= min_det) {
        return None;
    }
    let ji = Matrix2::new(j[(1, 1)], -j[(0, 1)], -j[(1, 0)], j[(0, 0)]) * (1.0 / det);
    let jit = ji.transpose();
    let m_x = jit * m * ji;
    let c_x = jit * (c - m * ji * jd) * ji;
    let g_x = jit * g;
    Some(Cartesian {
        M_x: m_x,
        C_x: c_x,
        G_x: g_x,
        J_inv: ji,
    })
}

impl TwoLinkArm {
    /// SPEC §2.1 closed forms `(M, C, G)` from `cos q2`, `sin q2`, the world-frame cosines
    /// `cos φ_1`, `cos φ_2` of the two links (gravity acts along −y) and `q̇`.
    #[inline]
    fn mcg(
        &self,
        c2: f64,
        s2: f64,
        cos_phi1: f64,
        cos_phi2: f64,
        qd: [f64; 2],
        g: f64,
    ) -> (Matrix2<f64>, Matrix2<f64>, Vector2<f64>) {
        let m12 = self.p3 + self.p2 * c2;
        let m = Matrix2::new(self.p1 + 2.0 * self.p2 * c2, m12, m12, self.p3);
        let h = self.p2 * s2;
        let c = Matrix2::new(-h * qd[1], -h * (qd[0] + qd[1]), h * qd[0], 0.0);
        let gv = Vector2::new(
            self.g1 * g * cos_phi1 + self.g2 * g * cos_phi2,
            self.g2 * g * cos_phi2,
        );
        (m, c, gv)
    }

    /// Pose from link directions: fills `J_e = [(l_1 u_1 + l_2 u_12)^⊥ | (l_2 u_12)^⊥]`.
    #[inline]
    fn pose_from_dirs(&self, u1: Vector2<f64>, u12: Vector2<f64>, c2: f64, s2: f64) -> TwoLinkPose {
        let e2 = self.l2 * u12;
        let e = self.l1 * u1 + e2;
        TwoLinkPose {
            u1,
            u12,
            c2,
            s2,
            J: Matrix2::new(-e.y, -e2.y, e.x, e2.x),
        }
    }

    /// Pose at joint angles `q`: one `sin_cos` per link, accumulated as [`Arm::kinematics`]
    /// does (`φ_1 = base angle + q_1`, `φ_2 = φ_1 + q_2`), so the directions are bitwise those
    /// of the general path; `cos q2 = u_1·u_12`, `sin q2 = u_1 × u_12`. Inlined into every
    /// caller (the plant's and the controller's hot paths), so that the two `sin_cos2` lanes
    /// overlap with the caller's other work.
    #[inline(always)]
    pub fn pose(&self, q: [f64; 2]) -> TwoLinkPose {
        let phi1 = self.base_angle + q[0];
        let phi2 = phi1 + q[1];
        let [(s1, c1), (s12, c12)] = crate::math::trig::sin_cos2(phi1, phi2);
        let u1 = Vector2::new(c1, s1);
        let u12 = Vector2::new(c12, s12);
        self.pose_from_dirs(u1, u12, u1.dot(&u12), cross(u1, u12))
    }

    /// End-effector position `p_WE = base + l_1 u_1 + l_2 u_12` at a pose, m.
    #[inline]
    pub fn end_effector(&self, pose: &TwoLinkPose) -> Vector2<f64> {
        self.base + self.l1 * pose.u1 + self.l2 * pose.u12
    }

    /// Target in the base frame and `cos q2` from the law of cosines; the reach check.
    /// Returns `(x, y, x² + y², cos q2)`.
    #[inline]
    fn ik_cos_q2(&self, p_we: Vector2<f64>) -> Result<(f64, f64, f64, f64), IkFailure> {
        let (l1, l2) = (self.l1, self.l2);
        let d = p_we - self.base;
        let (sb, cb) = self.base_sc;
        let x = cb * d.x + sb * d.y;
        let y = -sb * d.x + cb * d.y;
        let r2 = x * x + y * y;
        let c2 = (r2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
        if !(-1.0..=1.0).contains(&c2) {
            return Err(IkFailure::OutOfReach {
                distance: r2.sqrt(),
                min: (l1 - l2).abs(),
                max: l1 + l2,
            });
        }
        Ok((x, y, r2, c2))
    }

    /// Analytic inverse kinematics on the elbow branch, as angles
    /// (`q2 = ±acos c2`, `q1 = atan2(y, x) − atan2(l2 sin q2, l1 + l2 cos q2)`).
    pub fn inverse_kinematics(&self, p_we: Vector2<f64>) -> Result<[f64; 2], IkFailure> {
        let (x, y, _, c2) = self.ik_cos_q2(p_we)?;
        let (l1, l2) = (self.l1, self.l2);
        let q2 = self.elbow * c2.acos();
        let q1 = y.atan2(x) - (l2 * q2.sin()).atan2(l1 + l2 * q2.cos());
        Ok([q1, q2])
    }

    /// The same inverse kinematics as [`TwoLinkArm::inverse_kinematics`], as link directions
    /// and without transcendental calls (two `sqrt`, one division): `sin q2 = ±√((1 − c2)(1 + c2))`
    /// on the elbow branch, and `u(q_1)` is `(x, y)` rotated back by the angle of
    /// `k = (l1 + l2 c2, l2 s2)`: `(x k1 + y k2, y k1 − x k2) / (|(x, y)| |k|)`. (`|k| = r` by
    /// the law of cosines, but only to `ε (l1² + l2²) / r²`, which grows near a folded arm; the
    /// explicit norm keeps `|u_1| = 1` to ε.) Equal to the angle route up to round-off.
    #[inline]
    pub fn ik_pose(&self, p_we: Vector2<f64>) -> Result<TwoLinkPose, IkFailure> {
        let (x, y, r2, c2) = self.ik_cos_q2(p_we)?;
        let s2 = self.elbow * ((1.0 - c2) * (1.0 + c2)).sqrt();
        let k1 = self.l1 + self.l2 * c2;
        let k2 = self.l2 * s2;
        let inv_rk = 1.0 / (r2 * (k1 * k1 + k2 * k2)).sqrt();
        let (cq1, sq1) = ((x * k1 + y * k2) * inv_rk, (y * k1 - x * k2) * inv_rk);
        // World direction of link 1 (φ_1 = base angle + q_1), then link 2 (φ_2 = φ_1 + q_2).
        let (sb, cb) = self.base_sc;
        let u1 = Vector2::new(cb * cq1 - sb * sq1, sb * cq1 + cb * sq1);
        let u12 = Vector2::new(c2 * u1.x - s2 * u1.y, s2 * u1.x + c2 * u1.y);
        Ok(self.pose_from_dirs(u1, u12, c2, s2))
    }

    /// Kinematics and dynamics at `(pose, q̇)`: reads the pose's directions and Jacobian;
    /// writes every field of the result (SPEC §2.1 closed forms for `M`, `C`, `G`;
    /// `J̇_e = [v_E^⊥ | (l_2 φ̇_2 u_12^⊥)^⊥]`, `J̇_e q̇ = −l_1 φ̇_1² u_1 − l_2 φ̇_2² u_12`).
    #[inline]
    pub fn terms(&self, pose: &TwoLinkPose, qd: [f64; 2], g: f64) -> TwoLinkTerms {
        let (u1, u12) = (pose.u1, pose.u12);
        let (w1, w2) = (qd[0], qd[0] + qd[1]);
        let v1 = self.l1 * w1 * perp(u1);
        let v2 = self.l2 * w2 * perp(u12);
        let v_ee = v1 + v2;
        let (m, c, gv) = self.mcg(pose.c2, pose.s2, u1.x, u12.x, qd, g);
        let p2c2 = self.p2 * pose.c2;
        TwoLinkTerms {
            M: m,
            C: c,
            G: gv,
            J: pose.J,
            Jdot: Matrix2::new(-v_ee.y, -v2.y, v_ee.x, v2.x),
            jdot_qdot: -(self.l1 * w1 * w1) * u1 - (self.l2 * w2 * w2) * u12,
            p_ee: self.base + self.l1 * u1 + self.l2 * u12,
            v_ee,
            det_M: self.det0 - p2c2 * p2c2,
        }
    }
}

impl TwoLinkTerms {
    /// `M⁻¹ = adj(M) / det M` (closed form; the caller checks `det_M > 0`).
    #[inline]
    pub fn m_inv(&self) -> Matrix2<f64> {
        let m = &self.M;
        Matrix2::new(m[(1, 1)], -m[(0, 1)], -m[(1, 0)], m[(0, 0)]) * (1.0 / self.det_M)
    }

    /// Cartesian dynamics (3)–(4), as [`Arm::cartesian`]; `None` when |det J_e| < `min_det`.
    #[inline]
    pub fn cartesian(&self, min_det: f64) -> Option<Cartesian> {
        cartesian_2x2(&self.J, &self.M, &self.C, &self.Jdot, &self.G, min_det)
    }
}
