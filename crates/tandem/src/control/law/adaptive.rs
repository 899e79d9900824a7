//! Adaptive RBF-network control with an integral barrier and a switching function, paper
//! (37)–(44) with the SPEC §3.3–3.4 errata:
//!
//! $$τ_j = −\frac{k_{cj}^2 z_{1j}}{k_{cj}^2 − x_{1j}^2} − k_{2j} z_{2j} + Q Φ^a_j + (1 − Q) Φ^b_j − k_{rj}\,\mathrm{sgn}(z_{2j})$$
//!
//! with `Φᵃ_j = Ŵ_jᵀ S(Z)`, `Φᵇ_j = −f_jᵁ tanh(f_jᵁ z_{2j}/ϖ)`, `Z = [x_1, x_2, α, α̇]`,
//! `Q = M(Z)` (38) and the update (44) `Ŵ̇_j = −Θ_j (Q S z_{2j} + σ_j Ŵ_j)`.
//!
//! Errata applied (SPEC §3.4): the robust term and `K_r sgn(z2)` oppose `z2` (the paper adds
//! them), and the NN term is gated by `Q` (Remark 4). `α`, `α̇` use `x_1` in `k² − x²` (SPEC §3.3,
//! module [`crate::control::law::iblf`]).
//!
//! `f_jᵁ(Z) = a_j + b_j ‖x_2‖‖α‖ + c_j ‖α̇‖ + d_j ‖α‖` bounds `|F_j(Z)|` of (39),
//! `F = 𝓖 + 𝓒α + 𝓜α̇ + F_d`; the constants come from the controller's model at set-up
//! ([`FuBound::from_model`]).

use nalgebra::{Matrix2, SVector, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::control::law::iblf::Iblf;
use crate::control::law::switching::{SwitchParams, Switching};
use crate::control::rbf::structured::{NetworkStructure, StructuredNn};
use crate::control::rbf::{NnUpdate, Rbf, RbfNetwork, RbfWorkspace};
use crate::error::{ModelError, positive};
use crate::plant::planar::Plant;

/// Gains of the NN law on `N` outputs (plain data): `K1` of the virtual control (31), `K2`,
/// `K_r`, `ϖ` of the law (42)–(43), `Θ`, `σ` of the update (44), the RBF basis (36)–(37) and the
/// switching function (38)–(40), with the SPEC §3.4 errata. The planar object has `N = 3`
/// outputs `(x, y, θ)` (presets [`NnGains::paper`], [`NnGains::tuned`]); the spatial one
/// `N = 6`, `[x, y, z, rx, ry, rz]` in the output chart (SPEC-spatial S5; presets
/// [`NnGains::dual_ur5`], [`NnGains::dual_franka`], [`NnGains::from_design`]).
///
/// Serialised form (serde): the fields by name, unknown fields refused. `network` depends on
/// `N` ([`default_network`], [`network_is_skipped`]): planar (`N ≤ 3`) it defaults to the
/// paper's full grid and is not written when it is the full grid; spatial (`N > 3`, where the
/// full grid has `2^24` nodes and is refused) it defaults to one grid per output
/// ([`NetworkStructure::per_axis`]) and is always written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "[f64; N]: Serialize",
        deserialize = "[f64; N]: Deserialize<'de>"
    )
)]
pub struct NnGains<const N: usize> {
    /// `K1` diagonal (virtual control gain κ1), 1/s.
    pub k1: [f64; N],
    /// `K2` diagonal: N s/m on the linear outputs, N m s/rad on the angular ones (spatial: in
    /// chart coordinates).
    pub k2: [f64; N],
    /// `K_r` diagonal (sign term): N on the linear outputs, N m on the angular ones.
    pub k_r: [f64; N],
    /// Adaptation gains `Θ_j`.
    pub theta: [f64; N],
    /// σ-modification `σ_j`.
    pub sigma: [f64; N],
    /// Robust-term smoothing `ϖ`.
    pub varpi: f64,
    /// Safety factor on the `f^U` constants.
    pub fu_safety: f64,
    /// RBF width `ϑ²` ("variance").
    pub width2: f64,
    /// Centre levels per input (the full grid is their Cartesian product over the `4N`
    /// inputs).
    pub levels: Vec<f64>,
    /// Switching inner radius `d1` (every input).
    pub d1: f64,
    /// Switching outer radius `d2`.
    pub d2: f64,
    /// Switching shape `ω ≥ 1`.
    pub omega: f64,
    /// Structure of the RBF network ([`crate::control::rbf::structured`]): the paper's full grid on
    /// `levels` (bit for bit), one grid per output over a subset of `Z`, or quasi-random
    /// centres. Planar: the full grid by default, not serialised when it is the full grid.
    /// Spatial: the full grid (`2^24` nodes, 800 MB of weights) is refused, the default is one
    /// grid per output over its own four signals ([`NetworkStructure::per_axis`],
    /// `docs/network.md`), always serialised.
    #[serde(
        default = "default_network::<N>",
        skip_serializing_if = "network_is_skipped::<N>"
    )]
    pub network: NetworkStructure,
    /// How the robust term `Φᵇ` of (42)–(43) is smoothed ([`Smoothing`]): the paper's
    /// `tanh(f^U z2/ϖ)` with the constant `ϖ` (`"paper"`), or its boundary layer widened to
    /// what the control period resolves (`"sampled"`, `docs/smooth-nn.md`). Default: `paper`
    /// on planar outputs (`N ≤ 3`, where it is not written when it is the default), `sampled`
    /// on spatial ones (always written).
    #[serde(
        default = "default_smoothing::<N>",
        skip_serializing_if = "smoothing_is_skipped::<N>"
    )]
    pub smoothing: Smoothing,
}

