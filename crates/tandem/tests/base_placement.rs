//! The base-placement study's key facts (`docs/base-placement.md`, SPEC-spatial S6): the presets'
//! placements are where the study puts them, for the reasons it gives. The study code is the
//! `base_placement` example's (`examples/base_placement/study.rs`).

#[path = "../examples/base_placement/study.rs"]
mod study;

use study::FrankaGrasp;
use tandem::nalgebra::{Isometry3, Vector3, Vector6};
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::spatial::path::Se3Path;

/// The study's sampling step along the lap, s.
const DT: f64 = 0.5;

/// One lap of the UR5 pair at base separation `d`, continued from the S6 start angles.
fn ur5_lap(params: &tandem::plant::spatial::SpatialPlantParams) -> study::Lap {
    study::follow_lap(
        params,
        &Se3Path::spec_s6(),
        &tandem::presets::dual_ur5().q_guess,
        DT,
        true,
    )
}

fn min2(a: [f64; 2]) -> f64 {
    a[0].min(a[1])
}

fn max2(a: [f64; 2]) -> f64 {
    a[0].max(a[1])
}

#[test]
fn dual_ur5_preset_keeps_the_s6_branch_with_the_s6_figures() {
    // The preset itself (bases ∓0.70 m), not a rebuilt copy.
    let setup = tandem::presets::dual_ur5();
    let lap = ur5_lap(&setup.params);
    assert!(lap.failure.is_none(), "{:?}", lap.failure);
    assert_eq!(lap.samples, 121, "every 0.5 s over 60 s, both ends");
    // The IK lands on SPEC-spatial S6's start angles: they are printed to 6 decimals, so they
    // agree to the rounding (5e-7) plus the IK's 1e-12 residual; 1e-6 leaves 2× for rounding.
    // (S6 prints q6 as −1.570796, i.e. −π/2 rounded.)
    let h = -std::f64::consts::FRAC_PI_2;
    let s6 = [
        -0.212431, -1.267797, 1.525974, -0.258177, 1.358366, h, //
        -0.350708, -1.754035, 2.044645, -0.290610, 1.220088, h,
    ];
    for (k, (a, b)) in lap.q[0].iter().zip(s6).enumerate() {
        assert!((a - b).abs() < 1e-6, "q[{k}] = {a} vs S6 {b}");
    }
    // Measured (docs/base-placement.md): σ_min 0.1961 both arms, cond 9.462, |sin q3| 0.8536,
    // |sin q5| 0.8703, travel 39.93° (q3), τ/effort 23.63 %, closest approach 0.5646 m (the
    // wrist centres: 0.4 m box + 2 × 0.0823 m), lowest point 0.2510 m (the wrist centre at
    // 10° pitch: 0.3 − 0.2823 sin 10°). Sampling every 0.1 s instead changes none of them by
    // more than 0.03 % (the path is slow: 5 mm and ≤ 0.18° per 0.5 s step). The bounds are
    // S6's figures where S6 gives one; σ_min also from above (a ±0.001 band: a model change
    // shows up here first).
    for i in 0..2 {
        assert!(
            (lap.sigma_min[i] - 0.1961).abs() < 1e-3,
            "σ_min {:?}",
            lap.sigma_min
        );
    }
    assert!(
        min2(lap.sigma_min) >= 0.15,
        "the brief's floor: {:?}",
        lap.sigma_min
    );
    assert!(max2(lap.cond_max) <= 9.5, "cond {:?}", lap.cond_max);
    assert!(
        min2(lap.sin_q3_min) >= 0.85,
        "|sin q3| {:?}",
        lap.sin_q3_min
    );
    assert!(
        min2(lap.sin_q5_min) >= 0.87,
        "|sin q5| {:?}",
        lap.sin_q5_min
    );
    assert!(
        max2(lap.travel_max) <= 40f64.to_radians(),
        "travel {:?}°",
        lap.travel_max.map(f64::to_degrees)
    );
    // S6: "the static torques at 25 % of the effort limits"; measured 23.6 %.
    let tau = max2(lap.torque_ratio_max);
    assert!((0.23..=0.25).contains(&tau), "τ/effort {tau}");
    assert!(lap.separation_min >= 0.56, "{}", lap.separation_min);
    assert!(lap.height_min >= 0.25, "{}", lap.height_min);
}

