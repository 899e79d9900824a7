//! The NN law's smooth default on the spatial presets (issue 24, "smooth laws by design";
//! `docs/smooth-nn.md`): the robust term's sampled-data boundary layer (`smoothing =
//! "sampled"`) and the switching radii `d1 = 2`, `d2 = 3`, against the paper's form
//! (`smoothing = "paper"`, `d1 = 1`, `d2 = 1.5`), welded, 3 s (the S5 claims are measured from
//! 2 s on). Franka arms get their maker's 1000 N m/s torque-rate limit by default; the UR5 has
//! no published limit, so its run sets Franka's explicitly.

mod support;
use support::*;

fn summary(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let o = tandem(dir, args);
    let out = args[args.iter().position(|a| *a == "--out").unwrap() + 1];
    assert!(code(&o) == 0 || code(&o) == 1, "{}", stderr(&o));
    read_json(&dir.join(out).join("summary.json"))
}

fn run3(dir: &std::path::Path, file: &str, law: &str, out: &str) -> serde_json::Value {
    summary(
        dir,
        &[
            "run",
            file,
            "--controller",
            law,
            "--duration",
            "3",
            "--no-figures",
            "--out",
            out,
        ],
    )
}

fn z1(s: &serde_json::Value) -> (f64, f64) {
    let c = &s["s5_claims"];
    (
        c["z1_p_after_2s"]["max_m"].as_f64().unwrap(),
        c["z1_rot_after_2s"]["max_rad"].as_f64().unwrap(),
    )
}

#[test]
fn the_smooth_default_does_not_chatter_and_keeps_to_1000_nm_per_s_with_the_s5_claims() {
    let dir = scratch("smooth_nn");
    // (UR5 with Franka's limit set, Franka with its default), old form without a limit.
    let cases = [
        (
            "dual-ur5",
            embedded_with(
                &dir,
                "dual-ur5",
                "ur5.toml",
                "",
                "[controller.actuator]\nrate_limit = 1000.0",
            ),
            embedded_with(&dir, "dual-ur5", "ur5-paper.toml", PAPER_SWITCHING, ""),
        ),
        (
            "dual-franka",
            "dual-franka".to_string(),
            embedded_with(
                &dir,
                "dual-franka",
                "franka-paper.toml",
                PAPER_SWITCHING,
                "[controller.actuator]\nrate_limit = inf",
            ),
        ),
    ];
    for (name, new, old) in &cases {
        let s = run3(&dir, new, "nn", &format!("{name}-new"));
        let o = run3(&dir, old, "nn", &format!("{name}-old"));
        let (tn, to) = (&s["torque_rate"], &o["torque_rate"]);
        let ((pn, rn), (po, ro)) = (z1(&s), z1(&o));
        eprintln!(
            "{name}: paper form: peak {:.0} N m/s, {} chattering ticks, z1 {po:.3e} m / {ro:.3e} rad; \
             smooth default at 1000 N m/s: peak {:.0} N m/s, {} chattering ticks, {} rate-limited \
             ticks, Q min {}, z1 {pn:.3e} m / {rn:.3e} rad",
            to["peak_Nm_per_s"].as_f64().unwrap(),
            to["chatter_ticks"],
            tn["peak_Nm_per_s"].as_f64().unwrap(),
            tn["chatter_ticks"],
            s["events"]["rate_limited"],
            s["q_switch_min"],
        );
        // The paper's form chatters (the measurement) and needs more than the limit.
        assert!(to["chatter_ticks"].as_u64().unwrap() >= 40, "{name}: {to}");
        assert!(to["peak_Nm_per_s"].as_f64().unwrap() > 10_000.0, "{name}");
        // The smooth default: completed, no reversal above 0.5 N m after 10 ms, within the
        // limit, Q = 1 throughout (Ω1 holds the start), the S5 claims met.
        assert_eq!(s["status"], "completed", "{name}: {s}");
        assert_eq!(tn["chatter_ticks"], 0, "{name}: {tn}");
        assert!(
            tn["peak_Nm_per_s"].as_f64().unwrap() <= 1000.0 * (1.0 + 1e-12),
            "{name}: {tn}"
        );
        assert_eq!(s["q_switch_min"], 1.0, "{name}");
        assert_eq!(s["violation_ticks"], 0, "{name}");
        assert_eq!(s["s5_claims"]["pass"], true, "{name}: {}", s["s5_claims"]);
        // z1 as before: within 1 % of the paper form's (the issue allows 20 %).
        assert!((pn / po - 1.0).abs() < 0.01, "{name}: {pn} vs {po}");
        assert!((rn / ro - 1.0).abs() < 0.01, "{name}: {rn} vs {ro}");
    }
}

