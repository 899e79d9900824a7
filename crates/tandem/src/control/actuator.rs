//! The actuator stage (issue 24): what a real drive does to the torque a law commands, after the
//! law and before the plant, the same for planar and spatial arms and for every law.
//!
//! Per control tick `k` (period `h`) and joint `j`, from the commanded torque `u_k`:
//!
//! 1. **output filter** (optional, time constant `T ≥ h`): the first-order low-pass
//!    `T ẏ = u − y` discretised exactly for an input held over the tick (zero-order hold),
//!    ```text
//!    y_k = y_{k−1} + α (u_k − y_{k−1}),   α = 1 − e^{−h/T};
//!    ```
//!    its step response from rest is `y_k = 1 − e^{−(k+1) h/T}` (the value the continuous filter
//!    reaches at the end of the tick, so the output of tick `k` already answers `u_k`; no extra
//!    tick of delay);
//! 2. **rate limit** `r` (N m/s): `v_k = clamp(y_k, τ_{k−1} − r h, τ_{k−1} + r h)`, measured from
//!    the torque applied on the previous tick `τ_{k−1}`;
//! 3. **effort limit** `E_j` (N m): `τ_k = clamp(v_k, −E_j, E_j)`.
//!
//! Clamping to the effort after the rate limit keeps both: `τ_{k−1}` lies in `[−E_j, E_j]`, so
//! the clamp moves `v_k` towards `τ_{k−1}`, never away from it; `|τ_k − τ_{k−1}| ≤ r h` and
//! `|τ_k| ≤ E_j` hold together on every tick.
//!
//! **The first tick.** A real drive starts from the torque it is holding (brakes released with
//! its gravity compensation on), and the loop holds zero torque before tick 0 only because
//! the simulation has to start somewhere; so by default the stage starts from the first
//! command: on the first [`Actuator::apply`] after construction or [`Actuator::reset`] the
//! filter state is set to the command (the filter passes it through) and the rate limit has
//! nothing to measure from; only the effort clamp acts. [`Actuator::start`] starts it from a known
//! torque instead (zero: the first ticks then ramp up at the rate limit through the filter).
//! The torque-rate monitor ([`crate::sim::torque_rate`]) measures rates from the first tick
//! on in the same way.
//!
//! **Counts.** Each limit counts the ticks on which it changed the torque of at least one joint
//! (the value it received lay strictly outside its window), and per joint the ticks on which it
//! changed that joint's torque. The filter acts on every tick and is not counted. The
//! controllers report the per-joint counts through
//! [`Drive::joint_limit_counts`](crate::drive::Drive::joint_limit_counts), and a run's
//! [`Outcome::joint_limits`](crate::sim::Outcome::joint_limits) carries them (`summary.json`'s
//! `joint_limits`).
//!
//! The law should adapt on what was applied, not on what it asked for (the NN update must not
//! wind up against a saturated actuator): the applied torque is the `applied` output, the
//! saturation deficit `applied − commanded`.
//!
//! **In the controllers.** Both cooperative controllers
//! ([`Controller`](crate::control::planar::Controller),
//! [`SpatialController`](crate::control::spatial::SpatialController)) build one stage from
//! their `actuator` parameters and pass every law's joint torques through it (`actuate`);
//! without `effort` the stage's effort limits are the controller's `torque_limit` (spatial: or
//! each joint's URDF `effort`), which reproduces the symmetric clamp the controllers had before
//! bit for bit. The ticks each limit acted on go into the controller's
//! [`ControlEvents`](crate::drive::ControlEvents) (`torque_clips`, `rate_limited`,
//! `filtered`). The NN law's update is trained against the deficit
//! ([`crate::control::law::adaptive::AdaptiveNn::anti_windup`]: `Ŵ̇_j = −Θ_j (Q S (z_2j − ξ_j)
//! + σ_j Ŵ_j)`, `M_j ξ̇_j = −K2_j ξ_j + δτ_j`), on by default when a limit of this table is set
//! ([`ActuatorParams::anti_windup`]).
//!
//! **A Franka's 1000 N m/s** (Franka Control Interface documentation, "Robot and interface
//! specifications": the torque derivative limit) is the default `rate_limit` of a scenario with
//! Franka arms ([`crate::model::spatial::urdf::FRANKA_TORQUE_RATE_LIMIT`]; the UR5 has no
//! published figure and no default). With the NN law's paper form (SPEC §3.4: `ϖ = 0.05`,
//! `d1 = 1`) the `dual-ur5` and `dual-franka` starts fault at that limit (0.84 s, 0.69 s): from
//! 16 ms `Q` drops and the robust term `(1 − Q) f^U tanh(f^U z2/ϖ)` switches faster than the
//! limit lets the torque follow. The spatial default (`smoothing = "sampled"`, `d1 = 2`,
//! `d2 = 3`; `docs/smooth-nn.md`) meets the S5 claims at 1000 N m/s with `z1` within 0.3 % of
//! the unlimited run. PD, PD + model gravity and computed torque are unchanged at that limit
//! (their peak rates, from the first tick, are 1000, 145 and 353 N m/s on UR5; 1000, 574, 621 on
//! Franka).
//!
//! The stage is preallocated for its joints; [`Actuator::apply`] allocates nothing.

