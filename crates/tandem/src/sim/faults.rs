//! Fault injection between the plant and the driver (sensors → driver → actuators), for
//! robustness studies. Off by default ([`Faults::default`] changes nothing).
//!
//! Per control tick, on what the driver sees and what the plant receives:
//! - **sensor dropout bursts:** bursts start at random ticks (rate `dropout_rate` per second,
//!   seeded by `seed`) and last `dropout_length` s; during a burst every reading (encoders,
//!   rates, forces) holds its last value;
//! - **force-sensor saturation** at `±force_limit` N per force component (the torque channels
//!   of a spatial wrist sensor are not saturated) and **delay** of `force_delay` s (a whole
//!   number of control periods) of every wrench channel;
//! - **encoder quantisation:** joint angles rounded to multiples of `encoder_resolution` rad;
//! - **actuator limits:** torques saturated at `±torque_limit` N m and rate-limited to
//!   `torque_rate` N m/s (the driver does not know).
//!
//! The payload mismatch (true object differs from the controller's nominal one) is a plant
//! parameter, not an injection: give the simulation and the controller different objects.

use crate::error::{ModelError, non_negative, positive};
use crate::math::random::splitmix64;

/// Longest force delay, s (the delay line is preallocated).
pub const MAX_FORCE_DELAY: f64 = 1.0;

/// The injected faults (plain data; all off by default).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Faults {
    /// Mean number of dropout bursts per second (0: none).
    pub dropout_rate: f64,
    /// Length of one burst, s.
    pub dropout_length: f64,
    /// Force-sensor saturation per component, N.
    pub force_limit: Option<f64>,
    /// Force-sensor delay, s (a whole number of control periods, at most 1 s).
    pub force_delay: f64,
    /// Encoder quantisation step, rad (0: none).
    pub encoder_resolution: f64,
    /// Actuator torque saturation, N m.
    pub torque_limit: Option<f64>,
    /// Actuator torque rate limit, N m/s.
    pub torque_rate: Option<f64>,
    /// Seed of the dropout bursts.
    pub seed: u64,
}

/// The preallocated state of the injection.
#[derive(Clone, Debug)]
pub(crate) struct FaultState {
    f: Faults,
    /// Burst probability per tick and burst length in ticks.
    p_start: f64,
    burst_ticks: usize,
    /// Ticks left in the current burst.
    left: usize,
    /// Delay in ticks and the ring of past wrench readings (`delay + 1` rows of `W n_arms`).
    delay: usize,
    ring: Vec<f64>,
    /// Channels per wrench `W` (2 planar, 6 spatial).
    width: usize,
    /// What the driver sees.
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    /// Wrench readings, flat (`W` per arm).
    pub wrenches: Vec<f64>,
    /// The previous applied torques (rate limit).
    tau_prev: Vec<f64>,
    started: bool,
}

impl Faults {
    /// Whether anything is injected.
    pub fn any(&self) -> bool {
        *self
            != Faults {
                seed: self.seed,
                ..Faults::default()
            }
    }

