//! The environment disturbance `F_d` on the object, paper (10): `M_o ẍ_o + C_o ẋ_o + G_o = F_o − F_d`.
//!
//! `F_d(t) = a ∘ sin(ω t + φ) − Σ push_k(t)`: sinusoids per axis (the paper's
//! `F_d = (0.02 sin t, 0.02 cos t, 0)`) plus timed pushes. A push is given as the force *on* the
//! object (what a person pushing feels), so it enters `F_d` with a minus sign.
//!
//! One model for both plants: `N = 3` channels `(f_x, f_y, τ)` in the plane, `N = 6`
//! channels `[f; τ]` (world axes, about the object's centre of mass) in space
//! ([`SpatialDisturbance`], SPEC-spatial S3).

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, non_negative};

/// A constant force/torque applied to the object during `[t0, t0 + duration)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, bound = "")]
pub struct Push<const N: usize = 3> {
    /// Start, s.
    pub t0: f64,
    /// Duration, s (> 0).
    pub duration: f64,
    /// Wrench on the object, (N, N, N m) in the plane; `[f; τ]` (N, N m) in space.
    #[serde(with = "exact_array")]
    pub wrench: [f64; N],
}

/// Serde for `[f64; N]` of any `N` (serde's own impls stop at fixed sizes): a sequence of
/// exactly `N` numbers, anything else an "invalid length" error as serde's arrays give.
mod exact_array {
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer, const N: usize>(v: &[f64; N], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(v.iter())
    }

    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<[f64; N], D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = [f64; N];
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "an array of length {N}")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[f64; N], A::Error> {
                let mut out = [0.0; N];
                for (k, v) in out.iter_mut().enumerate() {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| Error::invalid_length(k, &self))?;
                }
                let mut extra = 0;
                while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                    extra += 1;
                }
                if extra > 0 {
                    return Err(Error::invalid_length(N + extra, &self));
                }
                Ok(out)
            }
        }
        d.deserialize_seq(V::<N>)
    }
}

/// Disturbance parameters (plain data).
#[derive(Clone, Debug, PartialEq)]
pub struct Disturbance<const N: usize = 3> {
    /// Sinusoid amplitudes `a`, (N, N, N m).
    pub amplitude: [f64; N],
    /// Angular frequencies `ω`, rad/s.
    pub frequency: [f64; N],
    /// Phases `φ`, rad.
    pub phase: [f64; N],
    /// Timed pushes.
    pub pushes: Vec<Push<N>>,
}

/// The 6-D disturbance of the spatial plant: `[f; τ]` in world axes about the object's centre.
pub type SpatialDisturbance = Disturbance<6>;

impl SpatialDisturbance {
    /// The SPEC-spatial S6 scenario's "small environment disturbance": `0.2 sin t`,
    /// `0.2 cos t` N along world x and y, `0.02 sin 2t` N m about world z (the planar paper's
    /// pattern, ten times larger for a three times heavier object on stiffer arms).
    pub fn spec_s6() -> Self {
        Disturbance {
            amplitude: [0.2, 0.2, 0.0, 0.0, 0.0, 0.02],
            frequency: [1.0, 1.0, 0.0, 0.0, 0.0, 2.0],
            phase: [0.0, std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0],
            pushes: vec![],
        }
    }
}

impl<const N: usize> Disturbance<N> {
    /// No disturbance.
    pub fn zero() -> Self {
        Disturbance {
            amplitude: [0.0; N],
            frequency: [0.0; N],
            phase: [0.0; N],
            pushes: vec![],
        }
    }
}

impl Disturbance<3> {
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
        Self::zero()
    }
}

impl<const N: usize> Disturbance<N> {
    /// Validate (finite values, non-negative amplitudes, positive push durations).
    pub fn validate(&self) -> Result<(), ModelError> {
        for j in 0..N {
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
            for j in 0..N {
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
    pub fn at(&self, t: f64) -> SVector<f64, N> {
        let mut f = SVector::<f64, N>::zeros();
        let arg = |j: usize| self.frequency[j] * t + self.phase[j];
        // Channels two at a time (`trig::sin_cos2`, the same bits as one at a time).
        let mut j = 0;
        while j < N {
            if j + 1 < N && self.amplitude[j] != 0.0 && self.amplitude[j + 1] != 0.0 {
                let [(s0, _), (s1, _)] = crate::math::trig::sin_cos2(arg(j), arg(j + 1));
                f[j] = self.amplitude[j] * s0;
                f[j + 1] = self.amplitude[j + 1] * s1;
                j += 2;
            } else {
                if self.amplitude[j] != 0.0 {
                    f[j] = self.amplitude[j] * crate::math::trig::sin_cos(arg(j)).0;
                }
                j += 1;
            }
        }
        for p in &self.pushes {
            if t >= p.t0 && t < p.t0 + p.duration {
                f -= SVector::<f64, N>::from(p.wrench);
            }
        }
        f
    }
    /// Bound of `|F_d,j|` over all time (enters the NN law's `f^U`).
    pub fn bound(&self) -> [f64; N] {
        let mut b = self.amplitude;
        for j in 0..N {
            b[j] += self
                .pushes
                .iter()
                .map(|p| p.wrench[j].abs())
                .fold(0.0, f64::max);
        }
        b
    }
}
