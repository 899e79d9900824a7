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

use nalgebra::{Matrix2x3, Matrix3, Vector2, Vector3};

use super::{Plant, PlantInput, PlantWorkspace};

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
    /// terms in `ws.cartesian` and joint state in `ws.q_red`, `ws.qd_red`.
    pub fn object_space(
        &self,
        x_o: &Vector3<f64>,
        xd_o: &Vector3<f64>,
        ws: &mut PlantWorkspace,
    ) -> Result<ObjectSpace, ReducedFailure> {
        let mut q = std::mem::take(&mut ws.q_red);
        let mut qd = std::mem::take(&mut ws.qd_red);
        let r = self.arms_from_object(x_o, xd_o, &mut q, &mut qd, ws);
        let out = r.and_then(|_| {
            let mut m = self.object.M_o;
            let mut c = self.object.C_o;
            let mut g = self.object.G_o;
            for (i, arm) in self.arms.iter().enumerate() {
                let off = self.offsets[i];
                let t = &mut ws.terms[i];
                arm.dynamics(&q[off..off + 2], &qd[off..off + 2], self.g, t);
                let cart = arm
                    .cartesian(t, MIN_DET)
                    .ok_or(ReducedFailure::Singular(i))?;
                ws.cartesian[i] = cart;
                let gr = &self.grasps[i];
                let jg = gr.jacobian(x_o.z);
                let rw = gr.arm_w(x_o.z);
                // J̇_i = [0 | −R r θ̇].
                let jgd = Matrix2x3::new(0.0, 0.0, -rw.x * xd_o.z, 0.0, 0.0, -rw.y * xd_o.z);
                let jt = jg.transpose();
                m += jt * cart.M_x * jg;
                c += jt * (cart.M_x * jgd + cart.C_x * jg);
                g += jt * cart.G_x;
            }
            Ok(ObjectSpace { M: m, C: c, G: g })
        });
        ws.q_red = q;
        ws.qd_red = qd;
        out
    }

    /// State derivative of the reduced plant on `y = (x_o, ẋ_o)` (6), with the grasp forces
    /// recovered from (3) into `ws.forces`. Joint torques in `input.tau` are mapped to the
    /// object through `τ = Σ J_iᵀ J_e,i⁻ᵀ τ_i`.
    pub fn reduced_derivative(
        &self,
        y: &[f64],
        input: &PlantInput,
        ws: &mut PlantWorkspace,
        dy: &mut [f64],
    ) -> Result<(), ReducedFailure> {
        let x_o = Vector3::new(y[0], y[1], y[2]);
        let xd_o = Vector3::new(y[3], y[4], y[5]);
        let os = self.object_space(&x_o, &xd_o, ws)?;
        // τ on the object from joint torques.
        let mut tau = Vector3::zeros();
        for (i, _) in self.arms.iter().enumerate() {
            let off = self.offsets[i];
            let cart = &ws.cartesian[i];
            let tx = cart.J_inv.transpose() * Vector2::new(input.tau[off], input.tau[off + 1]);
            ws.tau_x[i] = tx;
            tau += self.grasps[i].jacobian(x_o.z).transpose() * tx;
        }
        let rhs = tau - input.f_d - os.C * xd_o - os.G;
        let xdd =
            os.M.cholesky()
                .map(|c| c.solve(&rhs))
                .ok_or(ReducedFailure::Singular(0))?;
        ws.xdd_o = xdd;
        // Grasp forces from (3).
        for (i, _) in self.arms.iter().enumerate() {
            let g = &self.grasps[i];
            let jg = g.jacobian(x_o.z);
            let xi_d = jg * xd_o;
            let xi_dd = jg * xdd + g.jdot_xdot(x_o.z, xd_o.z);
            let cart = &ws.cartesian[i];
            ws.forces[i] = cart.M_x * xi_dd + cart.C_x * xi_d + cart.G_x - ws.tau_x[i];
        }
        dy[..3].copy_from_slice(xd_o.as_slice());
        dy[3..6].copy_from_slice(xdd.as_slice());
        Ok(())
    }
}