/// The smoothing of the robust term `Φᵇ_j = −f_jᵁ tanh(f_jᵁ z_2j/ϖ_j)` of (42)–(43) (SPEC §3.4;
/// `docs/smooth-nn.md`).
///
/// In its linear zone the robust term is a feedback on `z_2j` of slope `(1 − Q) f_jᵁ²/ϖ`; held
/// over a control period `h` on an output of inertia `M_j` it moves `z_2j` by
/// `(1 − Q) (f_jᵁ²/ϖ) (h/M_j) z_2j` in one tick, and when that factor exceeds 1 the sampled
/// loop overshoots zero every tick: the robust term chatters at the tick rate (on the S6
/// set-up `f^U²/ϖ` reaches 5e5 N s/m against 20 kg and 1 ms, a factor of 25).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Smoothing {
    /// The paper's (42)–(43): `ϖ_j = ϖ`, constant.
    #[default]
    Paper,
    /// The sampled-data boundary layer: `ϖ_j(Z) = max(ϖ, f_jᵁ(Z)² h/(β M_j))` with
    /// [`SAMPLED_BETA`] `= 1/2` and `M_j` the lightest effective inertia of output `j`
    /// (`1/(𝓜⁻¹)_jj`) the controller expects, so that the linear zone's slope
    /// `f_jᵁ²/ϖ_j ≤ β M_j/h` removes at most half of `z_2j` per tick and never flips its
    /// sign. Where the paper's `ϖ` already satisfies it, the law is the paper's bit for bit;
    /// with `Q = 1` (inside Ω1) the term is off either way.
    Sampled,
}

impl Smoothing {
    /// The name in a scenario file (`paper`, `sampled`).
    pub fn name(self) -> &'static str {
        match self {
            Smoothing::Paper => "paper",
            Smoothing::Sampled => "sampled",
        }
    }
}

/// `β` of [`Smoothing::Sampled`]: the fraction of `z_2j` the robust term may remove in one
/// control period at its steepest (`1` is dead-beat, above it the sampled loop overshoots;
/// `1/2` leaves a factor 2 for an output lighter than expected).
pub const SAMPLED_BETA: f64 = 0.5;

/// The default [`NnGains::smoothing`] for `N` outputs: the paper's on planar outputs (the
/// planar presets reproduce the paper), [`Smoothing::Sampled`] on spatial ones.
pub fn default_smoothing<const N: usize>() -> Smoothing {
    if crate::control::law::is_planar(N) {
        Smoothing::Paper
    } else {
        Smoothing::Sampled
    }
}

/// Whether [`NnGains::smoothing`] is left out of the serialised gains: planar when it is the
/// default (`paper`), spatial never.
pub fn smoothing_is_skipped<const N: usize>(s: &Smoothing) -> bool {
    crate::control::law::is_planar(N) && *s == Smoothing::Paper
}

/// The default [`NnGains::network`] for `N` outputs: the paper's full grid when planar
/// (`N ≤ 3`, [`crate::control::law::is_planar`]), one grid per output
/// ([`NetworkStructure::per_axis`]) otherwise.
pub fn default_network<const N: usize>() -> NetworkStructure {
    if crate::control::law::is_planar(N) {
        NetworkStructure::FullGrid
    } else {
        NetworkStructure::per_axis()
    }
}

/// Whether [`NnGains::network`] is left out of the serialised gains: planar (`N ≤ 3`) when it is
/// the full grid (the default); spatial never.
pub fn network_is_skipped<const N: usize>(network: &NetworkStructure) -> bool {
    crate::control::law::is_planar(N) && network.is_full_grid()
}

impl NnGains<3> {
    /// The paper's gains (Section V-B-2), kept faithfully; SPEC §3.4 explains why they end in a
    /// limit cycle.
    pub fn paper() -> Self {
        NnGains {
            k1: [15.0, 20.0, 15.0],
            k2: [11.0, 15.0, 10.0],
            k_r: [0.01; 3],
            theta: [120.0, 150.0, 120.0],
            sigma: [0.001; 3],
            varpi: 0.05,
            fu_safety: 1.5,
            width2: 50.0,
            levels: vec![-1.0, 1.0],
            d1: 1.0,
            d2: 1.5,
            omega: 1.0,
            network: NetworkStructure::FullGrid,
            smoothing: Smoothing::Paper,
        }
    }
    /// Gains that make the paper's claims hold on the paper scenario (SPEC §3.4 starting point;
    /// see `docs/reproduction.md` for how they were checked).
    pub fn tuned() -> Self {
        NnGains {
            k1: [8.0; 3],
            k2: [233.0, 700.0, 50.0],
            k_r: [0.001; 3],
            theta: [1.6, 1.5, 0.5],
            ..NnGains::paper()
        }
    }
}

