//! Network structures that scale past the paper's full grid: the same basis (8), output (41),
//! update (44) and switching (38), with the centres and the inputs each output sees chosen so
//! that the node count stays small for the spatial controller's 24 inputs (SPEC-spatial S5).
//!
//! $$
//! \hat f_j(Z) = \hat W_j^{\mathsf T} S_j(Z),\qquad
//! \dot{\hat W}_j = -\Theta_j\big(Q\,S_j(Z)\,z_{2j} + \sigma_j \hat W_j\big)\quad (41),\ (44)
//! $$
//!
//! The paper's proof (Theorem 1, (45)–(51)) approximates each component `F_j(Z)` of (39) by its
//! own network, `F_j = W_j^{*\mathsf T} S_j(Z) + ε_j`, and uses nothing about `S_j` except that
//! it is bounded; the basis may differ between outputs. So every structure below keeps the
//! proof's form: one weight vector per output, the exact held-input solution of (44) per output
//! ([`crate::control::rbf`]), and the scalar `Q = M(Z)` of (38) over the **full** `Z` (computed by the
//! caller, [`crate::control::law::switching`]).
//!
//! | structure | basis of output `j` | nodes (planar, `n = 3`) | nodes (spatial, `n = 6`) |
//! |---|---|---|---|
//! | [`NetworkStructure::FullGrid`] | grid `{levels}^{4n}` over all of `Z`, shared | `2^12 = 4096` | `2^24 ≈ 1.7e7` |
//! | [`NetworkStructure::PerAxis`] | grid `{levels}^{|I_j|}` over `Z_{I_j}` | `3 × 2^4 = 48` | `6 × 2^4 = 96` |
//! | [`NetworkStructure::QuasiRandom`] | `N` scrambled-Halton centres in the box, shared | `N` | `N` |
//!
//! `I_j` defaults to output `j`'s own four signals `(x_1j, x_2j, α_j, α̇_j)` (indices
//! `j, n + j, 2n + j, 3n + j` of `Z`); any subset of `Z` may be given per output (cross terms).
//! Levels and the width `ϑ²` are shared with the full grid (`NnGains::levels`, `width2`); the
//! quasi-random centres fill the box `[min levels, max levels]^{4n}`.
//!
//! # Gains
//!
//! With the paper's `ϑ² = 50` every basis is nearly constant over the constraint box, so the
//! network acts per output as an adaptive bias with loop gain `γ_j = Θ_j ‖S_j‖²` (SPEC §3.4).
//! Changing the structure changes `‖S_j‖²` (2535 on the paper grid near `Z = 0`, 13.6 on a
//! 16-node axis grid), hence `γ_j`: keep `γ_j` by scaling `Θ_j` with
//! [`matched_theta`] (`docs/network.md` shows both).
//!
//! # Evaluation
//!
//! [`StructuredNn::tick`] is allocation-free. Per-axis: the Kronecker form of [`Rbf::grid`] on
//! each output's inputs, then one fused pass over that output's weights (output with the old
//! weights, exact update, norm), in a fixed order. The default axis grid (four inputs, two
//! levels, 16 nodes) goes through a fixed-size kernel (`pair4_tick`) that does the same on
//! arrays; for networks of six or more outputs (the spatial law) it also shares exponentials
//! between the factors (five a node grid instead of eight, a few ulps from the direct form),
//! for the planar ones it keeps the direct factors and the generic path's bits. Shared bases (full grid, quasi-random) go
//! through [`RbfNetwork::tick_at`] (the fused AVX2 pass of [`crate::control::rbf`]).

use nalgebra::{DMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::control::rbf::{MAX_NODES, NnTick, NnUpdate, Rbf, RbfNetwork, RbfWorkspace};
use crate::error::ModelError;
use crate::math::random::splitmix64;

/// Largest number of quasi-random centres (a guard against typos; 2^20 × 8 outputs is 64 MB).
pub const MAX_QUASI_RANDOM: usize = 1 << 20;

/// How the RBF network of the NN law is built (plain data; `NnGains::network`). The default is
/// the paper's full grid, bit for bit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum NetworkStructure {
    /// The paper's network (SPEC §3.4): one basis shared by all outputs, the grid of
    /// `NnGains::levels` on every one of the `4n` inputs (`levels^{4n}` nodes).
    #[default]
    FullGrid,
    /// One Kronecker grid network per output over a subset of `Z`: output `j` sees
    /// `Z_i, i ∈ inputs[j]`, each input on the grid of `NnGains::levels`
    /// (`levels^{|inputs[j]|}` nodes for output `j`).
    PerAxis {
        /// Indices into `Z = [x_1, x_2, α, α̇]` (length `4n`) per output; empty (the default)
        /// means output `j`'s own signals `[j, n + j, 2n + j, 3n + j]`.
        #[serde(default)]
        inputs: Vec<Vec<usize>>,
    },
    /// One basis shared by all outputs: `n` centres of a scrambled Halton sequence (random digit
    /// permutations drawn from `seed`) in the box `[min levels, max levels]^{4n}`.
    QuasiRandom {
        /// Number of centres `N_s`.
        n: usize,
        /// Seed of the digit scrambling (the same seed gives the same centres).
        #[serde(default)]
        seed: u64,
    },
}

