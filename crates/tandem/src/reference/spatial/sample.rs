//! [`PoseSample`]: a pose with its twist and twist rate, what the reference pose fit
//! ([`super::fit`](mod@super::fit)), the 6-D admittance ([`super::admittance`]) and the
//! controller's output chart ([`crate::control::spatial::chart`]) work on. Conventions
//! (SPEC-spatial S1): SI units; `R_AB` maps `B` coordinates to `A`; twists are `[v; ω]`,
//! **linear first**, in **world axes**, `v` the velocity of the frame's origin and `ω` the
//! angular velocity, so `Ṙ_WO = [ω]× R_WO` and `ṗ_WO = v`; the twist rate is the plain time
//! derivative `[v̇; ω̇]` of those world-axes vectors. Drake monogram names (`p_WO`, `R_WO`,
//! `X_OGi`, `X_WTi`).
//!
//! Nothing here allocates: every per-tick function works on fixed-size nalgebra values and
//! slices the caller owns.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3, Vector6};

use crate::geometry::motion::{ang, lin, stack};
use crate::plant::spatial::ObjectState;

/// A pose with its twist and twist rate: `(p_WA, R_WA, V_WA = [v; ω], V̇_WA = [v̇; ω̇])` of some
/// frame `A` (the object `O`, a tool `T_i`, a desired pose), world axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseSample {
    /// `p_WA`: position of the frame's origin, m.
    pub p: Vector3<f64>,
    /// `R_WA` as a unit quaternion.
    pub q: UnitQuaternion<f64>,
    /// `V_WA = [v; ω]`: velocity of the origin and angular velocity, world axes, (m/s, rad/s).
    pub twist: Vector6<f64>,
    /// `V̇_WA = [v̇; ω̇]`: time derivative of the world-axes twist, (m/s², rad/s²).
    pub twist_dot: Vector6<f64>,
}

impl PoseSample {
    /// A pose at rest.
    pub fn at_rest(p: Vector3<f64>, q: UnitQuaternion<f64>) -> Self {
        Self {
            p,
            q,
            twist: Vector6::zeros(),
            twist_dot: Vector6::zeros(),
        }
    }

    /// From a pose `X_WA` with its twist and twist rate.
    pub fn from_pose(x: &Isometry3<f64>, twist: Vector6<f64>, twist_dot: Vector6<f64>) -> Self {
        Self {
            p: x.translation.vector,
            q: x.rotation,
            twist,
            twist_dot,
        }
    }

    /// From the plant's object state (`p_WO`, `q_WO`, `[v_WO; ω_WO]`) and the object's
    /// acceleration `[v̇_WO; ω̇_WO]`.
    pub fn from_object_state(o: &ObjectState, twist_dot: Vector6<f64>) -> Self {
        Self {
            p: o.p,
            q: o.q,
            twist: o.twist(),
            twist_dot,
        }
    }

    /// The pose `X_WA`.
    pub fn pose(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.p), self.q)
    }

    /// `v`, m/s.
    pub fn v(&self) -> Vector3<f64> {
        lin(&self.twist)
    }

    /// `ω`, world axes, rad/s.
    pub fn w(&self) -> Vector3<f64> {
        ang(&self.twist)
    }

    /// `v̇`, m/s².
    pub fn v_dot(&self) -> Vector3<f64> {
        lin(&self.twist_dot)
    }

    /// `ω̇`, world axes, rad/s².
    pub fn w_dot(&self) -> Vector3<f64> {
        ang(&self.twist_dot)
    }

    /// The same motion seen from another world frame `W'`: `X_W'A = X_W'W X_WA`, twist and
    /// twist rate rotated by `R_W'W` (the origin velocity of `A` is a property of `A`, so only
    /// its axes change).
    pub fn transformed(&self, x_w2w: &Isometry3<f64>) -> Self {
        let r = x_w2w.rotation;
        Self {
            p: (x_w2w * nalgebra::Point3::from(self.p)).coords,
            q: r * self.q,
            twist: stack(&(r * self.v()), &(r * self.w())),
            twist_dot: stack(&(r * self.v_dot()), &(r * self.w_dot())),
        }
    }
}

/// The pure quaternion `(0, v)`.
#[inline]
pub(crate) fn pure(v: &Vector3<f64>) -> Quaternion<f64> {
    Quaternion::new(0.0, v.x, v.y, v.z)
}
