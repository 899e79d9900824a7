//! The simulation loop (SPEC §3 step order, §2.4 integration, §5 outputs), one loop for both
//! plants: [`Simulation`] is generic over the plant ([`ClosedChain`]: the planar [`Plant`] or
//! the spatial [`SpatialPlant`](crate::plant::spatial::SpatialPlant)) and its driver
//! ([`Drive`]: tandem's [`Controller`](crate::control::planar::Controller), a torque [`Replay`], or a
//! user's own law).
//!
//! Per control tick `k` at `t_k = k h_c`:
//! 1. grasp wrenches at `(y(t_k), u_{k−1})` (the input still held,
//!    [`ClosedChain::grasp_wrenches`]) → wrist sensors; encoders;
//! 2. the driver ([`Drive::tick`] on the [`Measurements`]) → joint torques `u_k`, actuator
//!    limits;
//! 3. `F_d(t_k)`; the plant advances `h_c / h_p` RK4 substeps with `(u_k, F_d)` held (ZOH,
//!    [`ClosedChain::step_with`]);
//! 4. health checks (non-finite state, constraint drift, singular arms) → a [`Fault`] stops the
//!    run cleanly with the time and the state;
//! 5. every `log_period`, one row into the preallocated [`Log`] ([`log::layout`]).
//!
//! Every tick's applied torque `u_k` (after the driver and any injected actuator fault) also
//! goes to the [`TorqueRateMonitor`] (peak `|Δτ|/Δt` and chattering per joint,
//! [`torque_rate`]), which only reads it; its result is [`Outcome::torque_rate`].
//!
//! Formulations: the planar plant integrates the constrained form or the reduced one (14)
//! ([`Formulation`], SPEC §2.4); the choice lives in the plant's [`Stepper`], which keeps
//! the reduced 6-state in the object part of the flat state (bit for bit), so the loop has
//! one state `y` whatever the formulation. The spatial plant has the constrained form only.
//!
//! Deterministic: the only randomness is in the seeded sensors. A tick allocates nothing.

pub mod driver;
pub mod external;
pub mod fault;
pub mod faults;
pub mod log;
pub mod replay;
pub mod sensors;
pub mod torque_rate;

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::drive::{ControlEvents, JointLimitCounts};
use crate::drive::{Drive, Measurements, Record};
use crate::error::{ModelError, positive};
use crate::model::disturbance::Disturbance;
use crate::plant::planar::{Plant, PlantParams};
use crate::plant::{ChainFault, ClosedChain, PlanarStart, Stepper};
use crate::sim::faults::{FaultState, Faults};
use crate::sim::sensors::{SensorParams, Sensors};

pub use crate::plant::{Formulation, SpatialDisturbance, SpatialStart};
pub use driver::Driver;
pub use external::{External, ExternalLaw, Held};
pub use fault::{Fault, FaultKind};
pub use log::{Column, Log};
pub use replay::Replay;
pub use torque_rate::{TorqueRate, TorqueRateMonitor, TorqueRateParams};

use fault::short;

/// Run settings (plain data).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimParams {
    /// Duration, s.
    pub duration: f64,
    /// Plant RK4 step, s (the control period must be a whole multiple).
    pub plant_step: f64,
    /// Control period, s.
    pub control_period: f64,
    /// Logging period, s (a whole multiple of the control period).
    pub log_period: f64,
    /// Start pose of the planar object, (m, m, rad); at rest. Read by the planar
    /// [`Simulation::new`]; [`Simulation::with_plant`] takes its start from its `start`
    /// argument instead.
    pub start: [f64; 3],
    /// Plant formulation.
    #[serde(default)]
    pub formulation: Formulation,
    /// Largest grasp-constraint drift tolerated before the run stops, m (and rad for the
    /// rotation of the spatial welds).
    #[serde(default = "default_drift")]
    pub max_drift: f64,
    /// Smallest arm-Jacobian singular value tolerated before the run stops, m/rad.
    #[serde(default = "default_sigma")]
    pub min_sigma: f64,
}

/// Most control ticks a run may have (10⁹: 11.6 simulated days at 1 kHz, about an hour of wall
/// time), so that every run ends in bounded time.
pub const MAX_TICKS: f64 = 1e9;

/// Most plant steps per control tick (a tiny plant step must not make the run endless).
pub const MAX_SUBSTEPS: usize = 1000;

/// Most memory the preallocated log may take, bytes (512 MiB): a longer log is refused at
/// validation with its size, never allocated.
pub const MAX_LOG_BYTES: f64 = 512.0 * 1024.0 * 1024.0;

fn default_drift() -> f64 {
    1e-6
}
fn default_sigma() -> f64 {
    1e-3
}

