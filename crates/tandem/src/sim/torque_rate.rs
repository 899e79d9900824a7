//! Torque rate and chattering of the applied joint torques, measured every control tick
//! (issue 24, "Measure it").
//!
//! The log is sampled at `log_period` (often 10 ms), so a metric computed from it cannot see a
//! torque that alternates from one 1 ms tick to the next; the loop feeds this monitor the torque
//! the plant receives on **every** tick instead (after the driver and any injected actuator
//! fault, [`crate::sim::faults`]). Per joint `j` and tick `k` (control period `h`, tick time
//! `t_k`), with the step `Δτ_{j,k} = τ_{j,k} − τ_{j,k−1}`:
//!
//! * **peak torque rate** `max_k |Δτ_{j,k}| / h` (N m/s) and the tick time `t_k` at which the new
//!   torque was applied (the first such tick on a tie);
//! * **chattering count**: ticks `k` with `t_k ≥ ignore_before` on which the step flips sign
//!   relative to the previous one, both larger than the threshold:
//!   `Δτ_{j,k} Δτ_{j,k−1} < 0`, `|Δτ_{j,k}| > threshold` and `|Δτ_{j,k−1}| > threshold`
//!   (defaults 0.5 N m and 10 ms, the issue's "no tick-to-tick sign flip above 0.5 N m after the
//!   first 10 ms"); and across joints, the ticks on which at least one joint chattered.
//!
//! **The first tick.** Before tick 0 the loop holds zero torque (the object hanging in the
//! arms' grasp); a real drive starts from the torque it is holding (brakes released with its
//! gravity compensation on). So the first observed torque is the baseline, not a step from zero:
//! rates start at the second tick, chattering at the third (it needs two steps).
//!
//! The monitor is preallocated for `n` joints; [`TorqueRateMonitor::observe`] allocates nothing
//! and does `O(n)` work; [`TorqueRateMonitor::result`] copies the per-joint results out.

use serde::Serialize;

use crate::error::{ModelError, non_negative, positive};

/// Settings of the chattering count (plain data).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueRateParams {
    /// A step counts towards chattering only if it and the previous step are both larger than
    /// this, N m (strictly).
    pub threshold: f64,
    /// Ticks before this time are not counted as chattering (their rates still count), s.
    pub ignore_before: f64,
}

impl Default for TorqueRateParams {
    /// The criterion: 0.5 N m, after the first 10 ms.
    fn default() -> Self {
        TorqueRateParams {
            threshold: 0.5,
            ignore_before: 0.01,
        }
    }
}

impl TorqueRateParams {
    /// Both finite and `>= 0`; errors name `torque_rate.threshold` / `torque_rate.ignore_before`.
    pub fn validate(&self) -> Result<(), ModelError> {
        non_negative("torque_rate.threshold", self.threshold)?;
        non_negative("torque_rate.ignore_before", self.ignore_before)?;
        Ok(())
    }
}

/// Torque rate and chattering of one joint.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct JointTorqueRate {
    /// Peak `|Δτ|/h`, N m/s (0 with fewer than two ticks).
    pub peak_rate: f64,
    /// Tick time of the peak, s (`None` with fewer than two ticks).
    pub peak_t: Option<f64>,
    /// Chattering ticks (see the module doc).
    pub chatter: u64,
    /// Tick time of the first chattering tick, s.
    pub first_chatter: Option<f64>,
    /// Tick time of the last chattering tick, s.
    pub last_chatter: Option<f64>,
}

/// Torque rate and chattering of a run's applied joint torques, per joint (the result shared by
/// the planar and spatial reports).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TorqueRate {
    /// The threshold the count used, N m.
    pub threshold: f64,
    /// The ignore-window the count used, s.
    pub ignore_before: f64,
    /// Control period, s.
    pub control_period: f64,
    /// Ticks observed.
    pub ticks: u64,
    /// Per joint (all arms, in the `tau_q*` column order).
    pub joints: Vec<JointTorqueRate>,
    /// Ticks on which at least one joint chattered.
    pub chatter_ticks: u64,
}

impl TorqueRate {
    /// The largest peak rate over joints: `(joint index from 0, rate N m/s, tick time s)`;
    /// `None` with fewer than two ticks or no joints (the first joint on a tie).
    pub fn peak(&self) -> Option<(usize, f64, f64)> {
        let mut best: Option<(usize, f64, f64)> = None;
        for (j, r) in self.joints.iter().enumerate() {
            if let Some(t) = r.peak_t
                && best.is_none_or(|b| r.peak_rate > b.1)
            {
                best = Some((j, r.peak_rate, t));
            }
        }
        best
    }
    /// Chattering ticks summed over joints.
    pub fn chatter_total(&self) -> u64 {
        self.joints.iter().map(|j| j.chatter).sum()
    }
}

