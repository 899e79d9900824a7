//! Drivers whose torques come from outside tandem (issue 23): [`External`], a user's law behind
//! the [`ExternalLaw`] trait (a Python function, a law in another crate) that may fail, and
//! [`Held`], torques set by the caller between ticks (a plant stepped from Python). Both log no
//! columns of their own ([`NoRecord`]); a run driven by them is scored on the true state, as a
//! torque replay is.

use crate::drive::{Drive, Measurements, NoRecord};
use crate::plant::ClosedChain;

/// A user's law: `(t, measurements) → joint torques`, which may fail (a Python exception, a
/// solver that did not converge). The loop contract is [`Drive`]'s: [`start`](Self::start)
/// once with the first readings, then [`tick`](Self::tick) every control period from `t0` on.
pub trait ExternalLaw: Send {
    /// Start at `t0` with the first readings. `Err(message)` stops the run at its first tick.
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) -> Result<(), String>;
    /// One tick: the joint torques into `tau` (`n_q`, zeroed before the call).
    /// `Err(message)` stops the run at `t` with a
    /// [`FaultKind::Driver`](crate::sim::FaultKind::Driver) fault.
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64]) -> Result<(), String>;
}

/// A user's law as a driver of the simulation: its first error stops the run (the loop reads it
/// through [`Drive::failure`]); its torques are checked and logged as any driver's.
pub struct External {
    law: Box<dyn ExternalLaw>,
    failure: Option<String>,
}

impl External {
    /// Drive the loop with `law`.
    pub fn new(law: Box<dyn ExternalLaw>) -> Self {
        External { law, failure: None }
    }
    /// The law (to read what it kept once the run is over).
    pub fn law(&self) -> &dyn ExternalLaw {
        self.law.as_ref()
    }
    /// Take the law back.
    pub fn into_law(self) -> Box<dyn ExternalLaw> {
        self.law
    }
}

impl<P: ClosedChain> Drive<P> for External {
    type Record = NoRecord;
    fn new_record(&self) -> NoRecord {
        NoRecord
    }
    fn start(&mut self, t0: f64, meas: &Measurements<'_>) {
        self.failure = self.law.start(t0, meas).err();
    }
    fn tick(&mut self, t: f64, meas: &Measurements<'_>, tau: &mut [f64], _rec: &mut NoRecord) {
        // A start that failed stops the run at its first tick, before the law is ticked.
        if self.failure.is_some() {
            tau.fill(0.0);
            return;
        }
        tau.fill(0.0);
        if let Err(e) = self.law.tick(t, meas, tau) {
            tau.fill(0.0);
            self.failure = Some(e);
        }
    }
    fn failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }
}

/// Joint torques set by the caller between ticks and held over each (a plant stepped from
/// outside, [`Stepped`](crate::sim::Stepped)).
#[derive(Clone, Debug, PartialEq)]
pub struct Held {
    /// The torques the next tick applies, N m (`n_q`).
    pub tau: Vec<f64>,
}

impl Held {
    /// Zero torques for `n_q` joints.
    pub fn new(n_q: usize) -> Self {
        Held {
            tau: vec![0.0; n_q],
        }
    }
}

impl<P: ClosedChain> Drive<P> for Held {
    type Record = NoRecord;
    fn new_record(&self) -> NoRecord {
        NoRecord
    }
    fn start(&mut self, _t0: f64, _meas: &Measurements<'_>) {}
    fn tick(&mut self, _t: f64, _meas: &Measurements<'_>, tau: &mut [f64], _rec: &mut NoRecord) {
        tau.copy_from_slice(&self.tau);
    }
}