#[test]
fn without_a_limit_the_smooth_ur5_start_is_the_gravity_catch_and_does_not_chatter() {
    let dir = scratch("smooth_nn_free");
    // The law's own torques (no rate limit on the UR5): Q stays 1, nothing reverses; the peak
    // rate is the first step, the law catching the box's unlearned weight through K2
    // (1345 N m/s at 1 ms), not the robust term.
    let s = summary(
        &dir,
        &[
            "run",
            "dual-ur5",
            "--duration",
            "3",
            "--no-figures",
            "--out",
            "u",
        ],
    );
    let t = &s["torque_rate"];
    assert_eq!(t["chatter_ticks"], 0, "{t}");
    assert_eq!(t["peak_t_s"], 0.001, "{t}");
    assert!(t["peak_Nm_per_s"].as_f64().unwrap() < 1400.0, "{t}");
    assert_eq!(s["events"]["rate_limited"], 0);
    assert_eq!(s["q_switch_min"], 1.0);
    assert_eq!(s["s5_claims"]["pass"], true, "{}", s["s5_claims"]);
}

#[test]
fn the_baselines_keep_their_results_under_the_franka_default_limit() {
    let dir = scratch("smooth_nn_baselines");
    let pdg = embedded_with(&dir, "dual-franka", "pdg.toml", "", "");
    let text = std::fs::read_to_string(dir.join(&pdg)).unwrap();
    assert!(text.contains("gravity_compensation = false"));
    std::fs::write(
        dir.join(&pdg),
        text.replacen(
            "gravity_compensation = false",
            "gravity_compensation = true",
            1,
        ),
    )
    .unwrap();
    for (file, law, s5) in [
        (pdg.as_str(), "pd", true),
        ("dual-franka", "ctc", true),
        // The paper's PD (no gravity compensation) misses S5 with or without a limit.
        ("dual-franka", "pd", false),
    ] {
        let s = run3(&dir, file, law, &format!("{law}-{s5}"));
        assert_eq!(s["status"], "completed", "{file} {law}");
        assert_eq!(s["torque_rate"]["chatter_ticks"], 0, "{file} {law}");
        assert!(
            s["torque_rate"]["peak_Nm_per_s"].as_f64().unwrap() <= 1000.0 * (1.0 + 1e-12),
            "{file} {law}"
        );
        assert_eq!(
            s["s5_claims"]["pass"], s5,
            "{file} {law}: {}",
            s["s5_claims"]
        );
    }
}

