//! Reduced object-space dynamics, paper (14), SPEC §2.4:
//!
//! $$𝓜 \ddot x_o + 𝓒 \dot x_o + 𝓖 = τ − F_d,\quad 𝓜 = Σ_i J_i^\top M_{x,i} J_i + M_o,\quad
//! 𝓒 = Σ_i J_i^\top (M_{x,i} \dot J_i + C_{x,i} J_i) + C_o,\quad 𝓖 = Σ_i J_i^\top G_{x,i} + G_o$$
//!
//! with `τ = Σ J_iᵀ τ_x,i`, `τ_x,i = J_e,i⁻ᵀ τ_joint,i`. Each arm's joints come from the analytic
//! inverse kinematics on its fixed elbow branch (2-link arms only) and `q̇_i = J_e,i⁻¹ J_i ẋ_o`.
//! Grasp forces are recovered from (3): `F_i = M_x ẍ_i + C_x ẋ_i + G_x − τ_x,i` with
//! `ẍ_i = J_i ẍ_o + J̇_i ẋ_o`. (Paper (14) prints `J(x_o)` block-diagonal; with pinned grasps it
//! is the stack of the `J_i`.)
//!
//! Every per-arm block is a fixed-size value ([`TwoLinkArm`](crate::dynamics::planar::TwoLinkArm)): the
//! inverse kinematics gives the link directions without transcendental calls
//! ([`TwoLinkArm::ik_pose`](crate::dynamics::planar::TwoLinkArm::ik_pose)), `M`, `C`, `G` are the SPEC §2.1
//! closed forms, the Cartesian terms (3)–(4) are 2×2 closed forms, and the pinned grasp Jacobian
//! `J_i = [I₂ | d_i]`, `d_i = (R(θ) r_i)^⊥`, is used by its structure. One `sin_cos` (of `θ`)
//! per evaluation.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use super::{Plant, PlantInput, PlantWorkspace};
use crate::math::linalg::{cholesky_in_place, cholesky_solve_in_place};

/// Object-space dynamics terms of (14) at one state.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectSpace {
    /// `𝓜`, 3 × 3.
    pub M: Matrix3<f64>,
    /// `𝓒`, 3 × 3.
    pub C: Matrix3<f64>,
    /// `𝓖`, 3.
    pub G: Vector3<f64>,
}

/// Why the reduced formulation cannot be evaluated at a state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReducedFailure {
    /// Arm `i`'s grasp point is out of reach, or the arm is not a 2-link arm.
    Ik(usize),
    /// Arm `i`'s Jacobian is singular there.
    Singular(usize),
}

/// Smallest |det J_e| accepted by the reduced formulation, m²/rad².
const MIN_DET: f64 = 1e-9;

#[inline]
fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

/// `J_iᵀ [B | b]` for the pinned grasp Jacobian `J_i = [I₂ | d]` (so `J_iᵀ = [I₂; dᵀ]`):
/// `[[B, b], [dᵀB, dᵀb]]`, 3 × 3.
#[inline]
fn grasp_left(bm: &Matrix2<f64>, b: &Vector2<f64>, d: &Vector2<f64>) -> Matrix3<f64> {
    let db = bm.tr_mul(d);
    Matrix3::new(
        bm[(0, 0)],
        bm[(0, 1)],
        b.x,
        bm[(1, 0)],
        bm[(1, 1)],
        b.y,
        db.x,
        db.y,
        d.dot(b),
    )
}

