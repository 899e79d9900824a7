//! Contact grasps held by friction (`plant::spatial::contact`): analytic limits on a two-pad
//! gripper, the energy audit, and the weld as the limit of a stiff, frictional grasp.
//!
//! The rig for the analytic limits: a box between the two pads of a gripper on a vertical
//! carriage (one prismatic joint, 10⁴ kg, held by a constant force that balances its weight and
//! the load the pads carry), so the pads stand still to 1e-4 of the box's motion and the box's
//! motion is the pads' friction alone.

use nalgebra::{Isometry3, Matrix3, Vector3, Vector6};
use tandem::math::integrate::Rk4;
use tandem::model::spatial::{
    Chain, ChainJoint, JointKind, JointLimits, RigidBody, SpatialArm, SpatialObjectParams,
};
use tandem::plant::spatial::{
    ContactParams, GraspModel, Pad, PadStatus, SpatialInput, SpatialPlant, SpatialPlantParams,
};
use tandem::presets;

const G: f64 = 9.81;
/// The carriage's mass, kg.
const M_C: f64 = 1e4;
/// The box: 1 kg, 0.1 × 0.08 × 0.1 m.
const M_BOX: f64 = 1.0;
const HALF: [f64; 3] = [0.05, 0.04, 0.05];

struct Rig {
    mu: f64,
    torsion: f64,
    grip: f64,
    k: f64,
    d_n: f64,
    d_t: f64,
}

impl Default for Rig {
    fn default() -> Self {
        Rig {
            mu: 0.5,
            torsion: 0.0,
            grip: 20.0,
            k: 1e5,
            d_n: 300.0,
            d_t: 300.0,
        }
    }
}

fn two_pads(radius: f64) -> Vec<Pad> {
    vec![
        Pad {
            position: Vector3::new(0.0, -HALF[1], 0.0),
            normal: Vector3::new(0.0, 1.0, 0.0),
            radius,
        },
        Pad {
            position: Vector3::new(0.0, HALF[1], 0.0),
            normal: Vector3::new(0.0, -1.0, 0.0),
            radius,
        },
    ]
}

fn contact(r: &Rig, pads: Vec<Vec<Pad>>, grip: Vec<f64>, half: [f64; 3]) -> ContactParams {
    ContactParams {
        pads,
        grip,
        mu: r.mu,
        torsion: r.torsion,
        normal_stiffness: r.k,
        normal_damping: r.d_n,
        tangential_stiffness: r.k,
        tangential_damping: r.d_t,
        half_extents: Vector3::from(half),
    }
}

fn rig_params(r: &Rig) -> SpatialPlantParams {
    let carriage = SpatialArm {
        chain: Chain {
            name: "carriage".into(),
            base_link: "base".into(),
            tool_link: "gripper".into(),
            joints: vec![ChainJoint {
                name: "z".into(),
                kind: JointKind::Prismatic,
                placement: Isometry3::identity(),
                axis: Vector3::z_axis(),
                limits: JointLimits::UNLIMITED,
                damping: 0.0,
            }],
            bodies: vec![RigidBody {
                name: "carriage".into(),
                mass: M_C,
                com: Vector3::zeros(),
                inertia: Matrix3::identity() * 100.0,
            }],
            tool: Isometry3::translation(0.0, 0.0, 0.5),
        },
        base: Isometry3::identity(),
    };
    SpatialPlantParams {
        arms: vec![carriage],
        grasps: vec![Isometry3::identity()],
        object: SpatialObjectParams::uniform_box([0.1, 0.08, 0.1], M_BOX),
        gravity: Vector3::new(0.0, 0.0, -G),
        baumgarte: 0.0,
        grasp_model: GraspModel::Contact(contact(r, vec![two_pads(0.01)], vec![r.grip], HALF)),
        pad_gauge: None,
    }
}

