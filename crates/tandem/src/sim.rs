//! The simulation loop (SPEC §3 step order, §2.4 integration, §5 outputs).
//!
//! Per control tick `k` at `t_k = k h_c`:
//! 1. grasp forces at `(y(t_k), u_{k−1})` (the input still held) → force sensors; encoders;
//! 2. the driver (a [`Controller`] or a torque [`Replay`]) → joint torques `u_k`, actuator limits;
//! 3. `F_d(t_k)`; the plant advances `h_c / h_p` RK4 substeps with `(u_k, F_d)` held (ZOH);
//! 4. health checks (non-finite state, constraint drift, singular arms) → a [`Fault`] stops the
//!    run cleanly with the time and the state;
//! 5. every `log_period`, one row into the preallocated [`Log`].
//!
//! Deterministic: the only randomness is in the seeded sensors.

use std::time::Instant;

use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::control::{ControlEvents, Controller, Measurements, TickRecord};
use crate::disturbance::Disturbance;
use crate::error::{ModelError, positive};
use crate::faults::{FaultState, Faults};
use crate::integrate::Rk4;
use crate::plant::{ConstrainedOde, Plant, PlantInput, PlantParams, PlantWorkspace, ReducedOde};
use crate::sensors::{SensorParams, Sensors};

/// Which plant formulation integrates the truth (SPEC §2.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Formulation {
    /// Joints + object with Lagrange multipliers (default; any arms).
    #[default]
    Constrained,
    /// Object coordinates only, (14) (2-link arms).
    Reduced,
}

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
    /// Start pose of the object, (m, m, rad); at rest.
    pub start: [f64; 3],
    /// Plant formulation.
    #[serde(default)]
    pub formulation: Formulation,
    /// Largest grasp-constraint drift tolerated before the run stops, m.
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

/// What produces the joint torques.
pub enum Driver {
    /// A cooperative controller (boxed: it owns sizeable buffers).
    Controller(Box<Controller>),
    /// A torque replay.
    Replay(Replay),
}

/// What went wrong numerically.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FaultKind {
    /// The plant state became non-finite.
    NonFinite,
    /// The grasp constraints drifted beyond `max_drift`.
    ConstraintDrift {
        /// Drift, m.
        drift: f64,
    },
    /// An arm came within `min_sigma` of a singular configuration.
    Singular {
        /// Smallest singular value, m/rad.
        sigma: f64,
    },
    /// The reduced formulation could not be evaluated (IK out of reach or singular arm).
    Reduced,
    /// A signal of the tick (grasp force, sensor reading, controller internal or output) became
    /// non-finite; it is named as its log column (`F_meas1.x`, `x_r.y`, `tau_q2`, ...).
    NonFiniteSignal {
        /// The signal.
        signal: String,
    },
}

/// Why a run stopped early: what, when, and the last good state (never a NaN one).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fault {
    /// Time of detection, s.
    pub t: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: FaultKind,
    /// Object pose of the last good state, (m, m, rad).
    pub x_o: [f64; 3],
    /// Joint angles of the last good state, rad.
    pub q: Vec<f64>,
}

/// A number for a message in its shortest form, with an exponent outside [1e-4, 1e6)
/// (`0.001`, `1e-300`), never hundreds of digits.
fn short(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 || (1e-4..1e6).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A number for a message: fixed point for ordinary magnitudes, an exponent otherwise (a
/// diverged state prints as `1.7e96`, never as a 97-digit number).
fn readable(v: f64, decimals: usize) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 || (1e-3..1e6).contains(&a) {
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = self.t;
        match &self.kind {
            FaultKind::NonFinite => write!(f, "the plant state became non-finite at t = {t:.4} s")?,
            FaultKind::ConstraintDrift { drift } => {
                write!(f, "grasp constraint drift {drift:.3e} m at t = {t:.4} s")?
            }
            FaultKind::Singular { sigma } => write!(
                f,
                "an arm reached a singular configuration (σ_min = {sigma:.3e} m/rad) at t = {t:.4} s"
            )?,
            FaultKind::Reduced => write!(
                f,
                "the reduced formulation failed (grasp out of reach or singular arm) at t = {t:.4} s"
            )?,
            FaultKind::NonFiniteSignal { signal } => {
                write!(f, "{signal} became non-finite at t = {t:.4} s")?
            }
        }
        let q: Vec<String> = self.q.iter().map(|v| readable(*v, 4)).collect();
        write!(
            f,
            "; last good state x_o = ({}, {}, {}), q = [{}]",
            readable(self.x_o[0], 5),
            readable(self.x_o[1], 5),
            readable(self.x_o[2], 5),
            q.join(", ")
        )
    }
}

/// One logged column: name, unit and samples (capacity reserved at start).
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// Name, e.g. `x_o.x`.
    pub name: String,
    /// Unit, e.g. `m`.
    pub unit: String,
    /// Samples.
    pub data: Vec<f64>,
}

