//! The set-up as a MuJoCo model (MJCF), written from tandem's own chains (not through MuJoCo's
//! URDF importer), so that MuJoCo simulates the bodies, joints and inertias tandem simulates.
//!
//! What is written, and why:
//! - Each arm: a static base body at `X_WB`, then one body per moving joint at the joint's
//!   placement `X_PJ` in its parent (fixed joints already merged by tandem's URDF reader), the
//!   joint at the body's origin with its axis, an explicit `inertial` (mass, centre, full
//!   inertia; never derived from geometry), the URDF's viscous damping, no armature and no
//!   friction (tandem has neither). Position limits are written as `range` but not enforced
//!   (`limited="false"`): tandem's plant does not enforce them either (it reports them).
//! - The tool frame `X_LT` as a site `arm{i}_tool`, the grasp frame `X_OG` as a site
//!   `arm{i}_grasp` on the box, and a `weld` equality between the two.
//! - The box: a free body with its mass and inertia about its centre, its damping on the free
//!   joint (exact when the six values are equal: MuJoCo's free-joint damping is one number,
//!   applied to the world-axes linear and the body-axes angular velocity; tandem's is diagonal
//!   in world axes).
//! - A torque motor per joint, `ctrlrange` = ± the URDF effort (unlimited when none is given).
//! - A keyframe `start`: tandem's IK start (`qpos`), at rest, with the holding torques as
//!   `ctrl`.
//! - Contacts off (tandem has none): every geom `contype = conaffinity = 0`, and the contact
//!   flag disabled. Geoms are for looking at only (capsules between the joint origins, the box).
//!
//! Solver: RK4 at the scenario's plant step (tandem's plant integrates with RK4 at that step
//! too); Newton, which solves the welds (equalities only, no contact) in one iteration, to a
//! tolerance of 1e-12; a dense Jacobian (a few dozen degrees of freedom); the elliptic cone
//! (no contact uses it; MuJoCo's recommended cone should a user turn contacts on). The welds:
//! [`solref`], [`SOLIMP`].

use std::fmt::Write as _;

use nalgebra::{Isometry3, Matrix3, Vector3};
use tandem::model::spatial::{Chain, JointKind};
use tandem::plant::spatial::GraspModel;

use super::{Setup, wxyz};
use crate::files::fmt_f64;

/// The welds' `solref` `(timeconst, dampratio)`: critically damped with the time constant
/// equal to the model's step (`refsafe` disabled, which would raise it to two steps). The
/// weld's error then obeys `ë = −(2/h) ė − (1/h²) e`, whose eigenvalue `−1/h` times the step
/// is −1, inside RK4's stability interval (−2.78, 0) with a margin of 2.8 (measured: stable
/// down to `h/2`, unstable at `h/4`); semi-implicit Euler and `implicitfast` need two steps
/// or more (MuJoCo's own `refsafe` limit). A weld held against a load `f` gives way by
/// `(1 − d)/d · A f · h²` (`A` the constraint's inverse inertia): about 1.6e-9 m for the
/// dual-UR5 box at 1 kHz, 6.3e-9 m with MuJoCo's default of two steps.
pub fn solref(h: f64) -> String {
    format!("{} 1", fmt_f64(h))
}

/// The welds' `solimp` `(dmin, dmax, width, midpoint, power)`: impedance 0.9999 (MuJoCo's
/// largest) at every violation, so that a weld's regularisation is 1e-4 of its inertia.
pub const SOLIMP: &str = "0.9999 0.9999 0.001 0.5 2";

/// Radius of the capsules drawn along an arm, m (looks only).
const LINK_RADIUS: f64 = 0.03;

fn n(v: f64) -> String {
    fmt_f64(v)
}

fn v3(v: &Vector3<f64>) -> String {
    format!("{} {} {}", n(v.x), n(v.y), n(v.z))
}

fn quat(x: &Isometry3<f64>) -> String {
    let q = wxyz(&x.rotation);
    format!("{} {} {} {}", n(q[0]), n(q[1]), n(q[2]), n(q[3]))
}

/// `pos="…" quat="…"` of a pose in its parent.
fn pose_attrs(x: &Isometry3<f64>) -> String {
    format!("pos=\"{}\" quat=\"{}\"", v3(&x.translation.vector), quat(x))
}

/// MuJoCo's `fullinertia` order: `ixx iyy izz ixy ixz iyz`.
fn full_inertia(i: &Matrix3<f64>) -> String {
    format!(
        "{} {} {} {} {} {}",
        n(i[(0, 0)]),
        n(i[(1, 1)]),
        n(i[(2, 2)]),
        n(i[(0, 1)]),
        n(i[(0, 2)]),
        n(i[(1, 2)])
    )
}