#[test]
fn dual_ur5_closer_than_a_metre_cannot_reach_and_farther_breaks_the_figures() {
    let path = Se3Path::spec_s6();
    let x0 = study::s6_pose(&path, 0.0);
    // d = 0.90 m: arm 2's wrist centre (0.0823 m behind the flange along the tool z) comes within
    // d4 of its base axis, and a UR arm's wrist centre can never be closer than d4 (the q1
    // equation, q1 = atan2(y, x) ± acos(d4 / r) + π/2, needs r ≥ d4): no solution on any branch.
    let params = study::dual_ur5_at(0.90);
    let arm2 = &params.arms[1];
    let d4 = arm2.chain.joints[3].placement.translation.vector.z;
    assert!((d4 - 0.10915).abs() < 1e-12, "the UR5's d4: {d4}");
    let g = study::grasp_target(&params, 1, &x0);
    let w = g.translation.vector - g.rotation * Vector3::z() * 0.0823;
    let b = arm2.base.translation.vector;
    let r = ((w.x - b.x).powi(2) + (w.y - b.y).powi(2)).sqrt();
    assert!(r < d4 - 0.04, "wrist centre {r} m from the base axis");
    // The plant's IK agrees, and so does a search from random starts (any branch).
    let plant = SpatialPlant::new(&params).expect("valid");
    let e = plant
        .initial_state(&x0, &Vector6::zeros(), &tandem::presets::dual_ur5().q_guess)
        .expect_err("out of reach");
    assert!(e.to_string().contains("arms[1]"), "{e}");
    assert!(study::ik_search(arm2, &g, 50, None, 3).is_empty());
    // The lap is solvable again from about 0.984 m (the study's 1 mm scan), and at 1.00 m the
    // wrists pass near singular: measured σ_min 0.029, |sin q5| 0.30.
    let lap = ur5_lap(&study::dual_ur5_at(1.00));
    assert!(lap.failure.is_none(), "{:?}", lap.failure);
    assert!(min2(lap.sigma_min) < 0.035, "σ_min {:?}", lap.sigma_min);
    assert!(min2(lap.sin_q5_min) < 0.35, "|sin q5| {:?}", lap.sin_q5_min);
    // σ_min peaks at about 1.425 m (0.2030); the preset's 1.40 m is within 4 % of it (measured
    // 3.4 %) and well above 1.30 m (0.162), while 1.46 m already breaks S6's travel and torque
    // figures (measured 41.6°, 25.7 %): the preset is the widest placement that keeps them.
    let at = |d: f64| ur5_lap(&study::dual_ur5_at(d));
    let (l130, l140, l1425, l146) = (at(1.30), at(1.40), at(1.425), at(1.46));
    for l in [&l130, &l140, &l1425, &l146] {
        assert!(l.failure.is_none(), "{:?}", l.failure);
    }
    let s = |l: &study::Lap| min2(l.sigma_min);
    assert!(s(&l1425) > s(&l140), "{} vs {}", s(&l1425), s(&l140));
    assert!(
        s(&l140) >= 0.96 * s(&l1425),
        "{} vs {}",
        s(&l140),
        s(&l1425)
    );
    assert!(s(&l140) > s(&l130) + 0.03, "{} vs {}", s(&l140), s(&l130));
    assert!(max2(l146.travel_max) > 41f64.to_radians());
    assert!(max2(l146.torque_ratio_max) > 0.255);
}