/// The per-tick monitor: feed it the applied torque of every control tick, in order.
#[derive(Clone, Debug)]
pub struct TorqueRateMonitor {
    params: TorqueRateParams,
    /// Control period `h`, s.
    h: f64,
    /// `τ_{k−1}`, N m.
    prev: Vec<f64>,
    /// `Δτ_{k−1}`, N m (0 before the second tick).
    prev_step: Vec<f64>,
    out: TorqueRate,
}

impl TorqueRateMonitor {
    /// A monitor for `n` joints at control period `h` (s); errors name the field.
    pub fn new(n: usize, h: f64, params: TorqueRateParams) -> Result<Self, ModelError> {
        positive("control_period", h)?;
        params.validate()?;
        Ok(TorqueRateMonitor {
            params,
            h,
            prev: vec![0.0; n],
            prev_step: vec![0.0; n],
            out: TorqueRate {
                threshold: params.threshold,
                ignore_before: params.ignore_before,
                control_period: h,
                ticks: 0,
                joints: vec![JointTorqueRate::default(); n],
                chatter_ticks: 0,
            },
        })
    }

    /// The settings.
    pub fn params(&self) -> TorqueRateParams {
        self.params
    }

    /// Forget every observation (same joints, period and settings). No allocation.
    pub fn reset(&mut self) {
        self.prev.fill(0.0);
        self.prev_step.fill(0.0);
        self.out.ticks = 0;
        self.out.chatter_ticks = 0;
        self.out.joints.fill(JointTorqueRate::default());
    }

    /// One tick: the torque `tau` (N m, one per joint) applied from tick time `t` (s). No
    /// allocation. A non-finite torque is not a rate (the loop stops on it before it is
    /// observed); it compares false everywhere and leaves the peaks alone.
    pub fn observe(&mut self, t: f64, tau: &[f64]) {
        assert_eq!(tau.len(), self.prev.len(), "one torque per joint");
        let k = self.out.ticks;
        self.out.ticks += 1;
        if k == 0 {
            self.prev.copy_from_slice(tau);
            return;
        }
        let thr = self.params.threshold;
        let counting = k >= 2 && t >= self.params.ignore_before;
        let mut any = false;
        for (((j, &x), p), ps) in self
            .out
            .joints
            .iter_mut()
            .zip(tau)
            .zip(&mut self.prev)
            .zip(&mut self.prev_step)
        {
            let d = x - *p;
            let rate = d.abs() / self.h;
            if rate > j.peak_rate || j.peak_t.is_none() {
                j.peak_rate = j.peak_rate.max(rate);
                j.peak_t = Some(t);
            }
            if counting && d * *ps < 0.0 && d.abs() > thr && ps.abs() > thr {
                j.chatter += 1;
                j.first_chatter.get_or_insert(t);
                j.last_chatter = Some(t);
                any = true;
            }
            *p = x;
            *ps = d;
        }
        if any {
            self.out.chatter_ticks += 1;
        }
    }

    /// What has been observed so far (allocates the per-joint copy).
    pub fn result(&self) -> TorqueRate {
        self.out.clone()
    }

    /// The result, moved out without a copy (the loop's end allocates nothing); the monitor is
    /// left with an empty result.
    pub fn take(&mut self) -> TorqueRate {
        std::mem::take(&mut self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_settings_name_the_field() {
        let e = TorqueRateMonitor::new(
            2,
            1e-3,
            TorqueRateParams {
                threshold: f64::NAN,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(e.to_string().starts_with("torque_rate.threshold"), "{e}");
        let e = TorqueRateMonitor::new(
            2,
            1e-3,
            TorqueRateParams {
                ignore_before: -1.0,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(
            e.to_string().starts_with("torque_rate.ignore_before"),
            "{e}"
        );
        assert!(TorqueRateMonitor::new(2, 0.0, TorqueRateParams::default()).is_err());
    }

    #[test]
    fn one_tick_is_no_rate_and_reset_forgets() {
        let mut m = TorqueRateMonitor::new(1, 1e-3, TorqueRateParams::default()).unwrap();
        m.observe(0.0, &[100.0]);
        let r = m.result();
        assert_eq!((r.ticks, r.joints[0].peak_t, r.peak()), (1, None, None));
        m.observe(1e-3, &[101.0]);
        assert_eq!(m.result().peak().unwrap().0, 0);
        m.reset();
        assert_eq!(m.result().ticks, 0);
        assert_eq!(m.result().joints[0], JointTorqueRate::default());
    }
}