/// Text for an XML attribute value.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\t' => o.push(' '),
            c => o.push(c),
        }
    }
    o
}

/// Text for inside an XML comment (no `--`, no trailing `-`).
fn comment(s: &str) -> String {
    let mut t: String = s
        .chars()
        .map(|c| if (c as u32) < 0x20 { ' ' } else { c })
        .collect();
    while t.contains("--") {
        t = t.replace("--", "- -");
    }
    if t.ends_with('-') {
        t.push(' ');
    }
    t
}

/// The name prefix of arm `i`'s bodies, joints, sites and motors.
pub fn prefix(i: usize) -> String {
    format!("arm{i}_")
}

/// What MuJoCo cannot express exactly: refused with the field and the way out.
fn check(s: &Setup) -> Result<(), String> {
    if let GraspModel::Compliant { .. } = s.grasp_model {
        return Err(
            "mjcf export: plant.compliant_grasps: MuJoCo's welds are constraints with their own \
             impedance, not tandem's 6-D grasp springs; export the rigid set-up (without \
             [plant.compliant_grasps]) or use --format json, which gives the springs"
                .into(),
        );
    }
    if let GraspModel::Contact(_) = s.grasp_model {
        return Err(
            "mjcf export: plant.contact_grasps: the pads' compliant contact and friction anchors \
             are tandem's model, not MuJoCo's soft contacts; export the welded set-up or use \
             --format json, which gives the pads"
                .into(),
        );
    }
    let d = &s.object.damping;
    if d.iter().any(|v| *v != d[0]) {
        return Err(format!(
            "mjcf export: object.damping = [{}]: MuJoCo's free joint takes one damping value \
             (on the linear velocity in world axes and the angular velocity in the box's axes); \
             tandem's is per axis in world axes, the same only when all six are equal. Give six \
             equal values or use --format json",
            d.iter().map(|v| n(*v)).collect::<Vec<_>>().join(", ")
        ));
    }
    Ok(())
}

/// Write the arm's chain as nested bodies inside its base body, with `indent` spaces.
fn write_chain(o: &mut String, i: usize, chain: &Chain, indent: usize) {
    let pre = prefix(i);
    let nj = chain.joints.len();
    for k in 0..nj {
        let j = &chain.joints[k];
        let b = &chain.bodies[k];
        let pad = " ".repeat(indent + 2 * k);
        let _ = writeln!(
            o,
            "{pad}<body name=\"{pre}{}\" {}>",
            escape(&b.name),
            pose_attrs(&j.placement)
        );
        let kind = match j.kind {
            JointKind::Revolute => "hinge",
            JointKind::Prismatic => "slide",
        };
        let range = if j.limits.lower.is_finite() && j.limits.upper.is_finite() {
            format!(" range=\"{} {}\"", n(j.limits.lower), n(j.limits.upper))
        } else {
            String::new()
        };
        let damping = if j.damping != 0.0 {
            format!(" damping=\"{}\"", n(j.damping))
        } else {
            String::new()
        };
        let _ = writeln!(
            o,
            "{pad}  <joint name=\"{pre}{}\" type=\"{kind}\" axis=\"{}\"{range}{damping}/>",
            escape(&j.name),
            v3(&j.axis)
        );
        let _ = writeln!(
            o,
            "{pad}  <inertial pos=\"{}\" mass=\"{}\" fullinertia=\"{}\"/>",
            v3(&b.com),
            n(b.mass),
            full_inertia(&b.inertia)
        );
        // Looks: a capsule to the next joint's origin (or the tool), a sphere when they meet.
        let to = if k + 1 < nj {
            chain.joints[k + 1].placement.translation.vector
        } else {
            chain.tool.translation.vector
        };
        if to.norm() > 1e-6 {
            let _ = writeln!(
                o,
                "{pad}  <geom type=\"capsule\" fromto=\"0 0 0 {}\" size=\"{}\"/>",
                v3(&to),
                n(LINK_RADIUS)
            );
        } else {
            let _ = writeln!(
                o,
                "{pad}  <geom type=\"sphere\" size=\"{}\"/>",
                n(LINK_RADIUS)
            );
        }
        if k + 1 == nj {
            let _ = writeln!(
                o,
                "{pad}  <site name=\"{pre}tool\" {} size=\"0.01\"/>",
                pose_attrs(&chain.tool)
            );
        }
    }
    for k in (0..nj).rev() {
        let _ = writeln!(o, "{}</body>", " ".repeat(indent + 2 * k));
    }
}

