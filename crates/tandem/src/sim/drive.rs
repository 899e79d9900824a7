//! The driver of the simulation (SPEC §3 step 2): what reads the sensors and writes the joint
//! torques. tandem's planar [`Controller`], the torque [`Replay`] and a user's own law all
//! implement [`Drive`], so a new law plugs into [`Simulation`](super::Simulation) without a
//! fork of the loop.
//!
//! A tick has the signature of [`Controller::tick`]: `(t, measurements) → joint torques`, plus a
//! record of the driver's internals that the loop logs ([`Record`]: columns before the joint
//! torques and after the sensor readings) and checks for non-finite values. A driver sees only
//! [`Measurements`] (sensor outputs), never the plant state; the true state reaches it only for
//! the output-bound bookkeeping ([`Drive::truth_margin`]) and for record columns that show the
//! truth ([`Drive::record_truth`]), neither of which feeds back into the torques.

use nalgebra::{Vector2, Vector6};

use crate::control::{ControlEvents, Controller, TickRecord};
use crate::plant::ClosedChain;
use crate::plant::planar::Plant;

use super::Replay;

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

/// A record with no columns (the torque [`Replay`], or a driver that logs nothing).
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
    /// Start (or restart) at `t0` with the first measurements.
    fn start(&mut self, t0: f64, meas: &Measurements<'_>);
    /// One tick: `(t, measurements) →` joint torques (`n_q`, written into `tau`) and the record.
    /// Must not allocate.
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut Self::Record);
    /// Event counters since start (default: none).
    fn events(&self) -> ControlEvents {
        ControlEvents::default()
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
    /// [`Driver::Replay`] logs the true pose as `x_hat`. Never feeds the torques.
    fn record_truth(&self, plant: &P, y: &[f64], rec: &mut Self::Record) {
        let _ = (plant, y, rec);
    }
}

/// What produces the joint torques of a planar run (the CLI's choice): one of tandem's drivers.
pub enum Driver {
    /// A cooperative controller (boxed: it owns sizeable buffers).
    Controller(Box<Controller>),
    /// A torque replay; its log shows the true pose as `x_hat`, `Q = 1`, `margin = 0`.
    Replay(Replay),
}

const AX: [&str; 3] = ["x", "y", "theta"];

/// The planar record groups in log order (SPEC §5): name, units of `(x, y)` and `θ`.
const HEAD: [(&str, &str, &str); 9] = [
    ("x_hat", "m", "rad"),
    ("x_d", "m", "rad"),
    ("x_r", "m", "rad"),
    ("z1", "m", "rad"),
    ("z2", "m/s", "rad/s"),
    ("alpha", "m/s", "rad/s"),
    ("alpha_dot", "m/s^2", "rad/s^2"),
    ("tau", "N", "N m"),
    ("w_norm", "1", "1"),
];

impl TickRecord {
    fn groups(&self) -> [&nalgebra::Vector3<f64>; 9] {
        [
            &self.x_o,
            &self.x_d,
            &self.x_r,
            &self.z1,
            &self.z2,
            &self.alpha,
            &self.alpha_dot,
            &self.wrench,
            &self.w_norm,
        ]
    }
}

