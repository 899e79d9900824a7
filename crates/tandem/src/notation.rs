//! Notation: the paper's symbols as they appear in the code. SI units everywhere
//! (m, rad, s, kg, N, N m); angles in radians.
//!
//! | symbol | code | meaning | shape, unit |
//! |---|---|---|---|
//! | `q_i`, `q̇_i` | `q`, `qd` | joint angles / rates of arm `i` (`q_i1` absolute from +x) | n_i, rad, rad/s |
//! | `M, C, G` | `ArmTerms::{M, C, G}` | joint-space inertia, Christoffel Coriolis matrix, gravity torques (1) | n×n, n |
//! | `J_e,i` | `ArmTerms::J` | end-effector Jacobian (2) | 2×n, m/rad |
//! | `M_x, C_x, G_x` | `Cartesian` | Cartesian-space dynamics (3)–(4) | 2×2, 2 |
//! | `F_i` | `PlantWorkspace::forces` | force the object exerts on end-effector `i` (what its sensor reads) | 2, N |
//! | `x_o = (x, y, θ)` | `x_o` | object pose | 3, (m, m, rad) |
//! | `M_o, C_o, G_o` | `Object` | object inertia, viscous damping, gravity wrench (10) | 3×3, 3 |
//! | `F_d` | `PlantInput::f_d` | environment disturbance, subtracted in (10) | 3, (N, N, N m) |
//! | `r_i` (`p_OGi`) | `Grasp::r` | grasp point of arm `i` in the object frame | 2, m |
//! | `J_i(x_o)` | `Grasp::jacobian` | grasp Jacobian, `ẋ_i = J_i ẋ_o` | 2×3 |
//! | `𝓜, 𝓒, 𝓖` | `ObjectSpace` | object-space dynamics of the closed chain (14) | 3×3, 3 |
//! | `τ` | `TickRecord::wrench` | wrench the arms put on the object ("control torque", Fig. 10/15) | 3, (N, N, N m) |
//! | `τ_x,i` | — | Cartesian force arm `i` applies, `τ = Σ J_iᵀ τ_x,i` | 2, N |
//! | `x_d, x_d,i` | `TickRecord::x_d` | desired object pose / desired end-effector point | 3 / 2 |
//! | `x_r, x_r,i` | `TickRecord::x_r` | reference from the admittance generators (15)–(21) | 3 / 2 |
//! | `e = x_r,i − x_d,i` | `AdmittanceState::e` | admittance offset | 2, m |
//! | `M_e, C_e, K_e` | `AdmittanceParams` | virtual mass, damping, stiffness (SPEC §3.1) | per axis |
//! | `δ_i` | `ControllerParams::delta` | desired point's offset inside the grasp (squeeze) | m |
//! | `x_1, x_2` | `TickRecord::{x_o, xd_o}` | estimated object pose and velocity (22) | 3 |
//! | `z_1, z_2` | `TickRecord::{z1, z2}` | `x_1 − x_r`, `x_2 − α` (23) | 3 |
//! | `k_c` | `ControllerParams::k_c` | output bounds, `|x_1j| < k_cj` (24) | 3 |
//! | `ρ, α, α̇` | [`crate::control::law::iblf`] | (29), (31) with the SPEC §3.3 errata | 3 |
//! | `κ_1, K_1, K_2, K_r` | `NnGains::{k1, k2, k_r}` | backstepping and robust gains (31), (42) | 3 |
//! | `Z` | — | NN input `[x_1, x_2, α, α̇]` | 12 |
//! | `S(Z), ϑ` | [`crate::control::rbf`], `NnGains::width2` (= ϑ²) | Gaussian basis (8) | 4096 |
//! | `Ŵ_j, Θ_j, σ_j` | `NnGains::{theta, sigma}` | weights and adaptation law (44) | 4096×3 |
//! | `Q = M(Z), m(z), d_1, d_2, ω` | [`crate::control::law::switching`] | switching function (37)–(38) | scalar |
//! | `f^U, ϖ` | `FuBound`, `NnGains::varpi` | bound of `|F(Z)|` and robust-term smoothing (40), (43) | 3 |
//! | `V_1, V_2, V_3` | `iblf::v1` | Lyapunov functions (27), (33), (46) | scalar |
//!
//! # Spatial (SPEC-spatial S1)
//!
//! Frames in Drake's monogram notation: `X_AB` is the pose of frame `B` in `A` (`p_A = X_AB p_B`),
//! `R_AB` its rotation, `p_AB` its translation; `W` world, `B_i` arm `i`'s base, `L_k` body `k`,
//! `T_i` tool `i`, `O` the object (at its centre of mass), `G_i` grasp `i` in the object. Twists
//! `[v; ω]` and wrenches `[f; τ]` are ordered **linear first**; quaternions in files `[w, x, y, z]`.
//!
//! | symbol | code | meaning | shape, unit |
//! |---|---|---|---|
//! | `X_WB_i` | `SpatialArm::base` | base placement of arm `i` | SE(3) |
//! | `X_WL_k`, `X_WT` | `ChainData::{X_WL, X_WT}` | body and tool poses | SE(3) |
//! | `J_i` | `ChainData::J` | tool Jacobian, world axes, `[ṗ_T; ω_T] = J q̇` | 6×n, (m, 1)/rad |
//! | `J̇_i q̇_i` | `ChainData::jdqd` | classical tool acceleration at `q̈ = 0` | 6, (m/s², rad/s²) |
//! | `M, C q̇ + g` | `ChainData::{M, bias}` | joint-space inertia (CRBA), bias (RNEA) | n×n, n |
//! | `X_OG_i` | `SpatialPlantParams::grasps` | grasp frame `i` in the object | SE(3) |
//! | `p_WO, R_WO, [v_WO; ω_WO]` | `ObjectState::{p, q, v, w}` | object pose and twist (world axes) | 3, SO(3), 6 |
//! | `F_i` | `SpatialWorkspace::wrenches` | grasp wrench: the object on tool `i`, about its origin, world axes | 6, (N, N m) |
//! | `G_i = Ad_i` | [`crate::plant::spatial`] | grasp matrix block, `F_o = −Σ G_iᵀ F_i` | 6×6 |
//! | `F_d` | `SpatialInput::f_d` | environment wrench on the object (subtracted) | 6, (N, N m) |