impl SimParams {
    /// The paper's run: 90 s, 1 kHz control, 1 ms plant step, log every 30 ms, start
    /// `(0.19, 0, 0)` (SPEC §4).
    pub fn paper() -> Self {
        SimParams {
            duration: 90.0,
            plant_step: 1e-3,
            control_period: 1e-3,
            log_period: 0.03,
            start: [0.19, 0.0, 0.0],
            formulation: Formulation::Constrained,
            max_drift: default_drift(),
            min_sigma: default_sigma(),
        }
    }

    /// Validate periods and their ratios; returns (substeps per tick, ticks per log row, ticks).
    pub fn validate(&self) -> Result<(usize, usize, usize), ModelError> {
        let d = positive("duration", self.duration)?;
        let hp = positive("plant_step", self.plant_step)?;
        let hc = positive("control_period", self.control_period)?;
        let hl = positive("log_period", self.log_period)?;
        positive("max_drift", self.max_drift)?;
        positive("min_sigma", self.min_sigma)?;
        let ratio = |a: f64, b: f64, what: &str, of: &str| -> Result<usize, ModelError> {
            let r = a / b;
            let n = r.round();
            if n < 1.0 || (r - n).abs() > 1e-9 * n {
                Err(ModelError::invalid(
                    what,
                    a,
                    format!("must be a whole multiple of {of} ({})", short(b)),
                ))
            } else {
                Ok(n as usize)
            }
        };
        if hl > d {
            return Err(ModelError::invalid(
                "log_period",
                hl,
                format!(
                    "must not exceed the duration ({} s): the log would hold one row",
                    short(d)
                ),
            ));
        }
        if !(hc / hp < MAX_SUBSTEPS as f64 + 0.5) {
            return Err(ModelError::invalid(
                "plant_step",
                hp,
                format!(
                    "gives {:.3e} plant steps per control period, more than {MAX_SUBSTEPS} (the run would never end)",
                    hc / hp
                ),
            ));
        }
        let sub = ratio(hc, hp, "control_period", "plant_step")?;
        let per_log = ratio(hl, hc, "log_period", "control_period")?;
        if !((d / hc).round() <= MAX_TICKS) {
            return Err(ModelError::invalid(
                "duration",
                d,
                format!(
                    "is {:.3e} control ticks of {hc} s, more than the {MAX_TICKS:.0e} a run may have",
                    (d / hc).round()
                ),
            ));
        }
        let ticks = (d / hc).round() as usize;
        for (j, v) in self.start.iter().enumerate() {
            if !v.is_finite() {
                return Err(ModelError::invalid(
                    format!("start[{j}]"),
                    *v,
                    "must be finite",
                ));
            }
        }
        Ok((sub, per_log, ticks))
    }
}

/// The result of a run.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The log (rows up to the stop).
    pub log: Log,
    /// Why the run stopped early, if it did.
    pub fault: Option<Fault>,
    /// Driver event counters (zero for a replay).
    pub events: ControlEvents,
    /// Ticks simulated.
    pub ticks: usize,
    /// Simulated time reached, s.
    pub t_end: f64,
    /// Wall time of the loop (outputs excluded), s.
    pub wall_time: f64,
    /// Largest constraint drift seen (position), m.
    pub max_drift: f64,
    /// Largest rotational drift of the spatial welds seen, rad (0 for the planar plant).
    pub max_drift_rot: f64,
    /// Evaluations that needed a regularised grasp-space solve.
    pub regularised: u64,
    /// Smallest constraint margin `1 − max_j |x_o,j|/k_cj` of the true pose over every control
    /// tick (not only logged rows); `None` for a driver without bounds (a replay).
    pub min_margin: Option<f64>,
    /// Control ticks that ended with the true pose on or outside the bound.
    pub violation_ticks: u64,
    /// Torque rate and chattering of the applied joint torques, from every control tick (not
    /// only logged rows); see [`torque_rate`].
    pub torque_rate: TorqueRate,
    /// Per joint, the ticks on which the actuator stage's rate and effort limits acted
    /// ([`Drive::joint_limit_counts`]); `None` for a driver without the stage (a replay, a
    /// user's law).
    pub joint_limits: Option<JointLimitCounts>,
}

/// Lengths of the log row's segments (see [`log::layout`]).
#[derive(Clone, Copy, Debug)]
struct Segments {
    object: usize,
    head: usize,
    joints: usize,
    tail: usize,
    drift: usize,
    contacts: usize,
}

/// The planar simulation the CLI runs: the planar plant driven by a [`Driver`].
pub type PlanarSimulation = Simulation<Plant, Driver>;