/// The time series of a run (SPEC §5), column-major, preallocated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Log {
    /// Columns in a fixed order (see [`Log::names`]).
    pub columns: Vec<Column>,
}

impl Log {
    fn with_layout(layout: &[(String, String)], rows: usize) -> Self {
        Log {
            columns: layout
                .iter()
                .map(|(n, u)| Column {
                    name: n.clone(),
                    unit: u.clone(),
                    data: Vec::with_capacity(rows),
                })
                .collect(),
        }
    }
    /// Column by name.
    pub fn get(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .map(|c| c.data.as_slice())
    }
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, |c| c.data.len())
    }
    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Column names with units, `name [unit]`.
    pub fn names(&self) -> Vec<String> {
        self.columns
            .iter()
            .map(|c| format!("{} [{}]", c.name, c.unit))
            .collect()
    }
}

const AX: [&str; 3] = ["x", "y", "theta"];

fn layout(n_q: usize, n_arms: usize) -> Vec<(String, String)> {
    let mut l: Vec<(String, String)> = vec![("t".into(), "s".into())];
    let lin = |j: usize, m: &str, r: &str| if j < 2 { m.to_string() } else { r.to_string() };
    for (group, (m, r)) in [
        ("x_o", ("m", "rad")),
        ("x_hat", ("m", "rad")),
        ("x_d", ("m", "rad")),
        ("x_r", ("m", "rad")),
        ("z1", ("m", "rad")),
        ("z2", ("m/s", "rad/s")),
        ("alpha", ("m/s", "rad/s")),
        ("alpha_dot", ("m/s^2", "rad/s^2")),
        ("tau", ("N", "N m")),
        ("w_norm", ("1", "1")),
    ] {
        for (j, a) in AX.iter().enumerate() {
            l.push((format!("{group}.{a}"), lin(j, m, r)));
        }
    }
    for k in 0..n_q {
        l.push((format!("tau_q{}", k + 1), "N m".into()));
    }
    for k in 0..n_q {
        l.push((format!("q{}", k + 1), "rad".into()));
    }
    for i in 0..n_arms {
        for a in ["x", "y"] {
            l.push((format!("F{}.{a}", i + 1), "N".into()));
        }
    }
    for i in 0..n_arms {
        for a in ["x", "y"] {
            l.push((format!("F_meas{}.{a}", i + 1), "N".into()));
        }
    }
    l.push(("Q".into(), "1".into()));
    l.push(("margin".into(), "1".into()));
    l.push(("drift".into(), "m".into()));
    l
}

/// The result of a run.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The log (rows up to the stop).
    pub log: Log,
    /// Why the run stopped early, if it did.
    pub fault: Option<Fault>,
    /// Controller event counters (zero for a replay).
    pub events: ControlEvents,
    /// Ticks simulated.
    pub ticks: usize,
    /// Simulated time reached, s.
    pub t_end: f64,
    /// Wall time of the loop (outputs excluded), s.
    pub wall_time: f64,
    /// Largest constraint drift seen, m.
    pub max_drift: f64,
    /// Evaluations that needed a regularised grasp-space solve.
    pub regularised: u64,
    /// Smallest constraint margin `1 − max_j |x_o,j|/k_cj` of the true pose over every control
    /// tick (not only logged rows); `None` for a replay (no bounds).
    pub min_margin: Option<f64>,
    /// Control ticks that ended with the true pose on or outside the bound.
    pub violation_ticks: u64,
}

