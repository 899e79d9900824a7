//! Arm kinematics and dynamics against independent references: the 2-link closed forms and the
//! fixed-size 2-link fast path against the general algorithm, finite differences, RNEA against
//! `Mq̈ + Cq̇ + G`, Property 1.

use nalgebra::{DMatrix, Matrix2, Vector2};
use proptest::prelude::*;
use tandem::dynamics::planar::{Arm, FixedArm};
use tandem::error::ModelError;
use tandem::model::planar::arm::{ArmParams, Elbow, LinkParams};

use tandem::math::random::SplitMix64 as Rng;

fn paper_arm() -> Arm {
    Arm::new("arm", &ArmParams::paper([-0.38, 0.0], Elbow::Negative)).unwrap()
}

fn random_arm(rng: &mut Rng, n: usize) -> Arm {
    Arm::new("arm", &random_params(rng, n)).unwrap()
}

fn random_params(rng: &mut Rng, n: usize) -> ArmParams {
    let links = (0..n)
        .map(|_| {
            let l = rng.range(0.1, 0.5);
            LinkParams {
                mass: rng.range(0.3, 3.0),
                length: l,
                com: rng.range(0.0, l),
                inertia: rng.range(0.0, 0.1),
            }
        })
        .collect();
    ArmParams {
        base: [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)],
        base_angle: rng.range(-1.0, 1.0),
        links,
        elbow: Elbow::Positive,
    }
}

fn rel_err(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm().max(1e-300)
}

#[test]
fn two_link_closed_forms_equal_general_algorithm() {
    // Same physics by two routes; only round-off separates them (entries are O(0.1..10), sums of
    // a handful of products): 1e-12 relative leaves ~4 decimal digits of slack over ε·cond.
    let mut rng = Rng(1);
    for trial in 0..200 {
        let arm = if trial % 2 == 0 {
            paper_arm()
        } else {
            random_arm(&mut rng, 2)
        };
        let q = rng.vec(2, 3.0);
        let qd = rng.vec(2, 5.0);
        let mut fast = arm.terms();
        let mut general = arm.terms();
        arm.dynamics(&q, &qd, 9.8, &mut fast);
        arm.kinematics(&q, &qd, &mut general);
        arm.general_dynamics(9.8, &mut general);
        assert!(
            rel_err(&fast.M, &general.M) < 1e-12,
            "M: {} vs {}",
            fast.M,
            general.M
        );
        assert!(
            rel_err(&fast.C, &general.C) < 1e-12,
            "C: {} vs {}",
            fast.C,
            general.C
        );
        let ge = (&fast.G - &general.G).norm() / general.G.norm().max(1e-12);
        assert!(ge < 1e-12, "G: {} vs {}", fast.G, general.G);
    }
}

/// `‖a − b‖ / ‖b‖` for fixed-size values.
fn rel2<const R: usize, const C: usize>(
    a: &nalgebra::SMatrix<f64, R, C>,
    b: &nalgebra::SMatrix<f64, R, C>,
) -> f64 {
    (a - b).norm() / b.norm().max(1e-300)
}

fn mat2(a: &DMatrix<f64>) -> Matrix2<f64> {
    Matrix2::new(a[(0, 0)], a[(0, 1)], a[(1, 0)], a[(1, 1)])
}

