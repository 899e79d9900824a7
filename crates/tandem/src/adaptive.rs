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
//! module [`crate::iblf`]).
//!
//! `f_jᵁ(Z) = a_j + b_j ‖x_2‖‖α‖ + c_j ‖α̇‖ + d_j ‖α‖` bounds `|F_j(Z)|` of (39),
//! `F = 𝓖 + 𝓒α + 𝓜α̇ + F_d`; the constants come from the controller's model at set-up
//! ([`FuBound::from_model`]).

use nalgebra::{Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::control::TickRecord;
use crate::error::{ModelError, positive};
use crate::iblf::Iblf;
use crate::plant::Plant;
use crate::rbf::{AdaptiveRbf, RbfGrid};
use crate::switching::{SwitchParams, Switching};

/// Gains of the NN law (plain data). Presets: [`NnGains::paper`], [`NnGains::tuned`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NnGains {
    /// `K1` diagonal (virtual control gain κ1), 1/s.
    pub k1: [f64; 3],
    /// `K2` diagonal, (N s/m, N s/m, N m s/rad).
    pub k2: [f64; 3],
    /// `K_r` diagonal (sign term), (N, N, N m).
    pub k_r: [f64; 3],
    /// Adaptation gains `Θ_j`.
    pub theta: [f64; 3],
    /// σ-modification `σ_j`.
    pub sigma: [f64; 3],
    /// Robust-term smoothing `ϖ`.
    pub varpi: f64,
    /// Safety factor on the `f^U` constants.
    pub fu_safety: f64,
    /// RBF width `ϑ²` ("variance").
    pub width2: f64,
    /// Centre levels per input (the grid is their Cartesian product over the 12 inputs).
    pub levels: Vec<f64>,
    /// Switching inner radius `d1` (every input).
    pub d1: f64,
    /// Switching outer radius `d2`.
    pub d2: f64,
    /// Switching shape `ω ≥ 1`.
    pub omega: f64,
}

impl NnGains {
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

/// Constants of `f_jᵁ = a_j + b_j ‖x_2‖‖α‖ + c_j ‖α̇‖ + d_j ‖α‖`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FuBound {
    /// Gravity plus disturbance bound, (N, N, N m).
    pub a: [f64; 3],
    /// Coriolis coefficient.
    pub b: [f64; 3],
    /// Inertia row norms.
    pub c: [f64; 3],
    /// Object damping row norms.
    pub d: [f64; 3],
    /// Model poses used (reachable and well-conditioned).
    pub poses: usize,
}

