//! URDF loader (`model::spatial::urdf`, SPEC-spatial S2): typed errors with lines, fixed-joint merging,
//! conventions, and the embedded models.

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use tandem::model::spatial::urdf::{Urdf, UrdfError, load_chain};
use tandem::model::spatial::{Chain, JointKind};

/// 1-based line of the first occurrence of `needle` in `text`.
fn line_of(text: &str, needle: &str) -> u32 {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("`{needle}` not in text"));
    1 + text[..at].matches('\n').count() as u32
}

/// A small two-link arm, one element per line, with `extra` spliced in before `</robot>`.
fn two_link(extra: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <link name="link1">
    <inertial>
      <origin xyz="0.15 0 0" rpy="0 0 0"/>
      <mass value="2.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.045" iyz="0" izz="0.045"/>
    </inertial>
  </link>
  <link name="link2">
    <inertial>
      <origin xyz="0.15 0 0"/>
      <mass value="0.85"/>
      <inertia ixx="0.001" iyy="0.019" izz="0.019"/>
    </inertial>
  </link>
  <link name="tool0"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="link1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="link1"/>
    <child link="link2"/>
    <origin xyz="0.3 0 0"/>
    <axis xyz="0 0 2"/>
    <dynamics damping="0.5" friction="0.1"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="link2"/>
    <child link="tool0"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/>
  </joint>
{extra}
</robot>
"#
    )
}

fn rel_close(a: &Matrix3<f64>, b: &Matrix3<f64>, tol: f64) -> bool {
    (a - b).abs().max() <= tol * b.abs().max().max(1e-300)
}

#[test]
fn two_link_loads_with_expected_fields() {
    let text = two_link("");
    let (c, w) = load_chain(&text, "base", "tool0").unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(c.name, "two");
    assert_eq!(c.dof(), 2);
    assert_eq!(c.joints[0].name, "j1");
    assert_eq!(c.joints[0].kind, JointKind::Revolute);
    assert_eq!(c.joints[0].limits.lower, -3.0);
    assert_eq!(c.joints[0].limits.effort, 10.0);
    assert_eq!(c.joints[1].limits.lower, f64::NEG_INFINITY);
    assert_eq!(c.joints[1].limits.upper, f64::INFINITY);
    assert_eq!(c.joints[1].limits.effort, f64::INFINITY);
    assert_eq!(c.joints[1].damping, 0.5);
    // Axis normalised.
    assert_eq!(c.joints[1].axis.into_inner(), Vector3::z());
    assert_eq!(
        c.joints[1].placement.translation.vector,
        Vector3::new(0.3, 0.0, 0.0)
    );
    assert_eq!(c.tool.translation.vector, Vector3::new(0.3, 0.0, 0.0));
    assert_eq!(c.bodies[0].name, "link1");
    assert_eq!(c.bodies[1].mass, 0.85);
    let u = Urdf::parse(&text).unwrap();
    assert_eq!(u.name(), "two");
    assert_eq!(
        u.links().collect::<Vec<_>>(),
        ["base", "link1", "link2", "tool0"]
    );
    assert_eq!(u.joints().collect::<Vec<_>>(), ["j1", "j2", "tool_joint"]);
    // A sub-chain ending at a moving link.
    let (c1, _) = u.chain("base", "link1").unwrap();
    assert_eq!(c1.dof(), 1);
    assert_eq!(c1.tool, Isometry3::identity());
    // The massless tool0 hanging off link2 when the tool is link2 is merged harmlessly.
    let (c2, _) = u.chain("base", "link2").unwrap();
    assert_eq!(c2.bodies[1], c.bodies[1]);
}

#[test]
fn mimic_joint_on_the_chain_is_an_error_naming_it() {
    let text = two_link("").replace(
        r#"<dynamics damping="0.5" friction="0.1"/>"#,
        r#"<dynamics damping="0.5"/>
    <mimic joint="j1" multiplier="1"/>"#,
    );
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    assert_eq!(
        e,
        UrdfError::Mimic {
            joint: "j2".into(),
            line: line_of(&text, "<mimic")
        }
    );
    assert!(e.to_string().contains("j2"), "{e}");
    // Off the chain it does not matter.
    assert!(load_chain(&text, "base", "link1").is_ok());
}

#[test]
fn missing_link_suggests_the_nearest_name() {
    let text = two_link("");
    let e = load_chain(&text, "base", "tool").unwrap_err();
    assert_eq!(
        e,
        UrdfError::MissingLink {
            name: "tool".into(),
            suggestion: Some("tool0".into())
        }
    );
    assert!(e.to_string().contains("did you mean `tool0`"), "{e}");
    let e = load_chain(&text, "Base_link", "tool0").unwrap_err();
    assert!(
        matches!(&e, UrdfError::MissingLink { suggestion: Some(s), .. } if s == "base"),
        "{e:?}"
    );
}