#[test]
fn two_link_fixed_size_terms_equal_general_algorithm() {
    // The fast path (TwoLinkArm: one sin_cos per link, closed forms, fixed-size values) against
    // the general algorithm on ArmTerms (per-link points, composite-rigid-body M, Christoffel C):
    // the same physics by two routes, so only round-off separates them. Entries are sums of a
    // handful of products: 1e-12 of their scale leaves ~3 digits of slack over ε.
    let mut rng = Rng(21);
    let mut worst: f64 = 0.0;
    for trial in 0..500 {
        let arm = if trial % 2 == 0 {
            paper_arm()
        } else {
            random_arm(&mut rng, 2)
        };
        let k = arm.two_link().expect("a 2-link arm has the fast path");
        let q = rng.vec(2, 3.0);
        let qd = rng.vec(2, 5.0);
        let mut t = arm.terms();
        arm.kinematics(&q, &qd, &mut t);
        arm.general_dynamics(9.8, &mut t);
        let f = k.terms(&k.pose([q[0], q[1]]), [qd[0], qd[1]], 9.8);
        // Relative to each quantity's natural scale (M, M|q̇|, reach, reach|q̇|, reach|q̇|²,
        // m g reach), so that a small entry made of cancelling O(scale) terms (C when
        // sin q2 ≈ 0) is judged by the round-off of those terms.
        let reach = arm.reach();
        let w = qd[0].abs() + qd[1].abs();
        let m_scale = mat2(&t.M).norm();
        let rel = |e: f64, b: f64, s: f64| e / (b + s);
        let jd_g = Matrix2::new(
            t.Jdot[(0, 0)],
            t.Jdot[(0, 1)],
            t.Jdot[(1, 0)],
            t.Jdot[(1, 1)],
        );
        let j_g = Matrix2::new(t.J[(0, 0)], t.J[(0, 1)], t.J[(1, 0)], t.J[(1, 1)]);
        let g_g = Vector2::new(t.G[0], t.G[1]);
        let errs = [
            rel((f.M - mat2(&t.M)).norm(), m_scale, 0.0),
            rel((f.C - mat2(&t.C)).norm(), mat2(&t.C).norm(), m_scale * w),
            rel((f.G - g_g).norm(), g_g.norm(), 9.8 * m_scale / reach),
            rel((f.J - j_g).norm(), j_g.norm(), reach),
            rel((f.Jdot - jd_g).norm(), jd_g.norm(), reach * w),
            rel(
                (f.jdot_qdot - t.jdot_qdot).norm(),
                t.jdot_qdot.norm(),
                reach * w * w,
            ),
            rel((f.p_ee - t.p_ee).norm(), t.p_ee.norm(), reach),
            rel((f.v_ee - t.v_ee).norm(), t.v_ee.norm(), reach * w),
        ];
        for (name, e) in ["M", "C", "G", "J", "Jdot", "jdot_qdot", "p_ee", "v_ee"]
            .iter()
            .zip(errs)
        {
            assert!(
                e < 1e-12,
                "trial {trial}: {name} differs by {e:e} (relative)"
            );
            worst = worst.max(e);
        }
        // det M in closed form is cancellation-free; from the entries it carries an absolute
        // round-off of a few ε·M11·M22.
        let m = &f.M;
        assert!(
            (f.det_M - m.determinant()).abs() < 1e-14 * m[(0, 0)] * m[(1, 1)],
            "det M {} vs {}",
            f.det_M,
            m.determinant()
        );
        // M⁻¹ in closed form: ‖M⁻¹M − I‖ ≲ ε·cond(M).
        let cond = m.norm() * m.try_inverse().unwrap().norm();
        assert!((f.m_inv() * m - Matrix2::identity()).norm() < 1e-14 * cond);
    }
    println!("fixed-size 2-link terms vs general algorithm: worst relative difference {worst:.2e}");
    // Other link counts have no fast path.
    let mut r = Rng(2);
    assert!(random_arm(&mut r, 3).two_link().is_none());
    assert!(random_arm(&mut r, 1).two_link().is_none());
}

#[test]
fn two_link_fixed_size_cartesian_terms_equal_the_arm_terms_route() {
    // Away from the stretched/folded singularities (|q2| in [0.3, 2.8], cond J_e ≲ 10), the
    // Cartesian terms (3)–(4) from the fixed-size terms equal Arm::cartesian on ArmTerms.
    let mut rng = Rng(23);
    for trial in 0..200 {
        let arm = if trial % 2 == 0 {
            paper_arm()
        } else {
            random_arm(&mut rng, 2)
        };
        let k = arm.two_link().unwrap();
        let sign = if trial % 4 < 2 { 1.0 } else { -1.0 };
        let q = vec![rng.range(-3.0, 3.0), sign * rng.range(0.3, 2.8)];
        let qd = rng.vec(2, 3.0);
        let mut t = arm.terms();
        arm.dynamics(&q, &qd, 9.8, &mut t);
        let a = arm.cartesian(&t, 1e-9).unwrap();
        let b = k
            .terms(&k.pose([q[0], q[1]]), [qd[0], qd[1]], 9.8)
            .cartesian(1e-9)
            .unwrap();
        for (name, e) in [
            ("M_x", rel2(&b.M_x, &a.M_x)),
            ("C_x", rel2(&b.C_x, &a.C_x)),
            ("G_x", rel2(&b.G_x, &a.G_x)),
            ("J_inv", rel2(&b.J_inv, &a.J_inv)),
        ] {
            assert!(
                e < 1e-12,
                "trial {trial}: {name} differs by {e:e} (relative)"
            );
        }
    }
}