#[test]
fn smoothing_and_the_rate_limit_default_are_settable_and_checked() {
    let dir = scratch("smooth_nn_fields");
    // A bad value names the field and its line.
    let f = embedded_with(&dir, "dual-ur5", "bad.toml", "smoothing = \"smooth\"", "");
    let o = tandem(&dir, &["validate", &f]);
    exit(&o, 2);
    let e = stderr(&o);
    assert!(e.contains("smoothing"), "{e}");
    assert!(e.contains("(line "), "{e}");
    // `rate_limit = inf` turns the Franka default off: the start's first step is the law's own.
    let f = embedded_with(
        &dir,
        "dual-franka",
        "free.toml",
        "",
        "[controller.actuator]\nrate_limit = inf",
    );
    for (file, out, limited) in [(f.as_str(), "free", false), ("dual-franka", "dflt", true)] {
        let s = summary(
            &dir,
            &[
                "run",
                file,
                "--duration",
                "0.05",
                "--no-figures",
                "--out",
                out,
            ],
        );
        let peak = s["torque_rate"]["peak_Nm_per_s"].as_f64().unwrap();
        assert_eq!(peak > 1000.0 * (1.0 + 1e-12), !limited, "{out}: {peak}");
        assert_eq!(
            s["events"]["rate_limited"].as_u64().unwrap() > 0,
            limited,
            "{out}"
        );
    }
    // The planar per-arm scheme has no lightest-inertia bound: `sampled` is refused by name.
    let p = paper_with(
        &dir,
        "perarm.toml",
        &[
            ("scheme = \"object\"", "scheme = \"per_arm\""),
            (
                "[controller.nn]\n",
                "[controller.nn]\nsmoothing = \"sampled\"\n",
            ),
        ],
    );
    let o = tandem(&dir, &["validate", p.to_str().unwrap()]);
    exit(&o, 2);
    assert!(
        stderr(&o).contains("controller.nn.smoothing"),
        "{}",
        stderr(&o)
    );
}

/// An embedded scenario on compliant true grasps of a firm parallel gripper (issue 24: 1e5 N/m,
/// 1e3 N m/rad; damping critical on a UR5 flange, `2√(k · 0.2 kg)`, `2√(k_rot · 1e-4 kg m²)`),
/// the plant step 0.25 ms (the grasp's fastest mode), a slip at 5 cm, with `nn` in the NN table.
fn compliant(dir: &std::path::Path, name: &str, file: &str, nn: &str) -> String {
    let f = embedded_with(dir, name, file, nn, "");
    let mut text = std::fs::read_to_string(dir.join(&f)).unwrap();
    for (from, to) in [
        (
            "baumgarte = 20.0",
            "baumgarte = 20.0\ncompliant_grasps = { stiffness = [1e5, 1e5, 1e5, 1e3, 1e3, 1e3], damping = [283.0, 283.0, 283.0, 0.632, 0.632, 0.632] }",
        ),
        ("plant_step = 0.001", "plant_step = 0.00025"),
        ("max_drift = 1e-6", "max_drift = 0.05"),
    ] {
        assert!(text.contains(from), "{name}: no `{from}`");
        text = text.replacen(from, to, 1);
    }
    std::fs::write(dir.join(&f), text).unwrap();
    f
}

#[test]
fn a_firm_compliant_grasp_holds_under_the_smooth_default() {
    let dir = scratch("smooth_nn_compliant");
    // dual-UR5: the smooth default completes inside the bounds with the S5 claims, nothing
    // reverses (Q = 1 throughout); the paper form slips (measured 0.83 s, 65 violating ticks:
    // its robust term chatters through the wrists' springs, docs/robustness.md).
    let f = compliant(&dir, "dual-ur5", "ur5.toml", "");
    let s = run3(&dir, &f, "nn", "ur5");
    assert_eq!(s["status"], "completed", "{s}");
    assert_eq!(s["violation_ticks"], 0);
    assert_eq!(s["torque_rate"]["chatter_ticks"], 0, "{}", s["torque_rate"]);
    assert_eq!(s["q_switch_min"], 1.0);
    assert_eq!(s["s5_claims"]["pass"], true, "{}", s["s5_claims"]);
    let f = compliant(&dir, "dual-ur5", "ur5-paper.toml", PAPER_SWITCHING);
    let s = run3(&dir, &f, "nn", "ur5-paper");
    assert_eq!(s["status"], "fault", "{}", s["status"]);
    // dual-Franka (at its 1000 N m/s default): completed, inside, S5 met, but the wrists
    // (q6, q13; q2 from 96 ms) reverse on nearly every tick, held at the rate limit: the design's
    // rotational K2 (70.4 N m s/rad on ry) is too stiff a sampled damping for the wrist's
    // rotation on the 1e3 N m/rad spring (docs/smooth-nn.md, "Compliant grasps"; K2_ry = 35
    // leaves 4 reversals). Pinned so that a fix shows.
    let f = compliant(&dir, "dual-franka", "franka.toml", "");
    let s = run3(&dir, &f, "nn", "franka");
    assert_eq!(s["status"], "completed", "{s}");
    assert_eq!(s["violation_ticks"], 0);
    assert_eq!(s["s5_claims"]["pass"], true, "{}", s["s5_claims"]);
    assert!(
        s["torque_rate"]["chatter_ticks"].as_u64().unwrap() > 2000,
        "{}",
        s["torque_rate"]
    );
}