#[test]
fn dual_franka_preset_holds_from_above_and_not_by_the_end_faces() {
    // The preset itself (bases ∓0.55 m, top-face grasps) from its own guess, as the run starts.
    let setup = tandem::presets::dual_franka();
    let path = Se3Path::spec_s6();
    let x0 = study::s6_pose(&path, 0.0);
    let plant = SpatialPlant::new(&setup.params).expect("valid");
    let y0 = plant
        .initial_state(&x0, &Vector6::zeros(), &setup.q_guess)
        .expect("the preset starts inside the limits");
    let lap = study::follow_lap(&setup.params, &path, &y0[..14], DT, false);
    assert!(lap.failure.is_none(), "{:?}", lap.failure);
    // Measured: σ_min 0.170 (both arms), travel 52.0°, τ/effort 39.0 %, 0.379 rad from the
    // nearest joint limit. Bands of about ±3 % around them (a change of model or of the
    // continuation shows up), and the brief's σ_min ≥ 0.15.
    assert!(min2(lap.sigma_min) >= 0.165, "σ_min {:?}", lap.sigma_min);
    assert!(max2(lap.sigma_min) <= 0.175, "σ_min {:?}", lap.sigma_min);
    let travel = max2(lap.travel_max).to_degrees();
    assert!((50.5..=53.5).contains(&travel), "travel {travel}°");
    let tau = max2(lap.torque_ratio_max);
    assert!((0.38..=0.40).contains(&tau), "τ/effort {tau}");
    let m = min2(lap.limit_margin_min);
    assert!((0.36..=0.40).contains(&m), "limit margin {m}");

    // End-face grasps (the UR5's frames) at the preset placement and the box 0.35 m up: no
    // in-limit solution for either arm from 100 random starts, while the same search finds
    // top-face solutions (so it can find them).
    let x_wo = Isometry3::translation(0.1, 0.0, 0.35);
    let end = study::dual_franka_at(1.10, FrankaGrasp::End { roll: 0.0 });
    let top = study::dual_franka_at(1.10, FrankaGrasp::Top);
    for i in 0..2 {
        let g = study::grasp_target(&end, i, &x_wo);
        assert!(
            study::ik_search(&end.arms[i], &g, 100, None, 5 + i as u64).is_empty(),
            "arm {i}: an end-face grasp inside the limits"
        );
        let g = study::grasp_target(&top, i, &x_wo);
        assert!(!study::ik_search(&top.arms[i], &g, 100, None, 5 + i as u64).is_empty());
    }
}

