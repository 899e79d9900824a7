//! The friction-aware load distribution (`control::spatial::distribute::friction`, issue 25):
//! where a distribution inside the cones exists it is found, with the object wrench exact and
//! every pad inside its cone by the margin; where the weld-assuming share is already inside, it
//! is kept; where none exists, the tick falls back and is counted; the grip consistency of
//! opposing pads holds; and it is checked against a brute-force property test.

use nalgebra::{UnitQuaternion, Vector3, Vector6};
use proptest::prelude::*;
use tandem::control::spatial::distribute::Distribution;
use tandem::control::spatial::distribute::friction::{
    FrictionDistribution, FrictionParams, PadModel,
};

/// Two opposing pads across the tool's y axis, 3 cm along its z: a parallel-jaw gripper.
fn jaw() -> Vec<PadModel> {
    vec![
        PadModel {
            position: Vector3::new(0.0, 0.1, 0.03),
            normal: Vector3::new(0.0, -1.0, 0.0),
        },
        PadModel {
            position: Vector3::new(0.0, -0.1, 0.03),
            normal: Vector3::new(0.0, 1.0, 0.0),
        },
    ]
}

fn params(m: usize, mu: f64, torsion: f64, grip: f64, margin: f64) -> FrictionParams {
    FrictionParams {
        pads: vec![jaw(); m],
        mu,
        torsion,
        grip: vec![grip; m],
        margin,
    }
}

/// Scaled cone margin of pad force `(N, t1, t2, τ)`: `N − ‖(t/μ, τ/μ_τ)‖`.
fn margin(f: &[f64; 4], mu: f64, mt: f64) -> f64 {
    let tor = if mt > 0.0 { f[3] / mt } else { 0.0 };
    f[0] - ((f[1] / mu).powi(2) + (f[2] / mu).powi(2) + tor * tor).sqrt()
}

/// A weld-assuming share that the pads already carry inside their cones comes back unchanged:
/// the weight of a 3 kg box over two grippers (each pad 60 N, 7.35 N of friction).
#[test]
fn a_share_inside_the_cones_is_kept() {
    let p = params(2, 0.3, 0.002, 60.0, 2.0);
    let mut d = FrictionDistribution::new(&p, 0.2).unwrap();
    let r = [Vector3::new(-0.2, 0.0, 0.0), Vector3::new(0.2, 0.0, 0.0)];
    let rot = [UnitQuaternion::identity(); 2];
    let w0 = [Vector6::new(0.0, 0.0, 14.7, 0.0, 0.0, 0.0); 2];
    let mut w = w0;
    assert!(d.solve(0.0, &r, &rot, &mut w));
    for i in 0..2 {
        assert!((w[i] - w0[i]).norm() < 1e-9, "{:?} vs {:?}", w[i], w0[i]);
    }
    let mut f = [[0.0; 4]; 4];
    d.pad_forces(&mut f);
    for pf in &f {
        assert!((pf[0] - 60.0).abs() < 1e-9, "{f:?}");
        assert!((pf[1].abs() - 7.35).abs() < 1e-9, "{f:?}");
    }
    assert_eq!(d.stats.fallbacks, 0);
}

/// A moment about the jaw axis beyond the torsion the pads hold (0.002 m × 2 × 58 N = 0.23 N m)
/// is moved to the other gripper as a couple of vertical forces: the object wrench is the
/// same, every pad inside its cone by the margin.
#[test]
fn a_moment_the_torsion_cannot_hold_is_carried_as_a_couple() {
    let (mu, mt, grip, dm) = (0.3, 0.002, 60.0, 2.0);
    let p = params(2, mu, mt, grip, dm);
    let mut d = FrictionDistribution::new(&p, 0.2).unwrap();
    let r = [Vector3::new(-0.2, 0.0, 0.0), Vector3::new(0.2, 0.0, 0.0)];
    let rot = [UnitQuaternion::identity(); 2];
    // Each arm: its weight share and 1 N m about the jaw axis (world y), as a pitch command
    // shared by the minimum-norm rule would give.
    let w0 = [Vector6::new(0.0, 0.0, 14.7, 0.0, 1.0, 0.0); 2];
    let mut w = w0;
    assert!(d.solve(0.0, &r, &rot, &mut w));
    let before = Distribution::net(&r, &w0);
    let after = Distribution::net(&r, &w);
    assert!((before - after).norm() < 1e-9, "{before:?} vs {after:?}");
    let mut f = [[0.0; 4]; 4];
    d.pad_forces(&mut f);
    for pf in &f {
        assert!(margin(pf, mu, mt) >= 0.5 * dm, "{f:?}");
        assert!(pf[3].abs() <= mt * (pf[0] - 0.5 * dm) + 1e-9, "{f:?}");
    }
    // The 2 N m pitch is now mostly a vertical couple of the two grippers (measured 1.58 N m;
    // the torsion they keep, 0.42 N m, is inside 2 μ_τ (N − δ) = 0.23 N m per gripper).
    let couple = (w[0][2] - w[1][2]) * 0.2;
    println!("w = {w:?}; pitch by couple {couple} N m");
    assert!(couple > 1.5 && couple < 2.0 + 1e-9, "{couple}");
    // The opposing pads' normals sum to twice the grip.
    assert!((f[0][0] + f[1][0] - 2.0 * grip).abs() < 1e-6, "{f:?}");
}