#[test]
fn transcendental_free_ik_equals_the_angle_route() {
    // TwoLinkArm::ik_pose (sin q2 = ±√((1−c2)(1+c2)), u(q1) by rotating the target back; one
    // sqrt) against the angles of inverse_kinematics (acos, two atan2) fed to pose (two
    // sin_cos). Targets stay 2 % of the reach inside the annulus, where |sin q2| ≳ 0.2 and the
    // angle route's acos loses at most ~ε/|sin q2| (the two agree to ~1e-15 there).
    let mut rng = Rng(29);
    for trial in 0..400 {
        let elbow = if trial % 2 == 0 {
            Elbow::Negative
        } else {
            Elbow::Positive
        };
        let mut p = if trial % 4 < 2 {
            ArmParams::paper([0.1, -0.2], elbow)
        } else {
            let l1 = rng.range(0.1, 0.5);
            let l2 = rng.range(0.1, 0.5);
            let mut p = ArmParams::paper([rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)], elbow);
            p.links[0].length = l1;
            p.links[0].com = l1 / 2.0;
            p.links[1].length = l2;
            p.links[1].com = l2 / 2.0;
            p
        };
        p.base_angle = rng.range(-3.0, 3.0);
        let arm = Arm::new("arm", &p).unwrap();
        let k = arm.two_link().unwrap();
        let (l1, l2) = (p.links[0].length, p.links[1].length);
        let margin = 0.02 * (l1 + l2);
        let r = rng.range((l1 - l2).abs() + margin, l1 + l2 - margin);
        let a = rng.range(-3.1, 3.1);
        let target = arm.base() + r * Vector2::new(a.cos(), a.sin());
        let fast = k.ik_pose(target).unwrap();
        let q = arm.inverse_kinematics(target).unwrap();
        let slow = k.pose(q);
        let e = (fast.u1 - slow.u1)
            .norm()
            .max((fast.u12 - slow.u12).norm())
            .max((fast.c2 - slow.c2).abs())
            .max((fast.s2 - slow.s2).abs())
            .max(rel2(&fast.J, &slow.J));
        assert!(e < 1e-12, "trial {trial}: ik_pose differs by {e:e}");
        // It reaches the target, on the branch, with unit directions.
        let reach = arm.base() + l1 * fast.u1 + l2 * fast.u12;
        assert!(
            (reach - target).norm() < 1e-13,
            "misses by {}",
            (reach - target).norm()
        );
        assert!(fast.s2 * q[1] >= 0.0);
        assert!((fast.u1.norm() - 1.0).abs() < 1e-15 && (fast.u12.norm() - 1.0).abs() < 1e-15);
    }
    // Out of reach: the same error as the angle route.
    let arm = paper_arm();
    let far = arm.base() + Vector2::new(0.61, 0.0);
    assert_eq!(
        arm.two_link().unwrap().ik_pose(far).unwrap_err(),
        arm.inverse_kinematics(far).unwrap_err()
    );
}

#[test]
fn two_link_closed_forms_match_hand_values() {
    // Table I, lc = l/2: p1 = 2·0.15² + 0.85(0.3² + 0.15²) + 0.045 + 0.019 = 0.2046250,
    // p2 = 0.85·0.3·0.15 = 0.03825, p3 = 0.85·0.15² + 0.019 = 0.0381250.
    let arm = paper_arm();
    let mut t = arm.terms();
    arm.dynamics(&[0.0, 0.0], &[0.0, 0.0], 9.8, &mut t);
    assert!((t.M[(0, 0)] - (0.204625 + 2.0 * 0.03825)).abs() < 1e-15);
    assert!((t.M[(0, 1)] - (0.038125 + 0.03825)).abs() < 1e-15);
    assert!((t.M[(1, 1)] - 0.038125).abs() < 1e-15);
    // G at q = 0: G1 = (2·0.15 + 0.85·0.3)·9.8 + 0.85·0.15·9.8, G2 = 0.85·0.15·9.8.
    assert!((t.G[0] - (0.555 * 9.8 + 0.1275 * 9.8)).abs() < 1e-13);
    assert!((t.G[1] - 0.1275 * 9.8).abs() < 1e-14);
}