#[test]
fn a_joint_naming_an_unknown_link_is_an_error_with_its_line() {
    let text = two_link("").replace(r#"<child link="tool0"/>"#, r#"<child link="tool_0"/>"#);
    let e = Urdf::parse(&text).unwrap_err();
    assert_eq!(
        e,
        UrdfError::UnknownLink {
            joint: "tool_joint".into(),
            role: "child".into(),
            link: "tool_0".into(),
            line: line_of(&text, r#"<child link="tool_0"/>"#),
            suggestion: Some("tool0".into()),
        }
    );
}

#[test]
fn base_not_an_ancestor_of_tool_names_both() {
    let text = two_link(
        r#"  <link name="camera"/>
  <joint name="cam_joint" type="fixed">
    <parent link="base"/>
    <child link="camera"/>
  </joint>"#,
    );
    for (base, tool) in [("link2", "link1"), ("camera", "tool0"), ("tool0", "base")] {
        match load_chain(&text, base, tool).unwrap_err() {
            UrdfError::NotAChain {
                base: b,
                tool: t,
                reason,
            } => {
                assert_eq!((b.as_str(), t.as_str()), (base, tool));
                assert!(reason.contains("not an ancestor"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }
    let e = load_chain(&text, "base", "camera").unwrap_err();
    assert!(
        matches!(&e, UrdfError::NotAChain { reason, .. } if reason.contains("no movable joint")),
        "{e:?}"
    );
    let e = load_chain(&text, "link1", "link1").unwrap_err();
    assert!(matches!(e, UrdfError::NotAChain { .. }), "{e:?}");
}

#[test]
fn two_parents_is_a_closed_loop_error() {
    let text = two_link(
        r#"  <joint name="loop_joint" type="fixed">
    <parent link="base"/>
    <child link="link2"/>
  </joint>"#,
    );
    let e = Urdf::parse(&text).unwrap_err();
    assert_eq!(
        e,
        UrdfError::TwoParents {
            link: "link2".into(),
            first: "j2".into(),
            first_line: line_of(&text, r#"<joint name="j2""#),
            second: "loop_joint".into(),
            line: line_of(&text, r#"<joint name="loop_joint""#),
        }
    );
}

#[test]
fn a_cycle_of_joints_is_an_error() {
    let text = r#"<robot name="c">
  <link name="a"/>
  <link name="b"/>
  <joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>
  <joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>
</robot>"#;
    let e = Urdf::parse(text).unwrap_err();
    assert!(matches!(e, UrdfError::Cycle { .. }), "{e:?}");
}

#[test]
fn moving_link_with_mass_le_zero_is_an_error_naming_it() {
    // Zero mass on a moving link.
    let text = two_link("").replace(r#"<mass value="0.85"/>"#, r#"<mass value="0"/>"#);
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    match &e {
        UrdfError::BadMass {
            link, value, line, ..
        } => {
            assert_eq!(link, "link2");
            assert_eq!(*value, 0.0);
            assert_eq!(*line, line_of(&text, r#"<mass value="0"/>"#));
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("link2"));
    // A moving link with no <inertial> at all: the <link> line.
    let text = two_link("").replace(
        r#"<link name="link2">
    <inertial>
      <origin xyz="0.15 0 0"/>
      <mass value="0.85"/>
      <inertia ixx="0.001" iyy="0.019" izz="0.019"/>
    </inertial>
  </link>"#,
        r#"<link name="link2"/>"#,
    );
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    assert!(
        matches!(&e, UrdfError::BadMass { link, line, .. }
            if link == "link2" && *line == line_of(&text, r#"<link name="link2"/>"#)),
        "{e:?}"
    );
    // A negative mass anywhere is an error at parse time.
    let text = two_link(r#"  <link name="junk"><inertial><mass value="-1"/></inertial></link>"#);
    let e = Urdf::parse(&text).unwrap_err();
    assert!(
        matches!(&e, UrdfError::BadMass { link, value, line, .. }
            if link == "junk" && *value == -1.0 && *line == line_of(&text, "junk")),
        "{e:?}"
    );
}

#[test]
fn non_positive_definite_inertia_is_an_error_naming_the_link() {
    let text = two_link("").replace(
        r#"<inertia ixx="0.001" iyy="0.019" izz="0.019"/>"#,
        r#"<inertia ixx="0.001" ixy="0.01" iyy="0.019" izz="0.019"/>"#,
    );
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    match &e {
        UrdfError::BadInertia { link, line, reason } => {
            assert_eq!(link, "link2");
            assert_eq!(*line, line_of(&text, r#"ixy="0.01""#));
            assert!(reason.contains("positive definite"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    // A zero inertia on a moving link with mass (a point mass) is not PD either.
    let text = two_link("").replace(
        r#"<inertia ixx="0.001" iyy="0.019" izz="0.019"/>"#,
        r#"<inertia ixx="0" iyy="0" izz="0"/>"#,
    );
    assert!(matches!(
        load_chain(&text, "base", "tool0").unwrap_err(),
        UrdfError::BadInertia { .. }
    ));
}

#[test]
fn bad_numbers_name_element_attribute_and_line() {
    let cases = [
        (
            r#"<origin xyz="0.3 0 0"/>"#,
            r#"<origin xyz="0.3 zero 0"/>"#,
            "origin",
            "xyz",
        ),
        (
            r#"<origin xyz="0.3 0 0"/>"#,
            r#"<origin xyz="0.3 0"/>"#,
            "origin",
            "xyz",
        ),
        (
            r#"<origin xyz="0.3 0 0"/>"#,
            r#"<origin rpy="0 NaN 0"/>"#,
            "origin",
            "rpy",
        ),
        (
            r#"<mass value="0.85"/>"#,
            r#"<mass value="0.85kg"/>"#,
            "mass",
            "value",
        ),
        (
            r#"<mass value="0.85"/>"#,
            r#"<mass value="inf"/>"#,
            "mass",
            "value",
        ),
        (r#"iyy="0.019" izz"#, r#"iyy="1e400" izz"#, "inertia", "iyy"),
        (r#"effort="10""#, r#"effort="ten""#, "limit", "effort"),
        (r#"damping="0.5""#, r#"damping="""#, "dynamics", "damping"),
        (
            r#"<axis xyz="0 0 2"/>"#,
            r#"<axis xyz="0 0 1 0"/>"#,
            "axis",
            "xyz",
        ),
    ];
    for (from, to, element, attr) in cases {
        let text = two_link("").replacen(from, to, 1);
        assert_ne!(text, two_link(""), "{from}");
        match Urdf::parse(&text).unwrap_err() {
            UrdfError::BadAttribute {
                element: e,
                attr: a,
                line,
                owner,
                ..
            } => {
                assert_eq!((e.as_str(), a.as_str()), (element, attr), "{to}");
                assert_eq!(line, line_of(&text, to), "{to}");
                assert!(
                    owner.starts_with("joint ") || owner.starts_with("link "),
                    "{owner}"
                );
            }
            other => panic!("{to}: {other:?}"),
        }
    }
    // Unknown joint type.
    let text = two_link("").replace(r#"type="continuous""#, r#"type="spherical""#);
    assert!(matches!(
        Urdf::parse(&text).unwrap_err(),
        UrdfError::BadAttribute { attr, .. } if attr == "type"
    ));
}

#[test]
fn limits_axis_and_required_elements() {
    // A zero axis on a movable joint.
    let text = two_link("").replace(r#"<axis xyz="0 0 2"/>"#, r#"<axis xyz="0 0 0"/>"#);
    assert_eq!(
        Urdf::parse(&text).unwrap_err(),
        UrdfError::ZeroAxis {
            joint: "j2".into(),
            line: line_of(&text, r#"<axis xyz="0 0 0"/>"#)
        }
    );
    // A revolute joint needs <limit> (URDF spec).
    let text = two_link("").replace(
        r#"<limit lower="-3" upper="3" effort="10" velocity="2"/>"#,
        "",
    );
    assert!(matches!(
        Urdf::parse(&text).unwrap_err(),
        UrdfError::MissingElement { owner, element, .. } if owner == "joint j1" && element == "limit"
    ));
    // lower > upper on the chain.
    let text = two_link("").replace(r#"lower="-3" upper="3""#, r#"lower="3" upper="-3""#);
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    assert!(
        matches!(&e, UrdfError::BadAttribute { owner, element, line, .. }
            if owner == "joint j1" && element == "limit" && *line == line_of(&text, "<limit")),
        "{e:?}"
    );
    // A joint without <parent>.
    let text = two_link("").replace(r#"<parent link="link1"/>"#, "");
    assert!(matches!(
        Urdf::parse(&text).unwrap_err(),
        UrdfError::MissingElement { owner, element, .. } if owner == "joint j2" && element == "parent"
    ));
    // Duplicate names.
    let text = two_link(r#"  <link name="link1"/>"#);
    assert!(matches!(
        Urdf::parse(&text).unwrap_err(),
        UrdfError::Duplicate { kind, name, first_line, .. } if kind == "link" && name == "link1" && first_line == 4
    ));
    // A floating joint on the chain.
    let text = two_link("").replace(r#"type="continuous""#, r#"type="floating""#);
    assert!(matches!(
        load_chain(&text, "base", "tool0").unwrap_err(),
        UrdfError::UnsupportedJoint { joint, kind, .. } if joint == "j2" && kind == "floating"
    ));
}

#[test]
fn malformed_xml_gives_line_and_column() {
    let text = "<robot name=\"x\">\n  <link name=\"a\">\n  </lnk>\n</robot>\n";
    match Urdf::parse(text).unwrap_err() {
        UrdfError::Xml { line, col, msg } => {
            assert_eq!(line, 3, "{msg}");
            assert!(col >= 3, "{col}");
        }
        other => panic!("{other:?}"),
    }
    let e = Urdf::parse("").unwrap_err();
    assert!(matches!(e, UrdfError::Xml { .. }), "{e:?}");
    let e = Urdf::parse("<sdf version=\"1.6\"/>").unwrap_err();
    assert!(
        matches!(&e, UrdfError::NotARobot { found, line: 1 } if found == "sdf"),
        "{e:?}"
    );
    assert_eq!(e.line(), Some(1));
}

#[test]
fn triangle_inequality_break_is_a_warning_naming_the_link() {
    // izz > ixx + iyy: no rigid body has it.
    let text = two_link("").replace(
        r#"<inertia ixx="0.001" iyy="0.019" izz="0.019"/>"#,
        r#"<inertia ixx="0.001" iyy="0.002" izz="0.019"/>"#,
    );
    let (_, w) = load_chain(&text, "base", "tool0").unwrap();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("link2") && w[0].contains("triangle"),
        "{}",
        w[0]
    );
}

#[test]
fn urdf_rpy_is_rz_ry_rx() {
    let (r, p, y) = (0.4_f64, -1.2_f64, 2.5_f64);
    let text = two_link("").replace(
        r#"<origin xyz="0.3 0 0"/>"#,
        &format!(r#"<origin xyz="0.3 0 0" rpy="{r} {p} {y}"/>"#),
    );
    let (c, _) = load_chain(&text, "base", "tool0").unwrap();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, r.cos(), -r.sin(), 0.0, r.sin(), r.cos());
    let ry = Matrix3::new(p.cos(), 0.0, p.sin(), 0.0, 1.0, 0.0, -p.sin(), 0.0, p.cos());
    let rz = Matrix3::new(y.cos(), -y.sin(), 0.0, y.sin(), y.cos(), 0.0, 0.0, 0.0, 1.0);
    let got = c.joints[1]
        .placement
        .rotation
        .to_rotation_matrix()
        .into_inner();
    assert!((got - rz * ry * rx).abs().max() < 1e-15);
}

#[test]
fn inertial_origin_rotation_rotates_the_inertia_into_the_link_frame() {
    // A diagonal inertia given in a frame yawed by 90°: x and y moments swap in the link frame.
    let text = two_link("").replace(
        r#"<origin xyz="0.15 0 0"/>
      <mass value="0.85"/>
      <inertia ixx="0.001" iyy="0.019" izz="0.019"/>"#,
        r#"<origin xyz="0.15 0 0" rpy="0 0 1.5707963267948966"/>
      <mass value="0.85"/>
      <inertia ixx="0.019" iyy="0.001" izz="0.019"/>"#,
    );
    let (c, _) = load_chain(&text, "base", "tool0").unwrap();
    let want = Matrix3::from_diagonal(&Vector3::new(0.001, 0.019, 0.019));
    assert!((c.bodies[1].inertia - want).abs().max() < 1e-17);
}

/// Format a float so that it parses back to the same bits.
fn f(x: f64) -> String {
    format!("{x:e}")
}

fn inertia_attrs(i: &Matrix3<f64>) -> String {
    format!(
        r#"ixx="{}" ixy="{}" ixz="{}" iyy="{}" iyz="{}" izz="{}""#,
        f(i[(0, 0)]),
        f(i[(0, 1)]),
        f(i[(0, 2)]),
        f(i[(1, 1)]),
        f(i[(1, 2)]),
        f(i[(2, 2)])
    )
}

fn rpy_of(r: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    r.euler_angles()
}

/// A one-joint arm whose moving link is described by `links` (link elements for `link1` and any
/// welded links) and `welds` (fixed joints).
fn one_joint(links: &str, welds: &str) -> String {
    format!(
        r#"<robot name="split">
  <link name="base"/>
{links}
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="link1"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/>
  </joint>
{welds}
</robot>"#
    )
}

#[test]
fn fixed_joint_merging_is_exact() {
    // One rigid body: mass m, COM c and inertia I (about c) in the link1 frame.
    let m = 3.25;
    let c = Vector3::new(0.12, -0.034, 0.27);
    let i_c = Matrix3::new(
        0.031, 0.0021, -0.0013, 0.0021, 0.027, 0.0017, -0.0013, 0.0017, 0.019,
    );
    let single = one_joint(
        &format!(
            r#"  <link name="link1"><inertial><origin xyz="{} {} {}"/><mass value="{}"/><inertia {}/></inertial></link>"#,
            f(c.x),
            f(c.y),
            f(c.z),
            f(m),
            inertia_attrs(&i_c)
        ),
        "",
    );
    let (one, w) = load_chain(&single, "base", "link1").unwrap();
    assert!(w.is_empty());
    assert_eq!(one.bodies[0].mass, m);
    assert_eq!(one.bodies[0].com, c);
    assert_eq!(one.bodies[0].inertia, i_c);

    // Split: link1 keeps part A (m_a at c_a, I_a); part B (m_b at c_b, I_b, in link1 axes) moves
    // to link1b welded to link1 by a fixed joint X_1b (offset and rotation), written in link1b's
    // frame with its own inertial rotation. Parts chosen so that A + B is the body above.
    let (m_a, m_b) = (1.25, 2.0);
    let d = Vector3::new(0.05, -0.02, 0.04); // c_a = c + d·m_b/m, c_b = c − d·m_a/m
    let c_a = c + d * (m_b / m);
    let c_b = c - d * (m_a / m);
    let pa = |p: &Vector3<f64>, mm: f64| {
        (Matrix3::identity() * p.norm_squared() - p * p.transpose()) * mm
    };
    let i_b = Matrix3::new(
        0.011, 0.001, 0.0005, 0.001, 0.009, -0.0007, 0.0005, -0.0007, 0.008,
    );
    // I_c = I_a + I_b + m_a |c_a − c|²… + m_b …  ⇒  I_a = I_c − I_b − pa(c_a − c) − pa(c_b − c).
    let i_a = i_c - i_b - pa(&(c_a - c), m_a) - pa(&(c_b - c), m_b);
    assert!(i_a.symmetric_eigenvalues().min() > 0.0);
    let x_1b = Isometry3::from_parts(
        Translation3::new(0.2, -0.1, 0.05),
        UnitQuaternion::from_euler_angles(0.3, -0.5, 0.9),
    );
    // Part B in link1b's frame: COM x_1b⁻¹ c_b, inertia frame rotated by R_b1 · R_inertial where
    // the inertial frame is chosen with its own rotation R_c.
    let r_c = UnitQuaternion::from_euler_angles(-0.2, 0.4, 0.7);
    let c_b_in_b = x_1b.inverse_transform_point(&c_b.into()).coords;
    // Inertial frame orientation in link1b: R_bC = R_1b⁻¹ · R_c; tensor in C axes: R_cᵀ I_b R_c.
    let r_bc = x_1b.rotation.inverse() * r_c;
    let i_b_in_c =
        r_c.to_rotation_matrix().matrix().transpose() * i_b * r_c.to_rotation_matrix().matrix();
    let (rr, pp, yy) = rpy_of(&r_bc);
    let (xr, xp, xy) = rpy_of(&x_1b.rotation);
    let split = one_joint(
        &format!(
            r#"  <link name="link1"><inertial><origin xyz="{} {} {}"/><mass value="{}"/><inertia {}/></inertial></link>
  <link name="link1b"><inertial><origin xyz="{} {} {}" rpy="{} {} {}"/><mass value="{}"/><inertia {}/></inertial></link>"#,
            f(c_a.x),
            f(c_a.y),
            f(c_a.z),
            f(m_a),
            inertia_attrs(&i_a),
            f(c_b_in_b.x),
            f(c_b_in_b.y),
            f(c_b_in_b.z),
            f(rr),
            f(pp),
            f(yy),
            f(m_b),
            inertia_attrs(&((i_b_in_c + i_b_in_c.transpose()) * 0.5)),
        ),
        &format!(
            r#"  <joint name="weld" type="fixed"><parent link="link1"/><child link="link1b"/><origin xyz="{} {} {}" rpy="{} {} {}"/></joint>"#,
            f(x_1b.translation.x),
            f(x_1b.translation.y),
            f(x_1b.translation.z),
            f(xr),
            f(xp),
            f(xy)
        ),
    );
    for tool in ["link1", "link1b"] {
        let (two, _) = load_chain(&split, "base", tool).unwrap();
        let (a, b) = (&two.bodies[0], &one.bodies[0]);
        assert!((a.mass - b.mass).abs() <= 1e-14 * b.mass);
        assert!(
            (a.com - b.com).abs().max() <= 1e-14 * b.com.abs().max(),
            "{} vs {}",
            a.com,
            b.com
        );
        assert!(
            rel_close(&a.inertia, &b.inertia, 1e-14),
            "{} vs {}",
            a.inertia,
            b.inertia
        );
        assert_eq!(two.joints, one.joints);
    }
    let (two, _) = load_chain(&split, "base", "link1b").unwrap();
    let t = two.tool;
    assert!((t.translation.vector - x_1b.translation.vector).abs().max() < 1e-15);
    assert!(t.rotation.angle_to(&x_1b.rotation) < 1e-15);
}

#[test]
fn fixed_links_before_and_after_compose_into_placement_and_tool() {
    // base ─fixed A─ mount ─j1─ link1 ─fixed B─ (mass) ─j2─ link2 ─fixed C─ flange ─fixed D─ tool.
    let xa = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 0.5),
        UnitQuaternion::from_euler_angles(0.0, 0.0, 1.0),
    );
    let xj1 = Isometry3::from_parts(
        Translation3::new(0.1, 0.0, 0.0),
        UnitQuaternion::from_euler_angles(0.5, 0.0, 0.0),
    );
    let xb = Isometry3::from_parts(
        Translation3::new(0.0, 0.3, 0.0),
        UnitQuaternion::from_euler_angles(0.0, 0.7, 0.0),
    );
    let xj2 = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 0.2),
        UnitQuaternion::from_euler_angles(0.0, 0.0, -0.4),
    );
    let xc = Isometry3::from_parts(
        Translation3::new(0.05, 0.0, 0.0),
        UnitQuaternion::from_euler_angles(0.2, 0.3, 0.4),
    );
    let xd = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 0.1),
        UnitQuaternion::from_euler_angles(-1.0, 0.0, 0.5),
    );
    let o = |x: &Isometry3<f64>| {
        let (r, p, y) = x.rotation.euler_angles();
        let t = x.translation.vector;
        format!(
            r#"<origin xyz="{} {} {}" rpy="{} {} {}"/>"#,
            f(t.x),
            f(t.y),
            f(t.z),
            f(r),
            f(p),
            f(y)
        )
    };
    let inert =
        r#"<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>"#;
    let text = format!(
        r#"<robot name="c">
  <link name="world"/><link name="base"/><link name="mount">{inert}</link>
  <link name="link1">{inert}</link><link name="mid">{inert}</link><link name="link2">{inert}</link>
  <link name="flange"/><link name="tool"/>
  <joint name="w" type="fixed"><parent link="world"/><child link="base"/></joint>
  <joint name="A" type="fixed"><parent link="base"/><child link="mount"/>{}</joint>
  <joint name="j1" type="continuous"><parent link="mount"/><child link="link1"/>{}<axis xyz="0 0 1"/></joint>
  <joint name="B" type="fixed"><parent link="link1"/><child link="mid"/>{}</joint>
  <joint name="j2" type="prismatic"><parent link="mid"/><child link="link2"/>{}<axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="100" velocity="0.5"/></joint>
  <joint name="C" type="fixed"><parent link="link2"/><child link="flange"/>{}</joint>
  <joint name="D" type="fixed"><parent link="flange"/><child link="tool"/>{}</joint>
</robot>"#,
        o(&xa),
        o(&xj1),
        o(&xb),
        o(&xj2),
        o(&xc),
        o(&xd)
    );
    let (c, w) = load_chain(&text, "base", "tool").unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(c.dof(), 2);
    assert_eq!(c.joints[1].kind, JointKind::Prismatic);
    let close = |a: &Isometry3<f64>, b: &Isometry3<f64>| {
        (a.translation.vector - b.translation.vector).abs().max() < 1e-15
            && a.rotation.angle_to(&b.rotation) < 1e-14
    };
    assert!(close(&c.joints[0].placement, &(xa * xj1)));
    assert!(close(&c.joints[1].placement, &(xb * xj2)));
    assert!(close(&c.tool, &(xc * xd)));
    // Body 0 = link1 + mid (two unit masses): mass 2, COM halfway to mid's origin.
    assert_eq!(c.bodies[0].mass, 2.0);
    assert!((c.bodies[0].com - xb.translation.vector * 0.5).abs().max() < 1e-16);
    // Body 1 = link2 alone; mount's mass stays with the base.
    assert_eq!(c.bodies[1].mass, 1.0);
    // From the world link the chain is the same.
    let (cw, _) = load_chain(&text, "world", "tool").unwrap();
    assert_eq!(cw.joints, c.joints);
}

#[test]
fn branches_fixed_merge_and_movable_weld_with_warning() {
    let text = two_link(
        r#"  <link name="camera"><inertial><origin xyz="0 0 0.05"/><mass value="0.2"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
  <joint name="camera_joint" type="fixed"><parent link="link2"/><child link="camera"/><origin xyz="0.1 0 0"/></joint>
  <link name="finger"><inertial><mass value="0.05"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5"/></inertial></link>
  <joint name="finger_joint" type="prismatic"><parent link="tool0"/><child link="finger"/><limit lower="0" upper="0.04" effort="20" velocity="0.2"/></joint>
  <link name="side"/>
  <joint name="side_joint" type="revolute"><parent link="base"/><child link="side"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>"#,
    );
    let (c, w) = load_chain(&text, "base", "tool0").unwrap();
    // The finger (off the chain, beyond the tool) is welded, with a warning; the base-side
    // branch is ignored silently.
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("finger_joint") && w[0].contains("welded"),
        "{}",
        w[0]
    );
    assert!((c.bodies[1].mass - (0.85 + 0.2 + 0.05)).abs() < 1e-15);
    let want_com = (Vector3::new(0.15, 0.0, 0.0) * 0.85
        + Vector3::new(0.1, 0.0, 0.05) * 0.2
        + Vector3::new(0.3, 0.0, 0.0) * 0.05)
        / 1.1;
    assert!((c.bodies[1].com - want_com).abs().max() < 1e-15);
}

#[test]
fn urdf_errors_map_to_model_errors() {
    let e: tandem::ModelError = UrdfError::MissingLink {
        name: "x".into(),
        suggestion: None,
    }
    .into();
    assert!(e.to_string().contains("no link named `x`"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Embedded models: pure kinematics composed by hand (the dynamics module is not used here).

/// `X_BT(q)` and every `X_BLk(q)` from the chain's placements and joint motions (chain.rs doc).
fn fk(c: &Chain, q: &[f64]) -> (Vec<Isometry3<f64>>, Isometry3<f64>) {
    let mut x = Isometry3::identity();
    let mut links = Vec::new();
    for (j, &qj) in c.joints.iter().zip(q) {
        let motion = match j.kind {
            JointKind::Revolute => Isometry3::from_parts(
                Translation3::identity(),
                UnitQuaternion::from_axis_angle(&j.axis, qj),
            ),
            JointKind::Prismatic => Isometry3::from_parts(
                Translation3::from(j.axis.into_inner() * qj),
                UnitQuaternion::identity(),
            ),
        };
        x = x * j.placement * motion;
        links.push(x);
    }
    (links, x * c.tool)
}

fn rot_x(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a),
    )
}
fn rot_z(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a),
    )
}
fn trans(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::identity())
}

fn assert_pose_close(a: &Isometry3<f64>, b: &Isometry3<f64>, tol: f64, what: &str) {
    let dp = (a.translation.vector - b.translation.vector).abs().max();
    let dr = (a.rotation.to_rotation_matrix().into_inner()
        - b.rotation.to_rotation_matrix().into_inner())
    .abs()
    .max();
    assert!(
        dp < tol && dr < tol,
        "{what}: Δp = {dp:e}, ΔR = {dr:e}\n{a}\n{b}"
    );
}

use std::f64::consts::{FRAC_PI_2, PI};

/// UR5 standard DH (Universal Robots): d, a, α.
const UR5_D: [f64; 6] = [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823];
const UR5_A: [f64; 6] = [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0];
const UR5_ALPHA: [f64; 6] = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];

/// Standard DH forward kinematics of the UR5 in `base_link` (= the DH base turned by π about z,
/// ur_description's convention): returns DH frames 1..6.
fn ur5_dh(q: &[f64]) -> Vec<Isometry3<f64>> {
    let mut x = rot_z(PI);
    let mut out = Vec::new();
    for k in 0..6 {
        x = x
            * rot_z(q[k])
            * trans(0.0, 0.0, UR5_D[k])
            * trans(UR5_A[k], 0.0, 0.0)
            * rot_x(UR5_ALPHA[k]);
        out.push(x);
    }
    out
}

#[test]
fn ur5_loads_with_expected_joints_limits_and_masses() {
    use tandem::model::spatial::urdf::{UR5_BASE, UR5_TOOL, UR5_URDF, ur5};
    let (c, w) = load_chain(UR5_URDF, UR5_BASE, UR5_TOOL).unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(c, ur5());
    let names: Vec<_> = c.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "shoulder_pan_joint",
            "shoulder_lift_joint",
            "elbow_joint",
            "wrist_1_joint",
            "wrist_2_joint",
            "wrist_3_joint"
        ]
    );
    let bodies: Vec<_> = c.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(
        bodies,
        [
            "shoulder_link",
            "upper_arm_link",
            "forearm_link",
            "wrist_1_link",
            "wrist_2_link",
            "wrist_3_link"
        ]
    );
    let effort = [150.0, 150.0, 150.0, 28.0, 28.0, 28.0];
    for (j, e) in c.joints.iter().zip(effort) {
        assert_eq!(j.kind, JointKind::Revolute);
        assert_eq!(j.limits.effort, e, "{}", j.name);
        assert_eq!(j.limits.velocity, PI);
        assert_eq!((j.limits.lower, j.limits.upper), (-2.0 * PI, 2.0 * PI));
    }
    // Published masses; their sum is the moving mass (the 4 kg base is not part of the chain).
    let masses = [3.7, 8.393, 2.275, 1.219, 1.219, 0.1879];
    for (b, m) in c.bodies.iter().zip(masses) {
        assert_eq!(b.mass, m, "{}", b.name);
    }
    let total: f64 = c.bodies.iter().map(|b| b.mass).sum();
    assert!((total - 16.9939).abs() < 1e-12, "{total}");
    // Centres of mass back in DH frame k equal UR's table.
    let com_dh = [
        [0.0, -0.02561, 0.00193],
        [0.2125, 0.0, 0.11336],
        [0.15, 0.0, 0.0265],
        [0.0, -0.0018, 0.01634],
        [0.0, 0.0018, 0.01634],
        [0.0, 0.0, -0.001159],
    ];
    for k in 0..6 {
        let x_l_dh = trans(UR5_A[k], 0.0, 0.0) * rot_x(UR5_ALPHA[k]);
        let c_dh = x_l_dh
            .inverse_transform_point(&c.bodies[k].com.into())
            .coords;
        assert!(
            (c_dh - Vector3::from(com_dh[k])).abs().max() < 1e-15,
            "link {k}: {c_dh}"
        );
        // Cylinder inertias: diagonal in DH axes.
        let r = x_l_dh.rotation.to_rotation_matrix().into_inner();
        let i_dh = r.transpose() * c.bodies[k].inertia * r;
        assert!(
            (i_dh - Matrix3::from_diagonal(&i_dh.diagonal()))
                .abs()
                .max()
                < 1e-16
        );
    }
}

#[test]
fn ur5_tool0_pose_equals_dh_forward_kinematics() {
    let c = tandem::model::spatial::urdf::ur5();
    // q = 0, then a few fixed configurations.
    let qs: [[f64; 6]; 4] = [
        [0.0; 6],
        [0.3, -1.1, 1.4, -0.5, 1.2, 0.7],
        [-2.0, 0.4, -2.2, 2.9, -0.8, -3.0],
        [1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
    ];
    for q in qs {
        let (links, tool) = fk(&c, &q);
        let dh = ur5_dh(&q);
        assert_pose_close(&tool, &dh[5], 1e-14, "tool0");
        // Link frame k = DH frame k-1 turned by q_k and shifted by d_k.
        for k in 0..6 {
            let prev = if k == 0 { rot_z(PI) } else { dh[k - 1] };
            assert_pose_close(
                &links[k],
                &(prev * rot_z(q[k]) * trans(0.0, 0.0, UR5_D[k])),
                1e-14,
                "link",
            );
        }
    }
    // q = 0 by hand: the arm stretched along +x of base_link (a2 + a3), offset by d4 + d6 in y.
    let (_, tool) = fk(&c, &[0.0; 6]);
    let p = tool.translation.vector;
    let want = Vector3::new(0.425 + 0.39225, 0.10915 + 0.0823, 0.089159 - 0.09465);
    assert!((p - want).abs().max() < 1e-15, "{p}");
}

#[test]
#[allow(clippy::approx_constant)] // the SPEC prints the start angles to 1e-6 rad
fn ur5_spec_s6_start_puts_the_tools_on_the_grasps() {
    // SPEC-spatial S6: bases (∓0.70, 0, 0) with yaw 0 and π, box at (0.1, 0, 0.3), R_WO = I,
    // grasps r = (∓0.2, 0, 0) with R_OG1 = [(0,0,−1) (0,1,0) (1,0,0)], R_OG2 = [(0,0,−1) (0,−1,0) (−1,0,0)].
    let c = tandem::model::spatial::urdf::ur5();
    let q1 = [
        -0.212431, -1.267797, 1.525974, -0.258177, 1.358366, -1.570796,
    ];
    let q2 = [
        -0.350708, -1.754035, 2.044645, -0.290610, 1.220088, -1.570796,
    ];
    let x_wb1 = trans(-0.7, 0.0, 0.0);
    let x_wb2 = trans(0.7, 0.0, 0.0) * rot_z(PI);
    let r1 = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
    let r2 = Matrix3::new(0.0, 0.0, -1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 0.0);
    for (x_wb, q, p, r) in [
        (x_wb1, q1, Vector3::new(-0.1, 0.0, 0.3), r1),
        (x_wb2, q2, Vector3::new(0.3, 0.0, 0.3), r2),
    ] {
        let x_wt = x_wb * fk(&c, &q).1;
        let dp = (x_wt.translation.vector - p).abs().max();
        let dr = (x_wt.rotation.to_rotation_matrix().into_inner() - r)
            .abs()
            .max();
        // The start angles are printed to 1e-6 rad.
        assert!(dp < 5e-6 && dr < 5e-6, "Δp = {dp:e}, ΔR = {dr:e}");
    }
}

/// Franka modified DH (Craig): a_{i−1}, d_i, α_{i−1} for joints 1..7 and the flange.
const PANDA_MDH: [(f64, f64, f64); 8] = [
    (0.0, 0.333, 0.0),
    (0.0, 0.0, -FRAC_PI_2),
    (0.0, 0.316, FRAC_PI_2),
    (0.0825, 0.0, FRAC_PI_2),
    (-0.0825, 0.384, -FRAC_PI_2),
    (0.0, 0.0, FRAC_PI_2),
    (0.088, 0.0, FRAC_PI_2),
    (0.0, 0.107, 0.0),
];

#[test]
fn franka_loads_with_expected_joints_limits_masses_and_kinematics() {
    use tandem::model::spatial::urdf::{FRANKA_BASE, FRANKA_TOOL, FRANKA_URDF, franka};
    let (c, w) = load_chain(FRANKA_URDF, FRANKA_BASE, FRANKA_TOOL).unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(c, franka());
    assert_eq!(c.dof(), 7);
    for (k, j) in c.joints.iter().enumerate() {
        assert_eq!(j.name, format!("panda_joint{}", k + 1));
        assert_eq!(c.bodies[k].name, format!("panda_link{}", k + 1));
    }
    let lower = [
        -2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973,
    ];
    let upper = [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973];
    let vel = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61];
    let eff = [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0];
    for k in 0..7 {
        let l = c.joints[k].limits;
        assert_eq!(
            (l.lower, l.upper, l.velocity, l.effort),
            (lower[k], upper[k], vel[k], eff[k])
        );
    }
    // Gaz et al. (2019) masses, link 7 without the hand.
    let masses = [
        4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522,
    ];
    for (b, m) in c.bodies.iter().zip(masses) {
        assert_eq!(b.mass, m);
    }
    let total: f64 = c.bodies.iter().map(|b| b.mass).sum();
    assert!((total - 16.062132).abs() < 1e-12, "{total}");
    // Forward kinematics against the modified-DH product at a few configurations.
    let qs: [[f64; 7]; 3] = [
        [0.0; 7],
        [0.1, -0.785, 0.2, -2.356, 0.3, 1.571, 0.785],
        [1.0, 0.5, -1.5, -1.0, 2.0, 3.0, -2.5],
    ];
    for q in qs {
        let (links, tool) = fk(&c, &q);
        let mut x = Isometry3::identity();
        for k in 0..8 {
            let (a, d, al) = PANDA_MDH[k];
            x = x
                * rot_x(al)
                * trans(a, 0.0, 0.0)
                * rot_z(if k < 7 { q[k] } else { 0.0 })
                * trans(0.0, 0.0, d);
            if k < 7 {
                assert_pose_close(&links[k], &x, 1e-14, "panda link");
            }
        }
        assert_pose_close(&tool, &x, 1e-14, "panda flange");
    }
    // At q = 0 the flange is at (0.088, 0, 0.926) pointing down.
    let (_, tool) = fk(&c, &[0.0; 7]);
    assert!(
        (tool.translation.vector - Vector3::new(0.088, 0.0, 0.926))
            .abs()
            .max()
            < 1e-15
    );
    let r = tool.rotation.to_rotation_matrix().into_inner();
    assert!(
        (r - Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)))
            .abs()
            .max()
            < 1e-15
    );
    // The hand TCP frame, 0.1034 m further, turned by −π/4.
    let (ct, _) = load_chain(FRANKA_URDF, FRANKA_BASE, "panda_hand_tcp").unwrap();
    assert_eq!(ct.bodies, c.bodies);
    assert_pose_close(
        &ct.tool,
        &(c.tool * trans(0.0, 0.0, 0.1034) * rot_z(-PI / 4.0)),
        1e-15,
        "tcp",
    );
}

// ---------------------------------------------------------------------------------------------
// Real-world file, the planar Table I arm, and robustness.

const XACRO_UR5: &str = include_str!("data/ur5_xacro_output.urdf");
const PLANAR2: &str = include_str!("data/planar2.urdf");

#[test]
fn xacro_style_ur5_loads_and_matches_the_embedded_model() {
    let u = Urdf::parse(XACRO_UR5).unwrap();
    assert_eq!(u.name(), "ur5_robot");
    // The <joint> elements nested in <transmission> and <ros2_control> are not joints.
    assert_eq!(u.joints().count(), 13);
    let want = tandem::model::spatial::urdf::ur5();
    for base in ["world", "base_link"] {
        let (c, w) = u.chain(base, "tool0").unwrap();
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(c.dof(), 6);
        for (k, (j, e)) in c.joints.iter().zip(&want.joints).enumerate() {
            assert_eq!(j.name, e.name);
            assert_eq!(j.kind, e.kind);
            assert_eq!(j.axis, e.axis);
            assert_pose_close(&j.placement, &e.placement, 1e-15, &j.name);
            let (lo, hi) = match k {
                2 => (-PI, PI),                              // elbow ±π here
                3..=5 => (f64::NEG_INFINITY, f64::INFINITY), // continuous wrists
                _ => (-2.0 * PI, 2.0 * PI),
            };
            assert_eq!((j.limits.lower, j.limits.upper), (lo, hi), "{}", j.name);
            assert_eq!(j.limits.effort, e.limits.effort);
            assert_eq!(j.limits.velocity, e.limits.velocity);
        }
        // flange ∘ tool0 = identity up to rounding of π/2.
        assert_pose_close(&c.tool, &want.tool, 1e-15, "tool0");
        for k in [0, 1, 3, 4, 5] {
            let (a, b) = (&c.bodies[k], &want.bodies[k]);
            assert_eq!(a.name, b.name);
            assert_eq!(a.mass, b.mass);
            assert!((a.com - b.com).abs().max() < 1e-16, "{}", a.name);
            assert!(
                rel_close(&a.inertia, &b.inertia, 1e-14),
                "{}: {} vs {}",
                a.name,
                a.inertia,
                b.inertia
            );
        }
        // The forearm carries the camera: merge it by hand (parallel-axis theorem).
        let x_fc = Isometry3::from_parts(
            Translation3::new(-0.2, 0.05, 0.06),
            tandem::model::spatial::urdf::rpy_to_rotation([0.2, -0.4, 1.0]),
        );
        let x_ci = Isometry3::from_parts(
            Translation3::new(0.01, 0.0, 0.005),
            tandem::model::spatial::urdf::rpy_to_rotation([0.0, 0.0, 0.3]),
        );
        let x_fi = x_fc * x_ci;
        let (m_c, c_c) = (0.072, x_fi.translation.vector);
        let r = x_fi.rotation.to_rotation_matrix().into_inner();
        let i_c = r * Matrix3::from_diagonal(&Vector3::new(5.3e-5, 1.2e-5, 5.6e-5)) * r.transpose();
        let f = &want.bodies[2];
        let m = f.mass + m_c;
        let com = (f.com * f.mass + c_c * m_c) / m;
        let pa = |d: Vector3<f64>, mm: f64| {
            (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * mm
        };
        let inertia = f.inertia + pa(f.com - com, f.mass) + i_c + pa(c_c - com, m_c);
        let got = &c.bodies[2];
        assert!((got.mass - m).abs() < 1e-15);
        assert!((got.com - com).abs().max() < 1e-15, "{} vs {com}", got.com);
        assert!(
            rel_close(&got.inertia, &inertia, 1e-13),
            "{} vs {inertia}",
            got.inertia
        );
    }
}

#[test]
fn planar2_matches_table_one() {
    use tandem::model::planar::arm::{ArmParams, Elbow};
    let table = ArmParams::paper([0.0, 0.0], Elbow::Positive);
    let (c, w) = load_chain(PLANAR2, "base", "tool").unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(c.dof(), 2);
    let mut x_along = 0.0;
    for (k, lp) in table.links.iter().enumerate() {
        let (j, b) = (&c.joints[k], &c.bodies[k]);
        assert_eq!(j.kind, JointKind::Revolute);
        assert_eq!(j.axis.into_inner(), Vector3::z());
        assert_eq!(j.limits.lower, f64::NEG_INFINITY);
        // Joint k sits at the end of link k−1, along x, unrotated.
        assert_eq!(
            j.placement.translation.vector,
            Vector3::new(x_along, 0.0, 0.0)
        );
        assert_eq!(j.placement.rotation, UnitQuaternion::identity());
        assert_eq!(b.mass, lp.mass);
        assert_eq!(b.com, Vector3::new(lp.com, 0.0, 0.0));
        assert_eq!(lp.com, lp.length / 2.0);
        assert_eq!(b.inertia[(2, 2)], lp.inertia);
        assert_eq!(b.inertia[(1, 1)], lp.inertia);
        assert_eq!(b.inertia[(0, 0)], 1e-4);
        assert_eq!(b.inertia[(0, 1)], 0.0);
        x_along = lp.length;
    }
    assert_eq!(
        c.tool.translation.vector,
        Vector3::new(table.links[1].length, 0.0, 0.0)
    );
    // Tip at q = (q1, q2): the planar forward kinematics.
    let q = [0.7, -1.3];
    let (_, tip) = fk(&c, &q);
    let want = Vector3::new(
        0.3 * q[0].cos() + 0.3 * (q[0] + q[1]).cos(),
        0.3 * q[0].sin() + 0.3 * (q[0] + q[1]).sin(),
        0.0,
    );
    assert!((tip.translation.vector - want).abs().max() < 1e-15);
}

mod robustness {
    use super::*;
    use proptest::prelude::*;

    const TOOLS: [(&str, &str); 5] = [
        ("base_link", "tool0"),
        ("world", "tool0"),
        ("base_link", "forearm_link"),
        ("base", "tool"),
        ("base", "link2"),
    ];

    /// Parse and (when it parses) extract every chain; only `Result`s, never a panic.
    fn exercise(text: &str) {
        if let Ok(u) = Urdf::parse(text) {
            for (b, t) in TOOLS {
                let _ = u.chain(b, t).map(|(c, _)| c.validate());
            }
            let names: Vec<String> = u.links().map(String::from).collect();
            if let (Some(b), Some(t)) = (names.first(), names.last()) {
                let _ = u.chain(b, t);
                let _ = u.chain(t, b);
            }
        }
    }

    const BYTES: &[u8] = b"<>/\"'= -+.e0123456789xyzabc\n&;!?[]";

    fn mutate(base: &str, ops: &[(u8, usize, usize, u8)]) -> String {
        let mut s = base.as_bytes().to_vec();
        for &(op, a, b, c) in ops {
            if s.is_empty() {
                break;
            }
            let i = a % s.len();
            let j = (i + b % 64).min(s.len());
            match op % 5 {
                0 => s.truncate(i),
                1 => s[i] = BYTES[c as usize % BYTES.len()],
                2 => {
                    s.drain(i..j);
                }
                3 => {
                    let piece: Vec<u8> = s[i..j].to_vec();
                    s.splice(i..i, piece);
                }
                _ => s.insert(i, BYTES[c as usize % BYTES.len()]),
            }
        }
        // Byte edits can split a UTF-8 character: keep it valid text, lossily.
        String::from_utf8_lossy(&s).into_owned()
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 512,
            rng_seed: proptest::test_runner::RngSeed::Fixed(2026),
            ..ProptestConfig::default()
        })]

        #[test]
        fn mutated_urdf_never_panics(
            which in 0usize..3,
            ops in proptest::collection::vec((any::<u8>(), any::<usize>(), any::<usize>(), any::<u8>()), 1..6),
        ) {
            let base = [XACRO_UR5, PLANAR2, tandem::model::spatial::urdf::FRANKA_URDF][which];
            exercise(&mutate(base, &ops));
        }

        #[test]
        fn numbers_in_attributes_never_panic(v in "[-+0-9.eEinfaNxX ]{0,24}") {
            let text = PLANAR2.replace(r#"xyz="0.3 0 0""#, &format!(r#"xyz="{v}""#))
                .replace(r#"<mass value="0.85"/>"#, &format!(r#"<mass value="{v}"/>"#));
            exercise(&text);
        }
    }

    #[test]
    fn every_truncation_of_a_small_file_is_handled() {
        for n in 0..=PLANAR2.len() {
            if PLANAR2.is_char_boundary(n) {
                exercise(&PLANAR2[..n]);
            }
        }
    }
}

#[test]
fn long_and_deep_inputs_do_not_overflow() {
    // A 20 000-link fixed branch hanging off a moving link, and deeply nested unknown XML.
    let n = 20_000;
    let mut extra = String::new();
    let mut parent = "link2".to_string();
    for k in 0..n {
        extra.push_str(&format!(
            "  <link name=\"b{k}\"><inertial><mass value=\"1e-3\"/><inertia ixx=\"1e-6\" iyy=\"1e-6\" izz=\"1e-6\"/></inertial></link>\n  <joint name=\"bj{k}\" type=\"fixed\"><parent link=\"{parent}\"/><child link=\"b{k}\"/><origin xyz=\"0 0 0.001\"/></joint>\n"
        ));
        parent = format!("b{k}");
    }
    let (c, _) = load_chain(&two_link(&extra), "base", "tool0").unwrap();
    assert!((c.bodies[1].mass - (0.85 + n as f64 * 1e-3)).abs() < 1e-9);
    let deep = format!("{}{}", "<gazebo>".repeat(5000), "</gazebo>".repeat(5000));
    let _ = Urdf::parse(&two_link(&deep));
}

#[test]
fn lines_are_right_with_crlf_line_ends() {
    let text = two_link("")
        .replace(r#"<mass value="0.85"/>"#, r#"<mass value="-0.85"/>"#)
        .replace('\n', "\r\n");
    let e = Urdf::parse(&text).unwrap_err();
    assert_eq!(
        e.line(),
        Some(line_of(&text, r#"<mass value="-0.85"/>"#)),
        "{e}"
    );
}

/// A mass or inertia no robot link has (a typo in the exponent) is refused on its line when
/// the file is read, printed short, instead of failing later on whatever the arm cannot do; a
/// number that does not parse is echoed as an excerpt, not whole.
#[test]
fn absurd_masses_and_inertias_are_refused_on_their_line() {
    let text = two_link("").replace(r#"<mass value="0.85"/>"#, r#"<mass value="1e308"/>"#);
    let e = Urdf::parse(&text).unwrap_err();
    assert!(
        matches!(&e, UrdfError::BadMass { link, line, .. }
            if link == "link2" && *line == line_of(&text, r#"<mass value="1e308"/>"#)),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("mass 1e308 kg") && msg.contains("1e6 kg"),
        "{msg}"
    );
    // A heavy but real link (a 2 t boom) is taken.
    let text = two_link("").replace(r#"<mass value="0.85"/>"#, r#"<mass value="2000"/>"#);
    assert!(load_chain(&text, "base", "tool0").is_ok());
    let text = two_link("").replace(
        r#"<inertia ixx="0.001" iyy="0.019" izz="0.019"/>"#,
        r#"<inertia ixx="1e300" iyy="1e300" izz="1e300"/>"#,
    );
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    assert!(
        matches!(&e, UrdfError::BadInertia { link, reason, .. }
            if link == "link2" && reason.contains("beyond 1e6 kg m²")),
        "{e:?}"
    );
    let long = "9".repeat(5000);
    let text = two_link("").replace(
        r#"<mass value="0.85"/>"#,
        &format!(r#"<mass value="{long}x"/>"#),
    );
    let msg = Urdf::parse(&text).unwrap_err().to_string();
    assert!(
        msg.len() < 400 && msg.contains("(5001 characters)"),
        "{}",
        msg.len()
    );
}

/// Issue 22: "a DTD at line 37 is reported at line 1". roxmltree stops on a `<!DOCTYPE` without
/// a position; the loader finds it (past the declaration, comments and processing
/// instructions, not a `<!DOCTYPE` inside a comment) and says DTDs are not accepted.
#[test]
fn a_dtd_is_reported_at_its_own_line_and_column() {
    let mut text = String::from("<?xml version=\"1.0\"?>\n");
    for k in 2..=35 {
        text.push_str(&format!("<!-- line {k}: <!DOCTYPE not-this-one> -->\n"));
    }
    text.push_str("<?xml-stylesheet href=\"x\"?>\n");
    text.push_str("  <!DOCTYPE robot [ <!ENTITY a \"aaaaaaaaaa\"> ]>\n");
    text.push_str(&two_link("").replacen("<?xml version=\"1.0\"?>\n", "", 1));
    let e = Urdf::parse(&text).unwrap_err();
    assert_eq!(e, UrdfError::Dtd { line: 37, col: 3 }, "{e}");
    assert_eq!(e.line(), Some(37));
    let msg = e.to_string();
    assert!(
        msg.starts_with("URDF line 37, column 3:")
            && msg.contains("a DTD is not accepted in a URDF file"),
        "{msg}"
    );
    // On the first line, with a byte order mark and CRLF line ends.
    let e = Urdf::parse("\u{feff}<!DOCTYPE robot>\r\n<robot name=\"r\"/>").unwrap_err();
    assert_eq!(e, UrdfError::Dtd { line: 1, col: 1 }, "{e}");
    let e = Urdf::parse("\r\n\r\n<!DOCTYPE robot>\r\n<robot name=\"r\"/>").unwrap_err();
    assert_eq!(e, UrdfError::Dtd { line: 3, col: 1 }, "{e}");
    // Through load_chain too (as a scenario loads a URDF file).
    let e = load_chain(&text, "base", "tool0").unwrap_err();
    assert_eq!(e.line(), Some(37));
}
