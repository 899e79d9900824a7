//! The pad gauge (`gauge_only` pads on weld or compliant grasps): the pads' forces are the
//! linear-spring split of the grasp wrench, so they must sum back to it exactly, meet the
//! analytic splits of a symmetric parallel-jaw grasp, and report slip and separation where
//! those splits leave the cone.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use tandem::plant::spatial::{ContactParams, Pad, PadGauge, PadStatus};

const GRIP: f64 = 100.0;
const MU: f64 = 0.3;
const TORSION: f64 = 0.002;
const HALF: [f64; 3] = [0.1, 0.05, 0.05];

/// Two opposing pads on the box's ±x faces, the tool origin at the box centre (a
/// parallel-jaw gripper closing along x), one grasp.
fn params(radius: f64) -> ContactParams {
    ContactParams {
        pads: vec![vec![
            Pad {
                position: Vector3::new(-HALF[0], 0.0, 0.0),
                normal: Vector3::x(),
                radius,
            },
            Pad {
                position: Vector3::new(HALF[0], 0.0, 0.0),
                normal: -Vector3::x(),
                radius,
            },
        ]],
        grip: vec![GRIP],
        mu: MU,
        torsion: TORSION,
        normal_stiffness: 1e5,
        normal_damping: 30.0,
        tangential_stiffness: 4e4,
        tangential_damping: 10.0,
        half_extents: Vector3::from(HALF),
    }
}

/// Each pad's force `(N, |f_t|, τ)` and status for the wrench `w` (object on tool, about the
/// tool origin, world axes) with the object at `r_wo`.
fn gauge(g: &PadGauge, w: [f64; 6], r_wo: UnitQuaternion<f64>) -> Vec<(f64, f64, f64, PadStatus)> {
    let mut log = g.log();
    g.update(0, &Vector6::from(w), &r_wo, 0.0, &mut log);
    log.readings
        .iter()
        .map(|r| {
            (
                r.normal,
                r.tangential[0].hypot(r.tangential[1]),
                r.torsion,
                r.status,
            )
        })
        .collect()
}

fn gauge0() -> PadGauge {
    PadGauge::new(&params(0.01), &[Isometry3::identity()]).unwrap()
}

#[test]
fn no_wrench_leaves_the_grip_on_each_pad() {
    let g = gauge0();
    for (n, ft, tau, st) in gauge(&g, [0.0; 6], UnitQuaternion::identity()) {
        assert!((n - GRIP).abs() < 1e-12, "{n}");
        assert!(ft < 1e-12 && tau.abs() < 1e-15);
        assert_eq!(st, PadStatus::Stick);
    }
    let log = g.log();
    assert!(log.gauged);
    assert_eq!(log.pads, vec![(0, 0), (0, 1)]);
}

/// A shear `F` through the pads' midpoint splits in half by symmetry (equal springs, equal
/// arms): each pad carries `F/2` of friction and keeps the grip; the pads slip once
/// `F/2 > μ F_g`.
#[test]
fn a_shear_splits_in_half_and_slips_past_twice_mu_grip() {
    let g = gauge0();
    for (fy, fz, slip) in [
        (30.0, 0.0, false),
        (0.0, -50.0, false),
        (42.0, 42.0, false),
        (61.0, 0.0, true),
    ] {
        let r = gauge(&g, [0.0, fy, fz, 0.0, 0.0, 0.0], UnitQuaternion::identity());
        let half = 0.5 * f64::hypot(fy, fz);
        for (n, ft, tau, st) in r {
            assert!((n - GRIP).abs() < 1e-9, "{n}");
            assert!((ft - half).abs() < 1e-9, "{ft} vs {half}");
            assert!(tau.abs() < 1e-12);
            let want = if slip {
                PadStatus::Slip
            } else {
                PadStatus::Stick
            };
            assert_eq!(st, want, "({fy}, {fz})");
        }
    }
}