/// `Ṁ` by a central difference along `q̇`; its truncation error is O(h²·|M'''|) ≈ 1e-10 at
/// h = 1e-5 with O(1) derivatives, round-off O(ε|M|/h) ≈ 1e-11.
fn mdot_fd(arm: &Arm, q: &[f64], qd: &[f64]) -> DMatrix<f64> {
    let h = 1e-5;
    let mut t = arm.terms();
    let qp: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a + h * b).collect();
    let qm: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a - h * b).collect();
    arm.dynamics(&qp, qd, 9.8, &mut t);
    let mp = t.M.clone();
    arm.dynamics(&qm, qd, 9.8, &mut t);
    (mp - &t.M) / (2.0 * h)
}

#[test]
fn mdot_minus_2c_is_skew_for_2_to_5_links() {
    let mut rng = Rng(7);
    for n in 2..=5 {
        for _ in 0..20 {
            let arm = random_arm(&mut rng, n);
            let q = rng.vec(n, 3.0);
            let qd = rng.vec(n, 3.0);
            let mut t = arm.terms();
            arm.dynamics(&q, &qd, 9.8, &mut t);
            let nmat = mdot_fd(&arm, &q, &qd) - 2.0 * &t.C;
            let sym = &nmat + nmat.transpose();
            assert!(
                sym.norm() < 1e-8 * (1.0 + nmat.norm()),
                "n = {n}: N + Nᵀ = {sym}"
            );
            // And M is symmetric positive definite.
            assert!((&t.M - t.M.transpose()).norm() < 1e-14);
            assert!(t.M.clone().cholesky().is_some());
        }
    }
}

#[test]
fn jacobian_and_jdot_qdot_equal_finite_differences() {
    let mut rng = Rng(11);
    let h = 1e-6;
    for n in 1..=4 {
        for _ in 0..20 {
            let arm = random_arm(&mut rng, n);
            let q = rng.vec(n, 3.0);
            let qd = rng.vec(n, 2.0);
            let mut t = arm.terms();
            arm.kinematics(&q, &qd, &mut t);
            for i in 0..n {
                let mut qp = q.clone();
                let mut qm = q.clone();
                qp[i] += h;
                qm[i] -= h;
                let col = (arm.forward_kinematics(&qp) - arm.forward_kinematics(&qm)) / (2.0 * h);
                // Central difference: error O(h²·reach) ≈ 1e-12, round-off ≈ ε/h ≈ 1e-10.
                assert!((col - t.J.column(i)).norm() < 1e-8, "J col {i}");
            }
            // J̇q̇ = d/dt (J(q(t)) q̇) at fixed q̇.
            let qp: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + h * b).collect();
            let qm: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a - h * b).collect();
            let mut tp = arm.terms();
            let mut tm = arm.terms();
            arm.kinematics(&qp, &qd, &mut tp);
            arm.kinematics(&qm, &qd, &mut tm);
            let qdv = nalgebra::DVector::from_column_slice(&qd);
            let fd = (&tp.J * &qdv - &tm.J * &qdv) / (2.0 * h);
            assert!(
                (fd - nalgebra::DVector::from_column_slice(t.jdot_qdot.as_slice())).norm() < 1e-7
            );
            let jd_fd = (&tp.J - &tm.J) / (2.0 * h);
            assert!((jd_fd - &t.Jdot).norm() < 1e-7);
            assert!(
                (&t.Jdot * &qdv - nalgebra::DVector::from_column_slice(t.jdot_qdot.as_slice()))
                    .norm()
                    < 1e-12
            );
            // End-effector velocity is J q̇.
            assert!(
                ((&t.J * &qdv) - nalgebra::DVector::from_column_slice(t.v_ee.as_slice())).norm()
                    < 1e-13
            );
        }
    }
}

