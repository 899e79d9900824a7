//! The 3-D viewer of a spatial run (SPEC-spatial S7): one self-contained HTML page that plays
//! the motion offline ([`write_viewer`]) and static orthographic snapshots for reports
//! ([`write_snapshots`]).
//!
//! Data flow: `(plant, t_k, y_k)` → forward kinematics ([`scene_from_states`]) → [`Scene3d`]
//! (plain data: points and poses per frame) → `viewer.html` (the data embedded as JSON, rounded
//! to 0.1 mm / 1e-4 / 5 significant digits, the WebGL page from `viewer.html` + `viewer.js`
//! written in the project) and `snapshot_{front,side,top}.{png,svg}` (plotters, house style).
//!
//! The page makes no network request of any kind (no CDN, no font, `data:` favicon) and works
//! from `file://`. It exposes `window.tandemViewer = { seek(t), play(), pause(), frames, ready }`
//! for tests. See `docs/viewer.md`.
//!
//! Non-finite values (a run that faulted) never break the page: a frame with any non-finite
//! point of an arm or the object is marked invalid, the page shows the last valid frame and a
//! note in the HUD; non-finite scalars and wrenches are shown as "n/a" / not drawn.
//!
//! The module is self-contained (external crates, [`crate::files`] and [`crate::figures::plot`]), so
//! tests and examples can compile it with `#[path]`.

pub mod demo;
mod snapshot;

use std::path::Path;

use anyhow::Result;
use nalgebra::Isometry3;
use serde_json::{Value, json};
use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::plant::spatial::SpatialPlant;

/// The page template (the data and the script are substituted in).
const HTML_TEMPLATE: &str = include_str!("viewer.html");
/// The viewer's script (plain WebGL, no library).
const JS_SOURCE: &str = include_str!("viewer.js");

/// Everything the viewer draws, per frame (plain data, world frame `W`, z up, SI units).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene3d {
    /// Title shown in the HUD and on the snapshots.
    pub title: String,
    /// Frame times, s, increasing (one entry per frame).
    pub times: Vec<f64>,
    /// The arms.
    pub arms: Vec<ArmTrack>,
    /// The carried object (a box).
    pub object: ObjectTrack,
    /// Desired path of the object's origin, m (any number of points, drawn as a line).
    pub desired_path: Vec<[f64; 3]>,
    /// Grasp wrenches per frame, per arm: `[f; τ]` (N, N m) on the tool, about the tool origin,
    /// world axes. Empty: no arrows.
    pub wrenches: Vec<Vec<[f64; 6]>>,
    /// Scalars shown as text in the HUD, aligned with `times` (e.g. error, margin).
    pub scalars: Vec<ScalarTrack>,
    /// Free-form notes shown in the HUD (e.g. "kinematic playback").
    pub notes: Vec<String>,
    /// Contact grasps' pads, drawn with their friction cones and coloured by state. Empty:
    /// none.
    pub pads: Vec<PadTrack>,
}

/// A contact pad on a tool and its state over the frames.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PadTrack {
    /// The arm (0-based) whose tool carries it.
    pub arm: usize,
    /// Centre, tool frame, m.
    pub position: [f64; 3],
    /// Pressing direction (into the object), tool axes.
    pub normal: [f64; 3],
    /// Radius, m.
    pub radius: f64,
    /// Friction coefficient (the cone's half angle is `atan μ`).
    pub mu: f64,
    /// Per frame: 0 stick, 1 slip, 2 separated (NaN: unknown).
    pub state: Vec<f64>,
}

/// One arm's motion.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ArmTrack {
    /// Label, e.g. `"arm 1 (ur5)"`.
    pub name: String,
    /// `p_WB`: base origin, m.
    pub base: [f64; 3],
    /// Per frame, the joint-frame origins `p_WL_k` base → tool (n points), m. The links are
    /// drawn base → `p_WL_0` → … → `p_WL_{n−1}` → tool origin.
    pub joints: Vec<Vec<[f64; 3]>>,
    /// Per frame, the tool frame `X_WT`: origin (m) and orientation quaternion `(w, x, y, z)`.
    pub tool: Vec<([f64; 3], [f64; 4])>,
}

/// The carried box.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectTrack {
    /// Edge lengths along the object's x, y, z axes, m.
    pub size: [f64; 3],
    /// Per frame, `X_WO`: origin (m) and orientation quaternion `(w, x, y, z)`.
    pub poses: Vec<([f64; 3], [f64; 4])>,
}

/// A named scalar signal shown in the HUD.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScalarTrack {
    /// Name, e.g. `"error |p − p_d|"`.
    pub name: String,
    /// Unit, e.g. `"m"` (empty for none).
    pub unit: String,
    /// One value per frame (NaN: shown as "n/a").
    pub values: Vec<f64>,
}

impl ScalarTrack {
    /// A scalar from its name, unit and values.
    pub fn new(name: impl Into<String>, unit: impl Into<String>, values: Vec<f64>) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            values,
        }
    }
}