/// A simulation: plant, sensors, driver, state, scratch and the log. One loop for every
/// [`ClosedChain`] plant and every [`Drive`]r; the defaults are the planar plant and the
/// planar [`Driver`] enum.
pub struct Simulation<P: ClosedChain = Plant, D: Drive<P> = Driver> {
    plant: P,
    params: SimParams,
    sensors: Sensors,
    driver: D,
    disturbance: P::Disturbance,
    y: Vec<f64>,
    y_prev: Vec<f64>,
    ws: P::Workspace,
    stepper: Stepper,
    input: P::Input,
    /// Grasp wrenches of the tick's state, world axes, flat (`W` per arm).
    wrenches: Vec<f64>,
    /// The same wrenches as the wrist sensors see them (truth, sensor axes).
    sensor_truth: Vec<f64>,
    /// Wrist readings of the tick, flat.
    meas: Vec<f64>,
    rec: D::Record,
    log: Log,
    row: Vec<f64>,
    seg: Segments,
    substeps: usize,
    per_log: usize,
    ticks: usize,
    /// Whether the driver keeps output bounds (per-tick margin tracking).
    has_bounds: bool,
    min_margin: f64,
    violation_ticks: u64,
    /// Injected sensor and actuator faults ([`Simulation::with_faults`]).
    faults: Option<Box<FaultState>>,
    /// Torque rate and chattering of the applied torques, fed every tick (reads only).
    torque_rate: TorqueRateMonitor,
    /// Whether ticks write log rows (off for a plant stepped from outside, which has no end).
    logging: bool,
    /// The per-joint limit counts' buffers, sized at set-up, filled and moved out at the end
    /// of [`run`](Simulation::run) (so that the run allocates nothing after its set-up).
    joint_limits: Option<JointLimitCounts>,
}

impl<D: Drive<Plant>> Simulation<Plant, D> {
    /// Build a planar run: validates every part, places the chain at the start pose
    /// `params.start` (analytic IK for 2-link arms, `q_guess` for others) and starts the driver.
    pub fn new(
        plant: &PlantParams,
        sensors: &SensorParams,
        driver: D,
        disturbance: Disturbance,
        params: SimParams,
        q_guess: Option<&[f64]>,
    ) -> Result<Self, ModelError> {
        params.validate()?;
        disturbance.validate()?;
        let plant = Plant::new(plant)?;
        let start = PlanarStart {
            x_o: params.start,
            q_guess: q_guess.map(<[f64]>::to_vec),
        };
        Self::with_plant(plant, &start, sensors, driver, disturbance, params)
    }
}

/// A plant stepped from outside (issue 23: Python's `Scenario.plant()`): the scenario's plant,
/// sensors, disturbance and injected faults, with joint torques given per step and held over
/// it ([`Held`]). The run's tick split in two: the sensors are sampled at the current state
/// (what [`sensors`](Self::sensors) and [`readings`](Self::readings) show), then
/// [`step`](Self::step) applies the torques over whole control periods, runs the run's health
/// checks every tick, and samples again. Nothing is logged (it has no end); a step allocates
/// nothing unless it faults. After a fault the plant refuses to step.
pub struct Stepped<P: ClosedChain> {
    sim: Simulation<P, Held>,
    k: usize,
    fault: Option<Fault>,
}

