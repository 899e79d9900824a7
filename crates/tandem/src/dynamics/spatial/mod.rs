//! Rigid-body algorithms for one spatial arm ([`crate::model::spatial::SpatialArm`]), written by hand,
//! allocation-free on a preallocated [`ChainData`] (SPEC-spatial S2).
//!
//! # Conventions
//! Every quantity is in world axes unless said otherwise; twists `[v; ω]` and wrenches `[f; τ]`
//! are ordered linear first (SPEC-spatial S1). `g_W` is the gravity acceleration vector in world
//! axes (e.g. `(0, 0, −9.81)` m/s²). The arm's base pose `X_WB` is `arm.base`; body `k` is moved
//! by joint `k` and carries frame `L_k` ([`crate::model::spatial::chain`]). Joint coordinates are rad
//! (revolute) or m (prismatic); torques N m or N.
//!
//! # Contract
//! * [`ChainData::new`] sizes every buffer from the chain.
//! * [`kinematics`]`(arm, q, qd, d)`: body poses `d.X_WL`, tool pose `d.X_WT`, tool Jacobian
//!   `d.J` (6 × n, rows `[ṗ_T; ω_T]`, world axes, about the tool origin) and `d.jdqd` = `J̇ q̇`
//!   (classical: `[p̈_T; ω̇_T]` at `q̈ = 0`).
//! * [`crba`]`(arm, q, d)`: `d.M` (n × n).
//! * [`rnea`]`(arm, q, qd, qdd, g_W, f_T_W, tau, d)`: `τ = M q̈ + C q̇ + g − J_Tᵀ F_T`, with
//!   `F_T` the wrench applied **to** the tool frame (about its origin, world axes), or zero.
//! * [`aba`] / [`forward_dynamics`] (Cholesky of `M`): `q̈` from `τ` and `F_T`.
//! * [`terms`]`(arm, q, qd, g_W, d)`: one fused pass for the plant: [`kinematics`], `d.M`, and
//!   `d.bias = C q̇ + g`.
//! * Also: [`coriolis_matrix`] (Christoffel-consistent `C(q, q̇)`), [`gravity`] (`g(q)`),
//!   [`energy`] (kinetic and potential).
//!
//! # How: spatial quantities in world axes about the base origin
//! The algorithms are Featherstone's (2008: RNEA Table 5.1, CRBA Table 6.2, ABA Table 7.1),
//! but every spatial vector is expressed in **one fixed coordinate system, world axes about the
//! base origin `p_WB`**, instead of each body's own coordinates: the spatial-vector equations
//! are coordinate-free, so the recursions keep their form, the parent-to-child transforms
//! become identities, and the motion subspaces move with the bodies (`Ṡ_k = V_k × S_k`). With `S_k` the joint's motion subspace (`[p_k × z_k; z_k]` for a revolute
//! joint with world axis `z_k` through the body origin `p_k = p_WL_k − p_WB`, `[z_k; 0]` for a
//! prismatic one), the velocity recursion `V_k = V_{k−1} + S_k q̇_k`, the bias
//! `Ṡ_k q̇_k = V_k × S_k q̇_k` and the force recursion `f_{k−1} += f_k` need no change of frame
//! at all; each body's inertia is put into these coordinates once per call (`R I_c Rᵀ` and a
//! parallel-axis term, 45 + 15 multiplications), and the composite inertias of CRBA and the
//! articulated inertias of ABA are then plain sums. `M_ik = S_i · (𝕀ᶜ_k S_k)` costs 6
//! multiplications per entry and the tool Jacobian is `S_k` moved to the tool point. The
//! shared forward pass ([`kinematics`]) composes `X_WL_k = X_WL_{k−1} X_PJ[k] J_k(q_k)` as unit
//! quaternions (one `sin_cos` of `q_k/2` per revolute joint) and reads `R_WL_k` off the
//! quaternion.
//!
//! Why the base origin and not the world origin: the rounding error of these sums grows with
//! the distance of the bodies from the reference point (`|p|² m ε` in `M`); taking it at the
//! base keeps it at the arm's own size whatever `X_WB` (two arms 1.4 m apart lose nothing).
//! Gravity and the outputs (`X_WL`, `X_WT`, `J`, `J̇ q̇`, wrenches at the tool) do not depend on
//! the choice.
//!
//! Joint damping (`ChainJoint::damping`) is not part of these terms: it is a joint torque the
//! plant adds (`τ_damping = −b q̇`).
//!
//! # Cost
//! Instructions per call (callgrind, release build for baseline x86-64, so SSE2 and no FMA) and
//! criterion medians on the shared 2-core VM (2026-12-01, load 3–4 from other builds, so the
//! wall times are inflated and noisy; the `dynibo` 0.5.3 column ran in the same process on the
//! same model and state, see `benches/dynamics.rs`):
//!
//! | 7-DOF Panda-like | tandem          | dynibo            |
//! |------------------|-----------------|-------------------|
//! | kinematics (poses, J, J̇q̇) | 3 336 Ir, 0.55–0.72 µs | 6 447 Ir, 1.3–1.5 µs |
//! | RNEA             | 5 857 Ir, 0.80–0.91 µs | 7 229 Ir, 1.1–1.6 µs |
//! | CRBA             | 5 379 Ir, 0.79–0.90 µs | 9 207 Ir, 1.45–1.66 µs |
//! | ABA              | 9 258 Ir, 1.3–2.0 µs   | 19 450 Ir, 3.6–4.7 µs |
//! | terms (kinematics + M + C q̇ + g) | 7 714 Ir, 1.1–1.2 µs | ≈ 22 900 Ir (sum of the calls), 4.1–6.1 µs |
//!
//! For the 6-DOF UR5-like arm `terms` is 6 502 instructions (0.64–0.97 µs loaded); built for
//! x86-64-v3 (AVX2, FMA) every count drops by 10–18 % (Panda-like `terms` 6 661). The time is
//! arithmetic spread over the stages, not one hot spot: per body about 370 instructions for the
//! placement (two quaternion products, quaternion to matrix, world axis, one inlined
//! `sin_cos`), 160 for the world inertia (`R I_c Rᵀ`), 280 for the RNEA forward step (two
//! inertia applications, two cross products), 200 for the fused RNEA/CRBA backward step and the
//! O(n²) entries of `M`. What would make it faster: AVX2/FMA code generation (the crate is
//! built for baseline x86-64), interleaving two arms' recursions for instruction-level
//! parallelism, caching chain constants (placement matrices, body-frame `I_O`) in the data.
//!
//! # Validity
//! The chain should pass [`crate::model::spatial::Chain::validate`] (masses > 0, inertias SPD): then `M`
//! is SPD and every articulated-inertia pivot is > 0. Slices shorter than `n` panic (a
//! programming error); otherwise nothing panics, and finite inputs of physical magnitude give
//! finite outputs. A non-positive pivot (only an invalid chain has one) is counted in
//! [`ChainData::singular_pivots`] and its joint acceleration is set to 0 instead of dividing.
//!
//! # References
//! 1. R. Featherstone, *Rigid Body Dynamics Algorithms*, Springer, 2008 (RNEA Table 5.1, CRBA
//!    Table 6.2, ABA Table 7.1).
//! 2. S. Echeandia, P. M. Wensing, "Numerical methods to compute the Coriolis matrix and
//!    Christoffel symbols for rigid-body systems", *J. Comput. Nonlinear Dyn.* 16(9), 2021.
#![allow(non_snake_case)]