impl<const N: usize> NnGains<N> {
    /// The gains of the first `M ≤ N` outputs, the shared settings (`ϖ`, `ϑ²`, levels,
    /// switching, network) as they are: the planar per-arm scheme runs the `x`, `y` entries
    /// (`M = 2`) on each end-effector.
    pub fn outputs<const M: usize>(&self) -> NnGains<M> {
        const { assert!(M <= N, "cannot take more outputs than the gains have") };
        NnGains {
            k1: std::array::from_fn(|j| self.k1[j]),
            k2: std::array::from_fn(|j| self.k2[j]),
            k_r: std::array::from_fn(|j| self.k_r[j]),
            theta: std::array::from_fn(|j| self.theta[j]),
            sigma: std::array::from_fn(|j| self.sigma[j]),
            varpi: self.varpi,
            fu_safety: self.fu_safety,
            width2: self.width2,
            levels: self.levels.clone(),
            d1: self.d1,
            d2: self.d2,
            omega: self.omega,
            network: self.network.clone(),
            smoothing: self.smoothing,
        }
    }

    /// Check the per-output gains against the theory's conditions (SPEC §3.4): `K2, Θ, σ > 0`,
    /// `K_r ≥ 0`, output by output; errors name `gains.k2[j]` etc. (`K1` is checked with the
    /// bounds by the iBLF.)
    pub fn validate_outputs(&self) -> Result<(), ModelError> {
        for j in 0..N {
            positive(&format!("gains.k2[{j}]"), self.k2[j])?;
            crate::error::non_negative(&format!("gains.k_r[{j}]"), self.k_r[j])?;
            positive(&format!("gains.theta[{j}]"), self.theta[j])?;
            positive(&format!("gains.sigma[{j}]"), self.sigma[j])?;
        }
        Ok(())
    }
}

/// What one tick of the NN law computed, for `N` outputs (the controller copies it into its
/// record). `Copy`, fixed size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NnInternals<const N: usize> {
    /// `z2 = x_2 − α`.
    pub z2: SVector<f64, N>,
    /// Virtual control `α` (31).
    pub alpha: SVector<f64, N>,
    /// `α̇`.
    pub alpha_dot: SVector<f64, N>,
    /// Weight norms `‖Ŵ_j‖`.
    pub w_norm: SVector<f64, N>,
    /// Switching value `Q = M(Z)` (38).
    pub q: f64,
    /// A barrier term saturated (|x_1| or |x_r| at the bound).
    pub barrier_hit: bool,
    /// A non-finite input was replaced.
    pub non_finite: bool,
}

impl<const N: usize> Default for NnInternals<N> {
    fn default() -> Self {
        NnInternals {
            z2: SVector::zeros(),
            alpha: SVector::zeros(),
            alpha_dot: SVector::zeros(),
            w_norm: SVector::zeros(),
            q: 1.0,
            barrier_hit: false,
            non_finite: false,
        }
    }
}

/// Constants of `f_jᵁ = a_j + b_j ‖x_2‖‖α‖ + c_j ‖α̇‖ + d_j ‖α‖`, one entry per output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FuBound {
    /// Gravity plus disturbance bound, (N, N, N m).
    pub a: Vec<f64>,
    /// Coriolis coefficient.
    pub b: Vec<f64>,
    /// Inertia row norms.
    pub c: Vec<f64>,
    /// Damping row norms.
    pub d: Vec<f64>,
    /// Model poses used (reachable and well-conditioned).
    pub poses: usize,
}

/// Grid point `i` of `m` on `[−k, k]`.
fn grid(i: usize, m: usize, k: f64) -> f64 {
    k * (2.0 * i as f64 / (m - 1) as f64 - 1.0)
}

/// Call `f(x, object-space terms, ws)` on every pose of the constraint box's 13 × 13 × 5 grid
/// that the reduced model (14) evaluates and where every arm's `σ_min ≥ 0.05 m/rad` (kinematics
/// left in `ws`): the poses [`FuBound::from_model`] and [`FuBound::lightest_inertia`] use.
fn usable_poses(
    model: &Plant,
    k_c: Vector3<f64>,
    ws: &mut crate::plant::planar::PlantWorkspace,
    mut f: impl FnMut(
        &Vector3<f64>,
        &crate::plant::planar::reduced::ObjectSpace,
        &mut crate::plant::planar::PlantWorkspace,
    ),
) {
    let (n, nt) = (13, 5);
    for ix in 0..n {
        for iy in 0..n {
            for it in 0..nt {
                let x = Vector3::new(grid(ix, n, k_c.x), grid(iy, n, k_c.y), grid(it, nt, k_c.z));
                let Ok(os) = model.object_space(&x, &Vector3::zeros(), ws) else {
                    continue;
                };
                // Conditioning of every arm at this pose (kinematics left in ws).
                let sig = model
                    .arms()
                    .iter()
                    .enumerate()
                    .map(|(i, arm)| arm.min_singular_value(&ws.terms[i]))
                    .fold(f64::INFINITY, f64::min);
                if sig < 0.05 {
                    continue;
                }
                f(&x, &os, ws);
            }
        }
    }
}

impl FuBound {
    fn finish(mut self, safety: f64, dist: &[f64]) -> Result<Self, ModelError> {
        if self.poses == 0 {
            return Err(ModelError::geometry(
                "k_c",
                "no pose in the constraint box is reachable by every arm with a well-conditioned Jacobian",
            ));
        }
        for j in 0..self.a.len() {
            self.a[j] = safety * (self.a[j] + dist[j]);
            self.b[j] *= safety;
            self.c[j] *= safety;
            self.d[j] *= safety;
        }
        Ok(self)
    }

