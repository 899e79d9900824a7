//! The closed chain, paper (10)–(14): arms, object and grasps as one plant, and what the
//! simulation loop needs from it, planar or spatial.
//!
//! * [`planar`]: the planar plant (SPEC §2.4), constrained ([`planar::constrained`]) and
//!   reduced (14) ([`planar::reduced`]) formulations.
//! * [`spatial`]: the spatial plant (SPEC-spatial S3–S4): URDF arms, an object in SE(3),
//!   welded or compliant grasps, the KKT solve.
//!
//! One trait, [`ClosedChain`], two implementations ([`Plant`](planar::Plant): planar arms with point grasps and
//! 2-D grasp forces; [`SpatialPlant`]: URDF arms with welds and
//! 6-D grasp wrenches). Both keep a flat state `y` (the integrators' view), hold the input over
//! a step (zero-order hold), and report their grasp wrenches as the wrist sensors read them, so
//! one loop, one sensor model and one set of health checks serve both. See the crate docs,
//! "Architecture".

use nalgebra::{Isometry3, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::error::ModelError;
use crate::math::integrate::Rk4;

pub mod planar;
pub mod spatial;

use planar::ReducedOde;
use spatial::{SpatialPlant, SpatialWorkspace};

/// Which plant formulation integrates the truth (SPEC §2.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Formulation {
    /// Joints + object with Lagrange multipliers (default; any arms; both plants).
    #[default]
    Constrained,
    /// Object coordinates only, (14) (planar 2-link arms).
    Reduced,
}

/// Why the loop's evaluation or step of a plant failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChainFault {
    /// The state (or the derivative) became non-finite.
    NonFinite,
    /// The reduced formulation could not be evaluated (IK out of reach or a singular arm).
    Reduced,
}

/// The simulation loop's integrator of a plant: the formulation, the RK4 buffers and a
/// derivative scratch, sized once ([`ClosedChain::stepper`]). The planar reduced formulation
/// (14) needs no state of its own: its 6-state `(x_o, ẋ_o)` is read from and written back into
/// the object part of the flat state, bit for bit, and the joints follow by the analytic IK.
#[derive(Clone, Debug)]
pub struct Stepper {
    formulation: Formulation,
    rk: Rk4,
    rk_red: Rk4,
    dy: Vec<f64>,
}

impl Stepper {
    /// The formulation this stepper integrates.
    pub fn formulation(&self) -> Formulation {
        self.formulation
    }
}

/// Where a planar run starts: the object pose at rest, `q_guess` for arms that are not 2-link.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarStart {
    /// Object pose `(x, y, θ)`, (m, m, rad).
    pub x_o: [f64; 3],
    /// Initial joint guess (stacked n_q) for the numerical IK of arms with more than 2 links.
    pub q_guess: Option<Vec<f64>>,
}

/// Where a spatial run starts: the object pose at rest and a joint guess for the IK.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialStart {
    /// Object pose `X_WO`.
    pub x_wo: Isometry3<f64>,
    /// Initial joint guess (stacked n_q) of each arm's Newton–Raphson IK.
    pub q_guess: Vec<f64>,
}

pub use crate::model::disturbance::SpatialDisturbance;

/// Plant energy split, J.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// Kinetic energy of arms and object.
    pub kinetic: f64,
    /// Potential energy of arms and object.
    pub potential: f64,
}

impl Energy {
    /// Total mechanical energy.
    pub fn total(&self) -> f64 {
        self.kinetic + self.potential
    }
}

/// `(name, unit)` of a log column.
pub type ColumnSpec = (String, String);

fn col(name: impl Into<String>, unit: &str) -> ColumnSpec {
    (name.into(), unit.to_string())
}

/// A closed-chain plant as the simulation loop sees it.
pub trait ClosedChain {
    /// Per-step scratch and the last evaluation's secondary results.
    type Workspace;
    /// The input held over a step: joint torques plus the object disturbance.
    type Input;
    /// Channels per grasp wrench: 2 (a planar force) or 6 (a spatial `[f; τ]`).
    const WRENCH_DIM: usize;