/// The planar controller's record: head `x_hat … w_norm` (SPEC §5), tail `Q`, `margin`.
impl Record for TickRecord {
    fn head_columns(&self) -> Vec<(String, String)> {
        let mut l = Vec::with_capacity(27);
        for (g, m, r) in HEAD {
            for (j, a) in AX.iter().enumerate() {
                l.push((format!("{g}.{a}"), if j < 2 { m } else { r }.to_string()));
            }
        }
        l
    }
    fn tail_columns(&self) -> Vec<(String, String)> {
        vec![("Q".into(), "1".into()), ("margin".into(), "1".into())]
    }
    fn write_head(&self, out: &mut [f64]) {
        for (g, v) in self.groups().iter().enumerate() {
            out[3 * g..3 * g + 3].copy_from_slice(v.as_slice());
        }
    }
    fn write_tail(&self, out: &mut [f64]) {
        out[0] = self.q_switch;
        out[1] = self.margin;
    }
    fn non_finite(&self) -> Option<String> {
        // One pass without early exit over every value (the common case: all finite): a sum
        // of `0 · x` is ±0 unless some `x` is NaN or infinite.
        let mut z = 0.0 * self.q_switch + 0.0 * self.margin;
        for v in self.groups() {
            z += 0.0 * v.x + 0.0 * v.y + 0.0 * v.z;
        }
        if z == 0.0 && !self.non_finite {
            return None;
        }
        for ((name, _, _), v) in HEAD.iter().zip(self.groups()) {
            if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                return Some(format!("{name}.{}", AX[j]));
            }
        }
        if !self.q_switch.is_finite() {
            return Some("Q".into());
        }
        if !self.margin.is_finite() {
            return Some("margin".into());
        }
        if self.non_finite {
            return Some("a controller input or output (replaced by the controller)".into());
        }
        None
    }
}

/// The margin `1 − max_j |x_o,j|/k_cj` of a planar state's true pose.
fn planar_margin(plant: &Plant, y: &[f64], k_c: &nalgebra::Vector3<f64>) -> f64 {
    let n = plant.n_q();
    (0..3)
        .map(|j| 1.0 - y[n + j].abs() / k_c[j])
        .fold(f64::INFINITY, f64::min)
}

/// tandem's planar cooperative controller (SPEC §3) as a driver.
impl Drive<Plant> for Controller {
    type Record = TickRecord;
    fn new_record(&self) -> TickRecord {
        TickRecord::default()
    }
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        Controller::start(self, t0, meas);
    }
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut TickRecord) {
        Controller::tick(self, t, meas, tau, rec);
    }
    fn events(&self) -> ControlEvents {
        Controller::events(self)
    }
    fn truth_margin(&self, plant: &Plant, y: &[f64]) -> Option<f64> {
        Some(planar_margin(plant, y, &self.k_c()))
    }
}

/// The torque replay drives any plant; it logs nothing of its own.
impl<P: ClosedChain> Drive<P> for Replay {
    type Record = NoRecord;
    fn new_record(&self) -> NoRecord {
        NoRecord
    }
    fn start(&mut self, _t0: f64, _meas: &Measurements<'_>) {}
    fn tick(&mut self, t: f64, _meas: &Measurements<'_>, tau: &mut [f64], _rec: &mut NoRecord) {
        tau.copy_from_slice(self.at(t));
    }
}

/// The planar CLI's driver: delegates to the controller or the replay. Both log the planar
/// [`TickRecord`] columns (SPEC §5); for a replay `x_hat` shows the true pose.
impl Drive<Plant> for Driver {
    type Record = TickRecord;
    fn new_record(&self) -> TickRecord {
        TickRecord::default()
    }
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        if let Driver::Controller(c) = self {
            c.start(t0, meas);
        }
    }
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut TickRecord) {
        match self {
            Driver::Controller(c) => c.tick(t, meas, tau, rec),
            Driver::Replay(r) => tau.copy_from_slice(r.at(t)),
        }
    }
    fn events(&self) -> ControlEvents {
        match self {
            Driver::Controller(c) => c.events(),
            Driver::Replay(_) => ControlEvents::default(),
        }
    }
    fn truth_margin(&self, plant: &Plant, y: &[f64]) -> Option<f64> {
        match self {
            Driver::Controller(c) => Some(planar_margin(plant, y, &c.k_c())),
            Driver::Replay(_) => None,
        }
    }
    fn record_truth(&self, plant: &Plant, y: &[f64], rec: &mut TickRecord) {
        if let Driver::Replay(_) = self {
            let (_, x, _, xd) = plant.split(y);
            *rec = TickRecord {
                x_o: x,
                xd_o: xd,
                q_switch: 1.0,
                ..TickRecord::default()
            };
        }
    }
}
