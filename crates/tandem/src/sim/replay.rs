//! Joint torques replayed from a table (SPEC §5 outputs fed back in): a driver of any plant.

use crate::drive::{Drive, Measurements, NoRecord};
use crate::error::ModelError;
use crate::plant::ClosedChain;

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
    fn start(&mut self, _t0: f64, _meas: &Measurements<'_>) {}
    fn tick(&mut self, t: f64, _meas: &Measurements<'_>, tau: &mut [f64], _rec: &mut NoRecord) {
        tau.copy_from_slice(self.at(t));
    }
}
