//! The loop contract (SPEC §3 step 2): what reads the sensors and writes the joint torques.
//! tandem's planar [`Controller`](crate::control::planar::Controller), the spatial
//! [`SpatialController`](crate::control::spatial::SpatialController), the torque
//! [`Replay`](crate::sim::Replay) and a user's own law all implement [`Drive`], so a new law
//! plugs into [`Simulation`](crate::sim::Simulation) without a fork of the loop. It sits below
//! both the controllers and the loop: [`Measurements`], [`Record`], [`NoRecord`] and the event
//! counters [`ControlEvents`].
//!
//! A tick has the signature of [`Controller::tick`](crate::control::planar::Controller::tick): `(t, measurements) → joint torques`, plus a
//! record of the driver's internals that the loop logs ([`Record`]: columns before the joint
//! torques and after the sensor readings) and checks for non-finite values. A driver sees only
//! [`Measurements`] (sensor outputs), never the plant state; the true state reaches it only for
//! the output-bound bookkeeping ([`Drive::truth_margin`]) and for record columns that show the
//! truth ([`Drive::record_truth`]), neither of which feeds back into the torques.

use nalgebra::{Vector2, Vector6};
use serde::Serialize;

use crate::plant::ClosedChain;

/// What a driver reads at a tick: sensor outputs, never the plant state.
#[derive(Clone, Copy, Debug)]
pub struct Measurements<'a> {
    /// Encoder angles, stacked over arms, rad.
    pub q: &'a [f64],
    /// Encoder rates, rad/s.
    pub qd: &'a [f64],
    /// Wrist readings, flat, `W` channels per arm (`W` = [`ClosedChain::WRENCH_DIM`]): 2 for the
    /// planar force `F_i` (the object on end-effector `i`, world axes, N), 6 for the spatial
    /// `[f; τ]` (N, N m) in TOOL axes.
    pub wrenches: &'a [f64],
}

impl<'a> Measurements<'a> {
    /// Planar force reading `F_i` of arm `arm` (channels `2i, 2i+1`), N.
    ///
    /// # Panics
    /// If `arm` is out of range.
    #[inline]
    pub fn force(&self, arm: usize) -> Vector2<f64> {
        Vector2::new(self.wrenches[2 * arm], self.wrenches[2 * arm + 1])
    }
    /// Spatial wrist reading `[f; τ]` of arm `arm` in its tool axes (channels `6i..6i+6`),
    /// (N, N m).
    ///
    /// # Panics
    /// If `arm` is out of range.
    #[inline]
    pub fn wrench(&self, arm: usize) -> Vector6<f64> {
        Vector6::from_column_slice(&self.wrenches[6 * arm..6 * arm + 6])
    }
}

/// The per-tick record of a driver: what its log columns show. Allocation-free to write.
pub trait Record {
    /// Columns written before the joint torques `(name, unit)`, e.g. planar `x_hat.x [m]` …
    /// `w_norm.theta [1]`.
    fn head_columns(&self) -> Vec<(String, String)>;
    /// Columns written after the sensor readings (planar: `Q`, `margin`).
    fn tail_columns(&self) -> Vec<(String, String)>;
    /// Write the head values (`head_columns().len()` of them).
    fn write_head(&self, out: &mut [f64]);
    /// Write the tail values (`tail_columns().len()` of them).
    fn write_tail(&self, out: &mut [f64]);
    /// The first non-finite value, named as its log column (`x_r.y`, `Q`, ...); `None` if all
    /// are finite. May allocate only when it finds one.
    fn non_finite(&self) -> Option<String>;
}

/// A record with no columns (the torque [`Replay`](crate::sim::Replay), or a driver that logs nothing).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoRecord;

impl Record for NoRecord {
    fn head_columns(&self) -> Vec<(String, String)> {
        Vec::new()
    }
    fn tail_columns(&self) -> Vec<(String, String)> {
        Vec::new()
    }
    fn write_head(&self, _out: &mut [f64]) {}
    fn write_tail(&self, _out: &mut [f64]) {}
    fn non_finite(&self) -> Option<String> {
        None
    }
}