/// A simulation: plant, sensors, driver, state, scratch and the log.
pub struct Simulation {
    plant: Plant,
    params: SimParams,
    sensors: Sensors,
    driver: Driver,
    disturbance: Disturbance,
    y: Vec<f64>,
    y_prev: Vec<f64>,
    y_red: [f64; 6],
    ws: PlantWorkspace,
    rk: Rk4,
    rk_red: Rk4,
    input: PlantInput,
    dy: Vec<f64>,
    forces: Vec<Vector2<f64>>,
    rec: TickRecord,
    log: Log,
    substeps: usize,
    per_log: usize,
    ticks: usize,
    /// Output bounds of the controller (per-tick margin tracking), if any.
    k_c: Option<Vector3<f64>>,
    min_margin: f64,
    violation_ticks: u64,
    /// Injected sensor and actuator faults ([`Simulation::with_faults`]).
    faults: Option<Box<FaultState>>,
}

impl Simulation {
    /// Inject sensor and actuator faults between the plant and the driver (see
    /// [`crate::faults`]); errors name the field (`faults.force_delay`, ...).
    pub fn with_faults(mut self, f: &Faults) -> Result<Self, ModelError> {
        self.faults = if f.any() {
            let st = f.state(
                self.params.control_period,
                self.plant.n_q(),
                self.forces.len(),
            )?;
            Some(Box::new(st))
        } else {
            None
        };
        Ok(self)
    }

    /// Build a run: validates every part, places the chain at the start pose (analytic IK for
    /// 2-link arms, `q_guess` for others) and starts the driver.
    pub fn new(
        plant: &PlantParams,
        sensors: &SensorParams,
        driver: Driver,
        disturbance: Disturbance,
        params: SimParams,
        q_guess: Option<&[f64]>,
    ) -> Result<Self, ModelError> {
        let (substeps, per_log, ticks) = params.validate()?;
        disturbance.validate()?;
        let plant = Plant::new(plant)?;
        if params.formulation == Formulation::Reduced && plant.arms().iter().any(|a| a.dof() != 2) {
            return Err(ModelError::geometry(
                "formulation",
                "the reduced formulation needs 2-link arms",
            ));
        }
        let x0 = Vector3::from(params.start);
        let y = plant.initial_state(x0, Vector3::zeros(), q_guess)?;
        let mut ws = plant.workspace();
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
        let n_arms = plant.arms().len();
        let sensors = Sensors::new(sensors, plant.n_q(), n_arms, params.control_period)?;
        let rows = ticks / per_log + 2;
        let layout = layout(plant.n_q(), n_arms);
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
        let n = plant.state_dim();
        let mut sim = Simulation {
            input: plant.zero_input(),
            dy: vec![0.0; n],
            forces: vec![Vector2::zeros(); n_arms],
            rk: Rk4::new(n),
            rk_red: Rk4::new(6),
            y_red: [x0.x, x0.y, x0.z, 0.0, 0.0, 0.0],
            plant,
            params,
            // Reset below, once the initial grasp forces are known.
            sensors,
            driver,
            disturbance,
            y_prev: y.clone(),
            y,
            ws,
            rec: TickRecord::default(),
            log,
            substeps,
            per_log,
            ticks,
            k_c: None,
            min_margin: f64::INFINITY,
            violation_ticks: 0,
            faults: None,
        };
        if let Driver::Controller(c) = &sim.driver {
            sim.k_c = Some(c.k_c());
        }
        // Initial forces with zero torque held (the object hanging in the arms' grasp).
        sim.eval_forces();
        if let Some(i) = sim
            .forces
            .iter()
            .position(|f| !(f.x.is_finite() && f.y.is_finite()))
        {
            return Err(ModelError::geometry(
                "gravity",
                format!(
                    "the grasp force of arm {} holding the object at the start is not finite: \
                     gravity, masses or inertias too large",
                    i + 1
                ),
            ));
        }
        let (q, _, qd, _) = sim.plant.split(&sim.y);
        sim.sensors.reset(q, qd, &sim.forces);
        if let Driver::Controller(c) = &mut sim.driver {
            let meas = Measurements {
                q: sim.sensors.q(),
                qd: sim.sensors.qd(),
                forces: &sim.forces,
            };
            c.start(0.0, &meas);
        }
        Ok(sim)
    }

