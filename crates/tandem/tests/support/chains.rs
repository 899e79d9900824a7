//! Chains shared by `tests/dynamics.rs` and `benches/dynamics.rs` (included with `#[path]`):
//! a Franka-Panda-like and a UR5-like arm built programmatically, and a test-only
//! `Chain → URDF` writer for the dynibo comparisons.
#![allow(dead_code)]

use nalgebra::{Isometry3, Matrix3, Translation3, Unit, UnitQuaternion, Vector3};
use tandem::model::spatial::{Chain, ChainJoint, JointKind, JointLimits, RigidBody};

/// A movable joint without limits or damping.
pub fn joint(
    name: &str,
    kind: JointKind,
    placement: Isometry3<f64>,
    axis: Vector3<f64>,
) -> ChainJoint {
    ChainJoint {
        name: name.to_string(),
        kind,
        placement,
        axis: Unit::new_normalize(axis),
        limits: JointLimits::UNLIMITED,
        damping: 0.0,
    }
}

/// A chain from modified-DH rows `(a, d, α)` (`X_PJ = RotX(α) TransX(a) TransZ(d)`, joint axis
/// z) and bodies `(m, c, [Ixx, Iyy, Izz, Ixy, Ixz, Iyz])`.
fn from_mdh(
    name: &str,
    prefix: &str,
    dh: &[(f64, f64, f64)],
    bodies: &[(f64, [f64; 3], [f64; 6])],
    tool: Isometry3<f64>,
) -> Chain {
    let mut joints = Vec::new();
    let mut bs = Vec::new();
    for (k, (&(a, d, alpha), &(m, c, i))) in dh.iter().zip(bodies.iter()).enumerate() {
        let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), alpha);
        let placement = Isometry3::from_parts(
            Translation3::from(Vector3::new(a, 0.0, 0.0) + rx * Vector3::new(0.0, 0.0, d)),
            rx,
        );
        joints.push(joint(
            &format!("{prefix}_joint{}", k + 1),
            JointKind::Revolute,
            placement,
            Vector3::z(),
        ));
        let [ixx, iyy, izz, ixy, ixz, iyz] = i;
        bs.push(RigidBody {
            name: format!("{prefix}_link{}", k + 1),
            mass: m,
            com: Vector3::from(c),
            inertia: Matrix3::new(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz),
        });
    }
    let chain = Chain {
        name: name.to_string(),
        base_link: format!("{prefix}_link0"),
        tool_link: "tool".to_string(),
        joints,
        bodies: bs,
        tool,
    };
    chain.validate().expect("chain is valid");
    chain
}

/// A Franka-Panda-like 7-DOF chain (modified-DH offsets and rounded link inertias in the style
/// of the published Panda parameter tables; exact values do not matter for the checks).
pub fn panda_like() -> Chain {
    use std::f64::consts::FRAC_PI_2 as H;
    let dh = [
        (0.0, 0.333, 0.0),
        (0.0, 0.0, -H),
        (0.0, 0.316, H),
        (0.0825, 0.0, H),
        (-0.0825, 0.384, -H),
        (0.0, 0.0, H),
        (0.088, 0.0, H),
    ];
    let bodies = [
        (
            4.97,
            [0.0039, 0.0021, -0.0476],
            [0.7034, 0.7066, 0.0091, -0.0001, 0.0068, 0.0192],
        ),
        (
            0.65,
            [-0.0031, -0.0287, 0.0035],
            [0.0080, 0.0281, 0.0260, -0.0040, 0.0001, 0.0007],
        ),
        (
            3.23,
            [0.0275, 0.0392, -0.0665],
            [0.0372, 0.0361, 0.0108, -0.0048, -0.0114, -0.0128],
        ),
        (
            3.59,
            [-0.0532, 0.1043, 0.0274],
            [0.0259, 0.0196, 0.0286, 0.0078, -0.0013, 0.0086],
        ),
        (
            1.23,
            [-0.0120, 0.0410, -0.0380],
            [0.0355, 0.0295, 0.0086, -0.0021, 0.0002, 0.0002],
        ),
        (
            1.67,
            [0.0601, -0.0141, -0.0105],
            [0.0020, 0.0043, 0.0054, 0.0001, -0.0012, -0.0003],
        ),
        (
            0.74,
            [0.0105, -0.0043, 0.0617],
            [0.0126, 0.0101, 0.0048, -0.0004, -0.0012, 0.0010],
        ),
    ];
    let tool = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 0.107 + 0.1034),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -std::f64::consts::FRAC_PI_4),
    );
    from_mdh("panda_like", "panda", &dh, &bodies, tool)
}