/// No distribution exists (a 200 N pull on a 72 N grasp): the tick falls back, is counted with
/// its time, and the pads get the nearest forces they can carry.
#[test]
fn an_impossible_wrench_falls_back_and_is_counted() {
    let p = params(2, 0.3, 0.002, 60.0, 2.0);
    let mut d = FrictionDistribution::new(&p, 0.2).unwrap();
    let r = [Vector3::new(-0.2, 0.0, 0.0), Vector3::new(0.2, 0.0, 0.0)];
    let rot = [UnitQuaternion::identity(); 2];
    let mut w = [Vector6::new(0.0, 0.0, 100.0, 0.0, 0.0, 0.0); 2];
    assert!(!d.solve(1.25, &r, &rot, &mut w));
    assert_eq!(d.stats.fallbacks, 1);
    assert_eq!(d.stats.first_fallback_t, Some(1.25));
    assert!(w.iter().all(|x| x.iter().all(|v| v.is_finite())));
    let mut f = [[0.0; 4]; 4];
    d.pad_forces(&mut f);
    for pf in &f {
        assert!(margin(pf, 0.3, 0.002) >= 2.0 - 1e-6, "{f:?}");
    }
    // Less than asked, at most the pads' capacity 4 μ (N − δ) = 69.6 N.
    let lift: f64 = w.iter().map(|x| x[2]).sum();
    assert!(lift < 69.6 + 1e-6 && lift > 40.0, "{lift}");
}

/// A non-finite input (a NaN lever arm) is a fallback, counted, never a stale plan: the
/// wrenches come back as they went in, and the next finite tick is solved again.
#[test]
fn a_non_finite_input_falls_back_and_the_next_tick_recovers() {
    let p = params(2, 0.3, 0.002, 60.0, 2.0);
    let mut d = FrictionDistribution::new(&p, 0.2).unwrap();
    let r = [Vector3::new(-0.2, 0.0, 0.0), Vector3::new(0.2, 0.0, 0.0)];
    let rot = [UnitQuaternion::identity(); 2];
    let w0 = [Vector6::new(0.0, 0.0, 14.7, 0.0, 0.0, 0.0); 2];
    let mut w = w0;
    assert!(d.solve(0.0, &r, &rot, &mut w));
    let bad = [Vector3::new(f64::NAN, 0.0, 0.0), r[1]];
    let mut w = w0;
    assert!(!d.solve(0.001, &bad, &rot, &mut w));
    assert_eq!(w, w0, "a failed tick leaves the wrenches as they came");
    assert_eq!(d.stats.fallbacks, 1);
    assert_eq!(d.stats.first_fallback_t, Some(0.001));
    let mut w = w0;
    assert!(d.solve(0.002, &r, &rot, &mut w));
    assert!((w[0] - w0[0]).norm() < 1e-9);
}

/// Bad parameters name the field.
#[test]
fn bad_parameters_name_the_field() {
    let check = |f: &dyn Fn(&mut FrictionParams), want: &str| {
        let mut p = params(2, 0.3, 0.002, 60.0, 2.0);
        f(&mut p);
        let e = FrictionDistribution::new(&p, 0.2).unwrap_err().to_string();
        assert!(e.contains(want), "wanted {want}: {e}");
    };
    check(&|p| p.mu = 0.0, "friction.mu");
    check(&|p| p.mu = f64::NAN, "friction.mu");
    check(&|p| p.torsion = -1.0, "friction.torsion");
    check(&|p| p.mu = 1e308, "friction.mu");
    check(&|p| p.torsion = 1e308, "friction.torsion");
    check(&|p| p.grip[0] = 1e308, "friction.grip[0]");
    check(&|p| p.margin = f64::INFINITY, "friction.margin");
    check(&|p| p.grip[1] = -1.0, "friction.grip[1]");
    check(&|p| p.pads[0].clear(), "friction.pads[0]");
    check(
        &|p| p.pads[1][0].normal = Vector3::zeros(),
        "friction.pads[1][0]",
    );
}

