//! Planar serial arms with revolute joints: kinematics and joint-space dynamics, paper (1)–(4). The parameters are
//! [`crate::model::planar::arm`].
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

pub mod fixed;
pub mod general;
#[cfg(target_arch = "x86_64")]
mod pair;
pub mod two_link;

pub use fixed::{ArmBlock, ArmSolve, FixedArm, FixedKinematics, FixedLinkArm};
pub use general::{Arm, ArmTerms, Cartesian};
pub use two_link::{IkFailure, TwoLinkArm, TwoLinkPose, TwoLinkTerms};