    /// Joints over all arms.
    fn n_q(&self) -> usize;
    /// Number of arms (one grasp and one wrist sensor each).
    fn n_arms(&self) -> usize;
    /// Flat state dimension.
    fn state_dim(&self) -> usize;
    /// A workspace for this plant (allocates).
    fn workspace(&self) -> Self::Workspace;
    /// A zero input (allocates).
    fn zero_input(&self) -> Self::Input;
    /// The joint torques of an input (stacked, arm order, n_q).
    fn torques_mut(input: &mut Self::Input) -> &mut [f64];
    /// `(q, q̇)` of a state (stacked, arm order).
    fn joints<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]);
    /// `ẏ` at `(y, input)`; writes the grasp wrenches into the workspace. `false` when the
    /// derivative does not exist (never for a validated model at a finite state).
    fn derivative(
        &self,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        dy: &mut [f64],
    ) -> bool;
    /// `n` RK4 steps of size `h` from `(t, y)` with the input held, including any projection
    /// the state needs (the spatial plant renormalises its quaternion). No allocation.
    /// Returns `false` when the state became non-finite (the spatial plant then leaves `y` at
    /// the last good state).
    fn advance(
        &self,
        rk: &mut Rk4,
        t: f64,
        y: &mut [f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        h: f64,
        n: usize,
    ) -> bool;
    /// The grasp wrenches of the last evaluation as the wrist sensors read them, flat
    /// (`WRENCH_DIM` per arm): planar forces in world axes; spatial `[f; τ]` in tool axes.
    fn sensor_wrenches(&self, ws: &Self::Workspace, out: &mut [f64]);
    /// Largest grasp-constraint violation of a state `(position, m; rotation, rad)`; the planar
    /// plant has no rotational constraint and reports its velocity residual (m/s) instead.
    fn constraint_residual(&self, y: &[f64], ws: &mut Self::Workspace) -> (f64, f64);
    /// Smallest singular value over the arms' Jacobians.
    fn min_singular_value(&self, y: &[f64], ws: &mut Self::Workspace) -> f64;
    /// Mechanical energy of a state, J.
    fn energy(&self, y: &[f64], ws: &mut Self::Workspace) -> Energy;

    // --- What the simulation loop needs beyond the dynamics (crate::sim). ---

    /// Where a run starts (the object pose and what the inverse kinematics needs).
    type Start;
    /// The environment disturbance on the object (planar: [`crate::model::disturbance::Disturbance`];
    /// spatial: [`SpatialDisturbance`]).
    type Disturbance;

    /// A consistent state at rest at `start` (IK of every arm); errors name the arm or field.
    fn start_state(&self, start: &Self::Start) -> Result<Vec<f64>, ModelError>;
    /// Validate a disturbance (errors name the field).
    fn check_disturbance(&self, d: &Self::Disturbance) -> Result<(), ModelError>;
    /// Set the input's disturbance to `F_d(t)`; the name of its first non-finite channel
    /// (`the disturbance F_d.x`), if any (allocates only then).
    fn disturb(&self, d: &Self::Disturbance, t: f64, input: &mut Self::Input) -> Option<String>;
    /// The loop's integrator for a formulation; errors name `formulation` when the plant has
    /// no such formulation (the reduced one is planar, 2-link arms only).
    fn stepper(&self, formulation: Formulation) -> Result<Stepper, ModelError>;
    /// **The grasp wrenches of a state**: evaluate the plant at `(y, input)` in the stepper's
    /// formulation and write the grasp wrenches (the object on tool `i`, world axes) flat
    /// into `out` (`WRENCH_DIM` per arm: planar `(F_x, F_y)` N; spatial `[f; τ]` (N, N m)
    /// about the tool origin). Leaves that evaluation in `ws`, so
    /// [`sensor_wrenches`](Self::sensor_wrenches) then gives the wrist readings of the same
    /// state. No allocation.
    fn grasp_wrenches(
        &self,
        st: &mut Stepper,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        out: &mut [f64],
    ) -> Result<(), ChainFault>;
    /// Advance `n` plant steps of size `h` from `(t, y)` with the input held, in the stepper's
    /// formulation. On `Err` the state is not a new good one (the loop reports the last good
    /// state it kept). No allocation.
    fn step_with(
        &self,
        st: &mut Stepper,
        t: f64,
        y: &mut [f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        h: f64,
        n: usize,
    ) -> Result<(), ChainFault>;
    /// Grasp-constraint drift of a state `(position, m; rotation, rad)`; the planar point
    /// grasps constrain no rotation (0).
    fn drift(&self, y: &[f64], ws: &mut Self::Workspace) -> (f64, f64);
    /// [`drift`](Self::drift) and [`min_singular_value`](Self::min_singular_value) of one
    /// state (the loop's health check), the same values as the two calls; a plant may share
    /// their kinematics.
    fn drift_and_min_singular_value(
        &self,
        y: &[f64],
        ws: &mut Self::Workspace,
    ) -> ((f64, f64), f64) {
        (self.drift(y, ws), self.min_singular_value(y, ws))
    }
    /// Evaluations so far that needed a regularised grasp-space solve.
    fn regularised(ws: &Self::Workspace) -> u64;
    /// The object's pose of a state for a fault report: planar `(x, y, θ)`; spatial
    /// `(p_WO, q_WO = (w, x, y, z))` (allocates).
    fn object_pose(&self, y: &[f64]) -> Vec<f64>;
    /// Log columns of the object's true state (planar `x_o.{x,y,theta}`; spatial pose and
    /// twist), with units.
    fn object_columns(&self) -> Vec<ColumnSpec>;
    /// Write the [`object_columns`](Self::object_columns) of a state.
    fn write_object(&self, y: &[f64], out: &mut [f64]);
    /// Log columns of the joints' true state (planar `q*`; spatial `q*` and `qd*`).
    fn joint_columns(&self) -> Vec<ColumnSpec>;
    /// Write the [`joint_columns`](Self::joint_columns) of a state.
    fn write_joints(&self, y: &[f64], out: &mut [f64]);
    /// Units of the joint torques `tau_q*` (N m; N for a prismatic joint).
    fn torque_units(&self) -> Vec<String>;
    /// `(suffix, unit)` of one wrench's channels: planar `x, y` (N); spatial `fx … tz`
    /// (N, N m). The log names them `F{i}.{suffix}` (grasp, world axes) and
    /// `F_meas{i}.{suffix}` (wrist reading).
    fn wrench_channels(&self) -> Vec<(&'static str, &'static str)>;
    /// Drift columns: planar `drift` (m); spatial `drift` (m) and `drift_rot` (rad).
    fn drift_columns(&self) -> Vec<ColumnSpec>;
    /// The object's pose and twist in a state: planar `(x, y, θ)` and `(ẋ, ẏ, θ̇)`; spatial
    /// `(p, q = (w, x, y, z))` and `(v, ω)` (world axes).
    fn object_state<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]);
    /// Columns of the plant's contacts, after the drift columns (spatial contact grasps: per
    /// pad its normal force, friction, torsion, cone margin and state); none by default.
    fn contact_columns(&self) -> Vec<ColumnSpec> {
        Vec::new()
    }
    /// The contact columns' values after the last step (as many as [`contact_columns`]).
    ///
    /// [`contact_columns`]: ClosedChain::contact_columns
    fn write_contacts(&self, _ws: &Self::Workspace, _out: &mut [f64]) {}
    /// Set the workspace's per-state record from the start state (spatial contact grasps:
    /// the pads' readings at `t = 0`); nothing by default.
    fn prime(&self, _y: &mut [f64], _ws: &mut Self::Workspace) {}
    /// After the grasp wrenches of the state `y` at `t` were evaluated: the pads that gauge
    /// weld or compliant grasps (spatial [`spatial::SpatialPlantParams::pad_gauge`]); nothing
    /// by default. No allocation.
    fn gauge(&self, _t: f64, _y: &[f64], _ws: &mut Self::Workspace) {}
}