#[test]
fn rnea_equals_lagrangian_and_inverts_forward_dynamics() {
    let mut rng = Rng(3);
    for n in 1..=5 {
        for _ in 0..20 {
            let arm = random_arm(&mut rng, n);
            let q = rng.vec(n, 3.0);
            let qd = rng.vec(n, 3.0);
            let qdd = rng.vec(n, 10.0);
            let f = Vector2::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
            let mut t = arm.terms();
            let mut tau = vec![0.0; n];
            arm.rnea(&q, &qd, &qdd, f, 9.8, &mut t, &mut tau);
            arm.dynamics(&q, &qd, 9.8, &mut t);
            let qdv = nalgebra::DVector::from_column_slice(&qd);
            let qddv = nalgebra::DVector::from_column_slice(&qdd);
            let lag = &t.M * &qddv + &t.C * &qdv + &t.G - t.J.transpose() * f;
            let tv = nalgebra::DVector::from_column_slice(&tau);
            assert!(
                (&tv - &lag).norm() < 1e-11 * (1.0 + lag.norm()),
                "n={n}: {tv} vs {lag}"
            );
            // Forward dynamics with τ from RNEA returns q̈ (conditioning of M: ≤ 1e3 here).
            let mut back = vec![0.0; n];
            arm.forward_dynamics(&qd, &tau, f, &mut t, &mut back)
                .unwrap();
            for k in 0..n {
                assert!(
                    (back[k] - qdd[k]).abs() < 1e-9 * (1.0 + qdd[k].abs()),
                    "n={n} joint {k}: {} vs {}",
                    back[k],
                    qdd[k]
                );
            }
        }
    }
}

#[test]
fn cartesian_dynamics_reproduce_joint_accelerations() {
    let mut rng = Rng(5);
    let arm = paper_arm();
    let mut t = arm.terms();
    for _ in 0..100 {
        // Stay away from the singular stretched/folded poses.
        let q = vec![rng.range(-3.0, 3.0), -rng.range(0.3, 2.8)];
        let qd = rng.vec(2, 3.0);
        let tau = rng.vec(2, 5.0);
        let f = Vector2::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
        arm.dynamics(&q, &qd, 9.8, &mut t);
        let mut qdd = vec![0.0; 2];
        arm.forward_dynamics(&qd, &tau, f, &mut t, &mut qdd)
            .unwrap();
        let c = arm.cartesian(&t, 1e-9).unwrap();
        let xdd = Vector2::new(
            t.J[(0, 0)] * qdd[0] + t.J[(0, 1)] * qdd[1],
            t.J[(1, 0)] * qdd[0] + t.J[(1, 1)] * qdd[1],
        ) + t.jdot_qdot;
        let tau_x = c.J_inv.transpose() * Vector2::new(tau[0], tau[1]);
        // (3): M_x ẍ + C_x ẋ + G_x = τ_x + F.
        let r = c.M_x * xdd + c.C_x * t.v_ee + c.G_x - tau_x - f;
        assert!(
            r.norm() < 1e-9 * (1.0 + tau_x.norm() + f.norm()),
            "residual {r}"
        );
    }
}

#[test]
fn analytic_ik_inverts_forward_kinematics_on_its_branch() {
    let mut rng = Rng(9);
    for elbow in [Elbow::Negative, Elbow::Positive] {
        let arm = Arm::new("arm", &ArmParams::paper([0.1, -0.2], elbow)).unwrap();
        for _ in 0..100 {
            let r = rng.range(0.05, 0.59);
            let a = rng.range(-3.1, 3.1);
            let p = arm.base() + r * Vector2::new(a.cos(), a.sin());
            let q = arm.inverse_kinematics(p).unwrap();
            assert!((arm.forward_kinematics(&q) - p).norm() < 1e-13);
            assert!(match elbow {
                Elbow::Negative => q[1] <= 0.0,
                Elbow::Positive => q[1] >= 0.0,
            });
        }
        assert!(
            arm.inverse_kinematics(arm.base() + Vector2::new(0.61, 0.0))
                .is_err()
        );
    }
}

