//! The 2-link arm's closed forms (SPEC §2.1, with its errata against the paper's Section V-A):
//! [`TwoLinkArm`], a fast path selected once by [`Arm::two_link`](super::Arm::two_link) and held
//! equal to the general algorithm by the tests.

use nalgebra::{Matrix2, Vector2};

use super::fixed::{ArmBlock, ArmSolve, FixedArm};
use super::general::{Cartesian, cartesian_2x2, cross, perp};

/// A 2-link arm's fast path: the constants of the SPEC §2.1 closed forms and the geometry its
/// fixed-size kinematics need, computed once by [`Arm::new`](super::Arm::new) (see [`Arm::two_link`](super::Arm::two_link)).
///
/// Every method works on `Matrix2`/`Vector2` values on the stack: no `DMatrix` indexing, no
/// per-link `Vec` stores, at most one `sin_cos` per link ([`TwoLinkArm::pose`]) and none on the
/// inverse-kinematics route ([`TwoLinkArm::ik_pose`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLinkArm {
    pub(crate) base: Vector2<f64>,
    pub(crate) base_angle: f64,
    /// `(sin, cos)` of the base angle.
    pub(crate) base_sc: (f64, f64),
    pub(crate) l1: f64,
    pub(crate) l2: f64,
    /// `p1 = m1 lc1² + m2 (l1² + lc2²) + I1 + I2`, kg m².
    pub(crate) p1: f64,
    /// `p2 = m2 l1 lc2`, kg m².
    pub(crate) p2: f64,
    /// `p3 = m2 lc2² + I2`, kg m².
    pub(crate) p3: f64,
    /// `m1 lc1 + m2 l1`, kg m.
    pub(crate) g1: f64,
    /// `m2 lc2`, kg m.
    pub(crate) g2: f64,
    /// `p3 (p1 − p3)`: `det M = p3 (p1 − p3) − (p2 cos q2)²` without cancellation, kg² m⁴.
    pub(crate) det0: f64,
    /// Elbow sign `±1` of the inverse-kinematics branch.
    pub(crate) elbow: f64,
}

/// Link directions of a 2-link arm at one configuration (the output of
/// [`TwoLinkArm::pose`] or [`TwoLinkArm::ik_pose`]).
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLinkPose {
    /// `u(φ_1) = (cos φ_1, sin φ_1)`, link 1's world direction (`φ_1 = base angle + q_1`).
    pub u1: Vector2<f64>,
    /// `u(φ_2)`, link 2's world direction (`φ_2 = φ_1 + q_2`).
    pub u12: Vector2<f64>,
    /// `cos q_2`.
    pub c2: f64,
    /// `sin q_2`.
    pub s2: f64,
    /// End-effector Jacobian `J_e = [(l_1 u_1 + l_2 u_12)^⊥ | (l_2 u_12)^⊥]`, m/rad.
    pub J: Matrix2<f64>,
}

/// Kinematics and dynamics of a 2-link arm at one state in fixed-size types
/// ([`TwoLinkArm::terms`]); the same quantities as the matching [`ArmTerms`](super::ArmTerms) fields.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLinkTerms {
    /// Joint-space inertia `M(q)`, kg m².
    pub M: Matrix2<f64>,
    /// Christoffel-form Coriolis matrix `C(q, q̇)`, kg m²/s.
    pub C: Matrix2<f64>,
    /// Gravity torques `G(q)`, N m.
    pub G: Vector2<f64>,
    /// End-effector Jacobian `J_e`, m/rad.
    pub J: Matrix2<f64>,
    /// `J̇_e`, m/(rad s).
    pub Jdot: Matrix2<f64>,
    /// `J̇_e q̇`, m/s².
    pub jdot_qdot: Vector2<f64>,
    /// End-effector position `p_WE`, m.
    pub p_ee: Vector2<f64>,
    /// End-effector velocity `J_e q̇`, m/s.
    pub v_ee: Vector2<f64>,
    /// `det M = p3 (p1 − p3) − (p2 cos q2)²` (> 0 for physical parameters), kg² m⁴.
    pub det_M: f64,
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

