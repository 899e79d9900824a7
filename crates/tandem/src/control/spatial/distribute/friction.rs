//! The friction-aware load distribution (issue 25): the grasp wrenches closest to the
//! weld-assuming ones ([`super::Distribution`]) that realise the same object wrench with every
//! contact pad inside its friction cone by a set margin, and the grippers' normal forces
//! consistent with their grip.
//!
//! # The cone program
//! Pad `j` of grasp `i` presses along `n̂_j` (world axes, from the tool's orientation), at
//! `p_j` from the tool origin, with tangent axes `ê₁, ê₂`. Its contact force on the object is
//! `c_j = (N, t₁, t₂, τ)`: normal force, friction along `ê₁, ê₂`, torsion about `n̂`. The
//! variables are scaled so that the cone is the standard second-order cone:
//! `x_j = (N, t₁/μ, t₂/μ, τ/μ_τ)`. The arm's wrench on the object at its tool origin is
//! `w_i = Σ_j B_j x_j`, `B_j = [[n̂, μ ê₁, μ ê₂, 0], [p×n̂, μ p×ê₁, μ p×ê₂, μ_τ n̂]]`.
//!
//! ```text
//! x⁰ = argmin_x Σ_i ‖w_i(x) − w_i⁰‖²_W + ε ‖x − x_ref‖²   (the pads' share of the plan)
//! minimise   ½ ‖x − x⁰‖²
//! subject to Σ_i G_iᵀ w_i(x) = Σ_i G_iᵀ w_i⁰                (the same object wrench)
//!            U_iᵀ N_i = U_iᵀ 1 F_g,i                          (the grip: see below)
//!            ‖(t₁/μ, t₂/μ, τ/μ_τ)_j‖ ≤ N_j − δ               (each pad δ inside its cone)
//! ```
//!
//! `w⁰` is what the pads must carry under the weld-assuming plan (the minimum-norm share plus
//! squeeze, less each arm's own dynamics: the controller passes `w_i − Λ_i(G_i V̇ + Ġ_i V) − μ_i`,
//! and adds it back); `W` the share's metric (forces, and torques over the length `L`). `x⁰` is
//! its decomposition into pad forces (`ε = 1e-6` relative picks, among the splits that give the
//! same wrenches, the one nearest the nominal `x_ref = (F_g, 0, 0, 0)`), and the result is the
//! point nearest `x⁰` that meets the constraints: where the plan is already inside the cones it is
//! the plan (to the solver's tolerance); otherwise the least change of pad forces, in the scaled
//! variables, that keeps the object wrench. The internal force changes only as much as the cones
//! ask.
//!
//! **The grip.** A gripper's pads are pressed by its grip `F_g` and move with its tool: a rigid
//! displacement `Δx` of the tool changes pad `j`'s normal force by `k_n a_jᵀ Δx` with
//! `a_j = [n̂; p×n̂]` (tool axes). The normal forces a gripper can have are therefore
//! `F_g 1 + range(A_i)`: with `U_i` a basis of `range(A_i)`'s complement (computed once from the
//! tool-frame pads), `U_iᵀ (N_i − F_g 1) = 0`. Two opposing pads give `N₁ + N₂ = 2 F_g` (a push
//! along the jaw axis loads one pad and unloads the other); a single pad (a suction cup) is free.
//!
//! # The solver
//! ADMM (Boyd et al., 2011, §5; the OSQP/SCS splitting) on `x` (the equality-constrained step,
//! a projection onto the equalities with the tick's factor of `M Mᵀ`) and `y` (the cones, a
//! closed-form projection per pad), over-relaxed by 1.6, `ρ` balanced against the residuals every
//! 25 iterations. The factor is built once a tick, the iterates are warm-started from the last
//! tick, and every buffer is sized at set-up: no allocation. It stops when the primal and dual
//! residuals are below `1e-7 × (1 + F_g)`, or after [`MAX_ITERATIONS`]. The iterate `x` meets the
//! equalities exactly; it is used when its pads are inside their cones by half the margin.
//! Otherwise no distribution was found (none exists, or the iterations ran out): the tick falls
//! back to the pad forces nearest the plan that the grip and the cones allow (the same projection
//! with the object-wrench rows let go), so the object gets less than the law asked rather than a
//! plan the pads cannot carry, and the tick is counted in [`FrictionStats`] with the first time.