impl<P: ClosedChain> Stepped<P> {
    /// Step `sim` from outside, from its start (`t = 0`, at rest, zero torque held).
    pub fn new(mut sim: Simulation<P, Held>) -> Result<Self, Fault> {
        sim.logging = false;
        sim.log = Log::default();
        sim.sense(0)?;
        Ok(Stepped {
            sim,
            k: 0,
            fault: None,
        })
    }
    /// The simulation time, s.
    pub fn time(&self) -> f64 {
        self.k as f64 * self.sim.params.control_period
    }
    /// Control periods stepped so far.
    pub fn ticks(&self) -> usize {
        self.k
    }
    /// The control period (the step's unit), s.
    pub fn control_period(&self) -> f64 {
        self.sim.params.control_period
    }
    /// The fault that stopped the plant, if one did.
    pub fn fault(&self) -> Option<&Fault> {
        self.fault.as_ref()
    }
    /// Apply `tau` (`n_q`, N m, finite: the caller checks) for `periods` control periods. `Err`
    /// with the fault (its time and last good state) when the plant fails; the state is then
    /// the fault's last good one, and the plant stays failed.
    pub fn step(&mut self, tau: &[f64], periods: usize) -> Result<(), Fault> {
        if let Some(f) = &self.fault {
            return Err(f.clone());
        }
        for _ in 0..periods {
            self.sim.driver.tau.copy_from_slice(tau);
            // The run's health checks: the state every period, the chain (drift, singular
            // arms) every 10 periods as the run does.
            let k1 = self.k + 1;
            let r = self
                .sim
                .act(self.k)
                .and_then(|()| {
                    if k1.is_multiple_of(10) {
                        self.sim.check_chain(k1).1
                    } else {
                        Ok(())
                    }
                })
                .and_then(|()| self.sim.sense(k1));
            if let Err(f) = r {
                // Back to the last good state (the fault's): never a non-finite state shown.
                self.sim.y.copy_from_slice(&self.sim.y_prev);
                self.fault = Some(f.clone());
                return Err(f);
            }
            self.k += 1;
        }
        Ok(())
    }
    /// The plant model.
    pub fn plant(&self) -> &P {
        &self.sim.plant
    }
    /// The flat true state.
    pub fn state(&self) -> &[f64] {
        &self.sim.y
    }
    /// The true joint angles and rates.
    pub fn joints(&self) -> (&[f64], &[f64]) {
        self.sim.plant.joints(&self.sim.y)
    }
    /// The object's true pose and twist ([`ClosedChain::object_state`]).
    pub fn object(&self) -> (&[f64], &[f64]) {
        self.sim.plant.object_state(&self.sim.y)
    }
    /// The sensors at the current state: encoder angles and rates (with the scenario's noise,
    /// quantisation, delays), as a driver would read them.
    pub fn sensors(&self) -> &Sensors {
        &self.sim.sensors
    }
    /// The wrist readings at the current state (flat, `W` per arm), with the scenario's sensor
    /// models; injected sensor faults ([`Simulation::with_faults`]) act only on a driver's
    /// view and are not in these (injected actuator faults do act on the stepped torques).
    pub fn readings(&self) -> &[f64] {
        &self.sim.meas
    }
    /// The true grasp wrenches at the current state with the last torques held (world axes,
    /// flat, `W` per arm).
    pub fn wrenches(&self) -> &[f64] {
        &self.sim.wrenches
    }
    /// The same as the wrist sensors see them, without noise (sensor axes).
    pub fn sensor_truth(&self) -> &[f64] {
        &self.sim.sensor_truth
    }
    /// Hold `tau` from now on without stepping (a robot holding its pose before the loop
    /// starts): the sensors read again at the current state with it held, as a run's readings
    /// are always taken with the torque held since the last tick (noisy sensors draw again).
    pub fn hold(&mut self, tau: &[f64]) -> Result<(), Fault> {
        if let Some(f) = &self.fault {
            return Err(f.clone());
        }
        P::torques_mut(&mut self.sim.input).copy_from_slice(tau);
        self.sim.driver.tau.copy_from_slice(tau);
        self.sim
            .sense(self.k)
            .inspect_err(|f| self.fault = Some(f.clone()))
    }
    /// What the wrist sensors would read at the current state, without noise, if `tau` were
    /// held (sensor axes, flat), and the same grasp wrenches in world axes: e.g. the readings
    /// of a robot holding the object at rest. Changes nothing of the plant's course (the next
    /// [`step`](Self::step) holds its own torques). `Err` when the plant cannot be evaluated.
    pub fn truth_with(&mut self, tau: &[f64]) -> Result<(&[f64], &[f64]), FaultKind> {
        P::torques_mut(&mut self.sim.input).copy_from_slice(tau);
        let r = self.sim.eval_wrenches().map_err(chain_fault);
        r.map(|()| {
            (
                self.sim.sensor_truth.as_slice(),
                self.sim.wrenches.as_slice(),
            )
        })
    }
    /// The grasp-constraint residual of the current state ([`ClosedChain::constraint_residual`]).
    pub fn residual(&mut self) -> (f64, f64) {
        self.sim
            .plant
            .constraint_residual(&self.sim.y, &mut self.sim.ws)
    }
    /// The mechanical energy of the current state.
    pub fn energy(&mut self) -> crate::plant::Energy {
        self.sim.plant.energy(&self.sim.y, &mut self.sim.ws)
    }
}

impl Stepped<crate::plant::spatial::SpatialPlant> {
    /// The joint torques that hold the current configuration at rest in static equilibrium
    /// ([`SpatialPlant::holding_torques`](crate::plant::spatial::SpatialPlant::holding_torques):
    /// the arms' gravity and an equal share of the object's weight, no internal wrench), into
    /// `tau` (`n_q`). Allocates a scratch workspace: not for a hot loop.
    pub fn holding_torques(&self, tau: &mut [f64]) {
        let mut ws = self.sim.plant.workspace();
        self.sim.plant.holding_torques(&self.sim.y, &mut ws, tau);
    }
}

fn chain_fault(f: ChainFault) -> FaultKind {
    match f {
        ChainFault::NonFinite => FaultKind::NonFinite,
        ChainFault::Reduced => FaultKind::Reduced,
    }
}