    /// The plant model.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }
    /// The flat plant state.
    pub fn state(&self) -> &[f64] {
        &self.y
    }
    /// Total number of control ticks in the run.
    pub fn total_ticks(&self) -> usize {
        self.ticks
    }
    /// The driver (to inspect a controller after a run).
    pub fn driver(&self) -> &Driver {
        &self.driver
    }

    /// Grasp forces at the current state with the held input.
    fn eval_forces(&mut self) -> bool {
        let ok = match self.params.formulation {
            Formulation::Constrained => {
                self.plant
                    .derivative(&self.y, &self.input, &mut self.ws, &mut self.dy)
            }
            Formulation::Reduced => {
                let mut d = [0.0; 6];
                self.plant
                    .reduced_derivative(&self.y_red, &self.input, &mut self.ws, &mut d)
                    .is_ok()
            }
        };
        self.forces.copy_from_slice(&self.ws.forces);
        ok
    }

    /// Reduced runs keep the joint part of `y` in step with the object (for sensors and logs).
    fn sync_reduced(&mut self) -> bool {
        let n = self.plant.n_q();
        let x = Vector3::new(self.y_red[0], self.y_red[1], self.y_red[2]);
        let xd = Vector3::new(self.y_red[3], self.y_red[4], self.y_red[5]);
        let (q, rest) = self.y.split_at_mut(n);
        let (xo, rest) = rest.split_at_mut(3);
        let (qd, xdo) = rest.split_at_mut(n);
        xo.copy_from_slice(x.as_slice());
        xdo.copy_from_slice(xd.as_slice());
        self.plant
            .arms_from_object(&x, &xd, q, qd, &mut self.ws)
            .is_ok()
    }

    /// A fault record at `t` with the last good state.
    fn fault(&self, t: f64, kind: FaultKind) -> Fault {
        let n = self.plant.n_q();
        let y = &self.y_prev;
        Fault {
            t,
            kind,
            x_o: [y[n], y[n + 1], y[n + 2]],
            q: y[..n].to_vec(),
        }
    }