    /// Object scheme: bound the terms of (39) over the part of the constraint box `|x_j| ≤ k_cj`
    /// where every arm reaches its grasp with `σ_min(J_e) ≥ 0.05 m/rad`, on a 13 × 13 × 5 grid,
    /// times `safety`. `𝓒(x, ẋ) − C_o` is linear in `ẋ`, so
    /// `|((𝓒 − C_o)α)_j| ≤ ‖x_2‖‖α‖ Σ_k ‖row_j C_k‖` with `C_k = 𝓒(x, e_k) − C_o`.
    pub fn from_model(
        model: &Plant,
        k_c: Vector3<f64>,
        dist: [f64; 3],
        safety: f64,
    ) -> Result<Self, ModelError> {
        let mut ws = model.workspace();
        let mut fu = FuBound {
            a: vec![0.0; 3],
            b: vec![0.0; 3],
            c: vec![0.0; 3],
            d: vec![0.0; 3],
            poses: 0,
        };
        let co = model.object().C_o;
        for j in 0..3 {
            fu.d[j] = co.row(j).norm();
        }
        usable_poses(model, k_c, &mut ws, |x, os, ws| {
            let mut ck = [nalgebra::Matrix3::zeros(); 3];
            for (k, ckk) in ck.iter_mut().enumerate() {
                let mut e = Vector3::zeros();
                e[k] = 1.0;
                match model.object_space(x, &e, ws) {
                    Ok(o) => *ckk = o.C - co,
                    Err(_) => return,
                }
            }
            fu.poses += 1;
            for j in 0..3 {
                fu.a[j] = fu.a[j].max(os.G[j].abs());
                fu.c[j] = fu.c[j].max(os.M.row(j).norm());
                fu.b[j] = fu.b[j].max(ck.iter().map(|m| m.row(j).norm()).sum());
            }
        });
        fu.finish(safety, &dist)
    }

    /// Per-arm scheme: bound `F_i = G_x + C_x α + M_x α̇` of arm `i`'s Cartesian dynamics (3)
    /// over end-effector points `|x_j| ≤ k_j` the arm reaches with `σ_min ≥ 0.05 m/rad`
    /// (21 × 21 grid), times `safety`; `dist` bounds what the force feed-forward leaves.
    pub fn from_arm(
        model: &Plant,
        i: usize,
        k: Vector2<f64>,
        dist: [f64; 2],
        safety: f64,
    ) -> Result<Self, ModelError> {
        let arm = &model.arms()[i];
        let mut t = arm.terms();
        let mut fu = FuBound {
            a: vec![0.0; 2],
            b: vec![0.0; 2],
            c: vec![0.0; 2],
            d: vec![0.0; 2],
            poses: 0,
        };
        let n = 21;
        for ix in 0..n {
            for iy in 0..n {
                let p = Vector2::new(grid(ix, n, k.x), grid(iy, n, k.y));
                let Ok(q) = arm.inverse_kinematics(p) else {
                    continue;
                };
                arm.dynamics(&q, &[0.0, 0.0], model.gravity(), &mut t);
                if arm.min_singular_value(&t) < 0.05 {
                    continue;
                }
                let Some(c0) = arm.cartesian(&t, 1e-9) else {
                    continue;
                };
                // C_x is linear in ẋ: C_k = C_x(ẋ = e_k).
                let mut ck = [Matrix2::zeros(); 2];
                for (kk, m) in ck.iter_mut().enumerate() {
                    let mut v = Vector2::zeros();
                    v[kk] = 1.0;
                    let qd = c0.J_inv * v;
                    arm.dynamics(&q, qd.as_slice(), model.gravity(), &mut t);
                    if let Some(c) = arm.cartesian(&t, 1e-9) {
                        *m = c.C_x;
                    }
                }
                fu.poses += 1;
                for j in 0..2 {
                    fu.a[j] = fu.a[j].max(c0.G_x[j].abs());
                    fu.c[j] = fu.c[j].max(c0.M_x.row(j).norm());
                    fu.b[j] = fu.b[j].max(ck.iter().map(|m| m.row(j).norm()).sum());
                }
            }
        }
        fu.finish(safety, &dist)
    }

    /// The lightest effective object-space inertias `1/(𝓜⁻¹)_jj` of (14) over the poses
    /// [`FuBound::from_model`] uses (the reachable, well-conditioned part of the constraint
    /// box, 13 × 13 × 5): what [`Smoothing::Sampled`] sizes the robust term's boundary layer on
    /// ([`AdaptiveNn::set_sampling_inertia`]). `+∞` for an output when no pose is usable.
    pub fn lightest_inertia(model: &Plant, k_c: Vector3<f64>) -> [f64; 3] {
        let mut ws = model.workspace();
        let mut light = [f64::INFINITY; 3];
        usable_poses(model, k_c, &mut ws, |_, os, _| {
            if let Some(inv) = os.M.try_inverse() {
                for (j, l) in light.iter_mut().enumerate() {
                    if inv[(j, j)] > 0.0 {
                        *l = l.min(1.0 / inv[(j, j)]);
                    }
                }
            }
        });
        light
    }

    /// `f_jᵁ(Z)`.
    #[inline]
    pub fn eval(&self, j: usize, x2: f64, alpha: f64, alpha_dot: f64) -> f64 {
        fu_value(
            [self.a[j], self.b[j], self.c[j], self.d[j]],
            x2,
            alpha,
            alpha_dot,
        )
    }
}

