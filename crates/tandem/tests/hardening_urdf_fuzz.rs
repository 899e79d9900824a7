//! Issue 22, hardening: a property-based fuzzer of the URDF loader (proptest, stable Rust; the
//! coverage-guided one is `fuzz/`, target `urdf`, see `fuzz/README.md`).
//!
//! Mutated copies of the embedded URDFs (UR5, Franka) and the test files (the xacro output of
//! the UR5, the planar two-link arm): numbers replaced by extremes (NaN, ±1e308, -0, 5e-324,
//! ...), elements deleted or duplicated, attribute values truncated, elements wrapped in deeper
//! nesting, garbage inserted, several edits at once. For every one, `Urdf::parse` and a chain
//! from each root link to each leaf link (as a scenario names `base_link` and `tool_link`):
//!
//! - never panic;
//! - an error names its line (inside the text) when it comes from the text, and the message
//!   says `URDF line N`; a chain error without a line names the base and tool links;
//! - a chain that loads has finite placements, axes, masses, centres of mass, inertias and
//!   tool frame, limits that are not NaN, and finite kinematics and dynamics (`M`, `C q̇ + g`,
//!   `q̈`) at the middle of its limits.
//!
//! 256 cases by default (about a second in release); more with `PROPTEST_CASES=100000`.

use proptest::prelude::*;
use tandem::dynamics::spatial::{ChainData, aba, terms};
use tandem::model::spatial::urdf::{FRANKA_URDF, UR5_URDF, Urdf, UrdfError};
use tandem::model::spatial::{Chain, SpatialArm};
use tandem::nalgebra::{Isometry3, Vector3};

const XACRO_UR5: &str = include_str!("data/ur5_xacro_output.urdf");
const PLANAR2: &str = include_str!("data/planar2.urdf");
const BASES: [&str; 4] = [UR5_URDF, FRANKA_URDF, XACRO_UR5, PLANAR2];

/// Values that break naive code, as they would be written in an attribute.
const NASTY: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "-0",
    "-0.0",
    "0",
    "5e-324",
    "1e-300",
    "-1",
    "1e6",
    "1.000001e6",
    "1e3",
    "1001",
    "-1e3",
    "1e-12",
    "3.4e38",
    "",
    " ",
    "1 2",
    "1 2 3 4",
    "0x10",
    "1e",
    "+",
    "١",
];

const GARBAGE: &[&str] = &[
    "<",
    ">",
    "</robot>",
    "<robot name=\"x\">",
    "<link name=\"base_link\"/>",
    "<joint>",
    "&",
    "&amp;",
    "&#0;",
    "&#x10FFFF;",
    "<!--",
    "-->",
    "<![CDATA[",
    "]]>",
    "<?pi?>",
    "<!DOCTYPE r>",
    "\"",
    "'",
    "=",
    "\u{0}",
    "\u{feff}",
    "\r\n",
    "é",
    "<link name=\"\"/>",
];

const WRAPPERS: &[&str] = &["gazebo", "link", "joint", "robot", "inertial", "origin"];

/// One edit.
#[derive(Clone, Debug)]
enum Edit {
    /// Replace the n-th number inside an attribute value with a nasty value.
    Number(usize, usize),
    /// Replace the n-th number with an arbitrary float.
    Float(usize, f64),
    /// Delete the n-th element (with its content).
    Delete(usize),
    /// Duplicate the n-th element right after itself.
    Duplicate(usize),
    /// Truncate the n-th attribute value to a fraction of its length.
    TruncateAttr(usize, f64),
    /// Wrap the n-th element in `depth` levels of a tag.
    Deepen(usize, usize, usize),
    /// Insert garbage at a fraction of the text.
    Garbage(f64, usize),
    /// Cut the text at a fraction of its length.
    Truncate(f64),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        5 => (any::<usize>(), 0..NASTY.len()).prop_map(|(n, v)| Edit::Number(n, v)),
        2 => (any::<usize>(), any::<f64>()).prop_map(|(n, v)| Edit::Float(n, v)),
        2 => any::<usize>().prop_map(Edit::Delete),
        2 => any::<usize>().prop_map(Edit::Duplicate),
        2 => (any::<usize>(), 0.0..1.0f64).prop_map(|(n, f)| Edit::TruncateAttr(n, f)),
        1 => (any::<usize>(), 1usize..300, 0..WRAPPERS.len()).prop_map(|(n, d, w)| Edit::Deepen(n, d, w)),
        1 => (0.0..1.0f64, 0..GARBAGE.len()).prop_map(|(f, g)| Edit::Garbage(f, g)),
        1 => (0.0..1.0f64).prop_map(Edit::Truncate),
    ]
}