impl FuBound {
    /// Bound the terms of (39) over the part of the constraint box `|x_j| ≤ k_cj` where every
    /// arm reaches its grasp with `σ_min(J_e) ≥ 0.05 m/rad`, on a 13 × 13 × 5 grid, times
    /// `safety`. `𝓒(x, ẋ) − C_o` is linear in `ẋ`, so `|((𝓒 − C_o)α)_j| ≤ ‖x_2‖‖α‖ Σ_k ‖row_j C_k‖`
    /// with `C_k = 𝓒(x, e_k) − C_o`.
    pub fn from_model(
        model: &Plant,
        k_c: Vector3<f64>,
        dist: [f64; 3],
        safety: f64,
    ) -> Result<Self, ModelError> {
        let mut ws = model.workspace();
        let (mut a, mut b, mut c) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        let mut poses = 0;
        let n = 13;
        let nt = 5;
        for ix in 0..n {
            for iy in 0..n {
                for it in 0..nt {
                    let f =
                        |i: usize, m: usize, k: f64| k * (2.0 * i as f64 / (m - 1) as f64 - 1.0);
                    let x = Vector3::new(f(ix, n, k_c.x), f(iy, n, k_c.y), f(it, nt, k_c.z));
                    let Ok(os) = model.object_space(&x, &Vector3::zeros(), &mut ws) else {
                        continue;
                    };
                    // Conditioning of every arm at this pose (kinematics left in ws by object_space).
                    let sig = model
                        .arms()
                        .iter()
                        .enumerate()
                        .map(|(i, arm)| arm.min_singular_value(&ws.terms[i]))
                        .fold(f64::INFINITY, f64::min);
                    if sig < 0.05 {
                        continue;
                    }
                    let mut ck = [nalgebra::Matrix3::zeros(); 3];
                    let mut ok = true;
                    for (k, ckk) in ck.iter_mut().enumerate() {
                        let mut e = Vector3::zeros();
                        e[k] = 1.0;
                        match model.object_space(&x, &e, &mut ws) {
                            Ok(o) => *ckk = o.C - model.object().C_o,
                            Err(_) => ok = false,
                        }
                    }
                    if !ok {
                        continue;
                    }
                    poses += 1;
                    for j in 0..3 {
                        a[j] = a[j].max(os.G[j].abs());
                        c[j] = c[j].max(os.M.row(j).norm());
                        b[j] = b[j].max(ck.iter().map(|m| m.row(j).norm()).sum());
                    }
                }
            }
        }
        if poses == 0 {
            return Err(ModelError::geometry(
                "k_c",
                "no pose in the constraint box is reachable by every arm with a well-conditioned Jacobian",
            ));
        }
        let co = model.object().C_o;
        let mut d = [0.0; 3];
        for j in 0..3 {
            a[j] = safety * (a[j] + dist[j]);
            b[j] *= safety;
            c[j] *= safety;
            d[j] = safety * co.row(j).norm();
        }
        Ok(FuBound { a, b, c, d, poses })
    }

    /// `f_jᵁ(Z)`.
    #[inline]
    pub fn eval(&self, j: usize, x2: f64, alpha: f64, alpha_dot: f64) -> f64 {
        self.a[j] + self.b[j] * x2 * alpha + self.c[j] * alpha_dot + self.d[j] * alpha
    }
}

/// The NN law: validated gains, the iBLF, switching, the RBF grid and its weights (state), and
/// the input/basis scratch.
pub struct AdaptiveNn {
    iblf: Iblf<3>,
    switching: Switching,
    grid: RbfGrid,
    net: AdaptiveRbf,
    k2: Vector3<f64>,
    k_r: Vector3<f64>,
    varpi: f64,
    fu: FuBound,
    h: f64,
    theta: [f64; 3],
    z: [f64; 12],
    s: Vec<f64>,
}

impl AdaptiveNn {
    /// Validate the gains against the theory's conditions (SPEC §3.4: `K1, K2, Θ, σ > 0`,
    /// `0 < d1 < d2`, `ω ≥ 1`, `ϖ > 0`, `ϑ² > 0`) and build the network and the `f^U` bound.
    pub fn new(
        g: &NnGains,
        k_c: Vector3<f64>,
        model: &Plant,
        dist: [f64; 3],
        h: f64,
    ) -> Result<Self, ModelError> {
        for j in 0..3 {
            positive(&format!("gains.k2[{j}]"), g.k2[j])?;
            crate::error::non_negative(&format!("gains.k_r[{j}]"), g.k_r[j])?;
            positive(&format!("gains.theta[{j}]"), g.theta[j])?;
            positive(&format!("gains.sigma[{j}]"), g.sigma[j])?;
        }
        positive("gains.varpi", g.varpi)?;
        positive("gains.fu_safety", g.fu_safety)?;
        let iblf =
            Iblf::new(k_c, Vector3::from(g.k1)).map_err(|e| prefix_gains(e, "k1", "kappa1"))?;
        let sw = SwitchParams::new(g.d1, g.d2, g.omega).map_err(|e| prefix_gains(e, "", ""))?;
        let switching = Switching::uniform(12, sw)?;
        if g.levels.is_empty() {
            return Err(ModelError::geometry(
                "gains.levels",
                "needs at least one centre level",
            ));
        }
        let grid =
            RbfGrid::uniform(12, &g.levels, g.width2).map_err(|e| prefix_gains(e, "", ""))?;
        let net = AdaptiveRbf::new(grid.n_nodes(), 3, &g.theta, &g.sigma)
            .map_err(|e| prefix_gains(e, "", ""))?;
        let fu = FuBound::from_model(model, k_c, dist, g.fu_safety)?;
        let s = vec![0.0; grid.n_nodes()];
        Ok(AdaptiveNn {
            iblf,
            switching,
            grid,
            net,
            k2: Vector3::from(g.k2),
            k_r: Vector3::from(g.k_r),
            varpi: g.varpi,
            fu,
            h,
            theta: g.theta,
            z: [0.0; 12],
            s,
        })
    }

