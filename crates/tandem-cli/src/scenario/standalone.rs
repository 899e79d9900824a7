//! A scenario's controller outside tandem's loop (issue 23): built by the same functions as
//! `tandem run` ([`planar::make_controller`], [`spatial::make_controller`], which
//! `make_simulation` calls), with the start state a run begins from, to be stepped with the
//! caller's own measurements ([`Standalone::start`], [`Standalone::tick`]).
//!
//! The loop contract is the simulation's ([`tandem::drive`]): `start(t0, …)` once with the
//! first readings, then `tick(t, …)` every control period from `t0` on (the first tick at `t0`
//! itself); the controller integrates its internal states with the scenario's control period,
//! whatever the spacing of the `t` it is given. Wrenches are the wrist readings of
//! [`Measurements`]: planar, the object's force on each end effector in world axes (2 per arm,
//! N); spatial, the object's wrench `[f; τ]` on each tool, about the tool origin, in tool axes
//! (6 per arm, N and N m).
//!
//! [`Standalone::try_start`] and [`Standalone::try_tick`] check what a caller outside Rust can
//! get wrong (lengths, NaN or infinity, a time that goes back, a tick before the start) and
//! return an [`InputError`] naming the argument, the state untouched; the Python `Controller`
//! and the C ABI (`tandem-ffi`) both go through them.

use tandem::control::planar::{Controller, TickRecord};
use tandem::control::spatial::{SpatialController, SpatialTickRecord};
use tandem::drive::{ControlEvents, Measurements};
use tandem::plant::planar::Plant;
use tandem::plant::spatial::SpatialPlant;
use tandem::sim::{Held, Stepped};

use super::planar::{self, PlanarScenario};
use super::source::{ScenarioError, Source};
use super::spatial::{self, SpatialScenario};
use super::tables::{ControllerChoice, ControllerKind};

/// The controller of either kind with its tick record.
pub enum Law {
    /// The planar controller.
    Planar(Box<Controller>, Box<TickRecord>),
    /// The spatial controller.
    Spatial(Box<SpatialController>, Box<SpatialTickRecord>),
}

/// Where a run starts: the encoder readings and the wrist readings the run's driver is started
/// with (the chain at rest on the start pose, zero torque held).
#[derive(Clone, Debug, PartialEq)]
pub struct StartState {
    /// Joint angles, stacked over arms, rad.
    pub q: Vec<f64>,
    /// Joint rates, rad/s (zero: at rest).
    pub qd: Vec<f64>,
    /// Wrist readings, flat, `wrench_dim` per arm.
    pub wrenches: Vec<f64>,
}

/// A bad argument to [`Standalone::try_start`] or [`Standalone::try_tick`]: which one and why.
/// Nothing was changed by the call that returned it.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum InputError {
    /// A slice of the wrong length.
    Length {
        /// The argument: `q`, `qd`, `wrenches` or `tau`.
        arg: &'static str,
        /// Its length, `n_q` or `n_arms · wrench_dim`.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// NaN or infinity in a measurement.
    NonFinite {
        /// The argument: `q`, `qd` or `wrenches`.
        arg: &'static str,
        /// The first offending index in the flat slice.
        index: usize,
        /// Row length when the argument is a matrix (`wrenches`: `wrench_dim`, read as
        /// `[arm, channel]`); 0 for a vector.
        cols: usize,
        /// The value found there.
        value: f64,
    },
    /// A time that is NaN or infinite.
    Time {
        /// The time given, s.
        t: f64,
    },
    /// A tick at or before the previous tick (or before the start).
    TimeBack {
        /// The time given, s.
        t: f64,
        /// The previous start or tick, s.
        last: f64,
        /// Whether `last` was a tick (else the start, which the first tick may equal).
        after_tick: bool,
    },
    /// A tick before any start (or after a reset).
    NotStarted,
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            InputError::Length { arg, expected, got } => {
                write!(f, "{arg}: expected length {expected}, got {got}")
            }
            InputError::NonFinite {
                arg,
                index,
                cols,
                value,
            } => {
                match index.checked_div(cols) {
                    Some(row) => write!(f, "{arg}[{row}, {}]", index % cols)?,
                    None => write!(f, "{arg}[{index}]")?,
                }
                write!(f, " = {value}: every value must be finite")
            }
            InputError::Time { t } => write!(f, "t = {t}: must be finite"),
            InputError::TimeBack {
                t,
                last,
                after_tick,
            } => write!(
                f,
                "t = {t}: time went back (the previous {} was at t = {last}); ticks must advance",
                if after_tick { "tick" } else { "start" }
            ),
            InputError::NotStarted => {
                write!(
                    f,
                    "tick before start: call start(t0, q, qd, wrenches) first"
                )
            }
        }
    }
}