fn rot_strategy() -> impl Strategy<Value = UnitQuaternion<f64>> {
    (-3.0..3.0f64, -1.5..1.5f64, -3.0..3.0f64)
        .prop_map(|(a, b, c)| UnitQuaternion::from_euler_angles(a, b, c))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]
    /// Random grasps (2 or 3 grippers at random places and orientations, random μ, torsion,
    /// grip), and an object wrench made from random pad forces strictly inside their cones
    /// (so a distribution exists): the solver finds one, realises the object wrench to 1e-8,
    /// keeps every pad inside its cone by half the margin and the opposing normals at twice the
    /// grip; then any weld-assuming share of that wrench (plus a random internal squeeze) goes
    /// through the same way.
    #[test]
    fn feasible_wrenches_are_distributed_inside_the_cones(
        m in 2usize..4,
        mu in 0.2f64..1.0,
        torsion in prop_oneof![Just(0.0f64), 0.001f64..0.01],
        grip in 10.0f64..100.0,
        places in proptest::collection::vec((-0.4f64..0.4, -0.4f64..0.4, -0.4f64..0.4), 3),
        rots in proptest::collection::vec(rot_strategy(), 3),
        loads in proptest::collection::vec((0.0f64..0.8, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 6),
        squeeze in 0.0f64..10.0,
    ) {
        let dm = 0.05 * grip;
        let p = params(m, mu, torsion, grip, dm);
        let mut d = FrictionDistribution::new(&p, 0.2).unwrap();
        let r: Vec<Vector3<f64>> = places[..m].iter().map(|&(x, y, z)| Vector3::new(x, y, z)).collect();
        let rot: Vec<UnitQuaternion<f64>> = rots[..m].to_vec();
        // Pad forces strictly inside their cones (by twice the margin), the pair's normals
        // summing to twice the grip: N = grip (1 ± s), friction a fraction of what N − 2δ allows.
        let mut w0 = vec![Vector6::zeros(); m];
        for i in 0..m {
            let s = 0.5 * loads[2 * i].0 * (1.0 - 2.0 * dm / grip);
            for (k, pad) in jaw().iter().enumerate() {
                let n_f = grip * (1.0 + if k == 0 { s } else { -s });
                let room = (n_f - 2.0 * dm).max(0.0);
                let (_, u1, u2, u3) = loads[2 * i + k];
                let scale = 0.9 * room / (u1 * u1 + u2 * u2 + u3 * u3).sqrt().max(1.0);
                let nn = rot[i] * pad.normal;
                let helper = if nn.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
                let e1 = nn.cross(&helper).normalize();
                let e2 = nn.cross(&e1);
                let f = nn * n_f + e1 * (mu * u1 * scale) + e2 * (mu * u2 * scale);
                let tq = if torsion > 0.0 { nn * (torsion * u3 * scale) } else { Vector3::zeros() };
                let pw = rot[i] * pad.position;
                let mom = pw.cross(&f) + tq;
                w0[i] += Vector6::new(f.x, f.y, f.z, mom.x, mom.y, mom.z);
            }
        }
        let net = Distribution::net(&r, &w0);
        // The weld-assuming share of the same wrench, plus a squeeze.
        let mut share = vec![Vector6::zeros(); m];
        let mut dist = Distribution::new(m, 0.2).unwrap();
        prop_assert!(dist.distribute(&r, &net, squeeze, &mut share));
        for start in [w0.clone(), share] {
            let mut w = start.clone();
            let ok = d.solve(0.0, &r, &rot, &mut w);
            prop_assert!(ok, "no distribution found: {:?}", d.stats);
            let after = Distribution::net(&r, &w);
            prop_assert!((after - net).norm() <= 1e-8 * (1.0 + net.norm()), "{after:?} vs {net:?}");
            let mut f = vec![[0.0; 4]; 2 * m];
            d.pad_forces(&mut f);
            for pf in &f {
                prop_assert!(margin(pf, mu, torsion) >= 0.5 * dm - 1e-9 * grip, "{f:?}");
                if torsion == 0.0 {
                    prop_assert!(pf[3] == 0.0);
                }
            }
            for i in 0..m {
                prop_assert!((f[2 * i][0] + f[2 * i + 1][0] - 2.0 * grip).abs() <= 1e-6 * grip, "{f:?}");
            }
        }
        prop_assert_eq!(d.stats.fallbacks, 0);
    }
}