impl<P: ClosedChain, D: Drive<P>> Simulation<P, D> {
    /// Inject sensor and actuator faults between the plant and the driver (see
    /// [`crate::sim::faults`]); errors name the field (`faults.force_delay`, ...).
    pub fn with_faults(mut self, f: &Faults) -> Result<Self, ModelError> {
        self.faults = if f.any() {
            let st = f.state(
                self.params.control_period,
                self.plant.n_q(),
                self.plant.n_arms(),
                P::WRENCH_DIM,
            )?;
            Some(Box::new(st))
        } else {
            None
        };
        Ok(self)
    }

    /// Count chattering with other settings than the default (0.5 N m after 10 ms, see
    /// [`torque_rate`]); errors name the field (`torque_rate.threshold`, ...). Changes no
    /// torque and no state of the run.
    pub fn with_torque_rate(mut self, p: TorqueRateParams) -> Result<Self, ModelError> {
        self.torque_rate = TorqueRateMonitor::new(self.plant.n_q(), self.params.control_period, p)?;
        Ok(self)
    }

    /// Build a run of any plant: validates the settings, the disturbance and the formulation,
    /// places the chain at rest at `start` ([`ClosedChain::start_state`]; `params.start` is not
    /// read), checks its conditioning, sizes the sensors (`W` = [`ClosedChain::WRENCH_DIM`]
    /// channels per wrist) and the log, and starts the driver with the true wrist wrenches of
    /// the start (zero torque held).
    pub fn with_plant(
        plant: P,
        start: &P::Start,
        sensors: &SensorParams,
        driver: D,
        disturbance: P::Disturbance,
        params: SimParams,
    ) -> Result<Self, ModelError> {
        let (substeps, per_log, ticks) = params.validate()?;
        plant.check_disturbance(&disturbance)?;
        let stepper = plant.stepper(params.formulation)?;
        let mut y = plant.start_state(start)?;
        let mut ws = plant.workspace();
        plant.prime(&mut y, &mut ws);
        let sigma = plant.min_singular_value(&y, &mut ws);
        if sigma < params.min_sigma {
            return Err(ModelError::invalid(
                "start",
                sigma,
                format!(
                    "puts an arm at a singular configuration (σ_min below min_sigma = {})",
                    params.min_sigma
                ),
            ));
        }
        let (n_q, n_arms, w) = (plant.n_q(), plant.n_arms(), P::WRENCH_DIM);
        let sensors = Sensors::with_wrench_dim(sensors, n_q, n_arms, w, params.control_period)?;
        let rows = ticks / per_log + 2;
        let rec = driver.new_record();
        let layout = log::layout(&plant, &rec);
        let bytes = rows as f64 * layout.len() as f64 * 8.0;
        if bytes > MAX_LOG_BYTES {
            return Err(ModelError::invalid(
                "duration",
                params.duration,
                format!(
                    "the log would hold {rows} rows × {} columns = {:.1} GB, more than the {:.1} GB limit: \
                     raise the log period to at least {:.3e} s or shorten the run",
                    layout.len(),
                    bytes / 1e9,
                    MAX_LOG_BYTES / 1e9,
                    params.log_period * (bytes / MAX_LOG_BYTES).ceil()
                ),
            ));
        }
        let log = Log::with_layout(&layout, rows);
        let seg = Segments {
            object: plant.object_columns().len(),
            head: rec.head_columns().len(),
            joints: plant.joint_columns().len(),
            tail: rec.tail_columns().len(),
            drift: plant.drift_columns().len(),
            contacts: plant.contact_columns().len(),
        };
        let has_bounds = driver.truth_margin(&plant, &y).is_some();
        let torque_rate =
            TorqueRateMonitor::new(n_q, params.control_period, TorqueRateParams::default())?;
        let mut sim = Simulation {
            input: plant.zero_input(),
            wrenches: vec![0.0; w * n_arms],
            sensor_truth: vec![0.0; w * n_arms],
            meas: vec![0.0; w * n_arms],
            row: vec![0.0; layout.len()],
            seg,
            stepper,
            plant,
            params,
            // Reset below, once the initial grasp wrenches are known.
            sensors,
            driver,
            disturbance,
            y_prev: y.clone(),
            y,
            ws,
            rec,
            log,
            substeps,
            per_log,
            ticks,
            has_bounds,
            min_margin: f64::INFINITY,
            violation_ticks: 0,
            faults: None,
            torque_rate,
            logging: true,
            joint_limits: None,
        };
        sim.joint_limits = sim
            .driver
            .joint_limit_counts()
            .map(|(r, e)| JointLimitCounts {
                rate_limited: vec![0; r.len()],
                effort_clipped: vec![0; e.len()],
            });
        // Initial wrenches with zero torque held (the object hanging in the arms' grasp).
        let _ = sim.eval_wrenches();
        if let Some(i) = (0..n_arms).find(|&i| {
            !sim.wrenches[w * i..w * i + w]
                .iter()
                .chain(&sim.sensor_truth[w * i..w * i + w])
                .all(|v| v.is_finite())
        }) {
            return Err(ModelError::geometry(
                "gravity",
                format!(
                    "the grasp force of arm {} holding the object at the start is not finite: \
                     gravity, masses or inertias too large",
                    i + 1
                ),
            ));
        }
        let (q, qd) = sim.plant.joints(&sim.y);
        sim.sensors.reset_flat(q, qd, &sim.sensor_truth);
        let meas = Measurements {
            q: sim.sensors.q(),
            qd: sim.sensors.qd(),
            wrenches: &sim.sensor_truth,
        };
        sim.driver.set_control_period(sim.params.control_period);
        sim.driver.start(0.0, &meas);
        Ok(sim)
    }