use serde::{Deserialize, Serialize};

use crate::error::{ModelError, positive};

/// The actuator limits (plain data; every limit off by default: the stage then passes the
/// command through).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorParams {
    /// Per-joint effort limits `E_j` (symmetric, `|τ_j| ≤ E_j`), N m, all arms stacked in joint
    /// order; `+∞` for a joint without one (a URDF joint without `effort`); `None`: no effort
    /// limit.
    #[serde(default)]
    pub effort: Option<Vec<f64>>,
    /// Torque-rate limit `r`, every joint, N m/s (Franka: 1000 N m/s); `None`: no rate limit.
    #[serde(default)]
    pub rate_limit: Option<f64>,
    /// Time constant `T` of the first-order output filter, s (at least the control period);
    /// `None`: no filter.
    #[serde(default)]
    pub filter_time_constant: Option<f64>,
    /// Anti-windup of the NN law's update against this stage
    /// ([`crate::control::law::adaptive::AdaptiveNn::anti_windup`]). `None` (default): on
    /// exactly when a limit of this table is set (`effort`, `rate_limit` or
    /// `filter_time_constant`); the controllers' legacy effort limits (`torque_limit`, a URDF's
    /// `effort`) alone keep the update of (44) on `z2`, so runs that set none of these give the
    /// results they gave before the stage existed, bit for bit.
    #[serde(default)]
    pub anti_windup: Option<bool>,
}

impl ActuatorParams {
    /// Whether the NN update runs with anti-windup against this stage (see
    /// [`ActuatorParams::anti_windup`]).
    pub fn anti_windup_on(&self) -> bool {
        self.anti_windup.unwrap_or(
            self.effort.is_some()
                || self.rate_limit.is_some()
                || self.filter_time_constant.is_some(),
        )
    }
}

impl ActuatorParams {
    /// Validate for `n` joints at control period `h`; errors name the field
    /// (`actuator.effort[3]`, `actuator.rate_limit`, `actuator.filter_time_constant`).
    pub fn validate(&self, n: usize, h: f64) -> Result<(), ModelError> {
        positive("control_period", h)?;
        if let Some(e) = &self.effort {
            if e.len() != n {
                return Err(ModelError::geometry(
                    "actuator.effort",
                    format!("has {} limits for {n} joints", e.len()),
                ));
            }
            for (j, &v) in e.iter().enumerate() {
                // +∞ (no limit on that joint) is allowed, NaN, zero and negative are not.
                if v.is_nan() || v <= 0.0 {
                    return Err(ModelError::invalid(
                        format!("actuator.effort[{j}]"),
                        v,
                        "must be > 0 (+inf for no limit on this joint)",
                    ));
                }
            }
        }
        if let Some(r) = self.rate_limit {
            positive("actuator.rate_limit", r)?;
        }
        if let Some(tf) = self.filter_time_constant {
            positive("actuator.filter_time_constant", tf)?;
            if tf < h {
                return Err(ModelError::invalid(
                    "actuator.filter_time_constant",
                    tf,
                    format!("must be at least the control period ({h} s)"),
                ));
            }
        }
        Ok(())
    }
}