impl NetworkStructure {
    /// Whether this is the paper's full grid (the default).
    pub fn is_full_grid(&self) -> bool {
        matches!(self, NetworkStructure::FullGrid)
    }

    /// Short name: `full_grid`, `per_axis` or `quasi_random`.
    pub fn name(&self) -> &'static str {
        match self {
            NetworkStructure::FullGrid => "full_grid",
            NetworkStructure::PerAxis { .. } => "per_axis",
            NetworkStructure::QuasiRandom { .. } => "quasi_random",
        }
    }

    /// The per-axis structure over each output's own four signals.
    pub fn per_axis() -> Self {
        NetworkStructure::PerAxis { inputs: Vec::new() }
    }

    /// The input indices of output `j` of `n_out` for a per-axis structure (the defaults
    /// filled in); `None` for the shared structures.
    pub fn inputs_of(&self, j: usize, n_out: usize) -> Option<Vec<usize>> {
        match self {
            NetworkStructure::PerAxis { inputs } if inputs.is_empty() => {
                Some((0..4).map(|s| s * n_out + j).collect())
            }
            NetworkStructure::PerAxis { inputs } => inputs.get(j).cloned(),
            _ => None,
        }
    }
}

/// `‖S(0)‖²` of a grid of `levels` on `n_in` inputs, width `ϑ²`, in closed form:
/// `(Σ_l e^{−2c_l²/ϑ²})^{n_in}` (the Kronecker factors' norms multiply). Works for grids far too
/// large to build (the spatial `2^24`).
pub fn grid_norm2_at_zero(levels: &[f64], width2: f64, n_in: usize) -> f64 {
    let per: f64 = levels.iter().map(|c| (-2.0 * c * c / width2).exp()).sum();
    per.powi(n_in as i32)
}

/// `Θ_j` scaled so that the adaptive-bias loop gain `γ_j = Θ_j‖S_j(0)‖²` equals the paper
/// grid's on 12 inputs, `Θ_j · ‖S_grid(0)‖² / ‖S_j(0)‖²` (SPEC §3.4's `γ = Θ‖S‖²`). `norm2[j]`
/// is `‖S_j(0)‖²` of the structure ([`StructuredNn::norm2_at_zero`]).
pub fn matched_theta<const M: usize>(
    theta: &[f64],
    levels: &[f64],
    width2: f64,
    norm2: &[f64; M],
) -> [f64; M] {
    let reference = grid_norm2_at_zero(levels, width2, 12);
    std::array::from_fn(|j| theta[j] * reference / norm2[j])
}

/// The first 32 primes: Halton bases of up to 32 inputs (`4n`, `n ≤ 8`).
const PRIMES: [u64; 32] = [
    2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71, 73, 79, 83, 89, 97,
    101, 103, 107, 109, 113, 127, 131,
];

/// `n` points of the scrambled Halton sequence in `[0, 1)^dim` (row `k` = point `k + 1` of the
/// sequence), digit `d` of base `p_i` replaced by `π_i(d)`, `π_i` a permutation of `0..p_i`
/// with `π_i(0) = 0` drawn from `seed` (Fisher–Yates on SplitMix64). Scrambling breaks the
/// correlation of plain Halton between large bases (the first `p` points of bases `p`, `p'`
/// lie on a line). Deterministic.
///
/// # Panics
/// If `dim > 32`.
pub fn scrambled_halton(n: usize, dim: usize, seed: u64) -> DMatrix<f64> {
    assert!(
        dim <= PRIMES.len(),
        "scrambled_halton: at most 32 dimensions"
    );
    let mut state = splitmix64(seed ^ 0x6a09_e667_f3bc_c909);
    let mut next = || {
        state = splitmix64(state);
        state
    };
    let perms: Vec<Vec<u64>> = PRIMES[..dim]
        .iter()
        .map(|&p| {
            let mut perm: Vec<u64> = (0..p).collect();
            // Shuffle 1..p, keep 0 fixed (trailing zero digits must stay zero).
            for i in (2..p as usize).rev() {
                let k = 1 + (next() % i as u64) as usize;
                perm.swap(i, k);
            }
            perm
        })
        .collect();
    DMatrix::from_fn(n, dim, |k, i| {
        let p = PRIMES[i];
        let (mut idx, mut f, mut u) = (k as u64 + 1, 1.0 / p as f64, 0.0);
        while idx > 0 {
            u += perms[i][(idx % p) as usize] as f64 * f;
            idx /= p;
            f /= p as f64;
        }
        u
    })
}