    /// The plant model.
    pub fn plant(&self) -> &P {
        &self.plant
    }
    /// The flat plant state.
    pub fn state(&self) -> &[f64] {
        &self.y
    }
    /// The plant's workspace after the last evaluation (for the spatial plant, its contact
    /// grasps' record).
    pub fn workspace(&self) -> &P::Workspace {
        &self.ws
    }
    /// Total number of control ticks in the run.
    pub fn total_ticks(&self) -> usize {
        self.ticks
    }
    /// The driver (to inspect a controller after a run).
    pub fn driver(&self) -> &D {
        &self.driver
    }
    /// The driver, to change it between ticks (a test lifting an actuator limit mid-run).
    pub fn driver_mut(&mut self) -> &mut D {
        &mut self.driver
    }
    /// The torque-rate monitor (what it has seen of the applied torques so far).
    pub fn torque_rate(&self) -> &TorqueRateMonitor {
        &self.torque_rate
    }
    /// The sensors (parameters and the latest readings).
    pub fn sensors(&self) -> &Sensors {
        &self.sensors
    }
    /// The grasp wrenches (world axes, flat, `W` per arm) of the state at the start of the last
    /// tick, with the input then held: what the sensors sampled.
    pub fn last_wrenches(&self) -> &[f64] {
        &self.wrenches
    }
    /// The same wrenches as the wrist sensors see them (truth, sensor axes: planar world axes,
    /// spatial tool axes).
    pub fn last_sensor_truth(&self) -> &[f64] {
        &self.sensor_truth
    }
    /// The joint torques held over the last tick (the driver's, after any injected actuator
    /// fault), N m: what the log's `tau_q*` columns show. `&mut` only because the plant's
    /// input gives its torques mutably; nothing changes.
    pub fn applied_torques(&mut self) -> &[f64] {
        P::torques_mut(&mut self.input)
    }
    /// The wrist readings of the last tick (flat, `W` per arm), before any injected fault.
    pub fn last_readings(&self) -> &[f64] {
        &self.meas
    }
    /// **The grasp wrenches of the current state** with the input held: evaluated now
    /// ([`ClosedChain::grasp_wrenches`]), not left over from the last integrator stage. World
    /// axes, flat (`W` per arm). `Err` with the fault when the plant cannot be evaluated there.
    pub fn grasp_wrenches(&mut self) -> Result<&[f64], FaultKind> {
        self.eval_wrenches().map_err(chain_fault)?;
        Ok(&self.wrenches)
    }

    /// Grasp wrenches at the current state with the held input, world axes and sensor axes.
    fn eval_wrenches(&mut self) -> Result<(), ChainFault> {
        let r = self.plant.grasp_wrenches(
            &mut self.stepper,
            &self.y,
            &self.input,
            &mut self.ws,
            &mut self.wrenches,
        );
        self.plant.sensor_wrenches(&self.ws, &mut self.sensor_truth);
        r
    }

    /// A fault record at `t` with the last good state.
    fn fault(&self, t: f64, kind: FaultKind) -> Fault {
        let n = self.plant.n_q();
        let y = &self.y_prev;
        Fault {
            t,
            kind,
            x_o: self.plant.object_pose(y),
            q: y[..n].to_vec(),
        }
    }

    /// Advance one control tick; `Err` stops the run.
    pub fn tick(&mut self, k: usize) -> Result<(), Fault> {
        self.sense(k)?;
        self.act(k)
    }

    /// Step 1 of tick `k`: the grasp wrenches of the state with the input held, the wrist
    /// sensors and the encoders sampled.
    #[inline]
    fn sense(&mut self, k: usize) -> Result<(), Fault> {
        let t = k as f64 * self.params.control_period;
        self.y_prev.copy_from_slice(&self.y);
        if let Err(e) = self.eval_wrenches() {
            return Err(self.fault(t, chain_fault(e)));
        }
        self.plant.gauge(t, &self.y, &mut self.ws);
        let (q, qd) = self.plant.joints(&self.y);
        self.sensors.sample_flat(q, qd, &self.sensor_truth);
        self.sensors.read_wrenches(&mut self.meas);
        Ok(())
    }