    /// Validate against the control period `h` and size the buffers for `n_q` joints and
    /// `n_arms` wrist sensors of `width` channels. Errors name the field (`faults.force_delay`,
    /// ...).
    pub(crate) fn state(
        &self,
        h: f64,
        n_q: usize,
        n_arms: usize,
        width: usize,
    ) -> Result<FaultState, ModelError> {
        non_negative("faults.dropout_rate", self.dropout_rate)?;
        non_negative("faults.dropout_length", self.dropout_length)?;
        if let Some(l) = self.force_limit {
            positive("faults.force_limit", l)?;
        }
        non_negative("faults.force_delay", self.force_delay)?;
        if self.force_delay > MAX_FORCE_DELAY {
            return Err(ModelError::invalid(
                "faults.force_delay",
                self.force_delay,
                "must be at most 1 s",
            ));
        }
        let delay = (self.force_delay / h).round();
        if (self.force_delay - delay * h).abs() > 1e-9 * h.max(self.force_delay) {
            return Err(ModelError::invalid(
                "faults.force_delay",
                self.force_delay,
                format!("must be a whole multiple of the control period ({h} s)"),
            ));
        }
        non_negative("faults.encoder_resolution", self.encoder_resolution)?;
        if let Some(l) = self.torque_limit {
            positive("faults.torque_limit", l)?;
        }
        if let Some(r) = self.torque_rate {
            positive("faults.torque_rate", r)?;
        }
        let p_start = self.dropout_rate * h;
        if p_start >= 1.0 {
            return Err(ModelError::invalid(
                "faults.dropout_rate",
                self.dropout_rate,
                format!(
                    "must be below one burst per control period ({} /s)",
                    1.0 / h
                ),
            ));
        }
        let burst = self.dropout_length / h;
        if burst > 1e9 {
            return Err(ModelError::invalid(
                "faults.dropout_length",
                self.dropout_length,
                "is longer than 1e9 control periods",
            ));
        }
        let delay = delay as usize;
        Ok(FaultState {
            f: self.clone(),
            p_start,
            burst_ticks: burst.round() as usize,
            left: 0,
            delay,
            ring: vec![0.0; (delay + 1) * n_arms * width],
            width,
            q: vec![0.0; n_q],
            qd: vec![0.0; n_q],
            wrenches: vec![0.0; n_arms * width],
            tau_prev: vec![0.0; n_q],
            started: false,
        })
    }
}

impl FaultState {
    /// Sensors → what the driver sees at tick `k`: `(q, q̇, wrenches)` readings in (flat, `W`
    /// per arm), the faulted ones into `self.q`, `self.qd`, `self.wrenches`. No allocation.
    pub(crate) fn sense(&mut self, k: usize, q: &[f64], qd: &[f64], wrenches: &[f64]) {
        let n = wrenches.len();
        let w = self.width;
        // The delay line: slot k mod (delay + 1) holds the reading of tick k.
        let slots = self.delay + 1;
        for (c, v) in wrenches.iter().enumerate() {
            let mut v = *v;
            // Planar: both channels are forces; spatial: the first three of each six.
            match self.f.force_limit {
                Some(l) if w == 2 || c % 6 < 3 => v = v.clamp(-l, l),
                _ => {}
            }
            self.ring[(k % slots) * n + c] = v;
        }
        let old = k.saturating_sub(self.delay);
        // Dropout bursts: a seeded uniform per tick decides whether one starts.
        if self.left == 0 && self.p_start > 0.0 {
            let u =
                (splitmix64(self.f.seed ^ splitmix64(k as u64)) >> 11) as f64 / (1u64 << 53) as f64;
            if u < self.p_start {
                self.left = self.burst_ticks;
            }
        }
        if self.left > 0 && self.started {
            self.left -= 1;
            return; // hold every reading
        }
        self.started = true;
        self.wrenches
            .copy_from_slice(&self.ring[(old % slots) * n..(old % slots + 1) * n]);
        let r = self.f.encoder_resolution;
        for (m, v) in self.q.iter_mut().zip(q) {
            *m = if r > 0.0 { (v / r).round() * r } else { *v };
        }
        self.qd.copy_from_slice(qd);
    }

    /// The driver's torques → what the actuators apply (saturation, then the rate limit over one
    /// control period `h`). No allocation.
    pub(crate) fn actuate(&mut self, h: f64, tau: &mut [f64]) {
        for (k, t) in tau.iter_mut().enumerate() {
            if let Some(l) = self.f.torque_limit {
                *t = t.clamp(-l, l);
            }
            if let Some(r) = self.f.torque_rate {
                let p = self.tau_prev[k];
                *t = t.clamp(p - r * h, p + r * h);
            }
            self.tau_prev[k] = *t;
        }
    }
}
