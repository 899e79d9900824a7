//! A counting global allocator proves that the per-arm rigid-body algorithms allocate nothing
//! after `ChainData::new` (STYLE habit 5; Pinocchio's test_crba_malloc).

use nalgebra::{DMatrix, Isometry3, Matrix3, Translation3, Unit, UnitQuaternion, Vector3, Vector6};
use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::model::spatial::{Chain, ChainJoint, JointKind, JointLimits, RigidBody, SpatialArm};

#[path = "support/counting.rs"]
mod counting;
use counting::count;

#[global_allocator]
static A: counting::Counting = counting::Counting;

#[test]
fn the_counter_counts() {
    let n = count(|| {
        let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
        drop(v);
    });
    assert_eq!(n, 1);
}

/// A 7-joint chain with oblique axes, one prismatic joint and a base away from the origin.
fn arm() -> SpatialArm {
    let mut joints = Vec::new();
    let mut bodies = Vec::new();
    for k in 0..7 {
        let kind = if k == 3 {
            JointKind::Prismatic
        } else {
            JointKind::Revolute
        };
        joints.push(ChainJoint {
            name: format!("j{k}"),
            kind,
            placement: Isometry3::from_parts(
                Translation3::new(0.05 * k as f64, -0.02, 0.15),
                UnitQuaternion::from_euler_angles(0.3 * k as f64, -0.2, 0.1),
            ),
            axis: Unit::new_normalize(Vector3::new(0.1, (k as f64).sin(), 1.0)),
            limits: JointLimits::UNLIMITED,
            damping: 0.0,
        });
        bodies.push(RigidBody {
            name: format!("l{k}"),
            mass: 1.0 + 0.3 * k as f64,
            com: Vector3::new(0.01, 0.02 * k as f64, 0.05),
            inertia: Matrix3::new(0.02, 0.001, 0.0, 0.001, 0.03, 0.002, 0.0, 0.002, 0.025),
        });
    }
    let chain = Chain {
        name: "alloc".to_string(),
        base_link: "base".to_string(),
        tool_link: "tool".to_string(),
        joints,
        bodies,
        tool: Isometry3::translation(0.0, 0.0, 0.1),
    };
    chain.validate().unwrap();
    SpatialArm {
        chain,
        base: Isometry3::from_parts(
            Translation3::new(-0.7, 0.1, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 3.0),
        ),
    }
}

#[test]
fn rigid_body_algorithms_allocate_nothing() {
    let arm = arm();
    let n = arm.chain.dof();
    let mut d = ChainData::new(&arm);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let f_t = Vector6::new(1.0, -2.0, 3.0, 0.1, 0.2, -0.3);
    let mut q = vec![0.3; n];
    let qd = vec![-0.5; n];
    let qdd = vec![0.7; n];
    let mut tau = vec![0.0; n];
    let mut out = vec![0.0; n];
    let mut c = DMatrix::zeros(n, n);
    let mut run = |q: &[f64], d: &mut ChainData| {
        spatial::kinematics(&arm, q, None, d);
        spatial::kinematics(&arm, q, Some(&qd), d);
        spatial::crba(&arm, q, d);
        spatial::rnea(&arm, q, &qd, &qdd, &g, None, &mut tau, d);
        spatial::rnea(&arm, q, &qd, &qdd, &g, Some(&f_t), &mut tau, d);
        spatial::aba(&arm, q, &qd, &tau, &g, Some(&f_t), &mut out, d);
        spatial::forward_dynamics(&arm, q, &qd, &tau, &g, Some(&f_t), &mut out, d);
        spatial::terms(&arm, q, &qd, &g, d);
        spatial::coriolis_matrix(&arm, q, &qd, &mut c, d);
        spatial::gravity(&arm, q, &g, &mut out, d);
        std::hint::black_box(spatial::energy(&arm, q, &qd, &g, d));
    };
    run(&q, &mut d); // warm-up
    let allocs = count(|| {
        for k in 0..100 {
            q[k % n] += 0.01;
            run(&q, &mut d);
        }
    });
    assert_eq!(allocs, 0, "dynamics allocated {allocs} times in 100 rounds");
    assert!(d.M.iter().all(|v| v.is_finite()));
}