use nalgebra::{UnitQuaternion, Vector3, Vector6};

use crate::error::{ModelError, positive};
use crate::geometry::motion::{ang, lin};
use crate::math::linalg::{backward_rows, cholesky_rows, forward_rows};

use crate::plant::spatial::contact::{MAX_COEFFICIENT, MAX_GRIP};

/// Iterations of one tick's solve before it gives up.
pub const MAX_ITERATIONS: usize = 400;
/// ADMM over-relaxation.
const ALPHA: f64 = 1.6;
/// The tie-break weight `ε`, relative to the mean of `H`'s diagonal.
const EPS: f64 = 1e-6;

/// One pad in the tool frame, as the controller knows it.
#[derive(Clone, Debug, PartialEq)]
pub struct PadModel {
    /// Centre of the pad, tool frame, m.
    pub position: Vector3<f64>,
    /// The direction it presses (into the object), tool axes (normalised on construction).
    pub normal: Vector3<f64>,
}

/// The controller's model of contact grasps.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionParams {
    /// The pads of each grasp.
    pub pads: Vec<Vec<PadModel>>,
    /// Friction coefficient `μ` (> 0).
    pub mu: f64,
    /// Torsional friction coefficient `μ_τ`, m (≥ 0; 0: none).
    pub torsion: f64,
    /// Grip force of each grasp, N (≥ 0).
    pub grip: Vec<f64>,
    /// How far inside its cone each pad is kept, N of normal force (≥ 0).
    pub margin: f64,
}

impl FrictionParams {
    /// The controller's model of the plant's contact grasps, with `margin` (N).
    pub fn from_contact(c: &crate::plant::spatial::ContactParams, margin: f64) -> Self {
        FrictionParams {
            pads: c
                .pads
                .iter()
                .map(|l| {
                    l.iter()
                        .map(|p| PadModel {
                            position: p.position,
                            normal: p.normal,
                        })
                        .collect()
                })
                .collect(),
            mu: c.mu,
            torsion: c.torsion,
            grip: c.grip.clone(),
            margin,
        }
    }
}

/// What the friction-aware distribution did over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrictionStats {
    /// Ticks solved.
    pub solves: u64,
    /// Iterations over all ticks.
    pub iterations: u64,
    /// Most iterations of one tick.
    pub max_iterations: u64,
    /// Ticks that fell back to the weld-assuming wrenches (no distribution inside the cones
    /// found).
    pub fallbacks: u64,
    /// Ticks whose iterations ran out before the residuals met the tolerance (their result is
    /// used when it is inside the cones: feasible, if not the nearest).
    pub unconverged: u64,
    /// Time of the first fallback, s.
    pub first_fallback_t: Option<f64>,
    /// Smallest cone margin `N − ‖(t/μ, τ/μ_τ)‖` of the planned pad forces over the ticks
    /// whose plan was accepted, N of normal force (≥ δ/2 by construction).
    pub min_margin: f64,
}

/// A pad, precomputed.
#[derive(Clone, Debug)]
struct Pad {
    grasp: usize,
    p: Vector3<f64>,
    n: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
}

