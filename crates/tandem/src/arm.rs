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
//! Cartesian dynamics (3)–(4) for square (2-joint) arms: `M_x = J⁻ᵀ M J⁻¹`,
//! `C_x = J⁻ᵀ (C − M J⁻¹ J̇) J⁻¹` (the paper prints `J⁻ᵀ J̇`; SPEC §2.1), `G_x = J⁻ᵀ G`.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix2xX, Vector2};
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, non_negative, positive};
use crate::linalg::{cholesky_in_place, cholesky_solve_in_place};

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

/// Constants of the 2-link closed forms (SPEC §2.1).
#[derive(Clone, Copy, Debug)]
struct TwoLink {
    p1: f64,
    p2: f64,
    p3: f64,
    /// `m1 lc1 + m2 l1`.
    g1: f64,
    /// `m2 lc2`.
    g2: f64,
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
    two: Option<TwoLink>,
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
        let two = (n == 2).then(|| TwoLink {
            p1: m[0] * lc[0] * lc[0]
                + m[1] * (l[0] * l[0] + lc[1] * lc[1])
                + inertia[0]
                + inertia[1],
            p2: m[1] * l[0] * lc[1],
            p3: m[1] * lc[1] * lc[1] + inertia[1],
            g1: m[0] * lc[0] + m[1] * l[0],
            g2: m[1] * lc[1],
        });
        Ok(Arm {
            name: name.to_string(),
            base: Vector2::new(params.base[0], params.base[1]),
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
            p += lk * Vector2::new(phi.cos(), phi.sin());
        }
        p
    }

    /// Kinematics: joint points, COMs and their velocities, `J_e`, `J̇_e`, `J̇_e q̇`,
    /// end-effector position and velocity. Reads `(q, q̇)`; writes the kinematic fields of `t`.
    pub fn kinematics(&self, q: &[f64], qd: &[f64], t: &mut ArmTerms) {
        let n = self.dof();
        debug_assert!(q.len() >= n && qd.len() >= n);
        // Forward pass: absolute angles, joint points, COMs and their velocities.
        let mut phi = self.base_angle;
        let mut phid = 0.0;
        t.points[0] = self.base;
        t.points_dot[0] = Vector2::zeros();
        let mut jdq = Vector2::zeros();
        for k in 0..n {
            phi += q[k];
            phid += qd[k];
            t.phi[k] = phi;
            t.phi_dot[k] = phid;
            let (sk, ck) = phi.sin_cos();
            let u = Vector2::new(ck, sk);
            t.u[k] = u;
            let up = perp(u);
            t.com[k] = t.points[k] + self.lc[k] * u;
            t.com_dot[k] = t.points_dot[k] + self.lc[k] * phid * up;
            t.points[k + 1] = t.points[k] + self.l[k] * u;
            t.points_dot[k + 1] = t.points_dot[k] + self.l[k] * phid * up;
            jdq -= self.l[k] * phid * phid * u;
        }
        let pe = t.points[n];
        let ve = t.points_dot[n];
        for i in 0..n {
            t.J.set_column(i, &perp(pe - t.points[i]));
            t.Jdot.set_column(i, &perp(ve - t.points_dot[i]));
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
    pub fn general_dynamics(&self, g: f64, t: &mut ArmTerms) {
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

    fn two_link_dynamics(&self, k: &TwoLink, qd: &[f64], g: f64, t: &mut ArmTerms) {
        // SPEC §2.1 closed forms. The link directions u1 = u(q1), u12 = u(q1 + q2) come from
        // the kinematics pass: cos q2 = u1·u12, sin q2 = u1 × u12 (no further trigonometry).
        let (u1, u12) = (t.u[0], t.u[1]);
        let c2 = u1.dot(&u12);
        let s2 = cross(u1, u12);
        let m12 = k.p3 + k.p2 * c2;
        t.M[(0, 0)] = k.p1 + 2.0 * k.p2 * c2;
        t.M[(0, 1)] = m12;
        t.M[(1, 0)] = m12;
        t.M[(1, 1)] = k.p3;
        let h = k.p2 * s2;
        t.C[(0, 0)] = -h * qd[1];
        t.C[(0, 1)] = -h * (qd[0] + qd[1]);
        t.C[(1, 0)] = h * qd[0];
        t.C[(1, 1)] = 0.0;
        let c12 = u12.x;
        t.G[0] = k.g1 * g * u1.x + k.g2 * g * c12;
        t.G[1] = k.g2 * g * c12;
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
        if self.dof() != 2 {
            return Err(IkFailure::NotTwoLink);
        }
        let (l1, l2) = (self.l[0], self.l[1]);
        let d = p_we - self.base;
        let (sb, cb) = self.base_angle.sin_cos();
        // Target in the base frame.
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
        let q2 = self.elbow.sign() * c2.acos();
        let q1 = y.atan2(x) - (l2 * q2.sin()).atan2(l1 + l2 * q2.cos());
        Ok([q1, q2])
    }

    /// Cartesian dynamics (3)–(4) of a square (2-joint) arm after [`Arm::dynamics`];
    /// `None` when the arm is not square or `J_e` is singular (|det J| < `min_det`).
    pub fn cartesian(&self, t: &ArmTerms, min_det: f64) -> Option<Cartesian> {
        if self.dof() != 2 {
            return None;
        }
        let j = Matrix2::new(t.J[(0, 0)], t.J[(0, 1)], t.J[(1, 0)], t.J[(1, 1)]);
        let det = j.determinant();
        if !(det.abs() >= min_det) {
            return None;
        }
        let ji = Matrix2::new(j[(1, 1)], -j[(0, 1)], -j[(1, 0)], j[(0, 0)]) / det;
        let jit = ji.transpose();
        let m = Matrix2::new(t.M[(0, 0)], t.M[(0, 1)], t.M[(1, 0)], t.M[(1, 1)]);
        let c = Matrix2::new(t.C[(0, 0)], t.C[(0, 1)], t.C[(1, 0)], t.C[(1, 1)]);
        let jd = Matrix2::new(
            t.Jdot[(0, 0)],
            t.Jdot[(0, 1)],
            t.Jdot[(1, 0)],
            t.Jdot[(1, 1)],
        );
        let m_x = jit * m * ji;
        let c_x = jit * (c - m * ji * jd) * ji;
        let g_x = jit * Vector2::new(t.G[0], t.G[1]);
        Some(Cartesian {
            M_x: m_x,
            C_x: c_x,
            G_x: g_x,
            J_inv: ji,
        })
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