    /// The `f^U` constants in use.
    pub fn fu(&self) -> &FuBound {
        &self.fu
    }
    /// Zero the weights.
    pub fn reset_weights(&mut self) {
        self.net.reset();
    }
    /// The weights `Ŵ`, interleaved by node (`w[k·3 + j]`: node k, output j).
    pub fn weights(&self) -> &[f64] {
        self.net.weights()
    }
    /// The adaptation gains `Θ_j`.
    pub fn theta(&self) -> [f64; 3] {
        self.theta
    }
    /// Current weight norms `‖Ŵ_j‖`.
    pub fn weight_norms(&self) -> [f64; 3] {
        let mut n = [0.0; 3];
        for (j, v) in n.iter_mut().enumerate() {
            *v = self.net.weight_norm(j);
        }
        n
    }

    /// One tick of (42)–(44): `(x_1, x_2, x_r, ẋ_r, ẍ_r) → τ` and the weight update over the
    /// control period; internals into `rec`. No allocation.
    pub fn wrench(
        &mut self,
        x1: &Vector3<f64>,
        x2: &Vector3<f64>,
        x_r: &Vector3<f64>,
        xd_r: &Vector3<f64>,
        xdd_r: &Vector3<f64>,
        rec: &mut TickRecord,
    ) -> Vector3<f64> {
        // Step 1: α, α̇ with barrier saturation (never NaN).
        let ev = self.iblf.eval(x1, x2, x_r, xd_r, xdd_r);
        rec.barrier_hit = ev.saturation.iter().any(|s| s.x1 || s.x_r);
        rec.non_finite |= ev.saturation.iter().any(|s| s.non_finite);
        let z2 = x2 - ev.alpha;
        // Z = [x1, x2, α, α̇] (SPEC §3.4).
        for j in 0..3 {
            self.z[j] = x1[j];
            self.z[3 + j] = x2[j];
            self.z[6 + j] = ev.alpha[j];
            self.z[9 + j] = ev.alpha_dot[j];
        }
        let q = self.switching.eval(&self.z);
        self.grid.eval_into(&self.z, &mut self.s);
        let mut phi_a = [0.0; 3];
        let mut norms = [0.0; 3];
        self.net
            .tick(&self.s, q, z2.as_slice(), self.h, &mut phi_a, &mut norms);
        let (nx2, na, nad) = (x2.norm(), ev.alpha.norm(), ev.alpha_dot.norm());
        let mut tau = Vector3::zeros();
        for j in 0..3 {
            let fu = self.fu.eval(j, nx2, na, nad);
            let phi_b = -fu * (fu * z2[j] / self.varpi).tanh();
            let sgn = if z2[j] > 0.0 {
                1.0
            } else if z2[j] < 0.0 {
                -1.0
            } else {
                0.0
            };
            tau[j] = -ev.gain[j] * ev.z1[j] - self.k2[j] * z2[j] + q * phi_a[j] + (1.0 - q) * phi_b
                - self.k_r[j] * sgn;
        }
        rec.z2 = z2;
        rec.alpha = ev.alpha;
        rec.alpha_dot = ev.alpha_dot;
        rec.q_switch = q;
        rec.w_norm = Vector3::from(norms);
        let _ = Vector6::<f64>::zeros;
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
