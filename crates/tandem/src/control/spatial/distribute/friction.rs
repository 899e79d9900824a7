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
/// Iterations of a tick's solve with the effort limits (its ADMM is slower: up to ~1000 where
/// several limits and cones are active together; 190 on average where one to three joints are
/// at their limit).
pub const MAX_LIMITED_ITERATIONS: usize = 1000;
/// The limits are sought at `e (1 − EFFORT_TARGET)` ...
const EFFORT_TARGET: f64 = 1e-4;
/// ... and a plan is accepted up to `e (1 + EFFORT_ACCEPT)` (the actuator stage clips the rest,
/// at most 0.1 % of a joint's torque).
const EFFORT_ACCEPT: f64 = 1e-3;

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
    /// Ticks whose plan inside the cones asked an arm for more than a joint's effort limit,
    /// and that were solved again with the limits as constraints
    /// ([`FrictionDistribution::set_effort`]).
    pub torque_limited: u64,
    /// Of those, the ticks where no plan met the cones and the limits together (the plan
    /// inside the cones is kept, and the actuator stage clips it).
    pub torque_unmet: u64,
    /// Time of the first such tick, s.
    pub first_torque_unmet_t: Option<f64>,
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
    /// The arms' effort limits as rows of the program (none until
    /// [`FrictionDistribution::set_effort`]).
    limits: Option<Box<TorqueRows>>,
    /// What it did so far.
    pub stats: FrictionStats,
}

/// The arms' effort limits as rows of the cone program: arm `i`'s joint torques are affine in
/// its pads' forces, `τ_i = τ⁰_i + J_iᵀ Σ_j B_j x_j` (`τ⁰_i` the torques of the arm's own share
/// and posture task), so `|τ_i,k| ≤ e_i,k` is a pair of linear bounds `l ≤ C x ≤ u`.
#[derive(Clone, Debug)]
struct TorqueRows {
    /// Per arm: its first row and its joint count.
    arms: Vec<(usize, usize)>,
    /// Effort limit per joint (arms stacked), N m (`∞`: none).
    effort: Vec<f64>,
    /// Per joint its Jacobian column (world axes, about the tool origin, `[v; ω]`), set each
    /// tick.
    jac: Vec<f64>,
    /// `τ⁰` per joint, set each tick.
    tau0: Vec<f64>,
    /// `C` (rows × nv, each row scaled to unit norm), and the bounds in the scaled rows.
    c: Vec<f64>,
    /// Each row's norm before scaling (0: no row).
    norm: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// The box iterate, its dual and scratch (rows).
    z: Vec<f64>,
    u: Vec<f64>,
    zold: Vec<f64>,
    cx: Vec<f64>,
    /// The factor of `K = I + ρ (I + CᵀC)` (nv × nv), `K⁻¹ Mᵀ` (one row of nv per equality).
    kf: Vec<f64>,
    km: Vec<f64>,
    /// Scratch (nv).
    r: Vec<f64>,
    /// The cone-only plan, kept while the limited one is sought (x, y, u).
    save: Vec<f64>,
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
            limits: None,
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