/// Ticks on which each limit acted.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ActuatorCounts {
    /// Ticks applied.
    pub ticks: u64,
    /// Ticks on which the rate limit changed at least one joint's torque.
    pub rate: u64,
    /// Ticks on which the effort limit changed at least one joint's torque.
    pub effort: u64,
    /// Per joint, ticks on which the rate limit changed its torque.
    pub rate_per_joint: Vec<u64>,
    /// Per joint, ticks on which the effort limit changed its torque.
    pub effort_per_joint: Vec<u64>,
}

/// The actuator stage: validated limits and their state (last applied torque, filter state,
/// counts), preallocated for `n` joints.
#[derive(Clone, Debug)]
pub struct Actuator {
    params: ActuatorParams,
    /// Control period `h`, s.
    h: f64,
    /// `E_j`, N m (`+∞` without an effort limit).
    effort: Vec<f64>,
    /// `r h`, N m per tick (`+∞` without a rate limit).
    step: f64,
    /// `α = 1 − e^{−h/T}` (`None` without a filter).
    alpha: Option<f64>,
    /// Filter state `y_{k−1}`, N m.
    y: Vec<f64>,
    /// Applied torque `τ_{k−1}`, N m.
    last: Vec<f64>,
    /// Whether `y` and `last` hold a previous tick (or a [`Actuator::start`]).
    started: bool,
    counts: ActuatorCounts,
}

impl Actuator {
    /// The largest command magnitude the stage takes, N m (`1e300`; larger ones, `±∞` among
    /// them, are taken as `±1e300`): the filter's `u − y` then never overflows.
    pub const COMMAND_MAX: f64 = 1e300;

    /// The stage for `n` joints at control period `h` (s); errors name the field (see
    /// [`ActuatorParams::validate`]).
    pub fn new(p: &ActuatorParams, n: usize, h: f64) -> Result<Self, ModelError> {
        p.validate(n, h)?;
        Ok(Actuator {
            params: p.clone(),
            h,
            effort: p.effort.clone().unwrap_or_else(|| vec![f64::INFINITY; n]),
            step: p.rate_limit.map_or(f64::INFINITY, |r| r * h),
            alpha: p.filter_time_constant.map(|tf| -(-h / tf).exp_m1()),
            y: vec![0.0; n],
            last: vec![0.0; n],
            started: false,
            counts: ActuatorCounts {
                rate_per_joint: vec![0; n],
                effort_per_joint: vec![0; n],
                ..ActuatorCounts::default()
            },
        })
    }

    /// The limits.
    pub fn params(&self) -> &ActuatorParams {
        &self.params
    }
    /// The control period the stage was built for, s.
    pub fn control_period(&self) -> f64 {
        self.h
    }
    /// Number of joints.
    pub fn n(&self) -> usize {
        self.last.len()
    }
    /// The torque applied on the last tick (or given to [`Actuator::start`]), N m.
    pub fn last(&self) -> &[f64] {
        &self.last
    }
    /// The effort limits `E_j` in force, N m, one per joint (`+∞` where there is none).
    pub fn effort(&self) -> &[f64] {
        &self.effort
    }
    /// The ticks on which each limit acted.
    pub fn counts(&self) -> &ActuatorCounts {
        &self.counts
    }

    /// Start from a known torque `tau0` (N m): the filter state and the last applied torque
    /// become `tau0` clamped to the effort limits and to `±`[`Actuator::COMMAND_MAX`], a NaN
    /// zero (the clamp is not counted). No allocation.
    pub fn start(&mut self, tau0: &[f64]) {
        assert_eq!(tau0.len(), self.n(), "one torque per joint");
        for (((y, l), &t), &e) in self
            .y
            .iter_mut()
            .zip(&mut self.last)
            .zip(tau0)
            .zip(&self.effort)
        {
            let t = if t.is_nan() { 0.0 } else { t };
            *l = t.clamp(-e, e).clamp(-Self::COMMAND_MAX, Self::COMMAND_MAX);
            *y = *l;
        }
        self.started = true;
    }

