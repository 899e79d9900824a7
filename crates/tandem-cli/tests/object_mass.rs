//! A planar object with a mass (issue 26: the scenario's physical quantities are said once):
//! `mass` and the rotational `inertia` give `M_o = diag(m, m, I)` and `G_o = (0, m g, 0)` with the
//! plant's gravity. On the paper's object (m = 1 kg, I = 1 kg m², g = 9.8) the two forms are the
//! same model, so the runs must agree byte for byte, with and without a payload fault (which
//! scales the mass and everything that follows from it); a form that mixes the two is refused
//! naming the field.

use std::fs;

mod support;
use support::*;

/// The paper scenario's `[object]` in the form with a mass.
const WITH_MASS: [(&str, &str); 2] = [
    ("inertia = [1.0, 1.0, 1.0]", "mass = 1.0\ninertia = 1.0"),
    (
        "gravity = [0.0, 9.8, 0.0]",
        "# gravity follows from mass and plant.gravity",
    ),
];

fn run(dir: &std::path::Path, file: &std::path::Path, out: &str) -> Vec<u8> {
    ok(&tandem(
        dir,
        &[
            "run",
            file.to_str().unwrap(),
            "--duration",
            "2",
            "--no-figures",
            "--out",
            out,
        ],
    ));
    fs::read(dir.join(out).join("timeseries.csv")).unwrap()
}

#[test]
fn the_mass_form_is_the_explicit_model() {
    let dir = scratch("object_mass_same");
    let explicit = paper_with(&dir, "explicit.toml", &[]);
    let mass = paper_with(&dir, "mass.toml", &WITH_MASS);
    let a = run(&dir, &explicit, "a");
    let b = run(&dir, &mass, "b");
    assert!(
        a == b,
        "the two forms of the paper's object ran differently"
    );
    // The run's scenario.toml keeps the form the file used.
    let echo = fs::read_to_string(dir.join("b/scenario.toml")).unwrap();
    assert!(echo.contains("mass = 1.0\ninertia = 1.0\n"), "{echo}");
}

#[test]
fn a_payload_fault_scales_the_mass_in_either_form() {
    let dir = scratch("object_mass_payload");
    let fault = (
        "[run]",
        "[faults]\npayload_mass = 1.5\npayload_inertia = 0.8\n\n[run]",
    );
    let explicit = paper_with(&dir, "explicit.toml", &[fault]);
    let mass = paper_with(&dir, "mass.toml", &[WITH_MASS[0], WITH_MASS[1], fault]);
    let nominal = paper_with(&dir, "nominal.toml", &[]);
    let a = run(&dir, &explicit, "a");
    let b = run(&dir, &mass, "b");
    let c = run(&dir, &nominal, "c");
    assert!(a == b, "a payload fault differs between the two forms");
    assert!(a != c, "the payload fault changed nothing");
}

#[test]
fn mixed_forms_are_refused_naming_the_field() {
    let dir = scratch("object_mass_refused");
    let cases: [(&[(&str, &str)], &str); 5] = [
        (
            &[("inertia = [1.0, 1.0, 1.0]", "mass = 1.0\ninertia = 1.0")],
            "object.gravity: follows from object.mass",
        ),
        (
            &[(
                "inertia = [1.0, 1.0, 1.0]",
                "mass = 1.0\ninertia = [1.0, 1.0, 1.0]",
            )],
            "object.inertia: with object.mass give the rotational inertia alone",
        ),
        (
            &[
                ("inertia = [1.0, 1.0, 1.0]", "inertia = 1.0"),
                ("gravity = [0.0, 9.8, 0.0]", ""),
            ],
            "object.mass: missing",
        ),
        (
            &[("gravity = [0.0, 9.8, 0.0]", "")],
            "object.gravity: missing: the explicit form",
        ),
        (
            &[
                WITH_MASS[0],
                WITH_MASS[1],
                ("mass = 1.0\ninertia", "mass = nan\ninertia"),
            ],
            "object.mass",
        ),
    ];
    for (i, (edits, want)) in cases.iter().enumerate() {
        let f = paper_with(&dir, &format!("bad{i}.toml"), edits);
        let o = tandem(&dir, &["validate", f.to_str().unwrap()]);
        exit(&o, 2);
        let e = stderr(&o);
        assert!(e.contains(want), "case {i}: wanted `{want}` in:\n{e}");
        assert!(e.contains("line "), "case {i}: no line in:\n{e}");
    }
}