#[test]
fn bad_link_parameters_name_the_arm_link_and_field() {
    let mut p = ArmParams::paper([0.0, 0.0], Elbow::Positive);
    p.links[1].mass = -1.0;
    let e = Arm::new("arms[1]", &p).unwrap_err();
    assert!(
        matches!(&e, ModelError::Invalid { param, .. } if param == "arms[1].links[1].mass"),
        "{e}"
    );
    let mut p = ArmParams::paper([0.0, 0.0], Elbow::Positive);
    p.links[0].length = 0.0;
    let e = Arm::new("arms[0]", &p).unwrap_err();
    assert!(e.to_string().contains("arms[0].links[0].length"), "{e}");
    let mut p = ArmParams::paper([0.0, 0.0], Elbow::Positive);
    p.links[0].inertia = -0.1;
    assert!(
        Arm::new("a", &p)
            .unwrap_err()
            .to_string()
            .contains("inertia")
    );
    let mut p = ArmParams::paper([0.0, 0.0], Elbow::Positive);
    p.links[0].com = 0.5;
    assert!(Arm::new("a", &p).unwrap_err().to_string().contains("com"));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(42), ..ProptestConfig::default() })]
    #[test]
    fn christoffel_c_gives_skew_mdot_minus_2c(q1 in -3.0..3.0f64, q2 in -3.0..3.0f64, w1 in -4.0..4.0f64, w2 in -4.0..4.0f64) {
        let arm = paper_arm();
        let mut t = arm.terms();
        arm.dynamics(&[q1, q2], &[w1, w2], 9.8, &mut t);
        let n = mdot_fd(&arm, &[q1, q2], &[w1, w2]) - 2.0 * &t.C;
        prop_assert!((&n + n.transpose()).norm() < 1e-8);
    }
}

/// Every field of a [`FixedArm::state_block`] result as bits.
fn block_bits<const N: usize>(
    r: &(
        tandem::dynamics::planar::ArmBlock<N>,
        tandem::dynamics::planar::ArmSolve<N>,
    ),
) -> Vec<u64> {
    let (b, s) = r;
    [
        b.a0.as_slice(),
        b.y.as_slice(),
        b.k.as_slice(),
        b.j.as_slice(),
        b.p_ee.as_slice(),
        b.v_ee.as_slice(),
        b.jdot_qdot.as_slice(),
        s.m.as_slice(),
        s.inv_diag.as_slice(),
        s.bias.as_slice(),
        s.g.as_slice(),
    ]
    .concat()
    .iter()
    .map(|x| x.to_bits())
    .collect()
}

#[test]
fn two_link_state_block_pair_is_two_state_blocks_bit_for_bit() {
    // TwoLinkArm's FixedArm::state_block_pair (the two arms in the two lanes of SSE2 registers
    // on x86-64) against state_block of each arm: the same operations per lane, so the same
    // bits in every field, on random arm pairs and states (angles beyond sin_cos's polynomial
    // range and zero rates included).
    let mut rng = Rng(909);
    for trial in 0..500 {
        let (a, b) = if trial % 3 == 0 {
            (paper_arm(), random_arm(&mut rng, 2))
        } else {
            (random_arm(&mut rng, 2), random_arm(&mut rng, 2))
        };
        let (ka, kb) = (a.two_link().unwrap(), b.two_link().unwrap());
        let mut q: [[f64; 2]; 2] =
            std::array::from_fn(|_| [rng.range(-4.0, 4.0), rng.range(-4.0, 4.0)]);
        let mut qd: [[f64; 2]; 2] =
            std::array::from_fn(|_| [rng.range(-6.0, 6.0), rng.range(-6.0, 6.0)]);
        match trial % 7 {
            1 => q[1][0] += 2e5,
            2 => qd[0] = [0.0, 0.0],
            3 => qd[1][1] = -qd[1][0],
            _ => {}
        }
        let g = if trial % 5 == 0 { 0.0 } else { 9.81 };
        let pair = FixedArm::state_block_pair([ka, kb], q, qd, g).expect("positive definite");
        let one = ka.state_block(q[0], qd[0], g).unwrap();
        let two = kb.state_block(q[1], qd[1], g).unwrap();
        assert_eq!(
            block_bits(&pair[0]),
            block_bits(&one),
            "trial {trial}, first arm"
        );
        assert_eq!(
            block_bits(&pair[1]),
            block_bits(&two),
            "trial {trial}, second arm"
        );
    }
}