    /// Forget the last torque, the filter state and the counts: the next [`Actuator::apply`]
    /// starts from its command. No allocation.
    pub fn reset(&mut self) {
        self.started = false;
        self.y.fill(0.0);
        self.last.fill(0.0);
        let c = &mut self.counts;
        c.ticks = 0;
        c.rate = 0;
        c.effort = 0;
        c.rate_per_joint.fill(0);
        c.effort_per_joint.fill(0);
    }

    /// One tick: the `commanded` torques (N m, one per joint) → the `applied` ones (filter,
    /// then rate limit, then effort clamp; see the module doc). No allocation.
    ///
    /// Any command gives a finite torque within the limits, and the stage's state stays finite:
    /// a NaN command holds the last applied torque (zero on the first tick), and a command beyond
    /// `±`[`Actuator::COMMAND_MAX`] (`±∞` too) is taken as `±COMMAND_MAX` before the filter (an
    /// infinite command would otherwise leave the filter state infinite, and the next finite
    /// command would make it NaN). Neither is counted here (the controllers' `actuate` counts a
    /// non-finite command as a clipped torque).
    pub fn apply(&mut self, commanded: &[f64], applied: &mut [f64]) {
        let n = self.n();
        assert!(
            commanded.len() == n && applied.len() == n,
            "one torque per joint"
        );
        let first = !self.started;
        self.started = true;
        let (mut rate_any, mut effort_any) = (false, false);
        for j in 0..n {
            let u = commanded[j];
            let u = if u.is_nan() {
                self.last[j]
            } else {
                u.clamp(-Self::COMMAND_MAX, Self::COMMAND_MAX)
            };
            // 1. Filter (the first tick without a start passes the command through).
            let y = match self.alpha {
                Some(a) if !first => self.y[j] + a * (u - self.y[j]),
                _ => u,
            };
            self.y[j] = y;
            // 2. Rate limit from the last applied torque.
            let mut v = y;
            if !first {
                let p = self.last[j];
                let (lo, hi) = (p - self.step, p + self.step);
                if v < lo || v > hi {
                    v = v.clamp(lo, hi);
                    self.counts.rate_per_joint[j] += 1;
                    rate_any = true;
                }
            }
            // 3. Effort clamp.
            let e = self.effort[j];
            if v.abs() > e {
                v = v.clamp(-e, e);
                self.counts.effort_per_joint[j] += 1;
                effort_any = true;
            }
            self.last[j] = v;
            applied[j] = v;
        }
        self.counts.ticks += 1;
        self.counts.rate += u64::from(rate_any);
        self.counts.effort += u64::from(effort_any);
    }
}