/// Byte ranges of the numbers inside attribute values (between quotes, outside comments).
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let (mut i, mut in_quote, mut in_comment) = (0, false, false);
    while i < b.len() {
        if !text.is_char_boundary(i) {
            i += 1;
            continue;
        }
        if in_comment {
            if text[i..].starts_with("-->") {
                in_comment = false;
                i += 3;
            } else {
                i += 1;
            }
            continue;
        }
        if !in_quote && text[i..].starts_with("<!--") {
            in_comment = true;
            i += 4;
            continue;
        }
        if b[i] == b'"' {
            in_quote = !in_quote;
            i += 1;
            continue;
        }
        if in_quote && (b[i].is_ascii_digit() || b[i] == b'-' || b[i] == b'.') {
            let s = i;
            while i < b.len() && matches!(b[i], b'0'..=b'9' | b'.' | b'e' | b'E' | b'-' | b'+') {
                i += 1;
            }
            out.push((s, i));
            continue;
        }
        i += 1;
    }
    out
}

/// Byte ranges `(start, end)` in a text.
type Ranges = Vec<(usize, usize)>;

/// Byte ranges of the elements and of the attribute values, when the text is XML.
fn structure(text: &str) -> (Ranges, Ranges) {
    let Ok(doc) = roxmltree::Document::parse(text) else {
        return (Vec::new(), Vec::new());
    };
    let mut elements = Vec::new();
    let mut values = Vec::new();
    for n in doc.descendants().filter(|n| n.is_element()) {
        elements.push((n.range().start, n.range().end));
        for a in n.attributes() {
            let r = a.range_value();
            values.push((r.start, r.end));
        }
    }
    (elements, values)
}