fn rig(r: &Rig) -> (SpatialPlant, Vec<f64>) {
    let plant = SpatialPlant::new(&rig_params(r)).expect("valid rig");
    let y = plant
        .initial_state(
            &Isometry3::translation(0.0, 0.0, 0.5),
            &Vector6::zeros(),
            &[0.0],
        )
        .expect("start");
    (plant, y)
}

/// The box pushed down by `push(t)` (N) on top of its weight; the carriage held by its weight
/// plus `carried(t)` (the load its pads take). Calls `each(t, y, ws)` after every step.
#[allow(clippy::too_many_arguments)]
fn run(
    plant: &SpatialPlant,
    y: &mut [f64],
    h: f64,
    steps: usize,
    push: impl Fn(f64) -> f64,
    carried: impl Fn(f64) -> f64,
    mut each: impl FnMut(f64, &[f64], &tandem::plant::spatial::SpatialWorkspace, &SpatialInput),
) -> tandem::plant::spatial::SpatialWorkspace {
    let mut ws = plant.workspace();
    let mut rk = Rk4::new(plant.state_dim());
    let mut input = plant.zero_input();
    for k in 0..steps {
        let t = k as f64 * h;
        input.f_d = Vector6::new(0.0, 0.0, push(t), 0.0, 0.0, 0.0);
        input.tau[0] = M_C * G + carried(t);
        plant
            .step(&mut rk, t, y, &input, &mut ws, h, 1)
            .expect("finite");
        each(t + h, y, &ws, &input);
    }
    ws
}

fn box_z(plant: &SpatialPlant, y: &[f64]) -> (f64, f64) {
    let n = plant.n_q();
    (y[n + 2], y[2 * n + 7 + 2])
}

/// Held: a box of 1 kg between two pads of grip 12 N and μ = 0.5 (capacity 2 μ F_g = 12 N
/// against a weight of 9.81 N) does not slip over 10 s: the anchors never move. It sags by the
/// pads' elastic deflection, m g/(2 k_t). The margin (22 %) is the drop's: the box starts on
/// unloaded pads, and the pads' force peaks above the weight as it settles (by 13.5 % even for
/// a critically damped drop, `e⁻²`; at 11 N it slips, by 2e-5 m).
#[test]
fn a_box_held_below_its_friction_capacity_never_slips() {
    let r = Rig {
        grip: 12.0,
        ..Rig::default()
    };
    let (plant, mut y) = rig(&r);
    let z0 = box_z(&plant, &y).0;
    let mut slipped = false;
    let ws = run(
        &plant,
        &mut y,
        1e-4,
        100_000,
        |_| 0.0,
        |_| M_BOX * G,
        |_, _, ws, _| {
            slipped |= ws
                .contacts
                .readings
                .iter()
                .any(|p| p.status != PadStatus::Stick)
        },
    );
    let slip = ws.contacts.slip_distance[0];
    let sag = z0 - box_z(&plant, &y).0;
    let want = M_BOX * G / (2.0 * r.k);
    println!("slip over 10 s {slip:e} m; sag {sag:e} m (m g / 2 k_t = {want:e})");
    assert!(slip < 1e-9 && !slipped, "{slip:e}");
    assert!(ws.contacts.events.is_empty(), "{:?}", ws.contacts.events);
    // The carriage moves by (1 kg / 10⁴ kg) of the box: sag to 1e-3.
    assert!((sag / want - 1.0).abs() < 1e-3, "{sag:e} vs {want:e}");
    // The margins: μ N − |f_t| = 0.5·12 − 9.81/2 at rest.
    let m = ws.contacts.readings[0].margin;
    assert!((m - (0.5 * 12.0 - 0.5 * M_BOX * G)).abs() < 1e-6, "{m}");
    // The elliptic margin in normal force: N − |f_t|/μ = 12 − 4.905/0.5.
    let mc = ws.contacts.readings[0].cone_margin;
    assert!((mc - (12.0 - 0.5 * M_BOX * G / 0.5)).abs() < 1e-5, "{mc}");
    println!("smallest margin {:?} N", ws.contacts.min_margin[0]);
    assert!(ws.contacts.min_margin[0].0 > 0.0);
}