/// One output's own grid network (per-axis structure).
#[derive(Debug, Clone, PartialEq)]
struct AxisNet {
    /// Indices into `Z`.
    inputs: Vec<usize>,
    rbf: Rbf,
    ws: RbfWorkspace,
    /// Start of this output's weights in the shared weight vector.
    offset: usize,
    /// `(c_0, c_1, 1/ϑ²)` when the basis is a grid of four inputs on two levels (the default
    /// per-axis network): evaluated by the fixed-size kernel [`pair4_tick`] (shared
    /// exponentials).
    pair4: Option<(f64, f64, f64)>,
    /// Share exponentials in [`pair4_tick`] (networks of [`SHARED_EXP_MIN_OUTPUTS`] or more
    /// outputs); otherwise the kernel computes every factor directly, the bits of the generic
    /// path.
    share_exp: bool,
}

/// Largest `|2 δ y_i/ϑ²|` for which [`pair4_tick`] shares the exponentials; beyond it (or
/// with a Gaussian part below `e^{−400}`) each factor gets its own exponential. Within both
/// limits every partial product lies in `[e^{−600}, e^{200}]`: no overflow, no underflow
/// before the last product.
const SHARED_EXP_LIMIT: f64 = 100.0;
/// Largest `(Σ y_i² + 4δ²)/ϑ²` for which [`pair4_tick`] shares the exponentials.
const SHARED_GAUSS_LIMIT: f64 = 400.0;
/// Networks with at least this many outputs (the spatial law's six) share exponentials in
/// the fixed-size per-axis kernel (`pair4_tick`); the planar laws' networks (two or three outputs) compute every factor
/// directly, so planar results stay bit for bit those of the generic path (a project rule).
pub const SHARED_EXP_MIN_OUTPUTS: usize = 6;

/// One output of the per-axis network on a grid of four inputs with two levels `c_0, c_1`
/// each (16 nodes), fused: the basis (8), the output `Ŵᵀ S` with the old weights, the exact
/// update (44) `Ŵ ← e Ŵ − c S`, and `‖Ŵ‖²` after it. Writes `S` into `s`; returns
/// `(Ŵᵀ S, ‖Ŵ‖², ‖S‖²)`.
///
/// The factors share exponentials: with the levels `m ∓ δ` (`m` their midpoint, `δ` the
/// half-spacing) and `y_i = Z_i − m`,
///
/// $$ e^{-(y_i \pm \delta)^2/\vartheta^2} = e^{-(y_i^2 + \delta^2)/\vartheta^2}\,
///    t_i^{\mp 1},\qquad t_i = e^{2\delta y_i/\vartheta^2}, $$
///
/// and the Gaussian parts of the four inputs multiply into one,
/// `S = e^{−(Σ y_i² + 4δ²)/ϑ²} (t_0^{∓} ⊗ t_1^{∓}) ⊗ (t_2^{∓} ⊗ t_3^{∓})`: five exponentials
/// and four reciprocals instead of eight exponentials, `‖S‖² = e^{−2(…)/ϑ²} Π(t_i² + t_i^{−2})`.
/// Agrees with the direct (8) to a few ulps (test
/// `the_fixed_size_axis_kernel_agrees_with_the_generic_path`). Without `share` (planar
/// networks), or where some `|2δ y_i/ϑ²|` exceeds [`SHARED_EXP_LIMIT`] or the Gaussian part
/// [`SHARED_GAUSS_LIMIT`] (an input far outside the grid), the factors are direct, with the
/// operations and order of [`Rbf::eval_into`] and the generic pass: the same bits.
#[inline(always)]
fn pair4_tick(
    z: &[f64; 4],
    (c0, c1, inv_width2): (f64, f64, f64),
    share: bool,
    w: &mut [f64; 16],
    decay: f64,
    c: f64,
    s: &mut [f64; 16],
) -> (f64, f64, f64) {
    let (mid, half) = (0.5 * (c0 + c1), 0.5 * (c1 - c0));
    let y = z.map(|v| v - mid);
    let k = 2.0 * half * inv_width2;
    // f[i] = [factor at c_0, factor at c_1] without the Gaussian part g (shared) or with it.
    let mut f = [[0.0; 2]; 4];
    let g;
    let r2 = 4.0 * half * half + y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3];
    if share
        && y.iter().all(|&v| (k * v).abs() <= SHARED_EXP_LIMIT)
        && r2 * inv_width2 <= SHARED_GAUSS_LIMIT
    {
        for i in 0..4 {
            let t = (k * y[i]).exp();
            f[i] = [1.0 / t, t];
        }
        g = (-r2 * inv_width2).exp();
    } else {
        for i in 0..4 {
            let (d0, d1) = (z[i] - c0, z[i] - c1);
            f[i] = [
                (-(d0 * d0) * inv_width2).exp(),
                (-(d1 * d1) * inv_width2).exp(),
            ];
        }
        g = 1.0;
    }
    let mut s_n2 = g * g;
    for fi in &f {
        s_n2 *= fi[0] * fi[0] + fi[1] * fi[1];
    }
    let a = [
        g * f[0][0] * f[1][0],
        g * f[0][0] * f[1][1],
        g * f[0][1] * f[1][0],
        g * f[0][1] * f[1][1],
    ];
    let b = [
        f[2][0] * f[3][0],
        f[2][0] * f[3][1],
        f[2][1] * f[3][0],
        f[2][1] * f[3][1],
    ];
    for i in 0..4 {
        for j in 0..4 {
            s[4 * i + j] = a[i] * b[j];
        }
    }
    let (mut acc, mut n2) = (0.0, 0.0);
    for k in 0..16 {
        let old = w[k];
        acc += old * s[k];
        let new = decay * old - c * s[k];
        w[k] = new;
        n2 += new * new;
    }
    (acc, n2, s_n2)
}