fn apply(text: &str, e: &Edit) -> String {
    let pick = |v: &[(usize, usize)], n: usize| (!v.is_empty()).then(|| v[n % v.len()]);
    let at = |f: f64| {
        let mut i = (f * text.len() as f64) as usize;
        while !text.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    let splice = |(s, e): (usize, usize), with: &str| format!("{}{with}{}", &text[..s], &text[e..]);
    match *e {
        Edit::Number(n, v) => pick(&numbers(text), n).map(|r| splice(r, NASTY[v])),
        Edit::Float(n, v) => pick(&numbers(text), n).map(|r| splice(r, &format!("{v:e}"))),
        Edit::Delete(n) => pick(&structure(text).0, n).map(|r| splice(r, "")),
        Edit::Duplicate(n) => pick(&structure(text).0, n).map(|(s, e)| splice((e, e), &text[s..e])),
        Edit::TruncateAttr(n, f) => pick(&structure(text).1, n).map(|(s, e)| {
            let mut cut = s + ((e - s) as f64 * f) as usize;
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            splice((cut, e), "")
        }),
        Edit::Deepen(n, depth, w) => pick(&structure(text).0, n).map(|(s, e)| {
            let tag = WRAPPERS[w];
            let open = format!("<{tag} name=\"w\">").repeat(depth);
            let close = format!("</{tag}>").repeat(depth);
            format!("{}{open}{}{close}{}", &text[..s], &text[s..e], &text[e..])
        }),
        Edit::Garbage(f, g) => Some(splice((at(f), at(f)), GARBAGE[g])),
        Edit::Truncate(f) => Some(text[..at(f)].to_string()),
    }
    .unwrap_or_else(|| text.to_string())
}

/// The property (see the module doc); returns what was checked, for the summary.
fn check(text: &str) -> Result<&'static str, TestCaseError> {
    let lines = 1 + text.matches('\n').count() as u32;
    let u = match Urdf::parse(text) {
        Ok(u) => u,
        Err(e) => {
            let msg = e.to_string();
            let line = e.line();
            prop_assert!(line.is_some(), "a parse error without a line: {msg}");
            let line = line.unwrap();
            prop_assert!((1..=lines).contains(&line), "line {line} of {lines}: {msg}");
            prop_assert!(msg.starts_with(&format!("URDF line {line}")), "{msg}");
            return Ok("parse error");
        }
    };
    let roots: Vec<String> = u.root_links().take(2).map(String::from).collect();
    let leaves: Vec<String> = u.leaf_links().take(8).map(String::from).collect();
    let mut got = "no chain";
    for b in &roots {
        for t in &leaves {
            match u.chain(b, t) {
                Ok((c, _)) => {
                    finite_chain(&c)?;
                    got = "chain";
                }
                Err(e) => {
                    let msg = e.to_string();
                    match (&e, e.line()) {
                        (_, Some(l)) => {
                            prop_assert!((1..=lines).contains(&l), "line {l} of {lines}: {msg}");
                            prop_assert!(msg.starts_with(&format!("URDF line {l}")), "{msg}");
                        }
                        (UrdfError::NotAChain { .. }, None) => {
                            prop_assert!(
                                msg.contains(b.as_str()) && msg.contains(t.as_str()),
                                "{msg}"
                            );
                        }
                        // A chain the loader built but Chain::validate refused: the loader's
                        // own checks (with lines) should have caught it first.
                        _ => prop_assert!(false, "an error without a URDF line: {msg}"),
                    }
                }
            }
        }
    }
    Ok(got)
}