impl Plant {
    /// Joint angles and velocities of every arm for an object state, from the analytic IK
    /// (writes the stacked `q`, `q̇` into the slices and the arm terms into `ws`).
    pub fn arms_from_object(
        &self,
        x_o: &Vector3<f64>,
        xd_o: &Vector3<f64>,
        q: &mut [f64],
        qd: &mut [f64],
        ws: &mut PlantWorkspace,
    ) -> Result<(), ReducedFailure> {
        for (i, arm) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let g = &self.grasps[i];
            let qi = arm
                .inverse_kinematics(g.point(x_o))
                .map_err(|_| ReducedFailure::Ik(i))?;
            q[off..off + 2].copy_from_slice(&qi);
            let t = &mut ws.terms[i];
            arm.kinematics(&q[off..off + 2], &[0.0, 0.0], t);
            let v = g.jacobian(x_o.z) * xd_o;
            let det = t.J[(0, 0)] * t.J[(1, 1)] - t.J[(0, 1)] * t.J[(1, 0)];
            if !(det.abs() >= MIN_DET) {
                return Err(ReducedFailure::Singular(i));
            }
            qd[off] = (t.J[(1, 1)] * v.x - t.J[(0, 1)] * v.y) / det;
            qd[off + 1] = (-t.J[(1, 0)] * v.x + t.J[(0, 0)] * v.y) / det;
        }
        Ok(())
    }

    /// Object-space terms `(𝓜, 𝓒, 𝓖)` of (14) at `(x_o, ẋ_o)`; also leaves each arm's Cartesian
    /// terms in `ws.cartesian`, joint state in `ws.q_red`, `ws.qd_red`, and its kinematics and
    /// dynamics in `ws.terms`.
    pub fn object_space(
        &self,
        x_o: &Vector3<f64>,
        xd_o: &Vector3<f64>,
        ws: &mut PlantWorkspace,
    ) -> Result<ObjectSpace, ReducedFailure> {
        self.object_space_into(x_o, xd_o, ws, true)
    }

    /// The fixed-size evaluation of (14). Per arm: `R(θ) r_i` (into `ws.rw`) → IK link
    /// directions → `q̇_i = J_e,i⁻¹ J_i ẋ_o` → closed-form `M, C, G, J̇_e` → Cartesian terms (into
    /// `ws.cartesian`) → accumulated into `(𝓜, 𝓒, 𝓖)`. With `publish`, also the joint angles
    /// (by [`TwoLinkArm::inverse_kinematics`]) and velocities into `ws.q_red`, `ws.qd_red` and
    /// the full arm terms into `ws.terms` (what [`Plant::object_space`] promises; the
    /// derivative does not need them).
    ///
    /// [`TwoLinkArm`]: crate::dynamics::planar::TwoLinkArm
    /// [`TwoLinkArm::inverse_kinematics`]: crate::dynamics::planar::TwoLinkArm::inverse_kinematics
    #[inline]
    fn object_space_into(
        &self,
        x_o: &Vector3<f64>,
        xd_o: &Vector3<f64>,
        ws: &mut PlantWorkspace,
        publish: bool,
    ) -> Result<ObjectSpace, ReducedFailure> {
        let (sin_th, cos_th) = crate::math::trig::sin_cos(x_o.z);
        let p_o = Vector2::new(x_o.x, x_o.y);
        let th_d = xd_o.z;
        let mut m = self.object.M_o;
        let mut c = self.object.C_o;
        let mut g = self.object.G_o;
        for (i, arm) in self.arms.iter().enumerate() {
            let k = arm.two_link().ok_or(ReducedFailure::Ik(i))?;
            // Grasp i: R(θ) r_i, its point and d_i = (R r_i)^⊥, so J_i = [I | d_i].
            let r = self.grasps[i].r;
            let rw = Vector2::new(cos_th * r.x - sin_th * r.y, sin_th * r.x + cos_th * r.y);
            ws.rw[i] = rw;
            let d = perp(rw);
            let p = p_o + rw;
            // Joints: IK pose, then q̇ = J_e⁻¹ J_i ẋ_o (Cramer's rule).
            let pose = k.ik_pose(p).map_err(|_| ReducedFailure::Ik(i))?;
            let j = &pose.J;
            let det = j[(0, 0)] * j[(1, 1)] - j[(0, 1)] * j[(1, 0)];
            if !(det.abs() >= MIN_DET) {
                return Err(ReducedFailure::Singular(i));
            }
            let v = Vector2::new(xd_o.x + d.x * th_d, xd_o.y + d.y * th_d);
            let inv_det = 1.0 / det;
            let qd = [
                (j[(1, 1)] * v.x - j[(0, 1)] * v.y) * inv_det,
                (-j[(1, 0)] * v.x + j[(0, 0)] * v.y) * inv_det,
            ];
            // Arm dynamics and its Cartesian form (3)–(4).
            let t = k.terms(&pose, qd, self.g);
            let cart = t.cartesian(MIN_DET).ok_or(ReducedFailure::Singular(i))?;
            ws.cartesian[i] = cart;
            if publish {
                let off = self.offsets[i];
                let q = k.inverse_kinematics(p).map_err(|_| ReducedFailure::Ik(i))?;
                ws.q_red[off..off + 2].copy_from_slice(&q);
                ws.qd_red[off..off + 2].copy_from_slice(&qd);
                arm.dynamics(&q, &qd, self.g, &mut ws.terms[i]);
            }
            // (14) with J_i = [I | d] and J̇_i = [0 | e], e = −R r_i θ̇:
            // J_iᵀ M_x J_i = J_iᵀ [M_x | M_x d], J_iᵀ (M_x J̇_i + C_x J_i) = J_iᵀ [C_x | C_x d + M_x e].
            let e = Vector2::new(-rw.x * th_d, -rw.y * th_d);
            m += grasp_left(&cart.M_x, &(cart.M_x * d), &d);
            c += grasp_left(&cart.C_x, &(cart.C_x * d + cart.M_x * e), &d);
            g += Vector3::new(cart.G_x.x, cart.G_x.y, d.dot(&cart.G_x));
        }
        Ok(ObjectSpace { M: m, C: c, G: g })
    }

    /// State derivative of the reduced plant on `y = (x_o, ẋ_o)` (6), with the grasp forces
    /// recovered from (3) into `ws.forces`. Joint torques in `input.tau` are mapped to the
    /// object through `τ = Σ J_iᵀ J_e,i⁻ᵀ τ_i`. Reads `(y, input)`; writes `dy`, `ws.forces`,
    /// `ws.xdd_o` and `ws.cartesian` (not `ws.terms`, `ws.q_red`, `ws.qd_red`: use
    /// [`Plant::object_space`] or [`Plant::arms_from_object`] for those).
    pub fn reduced_derivative(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> Result<(), ReducedFailure> {
        let x_o = Vector3::new(y[0], y[1], y[2]);
        let xd_o = Vector3::new(y[3], y[4], y[5]);
        let os = self.object_space_into(&x_o, &xd_o, ws, false)?;
        // τ on the object from joint torques: τ_x,i = J_e,i⁻ᵀ τ_i, τ = Σ J_iᵀ τ_x,i.
        let mut tau = Vector3::zeros();
        for i in 0..self.arms.len() {
            let off = self.offsets[i];
            let tx = ws.cartesian[i]
                .J_inv
                .tr_mul(&Vector2::new(input.tau[off], input.tau[off + 1]));
            ws.tau_x[i] = tx;
            tau += Vector3::new(tx.x, tx.y, perp(ws.rw[i]).dot(&tx));
        }
        // 𝓜 ẍ_o = τ − F_d − 𝓒 ẋ_o − 𝓖 by the in-place Cholesky (𝓜 is SPD where (14) exists).
        let mut xdd = tau - input.f_d - os.C * xd_o - os.G;
        let mut l = os.M;
        cholesky_in_place(&mut l, 3).map_err(|_| ReducedFailure::Singular(0))?;
        cholesky_solve_in_place(&l, 3, xdd.as_mut_slice());
        ws.xdd_o = xdd;
        // Grasp forces from (3): ẋ_i = J_i ẋ_o, ẍ_i = J_i ẍ_o + J̇_i ẋ_o (J̇_i ẋ_o = −R r_i θ̇²).
        for i in 0..self.arms.len() {
            let rw = ws.rw[i];
            let d = perp(rw);
            let xi_d = Vector2::new(xd_o.x + d.x * xd_o.z, xd_o.y + d.y * xd_o.z);
            let xi_dd =
                Vector2::new(xdd.x + d.x * xdd.z, xdd.y + d.y * xdd.z) + -rw * xd_o.z * xd_o.z;
            let cart = &ws.cartesian[i];
            ws.forces[i] = cart.M_x * xi_dd + cart.C_x * xi_d + cart.G_x - ws.tau_x[i];
        }
        dy[..3].copy_from_slice(xd_o.as_slice());
        dy[3..6].copy_from_slice(xdd.as_slice());
        Ok(())
    }
}