#[test]
fn the_branch_test_tells_the_eight_ur5_solutions_apart() {
    // The study keeps the S6 branch by reading it geometrically (`study::ur5_branch`). A UR5
    // has (generically) 8 inverse-kinematics solutions: shoulder × elbow × wrist. Found from
    // random starts at the preset's start pose, distinct solutions (modulo 2π) must get
    // distinct branches, and only the S6 start angles the S6 branch.
    let setup = tandem::presets::dual_ur5();
    let x0 = study::s6_pose(&Se3Path::spec_s6(), 0.0);
    let arm = &setup.params.arms[0];
    let g = study::grasp_target(&setup.params, 0, &x0);
    let mut d = tandem::dynamics::spatial::ChainData::new(arm);
    let mut found: Vec<(Vec<f64>, study::Branch)> = Vec::new();
    for q in study::ik_search(arm, &g, 200, None, 21) {
        let wrap = |a: f64| (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
        let same = |p: &Vec<f64>| {
            p.iter()
                .zip(&q)
                .all(|(a, b)| (wrap(*a) - wrap(*b)).abs() < 1e-6)
        };
        if !found.iter().any(|(p, _)| same(p)) {
            let b = study::ur5_branch(arm, &q, &mut d);
            found.push((q, b));
        }
    }
    assert_eq!(found.len(), 8, "{found:?}");
    for (i, (_, a)) in found.iter().enumerate() {
        for (_, b) in &found[..i] {
            assert_ne!(a, b, "two solutions on one branch: {found:?}");
        }
    }
    let s6: Vec<_> = found
        .iter()
        .filter(|(_, b)| *b == study::Branch::S6)
        .collect();
    assert_eq!(s6.len(), 1);
    for (a, b) in s6[0].0.iter().zip(&setup.q_guess[..6]) {
        let da = (a - b).rem_euclid(std::f64::consts::TAU);
        assert!(da.min(std::f64::consts::TAU - da) < 1e-6, "{:?}", s6[0].0);
    }
}

#[test]
fn the_library_branch_search_finds_the_studys_eight_ur5_branches() {
    // `tandem ik`'s search (`plant::spatial::branches`) at the S6 start: the 8 solutions, one on
    // each of the study's geometric branches, the preset's own (from its q_guess, as the run
    // starts) on the S6 branch; all 8 carry the box the whole lap inside the UR5's limits.
    use tandem::plant::spatial::branches::{self, SearchOptions};
    let setup = tandem::presets::dual_ur5();
    let plant = SpatialPlant::new(&setup.params).expect("valid");
    let path = Se3Path::spec_s6();
    let x0 = study::s6_pose(&path, 0.0);
    let pose = |t: f64| study::s6_pose(&path, t);
    let opts = SearchOptions {
        starts: 200,
        seed: 0,
        times: (0..=120).map(|k| 0.5 * k as f64).collect(),
        sigma_floor: 1e-3,
    };
    for i in 0..2 {
        let s = plant.offset(i);
        let arm = &plant.arms()[i];
        let sol = branches::arm_solutions(&plant, i, &x0, &pose, &setup.q_guess[s..s + 6], &opts);
        assert_eq!(sol.solutions.len(), 8, "arm {i}");
        assert!(!sol.redundant);
        let mut d = tandem::dynamics::spatial::ChainData::new(arm);
        let kinds: Vec<study::Branch> = sol
            .solutions
            .iter()
            .map(|x| study::ur5_branch(arm, &x.q, &mut d))
            .collect();
        for (k, a) in kinds.iter().enumerate() {
            for b in &kinds[..k] {
                assert_ne!(a, b, "arm {i}: two solutions on one branch");
            }
        }
        let own = sol.own.expect("the preset's q_guess solves");
        assert_eq!(kinds[own], study::Branch::S6, "arm {i}");
        // The preset's start angles, to the 6 decimals S6 prints.
        for (a, b) in sol.solutions[own].q.iter().zip(&setup.q_guess[s..s + 6]) {
            assert!((a - b).abs() < 1e-6, "arm {i}: {a} vs {b}");
        }
        // Its lap: the study's figures (σ_min 0.1961, τ/effort 23.6 %).
        let p = &sol.solutions[own].path;
        assert!(p.feasible(), "{:?}", p.failure);
        assert_eq!(p.samples, 121);
        assert!((p.sigma_min - 0.1961).abs() < 1e-3, "σ_min {}", p.sigma_min);
        assert!(
            (0.23..=0.25).contains(&p.torque_ratio),
            "{}",
            p.torque_ratio
        );
    }
}

#[test]
fn the_placement_scan_moves_two_bases_along_their_line_and_more_radially() {
    use tandem::plant::spatial::placement::{base_spread, spread_to};
    // Two arms: the separation, about the midpoint, orientations kept (the study's set-up).
    let p = tandem::presets::dual_ur5().params;
    assert!((base_spread(&p).expect("two arms") - 1.40).abs() < 1e-12);
    let q = spread_to(&p, 1.0).expect("spread");
    let study = study::dual_ur5_at(1.0);
    for i in 0..2 {
        let (a, b) = (&q.arms[i].base, &study.arms[i].base);
        assert!((a.translation.vector - b.translation.vector).norm() < 1e-12);
        assert!(a.rotation.angle_to(&b.rotation) < 1e-12);
    }
    // Three arms: radially about the centroid, the mean distance from it is the spread.
    let mut three = p.clone();
    let mut arm3 = tandem::presets::ur5_arm(0.0, -0.9, std::f64::consts::FRAC_PI_2);
    arm3.base.translation.vector.z = 0.3;
    three.arms.push(arm3);
    three.grasps.push(three.grasps[0]);
    let d0 = base_spread(&three).expect("three arms");
    let c = |p: &tandem::plant::spatial::SpatialPlantParams| {
        p.arms
            .iter()
            .map(|a| a.base.translation.vector)
            .sum::<Vector3<f64>>()
            / 3.0
    };
    let s = spread_to(&three, 2.0 * d0).expect("spread");
    assert!((base_spread(&s).expect("three") - 2.0 * d0).abs() < 1e-12);
    assert!((c(&s) - c(&three)).norm() < 1e-12);
    for (a, b) in s.arms.iter().zip(&three.arms) {
        let (x, y) = (
            a.base.translation.vector - c(&s),
            b.base.translation.vector - c(&three),
        );
        assert!((x - 2.0 * y).norm() < 1e-12);
    }
    // One arm: no separation.
    let mut one = p.clone();
    one.arms.truncate(1);
    one.grasps.truncate(1);
    assert!(base_spread(&one).is_none());
    assert!(spread_to(&one, 1.0).is_err());
}