/// The friction-aware distribution and its preallocated scratch.
#[derive(Clone, Debug)]
pub struct FrictionDistribution {
    pads: Vec<Pad>,
    m: usize,
    mu: f64,
    torsion: f64,
    grip: Vec<f64>,
    margin: f64,
    l2: f64,
    /// Grip rows: (grasp, coefficients over that grasp's pads (in pad order), rhs).
    grip_rows: Vec<(usize, Vec<f64>, f64)>,
    nv: usize,
    ne: usize,
    // Per tick.
    /// `B` per pad, world: 6 × 4, row-major.
    b: Vec<[f64; 24]>,
    /// `H`, then its Cholesky factor (for `x⁰`).
    k: Vec<f64>,
    q: Vec<f64>,
    mm: Vec<f64>,
    rhs_b: Vec<f64>,
    /// The pad forces nearest the weld-assuming wrenches (the point projected).
    x0: Vec<f64>,
    s: Vec<f64>,
    // Iterates.
    x: Vec<f64>,
    y: Vec<f64>,
    u: Vec<f64>,
    g: Vec<f64>,
    lam: Vec<f64>,
    ytmp: Vec<f64>,
    rho: f64,
    /// The first equality row the projection keeps (0: all; 6: the grip rows alone, the
    /// fallback).
    first: usize,
    /// What it did so far.
    pub stats: FrictionStats,
}

fn tangents(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = n.cross(&a).normalize();
    (e1, n.cross(&e1))
}

impl FrictionDistribution {
    /// Validate and size. `metric_length` is the weld-assuming distribution's `L` (m). Errors
    /// name the field (`friction.mu`, `friction.pads[i][j].normal`, …).
    pub fn new(p: &FrictionParams, metric_length: f64) -> Result<Self, ModelError> {
        positive("friction.mu", p.mu)?;
        for (name, v) in [("friction.mu", p.mu), ("friction.torsion", p.torsion)] {
            if v > MAX_COEFFICIENT {
                return Err(ModelError::invalid(
                    name,
                    v,
                    format!(
                        "must be ≤ {MAX_COEFFICIENT:e} (no contact has more friction; beyond it the cone's scaling loses its digits)"
                    ),
                ));
            }
        }
        if !(p.torsion.is_finite() && p.torsion >= 0.0) {
            return Err(ModelError::invalid(
                "friction.torsion",
                p.torsion,
                "must be ≥ 0 and finite",
            ));
        }
        if !(p.margin.is_finite() && p.margin >= 0.0) {
            return Err(ModelError::invalid(
                "friction.margin",
                p.margin,
                "must be ≥ 0 and finite (N of normal force)",
            ));
        }
        positive("metric_length", metric_length)?;
        let m = p.pads.len();
        if m == 0 || p.grip.len() != m {
            return Err(ModelError::geometry(
                "friction.grip",
                format!("{} grip forces for {m} grasps", p.grip.len()),
            ));
        }
        for (i, g) in p.grip.iter().enumerate() {
            if !(g.is_finite() && *g >= 0.0 && *g <= MAX_GRIP) {
                return Err(ModelError::invalid(
                    format!("friction.grip[{i}]"),
                    *g,
                    format!("must be ≥ 0 and ≤ {MAX_GRIP:e} N"),
                ));
            }
        }
        let mut pads = Vec::new();
        let mut grip_rows = Vec::new();
        for (i, list) in p.pads.iter().enumerate() {
            if list.is_empty() {
                return Err(ModelError::geometry(
                    format!("friction.pads[{i}]"),
                    "a grasp needs at least one pad",
                ));
            }
            // A_i rows [n; p × n] (tool frame); U_i = the complement of its range.
            let np = list.len();
            let mut a = nalgebra::DMatrix::<f64>::zeros(np, 6);
            for (j, pad) in list.iter().enumerate() {
                let nn = pad.normal.norm();
                if !(nn.is_finite() && nn > 1e-9 && pad.position.iter().all(|v| v.is_finite())) {
                    return Err(ModelError::geometry(
                        format!("friction.pads[{i}][{j}]"),
                        "needs a finite position and a finite non-zero normal",
                    ));
                }
                let n = pad.normal / nn;
                let (e1, e2) = tangents(&n);
                let pn = pad.position.cross(&n);
                for c in 0..3 {
                    a[(j, c)] = n[c];
                    a[(j, 3 + c)] = pn[c];
                }
                pads.push(Pad {
                    grasp: i,
                    p: pad.position,
                    n,
                    e1,
                    e2,
                });
            }
            // Left singular vectors of A beyond its rank span the complement of range(A).
            let svd = nalgebra::linalg::SVD::new(a.clone() * a.transpose(), true, false);
            let u = svd.u.expect("u requested");
            let smax = svd.singular_values.max().max(1e-300);
            for (c, sv) in svd.singular_values.iter().enumerate() {
                if *sv <= 1e-10 * smax {
                    let v: Vec<f64> = u.column(c).iter().copied().collect();
                    let rhs = p.grip[i] * v.iter().sum::<f64>();
                    grip_rows.push((i, v, rhs));
                }
            }
        }
        let nv = 4 * pads.len();
        let ne = 6 + grip_rows.len();
        let mut x = vec![0.0; nv];
        for (j, pad) in pads.iter().enumerate() {
            x[4 * j] = p.grip[pad.grasp];
        }
        let np = pads.len();
        Ok(FrictionDistribution {
            pads,
            m,
            mu: p.mu,
            torsion: p.torsion,
            grip: p.grip.clone(),
            margin: p.margin,
            l2: metric_length * metric_length,
            grip_rows,
            nv,
            ne,
            b: vec![[0.0; 24]; np],
            k: vec![0.0; nv * nv],
            q: vec![0.0; nv],
            mm: vec![0.0; ne * nv],
            rhs_b: vec![0.0; ne],
            x0: vec![0.0; nv],
            s: vec![0.0; ne * ne],
            y: x.clone(),
            x,
            u: vec![0.0; nv],
            g: vec![0.0; nv],
            lam: vec![0.0; ne],
            ytmp: vec![0.0; nv],
            rho: 1.0,
            first: 0,
            stats: FrictionStats {
                min_margin: f64::INFINITY,
                ..FrictionStats::default()
            },
        })
    }

