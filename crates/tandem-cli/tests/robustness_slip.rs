//! The grasp-slip family of `tandem robustness` (`docs/robustness.md`): its classification at
//! one stiff and one soft setting, so that the report cannot change silently; and (ignored, run
//! by CI) its convergence in the plant step.

use tandem_cli::robustness::{
    Cell, SLIP_DEFLECTION, SLIP_LAWS, SLIP_LEVELS, TRACK_MM, slip_run, slip_run_with,
};

fn law(name: &str) -> usize {
    SLIP_LAWS
        .iter()
        .position(|l| l.name == name)
        .unwrap_or_else(|| panic!("no slip law {name}"))
}

fn run(level: usize, name: &str) -> Cell {
    slip_run(Some(level), law(name)).unwrap_or_else(|e| panic!("{name}: {e:#}"))
}

/// 1e7 N/m, 1e5 N m/rad: stiff enough that every law runs as with welds.
#[test]
fn stiff_grasps_keep_every_law_s_class() {
    assert_eq!(SLIP_LEVELS[0], (1e7, 1e5));
    // The paper's PD has no gravity compensation: it sags by 𝓖/K_P (about 110 N of arms and
    // box over 5000 N/m: 22 mm, measured 22.3 mm), inside the bounds but over the 10 mm limit.
    let pd = run(0, "PD (paper)");
    assert_eq!(pd.class, "degraded", "{}", pd.detail);
    assert!(
        pd.track_mm > 15.0 && pd.track_mm < 30.0 && pd.track_mm > TRACK_MM,
        "{}",
        pd.detail
    );
    // The others track to a fraction of a millimetre (measured 0.11–0.14 mm; 1 mm leaves room
    // for a change of the path's sampling, not for a regression to the sag) with the margin of
    // the welded run (measured 0.40).
    for name in ["PD + model gravity", "NN", "NN (paper form)", "NN, ϖ = 20"] {
        let c = run(0, name);
        assert_eq!(c.class, "inside", "{name}: {}", c.detail);
        assert!(c.track_mm < 1.0 && c.margin > 0.35, "{name}: {}", c.detail);
        let i = c.slip.as_ref().unwrap();
        assert!(i.track_rad < 1e-3, "{name}: {}", c.detail);
        assert_eq!(i.substeps, 32, "√(1e5/1e-4) rad/s · 1 ms = 31.6 → 32 steps");
    }
}

/// 1e4 N/m, 1e2 N m/rad: every law's grasp slips (a named fault) in the start transient.
#[test]
fn soft_grasps_slip_under_every_law() {
    assert_eq!(SLIP_LEVELS[5], (1e4, 1e2));
    for name in [
        "PD (paper)",
        "PD + model gravity",
        "NN",
        "NN (paper form)",
        "NN, ϖ = 20",
    ] {
        let c = run(5, name);
        assert_eq!(c.class, "fault", "{name}: {}", c.detail);
        assert!(
            c.detail.starts_with("constraint_drift at "),
            "{name}: {}",
            c.detail
        );
        let i = c.slip.as_ref().unwrap();
        // The fault fires at the first check past the threshold (every 10 ticks): the
        // deflection is over it, by less than 10 ms of motion (measured 0.051–0.055 rad).
        let d = i.deflection.0.max(i.deflection.1);
        assert!(
            d > SLIP_DEFLECTION && d < 2.0 * SLIP_DEFLECTION,
            "{name}: {}",
            c.detail
        );
        // Measured 0.03–0.28 s.
        let t: f64 = c.detail["constraint_drift at ".len()..]
            .split(' ')
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap();
        assert!(t < 0.5, "{name}: {}", c.detail);
    }
}

/// Halving the plant step: the runs that neither chatter nor wobble agree to 1e-5 (measured
/// 1e-8 and below), and no class changes but the NN law's at 1e6 / 1e4, whose chatter is
/// chaotic (`docs/robustness.md`). About 40 s.
#[test]
#[ignore]
fn slip_family_converges_in_the_step() {
    let smooth = |lv: usize, name: &str| match name {
        "PD (paper)" | "PD + model gravity" => lv <= 2,
        "NN (paper form)" => lv == 0,
        "NN, ϖ = 20" => lv <= 4,
        _ => false,
    };
    for lv in 0..SLIP_LEVELS.len() {
        for name in [
            "PD (paper)",
            "PD + model gravity",
            "NN (paper form)",
            "NN, ϖ = 20",
        ] {
            let a = run(lv, name);
            let b = slip_run_with(Some(lv), law(name), 2).unwrap();
            assert_eq!(b.slip.as_ref().unwrap().factor, 2);
            if !(lv == 2 && name == "NN (paper form)") {
                assert_eq!(a.class, b.class, "{lv} {name}: {} / {}", a.detail, b.detail);
            }
            if smooth(lv, name) {
                let (ia, ib) = (a.slip.as_ref().unwrap(), b.slip.as_ref().unwrap());
                let rel = |x: f64, y: f64| (x - y).abs() / x.abs().max(1e-12);
                assert!(
                    rel(a.track_mm, b.track_mm) < 1e-5
                        && rel(ia.track_rad, ib.track_rad) < 1e-5
                        && (a.margin - b.margin).abs() < 1e-5,
                    "{lv} {name}: {} / {}",
                    a.detail,
                    b.detail
                );
            }
        }
    }
}

/// 1e5 N/m, 1e3 N m/rad (a firm parallel gripper, issue 24): the NN law's smooth default
/// (`docs/smooth-nn.md`) stays inside the bounds, with `Q = 1` throughout; the paper's form
/// slips in its start transient (its robust term chatters through the wrists' springs).
#[test]
fn a_firm_gripper_holds_under_the_smooth_nn_default() {
    assert_eq!(SLIP_LEVELS[4], (1e5, 1e3));
    let c = run(4, "NN");
    assert_eq!(c.class, "inside", "{}", c.detail);
    assert!(c.track_mm < 1.0 && c.margin > 0.35, "{}", c.detail);
    // Measured: 0.78 s.
    let p = run(4, "NN (paper form)");
    assert_eq!(p.class, "fault", "{}", p.detail);
    assert!(p.detail.starts_with("constraint_drift at "), "{}", p.detail);
}
