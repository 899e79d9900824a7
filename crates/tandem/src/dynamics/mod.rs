//! Rigid-body algorithms for one spatial arm ([`crate::model::SpatialArm`]), written by hand,
//! allocation-free on a preallocated [`ChainData`] (SPEC-spatial S2).
//!
//! Every quantity is in world axes unless said otherwise; twists `[v; ω]` and wrenches `[f; τ]`
//! are ordered linear first (SPEC-spatial S1). `g_W` is the gravity acceleration vector in world
//! axes (e.g. `(0, 0, −9.81)`).
//!
//! Contract (the skeleton; the algorithms fill it):
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
#![allow(non_snake_case)]

use nalgebra::{DMatrix, DVector, Isometry3, Matrix6xX, Vector3, Vector6};

use crate::model::SpatialArm;

/// Per-arm workspace and outputs, sized from the chain by [`ChainData::new`].
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
        }
    }
}

/// Forward kinematics of every body and the tool, the tool Jacobian, and `J̇ q̇` when `qd` is
/// given. Writes `d.X_WL`, `d.X_WT`, `d.J`, `d.jdqd`.
pub fn kinematics(arm: &SpatialArm, q: &[f64], qd: Option<&[f64]>, d: &mut ChainData) {
    let _ = (arm, q, qd, d);
    todo!("dynamics::kinematics")
}

/// Joint-space inertia by the composite-rigid-body algorithm. Writes `d.M`.
pub fn crba(arm: &SpatialArm, q: &[f64], d: &mut ChainData) {
    let _ = (arm, q, d);
    todo!("dynamics::crba")
}

/// Inverse dynamics by recursive Newton–Euler: `tau = M q̈ + C q̇ + g − J_Tᵀ F_T`.
pub fn rnea(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    g_W: &Vector3<f64>,
    f_T_W: Option<&Vector6<f64>>,
    tau: &mut [f64],
    d: &mut ChainData,
) {
    let _ = (arm, q, qd, qdd, g_W, f_T_W, tau, d);
    todo!("dynamics::rnea")
}

/// Forward dynamics by the articulated-body algorithm: `q̈` from `τ` and the tool wrench.
pub fn aba(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    g_W: &Vector3<f64>,
    f_T_W: Option<&Vector6<f64>>,
    qdd: &mut [f64],
    d: &mut ChainData,
) {
    let _ = (arm, q, qd, tau, g_W, f_T_W, qdd, d);
    todo!("dynamics::aba")
}

/// Forward dynamics by CRBA + RNEA bias + Cholesky of `M`; agrees with [`aba`].
pub fn forward_dynamics(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    g_W: &Vector3<f64>,
    f_T_W: Option<&Vector6<f64>>,
    qdd: &mut [f64],
    d: &mut ChainData,
) {
    let _ = (arm, q, qd, tau, g_W, f_T_W, qdd, d);
    todo!("dynamics::forward_dynamics")
}

/// The plant's fused pass: [`kinematics`] with `qd`, `d.M`, and `d.bias = C q̇ + g`.
pub fn terms(arm: &SpatialArm, q: &[f64], qd: &[f64], g_W: &Vector3<f64>, d: &mut ChainData) {
    let _ = (arm, q, qd, g_W, d);
    todo!("dynamics::terms")
}
