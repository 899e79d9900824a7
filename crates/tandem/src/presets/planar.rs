//! Planar presets: the paper's two-arm set-up (SPEC §4) and its start, a redundant pair of
//! 3-link arms, three arms, and the paper scenario's closed loop.

use nalgebra::Vector3;

use crate::control::ControlWarning;
use crate::control::planar::{Controller, ControllerParams};
use crate::error::ModelError;
use crate::model::disturbance::Disturbance;
use crate::model::planar::arm::{ArmParams, Elbow, LinkParams};
use crate::plant::planar::PlantParams;
use crate::reference::planar::path::Path;
use crate::sim::sensors::SensorParams;
use crate::sim::{Driver, SimParams, Simulation};

/// The paper's two-arm set-up (SPEC §4); see [`PlantParams::paper`].
pub fn paper() -> PlantParams {
    PlantParams::paper()
}

/// The paper's start pose for the NN run, `x_o = (0.19, 0, 0)` at rest (SPEC §4).
pub fn paper_start() -> Vector3<f64> {
    Vector3::new(0.19, 0.0, 0.0)
}

/// A redundant case: two 3-link arms (0.2 m links) at the paper's bases, with a joint-angle
/// guess (stacked) for the numerical inverse kinematics at [`paper_start`].
pub fn redundant_pair() -> (PlantParams, Vec<f64>) {
    let link = |m: f64, i: f64| LinkParams {
        mass: m,
        length: 0.2,
        com: 0.1,
        inertia: i,
    };
    let arm = |x: f64, elbow| ArmParams {
        base: [x, 0.0],
        base_angle: 0.0,
        links: vec![link(1.5, 0.02), link(1.0, 0.01), link(0.5, 0.005)],
        elbow,
    };
    let mut p = PlantParams::paper();
    p.arms = vec![arm(-0.38, Elbow::Negative), arm(0.38, Elbow::Positive)];
    // Arm 1 reaches right from (−0.38, 0) to (0.14, 0) with its elbow down; arm 2 reaches left.
    let guess = vec![0.6, -0.6, -0.6, 2.5, 0.6, 0.6];
    (p, guess)
}

/// A three-arm case: the paper's two arms plus a third 2-link arm below the object, based at
/// `(0, −0.4)`, holding the bottom face's midpoint.
pub fn three_arms() -> PlantParams {
    let mut p = PlantParams::paper();
    p.arms.push(ArmParams::paper([0.0, -0.4], Elbow::Positive));
    p.grasps.push([0.0, -0.025]);
    p
}

/// The paper scenario (plant, path, ideal sensors) driven by a controller built from `cp`, with
/// the run settings `sp` (its duration also bounds the path checks) and the disturbance `dist`.
/// Returns the simulation and the controller's set-up warnings.
pub fn paper_simulation(
    cp: &ControllerParams,
    sp: SimParams,
    dist: Disturbance,
) -> Result<(Simulation, Vec<ControlWarning>), ModelError> {
    let plant = paper();
    let (c, warnings) = Controller::new(cp, &plant, Path::paper(), sp.duration)?;
    let sim = Simulation::new(
        &plant,
        &SensorParams::default(),
        Driver::Controller(Box::new(c)),
        dist,
        sp,
        None,
    )?;
    Ok((sim, warnings))
}