/// The MJCF text of a set-up; an error (`mjcf export: ...`) for what MuJoCo cannot express
/// exactly (compliant grasps, per-axis object damping).
pub fn write(s: &Setup) -> Result<String, String> {
    check(s)?;
    let mut o = String::new();
    let ver = env!("CARGO_PKG_VERSION");
    let _ = writeln!(
        o,
        "<!-- written by tandem export {ver} from scenario `{}`: a MuJoCo model of tandem's \
         closed chain at its start. Do not edit by hand: `tandem export` writes it again.",
        comment(&s.name)
    );
    if !s.description.is_empty() {
        let _ = writeln!(o, "     {}", comment(&s.description));
    }
    let _ = writeln!(o);
    let _ = writeln!(
        o,
        "     Joint order (qpos, qvel, ctrl), tandem's: arm 0's joints base to tool, then arm 1's, ...;"
    );
    let _ = writeln!(
        o,
        "     then the box's free joint (qpos: x y z [m, world], qw qx qy qz; qvel: linear velocity"
    );
    let _ = writeln!(
        o,
        "     in world axes, angular velocity in the box's axes, as MuJoCo's free joints have them)."
    );
    let mut idx = 0;
    for (i, a) in s.arms.iter().enumerate() {
        let names: Vec<String> = a
            .chain
            .joints
            .iter()
            .map(|j| format!("{}{}", prefix(i), comment(&j.name)))
            .collect();
        let _ = writeln!(
            o,
            "       qpos[{}..{}]: {}",
            idx,
            idx + names.len(),
            names.join(", ")
        );
        idx += names.len();
    }
    let _ = writeln!(o, "       qpos[{}..{}]: object (box)", idx, idx + 7);
    let _ = writeln!(
        o,
        "     Frames: site armI_tool is arm I's tool frame ({}), site armI_grasp the grasp frame on \
         the box; a weld holds each pair together.",
        s.arms
            .iter()
            .map(|a| comment(&a.chain.tool_link))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        o,
        "     Keyframe `start`: tandem's start (IK solved, at rest) with ctrl = the torques that \
         hold it (the arms share the box's weight, no internal wrench). Units SI, angles rad. -->"
    );
    let _ = writeln!(o, "<mujoco model=\"{}\">", escape(&s.name));
    let _ = writeln!(
        o,
        "  <compiler angle=\"radian\" autolimits=\"false\" inertiafromgeom=\"false\" \
         balanceinertia=\"false\" boundmass=\"0\" boundinertia=\"0\"/>"
    );
    let _ = writeln!(
        o,
        "  <option timestep=\"{}\" gravity=\"{}\" integrator=\"RK4\" cone=\"elliptic\" \
         jacobian=\"dense\" solver=\"Newton\" iterations=\"100\" tolerance=\"1e-12\" \
         ls_iterations=\"50\">",
        n(s.plant_step),
        v3(&s.gravity)
    );
    let _ = writeln!(
        o,
        "    <!-- contacts off: tandem has none; refsafe off: the welds' time constant is one \
         step (needs RK4: with Euler or implicitfast set the welds' solref to twice the step) -->"
    );
    let _ = writeln!(o, "    <flag contact=\"disable\" refsafe=\"disable\"/>");
    let _ = writeln!(o, "  </option>");
    let c = s.object_pose.translation.vector;
    let extent = s
        .arms
        .iter()
        .map(|a| (a.base.translation.vector - c).norm())
        .fold(0.5f64, f64::max);
    let _ = writeln!(
        o,
        "  <statistic center=\"{}\" extent=\"{}\"/>",
        v3(&c),
        n(extent)
    );
    let _ = writeln!(o, "  <default>");
    let _ = writeln!(
        o,
        "    <joint limited=\"false\" damping=\"0\" armature=\"0\" frictionloss=\"0\" stiffness=\"0\"/>"
    );
    let _ = writeln!(
        o,
        "    <geom contype=\"0\" conaffinity=\"0\" group=\"1\" rgba=\"0.6 0.65 0.7 1\"/>"
    );
    let _ = writeln!(
        o,
        "    <equality solref=\"{}\" solimp=\"{SOLIMP}\"/>",
        solref(s.plant_step)
    );
    let _ = writeln!(o, "    <motor gear=\"1\"/>");
    let _ = writeln!(o, "  </default>");
    let _ = writeln!(o, "  <worldbody>");
    let _ = writeln!(
        o,
        "    <light name=\"top\" pos=\"{} {} {}\" dir=\"0 0 -1\" directional=\"true\"/>",
        n(c.x),
        n(c.y),
        n(c.z + 3.0)
    );
    for (i, a) in s.arms.iter().enumerate() {
        let source = match (&a.model, &a.urdf_path) {
            (Some(m), _) => format!("embedded model `{m}`"),
            (None, Some(p)) => p.display().to_string(),
            (None, None) => String::new(),
        };
        let _ = writeln!(
            o,
            "    <!-- arm {i}: {} ({} → {}, {} joints) from {} -->",
            comment(&a.chain.name),
            comment(&a.chain.base_link),
            comment(&a.chain.tool_link),
            a.chain.dof(),
            comment(&source)
        );
        let _ = writeln!(
            o,
            "    <body name=\"{}{}\" {}>",
            prefix(i),
            escape(&a.chain.base_link),
            pose_attrs(&a.base)
        );
        let _ = writeln!(
            o,
            "      <geom type=\"cylinder\" size=\"0.06 0.02\" rgba=\"0.3 0.3 0.3 1\"/>"
        );
        write_chain(&mut o, i, &a.chain, 6);
        let _ = writeln!(o, "    </body>");
    }
    let h = s.size.map(|v| 0.5 * v);
    let _ = writeln!(o, "    <!-- the box: its frame at its centre of mass -->");
    let _ = writeln!(
        o,
        "    <body name=\"object\" {}>",
        pose_attrs(&s.object_pose)
    );
    let damping = s.object.damping[0];
    let _ = writeln!(
        o,
        "      <joint name=\"object\" type=\"free\"{}/>",
        if damping != 0.0 {
            format!(" damping=\"{}\"", n(damping))
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        o,
        "      <inertial pos=\"0 0 0\" mass=\"{}\" fullinertia=\"{}\"/>",
        n(s.object.mass),
        full_inertia(&s.object.inertia)
    );
    let _ = writeln!(
        o,
        "      <geom type=\"box\" size=\"{} {} {}\" rgba=\"0.85 0.55 0.2 1\"/>",
        n(h[0]),
        n(h[1]),
        n(h[2])
    );
    for (i, a) in s.arms.iter().enumerate() {
        let _ = writeln!(
            o,
            "      <site name=\"{}grasp\" {} size=\"0.01\"/>",
            prefix(i),
            pose_attrs(&a.grasp)
        );
    }
    let _ = writeln!(o, "    </body>");
    let _ = writeln!(o, "  </worldbody>");
    let _ = writeln!(o, "  <equality>");
    for i in 0..s.arms.len() {
        let p = prefix(i);
        let _ = writeln!(
            o,
            "    <weld name=\"{p}grasp\" site1=\"{p}tool\" site2=\"{p}grasp\"/>"
        );
    }
    let _ = writeln!(o, "  </equality>");
    let _ = writeln!(o, "  <actuator>");
    for (i, a) in s.arms.iter().enumerate() {
        for j in &a.chain.joints {
            let name = format!("{}{}", prefix(i), escape(&j.name));
            let e = j.limits.effort;
            let range = if e.is_finite() {
                format!(" ctrllimited=\"true\" ctrlrange=\"{} {}\"", n(-e), n(e))
            } else {
                " ctrllimited=\"false\"".to_string()
            };
            let _ = writeln!(o, "    <motor name=\"{name}\" joint=\"{name}\"{range}/>");
        }
    }
    let _ = writeln!(o, "  </actuator>");
    let mut qpos: Vec<f64> = s.arms.iter().flat_map(|a| a.q0.iter().copied()).collect();
    qpos.extend(s.object_pose.translation.vector.iter());
    qpos.extend(wxyz(&s.object_pose.rotation));
    let ctrl: Vec<f64> = s
        .arms
        .iter()
        .flat_map(|a| a.holding.iter().copied())
        .collect();
    let join = |v: &[f64]| v.iter().map(|x| n(*x)).collect::<Vec<_>>().join(" ");
    let _ = writeln!(o, "  <keyframe>");
    let _ = writeln!(
        o,
        "    <key name=\"start\" time=\"0\" qpos=\"{}\" qvel=\"{}\" ctrl=\"{}\"/>",
        join(&qpos),
        join(&vec![0.0; s.n_q() + 6]),
        join(&ctrl)
    );
    let _ = writeln!(o, "  </keyframe>");
    let _ = writeln!(o, "</mujoco>");
    Ok(o)
}
