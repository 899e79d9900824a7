//! A serial kinematic chain of rigid bodies from a base frame to a tool frame (SPEC-spatial S2).
//!
//! Conventions (SPEC-spatial S1): SI units; `X_AB` is the pose of frame `B` in frame `A`
//! (`p_A = X_AB · p_B`); twists and wrenches are ordered linear first.
//!
//! Body `k` is the rigid body moved by joint `k` (fixed joints already merged into it). Its frame
//! `L_k` is the joint frame of joint `k` after the joint's motion:
//!
//! ```text
//! X_B L_0   = X_PJ[0] · J_0(q_0)
//! X_B L_k   = X_B L_{k−1} · X_PJ[k] · J_k(q_k)
//! X_B T     = X_B L_{n−1} · X_LT
//! ```
//!
//! with `X_PJ[k]` the joint's placement in its parent body frame (the URDF `<origin>`, fixed
//! joints in between composed in), `J_k(q) = Rot(axis_k, q)` for a revolute joint and
//! `Trans(axis_k q)` for a prismatic one, `B` the base frame and `T` the tool frame.

use nalgebra::{Isometry3, Matrix3, Unit, Vector3};

use crate::error::ModelError;

/// How a joint moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the axis (URDF `revolute` and `continuous`), rad.
    Revolute,
    /// Translation along the axis (URDF `prismatic`), m.
    Prismatic,
}

/// Joint limits (URDF `<limit>`); a `continuous` joint has infinite position limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    /// Lower position limit, rad or m (`−∞` when unlimited).
    pub lower: f64,
    /// Upper position limit, rad or m (`+∞` when unlimited).
    pub upper: f64,
    /// Velocity limit, rad/s or m/s (`+∞` when not given).
    pub velocity: f64,
    /// Effort limit, N m or N (`+∞` when not given).
    pub effort: f64,
}

impl JointLimits {
    /// No limits at all.
    pub const UNLIMITED: JointLimits = JointLimits {
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        velocity: f64::INFINITY,
        effort: f64::INFINITY,
    };
}

/// One movable joint of the chain.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainJoint {
    /// The joint's name (URDF `name`), for messages.
    pub name: String,
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// `X_PJ`: placement of the joint frame in the parent body's frame at `q = 0` (fixed joints
    /// between the two bodies composed in).
    pub placement: Isometry3<f64>,
    /// Joint axis in the joint frame (unit).
    pub axis: Unit<Vector3<f64>>,
    /// Limits.
    pub limits: JointLimits,
    /// Viscous joint damping (URDF `<dynamics damping>`), N m s/rad or N s/m (≥ 0).
    pub damping: f64,
}

impl ChainJoint {
    /// The joint position that puts the body where `q` does and lies inside the limits: `q`
    /// itself when it is inside (the same bits), else, for a revolute joint, `q + 2πk` for the
    /// whole number `k` that lands inside and is nearest to `near` (a revolute joint's angle is
    /// only defined up to a turn, and an inverse kinematics result may come out a turn away from
    /// a range such as a Jaco's `[0.82, 5.46]` rad). `None` when no turn brings it inside, for a
    /// prismatic joint outside its limits, or for a non-finite `q`.
    pub fn wrap_into_limits(&self, q: f64, near: f64) -> Option<f64> {
        let (lo, hi) = (self.limits.lower, self.limits.upper);
        if q >= lo && q <= hi {
            return Some(q);
        }
        if self.kind != JointKind::Revolute || !q.is_finite() {
            return None;
        }
        let tau = std::f64::consts::TAU;
        // The turns k with lo <= q + 2πk <= hi, and of those the one nearest to `near`
        // (checked again after rounding; the neighbours cover a rounding at the edge).
        let (k_lo, k_hi) = (((lo - q) / tau).ceil(), ((hi - q) / tau).floor());
        if !(k_lo <= k_hi) {
            return None;
        }
        let k = ((near - q) / tau).round().clamp(k_lo, k_hi);
        [k, k - 1.0, k + 1.0]
            .into_iter()
            .map(|k| q + tau * k)
            .find(|v| *v >= lo && *v <= hi)
    }
}

/// A rigid body in its own frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidBody {
    /// Name of the link that carries the body's frame (the merged links' names are not kept).
    pub name: String,
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the body frame, m.
    pub com: Vector3<f64>,
    /// Rotational inertia about the centre of mass, body axes, kg m² (symmetric).
    pub inertia: Matrix3<f64>,
}

impl RigidBody {
    /// A body of zero mass.
    pub fn massless(name: impl Into<String>) -> Self {
        RigidBody {
            name: name.into(),
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
        }
    }
}