fn pose_parts(x: &Isometry3<f64>) -> ([f64; 3], [f64; 4]) {
    let p = x.translation.vector;
    let q = x.rotation.quaternion();
    ([p.x, p.y, p.z], [q.w, q.i, q.j, q.k])
}

/// The arms and the object of the flat plant states `states[k]` at `times[k]` by forward
/// kinematics (`tandem::dynamics::spatial::kinematics`: `X_WL` per body, `X_WT`); `box_size` is the
/// object's edge lengths (m). Desired path, wrenches, scalars and notes are left empty for the
/// caller. A state of the wrong length or with non-finite joint angles gives NaN points for
/// that frame (the page skips it).
pub fn scene_from_states(
    title: &str,
    plant: &SpatialPlant,
    box_size: [f64; 3],
    times: &[f64],
    states: &[Vec<f64>],
) -> Scene3d {
    let nan3 = [f64::NAN; 3];
    let nan4 = [f64::NAN; 4];
    let mut arms: Vec<ArmTrack> = plant
        .arms()
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let b = a.base.translation.vector;
            ArmTrack {
                name: format!("arm {} ({})", i + 1, a.chain.name),
                base: [b.x, b.y, b.z],
                joints: Vec::with_capacity(states.len()),
                tool: Vec::with_capacity(states.len()),
            }
        })
        .collect();
    let mut data: Vec<ChainData> = plant.arms().iter().map(ChainData::new).collect();
    let mut poses = Vec::with_capacity(states.len());
    for y in states {
        let ok = y.len() == plant.state_dim();
        for (i, arm) in plant.arms().iter().enumerate() {
            let n = arm.chain.dof();
            let s = plant.offset(i);
            let q = if ok { &y[s..s + n] } else { &[][..] };
            if ok && q.iter().all(|v| v.is_finite()) {
                let d = &mut data[i];
                spatial::kinematics(arm, q, None, d);
                arms[i]
                    .joints
                    .push(d.X_WL.iter().map(|x| pose_parts(x).0).collect());
                arms[i].tool.push(pose_parts(&d.X_WT));
            } else {
                arms[i].joints.push(vec![nan3; n]);
                arms[i].tool.push((nan3, nan4));
            }
        }
        if ok {
            let (_, o, _) = plant.split(y);
            poses.push(pose_parts(&o.pose()));
        } else {
            poses.push((nan3, nan4));
        }
    }
    Scene3d {
        title: title.to_string(),
        times: times.to_vec(),
        arms,
        object: ObjectTrack {
            size: box_size,
            poses,
        },
        ..Scene3d::default()
    }
}

/// Rounds to a multiple of `step` (a power of ten ≤ 1, e.g. 1e-4); non-finite → JSON null.
fn fixed(v: f64, decimals: i32) -> Value {
    if !v.is_finite() {
        return Value::Null;
    }
    let s = 10f64.powi(decimals);
    let r = (v * s).round() / s;
    // Integers print without ".0" and keep the page small.
    if r == r.trunc() && r.abs() < 1e15 {
        json!(r as i64)
    } else {
        json!(r)
    }
}

/// Rounds to `digits` significant digits; non-finite → JSON null.
fn sig(v: f64, digits: i32) -> Value {
    if !v.is_finite() {
        return Value::Null;
    }
    if v == 0.0 {
        return json!(0);
    }
    let e = v.abs().log10().floor() as i32;
    let d = digits - 1 - e;
    if d >= 0 {
        fixed(v, d.min(15))
    } else {
        let s = 10f64.powi(-d);
        let r = (v / s).round() * s;
        if r.abs() < 1e15 {
            json!(r as i64)
        } else {
            json!(r)
        }
    }
}

/// A point rounded to 0.1 mm.
fn p3(p: &[f64; 3]) -> Value {
    Value::Array(p.iter().map(|v| fixed(*v, 4)).collect())
}

/// A pose as `[x, y, z, w, qx, qy, qz]`: 0.1 mm and 1e-5 (≈ 1e-3 °).
fn pose7(x: &([f64; 3], [f64; 4])) -> Value {
    let mut v: Vec<Value> = x.0.iter().map(|v| fixed(*v, 4)).collect();
    v.extend(x.1.iter().map(|v| fixed(*v, 5)));
    Value::Array(v)
}

/// Whether every value of a frame's geometry is finite.
fn frame_valid(scene: &Scene3d, k: usize) -> bool {
    let fin3 = |p: &[f64; 3]| p.iter().all(|v| v.is_finite());
    let fin_pose = |x: &([f64; 3], [f64; 4])| fin3(&x.0) && x.1.iter().all(|v| v.is_finite());
    scene.object.poses.get(k).is_some_and(fin_pose)
        && scene.arms.iter().all(|a| {
            a.joints.get(k).is_some_and(|j| j.iter().all(fin3))
                && a.tool.get(k).is_some_and(fin_pose)
        })
}

