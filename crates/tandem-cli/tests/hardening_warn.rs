//! Issue 22, "refuse the impossible, warn about the implausible": a spatial scenario whose grasp
//! frames sit off the box's surface, whose tool approach axis points out of the box, or whose
//! arms stand on the same spot validates with a warning that names the field, its line and the
//! distance or angle; the presets validate without a word.

use tandem_cli::scenario::spatial as sp;
use tandem_cli::scenario::{EMBEDDED, Kind};
use tandem_cli::scenario::{Source, embedded_source};

/// The dual-UR5 preset with `from` replaced by `to` (which must occur), built.
fn warnings_of(edits: &[(&str, &str)]) -> Vec<String> {
    let mut src: Source = embedded_source(EMBEDDED.iter().find(|e| e.name == "dual-ur5").unwrap());
    for (from, to) in edits {
        assert!(src.text.contains(from), "the preset has no `{from}`");
        src.text = src.text.replacen(from, to, 1);
    }
    src.display = "test.toml".into();
    let sc = sp::parse(&src).unwrap();
    sp::build(&sc, &src).unwrap().warnings
}

const ARM0_GRASP: &str = "grasp = { position = [-0.2, 0.0, 0.0], axes = [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]] }";

#[test]
fn the_presets_validate_without_a_warning() {
    for e in tandem_cli::scenario::embedded(Kind::Spatial) {
        let src = embedded_source(e);
        let sc = sp::parse(&src).unwrap();
        let b = sp::build(&sc, &src).unwrap();
        assert!(b.warnings.is_empty(), "{}: {:?}", e.name, b.warnings);
    }
}

#[test]
fn a_grasp_a_tenth_of_a_metre_off_the_face_is_named_with_its_distance_and_line() {
    let w = warnings_of(&[(
        ARM0_GRASP,
        "grasp = { position = [-0.3, 0.0, 0.0], axes = [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]] }",
    )]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with(
            "arms[0].grasp: the tool frame sits 0.1 m outside the box (0.4 × 0.2 × 0.2 m)"
        ),
        "{w:?}"
    );
    assert!(w[0].contains("(test.toml, line 25)"), "{w:?}");
}

#[test]
fn a_one_millimetre_box_held_at_its_old_grasps_warns_for_both_arms() {
    let w = warnings_of(&[("size = [0.4, 0.2, 0.2]", "size = [0.001, 0.001, 0.001]")]);
    assert_eq!(w.len(), 2, "{w:?}");
    for (i, w) in w.iter().enumerate() {
        assert!(
            w.starts_with(&format!("arms[{i}].grasp: the tool frame sits 0.2 m outside the box (0.001 × 0.001 × 0.001 m)")),
            "{w}"
        );
    }
}

#[test]
fn a_grasp_inside_the_box_says_inside() {
    let w = warnings_of(&[(
        ARM0_GRASP,
        "grasp = { position = [-0.15, 0.0, 0.0], axes = [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]] }",
    )]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("arms[0].grasp: the tool frame sits 0.05 m inside the box"),
        "{w:?}"
    );
}

#[test]
fn a_tool_that_faces_away_from_the_box_names_the_axis_that_faces_it() {
    // Tool z along −x at the −x face: pointing out of the box; its −z points in.
    let w = warnings_of(&[(
        ARM0_GRASP,
        "grasp = { position = [-0.2, 0.0, 0.0], axes = [[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]] }",
    )]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("arms[0].grasp: the tool's approach axis (+z) is 180° from the box's inward normal at its −x face; the tool axis that points into the box is −z"),
        "{w:?}"
    );
    // Tool z along the face (tool x into the box): 90°, and +x is named.
    let w = warnings_of(&[(
        ARM0_GRASP,
        "grasp = { position = [-0.2, 0.0, 0.0], axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }",
    )]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("is 90° from"), "{w:?}");
    assert!(w[0].contains("points into the box is +x"), "{w:?}");
}