/// A driver of the simulation: tandem's controllers, the torque replay, or a user's law.
///
/// The loop calls [`new_record`](Self::new_record) once at set-up, [`start`](Self::start) with
/// the first measurements, then per control tick [`tick`](Self::tick),
/// [`record_truth`](Self::record_truth) and [`truth_margin`](Self::truth_margin); at the end
/// [`events`](Self::events).
pub trait Drive<P: ClosedChain> {
    /// What the driver logs per tick.
    type Record: Record;
    /// A record with its buffers sized (called once at set-up).
    fn new_record(&self) -> Self::Record;
    /// The loop's control period `h`, s: called once by the loop at set-up, before
    /// [`start`](Self::start) (default: nothing). A driver that keeps time stamps snaps them onto
    /// the control grid here (the torque [`Replay`](crate::sim::Replay) does).
    fn set_control_period(&mut self, h: f64) {
        let _ = h;
    }
    /// Start (or restart) at `t0` with the first measurements.
    fn start(&mut self, t0: f64, meas: &Measurements<'_>);
    /// One tick: `(t, measurements) →` joint torques (`n_q`, written into `tau`) and the record.
    /// Must not allocate.
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut Self::Record);
    /// Why the driver could not produce its last torques (a user's law raised or returned an
    /// error), checked by the loop after every [`tick`](Self::tick): `Some` stops the run with a
    /// [`FaultKind::Driver`](crate::sim::FaultKind::Driver) fault at the tick's time. Default:
    /// never.
    fn failure(&self) -> Option<&str> {
        None
    }
    /// Event counters since start (default: none).
    fn events(&self) -> ControlEvents {
        ControlEvents::default()
    }
    /// Per joint (all arms stacked in joint order), the ticks on which the actuator stage's
    /// torque-rate limit and effort limit changed that joint's torque since start, as
    /// `(rate_limited, effort_clipped)` (default: `None`, a driver without an actuator stage).
    fn joint_limit_counts(&self) -> Option<(&[u64], &[u64])> {
        None
    }
    /// Output-bound margin `1 − max_j |x_1j|/k_cj` of the TRUE plant state `y` (`None`: the
    /// driver has no bounds). Called every tick (and once at set-up on the start state, to
    /// know whether the driver has bounds).
    fn truth_margin(&self, plant: &P, y: &[f64]) -> Option<f64> {
        let _ = (plant, y);
        None
    }
    /// Fill record columns that show the true state of the tick (called right after
    /// [`tick`](Self::tick); default: nothing). For drivers that estimate nothing: the planar
    /// [`Driver::Replay`](crate::sim::Driver::Replay) logs the true pose as `x_hat`. Never feeds the torques.
    fn record_truth(&self, plant: &P, y: &[f64], rec: &mut Self::Record) {
        let _ = (plant, y, rec);
    }
}

/// Per joint, all arms stacked in joint order, the ticks on which the actuator stage's limits
/// changed that joint's torque (issue 24): [`Drive::joint_limit_counts`] copied out once at the
/// end of a run (the stage counts into buffers sized when it is built; the tick allocates
/// nothing).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct JointLimitCounts {
    /// Ticks on which the torque-rate limit changed the joint's torque.
    pub rate_limited: Vec<u64>,
    /// Ticks on which the effort limit clipped the joint's torque.
    pub effort_clipped: Vec<u64>,
}

/// Counters of events since the start (SPEC §3.3: a barrier hit is recorded and counted).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ControlEvents {
    /// Ticks with a barrier saturation.
    pub barrier_hits: u64,
    /// Ticks with clipped torques (the actuator's effort limit acted on a joint, or a
    /// non-finite torque was replaced).
    pub torque_clips: u64,
    /// Ticks on which the actuator's torque-rate limit acted on a joint.
    pub rate_limited: u64,
    /// Ticks through the actuator's output filter (every tick when it is on).
    pub filtered: u64,
    /// Ticks with a non-finite value replaced.
    pub non_finite: u64,
    /// Ticks that could not estimate or distribute (degenerate grasps).
    pub degenerate: u64,
}
