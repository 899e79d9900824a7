//! What the simulation loop needs from a closed-chain plant, planar or spatial.
//!
//! One trait, two implementations ([`Plant`](super::Plant): planar arms with point grasps and
//! 2-D grasp forces; [`SpatialPlant`](super::spatial::SpatialPlant): URDF arms with welds and
//! 6-D grasp wrenches). Both keep a flat state `y` (the integrators' view), hold the input over
//! a step (zero-order hold), and report their grasp wrenches as the wrist sensors read them, so
//! one loop, one sensor model and one set of health checks serve both. See the crate docs,
//! "Architecture".

use crate::integrate::Rk4;

use super::Energy;

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
}

impl ClosedChain for super::Plant {
    type Workspace = super::PlantWorkspace;
    type Input = super::PlantInput;
    const WRENCH_DIM: usize = 2;

    fn n_q(&self) -> usize {
        super::Plant::n_q(self)
    }
    fn n_arms(&self) -> usize {
        self.arms().len()
    }
    fn state_dim(&self) -> usize {
        super::Plant::state_dim(self)
    }
    fn workspace(&self) -> Self::Workspace {
        super::Plant::workspace(self)
    }
    fn zero_input(&self) -> Self::Input {
        super::Plant::zero_input(self)
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
        super::Plant::derivative(self, y, input, ws, dy)
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
        let mut sys = super::ConstrainedOde {
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
        super::Plant::constraint_residual(self, y, ws)
    }
    fn min_singular_value(&self, y: &[f64], ws: &mut Self::Workspace) -> f64 {
        super::Plant::min_singular_value(self, y, ws)
    }
    fn energy(&self, y: &[f64], ws: &mut Self::Workspace) -> Energy {
        super::Plant::energy(self, y, ws)
    }
}

impl ClosedChain for super::spatial::SpatialPlant {
    type Workspace = super::spatial::SpatialWorkspace;
    type Input = super::spatial::SpatialInput;
    const WRENCH_DIM: usize = 6;

    fn n_q(&self) -> usize {
        super::spatial::SpatialPlant::n_q(self)
    }
    fn n_arms(&self) -> usize {
        self.arms().len()
    }
    fn state_dim(&self) -> usize {
        super::spatial::SpatialPlant::state_dim(self)
    }
    fn workspace(&self) -> Self::Workspace {
        super::spatial::SpatialPlant::workspace(self)
    }
    fn zero_input(&self) -> Self::Input {
        super::spatial::SpatialPlant::zero_input(self)
    }
    fn torques_mut(input: &mut Self::Input) -> &mut [f64] {
        &mut input.tau
    }
    fn joints<'a>(&self, y: &'a [f64]) -> (&'a [f64], &'a [f64]) {
        let n = super::spatial::SpatialPlant::n_q(self);
        (&y[..n], &y[n + 7..2 * n + 7])
    }
    fn derivative(
        &self,
        y: &[f64],
        input: &Self::Input,
        ws: &mut Self::Workspace,
        dy: &mut [f64],
    ) -> bool {
        super::spatial::SpatialPlant::derivative(self, y, input, ws, dy)
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
        super::spatial::SpatialPlant::constraint_residual(self, y, ws)
    }
    fn min_singular_value(&self, y: &[f64], ws: &mut Self::Workspace) -> f64 {
        super::spatial::SpatialPlant::min_singular_value(self, y, ws)
    }
    fn energy(&self, y: &[f64], ws: &mut Self::Workspace) -> Energy {
        super::spatial::SpatialPlant::energy(self, y, ws)
    }
}
