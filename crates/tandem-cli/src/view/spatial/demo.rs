//! Kinematic playback (no dynamics, no controller): the closed chain solved by inverse
//! kinematics at each desired pose of a path, for the viewer's example and tests until the
//! spatial `run` command feeds the viewer with simulated runs.
//!
//! Per frame `t_k`: `(p_d, R_d, V_d) = path(t_k)` → `SpatialPlant::initial_state` (each arm's
//! IK onto its grasp frame from the previous frame's angles, rates from `J q̇ = Ad V`) → the
//! flat state `y_k`; then the static holding wrenches (`holding_torques`: the arms share the
//! box's weight, no internal wrench) and three scalars: the weld residual, the smallest
//! singular value of the arms' Jacobians and the smallest distance to a joint limit.

use anyhow::{Context, Result};
use nalgebra::{Isometry3, Translation3};
use tandem::plant::spatial::SpatialPlant;
use tandem::presets::SpatialSetup;
use tandem::reference::spatial::path::Se3Path;

use super::{ScalarTrack, Scene3d, scene_from_states};

/// A kinematic playback: the plant, the frame times and the flat states.
pub struct Playback {
    /// The validated plant of the set-up.
    pub plant: SpatialPlant,
    /// Frame times, s.
    pub times: Vec<f64>,
    /// Flat plant states per frame (see `tandem::plant::spatial`).
    pub states: Vec<Vec<f64>>,
}

/// Plays `path` on `setup` kinematically over `[0, t_end]` at `fps` frames per second (at
/// least one frame). Errors name the frame whose pose the chain cannot reach.
pub fn play(setup: &SpatialSetup, path: &Se3Path, t_end: f64, fps: f64) -> Result<Playback> {
    let plant = SpatialPlant::new(&setup.params).context("the set-up's plant is invalid")?;
    if !(t_end >= 0.0 && t_end.is_finite() && fps > 0.0 && fps.is_finite()) {
        anyhow::bail!("kinematic playback needs t_end ≥ 0 and fps > 0 (got {t_end} s, {fps} /s)");
    }
    let frames = (t_end * fps).round() as usize + 1;
    let mut q = setup.q_guess.clone();
    let mut times = Vec::with_capacity(frames);
    let mut states = Vec::with_capacity(frames);
    for k in 0..frames {
        let t = k as f64 / fps;
        let s = path.sample(t);
        let x_wo = Isometry3::from_parts(Translation3::from(s.p), s.r);
        let y = plant
            .initial_state(&x_wo, &s.twist(), &q)
            .with_context(|| format!("kinematic playback: frame {k} (t = {t:.3} s)"))?;
        q.copy_from_slice(&y[..plant.n_q()]);
        times.push(t);
        states.push(y);
    }
    Ok(Playback {
        plant,
        times,
        states,
    })
}

/// The viewer scene of a playback: arms and box, the desired path (`path` sampled at 4 Hz over
/// the playback, plus its end), the static holding wrenches and the scalars described in the
/// module doc. `box_size` in m.
pub fn scene(title: &str, pb: &Playback, path: &Se3Path, box_size: [f64; 3]) -> Scene3d {
    let plant = &pb.plant;
    let mut sc = scene_from_states(title, plant, box_size, &pb.times, &pb.states);
    let t_end = pb.times.last().copied().unwrap_or(0.0);
    let n_path = ((t_end * 4.0).ceil() as usize).max(1);
    sc.desired_path = (0..=n_path)
        .map(|k| {
            let p = path.sample(t_end * k as f64 / n_path as f64).p;
            [p.x, p.y, p.z]
        })
        .collect();
    let mut ws = plant.workspace();
    let mut tau = vec![0.0; plant.n_q()];
    let (mut resid, mut sigma, mut margin) = (vec![], vec![], vec![]);
    for y in &pb.states {
        plant.holding_torques(y, &mut ws, &mut tau);
        sc.wrenches.push(
            ws.wrenches
                .iter()
                .map(|w| [w[0], w[1], w[2], w[3], w[4], w[5]])
                .collect(),
        );
        let (lin, _ang) = plant.constraint_residual(y, &mut ws);
        resid.push(lin);
        sigma.push(plant.min_singular_value(y, &mut ws));
        let mut m = f64::INFINITY;
        for (i, arm) in plant.arms().iter().enumerate() {
            let s = plant.offset(i);
            for (k, j) in arm.chain.joints.iter().enumerate() {
                let q = y[s + k];
                m = m.min(q - j.limits.lower).min(j.limits.upper - q);
            }
        }
        margin.push(m);
    }
    sc.scalars = vec![
        ScalarTrack::new("weld residual", "m", resid),
        ScalarTrack::new("σ_min(J)", "", sigma),
        ScalarTrack::new("joint-limit margin", "rad", margin),
    ];
    sc.notes.push(
        "kinematic playback: inverse kinematics along the desired path, no dynamics; wrenches = static holding share"
            .into(),
    );
    sc
}