/// Rule 2 per scenario (`scenario::spatial::switching_radii`): a heavier box needs a larger
/// Ω1 for the start's gravity catch. The presets keep `d1 = 2`, `d2 = 3`; a 15 kg box on
/// dual-UR5 gets the rule's `d1 = 6.5`, `d2 = 9.75` (estimate 8 (0.08 + 147.15/240) = 5.55, × 1.15,
/// rounded up to a half), which keeps `Q ≡ 1` and the start's peak torque rate at the gravity
/// catch's; with the presets' radii `Q` drops and the peak rate more than triples.
#[test]
fn the_switching_radii_follow_the_scenario_s_load() {
    use tandem_cli::scenario::spatial as sp;
    use tandem_cli::scenario::{EMBEDDED, embedded_source};
    let radii = |name: &str, mass: Option<&str>| {
        let mut src = embedded_source(EMBEDDED.iter().find(|e| e.name == name).unwrap());
        if let Some(m) = mass {
            src.text = src.text.replacen("mass = 3.0", m, 1);
        }
        let sc = sp::parse(&src).unwrap();
        let g = sp::nn_gains(&sc, None);
        (g.d1, g.d2)
    };
    assert_eq!(radii("dual-ur5", None), (2.0, 3.0));
    assert_eq!(radii("dual-franka", None), (2.0, 3.0));
    assert_eq!(radii("dual-ur5", Some("mass = 15.0")), (6.5, 9.75));

    let d = scratch("smooth_nn_radii");
    let text = stdout(&tandem(&d, &["scenario", "show", "dual-ur5"]));
    let heavy = text.replacen("mass = 3.0", "mass = 15.0", 1);
    assert_ne!(heavy, text);
    std::fs::write(d.join("heavy.toml"), &heavy).unwrap();
    let fixed = heavy.replacen(
        "[controller.nn]\n",
        "[controller.nn]\nd1 = 2.0\nd2 = 3.0\n",
        1,
    );
    std::fs::write(d.join("fixed.toml"), &fixed).unwrap();
    let rule = run3(&d, "heavy.toml", "nn", "rule");
    let old = run3(&d, "fixed.toml", "nn", "fixed");
    for s in [&rule, &old] {
        assert_eq!(s["status"], "completed");
        assert_eq!(s["violation_ticks"], 0);
        assert_eq!(s["s5_claims"]["pass"], true);
    }
    assert_eq!(rule["q_switch_min"], 1.0, "{}", rule["q_switch_min"]);
    assert!(
        old["q_switch_min"].as_f64().unwrap() < 0.95,
        "{}",
        old["q_switch_min"]
    );
    let peak = |s: &serde_json::Value| s["torque_rate"]["peak_Nm_per_s"].as_f64().unwrap();
    assert!(peak(&rule) < 1500.0, "{}", peak(&rule));
    assert!(
        peak(&old) > 3.0 * peak(&rule),
        "{} vs {}",
        peak(&old),
        peak(&rule)
    );
}