    /// Steps 2–5 of tick `k` on what [`sense`](Self::sense) read: the driver, the checks, the
    /// log row, the plant's substeps and the bound bookkeeping.
    #[inline]
    fn act(&mut self, k: usize) -> Result<(), Fault> {
        let hc = self.params.control_period;
        let t = k as f64 * hc;
        // 2. Driver.
        {
            let tau = P::torques_mut(&mut self.input);
            match &mut self.faults {
                Some(fs) => {
                    fs.sense(k, self.sensors.q(), self.sensors.qd(), &self.meas);
                    let meas = Measurements {
                        q: &fs.q,
                        qd: &fs.qd,
                        wrenches: &fs.wrenches,
                    };
                    self.driver.tick(t, &meas, tau, &mut self.rec);
                }
                None => {
                    let meas = Measurements {
                        q: self.sensors.q(),
                        qd: self.sensors.qd(),
                        wrenches: &self.meas,
                    };
                    self.driver.tick(t, &meas, tau, &mut self.rec);
                }
            }
        }
        if let Some(m) = self.driver.failure() {
            let kind = FaultKind::Driver {
                message: m.to_string(),
            };
            return Err(self.fault(t, kind));
        }
        self.driver
            .record_truth(&self.plant, &self.y, &mut self.rec);
        if let Some(fs) = &mut self.faults {
            fs.actuate(hc, P::torques_mut(&mut self.input));
        }
        let disturbance = self.plant.disturb(&self.disturbance, t, &mut self.input);
        // Every value of the tick must be finite before it is logged or integrated.
        if let Some(signal) = self.non_finite_signal().or(disturbance) {
            return Err(self.fault(t, FaultKind::NonFiniteSignal { signal }));
        }
        // The applied torque of the tick, to the rate monitor (reads only).
        self.torque_rate.observe(t, P::torques_mut(&mut self.input));
        // 5 (before advancing): log the state at t_k with the torque chosen at t_k.
        if self.logging && k.is_multiple_of(self.per_log) {
            self.log_row(t);
        }
        // 3. Plant substeps with the input held.
        let t1 = t + hc;
        if let Err(e) = self.plant.step_with(
            &mut self.stepper,
            t,
            &mut self.y,
            &self.input,
            &mut self.ws,
            self.params.plant_step,
            self.substeps,
        ) {
            return Err(self.fault(t1, chain_fault(e)));
        }
        // 4. Health.
        if !crate::math::linalg::finite_slice(&self.y) {
            return Err(self.fault(t1, FaultKind::NonFinite));
        }
        // The output bound on the true pose, every tick.
        if self.has_bounds
            && let Some(m) = self.driver.truth_margin(&self.plant, &self.y)
        {
            self.min_margin = self.min_margin.min(m);
            if m <= 0.0 {
                self.violation_ticks += 1;
            }
        }
        Ok(())
    }

    /// The first non-finite signal of the tick (grasp wrenches, sensor readings, the driver's
    /// record and torques), named as its log column; `None` if all are finite. Allocates only
    /// when it finds one.
    fn non_finite_signal(&mut self) -> Option<String> {
        // The common case, every value finite, in one pass over each buffer without early
        // exit; then only the record's own check. The search below names the first offender.
        if crate::math::linalg::finite_slice(&self.wrenches)
            & crate::math::linalg::finite_slice(&self.sensor_truth)
            & crate::math::linalg::finite_slice(&self.meas)
            & crate::math::linalg::finite_slice(self.sensors.q())
            & crate::math::linalg::finite_slice(self.sensors.qd())
            & crate::math::linalg::finite_slice(P::torques_mut(&mut self.input))
        {
            return self.rec.non_finite();
        }
        let w = P::WRENCH_DIM;
        let fin = |v: &[f64]| v.iter().all(|x| x.is_finite());
        for i in 0..self.plant.n_arms() {
            if !fin(&self.wrenches[w * i..w * i + w]) || !fin(&self.sensor_truth[w * i..w * i + w])
            {
                return Some(format!("the grasp force F{}", i + 1));
            }
        }
        for i in 0..self.plant.n_arms() {
            if !fin(&self.meas[w * i..w * i + w]) {
                return Some(format!("the force-sensor reading F_meas{}", i + 1));
            }
        }
        if let Some(k) = self.sensors.q().iter().position(|v| !v.is_finite()) {
            return Some(format!("the encoder reading q{}", k + 1));
        }
        if let Some(k) = self.sensors.qd().iter().position(|v| !v.is_finite()) {
            return Some(format!("the joint-rate reading qd{}", k + 1));
        }
        if let Some(s) = self.rec.non_finite() {
            return Some(s);
        }
        if let Some(k) = P::torques_mut(&mut self.input)
            .iter()
            .position(|v| !v.is_finite())
        {
            return Some(format!("tau_q{}", k + 1));
        }
        None
    }

