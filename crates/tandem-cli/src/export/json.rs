//! The set-up as JSON: the same facts as the MJCF, for any other tool (Drake, Pinocchio,
//! Isaac), with the conventions spelled out in the file itself.
//!
//! A pose is `{"position": [x, y, z], "quaternion": [w, x, y, z]}`: `X_AB`, frame B in frame A
//! (`p_A = R q · p_B + position`). Every number is written so that it reads back bit for bit.

use nalgebra::{Isometry3, Matrix3, Vector3};
use serde_json::{Value, json};
use tandem::model::spatial::JointKind;
use tandem::plant::spatial::GraspModel;

use super::{Setup, wxyz};

/// The format's version: raised when a field changes meaning or goes away (a new field does
/// not raise it).
pub const VERSION: u32 = 1;

fn pose(x: &Isometry3<f64>) -> Value {
    let t = x.translation.vector;
    json!({ "position": [t.x, t.y, t.z], "quaternion": wxyz(&x.rotation) })
}

fn v3(v: &Vector3<f64>) -> Value {
    json!([v.x, v.y, v.z])
}

fn m3(m: &Matrix3<f64>) -> Value {
    json!([
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]]
    ])
}

/// A number, or `null` for an infinite limit (JSON has no infinity).
fn lim(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

/// The JSON text of a set-up (pretty-printed, final newline).
pub fn write(s: &Setup) -> String {
    let mut q_names = Vec::new();
    let arms: Vec<Value> = s
        .arms
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let c = &a.chain;
            for j in &c.joints {
                q_names.push(format!("{}{}", super::mjcf::prefix(i), j.name));
            }
            let joints: Vec<Value> = c
                .joints
                .iter()
                .map(|j| {
                    json!({
                        "name": j.name,
                        "type": match j.kind {
                            JointKind::Revolute => "revolute",
                            JointKind::Prismatic => "prismatic",
                        },
                        "placement": pose(&j.placement),
                        "axis": v3(&j.axis),
                        "lower": lim(j.limits.lower),
                        "upper": lim(j.limits.upper),
                        "velocity": lim(j.limits.velocity),
                        "effort": lim(j.limits.effort),
                        "damping": j.damping,
                    })
                })
                .collect();
            let bodies: Vec<Value> = c
                .bodies
                .iter()
                .map(|b| {
                    json!({
                        "link": b.name,
                        "mass": b.mass,
                        "com": v3(&b.com),
                        "inertia": m3(&b.inertia),
                    })
                })
                .collect();
            json!({
                "name": format!("arm{i}"),
                "model": a.model,
                "urdf_path": a.urdf_path.as_ref().map(|p| p.display().to_string()),
                "base_link": c.base_link,
                "tool_link": c.tool_link,
                "base": pose(&a.base),
                "grasp": pose(&a.grasp),
                "q_start": a.q0,
                "tool_pose_start": pose(&a.tool_pose),
                "holding_torques": a.holding,
                "holding_wrench": a.holding_wrench.as_slice(),
                "chain": {
                    "robot": c.name,
                    "joints": joints,
                    "bodies": bodies,
                    "tool": pose(&c.tool),
                },
                "urdf": a.urdf,
            })
        })
        .collect();
    let grasps = match &s.grasp_model {
        GraspModel::Weld => json!({
            "model": "weld",
            "baumgarte": s.baumgarte,
        }),
        GraspModel::Compliant { stiffness, damping } => json!({
            "model": "compliant",
            "stiffness": stiffness.as_slice(),
            "damping": damping.as_slice(),
            "axes": "the grasp frame's",
        }),
        GraspModel::Contact(c) => pads_json("contact", c),
    };
    let pad_gauge = match &s.pad_gauge {
        Some(c) => pads_json("gauge", c),
        None => Value::Null,
    };
    let sc = &s.scenario;
    let mut q_start: Vec<f64> = Vec::new();
    let mut holding: Vec<f64> = Vec::new();
    for a in &s.arms {
        q_start.extend(&a.q0);
        holding.extend(&a.holding);
    }
    let v = json!({
        "format": "tandem-setup",
        "version": VERSION,
        "written_by": format!("tandem export {}", env!("CARGO_PKG_VERSION")),
        "scenario": s.name,
        "description": s.description,
        "units": {
            "length": "m", "angle": "rad", "mass": "kg", "inertia": "kg m^2", "time": "s",
            "force": "N", "torque": "N m", "joint damping": "N m s/rad (N s/m prismatic)",
        },
        "conventions": {
            "pose": "X_AB = {position, quaternion}: frame B in frame A, p_A = R(quaternion) p_B + position",
            "quaternion": "[w, x, y, z], unit, w >= 0",
            "matrices": "row-major: m[row][column]",
            "twist_and_wrench": "linear first: [v; w], [f; tau]",
            "world": "the scenario's world frame (gravity as given below)",
            "joint_order": "arm 0's joints base to tool, then arm 1's, ...: the order of q_start, holding_torques and tandem's time series",
            "limits": "null = unlimited",
            "chain": "tandem's parse of the URDF (fixed joints merged): body k is moved by joint k, its frame L_k = L_(k-1) * placement_k * J_k(q_k) (J = rotation about / translation along axis), L_(-1) = the base frame at `base`; the tool frame is `tool` in the last body's frame; inertia is about the body's centre of mass `com`, in body axes",
        },
        "gravity": v3(&s.gravity),
        "time": {
            "plant_step": s.plant_step,
            "plant_integrator": "RK4 on the closed chain (welds as constraints, Baumgarte drift control)",
            "control_period": s.control_period,
            "log_period": s.log_period,
            "duration": s.duration,
        },
        "loop": {
            "order": "start(0, the readings at rest with zero torque) once; then tick(t_k, readings) -> joint torques at t_k = k * control_period from k = 0 (the first tick on the same first frame); each tick's torques are held (zero-order hold) while the plant steps to t_(k+1)",
            "readings": "each reading is taken with the previous tick's torque held (the first with the zero torque of the start)",
            "joint_sensors": "q [rad or m], qd [rad/s or m/s], joint order as above",
            "wrist_wrench": "per arm [f; tau] (N, N m): the object's wrench on the tool, about the tool origin, in tool axes",
        },
        "arms": arms,
        "object": {
            "shape": "box",
            "size": s.size,
            "mass": s.object.mass,
            "inertia": m3(&s.object.inertia),
            "inertia_about": "the centre of mass = the object frame's origin, object axes",
            "damping": s.object.damping.as_slice(),
            "damping_on": "the twist [v; w] of the object frame, world axes (diagonal, viscous)",
            "pose_start": pose(&s.object_pose),
        },
        "grasps": grasps,
        "pad_gauge": pad_gauge,
        "start": {
            "q": q_start,
            "qd": vec![0.0; s.n_q()],
            "object_pose": pose(&s.object_pose),
            "object_twist": vec![0.0; 6],
            "holding_torques": holding,
            "holding": "the joint torques that hold the start at rest: the arms share the object's weight, no internal wrench",
            "weld_residual": { "position": s.residual.0, "rotation": s.residual.1 },
        },
        "joint_names": q_names,
        "sensors": serde_json::to_value(&sc.sensors).unwrap_or(Value::Null),
        "seed": sc.run.seed,
        "disturbance": serde_json::to_value(&sc.disturbance).unwrap_or(Value::Null),
        "disturbance_on": "the object, about its centre of mass, world axes, subtracted (F_d)",
    });
    let mut t = serde_json::to_string_pretty(&v).unwrap_or_default();
    t.push('\n');
    t
}

/// Pads: those of contact grasps (`model = "contact"`) or those gauging welds or springs
/// (`model = "gauge"`).
fn pads_json(model: &str, c: &tandem::plant::spatial::ContactParams) -> Value {
    json!({
        "model": model,
        "mu": c.mu,
        "torsion": c.torsion,
        "normal_stiffness": c.normal_stiffness,
        "normal_damping": c.normal_damping,
        "tangential_stiffness": c.tangential_stiffness,
        "tangential_damping": c.tangential_damping,
        "grip": c.grip,
        "pads": c.pads.iter().map(|list| list.iter().map(|p| json!({
            "position": p.position.as_slice(),
            "normal": p.normal.as_slice(),
            "radius": p.radius,
        })).collect::<Vec<_>>()).collect::<Vec<_>>(),
        "axes": "the tool frame's",
    })
}