impl std::error::Error for InputError {}

/// `t` is finite.
pub fn check_time(t: f64) -> Result<(), InputError> {
    if t.is_finite() {
        Ok(())
    } else {
        Err(InputError::Time { t })
    }
}

/// Every value of `v` (the argument `arg`; a matrix of rows of `cols`, or a vector when `cols`
/// is 0) is finite.
pub fn check_finite(arg: &'static str, v: &[f64], cols: usize) -> Result<(), InputError> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(InputError::NonFinite {
            arg,
            index,
            cols,
            value: v[index],
        }),
    }
}

/// `v` (the argument `arg`) has `expected` values.
pub fn check_len(arg: &'static str, v: &[f64], expected: usize) -> Result<(), InputError> {
    if v.len() == expected {
        Ok(())
    } else {
        Err(InputError::Length {
            arg,
            expected,
            got: v.len(),
        })
    }
}

/// A scenario's controller, ready to be started and ticked by the caller.
pub struct Standalone {
    /// The controller and its record.
    pub law: Law,
    /// Joints, all arms.
    pub n_q: usize,
    /// Arms.
    pub n_arms: usize,
    /// Wrench channels per arm: 2 (planar force) or 6 (spatial `[f; τ]`).
    pub wrench_dim: usize,
    /// The scenario's control period, s.
    pub control_period: f64,
    /// The run's start state.
    pub start: StartState,
    /// What the first readings should look like ([`Standalone::check_start`]).
    pub expect: StartExpectation,
    /// The time of the last start or tick; `None` before the start.
    t_last: Option<f64>,
    /// Whether a tick has run since the start (the first may be at the start's time).
    ticked: bool,
}

/// What a controller expects of its first wrist readings (issue 23's sensor sanity check): the
/// readings of a robot holding the object at rest on the start pose, and the frame each
/// reading is in.
#[derive(Clone, Debug, PartialEq)]
pub struct StartExpectation {
    /// The readings (flat, `wrench_dim` per arm, sensor axes) of a static hold at the start
    /// pose: spatial, the plant's holding torques held (the arms share the weight, no internal
    /// wrench); planar, an equal share of the object's weight.
    pub hold: Vec<f64>,
    /// Each arm's sensor axes in world axes (row-major 3×3; the identity for planar arms,
    /// whose readings are in world axes).
    pub axes: Vec<[[f64; 3]; 3]>,
}

/// How far the sum of the first readings' forces (world axes) may be from the hold's, as a
/// fraction of the object's weight: a held object under a controller's internal squeeze or a
/// sensor bias passes; a flipped sign, a reading in the wrong axes or in the wrong unit does
/// not.
pub const START_TOLERANCE: f64 = 0.25;

/// Refuse a torque replay: it is not a controller.
fn no_replay(src: &Source, kind: ControllerKind) -> Result<(), ScenarioError> {
    if kind == ControllerKind::Replay {
        return Err(src.error_at(
            "controller.kind",
            format!(
                "controller.kind = \"replay\": a torque replay is not a controller; choose a law ({})",
                ControllerChoice::LAWS.join(", ")
            ),
        ));
    }
    Ok(())
}