mod aba;
mod coriolis;
mod crba;
mod energy;
mod forward;
mod kinematics;
mod rnea;
mod terms;

pub use aba::aba;
pub use coriolis::coriolis_matrix;
pub use crba::crba;
pub use energy::energy;
pub use forward::forward_dynamics;
pub use kinematics::kinematics;
pub use rnea::{gravity, gravity_at_placements, rnea};
pub use terms::terms;

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Matrix6, Matrix6xX, Vector3, Vector6};

use crate::geometry::SpatialInertia;
use crate::model::spatial::SpatialArm;

/// Per-arm workspace and outputs, sized from the chain by [`ChainData::new`].
///
/// The public fields are outputs; the private ones are per-body scratch (world rotations, motion
/// subspaces, inertias, velocities, forces, articulated inertias) sized once, so that no
/// algorithm allocates. The data holds no chain constants: it may be reused with any arm of the
/// same number of joints.
#[derive(Clone, Debug)]
pub struct ChainData {
    /// `X_WL_k`: pose of each body frame in the world (n).
    pub X_WL: Vec<Isometry3<f64>>,
    /// `X_WT`: tool pose in the world.
    pub X_WT: Isometry3<f64>,
    /// Tool Jacobian, 6 × n, world axes, `[ṗ_T; ω_T] = J q̇`.
    pub J: Matrix6xX<f64>,
    /// `J̇ q̇` at the tool origin (classical), world axes.
    pub jdqd: Vector6<f64>,
    /// Joint-space inertia `M` (n × n).
    pub M: DMatrix<f64>,
    /// `C q̇ + g` (n).
    pub bias: DVector<f64>,
    /// `R_WL_k` as matrices (n).
    R_WL: Vec<Matrix3<f64>>,
    /// `p_BL_k = p_WL_k − p_WB`: body origins relative to the base origin, world axes (n).
    p_BL: Vec<Vector3<f64>>,
    /// `p_BT = p_WT − p_WB`: the tool origin relative to the base origin, world axes.
    p_BT: Vector3<f64>,
    /// `S_k`: motion subspace of joint `k`, world axes about the base origin (n).
    S: Vec<Vector6<f64>>,
    /// `𝕀_k`: body inertias, world axes about the base origin (n).
    I_W: Vec<SpatialInertia>,
    /// `V_k`: body twists, world axes about the base origin (n).
    V: Vec<Vector6<f64>>,
    /// Per-body spatial accelerations (RNEA) or bias accelerations `Ṡ q̇` (ABA) (n).
    a: Vec<Vector6<f64>>,
    /// Per-body forces (RNEA) or articulated bias forces `p^A` (ABA) (n).
    f: Vec<Vector6<f64>>,
    /// Composite inertias (CRBA) (n).
    Ic: Vec<SpatialInertia>,
    /// Articulated inertias `𝕀^A` (ABA) or composite `B` matrices (Coriolis) (n).
    IA: Vec<Matrix6<f64>>,
    /// `U_k = 𝕀^A_k S_k` (ABA) (n).
    U: Vec<Vector6<f64>>,
    /// `1/D_k` (ABA) and `u_k` (ABA) (n each).
    Dinv: Vec<f64>,
    u: Vec<f64>,
    /// Cholesky factor scratch (n × n).
    chol: DMatrix<f64>,
    /// Non-positive pivots met by [`aba`] or [`forward_dynamics`] (invalid chains only).
    singular: u64,
}

