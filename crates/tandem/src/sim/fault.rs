//! Why a run stopped early (SPEC §3 step 4 health checks): what, when, the last good state.

use serde::Serialize;

/// What went wrong numerically.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FaultKind {
    /// The plant state became non-finite.
    NonFinite,
    /// The grasp constraints drifted beyond `max_drift`.
    ConstraintDrift {
        /// Position drift, m.
        drift: f64,
        /// Rotation drift of the spatial welds, rad (absent for the planar point grasps).
        #[serde(skip_serializing_if = "Option::is_none")]
        rotation: Option<f64>,
    },
    /// An arm came within `min_sigma` of a singular configuration.
    Singular {
        /// Smallest singular value, m/rad.
        sigma: f64,
    },
    /// The reduced formulation could not be evaluated (IK out of reach or singular arm).
    Reduced,
    /// A signal of the tick (grasp force, sensor reading, controller internal or output) became
    /// non-finite; it is named as its log column (`F_meas1.x`, `x_r.y`, `tau_q2`, ...).
    NonFiniteSignal {
        /// The signal.
        signal: String,
    },
    /// The driver could not produce the tick's torques: a user's law
    /// ([`External`](crate::sim::External)) returned an error ([`Drive::failure`](crate::drive::Drive::failure)).
    Driver {
        /// What the driver said.
        message: String,
    },
}

/// Why a run stopped early: what, when, and the last good state (never a NaN one).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fault {
    /// Time of detection, s.
    pub t: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: FaultKind,
    /// Object pose of the last good state: planar `(x, y, θ)` (m, m, rad); spatial
    /// `(p_WO, q_WO = (w, x, y, z))` (m, 1).
    pub x_o: Vec<f64>,
    /// Joint angles of the last good state, rad.
    pub q: Vec<f64>,
}

/// A number for a message in its shortest form, with an exponent outside [1e-4, 1e6)
/// (`0.001`, `1e-300`), never hundreds of digits.
pub(super) fn short(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 || (1e-4..1e6).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A number for a message: fixed point for ordinary magnitudes, an exponent otherwise (a
/// diverged state prints as `1.7e96`, never as a 97-digit number).
fn readable(v: f64, decimals: usize) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 || (1e-3..1e6).contains(&a) {
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = self.t;
        match &self.kind {
            FaultKind::NonFinite => write!(f, "the plant state became non-finite at t = {t:.4} s")?,
            FaultKind::ConstraintDrift {
                drift,
                rotation: None,
            } => write!(f, "grasp constraint drift {drift:.3e} m at t = {t:.4} s")?,
            FaultKind::ConstraintDrift {
                drift,
                rotation: Some(r),
            } => write!(
                f,
                "grasp constraint drift {drift:.3e} m, {r:.3e} rad at t = {t:.4} s"
            )?,
            FaultKind::Singular { sigma } => write!(
                f,
                "an arm reached a singular configuration (σ_min = {sigma:.3e} m/rad) at t = {t:.4} s"
            )?,
            FaultKind::Reduced => write!(
                f,
                "the reduced formulation failed (grasp out of reach or singular arm) at t = {t:.4} s"
            )?,
            FaultKind::NonFiniteSignal { signal } => {
                write!(f, "{signal} became non-finite at t = {t:.4} s")?
            }
            FaultKind::Driver { message } => {
                write!(f, "the law failed at t = {t:.4} s: {message}")?
            }
        }
        let q: Vec<String> = self.q.iter().map(|v| readable(*v, 4)).collect();
        let x: Vec<String> = self.x_o.iter().map(|v| readable(*v, 5)).collect();
        write!(
            f,
            "; last good state x_o = ({}), q = [{}]",
            x.join(", "),
            q.join(", ")
        )
    }
}