    fn log_row(&mut self, t: f64) {
        let drift = self.plant.drift(&self.y, &mut self.ws);
        let s = self.seg;
        let row = &mut self.row;
        row[0] = t;
        let mut c = 1;
        self.plant.write_object(&self.y, &mut row[c..c + s.object]);
        c += s.object;
        self.rec.write_head(&mut row[c..c + s.head]);
        c += s.head;
        let tau = P::torques_mut(&mut self.input);
        row[c..c + tau.len()].copy_from_slice(tau);
        c += tau.len();
        self.plant.write_joints(&self.y, &mut row[c..c + s.joints]);
        c += s.joints;
        row[c..c + self.wrenches.len()].copy_from_slice(&self.wrenches);
        c += self.wrenches.len();
        row[c..c + self.meas.len()].copy_from_slice(&self.meas);
        c += self.meas.len();
        self.rec.write_tail(&mut row[c..c + s.tail]);
        c += s.tail;
        let d = [drift.0, drift.1];
        row[c..c + s.drift].copy_from_slice(&d[..s.drift]);
        c += s.drift;
        self.plant
            .write_contacts(&self.ws, &mut row[c..c + s.contacts]);
        for (col, v) in self.log.columns.iter_mut().zip(row.iter()) {
            col.data.push(*v);
        }
    }

    /// The chain's health at the start of tick `k` (SPEC §3 step 4): constraint drift within
    /// `max_drift`, no arm within `min_sigma` of a singularity. The drift `(position,
    /// rotation)` measured, whether or not it faults (the run's maxima include the drift that
    /// stopped it).
    fn check_chain(&mut self, k: usize) -> ((f64, f64), Result<(), Fault>) {
        let t = k as f64 * self.params.control_period;
        let ((d, r), s) = self
            .plant
            .drift_and_min_singular_value(&self.y, &mut self.ws);
        if d > self.params.max_drift || r > self.params.max_drift {
            self.y_prev.copy_from_slice(&self.y);
            let rotation = (self.seg.drift > 1).then_some(r);
            let f = self.fault(t, FaultKind::ConstraintDrift { drift: d, rotation });
            return ((d, r), Err(f));
        }
        if s < self.params.min_sigma {
            self.y_prev.copy_from_slice(&self.y);
            return ((d, r), Err(self.fault(t, FaultKind::Singular { sigma: s })));
        }
        ((d, r), Ok(()))
    }

    /// The driver's per-joint limit counts, copied into the buffers sized at set-up and moved
    /// out (no allocation; `None` when the driver has no actuator stage or the counts changed
    /// length, which a driver does not do).
    fn take_joint_limits(&mut self) -> Option<JointLimitCounts> {
        let (r, e) = self.driver.joint_limit_counts()?;
        let mut out = self.joint_limits.take()?;
        if out.rate_limited.len() != r.len() || out.effort_clipped.len() != e.len() {
            return None;
        }
        out.rate_limited.copy_from_slice(r);
        out.effort_clipped.copy_from_slice(e);
        Some(out)
    }

    /// Run to the end (or the first fault). `progress(fraction)` is called about 200 times.
    pub fn run(mut self, mut progress: impl FnMut(f64)) -> (Outcome, Self) {
        let start = Instant::now();
        let mut fault = None;
        let mut max_drift: f64 = 0.0;
        let mut max_drift_rot: f64 = 0.0;
        let every = (self.ticks / 200).max(1);
        let mut k = 0;
        while k < self.ticks {
            if let Err(f) = self.tick(k) {
                fault = Some(f);
                break;
            }
            k += 1;
            // Drift and singularity checks every 10 ticks (kinematics only, once for both).
            if k % 10 == 0 {
                let ((d, r), health) = self.check_chain(k);
                max_drift = max_drift.max(d);
                max_drift_rot = max_drift_rot.max(r);
                if let Err(f) = health {
                    fault = Some(f);
                    break;
                }
            }
            if k % every == 0 {
                progress(k as f64 / self.ticks as f64);
            }
        }
        let wall_time = start.elapsed().as_secs_f64();
        let out = Outcome {
            log: std::mem::take(&mut self.log),
            fault,
            events: self.driver.events(),
            ticks: k,
            t_end: k as f64 * self.params.control_period,
            wall_time,
            max_drift,
            max_drift_rot,
            regularised: P::regularised(&self.ws),
            min_margin: self.has_bounds.then_some(self.min_margin),
            violation_ticks: self.violation_ticks,
            torque_rate: self.torque_rate.take(),
            joint_limits: self.take_joint_limits(),
        };
        (out, self)
    }
}