/// Slip onset: with the load ramped slowly (1 N/s on top of the weight), the box starts to slide
/// when the load reaches 2 μ F_g (20 N), within 1 %.
#[test]
fn slip_starts_where_the_load_reaches_the_friction_capacity() {
    let r = Rig::default();
    let (plant, mut y) = rig(&r);
    let rate = 1.0;
    let mut onset = None;
    let h = 1e-4;
    run(
        &plant,
        &mut y,
        h,
        120_000,
        |t| rate * t,
        |t| M_BOX * G + rate * t,
        |t, _, ws, _| {
            if onset.is_none()
                && ws
                    .contacts
                    .readings
                    .iter()
                    .any(|p| p.status == PadStatus::Slip)
            {
                onset = Some(t);
            }
        },
    );
    let t = onset.expect("the box slips");
    let load = M_BOX * G + rate * t;
    let cap = 2.0 * r.mu * r.grip;
    println!("onset at t = {t} s, load {load} N, capacity {cap} N");
    assert!((load / cap - 1.0).abs() < 0.01, "{load} vs {cap}");
}

/// Coulomb sliding: a box pushed down by 15 N on top of its weight against a capacity of 20 N
/// slides with acceleration (m g + 15 − 2 μ F_g)/m, to 1e-6 (over 0.1 s: the box slides 2.4 cm
/// of its 5 cm half face).
#[test]
fn a_sliding_box_accelerates_as_coulomb_says() {
    let r = Rig::default();
    let (plant, mut y) = rig(&r);
    let push = 15.0;
    let cap = 2.0 * r.mu * r.grip;
    let h = 1e-4;
    let mut v = Vec::new();
    let ws = run(
        &plant,
        &mut y,
        h,
        1000,
        |_| push,
        |_| cap,
        |t, y, _, _| v.push((t, box_z(&plant, y).1)),
    );
    let (t1, v1) = v[399];
    let (t2, v2) = v[999];
    let a = (v2 - v1) / (t2 - t1);
    let want = -(M_BOX * G + push - cap) / M_BOX;
    println!("sliding: a = {a} m/s², Coulomb {want} m/s²");
    assert!((a / want - 1.0).abs() < 1e-6, "{a} vs {want}");
    assert!(
        ws.contacts
            .readings
            .iter()
            .all(|p| p.status == PadStatus::Slip)
    );
    // The friction sits on the cone: margin 0, to the tangential limit and the elliptic cone.
    assert!(ws.contacts.readings.iter().all(|p| p.margin.abs() < 1e-9));
    assert!(
        ws.contacts
            .readings
            .iter()
            .all(|p| p.cone_margin.abs() < 1e-9)
    );
    // Slip distance: both pads' anchors moved by the box's fall.
    let fall = -(box_z(&plant, &y).0 - 0.5);
    let slip = ws.contacts.slip_distance[0];
    println!("fall {fall} m, slip (2 pads) {slip} m");
    assert!((slip / (2.0 * fall) - 1.0).abs() < 1e-2, "{slip} vs {fall}");
    assert_eq!(ws.contacts.events.len(), 2, "{:?}", ws.contacts.events);
}

