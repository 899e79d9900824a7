//! The planar CLI's driver: [`Driver`], one of tandem's planar drivers chosen at run time (the
//! controller, a torque replay or a user's law), logging the planar record columns either way.

use crate::control::planar::{Controller, TickRecord, planar_margin};
use crate::drive::{ControlEvents, Drive, Measurements};
use crate::plant::planar::Plant;

use super::{External, Replay};

/// What produces the joint torques of a planar run (the CLI's choice): one of tandem's drivers.
pub enum Driver {
    /// A cooperative controller (boxed: it owns sizeable buffers).
    Controller(Box<Controller>),
    /// A torque replay; its log shows the true pose as `x_hat`, `Q = 1`, `margin = 0`.
    Replay(Replay),
    /// A user's law ([`External`]); logged as a replay is.
    External(External),
}

/// The planar CLI's driver: delegates to the controller or the replay. Both log the planar
/// [`TickRecord`] columns (SPEC §5); for a replay `x_hat` shows the true pose.
impl Drive<Plant> for Driver {
    type Record = TickRecord;
    fn new_record(&self) -> TickRecord {
        TickRecord::default()
    }
    fn set_control_period(&mut self, h: f64) {
        if let Driver::Replay(r) = self {
            <Replay as Drive<Plant>>::set_control_period(r, h);
        }
    }
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        match self {
            Driver::Controller(c) => c.start(t0, meas),
            Driver::Replay(_) => {}
            Driver::External(e) => <External as Drive<Plant>>::start(e, t0, meas),
        }
    }
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut TickRecord) {
        match self {
            Driver::Controller(c) => c.tick(t, meas, tau, rec),
            Driver::Replay(r) => tau.copy_from_slice(r.at(t)),
            Driver::External(e) => {
                <External as Drive<Plant>>::tick(e, t, meas, tau, &mut crate::drive::NoRecord)
            }
        }
    }
    fn failure(&self) -> Option<&str> {
        match self {
            Driver::External(e) => <External as Drive<Plant>>::failure(e),
            _ => None,
        }
    }
    fn events(&self) -> ControlEvents {
        match self {
            Driver::Controller(c) => c.events(),
            Driver::Replay(_) | Driver::External(_) => ControlEvents::default(),
        }
    }
    fn joint_limit_counts(&self) -> Option<(&[u64], &[u64])> {
        match self {
            Driver::Controller(c) => <Controller as Drive<Plant>>::joint_limit_counts(c),
            Driver::Replay(_) | Driver::External(_) => None,
        }
    }
    fn truth_margin(&self, plant: &Plant, y: &[f64]) -> Option<f64> {
        match self {
            Driver::Controller(c) => Some(planar_margin(plant, y, &c.k_c())),
            Driver::Replay(_) | Driver::External(_) => None,
        }
    }
    fn record_truth(&self, plant: &Plant, y: &[f64], rec: &mut TickRecord) {
        if let Driver::Replay(_) | Driver::External(_) = self {
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