// One per controller, built once: the size difference does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
enum Kind<const M: usize> {
    /// One basis for all outputs (full grid or quasi-random): the fused kernel of `crate::control::rbf`.
    Shared {
        rbf: Rbf,
        ws: RbfWorkspace,
        net: RbfNetwork<M>,
    },
    /// A grid per output.
    PerAxis {
        axes: Vec<AxisNet>,
        /// Output after output: `w[offset_j + k]` is node `k` of output `j`.
        w: Vec<f64>,
        /// Gathered `Z_{I_j}` (length of the longest `I_j`).
        z_sub: Vec<f64>,
    },
}

/// An adaptive RBF network of a chosen [`NetworkStructure`] for `M` outputs: bases, weights
/// `Ŵ_j` (zero at start) and the discretised update (44). Built once, ticked allocation-free.
#[derive(Debug, Clone, PartialEq)]
pub struct StructuredNn<const M: usize> {
    kind: Kind<M>,
    update: NnUpdate<M>,
    n_in: usize,
}

impl<const M: usize> StructuredNn<M> {
    /// Build the structure on `4M` inputs (`Z = [x_1, x_2, α, α̇]`), with the grid `levels`
    /// (and the quasi-random box `[min, max]`), width `ϑ² = width2` and the update (44).
    /// Errors name the field under `gains.network`, e.g. `gains.network.inputs[1][2]`.
    pub fn new(
        structure: &NetworkStructure,
        levels: &[f64],
        width2: f64,
        update: NnUpdate<M>,
    ) -> Result<Self, ModelError> {
        let n_in = 4 * M;
        if levels.is_empty() {
            return Err(ModelError::geometry(
                "gains.levels",
                "needs at least one centre level",
            ));
        }
        if let Some(&bad) = levels.iter().find(|c| !c.is_finite()) {
            return Err(ModelError::invalid("gains.levels", bad, "must be finite"));
        }
        crate::error::positive("gains.width2", width2)?;
        let kind = match structure {
            NetworkStructure::FullGrid => {
                let rbf = Rbf::grid(&vec![levels.to_vec(); n_in], width2)?;
                Self::shared(rbf)?
            }
            NetworkStructure::QuasiRandom { n, .. } if *n == 0 || *n > MAX_QUASI_RANDOM => {
                return Err(ModelError::invalid(
                    "gains.network.n",
                    *n as f64,
                    format!("needs 1..={MAX_QUASI_RANDOM} centres"),
                ));
            }
            NetworkStructure::QuasiRandom { n, seed } => {
                let lo = levels.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = levels.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let u = scrambled_halton(*n, n_in, *seed);
                let centres = u.map(|x| lo + (hi - lo) * x);
                Self::shared(Rbf::general(&centres, width2)?)?
            }
            NetworkStructure::PerAxis { inputs } => {
                if !inputs.is_empty() && inputs.len() != M {
                    return Err(ModelError::geometry(
                        "gains.network.inputs",
                        format!(
                            "{} lists for {M} outputs (give one per output, or none)",
                            inputs.len()
                        ),
                    ));
                }
                let mut axes = Vec::with_capacity(M);
                let mut offset = 0;
                for j in 0..M {
                    let idx = structure.inputs_of(j, M).expect("per-axis");
                    let name = format!("gains.network.inputs[{j}]");
                    if idx.is_empty() {
                        return Err(ModelError::geometry(name, "needs at least one input"));
                    }
                    for (k, &i) in idx.iter().enumerate() {
                        if i >= n_in {
                            return Err(ModelError::invalid(
                                format!("{name}[{k}]"),
                                i as f64,
                                format!("must index Z, length {n_in}"),
                            ));
                        }
                        if idx[..k].contains(&i) {
                            return Err(ModelError::invalid(
                                format!("{name}[{k}]"),
                                i as f64,
                                "repeats an input of this output",
                            ));
                        }
                    }
                    let rbf = Rbf::grid(&vec![levels.to_vec(); idx.len()], width2)
                        .map_err(|e| rename(e, "rbf.levels", &name))?;
                    let ws = rbf.workspace();
                    let n = rbf.n_nodes();
                    let pair4 = rbf.two_level_four_input();
                    axes.push(AxisNet {
                        inputs: idx,
                        rbf,
                        ws,
                        offset,
                        pair4,
                        share_exp: M >= SHARED_EXP_MIN_OUTPUTS,
                    });
                    offset += n;
                    if offset > MAX_NODES {
                        return Err(ModelError::geometry(
                            "gains.network.inputs",
                            format!("more than {MAX_NODES} nodes in all"),
                        ));
                    }
                }
                let longest = axes.iter().map(|a| a.inputs.len()).max().unwrap_or(0);
                Kind::PerAxis {
                    axes,
                    w: vec![0.0; offset],
                    z_sub: vec![0.0; longest],
                }
            }
        };
        Ok(Self { kind, update, n_in })
    }