/// Friction never adds energy: with no dampers, a push that makes the box slip and then stop.
/// `E − W` (the chain's and the contacts' energy less the work of the carriage force and the
/// push) never rises by more than the integrator's error, and what it loses is the friction's
/// work μ N × slip.
#[test]
fn friction_never_adds_energy() {
    let r = Rig {
        d_n: 0.0,
        d_t: 0.0,
        torsion: 0.002,
        ..Rig::default()
    };
    let (plant, mut y) = rig(&r);
    let mut ws = plant.workspace();
    let e = |y: &[f64], ws: &mut tandem::plant::spatial::SpatialWorkspace| {
        let e = plant.energy(y, ws);
        e.kinetic + e.potential
    };
    let e0 = e(&y, &mut ws);
    let n = plant.n_q();
    let mut w = 0.0;
    let mut prev_q = y[0];
    let mut prev_z = y[n + 2];
    let mut worst_rise = 0.0f64;
    let mut last = 0.0;
    let push = |t: f64| if t < 0.2 { 15.0 } else { 0.0 };
    let h = 1e-4;
    let steps = 6000;
    let mut rk = Rk4::new(plant.state_dim());
    let mut input = plant.zero_input();
    let mut ws2 = plant.workspace();
    for k in 0..steps {
        let t = k as f64 * h;
        input.f_d = Vector6::new(0.0, 0.0, push(t), 0.0, 0.0, 0.0);
        input.tau[0] = M_C * G + M_BOX * G;
        plant
            .step(&mut rk, t, &mut y, &input, &mut ws2, h, 1)
            .expect("finite");
        // Exact work of the held inputs over the step.
        w += input.tau[0] * (y[0] - prev_q) - push(t) * (y[n + 2] - prev_z);
        prev_q = y[0];
        prev_z = y[n + 2];
        let audit = e(&y, &mut ws) - e0 - w;
        worst_rise = worst_rise.max(audit - last);
        last = audit;
    }
    let slip = ws2.contacts.slip_distance[0];
    let friction_work = r.mu * r.grip * slip;
    println!(
        "E − W after the run {last:e} J; friction work μ N slip {friction_work:e} J; largest rise {worst_rise:e} J; slip {slip:e} m"
    );
    assert!(slip > 1e-3, "the push makes it slip");
    assert!(worst_rise < 1e-9, "energy created: {worst_rise:e} J");
    assert!(
        (-last / friction_work - 1.0).abs() < 0.02,
        "{last:e} vs {friction_work:e}"
    );
}

/// Bad contact parameters are errors naming the field.
#[test]
fn bad_contact_parameters_name_the_field() {
    let check = |f: &dyn Fn(&mut ContactParams), want: &str| {
        let mut p = rig_params(&Rig::default());
        if let GraspModel::Contact(c) = &mut p.grasp_model {
            f(c);
        }
        let e = SpatialPlant::new(&p).unwrap_err().to_string();
        assert!(e.contains(want), "wanted {want}: {e}");
        e
    };
    check(&|c| c.mu = 0.0, "grasp_model.mu");
    check(&|c| c.mu = -0.3, "grasp_model.mu");
    check(&|c| c.mu = f64::NAN, "grasp_model.mu");
    check(&|c| c.torsion = -1e-3, "grasp_model.torsion");
    // Beyond any contact, and beyond what the cone's scaling keeps digits for.
    check(&|c| c.mu = 1e308, "grasp_model.mu");
    check(&|c| c.torsion = 1e308, "grasp_model.torsion");
    check(&|c| c.grip[0] = 1e308, "grasp_model.grip[0]");
    check(
        &|c| c.pads[0][0].radius = 1e308,
        "grasp_model.pads[0][0].position",
    );
    check(
        &|c| c.pads[0][0].position.x = 1e308,
        "grasp_model.pads[0][0].position",
    );
    check(&|c| c.grip[0] = -5.0, "grasp_model.grip[0]");
    check(&|c| c.grip[0] = f64::NAN, "grasp_model.grip[0]");
    check(
        &|c| c.normal_stiffness = 0.0,
        "grasp_model.normal_stiffness",
    );
    check(
        &|c| c.tangential_damping = -1.0,
        "grasp_model.tangential_damping",
    );
    check(
        &|c| c.pads[0][1].radius = 0.0,
        "grasp_model.pads[0][1].radius",
    );
    check(
        &|c| c.pads[0][0].normal = Vector3::zeros(),
        "grasp_model.pads[0][0].normal",
    );
    check(&|c| c.pads[0].clear(), "grasp_model.pads[0]");
    check(&|c| c.grip.push(1.0), "grasp_model.grip");
    let e = check(
        &|c| c.pads[0][1].position.y += 0.002,
        "grasp_model.pads[0][1].position",
    );
    assert!(
        e.contains("does not touch") && e.contains("2.0000 mm"),
        "{e}"
    );
    let e = check(
        &|c| c.pads[0][0].position.x = 0.045,
        "grasp_model.pads[0][0].position",
    );
    assert!(e.contains("outside the face"), "{e}");
    let e = check(
        &|c| c.pads[0][0].normal = Vector3::new(0.1, 1.0, 0.0),
        "grasp_model.pads[0][0].normal",
    );
    assert!(e.contains("off the normal"), "{e}");
}