impl ChainData {
    /// Buffers for `arm`.
    pub fn new(arm: &SpatialArm) -> Self {
        let n = arm.chain.dof();
        ChainData {
            X_WL: vec![Isometry3::identity(); n],
            X_WT: Isometry3::identity(),
            J: Matrix6xX::zeros(n),
            jdqd: Vector6::zeros(),
            M: DMatrix::zeros(n, n),
            bias: DVector::zeros(n),
            R_WL: vec![Matrix3::identity(); n],
            p_BL: vec![Vector3::zeros(); n],
            p_BT: Vector3::zeros(),
            S: vec![Vector6::zeros(); n],
            I_W: vec![SpatialInertia::zero(); n],
            V: vec![Vector6::zeros(); n],
            a: vec![Vector6::zeros(); n],
            f: vec![Vector6::zeros(); n],
            Ic: vec![SpatialInertia::zero(); n],
            IA: vec![Matrix6::zeros(); n],
            U: vec![Vector6::zeros(); n],
            Dinv: vec![0.0; n],
            u: vec![0.0; n],
            chol: DMatrix::zeros(n, n),
            singular: 0,
        }
    }

    /// Number of joints the buffers are sized for.
    pub fn dof(&self) -> usize {
        self.X_WL.len()
    }

    /// How many non-positive pivots [`aba`] (articulated inertia `D_k ≤ 0`) and
    /// [`forward_dynamics`] (`M` not positive definite) have met since construction. Always 0
    /// for a chain that passes [`crate::model::spatial::Chain::validate`].
    pub fn singular_pivots(&self) -> u64 {
        self.singular
    }

    /// Body twists `V_k = [v_k; ω_k]` after [`kinematics`] with `qd` (or any algorithm taking
    /// `q̇`): world axes, **about the base origin** `p_WB` (`v_k` is the velocity of the body point
    /// passing through the base origin). Add `ω_k × (p_WL_k − p_WB)` for the body-origin velocity.
    pub fn body_twists(&self) -> &[Vector6<f64>] {
        &self.V
    }

    /// Joint motion subspaces `S_k` after any algorithm: world axes about the base
    /// origin (the columns of the body Jacobians, `V_k = Σ_{j≤k} S_j q̇_j`).
    pub fn motion_subspaces(&self) -> &[Vector6<f64>] {
        &self.S
    }
}

#[inline(always)]
fn check_len(arm: &SpatialArm, d: &ChainData, name: &str, x: &[f64]) {
    let n = arm.chain.dof();
    assert!(
        d.dof() == n && x.len() >= n,
        "dynamics: {name} has {} entries and the data {} joints; the arm has {n}",
        x.len(),
        d.dof()
    );
}