    fn shared(rbf: Rbf) -> Result<Kind<M>, ModelError> {
        let net = RbfNetwork::<M>::for_basis(&rbf)?;
        let ws = rbf.workspace();
        Ok(Kind::Shared { rbf, ws, net })
    }

    /// Number of inputs `4M`.
    pub fn n_inputs(&self) -> usize {
        self.n_in
    }

    /// Nodes of output `j`'s basis (`N_s` for a shared basis).
    ///
    /// # Panics
    /// If `j ≥ M`.
    pub fn nodes_of(&self, j: usize) -> usize {
        assert!(j < M, "structured_nn: output index");
        match &self.kind {
            Kind::Shared { rbf, .. } => rbf.n_nodes(),
            Kind::PerAxis { axes, .. } => axes[j].rbf.n_nodes(),
        }
    }

    /// Number of weights in all, `Σ_j N_j` (`M · N_s` for a shared basis).
    pub fn n_weights(&self) -> usize {
        self.weights().len()
    }

    /// The update law (44) in use.
    pub fn update(&self) -> &NnUpdate<M> {
        &self.update
    }

    /// All weights. Shared basis: node-major, `w[k·M + j]` (as [`RbfNetwork::weights`]).
    /// Per-axis: output after output, node `k` of output `j` at `offset_j + k`,
    /// `offset_j = Σ_{i<j} N_i`.
    pub fn weights(&self) -> &[f64] {
        match &self.kind {
            Kind::Shared { net, .. } => net.weights(),
            Kind::PerAxis { w, .. } => w,
        }
    }

    /// Mutable weights in the layout of [`StructuredNn::weights`] (e.g. to restore a checkpoint).
    pub fn weights_mut(&mut self) -> &mut [f64] {
        match &mut self.kind {
            Kind::Shared { net, .. } => net.weights_mut(),
            Kind::PerAxis { w, .. } => w,
        }
    }

    /// Weight `Ŵ_j[k]` (node `k` of output `j`'s basis).
    ///
    /// # Panics
    /// If `j ≥ M` or `k ≥` [`StructuredNn::nodes_of`]`(j)`.
    pub fn weight(&self, j: usize, k: usize) -> f64 {
        assert!(k < self.nodes_of(j), "structured_nn: node index");
        match &self.kind {
            Kind::Shared { net, .. } => net.weight(k, j),
            Kind::PerAxis { axes, w, .. } => w[axes[j].offset + k],
        }
    }