impl FixedArm<2> for TwoLinkArm {
    /// Closed forms: [`TwoLinkArm::terms`], `M⁻¹ = adj M / det M`; keeps `M⁻¹`, `C q̇`, `G`.
    #[inline(always)]
    fn state_block(&self, q: [f64; 2], qd: [f64; 2], g: f64) -> Option<(ArmBlock<2>, ArmSolve<2>)> {
        let t = self.terms(&self.pose(q), qd, g);
        if !(t.det_M > 0.0) {
            return None;
        }
        let m_inv = t.m_inv();
        let y = m_inv * t.J.transpose();
        let blk = ArmBlock {
            a0: Vector2::zeros(),
            y,
            k: t.J * y,
            j: t.J,
            p_ee: t.p_ee,
            v_ee: t.v_ee,
            jdot_qdot: t.jdot_qdot,
        };
        let s = ArmSolve {
            m: m_inv,
            inv_diag: Vector2::zeros(),
            bias: t.C * Vector2::from(qd),
            g: t.G,
        };
        Some((blk, s))
    }
    /// On x86-64 the two arms in the two lanes of SSE2 registers (module `pair`): every operation
    /// of [`state_block`](FixedArm::state_block) (through [`TwoLinkArm::pose`],
    /// [`TwoLinkArm::terms`] and [`TwoLinkTerms::m_inv`]) once for both, in the same order
    /// (elsewhere the trait's default, one arm after the other).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn state_block_pair(
        arms: [&Self; 2],
        q: [[f64; 2]; 2],
        qd: [[f64; 2]; 2],
        g: f64,
    ) -> Option<[(ArmBlock<2>, ArmSolve<2>); 2]> {
        super::pair::state_block_pair(arms, q, qd, g)
    }
    /// `M⁻¹ ((τ − C q̇) − G)`.
    #[inline(always)]
    fn a0(&self, s: &ArmSolve<2>, tau: [f64; 2]) -> Vector2<f64> {
        s.m * (Vector2::new(tau[0], tau[1]) - s.bias - s.g)
    }
}

impl TwoLinkArm {
    /// SPEC §2.1 closed forms `(M, C, G)` from `cos q2`, `sin q2`, the world-frame cosines
    /// `cos φ_1`, `cos φ_2` of the two links (gravity acts along −y) and `q̇`.
    #[inline]
    pub(crate) fn mcg(
        &self,
        c2: f64,
        s2: f64,
        cos_phi1: f64,
        cos_phi2: f64,
        qd: [f64; 2],
        g: f64,
    ) -> (Matrix2<f64>, Matrix2<f64>, Vector2<f64>) {
        let m12 = self.p3 + self.p2 * c2;
        let m = Matrix2::new(self.p1 + 2.0 * self.p2 * c2, m12, m12, self.p3);
        let h = self.p2 * s2;
        let c = Matrix2::new(-h * qd[1], -h * (qd[0] + qd[1]), h * qd[0], 0.0);
        let gv = Vector2::new(
            self.g1 * g * cos_phi1 + self.g2 * g * cos_phi2,
            self.g2 * g * cos_phi2,
        );
        (m, c, gv)
    }

    /// Pose from link directions: fills `J_e = [(l_1 u_1 + l_2 u_12)^⊥ | (l_2 u_12)^⊥]`.
    #[inline]
    pub(crate) fn pose_from_dirs(
        &self,
        u1: Vector2<f64>,
        u12: Vector2<f64>,
        c2: f64,
        s2: f64,
    ) -> TwoLinkPose {
        let e2 = self.l2 * u12;
        let e = self.l1 * u1 + e2;
        TwoLinkPose {
            u1,
            u12,
            c2,
            s2,
            J: Matrix2::new(-e.y, -e2.y, e.x, e2.x),
        }
    }

    /// Pose at joint angles `q`: one `sin_cos` per link, accumulated as [`Arm::kinematics`](super::Arm::kinematics)
    /// does (`φ_1 = base angle + q_1`, `φ_2 = φ_1 + q_2`), so the directions are bitwise those
    /// of the general path; `cos q2 = u_1·u_12`, `sin q2 = u_1 × u_12`. Inlined into every
    /// caller (the plant's and the controller's hot paths), so that the two `sin_cos2` lanes
    /// overlap with the caller's other work.
    #[inline(always)]
    pub fn pose(&self, q: [f64; 2]) -> TwoLinkPose {
        let phi1 = self.base_angle + q[0];
        let phi2 = phi1 + q[1];
        let [(s1, c1), (s12, c12)] = crate::math::trig::sin_cos2(phi1, phi2);
        let u1 = Vector2::new(c1, s1);
        let u12 = Vector2::new(c12, s12);
        self.pose_from_dirs(u1, u12, u1.dot(&u12), cross(u1, u12))
    }

    /// End-effector position `p_WE = base + l_1 u_1 + l_2 u_12` at a pose, m.
    #[inline]
    pub fn end_effector(&self, pose: &TwoLinkPose) -> Vector2<f64> {
        self.base + self.l1 * pose.u1 + self.l2 * pose.u12
    }

    /// Target in the base frame and `cos q2` from the law of cosines; the reach check.
    /// Returns `(x, y, x² + y², cos q2)`.
    #[inline]
    pub(crate) fn ik_cos_q2(&self, p_we: Vector2<f64>) -> Result<(f64, f64, f64, f64), IkFailure> {
        let (l1, l2) = (self.l1, self.l2);
        let d = p_we - self.base;
        let (sb, cb) = self.base_sc;
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
        Ok((x, y, r2, c2))
    }