/// The actuator stage of a tick, shared by the planar and spatial controllers: `tau` holds the
/// commanded torques on entry (`cmd` receives them, a non-finite one replaced by zero) and the
/// applied ones on exit (a non-finite one replaced by zero). Counts the ticks each limit acted
/// on into `events`; returns whether a torque was clipped (the effort limit acted, or a
/// non-finite command was replaced). No allocation.
pub(crate) fn actuate(
    act: &mut Actuator,
    tau: &mut [f64],
    cmd: &mut [f64],
    events: &mut crate::drive::ControlEvents,
) -> bool {
    let mut clipped = false;
    for (c, v) in cmd.iter_mut().zip(tau.iter()) {
        // A non-finite command counts as clipped and becomes zero (as the symmetric clamp did
        // with a NaN).
        clipped |= !v.is_finite();
        *c = if v.is_finite() { *v } else { 0.0 };
    }
    let (rate0, effort0) = (act.counts().rate, act.counts().effort);
    act.apply(cmd, tau);
    for v in tau.iter_mut() {
        if !v.is_finite() {
            *v = 0.0;
        }
    }
    let c = act.counts();
    clipped |= c.effort != effort0;
    events.rate_limited += c.rate - rate0;
    events.filtered += u64::from(act.params().filter_time_constant.is_some());
    clipped
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(p: ActuatorParams) -> String {
        Actuator::new(&p, 2, 1e-3).unwrap_err().to_string()
    }

    #[test]
    fn bad_limits_name_the_field() {
        for (p, want) in [
            (
                ActuatorParams {
                    rate_limit: Some(0.0),
                    ..Default::default()
                },
                "actuator.rate_limit",
            ),
            (
                ActuatorParams {
                    rate_limit: Some(f64::NAN),
                    ..Default::default()
                },
                "actuator.rate_limit",
            ),
            (
                ActuatorParams {
                    effort: Some(vec![10.0, -1.0]),
                    ..Default::default()
                },
                "actuator.effort[1]",
            ),
            (
                ActuatorParams {
                    effort: Some(vec![f64::NAN, 1.0]),
                    ..Default::default()
                },
                "actuator.effort[0]",
            ),
            (
                ActuatorParams {
                    effort: Some(vec![0.0, 1.0]),
                    ..Default::default()
                },
                "actuator.effort[0]",
            ),
            (
                ActuatorParams {
                    effort: Some(vec![1.0]),
                    ..Default::default()
                },
                "actuator.effort",
            ),
            (
                ActuatorParams {
                    filter_time_constant: Some(5e-4),
                    ..Default::default()
                },
                "actuator.filter_time_constant",
            ),
            (
                ActuatorParams {
                    filter_time_constant: Some(-1.0),
                    ..Default::default()
                },
                "actuator.filter_time_constant",
            ),
        ] {
            let e = err(p);
            assert!(e.starts_with(want), "{e} should name {want}");
        }
        // +∞ effort on a joint (a URDF joint without one) and T = h are allowed.
        Actuator::new(
            &ActuatorParams {
                effort: Some(vec![f64::INFINITY, 1.0]),
                filter_time_constant: Some(1e-3),
                rate_limit: Some(1000.0),
                anti_windup: None,
            },
            2,
            1e-3,
        )
        .unwrap();
    }

    #[test]
    fn actuate_zeroes_a_non_finite_command_and_counts_it_clipped() {
        let p = ActuatorParams {
            rate_limit: Some(1000.0),
            ..Default::default()
        };
        let mut a = Actuator::new(&p, 3, 1e-3).unwrap();
        let mut ev = crate::drive::ControlEvents::default();
        let mut cmd = [0.0; 3];
        let mut tau = [0.5, 0.2, -0.3];
        assert!(!actuate(&mut a, &mut tau, &mut cmd, &mut ev));
        assert_eq!(tau, [0.5, 0.2, -0.3]);
        // ±∞ and NaN become zero commands (clipped), then the rate limit acts from the last
        // torque: 1 N m per tick at most.
        let mut tau = [f64::INFINITY, f64::NAN, f64::NEG_INFINITY];
        assert!(actuate(&mut a, &mut tau, &mut cmd, &mut ev));
        assert_eq!(cmd, [0.0; 3]);
        assert_eq!(tau, [0.0; 3]);
        let mut tau = [f64::INFINITY, 5.0, -5.0];
        assert!(actuate(&mut a, &mut tau, &mut cmd, &mut ev));
        assert_eq!(tau, [0.0, 1.0, -1.0]);
        assert_eq!(ev.rate_limited, 1);
        assert_eq!(a.counts().rate_per_joint, vec![0, 1, 1]);
    }

    #[test]
    fn off_passes_through() {
        let mut a = Actuator::new(&ActuatorParams::default(), 2, 1e-3).unwrap();
        let mut out = [0.0; 2];
        for u in [[1.0, -3.0], [1e6, -1e6], [0.0, 5.0]] {
            a.apply(&u, &mut out);
            assert_eq!(out, u);
        }
        assert_eq!(
            (a.counts().rate, a.counts().effort, a.counts().ticks),
            (0, 0, 3)
        );
    }
}