/// With μ → ∞ and stiffer pads, the contact grasp converges to the weld: two pads on the box's
/// ±y faces 3 cm inside each grasp of the S6 dual UR5, k = 1e4, 1e5, 1e6 N/m (all its springs
/// scale with k); the largest distance of the object from the welded chain's over 0.2 s falls
/// with k: measured 6.2e-3, 1.2e-3, 1.4e-4 m (ratios 5.0 and 8.5: the soft torsion of a two-pad
/// grip about its jaw axis, k ρ²/2 per pad, rings the wrist at the lower stiffness; the distance
/// at the final instant alone goes 6.1e-3, 7.2e-4, 1.4e-4 and 5.3e-6 m at 1e7). Step 50 µs: the
/// pads' couple on the wrist is the stiffest mode, ω ≈ 1.4e4 rad/s at 1e6 N/m; halving the step
/// changes the result by 1e-17 m.
#[test]
fn a_stiff_frictional_grasp_converges_to_the_weld() {
    let s = presets::dual_ur5();
    let rigid = SpatialPlant::new(&s.params).unwrap();
    let y0 = rigid
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap();
    let mut input = rigid.zero_input();
    let mut tau = vec![0.0; rigid.n_q()];
    rigid.holding_torques(&y0, &mut rigid.workspace(), &mut tau);
    input.tau = tau;
    input.f_d = Vector6::new(2.0, 0.0, -1.0, 0.0, 0.3, 0.0);
    let h = 5e-5;
    let steps = 4000;
    let n_q = rigid.n_q();
    // The object's path, every step.
    let path = |plant: &SpatialPlant, y: &mut Vec<f64>, input: &SpatialInput| {
        let mut ws = plant.workspace();
        let mut rk = Rk4::new(plant.state_dim());
        let mut out = Vec::with_capacity(steps);
        for k in 0..steps {
            plant
                .step(&mut rk, k as f64 * h, y, input, &mut ws, h, 1)
                .expect("finite");
            out.push(Vector3::new(y[n_q], y[n_q + 1], y[n_q + 2]));
        }
        (out, ws)
    };
    let (weld, _) = path(&rigid, &mut y0.clone(), &input);
    let half = [0.2, 0.1, 0.1];
    // Pads on the ±y faces at x = ±0.17 (3 cm inside the ends), pressing inwards.
    let pads: Vec<Vec<Pad>> = s
        .params
        .grasps
        .iter()
        .map(|g| {
            let x = g.translation.vector.x.signum() * (half[0] - 0.03);
            [-1.0, 1.0]
                .iter()
                .map(|&side| {
                    let p_o = nalgebra::Point3::new(x, side * half[1], 0.0);
                    Pad {
                        position: (g.inverse() * p_o).coords,
                        normal: g.rotation.inverse() * Vector3::new(0.0, -side, 0.0),
                        radius: 0.02,
                    }
                })
                .collect()
        })
        .collect();
    let mut errs = Vec::new();
    for k in [1e4, 1e5, 1e6] {
        let mut p = s.params.clone();
        // A fifth of critical against the wrist's ~0.2 kg: the pads' couple (k r², r = 0.1 m)
        // on the wrist's small rotational inertia is damped enough by it, and more would be a
        // mode faster than the step.
        let d = 0.4 * (k * 0.2f64).sqrt();
        p.grasp_model = GraspModel::Contact(contact(
            &Rig {
                mu: 1e6,
                torsion: 1e6,
                grip: 50.0,
                k,
                d_n: d,
                d_t: d,
            },
            pads.clone(),
            vec![50.0; 2],
            half,
        ));
        let plant = SpatialPlant::new(&p).unwrap();
        let mut y = y0.clone();
        y.resize(plant.state_dim(), 0.0);
        let mut ip = plant.zero_input();
        ip.tau = input.tau.clone();
        ip.f_d = input.f_d;
        let (got, ws) = path(&plant, &mut y, &ip);
        assert!(ws.contacts.slip_distance.iter().all(|s| *s == 0.0));
        assert!(ws.contacts.events.is_empty(), "{:?}", ws.contacts.events);
        let e = got
            .iter()
            .zip(&weld)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        errs.push(e);
    }
    println!("contact (μ = 1e6) vs weld, largest object distance over 0.2 s: {errs:?} m");
    assert!(errs.iter().all(|e| e.is_finite()));
    assert!(
        errs[1] < errs[0] / 4.0 && errs[2] < errs[1] / 7.0,
        "{errs:?}"
    );
    assert!(errs[2] < 2e-4, "{errs:?}");
}