#[test]
fn fixed_link_state_block_pair_is_two_state_blocks_bit_for_bit() {
    // FixedLinkArm<N>'s FixedArm::state_block_pair (N = 3: closed-form inverse; N = 4:
    // Cholesky; the two arms in SSE2 lanes on x86-64) against state_block of each arm: the
    // same bits in every field, on random arm pairs and states, with edge cases: angles
    // beyond sin_cos's polynomial range and exact zeros (its library fallback), zero and
    // negative-zero rates, zero gravity, and a NaN angle in one arm (M not positive definite:
    // the pair is None exactly when either arm's block is).
    fn check<const N: usize>(rng: &mut Rng, trial: usize) -> bool {
        let (mut pa, mut pb) = (random_params(rng, N), random_params(rng, N));
        if trial % 11 == 7 {
            (pa.base_angle, pb.base_angle) = (0.0, 0.0);
        }
        let (a, b) = (Arm::new("a", &pa).unwrap(), Arm::new("b", &pb).unwrap());
        let (ka, kb) = (a.fixed::<N>().unwrap(), b.fixed::<N>().unwrap());
        let mut q: [[f64; N]; 2] =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.range(-4.0, 4.0)));
        let mut qd: [[f64; N]; 2] =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.range(-6.0, 6.0)));
        match trial % 11 {
            1 => q[1][N - 1] += 2e5,
            2 => qd[0] = [0.0; N],
            3 => qd[1] = [-0.0; N],
            4 => qd[1][1] = -qd[1][0],
            5 => q[0][N - 2] = f64::NAN,
            6 => q[1][0] = f64::NAN,
            7 => {
                // φ_1 = 0 exactly (sin_cos's ±0 fallback) in both arms.
                q[0][0] = 0.0;
                q[1][0] = -0.0;
            }
            8 => q[0] = [1e6; N],
            _ => {}
        }
        let g = if trial.is_multiple_of(5) { 0.0 } else { 9.81 };
        let pair = FixedArm::state_block_pair([&ka, &kb], q, qd, g);
        let one = ka.state_block(q[0], qd[0], g);
        let two = kb.state_block(q[1], qd[1], g);
        match (pair, one, two) {
            (Some(p), Some(one), Some(two)) => {
                assert_eq!(
                    block_bits(&p[0]),
                    block_bits(&one),
                    "trial {trial}, {N} links, first"
                );
                assert_eq!(
                    block_bits(&p[1]),
                    block_bits(&two),
                    "trial {trial}, {N} links, second"
                );
                false
            }
            (None, one, two) => {
                assert!(
                    one.is_none() || two.is_none(),
                    "trial {trial}, {N} links: None"
                );
                true
            }
            (Some(_), _, _) => panic!("trial {trial}, {N} links: Some, but an arm is None"),
        }
    }
    let mut rng = Rng(911);
    let mut nones = 0;
    for trial in 0..600 {
        nones += usize::from(check::<3>(&mut rng, trial));
        nones += usize::from(check::<4>(&mut rng, trial));
    }
    assert!(nones >= 2 * 2 * 50, "the None cases ran: {nones}");
}