    /// Respect the arms' effort limits: `effort[i][k]` is arm `i`'s joint `k` limit, N m
    /// (`∞`: none), one list per grasp. Each tick the caller then gives every arm's Jacobian
    /// and its torques without the pads' share ([`arm_rows`](Self::arm_rows)). A plan inside
    /// the cones that asks a joint for more than its limit is solved again with
    /// `|τ⁰_i + J_iᵀ Σ_j B_j x_j| ≤ e_i` as constraints; if none meets both, the plan inside
    /// the cones is kept (the actuator stage clips it) and the tick is counted
    /// ([`FrictionStats::torque_unmet`]). Errors name `effort[i][k]`.
    pub fn set_effort(&mut self, effort: &[Vec<f64>]) -> Result<(), ModelError> {
        if effort.len() != self.m {
            return Err(ModelError::geometry(
                "effort",
                format!("{} arms' limits for {} grasps", effort.len(), self.m),
            ));
        }
        let mut arms = Vec::with_capacity(self.m);
        let mut flat = Vec::new();
        for (i, e) in effort.iter().enumerate() {
            arms.push((flat.len(), e.len()));
            for (k, v) in e.iter().enumerate() {
                if v.is_nan() || *v <= 0.0 {
                    return Err(ModelError::invalid(
                        format!("effort[{i}][{k}]"),
                        *v,
                        "must be > 0 (∞: no limit)",
                    ));
                }
                flat.push(*v);
            }
        }
        let (n, nv) = (flat.len(), self.nv);
        self.limits = Some(Box::new(TorqueRows {
            arms,
            effort: flat,
            jac: vec![0.0; 6 * n],
            tau0: vec![0.0; n],
            c: vec![0.0; n * nv],
            norm: vec![0.0; n],
            lo: vec![0.0; n],
            hi: vec![0.0; n],
            z: vec![0.0; n],
            u: vec![0.0; n],
            zold: vec![0.0; n],
            cx: vec![0.0; n],
            kf: vec![0.0; nv * nv],
            km: vec![0.0; self.ne * nv],
            r: vec![0.0; nv],
            save: vec![0.0; 3 * nv],
        }));
        Ok(())
    }