    /// Analytic inverse kinematics on the elbow branch, as angles
    /// (`q2 = ±acos c2`, `q1 = atan2(y, x) − atan2(l2 sin q2, l1 + l2 cos q2)`).
    pub fn inverse_kinematics(&self, p_we: Vector2<f64>) -> Result<[f64; 2], IkFailure> {
        let (x, y, _, c2) = self.ik_cos_q2(p_we)?;
        let (l1, l2) = (self.l1, self.l2);
        let q2 = self.elbow * c2.acos();
        let q1 = y.atan2(x) - (l2 * q2.sin()).atan2(l1 + l2 * q2.cos());
        Ok([q1, q2])
    }

    /// The same inverse kinematics as [`TwoLinkArm::inverse_kinematics`], as link directions
    /// and without transcendental calls (two `sqrt`, one division): `sin q2 = ±√((1 − c2)(1 + c2))`
    /// on the elbow branch, and `u(q_1)` is `(x, y)` rotated back by the angle of
    /// `k = (l1 + l2 c2, l2 s2)`: `(x k1 + y k2, y k1 − x k2) / (|(x, y)| |k|)`. (`|k| = r` by
    /// the law of cosines, but only to `ε (l1² + l2²) / r²`, which grows near a folded arm; the
    /// explicit norm keeps `|u_1| = 1` to ε.) Equal to the angle route up to round-off.
    #[inline]
    pub fn ik_pose(&self, p_we: Vector2<f64>) -> Result<TwoLinkPose, IkFailure> {
        let (x, y, r2, c2) = self.ik_cos_q2(p_we)?;
        let s2 = self.elbow * ((1.0 - c2) * (1.0 + c2)).sqrt();
        let k1 = self.l1 + self.l2 * c2;
        let k2 = self.l2 * s2;
        let inv_rk = 1.0 / (r2 * (k1 * k1 + k2 * k2)).sqrt();
        let (cq1, sq1) = ((x * k1 + y * k2) * inv_rk, (y * k1 - x * k2) * inv_rk);
        // World direction of link 1 (φ_1 = base angle + q_1), then link 2 (φ_2 = φ_1 + q_2).
        let (sb, cb) = self.base_sc;
        let u1 = Vector2::new(cb * cq1 - sb * sq1, sb * cq1 + cb * sq1);
        let u12 = Vector2::new(c2 * u1.x - s2 * u1.y, s2 * u1.x + c2 * u1.y);
        Ok(self.pose_from_dirs(u1, u12, c2, s2))
    }

    /// Kinematics and dynamics at `(pose, q̇)`: reads the pose's directions and Jacobian;
    /// writes every field of the result (SPEC §2.1 closed forms for `M`, `C`, `G`;
    /// `J̇_e = [v_E^⊥ | (l_2 φ̇_2 u_12^⊥)^⊥]`, `J̇_e q̇ = −l_1 φ̇_1² u_1 − l_2 φ̇_2² u_12`).
    #[inline]
    pub fn terms(&self, pose: &TwoLinkPose, qd: [f64; 2], g: f64) -> TwoLinkTerms {
        let (u1, u12) = (pose.u1, pose.u12);
        let (w1, w2) = (qd[0], qd[0] + qd[1]);
        let v1 = self.l1 * w1 * perp(u1);
        let v2 = self.l2 * w2 * perp(u12);
        let v_ee = v1 + v2;
        let (m, c, gv) = self.mcg(pose.c2, pose.s2, u1.x, u12.x, qd, g);
        let p2c2 = self.p2 * pose.c2;
        TwoLinkTerms {
            M: m,
            C: c,
            G: gv,
            J: pose.J,
            Jdot: Matrix2::new(-v_ee.y, -v2.y, v_ee.x, v2.x),
            jdot_qdot: -(self.l1 * w1 * w1) * u1 - (self.l2 * w2 * w2) * u12,
            p_ee: self.base + self.l1 * u1 + self.l2 * u12,
            v_ee,
            det_M: self.det0 - p2c2 * p2c2,
        }
    }
}

impl TwoLinkTerms {
    /// `M⁻¹ = adj(M) / det M` (closed form; the caller checks `det_M > 0`).
    #[inline]
    pub fn m_inv(&self) -> Matrix2<f64> {
        let m = &self.M;
        Matrix2::new(m[(1, 1)], -m[(0, 1)], -m[(1, 0)], m[(0, 0)]) * (1.0 / self.det_M)
    }

    /// Cartesian dynamics (3)–(4), as [`Arm::cartesian`](super::Arm::cartesian); `None` when |det J_e| < `min_det`.
    #[inline]
    pub fn cartesian(&self, min_det: f64) -> Option<Cartesian> {
        cartesian_2x2(&self.J, &self.M, &self.C, &self.Jdot, &self.G, min_det)
    }
}