/// A serial chain from a base link to a tool frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    /// Name of the model (URDF `<robot name>`).
    pub name: String,
    /// The base link's name.
    pub base_link: String,
    /// The tool link's name.
    pub tool_link: String,
    /// Movable joints in chain order, base to tool (`n`).
    pub joints: Vec<ChainJoint>,
    /// Body `k` moved by joint `k`, in its frame `L_k` (`n`).
    pub bodies: Vec<RigidBody>,
    /// `X_LT`: the tool frame in the last body's frame.
    pub tool: Isometry3<f64>,
}

/// A chain placed in the world: base pose `X_WB`.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialArm {
    /// The chain.
    pub chain: Chain,
    /// `X_WB`: the base frame in the world.
    pub base: Isometry3<f64>,
}

impl Chain {
    /// Number of movable joints `n`.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Check the chain: at least one joint, as many bodies as joints, finite placements, unit
    /// axes, `lower ≤ upper`, non-negative damping, every moving body with mass > 0 and a
    /// symmetric positive-definite inertia. Returns the warnings (an inertia that breaks the
    /// triangle inequality, which no rigid body has but published models do), each naming the
    /// link. Errors name the link or the joint.
    pub fn validate(&self) -> Result<Vec<String>, ModelError> {
        if self.joints.is_empty() {
            return Err(ModelError::geometry(
                format!("chain {} → {}", self.base_link, self.tool_link),
                "has no movable joint",
            ));
        }
        if self.joints.len() != self.bodies.len() {
            return Err(ModelError::geometry(
                format!("chain {} → {}", self.base_link, self.tool_link),
                format!(
                    "has {} joints but {} bodies",
                    self.joints.len(),
                    self.bodies.len()
                ),
            ));
        }
        let finite_iso = |x: &Isometry3<f64>| {
            x.translation.vector.iter().all(|v| v.is_finite())
                && x.rotation.coords.iter().all(|v| v.is_finite())
        };
        for j in &self.joints {
            let at = format!("joint {}", j.name);
            if !finite_iso(&j.placement) {
                return Err(ModelError::geometry(at, "has a non-finite origin"));
            }
            let a = j.axis.into_inner();
            if !a.iter().all(|v| v.is_finite()) || (a.norm() - 1.0).abs() > 1e-9 {
                return Err(ModelError::geometry(
                    at,
                    "axis must be a finite unit vector",
                ));
            }
            let l = &j.limits;
            if l.lower.is_nan() || l.upper.is_nan() || l.lower > l.upper {
                return Err(ModelError::geometry(
                    at,
                    format!(
                        "limit lower = {} must not exceed upper = {}",
                        l.lower, l.upper
                    ),
                ));
            }
            if !(l.velocity > 0.0) || !(l.effort > 0.0) {
                return Err(ModelError::geometry(
                    at,
                    format!(
                        "limit velocity = {} and effort = {} must be > 0",
                        l.velocity, l.effort
                    ),
                ));
            }
            if !(j.damping.is_finite() && j.damping >= 0.0) {
                return Err(ModelError::invalid(
                    format!("joint {}: damping", j.name),
                    j.damping,
                    "must be finite and >= 0",
                ));
            }
        }
        if !finite_iso(&self.tool) {
            return Err(ModelError::geometry(
                format!("link {}", self.tool_link),
                "tool frame has a non-finite pose",
            ));
        }
        let mut warnings = Vec::new();
        for b in &self.bodies {
            let at = format!("link {}", b.name);
            if !(b.mass.is_finite() && b.mass > 0.0) {
                return Err(ModelError::invalid(
                    format!("{at}: mass"),
                    b.mass,
                    "a moving link must have a finite mass > 0",
                ));
            }
            if !b.com.iter().all(|v| v.is_finite()) || !b.inertia.iter().all(|v| v.is_finite()) {
                return Err(ModelError::geometry(
                    at,
                    "has a non-finite inertial origin or inertia",
                ));
            }
            let i = &b.inertia;
            if (i - i.transpose()).abs().max() > 1e-12 * i.abs().max().max(1e-300) {
                return Err(ModelError::geometry(at, "inertia is not symmetric"));
            }
            let ev = i.symmetric_eigenvalues();
            let (lo, hi) = (ev.min(), ev.max());
            if !(lo > 1e-12 * hi.max(f64::MIN_POSITIVE)) {
                return Err(ModelError::geometry(
                    at,
                    format!(
                        "inertia is not positive definite (principal moments {:.3e}, {:.3e}, {:.3e} kg m²)",
                        ev[0], ev[1], ev[2]
                    ),
                ));
            }
            let s = ev.sum();
            if (0..3).any(|k| 2.0 * ev[k] > s * (1.0 + 1e-9)) {
                warnings.push(format!(
                    "link {}: inertia breaks the triangle inequality (principal moments {:.4e}, {:.4e}, {:.4e} kg m²): no rigid body has it; kept as given",
                    b.name, ev[0], ev[1], ev[2]
                ));
            }
        }
        Ok(warnings)
    }
}