#[test]
fn fixed_link_kernels_equal_the_general_algorithm() {
    // FixedLinkArm<N> (N = 3, 4) against Arm::dynamics + forward_dynamics on random arms and
    // states: a0 = M⁻¹(τ − Cq̇ − G) (forward dynamics with no external force), Y = M⁻¹ J_eᵀ
    // (forward dynamics with zero τ, q̇, g and a unit force, minus nothing), K = J_e Y, and the
    // end-effector terms. The kinematics and M, C, G are the same sums; only the solve
    // differs (reciprocal pivots; for N = 3 the closed-form inverse adj M / det M), each with
    // errors of order cond(M)·ε, so 1e-12 relative (cond M ≲ 1e3 here; measured 3.6e-14).
    fn check<const N: usize>(rng: &mut Rng) -> f64 {
        let arm = random_arm(rng, N);
        let k = arm.fixed::<N>().expect("N links");
        assert!(arm.fixed::<5>().is_none());
        let mut t = arm.terms();
        let q: [f64; N] = std::array::from_fn(|_| rng.range(-3.0, 3.0));
        let qd: [f64; N] = std::array::from_fn(|_| rng.range(-2.0, 2.0));
        let tau: [f64; N] = std::array::from_fn(|_| rng.range(-5.0, 5.0));
        let b = k.block(q, qd, tau, 9.8).expect("M is positive definite");
        arm.dynamics(&q, &qd, 9.8, &mut t);
        let mut a0 = [0.0; N];
        arm.forward_dynamics(&qd, &tau, Vector2::zeros(), &mut t, &mut a0)
            .unwrap();
        let rel = |a: &[f64], b: &[f64]| {
            let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
            let n: f64 = b.iter().map(|y| y * y).sum();
            (d / n.max(1e-300)).sqrt()
        };
        let mut worst = rel(b.a0.as_slice(), &a0);
        // Y's columns: M⁻¹ J_eᵀ e_c = forward dynamics of J_eᵀ e_c alone (zero C q̇ and G).
        let zeros = [0.0; N];
        for c in 0..2 {
            arm.dynamics(&q, &zeros, 0.0, &mut t);
            let f = if c == 0 { Vector2::x() } else { Vector2::y() };
            let mut yc = [0.0; N];
            arm.forward_dynamics(&zeros, &zeros, f, &mut t, &mut yc)
                .unwrap();
            worst = worst.max(rel(b.y.column(c).as_slice(), &yc));
        }
        arm.dynamics(&q, &qd, 9.8, &mut t);
        let kk = t.J.clone() * nalgebra::DMatrix::from_column_slice(N, 2, b.y.as_slice());
        worst = worst.max(rel(b.k.as_slice(), kk.as_slice()));
        worst = worst.max(rel(b.j.as_slice(), t.J.as_slice()));
        worst = worst.max(rel(b.p_ee.as_slice(), t.p_ee.as_slice()));
        worst = worst.max(rel(b.v_ee.as_slice(), t.v_ee.as_slice()));
        worst = worst.max(rel(b.jdot_qdot.as_slice(), t.jdot_qdot.as_slice()));
        worst
    }
    let mut rng = Rng(2027);
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        worst = worst.max(check::<3>(&mut rng)).max(check::<4>(&mut rng));
    }
    println!("FixedLinkArm vs general: worst relative difference {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn fixed_link_kinematics_and_gravity_are_the_arm_terms_bit_for_bit() {
    // FixedLinkArm::kinematics_gravity (the controller's per-tick route for 3 and 4 links)
    // against Arm::kinematics + Arm::general_dynamics on random arms and states: the same sums
    // in the same order, so the same bits (exact equality; Rust contracts no a·b + c into an
    // FMA, so nothing but the order could differ).
    fn check<const N: usize>(rng: &mut Rng) {
        let arm = random_arm(rng, N);
        let k = arm.fixed::<N>().expect("N links");
        let mut t = arm.terms();
        let q: [f64; N] = std::array::from_fn(|_| rng.range(-3.0, 3.0));
        let qd: [f64; N] = std::array::from_fn(|_| rng.range(-2.0, 2.0));
        let g = rng.range(0.0, 10.0);
        let f = k.kinematics_gravity(q, qd, g);
        arm.kinematics(&q, &qd, &mut t);
        arm.general_dynamics(g, &mut t);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(f.j.as_slice()), bits(t.J.as_slice()), "J_e, {N} links");
        assert_eq!(bits(f.p_ee.as_slice()), bits(t.p_ee.as_slice()), "p_ee");
        assert_eq!(bits(f.v_ee.as_slice()), bits(t.v_ee.as_slice()), "v_ee");
        assert_eq!(bits(f.gravity.as_slice()), bits(t.G.as_slice()), "G");
    }
    let mut rng = Rng(2031);
    for _ in 0..200 {
        check::<3>(&mut rng);
        check::<4>(&mut rng);
    }
}
