//! Ready-made models shared by tests, benches, examples and the CLI (Pinocchio's sample models).

use nalgebra::Vector3;

use crate::control::ControlWarning;
use crate::control::planar::{Controller, ControllerParams};
use crate::error::ModelError;
use crate::model::disturbance::Disturbance;
use crate::model::planar::arm::{ArmParams, Elbow, LinkParams};
use crate::model::planar::object::ObjectParams;
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

/// A plant with no damping on the object (for energy-conservation checks).
pub fn undamped(mut p: PlantParams) -> PlantParams {
    p.object = ObjectParams {
        damping: [0.0; 3],
        ..p.object
    };
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

/// A spatial closed chain ready to start: plant parameters, the object's start pose and a
/// joint-angle guess for the inverse kinematics (stacked, arm order).
#[derive(Clone, Debug)]
pub struct SpatialSetup {
    /// Plant parameters (arms with base placements, grasps, object, gravity).
    pub params: crate::plant::spatial::SpatialPlantParams,
    /// `X_WO` at the start.
    pub x_wo: nalgebra::Isometry3<f64>,
    /// Joint-angle guess for [`SpatialPlant::initial_state`](crate::plant::spatial::SpatialPlant::initial_state), rad.
    pub q_guess: Vec<f64>,
}

/// The embedded UR5-class arm, `base_link` → `tool0`, placed at `(x, y, 0)` with yaw `yaw`.
pub fn ur5_arm(x: f64, y: f64, yaw: f64) -> crate::model::spatial::SpatialArm {
    let chain = crate::model::spatial::urdf::ur5();
    crate::model::spatial::SpatialArm {
        chain,
        base: nalgebra::Isometry3::new(
            nalgebra::Vector3::new(x, y, 0.0),
            nalgebra::Vector3::new(0.0, 0.0, yaw),
        ),
    }
}

/// The embedded Franka-class arm, `panda_link0` → `panda_hand_tcp`, at `(x, y, 0)`, yaw `yaw`.
pub fn franka_arm(x: f64, y: f64, yaw: f64) -> crate::model::spatial::SpatialArm {
    let (chain, _) = crate::model::spatial::urdf::load_chain(
        crate::model::spatial::urdf::FRANKA_URDF,
        "panda_link0",
        "panda_hand_tcp",
    )
    .expect("the embedded Franka model loads");
    crate::model::spatial::SpatialArm {
        chain,
        base: nalgebra::Isometry3::new(
            nalgebra::Vector3::new(x, y, 0.0),
            nalgebra::Vector3::new(0.0, 0.0, yaw),
        ),
    }
}

/// A grasp frame at `p_OG` whose axes are the given columns (tool x, y, z in object axes).
fn grasp_frame(p: [f64; 3], x: [f64; 3], y: [f64; 3], z: [f64; 3]) -> nalgebra::Isometry3<f64> {
    use nalgebra::{Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
        Vector3::from(x),
        Vector3::from(y),
        Vector3::from(z),
    ]));
    nalgebra::Isometry3::from_parts(
        Translation3::new(p[0], p[1], p[2]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// SPEC-spatial S6: two UR5-class arms facing each other (bases `(∓0.70, 0, 0)`, yaw 0 and π)
/// holding the 0.4 × 0.2 × 0.2 m, 3 kg box by its end faces, box at `(0.1, 0, 0.3)` with
/// `R_WO = I`; the S6 start angles as the guess. Gravity `(0, 0, −9.81)`, Baumgarte 20 rad/s.
pub fn dual_ur5() -> SpatialSetup {
    use crate::model::spatial::SpatialObjectParams;
    use crate::plant::spatial::{GraspModel, SpatialPlantParams};
    use std::f64::consts::FRAC_PI_2;
    let params = SpatialPlantParams {
        arms: vec![
            ur5_arm(-0.70, 0.0, 0.0),
            ur5_arm(0.70, 0.0, std::f64::consts::PI),
        ],
        grasps: vec![
            grasp_frame(
                [-0.2, 0.0, 0.0],
                [0.0, 0.0, -1.0],
                [0.0, 1.0, 0.0],
                [1.0, 0.0, 0.0],
            ),
            grasp_frame(
                [0.2, 0.0, 0.0],
                [0.0, 0.0, -1.0],
                [0.0, -1.0, 0.0],
                [-1.0, 0.0, 0.0],
            ),
        ],
        object: SpatialObjectParams::spec_box(),
        gravity: nalgebra::Vector3::new(0.0, 0.0, -9.81),
        baumgarte: 20.0,
        grasp_model: GraspModel::Weld,
    };
    SpatialSetup {
        params,
        x_wo: nalgebra::Isometry3::translation(0.1, 0.0, 0.3),
        q_guess: vec![
            -0.212431, -1.267797, 1.525974, -0.258177, 1.358366, -FRAC_PI_2, //
            -0.350708, -1.754035, 2.044645, -0.290610, 1.220088, -FRAC_PI_2,
        ],
    }
}

/// [`dual_ur5`] plus a third UR5-class arm at `(0, −0.70, 0)` facing +y, holding the middle of
/// the box's −y face (tool z into the box, tool x down).
pub fn three_ur5() -> SpatialSetup {
    use std::f64::consts::FRAC_PI_2;
    let mut s = dual_ur5();
    s.params
        .arms
        .push(ur5_arm(0.0, -0.70, std::f64::consts::FRAC_PI_2));
    s.params.grasps.push(grasp_frame(
        [0.0, -0.1, 0.0],
        [0.0, 0.0, -1.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ));
    s.q_guess.extend_from_slice(&[
        -0.212431, -1.267797, 1.525974, -0.258177, 1.358366, -FRAC_PI_2,
    ]);
    s
}

/// Two Franka-class (7-DOF) arms facing each other, grasping the box from above (tool z down,
/// SPEC-spatial S6's remark): bases `(∓0.55, 0, 0)`, box at `(0, 0, 0.35)`, grasps on the top
/// face at `(∓0.12, 0, 0.1)`.
pub fn dual_franka() -> SpatialSetup {
    use crate::model::spatial::SpatialObjectParams;
    use crate::plant::spatial::{GraspModel, SpatialPlantParams};
    let params = SpatialPlantParams {
        arms: vec![
            franka_arm(-0.55, 0.0, 0.0),
            franka_arm(0.55, 0.0, std::f64::consts::PI),
        ],
        grasps: vec![
            grasp_frame(
                [-0.12, 0.0, 0.1],
                [1.0, 0.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, -1.0],
            ),
            grasp_frame(
                [0.12, 0.0, 0.1],
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, -1.0],
            ),
        ],
        object: SpatialObjectParams::spec_box(),
        gravity: nalgebra::Vector3::new(0.0, 0.0, -9.81),
        baumgarte: 20.0,
        grasp_model: GraspModel::Weld,
    };
    let ready = [0.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785];
    let mut q_guess = ready.to_vec();
    q_guess.extend_from_slice(&ready);
    SpatialSetup {
        params,
        x_wo: nalgebra::Isometry3::translation(0.0, 0.0, 0.35),
        q_guess,
    }
}

/// The SPEC-spatial S6 closed loop on a set-up: `truth` is the simulated plant (its grasps may
/// be compliant, its object heavier), `model` the controller's (welds assumed); the S6 path,
/// the given law with the `spec_s6` controller settings, the S6 disturbance, ideal sensors, a
/// start at rest 1 cm inside the circle, 1 kHz control with `plant_step`, logged every 10 ms;
/// the run stops when the grasps separate by more than `max_drift` m (a weld's drift, or a
/// compliant grasp's deflection: a slip). Returns the controller's set-up warnings too.
pub fn spatial_s6_simulation(
    truth: &crate::plant::spatial::SpatialPlantParams,
    model: &SpatialSetup,
    law: crate::control::spatial::SpatialLaw,
    duration: f64,
    plant_step: f64,
    max_drift: f64,
) -> Result<
    (
        Simulation<crate::plant::spatial::SpatialPlant, crate::control::spatial::SpatialController>,
        Vec<ControlWarning>,
    ),
    ModelError,
> {
    let p = crate::control::spatial::SpatialControllerParams::spec_s6(law);
    spatial_s6_simulation_with(truth, model, &p, duration, plant_step, max_drift)
}

/// [`spatial_s6_simulation`] with the controller settings given whole (`p`, e.g.
/// `SpatialControllerParams::spec_s6(law)` without the admittance), for studies that vary
/// them; everything else (path, start, disturbance, sensors, rates) as there.
pub fn spatial_s6_simulation_with(
    truth: &crate::plant::spatial::SpatialPlantParams,
    model: &SpatialSetup,
    p: &crate::control::spatial::SpatialControllerParams,
    duration: f64,
    plant_step: f64,
    max_drift: f64,
) -> Result<
    (
        Simulation<crate::plant::spatial::SpatialPlant, crate::control::spatial::SpatialController>,
        Vec<ControlWarning>,
    ),
    ModelError,
> {
    use crate::control::spatial::SpatialController;
    use crate::reference::spatial::path::Se3Path;
    let path = Se3Path::spec_s6();
    let (c, warnings) =
        SpatialController::new(p, &model.params, path.clone(), duration, &model.q_guess)?;
    let d0 = path.sample(0.0);
    let start = crate::sim::SpatialStart {
        x_wo: nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::from(d0.p - Vector3::new(0.01, 0.0, 0.0)),
            d0.r,
        ),
        q_guess: model.q_guess.clone(),
    };
    let sim = Simulation::with_plant(
        crate::plant::spatial::SpatialPlant::new(truth)?,
        &start,
        &SensorParams::default(),
        c,
        crate::model::disturbance::SpatialDisturbance::spec_s6(),
        SimParams {
            duration,
            plant_step,
            control_period: 1e-3,
            log_period: 0.01,
            start: [0.0; 3],
            formulation: crate::sim::Formulation::Constrained,
            max_drift,
            min_sigma: 1e-3,
        },
    )?;
    Ok((sim, warnings))
}
