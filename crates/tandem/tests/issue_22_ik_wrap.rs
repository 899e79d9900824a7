//! Issue 22, "the first hour with your own arm": a revolute joint whose inverse kinematics comes
//! out a whole turn outside its limits (a Kinova Jaco2's `[0.8203, 5.4629]` rad and an IK answer
//! of −2.3597) is the same pose inside them, so the start state wraps it by 2π instead of
//! refusing the arm.

use std::f64::consts::TAU;

use tandem::nalgebra::Vector6;
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;

/// The joint angles the start pose of the dual-UR5 preset needs, with the preset's limits.
fn start_q() -> (presets::SpatialSetup, Vec<f64>) {
    let s = presets::dual_ur5();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y = plant
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap();
    let q = y[..plant.n_q()].to_vec();
    (s, q)
}

#[test]
fn a_revolute_angle_a_turn_outside_its_limits_is_wrapped_into_them() {
    let (mut s, q) = start_q();
    // Arm 1's base joint (index 0 of arm 0) gets a range a turn above the angle the start needs,
    // as the Jaco's [0.82, 5.46] is above −2.36: the IK still lands near the guess, below it.
    let k = 0;
    let (lo, hi) = (q[k] + TAU - 0.5, q[k] + TAU + 0.5);
    let j = &mut s.params.arms[0].chain.joints[k];
    j.limits.lower = lo;
    j.limits.upper = hi;
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y = plant
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .expect("the wrapped angle is inside the limits");
    assert!(y[k] >= lo && y[k] <= hi, "q = {} not in [{lo}, {hi}]", y[k]);
    assert!(
        (y[k] - (q[k] + TAU)).abs() < 1e-9,
        "{} vs {}",
        y[k],
        q[k] + TAU
    );
    // Every other joint is untouched, bit for bit.
    for i in 1..plant.n_q() {
        assert_eq!(y[i].to_bits(), q[i].to_bits(), "joint {i}");
    }
    // And the pose is the same: the closed chain is closed at the start.
    let mut ws = plant.workspace();
    let (dm, dr) = plant.constraint_residual(&y, &mut ws);
    assert!(dm < 1e-9 && dr < 1e-9, "{dm} m, {dr} rad");
}

#[test]
fn a_range_that_no_turn_reaches_is_still_refused_naming_the_joint() {
    let (mut s, q) = start_q();
    let k = 1;
    // A 1 rad window that starts 0.5 rad above the needed angle: no whole turn lands inside.
    let j = &mut s.params.arms[0].chain.joints[k];
    j.limits.lower = q[k] + 0.5;
    j.limits.upper = q[k] + 1.5;
    let name = j.name.clone();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let e = plant
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&format!("arms[0].joint {name}")), "{e}");
    assert!(e.contains("outside its limits"), "{e}");
}

#[test]
fn wrap_into_limits_is_the_identity_inside_and_picks_the_turn_nearest_the_guess() {
    let (s, _) = start_q();
    let mut j = s.params.arms[0].chain.joints[0].clone();
    j.limits.lower = -7.0;
    j.limits.upper = 7.0;
    // Inside: the same bits, whatever the guess.
    for q in [-7.0, -0.0, 0.0, 1e-300, 3.25, 7.0] {
        assert_eq!(
            j.wrap_into_limits(q, 100.0).unwrap().to_bits(),
            f64::to_bits(q)
        );
    }
    // 8 is outside; 8 − 2π = 1.717 is the only turn inside (8 − 4π = −4.57 too): the guess picks.
    let a = j.wrap_into_limits(8.0, 2.0).unwrap();
    assert!((a - (8.0 - TAU)).abs() < 1e-15, "{a}");
    let b = j.wrap_into_limits(8.0, -5.0).unwrap();
    assert!((b - (8.0 - 2.0 * TAU)).abs() < 1e-15, "{b}");
    // The Jaco case.
    j.limits.lower = 0.8203;
    j.limits.upper = 5.4629;
    let c = j.wrap_into_limits(-2.3597, 0.0).unwrap();
    assert!((c - (-2.3597 + TAU)).abs() < 1e-15, "{c}");
    // No turn fits; non-finite; prismatic joints never wrap.
    j.limits.lower = 0.0;
    j.limits.upper = 0.1;
    assert_eq!(j.wrap_into_limits(3.0, 0.0), None);
    assert_eq!(j.wrap_into_limits(f64::NAN, 0.0), None);
    assert_eq!(j.wrap_into_limits(f64::INFINITY, 0.0), None);
    j.kind = tandem::model::spatial::chain::JointKind::Prismatic;
    assert_eq!(j.wrap_into_limits(0.1 + TAU, 0.0), None);
}