    /// Advance one control tick; `Err` stops the run.
    pub fn tick(&mut self, k: usize) -> Result<(), Fault> {
        let hc = self.params.control_period;
        let t = k as f64 * hc;
        self.y_prev.copy_from_slice(&self.y);
        // 1. Sensors.
        if !self.eval_forces() {
            return Err(self.fault(t, FaultKind::Reduced));
        }
        {
            let (q, _, qd, _) = self.plant.split(&self.y);
            self.sensors.sample(q, qd, &self.forces);
        }
        // 2. Driver.
        match &mut self.driver {
            Driver::Controller(c) => {
                let n_arms = self.forces.len();
                for i in 0..n_arms {
                    self.forces[i] = self.sensors.force(i);
                }
                match &mut self.faults {
                    Some(fs) => {
                        fs.sense(k, self.sensors.q(), self.sensors.qd(), &self.forces);
                        let meas = Measurements {
                            q: &fs.q,
                            qd: &fs.qd,
                            forces: &fs.forces,
                        };
                        c.tick(t, &meas, &mut self.input.tau, &mut self.rec);
                    }
                    None => {
                        let meas = Measurements {
                            q: self.sensors.q(),
                            qd: self.sensors.qd(),
                            forces: &self.forces,
                        };
                        c.tick(t, &meas, &mut self.input.tau, &mut self.rec);
                    }
                }
            }
            Driver::Replay(r) => {
                self.input.tau.copy_from_slice(r.at(t));
                let (_, x, _, xd) = self.plant.split(&self.y);
                self.rec = TickRecord {
                    x_o: x,
                    xd_o: xd,
                    q_switch: 1.0,
                    ..TickRecord::default()
                };
            }
        }
        if let Some(fs) = &mut self.faults {
            fs.actuate(hc, &mut self.input.tau);
        }
        self.input.f_d = self.disturbance.at(t);
        // Every value of the tick must be finite before it is logged or integrated.
        if let Some(signal) = self.non_finite_signal() {
            return Err(self.fault(t, FaultKind::NonFiniteSignal { signal }));
        }
        // 5 (before advancing): log the state at t_k with the torque chosen at t_k.
        if k % self.per_log == 0 {
            self.log_row(t);
        }
        // 3. Plant substeps with the input held.
        let hp = self.params.plant_step;
        match self.params.formulation {
            Formulation::Constrained => {
                let mut sys = ConstrainedOde {
                    plant: &self.plant,
                    ws: &mut self.ws,
                    input: &self.input,
                };
                self.rk.substeps(
                    &mut sys,
                    t,
                    &mut self.y,
                    hp * self.substeps as f64,
                    self.substeps,
                );
            }
            Formulation::Reduced => {
                let mut sys = ReducedOde {
                    plant: &self.plant,
                    ws: &mut self.ws,
                    input: &self.input,
                };
                self.rk_red.substeps(
                    &mut sys,
                    t,
                    &mut self.y_red,
                    hp * self.substeps as f64,
                    self.substeps,
                );
                if !self.y_red.iter().all(|v| v.is_finite()) {
                    return Err(self.fault(t + hc, FaultKind::NonFinite));
                }
                if !self.sync_reduced() {
                    return Err(self.fault(t + hc, FaultKind::Reduced));
                }
            }
        }
        // 4. Health.
        let t1 = t + hc;
        if !self.y.iter().all(|v| v.is_finite()) {
            return Err(self.fault(t1, FaultKind::NonFinite));
        }
        // The output bound on the true pose, every tick.
        if let Some(k) = self.k_c {
            let n = self.plant.n_q();
            let m = (0..3)
                .map(|j| 1.0 - self.y[n + j].abs() / k[j])
                .fold(f64::INFINITY, f64::min);
            self.min_margin = self.min_margin.min(m);
            if m <= 0.0 {
                self.violation_ticks += 1;
            }
        }
        Ok(())
    }