/// The planar scenario's controller (law `law`, or the scenario's), every check of a run.
pub fn planar(
    sc: &PlanarScenario,
    src: &Source,
    law: Option<ControllerChoice>,
) -> Result<Standalone, ScenarioError> {
    let mut sc = sc.clone();
    if let Some(l) = law {
        sc.apply(&super::Overrides::law(l))
            .map_err(|e| src.error_at("controller.kind", e.to_string()))?;
    }
    no_replay(src, sc.controller.kind)?;
    let built = planar::build(&sc, src)?;
    // The whole set-up of a run (the start pose, the sensors), for the start state.
    let ready = planar::make_simulation(&sc, &built, src)?;
    super::check_finite(src, &sc)?;
    let cp = built
        .controller
        .as_ref()
        .ok_or_else(|| src.error_at("controller.kind", "the scenario has no controller"))?;
    let mut warnings = Vec::new();
    let c = planar::make_controller(&sc, &built, cp, src, &mut warnings)?;
    let sim = &ready.sim;
    let n_q = sim.sensors().q().len();
    let n_arms = built.plant.arms.len();
    // A static hold: each end effector carries an equal share of the object's weight (its
    // force on each, world axes: `−G_o / n`, SPEC §1's sign).
    let g = tandem::plant::planar::Plant::new(built.truth.as_ref().unwrap_or(&built.plant))
        .map(|p| p.object().G_o)
        .map_err(|e| src.error_at("object", e.to_string()))?;
    let share = [-g.x / n_arms as f64, -g.y / n_arms as f64];
    let expect = StartExpectation {
        hold: (0..n_arms).flat_map(|_| share).collect(),
        axes: vec![[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]; n_arms],
    };
    Ok(Standalone {
        law: Law::Planar(Box::new(c), Box::default()),
        n_q,
        n_arms,
        wrench_dim: 2,
        control_period: built.sim.control_period,
        start: StartState {
            q: sim.sensors().q().to_vec(),
            qd: sim.sensors().qd().to_vec(),
            wrenches: sim.last_sensor_truth().to_vec(),
        },
        expect,
        t_last: None,
        ticked: false,
    })
}

/// The spatial scenario's controller (law `law`, or the scenario's), every check of a run
/// (the NN law's design-inertia probe included).
pub fn spatial(
    sc: &SpatialScenario,
    src: &Source,
    law: Option<ControllerChoice>,
) -> Result<Standalone, ScenarioError> {
    let mut sc = sc.clone();
    if let Some(l) = law {
        sc.apply(&super::Overrides::law(l))
            .map_err(|e| src.error_at("controller.kind", e.to_string()))?;
    }
    no_replay(src, sc.controller.kind)?;
    let built = spatial::build(&sc, src)?;
    let ready = spatial::make_simulation(&sc, &built, src)?;
    super::check_finite(src, &sc)?;
    let d = spatial::make_controller(&sc, &built, src)?;
    let (start, n_q) = match &ready.sim {
        spatial::SpatialSim::Control(s) => (
            StartState {
                q: s.sensors().q().to_vec(),
                qd: s.sensors().qd().to_vec(),
                wrenches: s.last_sensor_truth().to_vec(),
            },
            s.sensors().q().len(),
        ),
        spatial::SpatialSim::Replay(_) | spatial::SpatialSim::External(_) => {
            return Err(src.error_at("controller.kind", "the scenario has no controller"));
        }
    };
    let n_arms = built.plant.arms.len();
    let expect = spatial_expectation(&sc, &built, src, n_q)?;
    Ok(Standalone {
        law: Law::Spatial(
            Box::new(d.controller),
            Box::new(SpatialTickRecord::new(n_arms)),
        ),
        n_q,
        n_arms,
        wrench_dim: 6,
        control_period: built.sim.control_period,
        start,
        expect,
        t_last: None,
        ticked: false,
    })
}

/// The spatial start's hold: the plant's holding torques held at the start pose, and each
/// tool's axes (welded: the grasp frame's).
fn spatial_expectation(
    sc: &SpatialScenario,
    built: &spatial::SpatialBuilt,
    src: &Source,
    n_q: usize,
) -> Result<StartExpectation, ScenarioError> {
    let sim = spatial::simulation_of(sc, built, src, Held::new(n_q))?;
    let mut st = Stepped::new(*sim).map_err(|f| start_fault(src, f))?;
    let mut tau = vec![0.0; n_q];
    st.holding_torques(&mut tau);
    let plant = st.plant().clone();
    let (pose, _) = st.object();
    let x_wo = nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(pose[0], pose[1], pose[2]),
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            pose[3], pose[4], pose[5], pose[6],
        )),
    );
    let hold = st
        .truth_with(&tau)
        .map_err(|k| src.error_at("run", format!("the start cannot be held: {k:?}")))?
        .0
        .to_vec();
    let axes = (0..plant.grasps().len())
        .map(|i| {
            let r = plant.grasp_pose(i, &x_wo).rotation.to_rotation_matrix();
            let m = r.matrix();
            [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ]
        })
        .collect();
    Ok(StartExpectation { hold, axes })
}