    /// Arm `i`'s rows for this tick (after [`set_effort`](Self::set_effort); `None` without
    /// limits): its Jacobian, one column of 6 per joint (world axes, about the tool origin,
    /// `[v; ω]`, as `J_iᵀ w` maps a tool wrench to joint torques), and `τ⁰_i`, the torques it
    /// gets besides its pads' share. No allocation.
    pub fn arm_rows(&mut self, i: usize) -> Option<(&mut [f64], &mut [f64])> {
        let l = self.limits.as_mut()?;
        let (first, n) = *l.arms.get(i)?;
        Some((
            &mut l.jac[6 * first..6 * (first + n)],
            &mut l.tau0[first..first + n],
        ))
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
        }
        let (over, hopeless) = if self.limits.is_some() {
            self.build_torque_rows()
        } else {
            (false, false)
        };
        if over {
            self.stats.torque_limited += 1;
            // A joint over its limit that no pad force moves: no plan helps; skip the solve.
            if hopeless || !self.limit_torques() {
                self.stats.torque_unmet += 1;
                self.stats.first_torque_unmet_t.get_or_insert(t);
            }
            worst = (0..self.pads.len())
                .map(|j| self.cone_margin(&self.x[4 * j..4 * j + 4]))
                .fold(f64::INFINITY, f64::min);
        }
        self.stats.min_margin = self.stats.min_margin.min(worst);
        self.write_wrenches(w);
        true
    }

    /// The torque rows `C`, `l`, `u` of this tick (scaled rows), from the arms' Jacobians,
    /// `τ⁰` and `B`. Returns `(over, hopeless)`: the plan `x` asks a joint for more than its
    /// limit (and the rows are finite); such a joint has no row (the pads' forces do not move
    /// it), so no plan can meet its limit.
    fn build_torque_rows(&mut self) -> (bool, bool) {
        let nv = self.nv;
        let Some(l) = self.limits.as_mut() else {
            return (false, false);
        };
        let (mut over, mut hopeless) = (false, false);
        l.c.fill(0.0);
        for (j, pad) in self.pads.iter().enumerate() {
            let (first, n) = l.arms[pad.grasp];
            let b = &self.b[j];
            for k in first..first + n {
                let col = &l.jac[6 * k..6 * k + 6];
                for c in 0..4 {
                    l.c[k * nv + 4 * j + c] = (0..6).map(|a| col[a] * b[4 * a + c]).sum::<f64>();
                }
            }
        }
        for k in 0..l.effort.len() {
            let row = &mut l.c[k * nv..(k + 1) * nv];
            let tau = l.tau0[k] + row.iter().zip(&self.x).map(|(a, b)| a * b).sum::<f64>();
            let e = l.effort[k];
            if !(tau.is_finite() && row.iter().all(|v| v.is_finite())) {
                return (false, false);
            }
            over |= tau.abs() > e;
            let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
            hopeless |= norm == 0.0 && tau.abs() > e;
            if norm > 0.0 && e.is_finite() {
                l.norm[k] = norm;
                row.iter_mut().for_each(|v| *v /= norm);
                let es = e * (1.0 - EFFORT_TARGET);
                l.lo[k] = (-es - l.tau0[k]) / norm;
                l.hi[k] = (es - l.tau0[k]) / norm;
            } else {
                // No limit, or a joint the pads' forces cannot move: no row.
                row.fill(0.0);
                l.norm[k] = 0.0;
                l.lo[k] = f64::NEG_INFINITY;
                l.hi[k] = f64::INFINITY;
            }
        }
        (over, hopeless)
    }

    /// The cones' block of an ADMM iteration, after the x-step: `y = Π(α x + (1 − α) y + u)`,
    /// `u += α x + (1 − α) y − y_new`. Returns the primal and dual residuals (max norms).
    fn cone_block(&mut self) -> (f64, f64) {
        let nv = self.nv;
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
        (rp, rd)
    }

    /// The plan nearest `x⁰` inside the cones **and** the effort limits (ADMM as
    /// [`iterate`](Self::iterate), with the box `l ≤ C x ≤ u` as a second block of the
    /// splitting: the OSQP form, its x-step the equality-constrained solve with
    /// `K = I + ρ (I + CᵀC)`). Warm-started from the plan inside the cones; `true` when it
    /// meets the cones by half the margin and every limit (to 1e-6 relative), else the plan
    /// inside the cones is restored. No allocation.
    fn limit_torques(&mut self) -> bool {
        let nv = self.nv;
        let mut l = self.limits.take().expect("torque rows");
        l.save[..nv].copy_from_slice(&self.x);
        l.save[nv..2 * nv].copy_from_slice(&self.y);
        l.save[2 * nv..].copy_from_slice(&self.u);
        let rows = l.effort.len();
        for k in 0..rows {
            let cx = (0..nv).map(|i| l.c[k * nv + i] * self.x[i]).sum::<f64>();
            l.z[k] = cx.clamp(l.lo[k], l.hi[k]);
        }
        l.u.fill(0.0);
        let tol = 1e-7 * (1.0 + self.grip_max());
        let mut ok = self.factor_limited(&mut l);
        let mut iters = 0;
        while ok && iters < MAX_LIMITED_ITERATIONS {
            iters += 1;
            // x-step: K x + Mᵀλ = x⁰ + ρ(y − u) + ρ Cᵀ(z − u_z), M x = b.
            for i in 0..nv {
                l.r[i] = self.x0[i] + self.rho * (self.y[i] - self.u[i]);
            }
            for k in 0..rows {
                let zk = self.rho * (l.z[k] - l.u[k]);
                for i in 0..nv {
                    l.r[i] += l.c[k * nv + i] * zk;
                }
            }
            forward_rows(&l.kf, nv, &mut l.r, 1);
            backward_rows(&l.kf, nv, &mut l.r);
            for e in 0..self.ne {
                let mut sum = -self.rhs_b[e];
                for i in 0..nv {
                    sum += self.mm[e * nv + i] * l.r[i];
                }
                self.lam[e] = sum;
            }
            forward_rows(&self.s, self.ne, &mut self.lam, 1);
            backward_rows(&self.s, self.ne, &mut self.lam);
            for i in 0..nv {
                let mut zl = 0.0;
                for e in 0..self.ne {
                    zl += l.km[e * nv + i] * self.lam[e];
                }
                self.x[i] = l.r[i] - zl;
            }
            // The cones' block.
            let (mut rp, mut rd) = self.cone_block();
            // The limits' block.
            l.zold.copy_from_slice(&l.z);
            for k in 0..rows {
                let cx = (0..nv).map(|i| l.c[k * nv + i] * self.x[i]).sum::<f64>();
                l.cx[k] = cx;
                let relaxed = ALPHA * cx + (1.0 - ALPHA) * l.zold[k];
                l.z[k] = (relaxed + l.u[k]).clamp(l.lo[k], l.hi[k]);
                l.u[k] += relaxed - l.z[k];
                rp = rp.max((cx - l.z[k]).abs());
                rd = rd.max(self.rho * (l.z[k] - l.zold[k]).abs());
            }
            if !(rp.is_finite() && rd.is_finite()) {
                ok = false;
                break;
            }
            if rp <= tol && rd <= tol {
                break;
            }
            if iters % 25 == 0 && rp > 0.0 && rd > 0.0 {
                let ratio = (rp / rd).sqrt();
                if !(0.2..=5.0).contains(&ratio) {
                    let new = (self.rho * ratio.clamp(1e-2, 1e2)).clamp(1e-8, 1e8);
                    let scale = self.rho / new;
                    self.rho = new;
                    self.u.iter_mut().for_each(|v| *v *= scale);
                    l.u.iter_mut().for_each(|v| *v *= scale);
                    ok = self.factor_limited(&mut l);
                }
            }
        }
        self.stats.iterations += iters as u64;
        self.stats.max_iterations = self.stats.max_iterations.max(iters as u64);
        // Accept when inside the cones by half the margin and inside every limit.
        let slack = 1e-9 * (1.0 + self.grip_max());
        let met = ok
            && self.x.iter().all(|v| v.is_finite())
            && (0..self.pads.len())
                .all(|j| self.cone_margin(&self.x[4 * j..4 * j + 4]) >= 0.5 * self.margin - slack)
            && (0..rows).all(|k| {
                let cx = (0..nv).map(|i| l.c[k * nv + i] * self.x[i]).sum::<f64>();
                let tau = l.tau0[k] + l.norm[k] * cx;
                !l.effort[k].is_finite() || tau.abs() <= l.effort[k] * (1.0 + EFFORT_ACCEPT)
            });
        if !met {
            self.x.copy_from_slice(&l.save[..nv]);
            self.y.copy_from_slice(&l.save[nv..2 * nv]);
            self.u.copy_from_slice(&l.save[2 * nv..]);
        }
        self.limits = Some(l);
        met
    }

    /// `K = I + ρ (I + CᵀC)` factored, `K⁻¹ Mᵀ`, and `S = M K⁻¹ Mᵀ` factored (into `s`, which
    /// the next tick's [`build`](Self::build) sets again). `false` on a singular factor.
    fn factor_limited(&mut self, l: &mut TorqueRows) -> bool {
        let (nv, ne, rows) = (self.nv, self.ne, l.effort.len());
        for a in 0..nv {
            for b in 0..nv {
                let ctc = (0..rows)
                    .map(|k| l.c[k * nv + a] * l.c[k * nv + b])
                    .sum::<f64>();
                l.kf[a * nv + b] = self.rho * ctc + if a == b { 1.0 + self.rho } else { 0.0 };
            }
        }
        if cholesky_rows(&mut l.kf, nv).is_err() {
            return false;
        }
        for e in 0..ne {
            let row = &mut l.km[e * nv..(e + 1) * nv];
            row.copy_from_slice(&self.mm[e * nv..(e + 1) * nv]);
            forward_rows(&l.kf, nv, row, 1);
            backward_rows(&l.kf, nv, row);
        }
        for a in 0..ne {
            for c in 0..ne {
                self.s[a * ne + c] = (0..nv)
                    .map(|i| self.mm[a * nv + i] * l.km[c * nv + i])
                    .sum::<f64>();
            }
        }
        cholesky_rows(&mut self.s, ne).is_ok()
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
            let (rp, rd) = self.cone_block();
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