    /// All weights back to 0.
    pub fn reset(&mut self) {
        self.weights_mut().fill(0.0);
    }

    /// `S_j(Z)` of output `j` at the last tick (the shared `S` for a shared basis).
    ///
    /// # Panics
    /// If `j ≥ M`.
    pub fn basis_of(&self, j: usize) -> &[f64] {
        assert!(j < M, "structured_nn: output index");
        match &self.kind {
            Kind::Shared { ws, .. } => ws.s(),
            Kind::PerAxis { axes, .. } => axes[j].ws.s(),
        }
    }

    /// The input indices of output `j` (all of `0..4M` for a shared basis).
    ///
    /// # Panics
    /// If `j ≥ M`.
    pub fn inputs_of(&self, j: usize) -> Vec<usize> {
        assert!(j < M, "structured_nn: output index");
        match &self.kind {
            Kind::Shared { .. } => (0..self.n_in).collect(),
            Kind::PerAxis { axes, .. } => axes[j].inputs.clone(),
        }
    }

    /// `‖S_j(0)‖²` per output, the quantity that sets the adaptive-bias gain `Θ_j‖S_j‖²`
    /// (see [`matched_theta`]). Evaluated on a copy (allocates; for set-up).
    pub fn norm2_at_zero(&self) -> [f64; M] {
        let z = vec![0.0; self.n_in];
        match &self.kind {
            Kind::Shared { rbf, .. } => {
                let mut ws = rbf.workspace();
                rbf.eval_into(&z, &mut ws);
                [ws.s_norm2(); M]
            }
            Kind::PerAxis { axes, .. } => std::array::from_fn(|j| {
                let a = &axes[j];
                let mut ws = a.rbf.workspace();
                a.rbf.eval_into(&z[..a.inputs.len()], &mut ws);
                ws.s_norm2()
            }),
        }
    }

    /// `‖Ŵ_j‖` per output (one read pass).
    pub fn norms(&self) -> SVector<f64, M> {
        match &self.kind {
            Kind::Shared { net, .. } => net.norms(),
            Kind::PerAxis { axes, w, .. } => SVector::from_fn(|j, _| {
                let a = &axes[j];
                w[a.offset..a.offset + a.rbf.n_nodes()]
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>()
                    .sqrt()
            }),
        }
    }

    /// One tick of (41) + (44): `(Z, Q, z_2) → (f̂_j = Ŵ_jᵀ S_j(Z)` with the weights before the
    /// update, `‖Ŵ_j‖` after it`)`, and `Ŵ_j ← e^{−Θ_jσ_jh} Ŵ_j − ((1 − e^{−Θ_jσ_jh})/σ_j) Q S_j z_2j`
    /// (the exact solution of (44) for held inputs). `Q` is the switching value (38) over the
    /// full `Z`. No allocation.
    ///
    /// # Panics
    /// If `z.len() != 4M`.
    pub fn tick(&mut self, z: &[f64], q: f64, z2: &SVector<f64, M>) -> NnTick<M> {
        assert_eq!(z.len(), self.n_in, "structured_nn: input length");
        match &mut self.kind {
            Kind::Shared { rbf, ws, net } => net.tick_at(rbf, z, ws, q, z2, &self.update),
            Kind::PerAxis { axes, w, z_sub } => {
                let (e, g) = (self.update.decay(), self.update.gain());
                let mut f_hat = SVector::<f64, M>::zeros();
                let mut w_norm = SVector::<f64, M>::zeros();
                for (j, a) in axes.iter_mut().enumerate() {
                    let c = g[j] * q * z2[j];
                    if let Some(pair) = a.pair4 {
                        // The default per-axis basis: the fixed-size kernel.
                        let ins = &a.inputs;
                        let zs = [z[ins[0]], z[ins[1]], z[ins[2]], z[ins[3]]];
                        let wj: &mut [f64; 16] = (&mut w[a.offset..a.offset + 16])
                            .try_into()
                            .expect("a 16-node axis");
                        let mut s = [0.0; 16];
                        let (acc, n2, s_n2) =
                            pair4_tick(&zs, pair, a.share_exp, wj, e[j], c, &mut s);
                        a.ws.store(&s, s_n2);
                        f_hat[j] = acc;
                        w_norm[j] = n2.sqrt();
                        continue;
                    }
                    // Z_{I_j}, then S_j on its grid (Kronecker form).
                    let zs = &mut z_sub[..a.inputs.len()];
                    for (o, &i) in zs.iter_mut().zip(&a.inputs) {
                        *o = z[i];
                    }
                    a.rbf.eval_into(zs, &mut a.ws);
                    let s = a.ws.s();
                    // Fused pass: f̂_j with the old weights, exact update (44), ‖Ŵ_j‖².
                    let (mut acc, mut n2) = (0.0, 0.0);
                    for (wk, &sk) in w[a.offset..a.offset + s.len()].iter_mut().zip(s) {
                        let old = *wk;
                        acc += old * sk;
                        let new = e[j] * old - c * sk;
                        *wk = new;
                        n2 += new * new;
                    }
                    f_hat[j] = acc;
                    w_norm[j] = n2.sqrt();
                }
                NnTick { f_hat, w_norm }
            }
        }
    }
}