impl Standalone {
    /// Start (or restart) at `t0` with the first readings (lengths as the fields say; the
    /// caller checks them: [`Standalone::try_start`] does).
    pub fn start(&mut self, t0: f64, q: &[f64], qd: &[f64], wrenches: &[f64]) {
        let m = Measurements { q, qd, wrenches };
        match &mut self.law {
            Law::Planar(c, _) => c.start(t0, &m),
            Law::Spatial(c, _) => c.start(t0, &m),
        }
        self.t_last = Some(t0);
        self.ticked = false;
    }

    /// One tick: joint torques into `tau` (`n_q`), the internals into the record. No
    /// allocation. Unchecked: [`Standalone::try_tick`] checks the arguments first.
    pub fn tick(&mut self, t: f64, q: &[f64], qd: &[f64], wrenches: &[f64], tau: &mut [f64]) {
        let m = Measurements { q, qd, wrenches };
        match &mut self.law {
            Law::Planar(c, r) => c.tick(t, &m, tau, r),
            Law::Spatial(c, r) => c.tick(t, &m, tau, r),
        }
        self.t_last = Some(t);
        self.ticked = true;
    }

    /// The measurements have the lengths of this controller (`q`, `qd`: `n_q`; `wrenches`:
    /// `n_arms · wrench_dim`) and are finite, checked in that order.
    pub fn check_measurements(
        &self,
        q: &[f64],
        qd: &[f64],
        wrenches: &[f64],
    ) -> Result<(), InputError> {
        check_len("q", q, self.n_q)?;
        check_len("qd", qd, self.n_q)?;
        check_len("wrenches", wrenches, self.n_arms * self.wrench_dim)?;
        check_finite("q", q, 0)?;
        check_finite("qd", qd, 0)?;
        check_finite("wrenches", wrenches, self.wrench_dim)
    }

    /// A tick may run at `t`: `t` finite, the controller started, and `t` after the previous
    /// tick (the first tick may be at the start's time).
    pub fn check_tick_time(&self, t: f64) -> Result<(), InputError> {
        check_time(t)?;
        let Some(last) = self.t_last else {
            return Err(InputError::NotStarted);
        };
        if t < last || (self.ticked && t == last) {
            return Err(InputError::TimeBack {
                t,
                last,
                after_tick: self.ticked,
            });
        }
        Ok(())
    }

    /// [`Standalone::start`] after checking `t0` and the measurements; on an error nothing
    /// changed.
    pub fn try_start(
        &mut self,
        t0: f64,
        q: &[f64],
        qd: &[f64],
        wrenches: &[f64],
    ) -> Result<(), InputError> {
        check_time(t0)?;
        self.check_measurements(q, qd, wrenches)?;
        self.start(t0, q, qd, wrenches);
        Ok(())
    }

    /// [`Standalone::tick`] after checking the time ([`Standalone::check_tick_time`]), the
    /// measurements and `tau`'s length; on an error nothing changed (the controller, its
    /// record and `tau` are as they were). No allocation.
    pub fn try_tick(
        &mut self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        wrenches: &[f64],
        tau: &mut [f64],
    ) -> Result<(), InputError> {
        self.check_tick_time(t)?;
        self.check_measurements(q, qd, wrenches)?;
        check_len("tau", tau, self.n_q)?;
        self.tick(t, q, qd, wrenches, tau);
        Ok(())
    }

    /// Whether the controller has been started (and not reset since).
    pub fn started(&self) -> bool {
        self.t_last.is_some()
    }