#[test]
fn two_arms_on_one_spot_overlap() {
    let w = warnings_of(&[(
        "base = { position = [0.70, 0.0, 0.0], rpy = [0.0, 0.0, 3.141592653589793] }",
        "base = { position = [-0.65, 0.0, 0.0], rpy = [0.0, 0.0, 3.141592653589793] }",
    )]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with(
            "arms[1].base: the base stands 0.05 m from arms[0]'s: the two arms overlap"
        ),
        "{w:?}"
    );
    assert!(w[0].contains("(test.toml, line 32)"), "{w:?}");
}

// ---------------------------------------------------------------------------------------------
// The planar loader's twin: grasp points off the box's outline, bases on the same spot.

/// The planar `paper` scenario with each `from` replaced by `to` (which must occur), its
/// set-up warnings (after every check a run makes).
fn planar_warnings_of(edits: &[(&str, &str)]) -> Vec<String> {
    use tandem_cli::scenario::{Scenario, parse};
    let mut src: Source = embedded_source(EMBEDDED.iter().find(|e| e.name == "paper").unwrap());
    for (from, to) in edits {
        assert!(src.text.contains(from), "the preset has no `{from}`");
        src.text = src.text.replacen(from, to, 1);
    }
    src.display = "test.toml".into();
    let Ok(Scenario::Planar(sc)) = parse(&src) else {
        panic!("not a planar scenario")
    };
    tandem_cli::run::planar::prepare(sc, &src)
        .unwrap()
        .ready
        .warnings
}

#[test]
fn the_planar_presets_validate_without_a_plausibility_warning() {
    for e in tandem_cli::scenario::embedded(Kind::Planar) {
        let src = embedded_source(e);
        let Ok(tandem_cli::scenario::Scenario::Planar(sc)) = tandem_cli::scenario::parse(&src)
        else {
            panic!("{}: not planar", e.name)
        };
        let w = tandem_cli::run::planar::prepare(sc, &src)
            .unwrap()
            .ready
            .warnings;
        assert!(
            !w.iter()
                .any(|w| w.contains("off its outline") || w.contains("overlap")),
            "{}: {w:?}",
            e.name
        );
    }
}

#[test]
fn a_planar_grasp_a_tenth_of_a_metre_off_the_box_end_is_named_with_its_distance_and_line() {
    let w = planar_warnings_of(&[("grasp = [0.05, 0.0]", "grasp = [0.15, 0.0]")]);
    let off: Vec<_> = w.iter().filter(|w| w.contains("off its outline")).collect();
    assert_eq!(off.len(), 1, "{w:?}");
    assert!(
        off[0].starts_with(
            "arms[1].grasp = (0.15, 0): the grasp point sits 0.1 m outside the box (0.1 × 0.05 m, object.size)"
        ),
        "{off:?}"
    );
    assert!(off[0].contains("(test.toml, line 46)"), "{off:?}");
    // Inside the box, by its distance to the nearest edge.
    let w = planar_warnings_of(&[("size = [0.1, 0.05]", "size = [0.3, 0.05]")]);
    let off: Vec<_> = w.iter().filter(|w| w.contains("off its outline")).collect();
    assert_eq!(off.len(), 2, "{w:?}");
    assert!(off[0].contains("sits 0.025 m inside the box"), "{off:?}");
}

#[test]
fn planar_bases_a_few_centimetres_apart_overlap() {
    let w = planar_warnings_of(&[
        ("base = [-0.38, 0.0]", "base = [-0.03, 0.0]"),
        ("base = [0.38, 0.0]", "base = [0.03, 0.0]"),
    ]);
    let o: Vec<_> = w.iter().filter(|w| w.contains("overlap")).collect();
    assert_eq!(o.len(), 1, "{w:?}");
    assert!(
        o[0].starts_with("arms[1].base: the base stands 0.06 m from arms[0]'s"),
        "{o:?}"
    );
    assert!(o[0].contains("(test.toml, line 43)"), "{o:?}");
}