const AX3: [&str; 3] = ["x", "y", "theta"];
const AX6: [&str; 6] = ["fx", "fy", "fz", "tx", "ty", "tz"];

impl ClosedChain for planar::Plant {
    type Workspace = planar::PlantWorkspace;
    type Input = planar::PlantInput;
    const WRENCH_DIM: usize = 2;

    fn n_q(&self) -> usize {
        planar::Plant::n_q(self)
    }
    fn n_arms(&self) -> usize {
        self.arms().len()
    }
    fn state_dim(&self) -> usize {
        planar::Plant::state_dim(self)
    }
    fn workspace(&self) -> Self::Workspace {
        planar::Plant::workspace(self)
    }
    fn zero_input(&self) -> Self::Input {
        planar::Plant::zero_input(self)
    }
    fn torques_mut(input: &mut Self::Input) -> &mut [f64] {
        &mut input.tau
    }
    fn joints<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]) {
        let (q, _, qd, _) = self.split(y);
        (q, qd)
    }
    fn derivative(
        &self,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        dy: &mut [f64],
    ) -> bool {
        planar::Plant::derivative(self, y, input, ws, dy)
    }
    fn advance(
        &self,
        rk: &mut Rk4,
        t: f64,
        y: &mut [f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        h: f64,
        n: usize,
    ) -> bool {
        let mut sys = planar::ConstrainedOde {
            plant: self,
            ws,
            input,
        };
        rk.substeps(&mut sys, t, y, h * n as f64, n);
        y.iter().all(|v| v.is_finite())
    }
    fn sensor_wrenches(&self, ws: &Self::Workspace, out: &mut [f64]) {
        for (i, f) in ws.forces.iter().enumerate() {
            out[2 * i] = f.x;
            out[2 * i + 1] = f.y;
        }
    }
    fn constraint_residual(&self, y: &[f64], ws: &mut Self::Workspace) -> (f64, f64) {
        planar::Plant::constraint_residual(self, y, ws)
    }
    fn min_singular_value(&self, y: &[f64], ws: &mut Self::Workspace) -> f64 {
        planar::Plant::min_singular_value(self, y, ws)
    }
    fn energy(&self, y: &[f64], ws: &mut Self::Workspace) -> Energy {
        planar::Plant::energy(self, y, ws)
    }

    type Start = PlanarStart;
    type Disturbance = crate::model::disturbance::Disturbance;

    fn start_state(&self, start: &PlanarStart) -> Result<Vec<f64>, ModelError> {
        self.initial_state(
            Vector3::from(start.x_o),
            Vector3::zeros(),
            start.q_guess.as_deref(),
        )
    }
    fn check_disturbance(&self, d: &Self::Disturbance) -> Result<(), ModelError> {
        d.validate()
    }
    fn disturb(&self, d: &Self::Disturbance, t: f64, input: &mut Self::Input) -> Option<String> {
        input.f_d = d.at(t);
        input
            .f_d
            .iter()
            .position(|v| !v.is_finite())
            .map(|j| format!("the disturbance F_d.{}", AX3[j]))
    }
    /// Constrained: any arms; reduced (14): 2-link arms only.
    fn stepper(&self, formulation: Formulation) -> Result<Stepper, ModelError> {
        if formulation == Formulation::Reduced && self.arms().iter().any(|a| a.dof() != 2) {
            return Err(ModelError::geometry(
                "formulation",
                "the reduced formulation needs 2-link arms",
            ));
        }
        let n = planar::Plant::state_dim(self);
        Ok(Stepper {
            formulation,
            rk: Rk4::new(n),
            rk_red: Rk4::new(6),
            dy: vec![0.0; n],
        })
    }
    fn grasp_wrenches(
        &self,
        st: &mut Stepper,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        out: &mut [f64],
    ) -> Result<(), ChainFault> {
        let ok = match st.formulation {
            // Kept for the first RK4 stage of the step that follows at this state; the
            // accelerations are not needed here.
            Formulation::Constrained => {
                planar::Plant::grasp_forces_keep(self, y, input, ws, &mut st.dy)
            }
            Formulation::Reduced => {
                let mut d = [0.0; 6];
                self.reduced_derivative(&reduced_state(self, y), input, ws, &mut d)
                    .is_ok()
            }
        };
        self.sensor_wrenches(ws, out);
        // A failed evaluation is reported as the reduced formulation's failure in both
        // formulations (the constrained one fails only for an inertia that is not positive
        // definite, never for a validated model).
        if ok { Ok(()) } else { Err(ChainFault::Reduced) }
    }
    fn step_with(
        &self,
        st: &mut Stepper,
        t: f64,
        y: &mut [f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        h: f64,
        n: usize,
    ) -> Result<(), ChainFault> {
        match st.formulation {
            Formulation::Constrained => {
                // As `advance`, with the first stage on the state part that
                // `grasp_wrenches` kept at this `y` (if it did): bit for bit the same.
                let mut sys = planar::ReusingOde {
                    plant: self,
                    ws,
                    input,
                    first: true,
                };
                st.rk.substeps(&mut sys, t, y, h * n as f64, n);
                if crate::math::linalg::finite_slice(y) {
                    Ok(())
                } else {
                    Err(ChainFault::NonFinite)
                }
            }
            Formulation::Reduced => {
                let mut y_red = reduced_state(self, y);
                let mut sys = ReducedOde {
                    plant: self,
                    ws: &mut *ws,
                    input,
                };
                st.rk_red.substeps(&mut sys, t, &mut y_red, h * n as f64, n);
                if !y_red.iter().all(|v| v.is_finite()) {
                    return Err(ChainFault::NonFinite);
                }
                // The joints follow the object (for sensors and logs).
                let nq = planar::Plant::n_q(self);
                let x = Vector3::new(y_red[0], y_red[1], y_red[2]);
                let xd = Vector3::new(y_red[3], y_red[4], y_red[5]);
                let (q, rest) = y.split_at_mut(nq);
                let (xo, rest) = rest.split_at_mut(3);
                let (qd, xdo) = rest.split_at_mut(nq);
                xo.copy_from_slice(x.as_slice());
                xdo.copy_from_slice(xd.as_slice());
                self.arms_from_object(&x, &xd, q, qd, ws)
                    .map_err(|_| ChainFault::Reduced)?;
                if y.iter().all(|v| v.is_finite()) {
                    Ok(())
                } else {
                    Err(ChainFault::NonFinite)
                }
            }
        }
    }
    fn drift(&self, y: &[f64], ws: &mut Self::Workspace) -> (f64, f64) {
        (planar::Plant::constraint_residual(self, y, ws).0, 0.0)
    }
    /// One kinematics pass per arm for both ([`planar::Plant::residual_and_min_singular_value`]).
    fn drift_and_min_singular_value(
        &self,
        y: &[f64],
        ws: &mut Self::Workspace,
    ) -> ((f64, f64), f64) {
        let ((ep, _), s) = planar::Plant::residual_and_min_singular_value(self, y, ws);
        ((ep, 0.0), s)
    }
    fn regularised(ws: &Self::Workspace) -> u64 {
        ws.regularised
    }
    fn object_pose(&self, y: &[f64]) -> Vec<f64> {
        let n = planar::Plant::n_q(self);
        y[n..n + 3].to_vec()
    }
    fn object_columns(&self) -> Vec<ColumnSpec> {
        vec![
            col("x_o.x", "m"),
            col("x_o.y", "m"),
            col("x_o.theta", "rad"),
        ]
    }
    fn write_object(&self, y: &[f64], out: &mut [f64]) {
        let n = planar::Plant::n_q(self);
        out[..3].copy_from_slice(&y[n..n + 3]);
    }
    fn joint_columns(&self) -> Vec<ColumnSpec> {
        (0..planar::Plant::n_q(self))
            .map(|k| col(format!("q{}", k + 1), "rad"))
            .collect()
    }
    fn write_joints(&self, y: &[f64], out: &mut [f64]) {
        let n = planar::Plant::n_q(self);
        out[..n].copy_from_slice(&y[..n]);
    }
    fn torque_units(&self) -> Vec<String> {
        vec!["N m".into(); planar::Plant::n_q(self)]
    }
    fn wrench_channels(&self) -> Vec<(&'static str, &'static str)> {
        vec![("x", "N"), ("y", "N")]
    }
    fn drift_columns(&self) -> Vec<ColumnSpec> {
        vec![col("drift", "m")]
    }
    fn object_state<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]) {
        let n = planar::Plant::n_q(self);
        (&y[n..n + 3], &y[2 * n + 3..2 * n + 6])
    }
}