/// `f^U = a + b‖x₂‖‖α‖ + c‖α̇‖ + d‖α‖` from one output's coefficients `[a, b, c, d]` (the one
/// formula of [`FuBound::eval`] and of the controller's tick, which keeps the coefficients in
/// a fixed-size array).
#[inline(always)]
fn fu_value([a, b, c, d]: [f64; 4], x2: f64, alpha: f64, alpha_dot: f64) -> f64 {
    a + b * x2 * alpha + c * alpha_dot + d * alpha
}

/// The network of an [`AdaptiveNn`]: the paper's grid (the default, with its fused
/// output-only pass and the carried norms) or a [`StructuredNn`].
enum Network<const N: usize> {
    Grid {
        rbf: Rbf,
        rbf_ws: RbfWorkspace,
        net: RbfNetwork<N>,
    },
    Structured(StructuredNn<N>),
}

/// The NN law for `N` outputs (3 on the object, 2 on one arm's end-effector): validated gains,
/// the iBLF, switching, the RBF network and its weights (state), and the input/basis scratch.
pub struct AdaptiveNn<const N: usize = 3> {
    iblf: Iblf<N>,
    switching: Switching,
    network: Network<N>,
    update: NnUpdate<N>,
    k2: SVector<f64, N>,
    k_r: SVector<f64, N>,
    varpi: f64,
    smoothing: Smoothing,
    /// `1/(β M_j/h)` per output: with [`Smoothing::Sampled`] and the inertia given
    /// ([`AdaptiveNn::set_sampling_inertia`]) `ϖ_j = max(ϖ, f_jᵁ² · this)`; zero otherwise
    /// (`ϖ_j = ϖ`).
    inv_slope_cap: [f64; N],
    fu: FuBound,
    /// `(a_j, b_j, c_j, d_j)` of `fu` per output, in a fixed-size array (the tick reads them
    /// without the vectors' bounds checks).
    fu_k: [[f64; 4]; N],
    theta: [f64; N],
    z: Vec<f64>,
    /// `‖Ŵ_j‖²`, carried by the exact recurrence and refreshed every [`NORM_REFRESH`] ticks.
    w_n2: [f64; N],
    ticks: u64,
    /// Anti-windup state `ξ` (see [`AdaptiveNn::anti_windup`]); zero without saturation.
    xi: SVector<f64, N>,
    /// `(e^{−K2_j h/M_j}, (1 − e^{−K2_j h/M_j})/K2_j)` of the anti-windup filter (`None`: off).
    aw: Option<[(f64, f64); N]>,
    /// Control period, s.
    h: f64,
}

/// Ticks between exact recomputations of the weight norms (one read pass over the weights).
const NORM_REFRESH: u64 = 1000;

impl<const N: usize> AdaptiveNn<N> {
    /// Validate the gains against the theory's conditions (SPEC §3.4: `K1, K2, Θ, σ > 0`,
    /// `K_r ≥ 0`, `0 < d1 < d2`, `ω ≥ 1`, `ϖ > 0`, `ϑ² > 0`; errors name `gains.k2[j]` etc.)
    /// and build the network on `4N` inputs with the given `f^U` bound (one entry per output).
    pub fn new(
        g: &NnGains<N>,
        k_c: SVector<f64, N>,
        fu: FuBound,
        h: f64,
    ) -> Result<Self, ModelError> {
        g.validate_outputs()?;
        if fu.a.len() != N || fu.b.len() != N || fu.c.len() != N || fu.d.len() != N {
            return Err(ModelError::geometry(
                "fu",
                format!("the f^U bound has {} outputs, the law {N}", fu.a.len()),
            ));
        }
        positive("gains.varpi", g.varpi)?;
        positive("gains.fu_safety", g.fu_safety)?;
        let k1 = SVector::<f64, N>::from(g.k1);
        let iblf = Iblf::new(k_c, k1).map_err(|e| prefix_gains(e, "k1", "kappa1"))?;
        let sw = SwitchParams::new(g.d1, g.d2, g.omega).map_err(|e| prefix_gains(e, "", ""))?;
        let switching = Switching::uniform(4 * N, sw)?;
        if g.levels.is_empty() {
            return Err(ModelError::geometry(
                "gains.levels",
                "needs at least one centre level",
            ));
        }
        let theta = SVector::from(g.theta);
        let sigma = SVector::from(g.sigma);
        let update = NnUpdate::new(theta, sigma, h).map_err(|e| prefix_gains(e, "", ""))?;
        let network = if g.network.is_full_grid() {
            let levels = vec![g.levels.clone(); 4 * N];
            let rbf = Rbf::grid(&levels, g.width2).map_err(|e| prefix_gains(e, "", ""))?;
            let net = RbfNetwork::<N>::for_basis(&rbf)?;
            let rbf_ws = rbf.workspace();
            Network::Grid { rbf, rbf_ws, net }
        } else {
            positive("gains.width2", g.width2)?;
            Network::Structured(StructuredNn::new(&g.network, &g.levels, g.width2, update)?)
        };
        Ok(AdaptiveNn {
            iblf,
            switching,
            network,
            update,
            k2: SVector::from(g.k2),
            k_r: SVector::from(g.k_r),
            varpi: g.varpi,
            smoothing: g.smoothing,
            inv_slope_cap: [0.0; N],
            fu_k: std::array::from_fn(|j| [fu.a[j], fu.b[j], fu.c[j], fu.d[j]]),
            fu,
            theta: g.theta,
            z: vec![0.0; 4 * N],
            w_n2: [0.0; N],
            ticks: 0,
            xi: SVector::zeros(),
            aw: None,
            h,
        })
    }

