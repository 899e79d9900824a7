//! The general n-link planar arm ([`Arm`]): kinematics, composite-rigid-body `M`, Christoffel
//! `C`, `G`, RNEA, forward dynamics and the Cartesian terms (3)–(4), on [`ArmTerms`] (`DMatrix`
//! blocks, any link count). The algorithms are listed in [the folder's docs](super).

use nalgebra::{DMatrix, DVector, Matrix2, Matrix2xX, Vector2};

use crate::error::{ModelError, non_negative, positive};
use crate::math::linalg::{cholesky_in_place, cholesky_solve_in_place};
use crate::model::planar::arm::{ArmParams, Elbow};

use super::fixed::FixedLinkArm;
use super::two_link::{IkFailure, TwoLinkArm};

/// A validated, immutable planar arm.
#[derive(Clone, Debug)]
pub struct Arm {
    pub(crate) name: String,
    pub(crate) base: Vector2<f64>,
    pub(crate) base_angle: f64,
    pub(crate) m: Vec<f64>,
    pub(crate) l: Vec<f64>,
    pub(crate) lc: Vec<f64>,
    pub(crate) inertia: Vec<f64>,
    pub(crate) elbow: Elbow,
    /// The 2-link fast path, selected once here (`None` for other link counts).
    pub(crate) two: Option<TwoLinkArm>,
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
    pub(crate) points_dot: Vec<Vector2<f64>>,
    pub(crate) com: Vec<Vector2<f64>>,
    pub(crate) com_dot: Vec<Vector2<f64>>,
    pub(crate) phi: Vec<f64>,
    pub(crate) phi_dot: Vec<f64>,
    /// `u(φ_k) = (cos φ_k, sin φ_k)` per link.
    pub(crate) u: Vec<Vector2<f64>>,
    pub(crate) rnea_f: Vec<Vector2<f64>>,
    pub(crate) rnea_a: Vec<Vector2<f64>>,
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

#[inline]
pub(crate) fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

#[inline]
pub(crate) fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
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
        let base = Vector2::new(params.base[0], params.base[1]);
        let two = (n == 2).then(|| {
            let p1 = m[0] * lc[0] * lc[0]
                + m[1] * (l[0] * l[0] + lc[1] * lc[1])
                + inertia[0]
                + inertia[1];
            let p3 = m[1] * lc[1] * lc[1] + inertia[1];
            TwoLinkArm {
                base,
                base_angle: params.base_angle,
                base_sc: crate::math::trig::sin_cos(params.base_angle),
                l1: l[0],
                l2: l[1],
                p1,
                p2: m[1] * l[0] * lc[1],
                p3,
                g1: m[0] * lc[0] + m[1] * l[0],
                g2: m[1] * lc[1],
                det0: p3 * (p1 - p3),
                elbow: params.elbow.sign(),
            }
        });
        Ok(Arm {
            name: name.to_string(),
            base,
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
            let (s, c) = crate::math::trig::sin_cos(phi);
            p += lk * Vector2::new(c, s);
        }
        p
    }

    /// Kinematics: joint points, COMs and their velocities, `J_e`, `J̇_e`, `J̇_e q̇`,
    /// end-effector position and velocity. Reads `(q, q̇)`; writes the kinematic fields of `t`.
    pub fn kinematics(&self, q: &[f64], qd: &[f64], t: &mut ArmTerms) {
        // The same body with the link count a constant for 2–4 links (unrolled loops).
        match self.dof() {
            2 => self.kinematics_n(2, q, qd, t),
            3 => self.kinematics_n(3, q, qd, t),
            4 => self.kinematics_n(4, q, qd, t),
            n => self.kinematics_n(n, q, qd, t),
        }
    }