/// The reduced formulation's state `(x_o, ẋ_o)`: the object part of a planar flat state.
fn reduced_state(p: &planar::Plant, y: &[f64]) -> [f64; 6] {
    let n = planar::Plant::n_q(p);
    [
        y[n],
        y[n + 1],
        y[n + 2],
        y[2 * n + 3],
        y[2 * n + 4],
        y[2 * n + 5],
    ]
}

impl ClosedChain for spatial::SpatialPlant {
    type Workspace = spatial::SpatialWorkspace;
    type Input = spatial::SpatialInput;
    const WRENCH_DIM: usize = 6;

    fn n_q(&self) -> usize {
        spatial::SpatialPlant::n_q(self)
    }
    fn n_arms(&self) -> usize {
        self.arms().len()
    }
    fn state_dim(&self) -> usize {
        spatial::SpatialPlant::state_dim(self)
    }
    fn workspace(&self) -> Self::Workspace {
        spatial::SpatialPlant::workspace(self)
    }
    fn zero_input(&self) -> Self::Input {
        spatial::SpatialPlant::zero_input(self)
    }
    fn torques_mut(input: &mut Self::Input) -> &mut [f64] {
        &mut input.tau
    }
    fn joints<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]) {
        let n = spatial::SpatialPlant::n_q(self);
        (&y[..n], &y[n + 7..2 * n + 7])
    }
    fn derivative(
        &self,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        dy: &mut [f64],
    ) -> bool {
        spatial::SpatialPlant::derivative(self, y, input, ws, dy)
    }
    fn advance(
        &self,
        rk: &mut Rk4,
        t: f64,
        y: &mut [f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        h: f64,
        n: usize,
    ) -> bool {
        self.step(rk, t, y, input, ws, h, n).is_ok()
    }
    fn sensor_wrenches(&self, ws: &Self::Workspace, out: &mut [f64]) {
        for i in 0..ws.wrenches.len() {
            let w = ws.tool_wrench(i);
            out[6 * i..6 * i + 6].copy_from_slice(w.as_slice());
        }
    }
    fn constraint_residual(&self, y: &[f64], ws: &mut Self::Workspace) -> (f64, f64) {
        spatial::SpatialPlant::constraint_residual(self, y, ws)
    }
    fn min_singular_value(&self, y: &[f64], ws: &mut Self::Workspace) -> f64 {
        spatial::SpatialPlant::min_singular_value(self, y, ws)
    }
    fn energy(&self, y: &[f64], ws: &mut Self::Workspace) -> Energy {
        spatial::SpatialPlant::energy(self, y, ws)
    }

    type Start = SpatialStart;
    type Disturbance = SpatialDisturbance;

    fn start_state(&self, start: &SpatialStart) -> Result<Vec<f64>, ModelError> {
        self.initial_state(&start.x_wo, &Vector6::zeros(), &start.q_guess)
    }
    fn check_disturbance(&self, d: &Self::Disturbance) -> Result<(), ModelError> {
        d.validate()
    }
    fn disturb(&self, d: &Self::Disturbance, t: f64, input: &mut Self::Input) -> Option<String> {
        input.f_d = d.at(t);
        input
            .f_d
            .iter()
            .position(|v| !v.is_finite())
            .map(|j| format!("the disturbance F_d.{}", AX6[j]))
    }
    /// Constrained only (welds or compliant grasps).
    fn stepper(&self, formulation: Formulation) -> Result<Stepper, ModelError> {
        if formulation != Formulation::Constrained {
            return Err(ModelError::geometry(
                "formulation",
                "the reduced formulation is planar only (2-link arms); the spatial plant integrates the constrained one",
            ));
        }
        let n = SpatialPlant::state_dim(self);
        Ok(Stepper {
            formulation,
            rk: Rk4::new(n),
            rk_red: Rk4::new(6),
            dy: vec![0.0; n],
        })
    }
    fn grasp_wrenches(
        &self,
        st: &mut Stepper,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        out: &mut [f64],
    ) -> Result<(), ChainFault> {
        let ok = SpatialPlant::derivative(self, y, input, ws, &mut st.dy);
        world_wrenches(ws, out);
        if ok {
            Ok(())
        } else {
            Err(ChainFault::NonFinite)
        }
    }
    fn step_with(
        &self,
        st: &mut Stepper,
        t: f64,
        y: &mut [f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        h: f64,
        n: usize,
    ) -> Result<(), ChainFault> {
        self.step(&mut st.rk, t, y, input, ws, h, n)
            .map_err(|_| ChainFault::NonFinite)
    }
    fn drift(&self, y: &[f64], ws: &mut Self::Workspace) -> (f64, f64) {
        SpatialPlant::constraint_residual(self, y, ws)
    }
    fn regularised(ws: &Self::Workspace) -> u64 {
        ws.regularised
    }
    fn object_pose(&self, y: &[f64]) -> Vec<f64> {
        let n = SpatialPlant::n_q(self);
        y[n..n + 7].to_vec()
    }
    /// SPEC-spatial S7 (the planar §5 columns on six outputs): `x_o.{x,y,z}` (m),
    /// `x_o.{qw,qx,qy,qz}` (1), `v_o.*` (m/s), `w_o.*` (rad/s, world axes).
    fn object_columns(&self) -> Vec<ColumnSpec> {
        let mut c = Vec::with_capacity(13);
        for a in ["x", "y", "z"] {
            c.push(col(format!("x_o.{a}"), "m"));
        }
        for a in ["qw", "qx", "qy", "qz"] {
            c.push(col(format!("x_o.{a}"), "1"));
        }
        for a in ["x", "y", "z"] {
            c.push(col(format!("v_o.{a}"), "m/s"));
        }
        for a in ["x", "y", "z"] {
            c.push(col(format!("w_o.{a}"), "rad/s"));
        }
        c
    }
    fn write_object(&self, y: &[f64], out: &mut [f64]) {
        let n = SpatialPlant::n_q(self);
        out[..7].copy_from_slice(&y[n..n + 7]);
        out[7..13].copy_from_slice(&y[2 * n + 7..2 * n + 13]);
    }
    fn joint_columns(&self) -> Vec<ColumnSpec> {
        let kinds = joint_kinds(self);
        let mut c: Vec<ColumnSpec> = kinds
            .iter()
            .enumerate()
            .map(|(k, p)| col(format!("q{}", k + 1), if *p { "m" } else { "rad" }))
            .collect();
        c.extend(
            kinds
                .iter()
                .enumerate()
                .map(|(k, p)| col(format!("qd{}", k + 1), if *p { "m/s" } else { "rad/s" })),
        );
        c
    }
    fn write_joints(&self, y: &[f64], out: &mut [f64]) {
        let n = SpatialPlant::n_q(self);
        out[..n].copy_from_slice(&y[..n]);
        out[n..2 * n].copy_from_slice(&y[n + 7..2 * n + 7]);
    }
    fn torque_units(&self) -> Vec<String> {
        joint_kinds(self)
            .iter()
            .map(|p| if *p { "N" } else { "N m" }.to_string())
            .collect()
    }
    fn wrench_channels(&self) -> Vec<(&'static str, &'static str)> {
        vec![
            ("fx", "N"),
            ("fy", "N"),
            ("fz", "N"),
            ("tx", "N m"),
            ("ty", "N m"),
            ("tz", "N m"),
        ]
    }
    /// Both weld residuals (SPEC-spatial S4: drift < 1e-9 m and 1e-9 rad).
    fn drift_columns(&self) -> Vec<ColumnSpec> {
        vec![col("drift", "m"), col("drift_rot", "rad")]
    }
    fn object_state<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]) {
        let n = SpatialPlant::n_q(self);
        (&y[n..n + 7], &y[2 * n + 7..2 * n + 13])
    }
    /// Per pad `pad{i}.{j}.*` (arm `i`, pad `j`, from 1): `normal` (N), `friction` (`|f_t|`,
    /// N), `torsion` (N m), `margin` (`μ N − |f_t|`, N) and `state` (0 stick, 1 slip, 2
    /// separated).
    fn contact_columns(&self) -> Vec<ColumnSpec> {
        let Some(c) = self.pads() else {
            return Vec::new();
        };
        let mut out = Vec::with_capacity(5 * c.n_pads());
        for i in 0..self.arms().len() {
            for j in 0..c.pads_of(i).len() {
                let p = format!("pad{}.{}", i + 1, j + 1);
                out.push(col(format!("{p}.normal"), "N"));
                out.push(col(format!("{p}.friction"), "N"));
                out.push(col(format!("{p}.torsion"), "N m"));
                out.push(col(format!("{p}.margin"), "N"));
                out.push(col(format!("{p}.state"), "1"));
            }
        }
        out
    }
    fn prime(&self, y: &mut [f64], ws: &mut Self::Workspace) {
        self.prime_contacts(y, ws);
    }
    fn gauge(&self, t: f64, y: &[f64], ws: &mut Self::Workspace) {
        self.gauge_pads(t, y, ws);
    }
    fn write_contacts(&self, ws: &Self::Workspace, out: &mut [f64]) {
        for (k, r) in ws.contacts.readings.iter().enumerate() {
            let o = &mut out[5 * k..5 * k + 5];
            o[0] = r.normal;
            o[1] = (r.tangential[0] * r.tangential[0] + r.tangential[1] * r.tangential[1]).sqrt();
            o[2] = r.torsion;
            o[3] = r.margin;
            o[4] = match r.status {
                spatial::PadStatus::Stick => 0.0,
                spatial::PadStatus::Slip => 1.0,
                spatial::PadStatus::Separated => 2.0,
            };
        }
    }
}

/// Whether each joint (stacked) is prismatic.
fn joint_kinds(p: &SpatialPlant) -> Vec<bool> {
    p.arms()
        .iter()
        .flat_map(|a| a.chain.joints.iter())
        .map(|j| j.kind == crate::model::spatial::JointKind::Prismatic)
        .collect()
}

/// The grasp wrenches of the last evaluation in world axes, flat (6 per arm).
fn world_wrenches(ws: &SpatialWorkspace, out: &mut [f64]) {
    for (i, w) in ws.wrenches.iter().enumerate() {
        out[6 * i..6 * i + 6].copy_from_slice(w.as_slice());
    }
}