/// A push along the jaw axis moves `F/2` of normal force from one pad to the other (equal
/// normal springs in series with the box); past `2 F_g` the unloaded pad separates.
#[test]
fn a_push_along_the_jaws_shifts_normal_force_and_separates_one_pad() {
    let g = gauge0();
    let r = gauge(
        &g,
        [80.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        UnitQuaternion::identity(),
    );
    let mut ns: Vec<f64> = r.iter().map(|x| x.0).collect();
    ns.sort_by(f64::total_cmp);
    assert!((ns[0] - (GRIP - 40.0)).abs() < 1e-9, "{ns:?}");
    assert!((ns[1] - (GRIP + 40.0)).abs() < 1e-9, "{ns:?}");
    let r = gauge(
        &g,
        [201.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        UnitQuaternion::identity(),
    );
    let sep = r.iter().filter(|x| x.3 == PadStatus::Separated).count();
    assert_eq!(sep, 1, "{r:?}");
    // The sign: the object pushing the tool toward +x unloads the pad pressing toward +x
    // (the one on the −x face, pad 0).
    assert_eq!(r[0].3, PadStatus::Separated, "{r:?}");
}

/// A twist about the jaw axis is torsion only (both pads on the axis), split in half; the
/// elliptic cone with friction-free tangents leaves the pads at `|τ| ≤ μ_τ N`.
#[test]
fn a_twist_about_the_jaws_is_torsion_split_in_half() {
    let g = gauge0();
    for (m, slip) in [(0.3, false), (0.41, true)] {
        let r = gauge(&g, [0.0, 0.0, 0.0, m, 0.0, 0.0], UnitQuaternion::identity());
        for (n, ft, tau, st) in r {
            assert!((n - GRIP).abs() < 1e-9);
            assert!(ft < 1e-9);
            assert!((tau.abs() - 0.5 * m).abs() < 1e-12, "{tau}");
            assert_eq!(
                st == PadStatus::Slip,
                slip,
                "{m}: {tau} vs {}",
                TORSION * GRIP
            );
        }
    }
}

/// Any wrench, any object orientation, any tool offset: the pads' forces, put back on the
/// tool the way the contact plant sums them, give the wrench back (the gauge is an exact
/// split, not an estimate).
#[test]
fn the_pads_forces_sum_back_to_the_wrench() {
    let x_og = Isometry3::from_parts(
        Translation3::new(0.0, 0.01, -0.02),
        UnitQuaternion::identity(),
    );
    // The pads in the tool frame, so that they stay on the faces with the tool offset.
    let mut p = params(0.01);
    for pad in &mut p.pads[0] {
        pad.position -= x_og.translation.vector;
    }
    let g = PadGauge::new(&p, &[x_og]).unwrap();
    let mut s = 0x2545_f491_4f6c_dd1d_u64;
    let mut rnd = || {
        s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..200 {
        let w = [
            60.0 * rnd(),
            60.0 * rnd(),
            60.0 * rnd(),
            3.0 * rnd(),
            3.0 * rnd(),
            3.0 * rnd(),
        ];
        let r_wo = UnitQuaternion::from_scaled_axis(Vector3::new(rnd(), rnd(), rnd()) * 2.0);
        let mut log = g.log();
        g.update(0, &Vector6::from(w), &r_wo, 0.0, &mut log);
        // Pad 0 on the −x face (outward normal −x), pad 1 on +x; tangents y, z.
        let mut sum = Vector6::zeros();
        for (k, (c, sign)) in [(-HALF[0], -1.0), (HALF[0], 1.0)].into_iter().enumerate() {
            let rd = &log.readings[k];
            let f = Vector3::new(sign * rd.normal, rd.tangential[0], rd.tangential[1]);
            let rho = Vector3::new(c, 0.0, 0.0) - x_og.translation.vector;
            let m = rho.cross(&f) + Vector3::x() * sign * rd.torsion;
            let (fw, mw) = (r_wo * f, r_wo * m);
            sum += Vector6::new(fw.x, fw.y, fw.z, mw.x, mw.y, mw.z);
        }
        let err = (sum - Vector6::from(w)).abs().max();
        assert!(err < 1e-9, "{w:?}: {sum:?} ({err:e})");
    }
}

#[test]
fn one_pad_cannot_gauge_a_grasp() {
    let mut p = params(0.01);
    p.pads[0].truncate(1);
    let e = PadGauge::new(&p, &[Isometry3::identity()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("grasp_model.pads[0]") && e.contains("two pads"),
        "{e}"
    );
}

/// A non-finite wrench (a faulted sensor) reads as separated pads, never as a margin: the
/// minima keep the last finite reading.
#[test]
fn a_non_finite_wrench_reads_as_separated() {
    let g = gauge0();
    let mut log = g.log();
    g.update(
        0,
        &Vector6::new(0.0, 30.0, 0.0, 0.0, 0.0, 0.0),
        &UnitQuaternion::identity(),
        0.0,
        &mut log,
    );
    let before = log.min_cone_margin.clone();
    for w in [f64::NAN, f64::INFINITY, 1e308] {
        g.update(
            0,
            &Vector6::new(w, w, 0.0, 0.0, 0.0, 0.0),
            &UnitQuaternion::identity(),
            1.0,
            &mut log,
        );
        if !w.is_finite() {
            assert!(
                log.readings
                    .iter()
                    .all(|r| r.status == PadStatus::Separated),
                "{w}: {:?}",
                log.readings
            );
        }
    }
    assert!(
        log.min_cone_margin.iter().all(|(m, _)| !m.is_nan()),
        "{:?}",
        log.min_cone_margin
    );
    assert!(before[0].0 > 0.0);
}