fn finite_chain(c: &Chain) -> Result<(), TestCaseError> {
    let fin = |x: &Isometry3<f64>| {
        x.translation
            .vector
            .iter()
            .chain(x.rotation.coords.iter())
            .all(|v| v.is_finite())
    };
    for j in &c.joints {
        prop_assert!(
            fin(&j.placement),
            "joint {}: placement {:?}",
            j.name,
            j.placement
        );
        prop_assert!(
            j.axis.iter().all(|v| v.is_finite()),
            "joint {}: axis",
            j.name
        );
        prop_assert!(
            !j.limits.lower.is_nan() && !j.limits.upper.is_nan(),
            "joint {}",
            j.name
        );
        prop_assert!(j.damping.is_finite(), "joint {}: damping", j.name);
    }
    for b in &c.bodies {
        prop_assert!(
            b.mass.is_finite() && b.mass > 0.0,
            "link {}: mass {}",
            b.name,
            b.mass
        );
        prop_assert!(
            b.com.iter().chain(b.inertia.iter()).all(|v| v.is_finite()),
            "link {}",
            b.name
        );
    }
    prop_assert!(fin(&c.tool), "tool {:?}", c.tool);
    if c.dof() > 16 {
        return Ok(()); // a scenario refuses it (MAX_LINKS) before any dynamics
    }
    let arm = SpatialArm {
        chain: c.clone(),
        base: Isometry3::identity(),
    };
    let q: Vec<f64> = c
        .joints
        .iter()
        .map(|j| {
            let (lo, hi) = (j.limits.lower, j.limits.upper);
            if lo.is_finite() && hi.is_finite() {
                0.5 * lo + 0.5 * hi
            } else {
                0.0
            }
        })
        .collect();
    let n = q.len();
    let (qd, tau, mut qdd) = (vec![0.1; n], vec![0.0; n], vec![0.0; n]);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let mut d = ChainData::new(&arm);
    terms(&arm, &q, &qd, &g, &mut d);
    prop_assert!(
        d.M.iter()
            .chain(d.bias.iter())
            .chain(d.J.iter())
            .all(|v| v.is_finite()),
        "{} → {}: M, bias or J not finite",
        c.base_link,
        c.tool_link
    );
    aba(&arm, &q, &qd, &tau, &g, None, &mut qdd, &mut d);
    prop_assert!(
        qdd.iter().all(|v| v.is_finite()),
        "{} → {}: q̈ {qdd:?}",
        c.base_link,
        c.tool_link
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        rng_seed: proptest::test_runner::RngSeed::Fixed(22),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_urdfs_load_finite_or_fail_on_a_line(
        which in 0..BASES.len(),
        edits in proptest::collection::vec(edit(), 1..5),
    ) {
        let mut text = BASES[which].to_string();
        for e in &edits {
            text = apply(&text, e);
        }
        check(&text)?;
    }
}

/// Each base loads untouched; then, exhaustively on the planar two-link arm, every number
/// replaced by each nasty value in turn (the loader names the attribute or loads finite
/// data), and every element deleted, duplicated, nested 200 deep and its attribute cut.
#[test]
fn every_number_and_element_of_the_planar_arm() {
    for b in BASES {
        assert_eq!(check(b).unwrap(), "chain");
    }
    let n_numbers = numbers(PLANAR2).len();
    for k in 0..n_numbers {
        for v in 0..NASTY.len() {
            let t = apply(PLANAR2, &Edit::Number(k, v));
            check(&t).unwrap_or_else(|e| panic!("number {k} → {}: {e}", NASTY[v]));
        }
    }
    let n_el = structure(PLANAR2).0.len();
    for k in 0..n_el {
        for e in [
            Edit::Delete(k),
            Edit::Duplicate(k),
            Edit::Deepen(k, 200, 0),
            Edit::TruncateAttr(k, 0.5),
        ] {
            let t = apply(PLANAR2, &e);
            check(&t).unwrap_or_else(|err| panic!("{e:?}: {err}"));
        }
    }
}

/// A two-link arm (base → link1 → link2 → tool0) with `extra` before `</robot>`.
fn small(origin: &str, limit: &str, extra: &str) -> String {
    format!(
        r#"<robot name="s">
  <link name="base"/>
  <link name="link1"><inertial><origin xyz="0.1 0 0"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
  <link name="link2"><inertial><origin xyz="{origin}"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
  <link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="link1"/><child link="link2"/><origin xyz="0.3 0 0"/>
    <limit {limit} effort="10" velocity="1"/></joint>
  <joint name="t" type="fixed"><parent link="link2"/><child link="tool0"/></joint>
{extra}</robot>
"#
    )
}

/// Found while writing the fuzz targets (issue 22; the property above and the `urdf` target's
/// finite-dynamics check pin it): an `<origin xyz>` or a prismatic limit of 1e200 m loaded as
/// finite data whose mass matrix was infinite (a body 1e200 m from the base has an infinite
/// moment of inertia about it). Refused on its line, naming the element and attribute.
#[test]
fn offsets_and_prismatic_travel_beyond_a_kilometre_are_refused_on_their_line() {
    let text = small("1e200 0 0", r#"lower="0" upper="0.5""#, "");
    let e = Urdf::parse(&text).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(&e, UrdfError::BadAttribute { owner, element, attr, line: 4, .. }
            if owner == "link link2" && element == "origin" && attr == "xyz"),
        "{e:?}"
    );
    assert!(msg.contains("beyond 1e3 m"), "{msg}");
    let text = small("0.1 0 0", r#"lower="0" upper="1e200""#, "");
    let e = Urdf::parse(&text).unwrap_err();
    assert!(
        matches!(&e, UrdfError::BadAttribute { owner, element, attr, line: 8, .. }
            if owner == "joint j2" && element == "limit" && attr == "upper"),
        "{e:?}"
    );
    // A kilometre is taken, and its dynamics are finite.
    let text = small("1000 0 0", r#"lower="-1000" upper="1000""#, "");
    check(&text).unwrap();
    assert!(tandem::model::spatial::urdf::load_chain(&text, "base", "tool0").is_ok());
}

/// A joint naming a megabyte-long unknown link, and 20 000 links to suggest from: the
/// suggestion is bounded work, not the names' lengths squared times their number.
#[test]
fn a_long_unknown_link_name_is_reported_at_once() {
    let long = "x".repeat(1 << 20);
    let mut extra = String::new();
    for k in 0..20_000 {
        extra.push_str(&format!("<link name=\"l{k}_{}\"/>\n", "y".repeat(60)));
    }
    extra.push_str(&format!(
        "<joint name=\"bad\" type=\"fixed\"><parent link=\"link2\"/><child link=\"{long}\"/></joint>\n"
    ));
    let text = small("0.1 0 0", r#"lower="0" upper="0.5""#, &extra);
    let t0 = std::time::Instant::now();
    let e = Urdf::parse(&text).unwrap_err();
    assert!(
        matches!(&e, UrdfError::UnknownLink { joint, .. } if joint == "bad"),
        "{e:?}"
    );
    assert!(e.to_string().len() < 400);
    let e = Urdf::parse(&text.replace(&long, "l1_yyy")).unwrap_err();
    assert!(
        matches!(
            &e,
            UrdfError::UnknownLink {
                suggestion: Some(_),
                ..
            }
        ),
        "{e:?}"
    );
    assert!(t0.elapsed().as_secs_f64() < 2.0, "{:?}", t0.elapsed());
}

/// A branch of 20 000 movable joints off the chain, each welded with a warning that gives its
/// subtree's size and mass: linear work (it was quadratic, one subtree walk per joint).
#[test]
fn a_long_welded_branch_is_linear() {
    let n = 20_000;
    let mut extra = String::new();
    let mut parent = "link1".to_string();
    for k in 0..n {
        extra.push_str(&format!(
            "<link name=\"b{k}\"><inertial><mass value=\"0.001\"/><inertia ixx=\"1e-6\" iyy=\"1e-6\" izz=\"1e-6\"/></inertial></link>\n\
             <joint name=\"bj{k}\" type=\"continuous\"><parent link=\"{parent}\"/><child link=\"b{k}\"/><origin xyz=\"0 0 0.001\"/></joint>\n"
        ));
        parent = format!("b{k}");
    }
    let text = small("0.1 0 0", r#"lower="0" upper="0.5""#, &extra);
    let t0 = std::time::Instant::now();
    let (c, w) = tandem::model::spatial::urdf::load_chain(&text, "base", "tool0").unwrap();
    assert_eq!(w.len(), n);
    assert!(
        w[0].contains("bj0") && w[0].contains("(20000 links, "),
        "{}",
        w[0]
    );
    assert!(w[n - 1].contains("(1 link, 0.001 kg)"), "{}", w[n - 1]);
    assert!((c.bodies[0].mass - 21.0).abs() < 1e-9);
    assert!(t0.elapsed().as_secs_f64() < 2.0, "{:?}", t0.elapsed());
}

/// Found by `every_number_and_element_of_the_planar_arm` (issue 22): `<axis xyz="1e308 0 1e308">`
/// overflowed its norm, and the chain got a NaN "unit" axis that only `Chain::validate` caught,
/// without a URDF line. The axis is scaled before it is normalised; a zero axis is still one.
#[test]
fn a_huge_axis_is_a_direction_and_a_tiny_one_is_zero() {
    let text = small("0.1 0 0", r#"lower="0" upper="0.5""#, "")
        .replace(r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="1e308 0 1.7e308"/>"#);
    let (c, _) = tandem::model::spatial::urdf::load_chain(&text, "base", "tool0").unwrap();
    let a = c.joints[0].axis.into_inner();
    let want = Vector3::new(1.0, 0.0, 1.7).normalize();
    assert!((a - want).norm() < 1e-15, "{a:?}");
    check(&text).unwrap();
    let text = small("0.1 0 0", r#"lower="0" upper="0.5""#, "")
        .replace(r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="1e-13 0 0"/>"#);
    let e = Urdf::parse(&text).unwrap_err();
    assert!(
        matches!(&e, UrdfError::ZeroAxis { joint, line: 6 } if joint == "j1"),
        "{e:?}"
    );
}