/// Re-label the parameter of an error from a sub-module.
fn rename(e: ModelError, from: &str, to: &str) -> ModelError {
    match e {
        ModelError::Invalid {
            param,
            value,
            reason,
        } => ModelError::Invalid {
            param: param.replace(from, to),
            value,
            reason,
        },
        ModelError::Geometry { what, reason } => ModelError::Geometry {
            what: what.replace(from, to),
            reason,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scrambled_halton_is_deterministic_stratified_and_seeded() {
        let a = scrambled_halton(243, 12, 7);
        assert_eq!(a, scrambled_halton(243, 12, 7));
        assert_ne!(a, scrambled_halton(243, 12, 8));
        assert!(a.iter().all(|&u| (0.0..1.0).contains(&u)));
        // The first digit of point k is π(k mod p): over any run of consecutive points the
        // strata [i/p, (i+1)/p) of base p get counts that differ by at most one.
        let u = scrambled_halton(242, 2, 3);
        for (dim, p) in [(0usize, 2usize), (1, 3)] {
            let mut bins = vec![0usize; p];
            for k in 0..242 {
                bins[(u[(k, dim)] * p as f64) as usize] += 1;
            }
            let (lo, hi) = (bins.iter().min().unwrap(), bins.iter().max().unwrap());
            assert!(hi - lo <= 1, "dim {dim}: {bins:?}");
        }
        // Unlike plain Halton, the first points of two large bases are not on a line.
        let v = scrambled_halton(60, 24, 0);
        let (x, y): (Vec<f64>, Vec<f64>) = (0..60).map(|k| (v[(k, 22)], v[(k, 23)])).unzip();
        let mean = |w: &[f64]| w.iter().sum::<f64>() / w.len() as f64;
        let (mx, my) = (mean(&x), mean(&y));
        let cov: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
        let vx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
        let vy: f64 = y.iter().map(|b| (b - my) * (b - my)).sum();
        let corr = cov / (vx * vy).sqrt();
        assert!(corr.abs() < 0.5, "bases 83 and 89 correlate: {corr}");
    }

    #[test]
    fn the_fixed_size_axis_kernel_agrees_with_the_generic_path() {
        // The default per-axis network (four inputs, two levels) takes `pair4_tick`; with the
        // kernel switched off the same network takes the generic path (`Rbf::eval_into`: one
        // exponential per factor, and the slice pass). Inputs span the grid's neighbourhood,
        // far outside it (the direct fallback, exact bits) and asymmetric levels.
        for (levels, width2, span) in [
            ([-1.0, 1.0], 50.0, 3.0),
            ([-1.0, 1.0], 0.5, 4.0),
            ([-0.3, 0.7], 2.0, 3.0),
            ([-1.0, 1.0], 0.01, 2.0),
        ] {
            let upd = NnUpdate::<6>::new(
                SVector::from_fn(|j, _| 0.5 + j as f64),
                SVector::repeat(0.1),
                1e-3,
            )
            .unwrap();
            let structure = NetworkStructure::per_axis();
            let mut fast = StructuredNn::<6>::new(&structure, &levels, width2, upd).unwrap();
            let mut slow = fast.clone();
            let Kind::PerAxis { axes, .. } = &mut slow.kind else {
                panic!("per-axis");
            };
            for a in axes.iter_mut() {
                assert!(a.pair4.is_some() && a.share_exp);
                a.pair4 = None;
            }
            let mut state = 11u64;
            let mut rnd = |lo: f64, hi: f64| {
                state = splitmix64(state);
                lo + (hi - lo) * (state >> 11) as f64 / (1u64 << 53) as f64
            };
            for _ in 0..200 {
                let z: Vec<f64> = (0..24).map(|_| rnd(-span, span)).collect();
                let z2 = SVector::<f64, 6>::from_fn(|_, _| rnd(-0.5, 0.5));
                let q = rnd(0.0, 1.0);
                let scale: Vec<f64> = (0..6)
                    .map(|j| {
                        let w = &fast.weights()[16 * j..16 * j + 16];
                        w.iter().map(|v| v.abs()).sum::<f64>() + 1.0
                    })
                    .collect();
                let (a, b) = (fast.tick(&z, q, &z2), slow.tick(&z, q, &z2));
                for j in 0..6 {
                    // Each basis value carries a few roundings of its exponent (|·| < 40 here)
                    // instead of one: relative 1e-13 per S_k is ~500 ulps of margin.
                    for (x, y) in fast.basis_of(j).iter().zip(slow.basis_of(j)) {
                        // (Plus the smallest normal number: subnormal values lose relative
                        // precision in either path.)
                        assert!(
                            (x - y).abs() <= 1e-13 * y.abs() + f64::MIN_POSITIVE,
                            "S {x} vs {y}"
                        );
                    }
                    assert!((a.f_hat[j] - b.f_hat[j]).abs() <= 1e-13 * scale[j]);
                    assert!((a.w_norm[j] - b.w_norm[j]).abs() <= 1e-13 * scale[j]);
                }
                // Keep both on the same weights (the comparison is of one tick).
                let w = slow.weights().to_vec();
                fast.weights_mut().copy_from_slice(&w);
            }
            assert!(fast.weights().iter().any(|&w| w != 0.0));
        }
        // Planar networks (three outputs) take the kernel with direct factors: the same bits
        // as the generic path.
        let upd3 = NnUpdate::<3>::new(SVector::repeat(2.0), SVector::repeat(0.1), 1e-3).unwrap();
        let mut fast =
            StructuredNn::<3>::new(&NetworkStructure::per_axis(), &[-1.0, 1.0], 50.0, upd3)
                .unwrap();
        let mut slow = fast.clone();
        let Kind::PerAxis { axes, .. } = &mut slow.kind else {
            panic!("per-axis");
        };
        for a in axes.iter_mut() {
            assert!(a.pair4.is_some() && !a.share_exp);
            a.pair4 = None;
        }
        let mut state = 5u64;
        for _ in 0..200 {
            let mut rnd = |lo: f64, hi: f64| {
                state = splitmix64(state);
                lo + (hi - lo) * (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let z: Vec<f64> = (0..12).map(|_| rnd(-3.0, 3.0)).collect();
            let z2 = SVector::<f64, 3>::from_fn(|_, _| rnd(-0.5, 0.5));
            let q = rnd(0.0, 1.0);
            let (a, b) = (fast.tick(&z, q, &z2), slow.tick(&z, q, &z2));
            assert_eq!((a.f_hat, a.w_norm), (b.f_hat, b.w_norm));
            assert_eq!(fast.weights(), slow.weights());
            for j in 0..3 {
                assert_eq!(fast.basis_of(j), slow.basis_of(j));
            }
        }
        assert!(fast.weights().iter().any(|&w| w != 0.0));
        // Other shapes (three levels) keep the generic path.
        let upd = NnUpdate::<6>::new(SVector::repeat(1.0), SVector::repeat(0.1), 1e-3).unwrap();
        let three =
            StructuredNn::<6>::new(&NetworkStructure::per_axis(), &[-1.0, 0.0, 1.0], 50.0, upd)
                .unwrap();
        let Kind::PerAxis { axes, .. } = &three.kind else {
            panic!("per-axis");
        };
        assert!(axes.iter().all(|a| a.pair4.is_none()));
    }

    #[test]
    fn sizes_and_default_inputs() {
        let upd = NnUpdate::<6>::new(SVector::repeat(1.0), SVector::repeat(0.1), 1e-3).unwrap();
        let s = NetworkStructure::per_axis();
        assert_eq!(s.inputs_of(4, 6), Some(vec![4, 10, 16, 22]));
        let net = StructuredNn::<6>::new(&s, &[-1.0, 0.0, 1.0], 50.0, upd).unwrap();
        assert_eq!(net.n_inputs(), 24);
        assert_eq!(net.n_weights(), 6 * 81);
        assert_eq!(net.inputs_of(5), vec![5, 11, 17, 23]);
        let q = NetworkStructure::QuasiRandom { n: 100, seed: 2 };
        let net = StructuredNn::<6>::new(&q, &[-1.0, 1.0], 50.0, upd).unwrap();
        assert_eq!((net.nodes_of(3), net.n_weights()), (100, 600));
        let n2 = grid_norm2_at_zero(&[-1.0, 1.0], 50.0, 24);
        assert!((n2 - 6.423_876_652_867_8e6).abs() < 1e-3);
    }
}
