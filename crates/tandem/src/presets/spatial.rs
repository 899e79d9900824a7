//! Spatial presets (SPEC-spatial S6): the embedded UR5- and Franka-class arms, two or three of
//! them around a box, and the S6 closed loop.

use nalgebra::Vector3;

use crate::control::ControlWarning;
use crate::error::ModelError;
use crate::sim::sensors::SensorParams;
use crate::sim::{SimParams, Simulation};

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
        pad_gauge: None,
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

/// [`dual_ur5`] held by friction (the `dual-ur5-grip` scenario): each UR5 has a parallel-jaw
/// gripper whose two pads (10 mm radius) squeeze the box's top and bottom faces 3 cm in from
/// its end, μ = 0.3 (silicone fingertips on steel, the Robotiq Hand-E manual's tested value),
/// torsion 0.002 m, 100 N grip (a safety factor of 4.1 on the weight: the NN law's start
/// transient slips at 60 N), pads of 1e5 N/m and 30 N s/m.
pub fn dual_ur5_grip() -> SpatialSetup {
    use crate::plant::spatial::{ContactParams, GraspModel, Pad};
    let mut s = dual_ur5();
    let pads = vec![
        Pad {
            position: nalgebra::Vector3::new(-0.1, 0.0, 0.03),
            normal: nalgebra::Vector3::new(1.0, 0.0, 0.0),
            radius: 0.01,
        },
        Pad {
            position: nalgebra::Vector3::new(0.1, 0.0, 0.03),
            normal: nalgebra::Vector3::new(-1.0, 0.0, 0.0),
            radius: 0.01,
        },
    ];
    s.params.grasp_model = GraspModel::Contact(ContactParams {
        pads: vec![pads; 2],
        grip: vec![100.0; 2],
        mu: 0.3,
        torsion: 0.002,
        normal_stiffness: 1e5,
        normal_damping: 30.0,
        tangential_stiffness: 1e5,
        tangential_damping: 30.0,
        half_extents: nalgebra::Vector3::new(0.2, 0.1, 0.1),
    });
    s
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
        pad_gauge: None,
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
    law: crate::control::law::Law<6>,
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