    /// The `f^U` constants in use.
    pub fn fu(&self) -> &FuBound {
        &self.fu
    }
    /// Zero the weights.
    pub fn reset_weights(&mut self) {
        match &mut self.network {
            Network::Grid { net, .. } => net.reset(),
            Network::Structured(s) => s.reset(),
        }
        self.w_n2 = [0.0; N];
        self.xi = SVector::zeros();
    }
    /// The weights `Ŵ`: on the full grid interleaved by node (`w[k·N + j]`: node k, output j);
    /// otherwise in the layout of [`StructuredNn::weights`]. With the `batched` kernels'
    /// updates pending (or `batched-f32`'s weights in its `f32` store) they are computed into a
    /// new buffer ([`RbfNetwork::weights_now`]), so reading them does not change the run.
    pub fn weights(&self) -> std::borrow::Cow<'_, [f64]> {
        match &self.network {
            Network::Grid { net, .. } => net.weights_now(),
            Network::Structured(s) => std::borrow::Cow::Borrowed(s.weights()),
        }
    }
    /// The structured network, when the gains select one (`None` on the paper's full grid).
    pub fn structured(&self) -> Option<&StructuredNn<N>> {
        match &self.network {
            Network::Grid { .. } => None,
            Network::Structured(s) => Some(s),
        }
    }
    /// Switch the anti-windup filter of [`AdaptiveNn::anti_windup`] on, with the inertia `M_j`
    /// per output (kg, kg m², …; `> 0`, finite); `ξ` starts at zero.
    pub fn set_anti_windup_inertia(&mut self, m: [f64; N]) {
        self.xi = SVector::zeros();
        self.aw = Some(std::array::from_fn(|j| {
            let (k2, mj) = (self.k2[j], m[j]);
            if !(mj > 0.0 && mj.is_finite()) {
                // No inertia for this output: ξ_j stays zero.
                return (0.0, 0.0);
            }
            let a = -k2 * self.h / mj;
            // e^{a} and (1 − e^{a})/K2 (exp_m1 keeps the small-step gain accurate).
            (a.exp(), -a.exp_m1() / k2)
        }));
    }

    /// The robust term's smoothing in use.
    pub fn smoothing(&self) -> Smoothing {
        self.smoothing
    }

    /// The inertia `M_j` per output (kg, kg m², …) that [`Smoothing::Sampled`] sizes the
    /// robust term's boundary layer on: the lightest effective inertia `1/(𝓜⁻¹)_jj` the
    /// output can have (the fastest response to the term). With [`Smoothing::Paper`], or for
    /// an output whose `M_j` is not positive and finite, `ϖ_j = ϖ`.
    pub fn set_sampling_inertia(&mut self, m: [f64; N]) {
        for j in 0..N {
            let mj = m[j];
            self.inv_slope_cap[j] =
                if self.smoothing == Smoothing::Sampled && mj > 0.0 && mj.is_finite() {
                    self.h / (SAMPLED_BETA * mj)
                } else {
                    0.0
                };
        }
    }

    /// The widest robust-term boundary layer `ϖ_j` the law would use at `f_jᵁ = fu`
    /// (`ϖ` with [`Smoothing::Paper`]).
    pub fn varpi_at(&self, j: usize, fu: f64) -> f64 {
        self.varpi.max(fu * fu * self.inv_slope_cap[j])
    }

    /// Switch the anti-windup filter off (`ξ = 0`: the update (44) on `z2` whatever the
    /// actuator does; for comparisons).
    pub fn clear_anti_windup(&mut self) {
        self.aw = None;
        self.xi = SVector::zeros();
    }

    /// The anti-windup state `ξ` (zero while the actuator never limited the law).
    pub fn anti_windup_state(&self) -> SVector<f64, N> {
        self.xi
    }

    /// Anti-windup of the update (44) against a limiting actuator (issue 24). `deficit` is the
    /// actuator's deficit `δτ = τ_applied − τ_cmd` of the tick just run, mapped to the law's
    /// outputs with the maps the controller distributes the law's output with (planar: the
    /// arms' `J_eᵀ` and the grasp maps of (14); spatial: the wrist wrenches through the grasp
    /// map and the chart). The part of `z2` the deficit caused is estimated by the filter of
    /// the `z2` loop's dominant (damping) part,
    /// ```text
    /// M_j ξ̇_j = −K2_j ξ_j + δτ_j,
    /// ξ_j ← e^{−K2_j h/M_j} ξ_j + (1 − e^{−K2_j h/M_j}) δτ_j / K2_j   (exact for δτ held over the tick),
    /// ```
    /// and the update (44) is trained on what the law is responsible for,
    /// ```text
    /// Ŵ̇_j = −Θ_j (Q S (z_2j − ξ_j) + σ_j Ŵ_j),
    /// ```
    /// from the next tick on (one tick late: the deficit is known after the law ran). Without
    /// saturation `δτ = 0`, `ξ ≡ 0` and the update is (44) bit for bit. Without
    /// [`AdaptiveNn::set_anti_windup_inertia`] this does nothing. No allocation.
    pub fn anti_windup(&mut self, deficit: &SVector<f64, N>) {
        let Some(aw) = &self.aw else { return };
        for j in 0..N {
            let (e, g) = aw[j];
            let d = if deficit[j].is_finite() {
                deficit[j]
            } else {
                0.0
            };
            self.xi[j] = e * self.xi[j] + g * d;
        }
    }

    /// The adaptation gains `Θ_j`.
    pub fn theta(&self) -> [f64; N] {
        self.theta
    }

    /// One tick of (42)–(44): `(x_1, x_2, x_r, ẋ_r, ẍ_r) → τ` and the weight update over the
    /// control period; writes `z2, α, α̇, Q, ‖Ŵ‖` and the event flags into `out`. No
    /// allocation.
    pub fn wrench(
        &mut self,
        x1: &SVector<f64, N>,
        x2: &SVector<f64, N>,
        x_r: &SVector<f64, N>,
        xd_r: &SVector<f64, N>,
        xdd_r: &SVector<f64, N>,
        out: &mut NnInternals<N>,
    ) -> SVector<f64, N> {
        // Step 1: α, α̇ with barrier saturation (never NaN).
        let ev = self.iblf.eval(x1, x2, x_r, xd_r, xdd_r);
        // The flags or-ed over the outputs without early exit (no iterator closures).
        let (mut hit, mut bad) = (false, false);
        for s in &ev.saturation {
            hit |= s.x1 | s.x_r;
            bad |= s.non_finite;
        }
        out.barrier_hit = hit;
        out.non_finite = bad;
        let z2 = x2 - ev.alpha;
        // Z = [x1, x2, α, α̇] (SPEC §3.4); one length check, then constant indices.
        let z = &mut self.z[..4 * N];
        for j in 0..N {
            z[j] = x1[j];
            z[N + j] = x2[j];
            z[2 * N + j] = ev.alpha[j];
            z[3 * N + j] = ev.alpha_dot[j];
        }
        let q = self.switching.eval(&self.z);
        self.ticks += 1;
        // The update's error: z2, less the part the actuator's deficit caused
        // ([`AdaptiveNn::anti_windup`]; ξ = 0 without saturation: z2 itself).
        let e2 = if self.xi == SVector::<f64, N>::zeros() {
            z2
        } else {
            z2 - self.xi
        };
        let (phi_a, norms) = match &mut self.network {
            Network::Grid { rbf, rbf_ws, net } => {
                // S(Z) on the grid, outputs with the old weights and the exact held-input update
                // of (44), fused in one pass over the weights.
                let phi_a = net.tick_at_outputs(rbf, &self.z, rbf_ws, q, &e2, &self.update);
                // ‖Ŵ_j‖ for the record: ‖e Ŵ − c S‖² = e²‖Ŵ‖² − 2ec Ŵ·S + c²‖S‖², Ŵ·S = f̂_j.
                if self.ticks.is_multiple_of(NORM_REFRESH) {
                    // The exact norms need the stored weights to be `Ŵ` (kernels `batched`,
                    // `batched-f32`).
                    net.flush();
                    let n = net.norms();
                    for j in 0..N {
                        self.w_n2[j] = n[j] * n[j];
                    }
                } else {
                    let (e, g, s2) = (self.update.decay(), self.update.gain(), rbf_ws.s_norm2());
                    for j in 0..N {
                        let c = g[j] * q * e2[j];
                        self.w_n2[j] = (e[j] * e[j] * self.w_n2[j] - 2.0 * e[j] * c * phi_a[j]
                            + c * c * s2)
                            .max(0.0);
                    }
                }
                let norms: [f64; N] = std::array::from_fn(|j| self.w_n2[j].sqrt());
                (phi_a, norms)
            }
            Network::Structured(s) => {
                // Per output: f̂_j = Ŵ_jᵀ S_j(Z) and the exact update (44), Q over the full Z.
                let t = s.tick(&self.z, q, &e2);
                (t.f_hat, std::array::from_fn(|j| t.w_norm[j]))
            }
        };
        let (nx2, na, nad) = (x2.norm(), ev.alpha.norm(), ev.alpha_dot.norm());
        let mut tau = SVector::<f64, N>::zeros();
        for j in 0..N {
            let fu = fu_value(self.fu_k[j], nx2, na, nad);
            // With Q = 1 the robust term is weighted by (1 − Q) = +0: the product is ±0 with
            // the sign of φ_b. For a finite x, clamp(x, −1, 1) has the sign and zero-ness of
            // tanh(x) and keeps −f^U·(it) finite, so it stands in for tanh(x) there with the
            // same bits (the NN branch skips the tanh).
            // ϖ_j: the paper's ϖ, or the sampled-data boundary layer of [`Smoothing::Sampled`]
            // (`max(ϖ, f^U² h/(β M_j))`, `docs/smooth-nn.md`; `inv_slope_cap = 0` gives ϖ).
            let varpi = self.varpi.max(fu * fu * self.inv_slope_cap[j]);
            let x = fu * z2[j] / varpi;
            let th = if q == 1.0 && x.is_finite() {
                x.clamp(-1.0, 1.0)
            } else {
                x.tanh()
            };
            let phi_b = -fu * th;
            let sgn = if z2[j] > 0.0 {
                1.0
            } else if z2[j] < 0.0 {
                -1.0
            } else {
                0.0
            };
            tau[j] = -ev.gain[j] * ev.z1[j] - self.k2[j] * z2[j] + q * phi_a[j] + (1.0 - q) * phi_b
                - self.k_r[j] * sgn;
            out.w_norm[j] = norms[j];
        }
        out.z2 = z2;
        out.alpha = ev.alpha;
        out.alpha_dot = ev.alpha_dot;
        out.q = q;
        tau
    }
}