    /// The sensor sanity check of a start (issue 23): the sum over arms of the first readings'
    /// forces, in world axes, against a static hold's (the object's weight), within
    /// [`START_TOLERANCE`] of the weight. A start that fails it and is not tandem's own start
    /// ([`StartState`]: at rest, zero torque held) gets one warning that names each arm with
    /// its reading and the hold's, and says which arm's reading would pass with its sign
    /// flipped or read as given in world axes. Empty when the readings look right.
    pub fn check_start(&self, wrenches: &[f64]) -> Vec<String> {
        let w = self.wrench_dim;
        let e = &self.expect;
        let force = |v: &[f64], i: usize| -> [f64; 3] {
            let mut f = [0.0; 3];
            f[..w.min(3)].copy_from_slice(&v[w * i..w * i + w.min(3)]);
            f
        };
        let world = |i: usize, f: [f64; 3]| -> [f64; 3] {
            let r = &e.axes[i];
            [0, 1, 2].map(|a| r[a][0] * f[0] + r[a][1] * f[1] + r[a][2] * f[2])
        };
        let sum = |fs: &dyn Fn(usize) -> [f64; 3]| -> [f64; 3] {
            (0..self.n_arms).fold([0.0; 3], |s, i| {
                let f = fs(i);
                [s[0] + f[0], s[1] + f[1], s[2] + f[2]]
            })
        };
        let want = sum(&|i| world(i, force(&e.hold, i)));
        let weight = want.iter().map(|v| v * v).sum::<f64>().sqrt();
        let off = |got: [f64; 3]| {
            (0..3)
                .map(|a| (got[a] - want[a]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let ok = |got: [f64; 3]| off(got) <= START_TOLERANCE * weight;
        let got = sum(&|i| world(i, force(wrenches, i)));
        if ok(got) || weight == 0.0 {
            return Vec::new();
        }
        // tandem's own start (zero torque held while the chain is at rest) is known too.
        let scale = self
            .start
            .wrenches
            .iter()
            .fold(1.0_f64, |m, v| m.max(v.abs()));
        if wrenches
            .iter()
            .zip(&self.start.wrenches)
            .all(|(a, b)| (a - b).abs() <= 1e-6 * scale)
        {
            return Vec::new();
        }
        let fmt = |f: &[f64]| {
            let v: Vec<String> = f.iter().map(|x| format!("{x:.3}")).collect();
            format!("[{}]", v.join(", "))
        };
        let axes = if w == 6 { "tool axes" } else { "world axes" };
        let mut lines = Vec::new();
        for i in 0..self.n_arms {
            let flipped = sum(&|j| {
                let f = world(j, force(wrenches, j));
                if j == i { f.map(|v| -v) } else { f }
            });
            let in_world = sum(&|j| {
                if j == i {
                    force(wrenches, j)
                } else {
                    world(j, force(wrenches, j))
                }
            });
            let hint = if ok(flipped) {
                ": its sign looks flipped (the object's wrench ON the tool is expected)"
            } else if w == 6 && ok(in_world) {
                ": it looks given in world axes (tool axes are expected)"
            } else {
                ""
            };
            lines.push(format!(
                "arm {}: measured {} N, holding the object at rest gives about {} N ({axes}){hint}",
                i + 1,
                fmt(&wrenches[w * i..w * i + w.min(3)]),
                fmt(&e.hold[w * i..w * i + w.min(3)]),
            ));
        }
        let all = if ok(got.map(|v| -v)) {
            " Every reading's sign looks flipped."
        } else if w == 6 && ok(sum(&|j| force(wrenches, j))) {
            " The readings look given in world axes."
        } else {
            ""
        };
        vec![format!(
            "the first wrist readings do not hold the object: their forces sum to {} N in world \
             axes, a hold at rest to {} N (the object's weight; {:.0} % off, the check allows \
             {:.0} %). The controller expects each arm's reading to be the object's wrench on \
             the tool, about the tool origin, in {axes}, in N and N m (docs/loop.md).{all} {}",
            fmt(&got),
            fmt(&want),
            100.0 * off(got) / weight,
            100.0 * START_TOLERANCE,
            lines.join("; ")
        )]
    }

    /// Event counters since the start.
    pub fn events(&self) -> ControlEvents {
        match &self.law {
            Law::Planar(c, _) => c.events(),
            Law::Spatial(c, _) => c.events(),
        }
    }

    /// The last tick's record as named vectors (3 outputs planar, 6 spatial): `x_hat`,
    /// `xd_hat`, `x_d`, `x_r`, `xd_r`, `z1`, `z2`, `alpha`, `alpha_dot`, `wrench` (the object
    /// wrench commanded, the log's `tau.*`), `w_norm`.
    pub fn record_vectors(&self) -> [(&'static str, &[f64]); 11] {
        match &self.law {
            Law::Planar(_, r) => [
                ("x_hat", r.x_o.as_slice()),
                ("xd_hat", r.xd_o.as_slice()),
                ("x_d", r.x_d.as_slice()),
                ("x_r", r.x_r.as_slice()),
                ("xd_r", r.xd_r.as_slice()),
                ("z1", r.z1.as_slice()),
                ("z2", r.z2.as_slice()),
                ("alpha", r.alpha.as_slice()),
                ("alpha_dot", r.alpha_dot.as_slice()),
                ("wrench", r.wrench.as_slice()),
                ("w_norm", r.w_norm.as_slice()),
            ],
            Law::Spatial(_, r) => [
                ("x_hat", r.x_hat.as_slice()),
                ("xd_hat", r.xd_hat.as_slice()),
                ("x_d", r.x_d.as_slice()),
                ("x_r", r.x_r.as_slice()),
                ("xd_r", r.xd_r.as_slice()),
                ("z1", r.z1.as_slice()),
                ("z2", r.z2.as_slice()),
                ("alpha", r.alpha.as_slice()),
                ("alpha_dot", r.alpha_dot.as_slice()),
                ("wrench", r.wrench.as_slice()),
                ("w_norm", r.w_norm.as_slice()),
            ],
        }
    }

    /// The last tick's scalars: `Q` (NN switching value, 1 otherwise), `margin` (of the
    /// estimate), and spatial `angle_error`.
    pub fn record_scalars(&self) -> Vec<(&'static str, f64)> {
        match &self.law {
            Law::Planar(_, r) => vec![("Q", r.q_switch), ("margin", r.margin)],
            Law::Spatial(_, r) => vec![
                ("Q", r.q_switch),
                ("margin", r.margin),
                ("angle_error", r.angle_error),
            ],
        }
    }

    /// The last tick's flags: `barrier_hit`, `torque_clipped`, `non_finite`.
    pub fn record_flags(&self) -> [(&'static str, bool); 3] {
        let (b, c, n) = match &self.law {
            Law::Planar(_, r) => (r.barrier_hit, r.torque_clipped, r.non_finite),
            Law::Spatial(_, r) => (r.barrier_hit, r.torque_clipped, r.non_finite),
        };
        [("barrier_hit", b), ("torque_clipped", c), ("non_finite", n)]
    }

    /// Spatial: each arm's internal (null-space) commanded wrench, world axes (`None` planar).
    pub fn record_internal(&self) -> Option<&[nalgebra::Vector6<f64>]> {
        match &self.law {
            Law::Planar(..) => None,
            Law::Spatial(_, r) => Some(&r.internal),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The plant, stepped from outside.

/// The plant of either kind, stepped from outside.
pub enum PlantSim {
    /// The planar closed chain.
    Planar(Box<Stepped<Plant>>),
    /// The spatial closed chain.
    Spatial(Box<Stepped<SpatialPlant>>),
}

/// A scenario's plant as a run simulates it (the true plant, start pose, sensor models and
/// seed, disturbance, injected actuator faults, timing), stepped by the caller with its own
/// joint torques (issue 23: Python's `Scenario.plant()`). See [`Stepped`].
pub struct PlantSession {
    /// The plant.
    pub sim: PlantSim,
    /// Joints, all arms.
    pub n_q: usize,
    /// Arms.
    pub n_arms: usize,
    /// Wrench channels per arm: 2 (planar force) or 6 (spatial `[f; τ]`).
    pub wrench_dim: usize,
}

/// The start could not be evaluated (a plant whose grasp wrenches are not finite at rest).
fn start_fault(src: &Source, f: tandem::sim::Fault) -> ScenarioError {
    src.error_at("run", format!("the plant cannot start: {f}"))
}

/// The planar scenario's plant, every check of a run.
pub fn planar_plant(sc: &PlanarScenario, src: &Source) -> Result<PlantSession, ScenarioError> {
    let built = planar::build(sc, src)?;
    let n_q: usize = built.plant.arms.iter().map(|a| a.links.len()).sum();
    let mut warnings = Vec::new();
    let sim = planar::simulation_of(sc, &built, src, Held::new(n_q), &mut warnings)?;
    super::check_finite(src, sc)?;
    let n_arms = built.plant.arms.len();
    Ok(PlantSession {
        sim: PlantSim::Planar(Box::new(
            Stepped::new(sim).map_err(|f| start_fault(src, f))?,
        )),
        n_q,
        n_arms,
        wrench_dim: 2,
    })
}

/// The spatial scenario's plant, every check of a run.
pub fn spatial_plant(sc: &SpatialScenario, src: &Source) -> Result<PlantSession, ScenarioError> {
    let built = spatial::build(sc, src)?;
    let n_q: usize = spatial::dofs(&built).iter().sum();
    let sim = spatial::simulation_of(sc, &built, src, Held::new(n_q))?;
    super::check_finite(src, sc)?;
    let n_arms = built.plant.arms.len();
    Ok(PlantSession {
        sim: PlantSim::Spatial(Box::new(
            Stepped::new(*sim).map_err(|f| start_fault(src, f))?,
        )),
        n_q,
        n_arms,
        wrench_dim: 6,
    })
}

/// Call `$body` with `$s` bound to the [`Stepped`] plant of either kind.
macro_rules! with_stepped {
    ($sim:expr, $s:ident => $body:expr) => {
        match $sim {
            PlantSim::Planar($s) => $body,
            PlantSim::Spatial($s) => $body,
        }
    };
}

impl PlantSession {
    /// Apply `tau` (`n_q`, finite: the caller checks) for `periods` control periods.
    pub fn step(&mut self, tau: &[f64], periods: usize) -> Result<(), tandem::sim::Fault> {
        with_stepped!(&mut self.sim, s => s.step(tau, periods))
    }
    /// Hold `tau` without stepping; the sensors read again ([`Stepped::hold`]).
    pub fn hold(&mut self, tau: &[f64]) -> Result<(), tandem::sim::Fault> {
        with_stepped!(&mut self.sim, s => s.hold(tau))
    }
    /// The simulation time, s.
    pub fn time(&self) -> f64 {
        with_stepped!(&self.sim, s => s.time())
    }
    /// The control period, s.
    pub fn control_period(&self) -> f64 {
        with_stepped!(&self.sim, s => s.control_period())
    }
    /// The fault that stopped the plant.
    pub fn fault(&self) -> Option<&tandem::sim::Fault> {
        with_stepped!(&self.sim, s => s.fault())
    }
    /// True joint angles and rates.
    pub fn joints(&self) -> (&[f64], &[f64]) {
        with_stepped!(&self.sim, s => s.joints())
    }
    /// The object's true pose and twist.
    pub fn object(&self) -> (&[f64], &[f64]) {
        with_stepped!(&self.sim, s => s.object())
    }
    /// Encoder angles and rates as read now.
    pub fn encoders(&self) -> (&[f64], &[f64]) {
        with_stepped!(&self.sim, s => (s.sensors().q(), s.sensors().qd()))
    }
    /// Wrist readings as read now (flat).
    pub fn readings(&self) -> &[f64] {
        with_stepped!(&self.sim, s => s.readings())
    }
    /// True grasp wrenches, world axes (flat).
    pub fn wrenches(&self) -> &[f64] {
        with_stepped!(&self.sim, s => s.wrenches())
    }
    /// Constraint residual `(position, rotation or velocity)`.
    pub fn residual(&mut self) -> (f64, f64) {
        with_stepped!(&mut self.sim, s => s.residual())
    }
    /// Spatial: the torques that hold the current configuration at rest
    /// ([`Stepped::holding_torques`]) into `tau`; `false` (nothing written) on a planar plant.
    pub fn holding_torques(&self, tau: &mut [f64]) -> bool {
        match &self.sim {
            PlantSim::Planar(_) => false,
            PlantSim::Spatial(s) => {
                s.holding_torques(tau);
                true
            }
        }
    }
    /// Mechanical energy.
    pub fn energy(&mut self) -> tandem::plant::Energy {
        with_stepped!(&mut self.sim, s => s.energy())
    }
}