/// The scene as the JSON the page reads (rounded; non-finite values as null; per-frame arrays
/// cut or padded to the number of frames).
pub fn scene_json(scene: &Scene3d) -> Value {
    let n = scene.times.len();
    let valid: Vec<bool> = (0..n).map(|k| frame_valid(scene, k)).collect();
    let invalid = valid.iter().filter(|v| !**v).count();
    let mut notes = scene.notes.clone();
    if invalid > 0 {
        notes.push(format!(
            "{invalid} of {n} frames have non-finite values and are skipped (the last valid frame is shown)"
        ));
    }
    let arms: Vec<Value> = scene
        .arms
        .iter()
        .map(|a| {
            let joints: Vec<Value> = (0..n)
                .map(|k| match a.joints.get(k) {
                    Some(j) if valid[k] => Value::Array(j.iter().map(p3).collect()),
                    _ => Value::Null,
                })
                .collect();
            let tool: Vec<Value> = (0..n)
                .map(|k| match a.tool.get(k) {
                    Some(x) if valid[k] => pose7(x),
                    _ => Value::Null,
                })
                .collect();
            json!({ "name": a.name, "base": p3(&a.base), "joints": joints, "tool": tool })
        })
        .collect();
    let object: Vec<Value> = (0..n)
        .map(|k| match scene.object.poses.get(k) {
            Some(x) if valid[k] => pose7(x),
            _ => Value::Null,
        })
        .collect();
    let wrenches: Vec<Value> = if scene.wrenches.is_empty() {
        Vec::new()
    } else {
        (0..n)
            .map(|k| match scene.wrenches.get(k) {
                Some(w) => Value::Array(
                    w.iter()
                        .map(|f| Value::Array(f.iter().map(|v| sig(*v, 5)).collect()))
                        .collect(),
                ),
                None => Value::Null,
            })
            .collect()
    };
    let scalars: Vec<Value> = scene
        .scalars
        .iter()
        .map(|s| {
            let v: Vec<Value> = (0..n)
                .map(|k| s.values.get(k).map_or(Value::Null, |v| sig(*v, 5)))
                .collect();
            json!({ "name": s.name, "unit": s.unit, "values": v })
        })
        .collect();
    json!({
        "title": scene.title,
        "times": scene.times.iter().map(|t| sig(*t, 7)).collect::<Vec<_>>(),
        "valid": valid,
        "box": scene.object.size.iter().map(|v| fixed(*v, 4)).collect::<Vec<_>>(),
        "object": object,
        "arms": arms,
        "desired": scene.desired_path.iter().map(p3).collect::<Vec<_>>(),
        "wrenches": wrenches,
        "scalars": scalars,
        "notes": notes,
        "pads": scene.pads.iter().map(|p| json!({
            "arm": p.arm,
            "p": p.position.iter().map(|v| fixed(*v, 5)).collect::<Vec<_>>(),
            "n": p.normal.iter().map(|v| fixed(*v, 5)).collect::<Vec<_>>(),
            "r": fixed(p.radius, 5),
            "mu": sig(p.mu, 4),
            "state": (0..n).map(|k| p.state.get(k).map_or(Value::Null, |v| fixed(*v, 0))).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

/// The whole viewer page (HTML, CSS, script and data in one file; no external reference).
pub fn write_viewer(scene: &Scene3d) -> String {
    // `</` inside the JSON or the script must not close the <script> element.
    let data = serde_json::to_string(&scene_json(scene))
        .expect("a JSON value serialises")
        .replace("</", "<\\/");
    let title = html_escape(&scene.title);
    HTML_TEMPLATE
        .replacen("{{TITLE}}", &title, 1)
        .replacen("{{SCRIPT}}", &JS_SOURCE.replace("</", "<\\/"), 1)
        .replacen("{{DATA}}", &data, 1)
}

/// Writes `viewer.html` into `dir` atomically (whole or not at all); returns its path.
pub fn write_viewer_file(scene: &Scene3d, dir: &Path) -> Result<std::path::PathBuf> {
    let path = dir.join("viewer.html");
    crate::files::write_text_atomic(&path, &write_viewer(scene))?;
    Ok(path)
}

/// Writes `snapshot_front`, `snapshot_side` and `snapshot_top` (`.png` and `.svg`, each whole
/// or not at all) into `dir`: orthographic views (front looks along +y, side along −x, top
/// along −z) of the first valid frame (faded) and the last (solid), with the box, the desired
/// and traced paths, the end pose's tool frames, metre axes and a legend. Errors if no frame
/// is valid.
pub fn write_snapshots(scene: &Scene3d, dir: &Path) -> Result<()> {
    snapshot::write(scene, dir)
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('{', "&#123;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding() {
        assert_eq!(fixed(0.123456, 4), json!(0.1235));
        assert_eq!(fixed(-0.7, 4), json!(-0.7));
        assert_eq!(fixed(2.0, 4), json!(2));
        assert_eq!(fixed(f64::NAN, 4), Value::Null);
        assert_eq!(sig(12345.67, 5), json!(12346));
        assert_eq!(sig(1234567.0, 5), json!(1234600));
        assert_eq!(sig(0.000123456789, 5), json!(0.00012346));
        assert_eq!(sig(-9.81, 5), json!(-9.81));
        assert_eq!(sig(f64::INFINITY, 5), Value::Null);
    }
}