/// Re-label a sub-module's parameter path as a `gains.` path.
fn prefix_gains(e: ModelError, from: &str, to: &str) -> ModelError {
    match e {
        ModelError::Invalid {
            param,
            value,
            reason,
        } => {
            let p = if !from.is_empty() {
                param.replace(to, from)
            } else {
                param
            };
            ModelError::Invalid {
                param: format!("gains.{p}"),
                value,
                reason,
            }
        }
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sampled_boundary_layer_caps_the_robust_slope_and_keeps_the_paper_where_it_fits() {
        // ϖ_j = max(ϖ, f² h/(β M_j)): the linear zone's slope f²/ϖ_j is at most β M_j/h, and
        // where the paper's ϖ already meets that the law keeps it (docs/smooth-nn.md).
        let plant = Plant::new(&crate::presets::paper()).unwrap();
        let k_c = Vector3::repeat(0.35);
        let fu = FuBound::from_model(&plant, k_c, [0.02, 0.02, 0.0], 1.5).unwrap();
        let h = 1e-3;
        let sampled = NnGains {
            smoothing: Smoothing::Sampled,
            ..NnGains::tuned()
        };
        let mut nn = AdaptiveNn::<3>::new(&sampled, k_c, fu.clone(), h).unwrap();
        // Before the inertia is known, and with the paper's form: ϖ.
        assert_eq!(nn.varpi_at(0, 100.0), 0.05);
        let m = [2.0, 3.0, 0.5];
        nn.set_sampling_inertia(m);
        for (j, &mj) in m.iter().enumerate() {
            for f in [0.1, 1.0, 10.0, 164.0, 1e4] {
                let v = nn.varpi_at(j, f);
                assert!(v >= 0.05);
                let slope = f * f / v;
                assert!(
                    slope <= SAMPLED_BETA * mj / h * (1.0 + 1e-12),
                    "{j} {f}: {slope}"
                );
                // Paper's ϖ kept exactly where its slope fits.
                if f * f / 0.05 <= SAMPLED_BETA * mj / h {
                    assert_eq!(v, 0.05);
                }
            }
        }
        // The paper form ignores the inertia.
        let mut paper = AdaptiveNn::<3>::new(&NnGains::tuned(), k_c, fu, h).unwrap();
        paper.set_sampling_inertia(m);
        assert_eq!(paper.smoothing(), Smoothing::Paper);
        assert_eq!(paper.varpi_at(1, 164.0), 0.05);
        // The lightest effective inertias over the box are positive and finite, and no more
        // than the row-norm bound of (14)'s 𝓜 that `f^U`'s c_j carries.
        let fu = FuBound::from_model(&plant, k_c, [0.02, 0.02, 0.0], 1.0).unwrap();
        let light = FuBound::lightest_inertia(&plant, k_c);
        for j in 0..3 {
            assert!(light[j] > 0.0 && light[j].is_finite(), "{light:?}");
            assert!(
                light[j] <= fu.c[j] * (1.0 + 1e-12),
                "{light:?} vs {:?}",
                fu.c
            );
        }
    }

    #[test]
    fn recorded_weight_norms_equal_the_exact_norms() {
        // The norms are carried by a recurrence between exact refreshes; after 2500 ticks of
        // varied inputs they must equal ‖Ŵ_j‖ computed from the weights (relative 1e-9: the
        // recurrence adds a few ulps per tick, refreshed every 1000 ticks).
        let plant = Plant::new(&crate::presets::paper()).unwrap();
        let k_c = Vector3::repeat(0.35);
        let fu = FuBound::from_model(&plant, k_c, [0.02, 0.02, 0.0], 1.5).unwrap();
        let mut nn = AdaptiveNn::<3>::new(&NnGains::paper(), k_c, fu, 1e-3).unwrap();
        let mut rec = NnInternals::default();
        for k in 0..2500 {
            let t = k as f64 * 1e-3;
            let x1 = Vector3::new(
                0.19 + 0.01 * (3.0 * t).sin(),
                0.02 * t.cos(),
                0.01 * (5.0 * t).sin(),
            );
            let x2 = Vector3::new(
                0.03 * (3.0 * t).cos(),
                -0.02 * t.sin(),
                0.05 * (5.0 * t).cos(),
            );
            let xr = Vector3::new(0.19, 0.0, 0.0);
            nn.wrench(
                &x1,
                &x2,
                &xr,
                &Vector3::zeros(),
                &Vector3::zeros(),
                &mut rec,
            );
            if k % 97 == 0 || k == 2499 {
                for j in 0..3 {
                    let exact = nn
                        .weights()
                        .iter()
                        .skip(j)
                        .step_by(3)
                        .map(|x| x * x)
                        .sum::<f64>()
                        .sqrt();
                    assert!(
                        (rec.w_norm[j] - exact).abs() <= 1e-9 * exact.max(1e-12),
                        "tick {k}, output {j}: {} vs {exact}",
                        rec.w_norm[j]
                    );
                }
            }
        }
    }
}