/// The grip is an input of every step: opening the jaws from 12 N to 4 N (capacity
/// 2 μ F_g = 4 N against the 9.81 N weight) drops the box at that step and not before; a grip
/// that is not a pressing force (NaN, negative, beyond MAX_GRIP, or for a grasp that does not
/// exist) refuses the step, naming the entry, with the state untouched.
#[test]
fn the_grip_is_a_per_step_input_and_a_bad_one_refuses_the_step() {
    use tandem::plant::spatial::StepFault;
    let r = Rig::default();
    let (plant, mut y) = rig(&r);
    let h = 1e-4;
    let mut ws = plant.workspace();
    let mut rk = Rk4::new(plant.state_dim());
    let mut input = plant.zero_input();
    input.tau[0] = M_C * G + M_BOX * G;
    let mut first_slip = None;
    for k in 0..10_000 {
        let t = k as f64 * h;
        input.grip = vec![if t < 0.5 { r.grip } else { 4.0 }];
        plant
            .step(&mut rk, t, &mut y, &input, &mut ws, h, 1)
            .unwrap();
        if first_slip.is_none() && ws.contacts.slip_distance[0] > 0.0 {
            first_slip = Some(t + h);
        }
    }
    let t = first_slip.expect("the box slips once the grip drops");
    assert!((0.5..0.5 + 1e-3).contains(&t), "slip at {t}");
    let (z, _) = box_z(&plant, &y);
    assert!(
        z < 0.5 - 0.5 * 0.5 * (G - 4.0 / M_BOX) * 0.25,
        "the box fell only to {z}"
    );
    for (grip, index) in [
        (vec![f64::NAN], 0),
        (vec![-1.0], 0),
        (vec![2e6], 0),
        (vec![f64::INFINITY], 0),
        (vec![10.0, 10.0], 1),
    ] {
        let before = y.clone();
        input.grip = grip.clone();
        let e = plant
            .step(&mut rk, 1.0, &mut y, &input, &mut ws, h, 1)
            .unwrap_err();
        let StepFault::BadGrip { index: i, t, .. } = e else {
            panic!("{grip:?}: {e:?}")
        };
        assert_eq!((i, t), (index, 1.0), "{grip:?}");
        assert!(
            e.to_string().contains(&format!("input.grip[{index}]")),
            "{e}"
        );
        assert_eq!(y, before, "{grip:?}: the state moved");
    }
}
