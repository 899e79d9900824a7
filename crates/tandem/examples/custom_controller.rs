//! Your own controller in tandem's simulation loop, written outside the crate (public API only):
//! a joint PD with gravity compensation,
//!
//! ```text
//! τ = g(q) + τ_load + K_p (q0 − q) − K_d q̇,
//! ```
//!
//! `g` the arms' own gravity torques at the measured angles, `τ_load` the constant share of the
//! object's weight at the start, `q0` the start. One `Drive` implementation drives the planar
//! paper plant (under the paper's disturbance) and the spatial dual UR5 (under a sinusoidal push)
//! for 2 s each; the run prints how far the object strayed and the constraint drift.
//!
//! `cargo run --release -p tandem --example custom_controller`

use tandem::ModelError;
use tandem::drive::{Drive, Measurements, Record};
use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::model::disturbance::Disturbance;
use tandem::model::planar::grasp::distribute_wrench;
use tandem::nalgebra::{Vector2, Vector3, Vector6};
use tandem::plant::planar::Plant;
use tandem::plant::spatial::SpatialPlant;
use tandem::plant::{ClosedChain, SpatialStart};
use tandem::presets;
use tandem::sim::sensors::SensorParams;
use tandem::sim::{Log, Outcome, SimParams, Simulation};

/// The law: gains, the start, the load feed-forward and a gravity model `g(q) → τ` (no
/// allocation per call).
struct JointPd<G: FnMut(&[f64], &mut [f64])> {
    q0: Vec<f64>,
    tau_load: Vec<f64>,
    kp: f64,
    kd: f64,
    gravity: G,
}

/// What the law logs: the largest joint error (before the torques) and the PD torque norm
/// (after the sensor readings).
#[derive(Default)]
struct PdRecord {
    e_max: f64,
    pd_norm: f64,
}

impl Record for PdRecord {
    fn head_columns(&self) -> Vec<(String, String)> {
        vec![("e_max".into(), "rad".into())]
    }
    fn tail_columns(&self) -> Vec<(String, String)> {
        vec![("pd_norm".into(), "N m".into())]
    }
    fn write_head(&self, out: &mut [f64]) {
        out[0] = self.e_max;
    }
    fn write_tail(&self, out: &mut [f64]) {
        out[0] = self.pd_norm;
    }
    fn non_finite(&self) -> Option<String> {
        [("e_max", self.e_max), ("pd_norm", self.pd_norm)]
            .iter()
            .find(|(_, v)| !v.is_finite())
            .map(|(n, _)| n.to_string())
    }
}

/// One implementation for every plant: the law reads only the measurements.
impl<P: ClosedChain, G: FnMut(&[f64], &mut [f64])> Drive<P> for JointPd<G> {
    type Record = PdRecord;
    fn new_record(&self) -> PdRecord {
        PdRecord::default()
    }
    fn start(&mut self, _t0: f64, meas: &Measurements<'_>) {
        self.q0.copy_from_slice(meas.q);
    }
    fn tick(&mut self, _t: f64, meas: &Measurements<'_>, tau: &mut [f64], rec: &mut PdRecord) {
        (self.gravity)(meas.q, tau);
        let (mut e_max, mut pd2) = (0.0f64, 0.0);
        for k in 0..tau.len() {
            let e = self.q0[k] - meas.q[k];
            let pd = self.kp * e - self.kd * meas.qd[k];
            tau[k] += self.tau_load[k] + pd;
            e_max = e_max.max(e.abs());
            pd2 += pd * pd;
        }
        rec.e_max = e_max;
        rec.pd_norm = pd2.sqrt();
    }
}

/// Planar: arm gravity from `Arm::dynamics`; the object's `G_o` distributed over the grasps
/// (minimum norm) and mapped by `J_eᵀ` at the start.
fn planar_law(plant: &Plant, y0: &[f64]) -> JointPd<impl FnMut(&[f64], &mut [f64]) + use<>> {
    let (q, x, _, _) = plant.split(y0);
    let n = plant.n_q();
    let mut tx = vec![Vector2::zeros(); plant.arms().len()];
    distribute_wrench(plant.grasps(), x.z, &plant.object().G_o, 0.0, &mut tx);
    let arms = plant.arms().to_vec();
    let offsets: Vec<usize> = (0..arms.len()).map(|i| plant.offset(i)).collect();
    let mut terms: Vec<_> = arms.iter().map(|a| a.terms()).collect();
    let zeros = vec![0.0; n];
    let mut tau_load = vec![0.0; n];
    for (i, arm) in arms.iter().enumerate() {
        let (o, d) = (offsets[i], arm.dof());
        arm.dynamics(
            &q[o..o + d],
            &zeros[o..o + d],
            plant.gravity(),
            &mut terms[i],
        );
        for k in 0..d {
            tau_load[o + k] = terms[i].J.column(k).dot(&tx[i]);
        }
    }
    let g = plant.gravity();
    JointPd {
        q0: q.to_vec(),
        tau_load,
        kp: 400.0,
        kd: 20.0,
        gravity: move |q: &[f64], tau: &mut [f64]| {
            for (i, arm) in arms.iter().enumerate() {
                let (o, d) = (offsets[i], arm.dof());
                arm.dynamics(&q[o..o + d], &zeros[o..o + d], g, &mut terms[i]);
                tau[o..o + d].copy_from_slice(terms[i].G.as_slice());
            }
        },
    }
}

