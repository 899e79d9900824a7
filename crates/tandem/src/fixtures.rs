//! Ready-made models shared by tests, benches, examples and the CLI (Pinocchio's sample models).

use nalgebra::Vector3;

use crate::arm::{ArmParams, Elbow, LinkParams};
use crate::control::{ControlWarning, Controller, ControllerParams};
use crate::disturbance::Disturbance;
use crate::error::ModelError;
use crate::object::ObjectParams;
use crate::plant::PlantParams;
use crate::sensors::SensorParams;
use crate::sim::{Driver, SimParams, Simulation};
use crate::trajectory::Path;

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

/// SplitMix64 step: a well-mixed 64-bit hash of `z` (Steele, Lea, Flood 2014). Used to derive
/// independent per-run seeds from a run index, and by [`SplitMix64`].
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A tiny seeded generator for reproducible test states (SplitMix64; not for statistics —
/// the sensors use ChaCha).
#[derive(Clone, Copy, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Uniform in `[0, 1)`, 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        let z = splitmix64(self.0);
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next_f64()
    }
    /// `n` values uniform in `[−a, a)`.
    pub fn vec(&mut self, n: usize, a: f64) -> Vec<f64> {
        (0..n).map(|_| self.range(-a, a)).collect()
    }
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
