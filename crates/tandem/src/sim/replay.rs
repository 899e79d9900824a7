//! Joint torques replayed from a table (SPEC §5 outputs fed back in): a driver of any plant.
//!
//! Time stamps from a real log are rarely exact multiples of the control period: a simulator's
//! accumulated 1 kHz clock writes `0.0010000000000000002`, one rounding unit above the tick, and
//! compared exactly that row would apply one tick late (9.3 mm off after 1 s on the paper
//! scenario). The loop therefore hands the replay its control period
//! ([`Drive::set_control_period`]) and every stamp within [`SNAP`] of a tick is moved onto it
//! ([`snap_to_grid`], the one implementation, which the CLI's file reader uses too).

use crate::drive::{Drive, Measurements, NoRecord};
use crate::error::ModelError;
use crate::plant::ClosedChain;

/// Largest distance of a time stamp from a control tick `k h` that is snapped onto the tick, as a
/// fraction of the control period (1 %).
pub const SNAP: f64 = 0.01;

/// The tick `k h` that `t` lies within [`SNAP`]` h` of (computed as the loop computes its tick
/// times, `k as f64 * h`, so the two compare equal), or `None` when `t` is off the grid.
pub fn snap_to_grid(t: f64, h: f64) -> Option<f64> {
    let k = (t / h).round();
    ((t - k * h).abs() <= SNAP * h).then_some(k * h)
}

/// Joint torques replayed from a table (`t` plus one column per joint), each row held until the
/// next (zero-order hold); before the first row the first row applies.
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    times: Vec<f64>,
    rows: Vec<Vec<f64>>,
    cursor: usize,
    /// Linear interpolation between rows instead of the hold ([`Replay::linear`]).
    linear: bool,
    /// The interpolated row (one per joint).
    scratch: Vec<f64>,
}

impl Replay {
    /// Validate: at least one row, strictly increasing finite times, `n_q` finite torques a row.
    pub fn new(times: Vec<f64>, rows: Vec<Vec<f64>>, n_q: usize) -> Result<Self, ModelError> {
        if times.is_empty() || times.len() != rows.len() {
            return Err(ModelError::geometry(
                "replay",
                "needs at least one row and one time per row",
            ));
        }
        for (k, (t, r)) in times.iter().zip(&rows).enumerate() {
            if !t.is_finite() || (k > 0 && *t <= times[k - 1]) {
                return Err(ModelError::invalid(
                    format!("replay row {}: t", k + 1),
                    *t,
                    "times must be finite and strictly increasing",
                ));
            }
            if r.len() != n_q {
                return Err(ModelError::geometry(
                    format!("replay row {}", k + 1),
                    format!("has {} torques, the plant has {n_q} joints", r.len()),
                ));
            }
            if let Some(j) = r.iter().position(|v| !v.is_finite()) {
                return Err(ModelError::invalid(
                    format!("replay row {}: joint {j}", k + 1),
                    r[j],
                    "must be finite",
                ));
            }
        }
        let n = rows[0].len();
        Ok(Replay {
            times,
            rows,
            cursor: 0,
            linear: false,
            scratch: vec![0.0; n],
        })
    }
    /// The same table interpolated linearly between rows (the first row before the first time
    /// stamp, the last after the last one).
    pub fn linear(mut self) -> Self {
        self.linear = true;
        self
    }
    /// Moves every time stamp within [`SNAP`] of a tick of the control period `h` onto that
    /// tick ([`snap_to_grid`]; stamps off the grid stay as they are). Stamps that land on one
    /// tick keep their order, and the last of them is the row held from that tick on. The loop
    /// calls this through [`Drive::set_control_period`]; a non-positive or non-finite `h`
    /// changes nothing.
    pub fn snap_to_grid(&mut self, h: f64) {
        if !(h > 0.0 && h.is_finite()) {
            return;
        }
        for t in &mut self.times {
            if let Some(s) = snap_to_grid(*t, h) {
                *t = s;
            }
        }
        self.cursor = 0;
    }
    /// The row time stamps, s (after any [`snap_to_grid`](Self::snap_to_grid)).
    pub fn times(&self) -> &[f64] {
        &self.times
    }
    /// The held row at `t` (monotone `t` is O(1) amortised).
    pub fn at(&mut self, t: f64) -> &[f64] {
        if self.cursor > 0 && t < self.times[self.cursor] {
            self.cursor = 0;
        }
        while self.cursor + 1 < self.times.len() && self.times[self.cursor + 1] <= t {
            self.cursor += 1;
        }
        let k = self.cursor;
        if self.linear && k + 1 < self.times.len() && t > self.times[k] {
            let s = (t - self.times[k]) / (self.times[k + 1] - self.times[k]);
            for (j, v) in self.scratch.iter_mut().enumerate() {
                *v = self.rows[k][j] + s * (self.rows[k + 1][j] - self.rows[k][j]);
            }
            return &self.scratch;
        }
        &self.rows[k]
    }
}

/// The torque replay drives any plant; it logs nothing of its own.
impl<P: ClosedChain> Drive<P> for Replay {
    type Record = NoRecord;
    fn new_record(&self) -> NoRecord {
        NoRecord
    }
    fn set_control_period(&mut self, h: f64) {
        self.snap_to_grid(h);
    }
    fn start(&mut self, _t0: f64, _meas: &Measurements<'_>) {}
    fn tick(&mut self, t: f64, _meas: &Measurements<'_>, tau: &mut [f64], _rec: &mut NoRecord) {
        tau.copy_from_slice(self.at(t));
    }
}