    /// The first non-finite signal of the tick (grasp forces, sensor readings, the driver's
    /// record and torques, the disturbance), named as its log column; `None` if all are
    /// finite. Allocates only when it finds one.
    fn non_finite_signal(&self) -> Option<String> {
        const AX: [&str; 3] = ["x", "y", "theta"];
        let fin = |v: &Vector2<f64>| v.x.is_finite() && v.y.is_finite();
        for (i, f) in self.ws.forces.iter().enumerate() {
            if !fin(f) {
                return Some(format!("the grasp force F{}", i + 1));
            }
        }
        for (i, f) in self.forces.iter().enumerate() {
            if !fin(&self.sensors.force(i)) || !fin(f) {
                return Some(format!("the force-sensor reading F_meas{}", i + 1));
            }
        }
        if let Some(k) = self.sensors.q().iter().position(|v| !v.is_finite()) {
            return Some(format!("the encoder reading q{}", k + 1));
        }
        if let Some(k) = self.sensors.qd().iter().position(|v| !v.is_finite()) {
            return Some(format!("the joint-rate reading qd{}", k + 1));
        }
        let r = &self.rec;
        let groups = [
            ("x_hat", &r.x_o),
            ("x_d", &r.x_d),
            ("x_r", &r.x_r),
            ("z1", &r.z1),
            ("z2", &r.z2),
            ("alpha", &r.alpha),
            ("alpha_dot", &r.alpha_dot),
            ("tau", &r.wrench),
            ("w_norm", &r.w_norm),
        ];
        for (name, v) in groups {
            if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                return Some(format!("{name}.{}", AX[j]));
            }
        }
        if !r.q_switch.is_finite() {
            return Some("Q".into());
        }
        if !r.margin.is_finite() {
            return Some("margin".into());
        }
        if r.non_finite {
            return Some("a controller input or output (replaced by the controller)".into());
        }
        if let Some(k) = self.input.tau.iter().position(|v| !v.is_finite()) {
            return Some(format!("tau_q{}", k + 1));
        }
        if let Some(j) = self.input.f_d.iter().position(|v| !v.is_finite()) {
            return Some(format!("the disturbance F_d.{}", AX[j]));
        }
        None
    }

    fn log_row(&mut self, t: f64) {
        let (_, x, _, _) = self.plant.split(&self.y);
        let drift = self.plant.constraint_residual(&self.y, &mut self.ws).0;
        let r = &self.rec;
        let mut vals = [0.0f64; 31];
        vals[0] = t;
        let groups = [
            x,
            r.x_o,
            r.x_d,
            r.x_r,
            r.z1,
            r.z2,
            r.alpha,
            r.alpha_dot,
            r.wrench,
            r.w_norm,
        ];
        for (g, v) in groups.iter().enumerate() {
            for j in 0..3 {
                vals[1 + 3 * g + j] = v[j];
            }
        }
        let mut c = 0;
        for v in vals {
            self.log.columns[c].data.push(v);
            c += 1;
        }
        for k in 0..self.input.tau.len() {
            self.log.columns[c].data.push(self.input.tau[k]);
            c += 1;
        }
        let n_q = self.plant.n_q();
        for k in 0..n_q {
            self.log.columns[c].data.push(self.y[k]);
            c += 1;
        }
        for f in &self.ws.forces {
            self.log.columns[c].data.push(f.x);
            self.log.columns[c + 1].data.push(f.y);
            c += 2;
        }
        for i in 0..self.forces.len() {
            let f = self.sensors.force(i);
            self.log.columns[c].data.push(f.x);
            self.log.columns[c + 1].data.push(f.y);
            c += 2;
        }
        self.log.columns[c].data.push(r.q_switch);
        self.log.columns[c + 1].data.push(r.margin);
        self.log.columns[c + 2].data.push(drift);
    }

    /// Run to the end (or the first fault). `progress(fraction)` is called about 200 times.
    pub fn run(mut self, mut progress: impl FnMut(f64)) -> (Outcome, Self) {
        let start = Instant::now();
        let mut fault = None;
        let mut max_drift: f64 = 0.0;
        let every = (self.ticks / 200).max(1);
        let mut k = 0;
        while k < self.ticks {
            if let Err(f) = self.tick(k) {
                fault = Some(f);
                break;
            }
            k += 1;
            // Drift and singularity checks every 10 ticks (kinematics only).
            if k % 10 == 0 {
                let t = k as f64 * self.params.control_period;
                let d = self.plant.constraint_residual(&self.y, &mut self.ws).0;
                max_drift = max_drift.max(d);
                if d > self.params.max_drift {
                    self.y_prev.copy_from_slice(&self.y);
                    fault = Some(self.fault(t, FaultKind::ConstraintDrift { drift: d }));
                    break;
                }
                let s = self.plant.min_singular_value(&self.y, &mut self.ws);
                if s < self.params.min_sigma {
                    self.y_prev.copy_from_slice(&self.y);
                    fault = Some(self.fault(t, FaultKind::Singular { sigma: s }));
                    break;
                }
            }
            if k % every == 0 {
                progress(k as f64 / self.ticks as f64);
            }
        }
        let wall_time = start.elapsed().as_secs_f64();
        let events = match &self.driver {
            Driver::Controller(c) => c.events(),
            Driver::Replay(_) => ControlEvents::default(),
        };
        let out = Outcome {
            log: std::mem::take(&mut self.log),
            fault,
            events,
            ticks: k,
            t_end: k as f64 * self.params.control_period,
            wall_time,
            max_drift,
            regularised: self.ws.regularised,
            min_margin: self.k_c.map(|_| self.min_margin),
            violation_ticks: self.violation_ticks,
        };
        (out, self)
    }
}