    /// Number of grasps.
    pub fn m(&self) -> usize {
        self.m
    }

    /// Project `v` (one pad's 4 scaled numbers) onto its cone shifted by the margin.
    fn project(&self, v: &mut [f64]) {
        if self.torsion == 0.0 {
            v[3] = 0.0;
        }
        let s = v[0] - self.margin;
        let t = (v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt();
        if t <= s {
            return;
        }
        if t <= -s {
            v[0] = self.margin;
            v[1] = 0.0;
            v[2] = 0.0;
            v[3] = 0.0;
            return;
        }
        let a = 0.5 * (s + t);
        let f = a / t;
        v[0] = a + self.margin;
        v[1] *= f;
        v[2] *= f;
        v[3] *= f;
    }

    /// The margin of a pad's scaled force `v` to its (unshifted) cone, N.
    fn cone_margin(&self, v: &[f64]) -> f64 {
        v[0] - (v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt()
    }

    /// The friction-aware wrenches at time `t`: `r[i] = p_WTi − p_WO` and `rot[i] = R_WTi` (the
    /// tools' places and orientations), `w` the weld-assuming wrenches in, the friction-aware
    /// ones out (unchanged on a fallback). Returns whether it found them. No allocation.
    pub fn solve(
        &mut self,
        t: f64,
        r: &[Vector3<f64>],
        rot: &[UnitQuaternion<f64>],
        w: &mut [Vector6<f64>],
    ) -> bool {
        self.stats.solves += 1;
        let built = self.build(r, rot, w);
        let (iters, ok) = if built { self.iterate() } else { (0, false) };
        self.stats.iterations += iters as u64;
        self.stats.max_iterations = self.stats.max_iterations.max(iters as u64);
        // Accept only pads inside their cones by half the margin.
        let mut worst = f64::INFINITY;
        for j in 0..self.pads.len() {
            worst = worst.min(self.cone_margin(&self.x[4 * j..4 * j + 4]));
        }
        // The iterate `x` meets the equalities exactly (to round-off); it is accepted when its
        // pads are inside their cones by half the margin, converged or not (an unconverged
        // iterate is feasible but not the nearest: counted in `unconverged`).
        if !ok {
            self.stats.unconverged += 1;
        }
        // (A problem that could not be built, a non-finite input, is never accepted: `x` is then
        // the last tick's.)
        let accept = built
            && worst.is_finite()
            && worst >= 0.5 * self.margin - 1e-9 * (1.0 + self.grip_max());
        if !accept {
            // No distribution inside the cones realises the object wrench: the pads take the
            // nearest forces they can carry (the cone-side iterate `y`, inside every cone by
            // the margin), and the object gets less than the law asked for. Counted.
            self.stats.fallbacks += 1;
            self.stats.first_fallback_t.get_or_insert(t);
            if !built {
                self.reset_iterates();
                return false;
            }
            // The same projection with the object wrench let go: the grip rows and the cones.
            self.first = 6;
            let refactored = self.factor();
            let (more, _) = if refactored {
                self.iterate()
            } else {
                (0, false)
            };
            self.stats.iterations += more as u64;
            self.first = 0;
            // `x` meets the grip rows; `y` the cones: take `x` if it is inside the cones by half
            // the margin (it is, once converged), else `y`.
            let inside = (0..self.pads.len()).all(|j| {
                self.cone_margin(&self.x[4 * j..4 * j + 4])
                    >= 0.5 * self.margin - 1e-9 * (1.0 + self.grip_max())
            });
            if !inside {
                self.x.copy_from_slice(&self.y);
            }
            if !(refactored && self.x.iter().all(|v| v.is_finite())) {
                self.reset_iterates();
                return false;
            }
            self.write_wrenches(w);
            return false;
        } else {
            self.stats.min_margin = self.stats.min_margin.min(worst);
        }
        self.write_wrenches(w);
        true
    }

    /// `w_i = Σ_j B_j x_j`.
    fn write_wrenches(&self, w: &mut [Vector6<f64>]) {
        for wi in w[..self.m].iter_mut() {
            *wi = Vector6::zeros();
        }
        for (j, pad) in self.pads.iter().enumerate() {
            let b = &self.b[j];
            let x = &self.x[4 * j..4 * j + 4];
            let wi = &mut w[pad.grasp];
            for row in 0..6 {
                wi[row] += (0..4).map(|c| b[4 * row + c] * x[c]).sum::<f64>();
            }
        }
    }

    fn grip_max(&self) -> f64 {
        self.grip.iter().copied().fold(0.0, f64::max)
    }

    fn reset_iterates(&mut self) {
        for (j, pad) in self.pads.iter().enumerate() {
            self.y[4 * j] = self.grip[pad.grasp];
            self.y[4 * j + 1..4 * j + 4].fill(0.0);
        }
        self.x.copy_from_slice(&self.y);
        self.u.fill(0.0);
    }

    /// The tick's problem: `B`, `H`, `q`, `M`, `b`, and the factors of `K = H + ρ I` and of
    /// `S = M K⁻¹ Mᵀ`. `false` on a non-finite input or a singular factor.
    fn build(
        &mut self,
        r: &[Vector3<f64>],
        rot: &[UnitQuaternion<f64>],
        w: &[Vector6<f64>],
    ) -> bool {
        let nv = self.nv;
        let (mu, mt) = (self.mu, self.torsion);
        // B per pad (world).
        for (j, pad) in self.pads.iter().enumerate() {
            let rq = &rot[pad.grasp];
            let (n, e1, e2, p) = (rq * pad.n, rq * pad.e1, rq * pad.e2, rq * pad.p);
            let cols = [
                (n, p.cross(&n)),
                (e1 * mu, p.cross(&e1) * mu),
                (e2 * mu, p.cross(&e2) * mu),
                (Vector3::zeros(), n * mt),
            ];
            let b = &mut self.b[j];
            for (c, (f, tq)) in cols.iter().enumerate() {
                for a in 0..3 {
                    b[4 * a + c] = f[a];
                    b[4 * (3 + a) + c] = tq[a];
                }
            }
        }
        // H = Bᵀ W B (block-diagonal per grasp, pads of one grasp coupled), q = Bᵀ W w⁰.
        self.k.fill(0.0);
        self.q.fill(0.0);
        let wdiag = |row: usize, l2: f64| if row < 3 { 1.0 } else { 1.0 / l2 };
        for j in 0..self.pads.len() {
            let gj = self.pads[j].grasp;
            for jj in 0..self.pads.len() {
                if self.pads[jj].grasp != gj {
                    continue;
                }
                for c in 0..4 {
                    for cc in 0..4 {
                        let mut sum = 0.0;
                        for row in 0..6 {
                            sum += self.b[j][4 * row + c]
                                * wdiag(row, self.l2)
                                * self.b[jj][4 * row + cc];
                        }
                        self.k[(4 * j + c) * nv + 4 * jj + cc] = sum;
                    }
                }
            }
            for c in 0..4 {
                let mut sum = 0.0;
                for row in 0..6 {
                    sum += self.b[j][4 * row + c] * wdiag(row, self.l2) * w[gj][row];
                }
                self.q[4 * j + c] = sum;
            }
        }
        let mean_diag = (0..nv).map(|i| self.k[i * nv + i]).sum::<f64>() / nv as f64;
        if !(mean_diag.is_finite() && mean_diag > 0.0) {
            return false;
        }
        let eps = EPS * mean_diag;
        for (j, pad) in self.pads.iter().enumerate() {
            self.q[4 * j] += eps * self.grip[pad.grasp];
        }
        for i in 0..nv {
            self.k[i * nv + i] += eps;
        }
        if !self.k.iter().all(|v| v.is_finite()) {
            return false;
        }
        // x⁰ = H⁻¹ q: the pad forces nearest the weld-assuming wrenches.
        if cholesky_rows(&mut self.k, nv).is_err() {
            return false;
        }
        self.x0.copy_from_slice(&self.q);
        forward_rows(&self.k, nv, &mut self.x0, 1);
        backward_rows(&self.k, nv, &mut self.x0);
        // M: the net wrench rows and the grip rows; b.
        self.mm.fill(0.0);
        let mut net = Vector6::zeros();
        for i in 0..self.m {
            let f = lin(&w[i]);
            let tq = ang(&w[i]) + r[i].cross(&f);
            net += Vector6::new(f.x, f.y, f.z, tq.x, tq.y, tq.z);
        }
        for (j, pad) in self.pads.iter().enumerate() {
            let ri = r[pad.grasp];
            let b = &self.b[j];
            for c in 0..4 {
                let f = Vector3::new(b[c], b[4 + c], b[8 + c]);
                let tq = Vector3::new(b[12 + c], b[16 + c], b[20 + c]) + ri.cross(&f);
                for a in 0..3 {
                    self.mm[a * nv + 4 * j + c] = f[a];
                    self.mm[(3 + a) * nv + 4 * j + c] = tq[a];
                }
            }
        }
        self.rhs_b[..6].copy_from_slice(net.as_slice());
        for (e, (gi, coef, rhs)) in self.grip_rows.iter().enumerate() {
            let mut k = 0;
            for (j, pad) in self.pads.iter().enumerate() {
                if pad.grasp == *gi {
                    self.mm[(6 + e) * nv + 4 * j] = coef[k];
                    k += 1;
                }
            }
            self.rhs_b[6 + e] = *rhs;
        }
        if !(self.mm.iter().all(|v| v.is_finite()) && self.rhs_b.iter().all(|v| v.is_finite())) {
            return false;
        }
        self.factor()
    }

    /// `S = M Mᵀ` over the equality rows from `self.first` on, factored (the projection onto
    /// those equalities).
    fn factor(&mut self) -> bool {
        let (nv, f) = (self.nv, self.first);
        let ne = self.ne - f;
        for a in 0..ne {
            for c in 0..ne {
                let mut sum = 0.0;
                for i in 0..nv {
                    sum += self.mm[(f + a) * nv + i] * self.mm[(f + c) * nv + i];
                }
                self.s[a * ne + c] = sum;
            }
        }
        cholesky_rows(&mut self.s, ne).is_ok()
    }

    /// ADMM from the warm start; returns (iterations, converged).
    fn iterate(&mut self) -> (usize, bool) {
        let (nv, f) = (self.nv, self.first);
        let ne = self.ne - f;
        let tol = 1e-7 * (1.0 + self.grip_max());
        for it in 1..=MAX_ITERATIONS {
            // x = argmin ½‖x − x⁰‖² + ρ/2‖x − (y − u)‖² s.t. Mx = b: the point
            // v = (x⁰ + ρ(y − u))/(1 + ρ) projected onto the equalities.
            let inv = 1.0 / (1.0 + self.rho);
            for i in 0..nv {
                self.g[i] = (self.x0[i] + self.rho * (self.y[i] - self.u[i])) * inv;
            }
            for e in 0..ne {
                let mut sum = -self.rhs_b[f + e];
                for i in 0..nv {
                    sum += self.mm[(f + e) * nv + i] * self.g[i];
                }
                self.lam[e] = sum;
            }
            forward_rows(&self.s, ne, &mut self.lam, 1);
            backward_rows(&self.s, ne, &mut self.lam);
            for i in 0..nv {
                let mut zl = 0.0;
                for e in 0..ne {
                    zl += self.mm[(f + e) * nv + i] * self.lam[e];
                }
                self.x[i] = self.g[i] - zl;
            }
            // y = Π(α x + (1 − α) y + u); u += α x + (1 − α) y − y_new.
            self.ytmp.copy_from_slice(&self.y);
            for i in 0..nv {
                let relaxed = ALPHA * self.x[i] + (1.0 - ALPHA) * self.ytmp[i];
                self.g[i] = relaxed;
                self.y[i] = relaxed + self.u[i];
            }
            for j in 0..self.pads.len() {
                let mut v = [
                    self.y[4 * j],
                    self.y[4 * j + 1],
                    self.y[4 * j + 2],
                    self.y[4 * j + 3],
                ];
                self.project(&mut v);
                self.y[4 * j..4 * j + 4].copy_from_slice(&v);
            }
            let (mut rp, mut rd) = (0.0f64, 0.0f64);
            for i in 0..nv {
                self.u[i] += self.g[i] - self.y[i];
                rp = rp.max((self.x[i] - self.y[i]).abs());
                rd = rd.max(self.rho * (self.y[i] - self.ytmp[i]).abs());
            }
            if !(rp.is_finite() && rd.is_finite()) {
                return (it, false);
            }
            if rp <= tol && rd <= tol {
                return (it, true);
            }
            // Residual balancing (OSQP's rule): a primal residual far above the dual one asks
            // for a larger ρ, and the reverse (the x-step needs no refactoring); rescale u.
            if it % 25 == 0 && rp > 0.0 && rd > 0.0 {
                let ratio = (rp / rd).sqrt();
                if !(0.2..=5.0).contains(&ratio) {
                    let new = (self.rho * ratio.clamp(1e-2, 1e2)).clamp(1e-8, 1e8);
                    let scale = self.rho / new;
                    self.rho = new;
                    for v in self.u.iter_mut() {
                        *v *= scale;
                    }
                }
            }
        }
        (MAX_ITERATIONS, false)
    }

    /// The last accepted solution's pad forces, unscaled: `(N, t₁, t₂, τ)` per pad (grasps in
    /// order), N and N m.
    pub fn pad_forces(&self, out: &mut [[f64; 4]]) {
        for (j, o) in out.iter_mut().enumerate().take(self.pads.len()) {
            let x = &self.x[4 * j..4 * j + 4];
            *o = [x[0], x[1] * self.mu, x[2] * self.mu, x[3] * self.torsion];
        }
    }
}
