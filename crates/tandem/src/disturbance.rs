//! The environment disturbance `F_d` on the object, paper (10): `M_o ẍ_o + C_o ẋ_o + G_o = F_o − F_d`.
//!
//! `F_d(t) = a ∘ sin(ω t + φ) − Σ push_k(t)`: sinusoids per axis (the paper's
//! `F_d = (0.02 sin t, 0.02 cos t, 0)`) plus timed pushes. A push is given as the force *on* the
//! object (what a person pushing feels), so it enters `F_d` with a minus sign.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, non_negative};

/// A constant force/torque applied to the object during `[t0, t0 + duration)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Push {
    /// Start, s.
    pub t0: f64,
    /// Duration, s (> 0).
    pub duration: f64,
    /// Wrench on the object, (N, N, N m).
    pub wrench: [f64; 3],
}

/// Disturbance parameters (plain data).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disturbance {
    /// Sinusoid amplitudes `a`, (N, N, N m).
    pub amplitude: [f64; 3],
    /// Angular frequencies `ω`, rad/s.
    pub frequency: [f64; 3],
    /// Phases `φ`, rad.
    pub phase: [f64; 3],
    /// Timed pushes.
    #[serde(default)]
    pub pushes: Vec<Push>,
}

impl Disturbance {
    /// The paper's `F_d = (0.02 sin t, 0.02 cos t, 0)`.
    pub fn paper() -> Self {
        Disturbance {
            amplitude: [0.02, 0.02, 0.0],
            frequency: [1.0; 3],
            phase: [0.0, std::f64::consts::FRAC_PI_2, 0.0],
            pushes: vec![],
        }
    }
    /// No disturbance.
    pub fn none() -> Self {
        Disturbance {
            amplitude: [0.0; 3],
            frequency: [0.0; 3],
            phase: [0.0; 3],
            pushes: vec![],
        }
    }
    /// Validate (finite values, non-negative amplitudes, positive push durations).
    pub fn validate(&self) -> Result<(), ModelError> {
        for j in 0..3 {
            non_negative(&format!("disturbance.amplitude[{j}]"), self.amplitude[j])?;
            for (n, v) in [("frequency", self.frequency[j]), ("phase", self.phase[j])] {
                if !v.is_finite() {
                    return Err(ModelError::invalid(
                        format!("disturbance.{n}[{j}]"),
                        v,
                        "must be finite",
                    ));
                }
            }
        }
        for (k, p) in self.pushes.iter().enumerate() {
            if !p.t0.is_finite() || p.t0 < 0.0 {
                return Err(ModelError::invalid(
                    format!("disturbance.pushes[{k}].t0"),
                    p.t0,
                    "must be finite and >= 0",
                ));
            }
            if !(p.duration > 0.0) || !p.duration.is_finite() {
                return Err(ModelError::invalid(
                    format!("disturbance.pushes[{k}].duration"),
                    p.duration,
                    "must be finite and > 0",
                ));
            }
            for j in 0..3 {
                if !p.wrench[j].is_finite() {
                    return Err(ModelError::invalid(
                        format!("disturbance.pushes[{k}].wrench[{j}]"),
                        p.wrench[j],
                        "must be finite",
                    ));
                }
            }
        }
        Ok(())
    }
    /// `F_d(t)`.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        let mut f = Vector3::zeros();
        for j in 0..3 {
            if self.amplitude[j] != 0.0 {
                f[j] = self.amplitude[j] * (self.frequency[j] * t + self.phase[j]).sin();
            }
        }
        for p in &self.pushes {
            if t >= p.t0 && t < p.t0 + p.duration {
                f -= Vector3::from(p.wrench);
            }
        }
        f
    }
    /// Bound of `|F_d,j|` over all time (enters the NN law's `f^U`).
    pub fn bound(&self) -> [f64; 3] {
        let mut b = self.amplitude;
        for j in 0..3 {
            b[j] += self
                .pushes
                .iter()
                .map(|p| p.wrench[j].abs())
                .fold(0.0, f64::max);
        }
        b
    }
}
