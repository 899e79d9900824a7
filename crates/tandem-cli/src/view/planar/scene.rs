//! Animation frames of a run: arms, object and desired point at every log row.
//!
//! The arms are drawn from the logged joint angles `q1..qN` (the simulated configuration,
//! redundant arms included). A log without them (an older file) falls back to reconstructing
//! the arms from `x_o` through the grasps: 2-link arms by their analytic inverse kinematics on
//! the scenario's elbow branch, other arms by numerical inverse kinematics from the previous
//! frame.

use nalgebra::Vector3;
use tandem::plant::planar::{Plant, PlantParams};
use tandem::reference::planar::path::Path;
use tandem::sim::Log;

use crate::view::planar::anim::{AnimFrames, Frame};

fn col<'a>(log: &'a Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// The frames of the animation; `q_guess` is the stacked initial guess for arms that are not
/// 2-link. Rows whose arms cannot be reconstructed reuse the previous joint angles.
pub fn frames(
    params: &PlantParams,
    log: &Log,
    path: &Path,
    k_c: [f64; 3],
    q_guess: Option<&[f64]>,
) -> anyhow::Result<AnimFrames> {
    let plant = Plant::new(params).map_err(|e| anyhow::anyhow!("{e}"))?;
    let n_q = plant.n_q();
    let (t, x, y, th) = (
        col(log, "t"),
        col(log, "x_o.x"),
        col(log, "x_o.y"),
        col(log, "x_o.theta"),
    );
    let (xd, yd) = (col(log, "x_d.x"), col(log, "x_d.y"));
    let [l, h] = params.object.size;
    let corners = [
        [-l / 2.0, -h / 2.0],
        [l / 2.0, -h / 2.0],
        [l / 2.0, h / 2.0],
        [-l / 2.0, h / 2.0],
    ];
    let mut q: Vec<f64> = q_guess.map_or_else(|| vec![0.0; n_q], <[f64]>::to_vec);
    let mut terms: Vec<_> = plant.arms().iter().map(|a| a.terms()).collect();
    let zeros = vec![0.0; n_q];
    let logged_q: Vec<&[f64]> = (1..=n_q).map(|j| col(log, &format!("q{j}"))).collect();
    let have_q = logged_q.iter().all(|c| c.len() == t.len());
    let mut out = Vec::with_capacity(t.len());
    for k in 0..t.len() {
        let x_o = Vector3::new(x[k], y[k], th[k]);
        if !x_o.iter().all(|v| v.is_finite()) {
            continue;
        }
        if have_q {
            for (j, c) in logged_q.iter().enumerate() {
                q[j] = c[k];
            }
        } else if let Ok(state) = plant.initial_state(x_o, Vector3::zeros(), Some(&q)) {
            // Joint angles from the object pose (keep the previous ones on failure).
            q.copy_from_slice(&state[..n_q]);
        }
        let arms = plant
            .arms()
            .iter()
            .enumerate()
            .map(|(i, arm)| {
                let off = plant.offset(i);
                let n = arm.dof();
                arm.kinematics(&q[off..off + n], &zeros[..n], &mut terms[i]);
                terms[i].points.iter().map(|p| [p.x, p.y]).collect()
            })
            .collect();
        let (s, c) = x_o.z.sin_cos();
        let object = corners
            .iter()
            .map(|[a, b]| [x_o.x + c * a - s * b, x_o.y + s * a + c * b])
            .collect();
        let desired = match (xd.get(k), yd.get(k)) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => Some([*a, *b]),
            _ => None,
        };
        out.push(Frame {
            t: t[k],
            arms,
            object,
            desired,
        });
    }
    // The desired path, sampled finely over the run.
    let t_end = t.last().copied().unwrap_or(0.0);
    let n = 600;
    let desired_path = (0..=n)
        .map(|i| {
            let s = path.sample(t_end * i as f64 / n as f64);
            [s.p.x, s.p.y]
        })
        .collect();
    // A frame list must be consistent: either every frame has a desired point or none.
    if out.iter().any(|f| f.desired.is_none()) {
        for f in &mut out {
            f.desired = None;
        }
    }
    Ok(AnimFrames {
        frames: out,
        desired_path,
        bounds: Some((k_c[0], k_c[1])),
    })
}