/// Spatial: arm gravity from `dynamics::spatial::gravity`; the object's share is the plant's holding
/// torques at the start minus the arms' own gravity there.
fn spatial_law(
    plant: &SpatialPlant,
    y0: &[f64],
) -> JointPd<impl FnMut(&[f64], &mut [f64]) + use<>> {
    let n = plant.n_q();
    let mut hold = vec![0.0; n];
    plant.holding_torques(y0, &mut plant.workspace(), &mut hold);
    let arms = plant.arms().to_vec();
    let offsets: Vec<usize> = (0..arms.len()).map(|i| plant.offset(i)).collect();
    let g = plant.gravity();
    let mut data: Vec<ChainData> = arms.iter().map(ChainData::new).collect();
    let mut gravity = move |q: &[f64], tau: &mut [f64]| {
        for (i, arm) in arms.iter().enumerate() {
            let (o, d) = (offsets[i], arm.chain.dof());
            spatial::gravity(arm, &q[o..o + d], &g, &mut tau[o..o + d], &mut data[i]);
        }
    };
    let mut g0 = vec![0.0; n];
    gravity(&y0[..n], &mut g0);
    JointPd {
        q0: y0[..n].to_vec(),
        tau_load: hold.iter().zip(&g0).map(|(h, g)| h - g).collect(),
        kp: 400.0,
        kd: 20.0,
        gravity,
    }
}

/// A 2 N / 0.2 N m sinusoidal push on the spatial object (world axes).
fn push() -> tandem::model::disturbance::SpatialDisturbance {
    tandem::model::disturbance::Disturbance {
        amplitude: [2.0, 0.0, 0.0, 0.0, 0.0, 0.2],
        frequency: [2.0; 6],
        phase: [0.0; 6],
        pushes: vec![],
    }
}

fn largest_offset(log: &Log, axes: &[&str], start: &[f64]) -> f64 {
    let cols: Vec<&[f64]> = axes
        .iter()
        .map(|a| log.get(&format!("x_o.{a}")).unwrap_or(&[]))
        .collect();
    (0..log.len())
        .map(|k| {
            cols.iter()
                .zip(start)
                .map(|(c, s)| (c[k] - s).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

fn report(name: &str, out: &Outcome, offset: f64) {
    match &out.fault {
        Some(f) => println!("{name}: stopped: {f}"),
        None => println!(
            "{name}: {:.1} s in {:.3} s wall; object within {offset:.2e} m of its start; \
             drift ≤ {:.1e} m, {:.1e} rad; {} log columns",
            out.t_end,
            out.wall_time,
            out.max_drift,
            out.max_drift_rot,
            out.log.columns.len()
        ),
    }
}

fn main() -> Result<(), ModelError> {
    let run = |plant_step: f64| SimParams {
        duration: 2.0,
        plant_step,
        log_period: 0.01,
        ..SimParams::paper()
    };
    let ideal = SensorParams::default();

    // (a) The planar paper plant, under the paper's disturbance.
    let params = presets::paper();
    let plant = Plant::new(&params)?;
    let y0 = plant.initial_state(presets::paper_start(), Vector3::zeros(), None)?;
    let law = planar_law(&plant, &y0);
    let sim = Simulation::new(&params, &ideal, law, Disturbance::paper(), run(1e-3), None)?;
    let (out, _) = sim.run(|_| {});
    let x0 = presets::paper_start();
    report(
        "planar",
        &out,
        largest_offset(&out.log, &["x", "y"], &[x0.x, x0.y]),
    );

    // (b) The spatial dual UR5, under a sinusoidal push.
    let s = presets::dual_ur5();
    let plant = SpatialPlant::new(&s.params)?;
    let y0 = plant.initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)?;
    let law = spatial_law(&plant, &y0);
    let start = SpatialStart {
        x_wo: s.x_wo,
        q_guess: s.q_guess.clone(),
    };
    let sim = Simulation::with_plant(plant, &start, &ideal, law, push(), run(5e-4))?;
    let (out, _) = sim.run(|_| {});
    let p0 = s.x_wo.translation.vector;
    report(
        "spatial",
        &out,
        largest_offset(&out.log, &["x", "y", "z"], p0.as_slice()),
    );
    Ok(())
}