/// A UR5-like 6-DOF chain (the standard UR5 DH lengths written as modified DH, link masses of
/// the published UR5 table, cylinder-like inertias).
pub fn ur5_like() -> Chain {
    use std::f64::consts::FRAC_PI_2 as H;
    let dh = [
        (0.0, 0.089159, 0.0),
        (0.0, 0.0, H),
        (-0.425, 0.0, 0.0),
        (-0.39225, 0.10915, 0.0),
        (0.0, 0.09465, H),
        (0.0, 0.0823, -H),
    ];
    let bodies = [
        (
            3.7,
            [0.0, -0.02561, 0.00193],
            [0.0104, 0.0104, 0.0067, 0.0, 0.0, 0.0],
        ),
        (
            8.393,
            [-0.2125, 0.0, 0.11336],
            [0.0151, 0.1338, 0.1338, 0.0, 0.0, 0.0],
        ),
        (
            2.275,
            [-0.15, 0.0, 0.0265],
            [0.0041, 0.0312, 0.0312, 0.0, 0.0, 0.0],
        ),
        (
            1.219,
            [0.0, -0.0018, 0.01634],
            [0.0022, 0.0022, 0.0026, 0.0, 0.0, 0.0],
        ),
        (
            1.219,
            [0.0, 0.0018, 0.01634],
            [0.0022, 0.0022, 0.0026, 0.0, 0.0, 0.0],
        ),
        (
            0.1879,
            [0.0, 0.0, -0.001159],
            [0.0001, 0.0001, 0.0001, 0.0, 0.0, 0.0],
        ),
    ];
    from_mdh(
        "ur5_like",
        "ur5",
        &dh,
        &bodies,
        Isometry3::translation(0.0, 0.0, 0.0),
    )
}

/// `X_AB` → URDF `<origin xyz rpy>`; URDF rpy is `R = Rz(yaw) Ry(pitch) Rx(roll)`, nalgebra's
/// `euler_angles` convention. Numbers are written in Rust's shortest round-trip form.
pub fn urdf_origin(x: &Isometry3<f64>) -> String {
    let t = x.translation.vector;
    let (r, p, y) = x.rotation.euler_angles();
    format!(
        "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
        t.x, t.y, t.z, r, p, y
    )
}

/// A chain as URDF text (test-only writer): links `base`, the bodies, and a massless `tool`
/// link on a fixed joint. The base pose is **not** written (dynibo's root is at its base frame):
/// pass `absorb_base(arm)` or set dynibo's base frame.
pub fn chain_to_urdf(chain: &Chain) -> String {
    let mut s = format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"{}\">\n  <link name=\"{}\"/>\n",
        chain.name, chain.base_link
    );
    let mut parent = chain.base_link.clone();
    for (j, b) in chain.joints.iter().zip(&chain.bodies) {
        let kind = match j.kind {
            JointKind::Revolute => "revolute",
            JointKind::Prismatic => "prismatic",
        };
        let a = j.axis.into_inner();
        let i = &b.inertia;
        s += &format!(
            "  <joint name=\"{}\" type=\"{kind}\">\n    <parent link=\"{parent}\"/>\n    <child link=\"{}\"/>\n    {}\n    <axis xyz=\"{} {} {}\"/>\n    <limit lower=\"-100\" upper=\"100\" effort=\"1000\" velocity=\"100\"/>\n  </joint>\n",
            j.name,
            b.name,
            urdf_origin(&j.placement),
            a.x,
            a.y,
            a.z
        );
        s += &format!(
            "  <link name=\"{}\">\n    <inertial>\n      <origin xyz=\"{} {} {}\" rpy=\"0 0 0\"/>\n      <mass value=\"{}\"/>\n      <inertia ixx=\"{}\" ixy=\"{}\" ixz=\"{}\" iyy=\"{}\" iyz=\"{}\" izz=\"{}\"/>\n    </inertial>\n  </link>\n",
            b.name,
            b.com.x,
            b.com.y,
            b.com.z,
            b.mass,
            i[(0, 0)],
            i[(0, 1)],
            i[(0, 2)],
            i[(1, 1)],
            i[(1, 2)],
            i[(2, 2)]
        );
        parent = b.name.clone();
    }
    s += &format!(
        "  <joint name=\"tool_fixed\" type=\"fixed\">\n    <parent link=\"{parent}\"/>\n    <child link=\"{}\"/>\n    {}\n  </joint>\n  <link name=\"{}\"/>\n</robot>\n",
        chain.tool_link,
        urdf_origin(&chain.tool),
        chain.tool_link
    );
    s
}