    #[inline(always)]
    fn kinematics_n(&self, n: usize, q: &[f64], qd: &[f64], t: &mut ArmTerms) {
        debug_assert!(q.len() >= n && qd.len() >= n);
        let (q, qd) = (&q[..n], &qd[..n]);
        // One length check per buffer; then the loops index in range by construction.
        let (lc, l) = (&self.lc[..n], &self.l[..n]);
        let (phis, phi_dots, us) = (&mut t.phi[..n], &mut t.phi_dot[..n], &mut t.u[..n]);
        let (com, com_dot) = (&mut t.com[..n], &mut t.com_dot[..n]);
        let (points, points_dot) = (&mut t.points[..n + 1], &mut t.points_dot[..n + 1]);
        // Forward pass: absolute angles, joint points, COMs and their velocities.
        let mut phi = self.base_angle;
        let mut phid = 0.0;
        points[0] = self.base;
        points_dot[0] = Vector2::zeros();
        let mut jdq = Vector2::zeros();
        for k in 0..n {
            phi += q[k];
            phid += qd[k];
            phis[k] = phi;
            phi_dots[k] = phid;
            let (sk, ck) = crate::math::trig::sin_cos(phi);
            let u = Vector2::new(ck, sk);
            us[k] = u;
            let up = perp(u);
            com[k] = points[k] + lc[k] * u;
            com_dot[k] = points_dot[k] + lc[k] * phid * up;
            points[k + 1] = points[k] + l[k] * u;
            points_dot[k + 1] = points_dot[k] + l[k] * phid * up;
            jdq -= l[k] * phid * phid * u;
        }
        let pe = points[n];
        let ve = points_dot[n];
        let jm = &mut t.J.as_mut_slice()[..2 * n];
        let jdm = &mut t.Jdot.as_mut_slice()[..2 * n];
        for i in 0..n {
            let c = perp(pe - points[i]);
            jm[2 * i] = c.x;
            jm[2 * i + 1] = c.y;
            let cd = perp(ve - points_dot[i]);
            jdm[2 * i] = cd.x;
            jdm[2 * i + 1] = cd.y;
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
    ///
    /// For 3 and 4 links it runs a copy of the loops with the link count a constant (unrolled,
    /// no bounds checks; the same operations in the same order, so the same bits).
    pub fn general_dynamics(&self, g: f64, t: &mut ArmTerms) {
        match self.dof() {
            3 => self.general_dynamics_n::<3>(g, t),
            4 => self.general_dynamics_n::<4>(g, t),
            _ => self.general_dynamics_dyn(g, t),
        }
    }

    /// [`Arm::general_dynamics`] with the link count `N` a constant: one length check per
    /// buffer, then fixed-trip loops.
    #[inline]
    fn general_dynamics_n<const N: usize>(&self, g: f64, t: &mut ArmTerms) {
        let (m, inertia) = (&self.m[..N], &self.inertia[..N]);
        let (com, com_dot) = (&t.com[..N], &t.com_dot[..N]);
        let (points, points_dot) = (&t.points[..N], &t.points_dot[..N]);
        let mm = &mut t.M.as_mut_slice()[..N * N];
        let cc = &mut t.C.as_mut_slice()[..N * N];
        let gg = &mut t.G.as_mut_slice()[..N];
        // Lever arms c_k − P_i once; M_ji is M_ij (the same products, summed in the same
        // order), so only j ≥ i is summed.
        let mut r = [[Vector2::zeros(); N]; N];
        for k in 0..N {
            for i in 0..=k {
                r[k][i] = com[k] - points[i];
            }
        }
        for i in 0..N {
            for j in 0..N {
                let mut mij = 0.0;
                let mut cij = 0.0;
                for k in i.max(j)..N {
                    if j >= i {
                        mij += m[k] * r[k][i].dot(&r[k][j]) + inertia[k];
                    }
                    cij += m[k] * r[k][i].dot(&(com_dot[k] - points_dot[j]));
                }
                if j >= i {
                    mm[i + N * j] = mij;
                    mm[j + N * i] = mij;
                }
                cc[i + N * j] = cij;
            }
            let mut gi = 0.0;
            for k in i..N {
                gi += m[k] * r[k][i].x;
            }
            gg[i] = g * gi;
        }
    }

    fn general_dynamics_dyn(&self, g: f64, t: &mut ArmTerms) {
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

    fn two_link_dynamics(&self, k: &TwoLinkArm, qd: &[f64], g: f64, t: &mut ArmTerms) {
        // SPEC §2.1 closed forms. The link directions u1 = u(q1), u12 = u(q1 + q2) come from
        // the kinematics pass: cos q2 = u1·u12, sin q2 = u1 × u12 (no further trigonometry).
        let (u1, u12) = (t.u[0], t.u[1]);
        let (m, c, gv) = k.mcg(u1.dot(&u12), cross(u1, u12), u1.x, u12.x, [qd[0], qd[1]], g);
        t.M.copy_from(&m);
        t.C.copy_from(&c);
        t.G.copy_from(&gv);
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
        match &self.two {
            Some(k) => k.inverse_kinematics(p_we),
            None => Err(IkFailure::NotTwoLink),
        }
    }

    /// The fixed-size kernel of an `N`-link arm ([`FixedLinkArm`]), `None` unless the arm has
    /// exactly `N` links.
    pub fn fixed<const N: usize>(&self) -> Option<FixedLinkArm<N>> {
        (self.dof() == N).then(|| {
            let arr = |v: &[f64]| std::array::from_fn(|k| v[k]);
            FixedLinkArm {
                base: self.base,
                base_angle: self.base_angle,
                m: arr(&self.m),
                l: arr(&self.l),
                lc: arr(&self.lc),
                inertia: arr(&self.inertia),
            }
        })
    }

    /// The 2-link fast path (fixed-size kinematics and dynamics), `None` unless the arm has
    /// exactly two links. Selected once at construction.
    pub fn two_link(&self) -> Option<&TwoLinkArm> {
        self.two.as_ref()
    }

    /// Cartesian dynamics (3)–(4) of a square (2-joint) arm after [`Arm::dynamics`];
    /// `None` when the arm is not square or `J_e` is singular (|det J| < `min_det`).
    pub fn cartesian(&self, t: &ArmTerms, min_det: f64) -> Option<Cartesian> {
        if self.dof() != 2 {
            return None;
        }
        let m2 = |a: &DMatrix<f64>| Matrix2::new(a[(0, 0)], a[(0, 1)], a[(1, 0)], a[(1, 1)]);
        let j = Matrix2::new(t.J[(0, 0)], t.J[(0, 1)], t.J[(1, 0)], t.J[(1, 1)]);
        let jd = Matrix2::new(
            t.Jdot[(0, 0)],
            t.Jdot[(0, 1)],
            t.Jdot[(1, 0)],
            t.Jdot[(1, 1)],
        );
        cartesian_2x2(
            &j,
            &m2(&t.M),
            &m2(&t.C),
            &jd,
            &Vector2::new(t.G[0], t.G[1]),
            min_det,
        )
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

/// Cartesian dynamics (3)–(4) from 2×2 joint-space terms: `M_x = J⁻ᵀ M J⁻¹`,
/// `C_x = J⁻ᵀ (C − M J⁻¹ J̇) J⁻¹`, `G_x = J⁻ᵀ G` (SPEC §2.1); `None` when |det J| < `min_det`.
#[inline]
pub(crate) fn cartesian_2x2(
    j: &Matrix2<f64>,
    m: &Matrix2<f64>,
    c: &Matrix2<f64>,
    jd: &Matrix2<f64>,
    g: &Vector2<f64>,
    min_det: f64,
) -> Option<Cartesian> {
    let det = j.determinant();
    if !(det.abs() >= min_det) {
        return None;
    }
    let ji = Matrix2::new(j[(1, 1)], -j[(0, 1)], -j[(1, 0)], j[(0, 0)]) * (1.0 / det);
    let jit = ji.transpose();
    let m_x = jit * m * ji;
    let c_x = jit * (c - m * ji * jd) * ji;
    let g_x = jit * g;
    Some(Cartesian {
        M_x: m_x,
        C_x: c_x,
        G_x: g_x,
        J_inv: ji,
    })
}
