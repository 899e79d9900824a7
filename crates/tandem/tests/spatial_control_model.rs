//! The spatial controller's model blocks (`control::spatial::{model, distribute, bound}`):
//! the object-level model (14) against the closed-chain KKT plant (two algorithms that must
//! agree), the null-space projector, the wrench distribution, the bound `f^U` (39), no
//! allocation in the per-tick functions, and bad input.

use std::time::Instant;

use nalgebra::{DMatrix, DVector, Isometry3, UnitQuaternion, Vector3, Vector6};
use tandem::control::spatial::bound::{self, chart_dynamics, closed_chain_ik, fu_bound, usable};
use tandem::control::spatial::chart::Chart;
use tandem::control::spatial::distribute::{Distribution, PostureTask, joint_torques};
use tandem::control::spatial::model::{ObjectModel, nominal_params};
use tandem::error::ModelError;
use tandem::math::random::SplitMix64;
use tandem::plant::spatial::{SpatialInput, SpatialPlant};
use tandem::presets;
use tandem::presets::SpatialSetup;

#[path = "support/counting.rs"]
mod counting;
use counting::count;

#[global_allocator]
static A: counting::Counting = counting::Counting;

fn setups() -> Vec<(&'static str, SpatialSetup)> {
    vec![
        ("dual UR5", presets::dual_ur5()),
        ("dual Franka", presets::dual_franka()),
        ("three UR5", presets::three_ur5()),
    ]
}

/// The fixtures have no damping; this exercises the model's damping terms (object `C_o`,
/// joint `D_i`).
fn damped(mut s: SpatialSetup) -> SpatialSetup {
    s.params.object.damping = Vector6::new(2.0, 3.0, 4.0, 0.1, 0.2, 0.3);
    for a in &mut s.params.arms {
        for (k, j) in a.chain.joints.iter_mut().enumerate() {
            j.damping = 0.5 + 0.1 * k as f64;
        }
    }
    s
}

fn rand_v6(rng: &mut SplitMix64, lin: f64, ang: f64) -> Vector6<f64> {
    Vector6::new(
        rng.range(-lin, lin),
        rng.range(-lin, lin),
        rng.range(-lin, lin),
        rng.range(-ang, ang),
        rng.range(-ang, ang),
        rng.range(-ang, ang),
    )
}

fn rand_v3(rng: &mut SplitMix64, a: f64) -> Vector3<f64> {
    Vector3::new(rng.range(-a, a), rng.range(-a, a), rng.range(-a, a))
}

/// A pose near `x0`: up to `dp` m and `dr` rad away.
fn near(rng: &mut SplitMix64, x0: &Isometry3<f64>, dp: f64, dr: f64) -> Isometry3<f64> {
    let t = rand_v3(rng, dp);
    let r = rand_v3(rng, dr);
    Isometry3::from_parts(
        (x0.translation.vector + t).into(),
        UnitQuaternion::from_scaled_axis(r) * x0.rotation,
    )
}

fn split(y: &[f64], n_q: usize) -> (Vec<f64>, Vec<f64>) {
    (y[..n_q].to_vec(), y[n_q + 7..2 * n_q + 7].to_vec())
}

/// Add a random self-motion `(I − J⁺J) z` to a redundant arm's rates (keeps `J q̇`).
fn add_self_motion(model: &ObjectModel, q: &[f64], qd: &mut [f64], rng: &mut SplitMix64, amp: f64) {
    let mut ws = model.workspace();
    model.kinematics(q, qd, &mut ws);
    for (i, arm) in model.arms().iter().enumerate() {
        let n = arm.chain.dof();
        if n <= 6 {
            continue;
        }
        let s = model.offset(i);
        let j = DMatrix::from_column_slice(6, n, ws.data[i].J.as_slice());
        let z = DVector::from_vec(rng.vec(n, amp));
        let jjt = &j * j.transpose();
        let proj = &z - j.transpose() * jjt.cholesky().unwrap().solve(&(&j * &z));
        for k in 0..n {
            qd[s + k] += proj[k];
        }
    }
}

/// Model (14) against the KKT plant at consistent closed-chain states with a nonzero object
/// twist (and a random self-motion on the Franka arms), random `w_i`, random null-space
/// posture torques, random disturbance. Baumgarte is off for the tight comparison (at a
/// consistent state its terms are `2ω_b ė + ω_b² e` with `e, ė` at the IK's 1e-12 round-off,
/// so with `ω_b = 20` they add ≈ 400 · 1e-12 m/s²; measured below as well).
#[test]
fn model_matches_the_closed_chain_plant() {
    let mut rng = SplitMix64(7);
    let mut all = setups();
    all.push(("dual Franka, damped", damped(presets::dual_franka())));
    all.push(("dual UR5, damped", damped(presets::dual_ur5())));
    for (name, s) in all {
        for baumgarte in [0.0, 20.0] {
            let mut p = s.params.clone();
            p.baumgarte = baumgarte;
            let plant = SpatialPlant::new(&p).unwrap();
            let model = ObjectModel::new(&p).unwrap();
            let n_q = model.n_q();
            let m = model.arms().len();
            let mut pws = plant.workspace();
            let mut mws = model.workspace();
            let mut dist = Distribution::new(m, 0.2).unwrap();
            let (mut worst_a, mut worst_f) = (0.0f64, 0.0f64);
            for _ in 0..20 {
                let x_wo = near(&mut rng, &s.x_wo, 0.03, 0.1);
                let twist = rand_v6(&mut rng, 0.3, 0.8);
                let Ok(mut y) = plant.initial_state(&x_wo, &twist, &s.q_guess) else {
                    continue;
                };
                let (q, mut qd) = split(&y, n_q);
                add_self_motion(&model, &q, &mut qd, &mut rng, 0.5);
                y[n_q + 7..2 * n_q + 7].copy_from_slice(&qd);
                let od = model.dynamics(&q, &qd, &x_wo, &twist, &mut mws).unwrap();
                // Random arm wrenches and posture tasks; the object wrench they make.
                let w: Vec<Vector6<f64>> = (0..m).map(|_| rand_v6(&mut rng, 30.0, 5.0)).collect();
                let r: Vec<Vector3<f64>> = mws.arms.iter().map(|t| t.r).collect();
                let net = Distribution::net(&r, &w);
                let mut input = SpatialInput {
                    tau: vec![0.0; n_q],
                    f_d: rand_v6(&mut rng, 2.0, 0.5),
                    grip: Vec::new(),
                };
                for i in 0..m {
                    let n = model.arms()[i].chain.dof();
                    let s0 = model.offset(i);
                    let rest: Vec<f64> = (0..n).map(|k| q[s0 + k] + rng.range(-1.0, 1.0)).collect();
                    let post =
                        PostureTask::new(rng.range(5.0, 30.0), rng.range(1.0, 5.0), rest).unwrap();
                    joint_torques(
                        &model,
                        &mut mws,
                        i,
                        &w[i],
                        &q,
                        &qd,
                        Some(&post),
                        &mut input.tau,
                    );
                }
                let mut dy = vec![0.0; plant.state_dim()];
                assert!(plant.derivative(&y, &input, &mut pws, &mut dy));
                let a_model = od.acceleration(&net, &input.f_d).unwrap();
                let ea = (pws.a_o - a_model).norm() / pws.a_o.norm();
                worst_a = worst_a.max(ea);
                for i in 0..m {
                    let f = model.grasp_wrench(&mws, i, &w[i], &pws.a_o, &twist);
                    let ef = (pws.wrenches[i] - f).norm() / pws.wrenches[i].norm();
                    worst_f = worst_f.max(ef);
                }
                // Σ G_iᵀ w_i from the distribution's own helper is the same sum.
                let mut w2 = vec![Vector6::zeros(); m];
                assert!(dist.distribute(&r, &net, 0.0, &mut w2));
                assert!((Distribution::net(&r, &w2) - net).norm() < 1e-12 * net.norm());
            }
            println!(
                "{name}, ω_b = {baumgarte}: max relative error of V̇_o {worst_a:.2e}, of F_i {worst_f:.2e}"
            );
            // Measured (seed 7): ≤ 2.8e-12 (V̇_o) and 6.3e-12 (F_i) without Baumgarte; with
            // ω_b = 20 the IK's 1e-12 residuals add ≤ 1.8e-11 and 1.7e-10.
            let tol = if baumgarte == 0.0 { 1e-10 } else { 2e-9 };
            assert!(
                worst_a < tol && worst_f < tol,
                "{name}: {worst_a:e}, {worst_f:e}"
            );
        }
    }
}

/// Static equilibrium from the model: at rest, `F = 𝓖 + F_d` distributed (with a squeeze) and,
/// on the Frankas, the posture task at `q_rest = q` (so `τ0 = g(q)`, its null-space part
/// `N_iᵀ g_i` completing `g_i = J_iᵀ g_x,i + N_iᵀ g_i`) hold the whole chain still: the
/// plant's joint and object accelerations vanish.
#[test]
fn gravity_split_holds_the_chain_at_rest() {
    let mut rng = SplitMix64(17);
    for (name, mut s) in setups() {
        // Baumgarte off: with ω_b = 20 the IK's 1e-12 residuals alone give ≈ 4e-10 m/s².
        s.params.baumgarte = 0.0;
        let plant = SpatialPlant::new(&s.params).unwrap();
        let model = ObjectModel::new(&s.params).unwrap();
        let (n_q, m) = (model.n_q(), model.arms().len());
        let mut ws = model.workspace();
        let mut pws = plant.workspace();
        let mut dist = Distribution::new(m, 0.2).unwrap();
        let mut worst: f64 = 0.0;
        for _ in 0..10 {
            let x_wo = near(&mut rng, &s.x_wo, 0.03, 0.1);
            let y = plant
                .initial_state(&x_wo, &Vector6::zeros(), &s.q_guess)
                .unwrap();
            let (q, qd) = split(&y, n_q);
            let od = model
                .dynamics(&q, &qd, &x_wo, &Vector6::zeros(), &mut ws)
                .unwrap();
            let f_d = rand_v6(&mut rng, 2.0, 0.5);
            let r: Vec<Vector3<f64>> = ws.arms.iter().map(|t| t.r).collect();
            let mut w = vec![Vector6::zeros(); m];
            assert!(dist.distribute(&r, &(od.g + f_d), 10.0, &mut w));
            let mut input = SpatialInput {
                tau: vec![0.0; n_q],
                f_d,
                grip: Vec::new(),
            };
            for i in 0..m {
                let (s0, n) = (model.offset(i), model.arms()[i].chain.dof());
                let post = PostureTask::new(5.0, 1.0, q[s0..s0 + n].to_vec()).unwrap();
                joint_torques(
                    &model,
                    &mut ws,
                    i,
                    &w[i],
                    &q,
                    &qd,
                    Some(&post),
                    &mut input.tau,
                );
            }
            let mut dy = vec![0.0; plant.state_dim()];
            assert!(plant.derivative(&y, &input, &mut pws, &mut dy));
            let acc = dy[n_q + 7..].iter().fold(0.0f64, |a, v| a.max(v.abs()));
            worst = worst.max(acc);
        }
        println!("{name}: at rest under F = 𝓖 + F_d, max |q̈|, |V̇_o| = {worst:.2e}");
        // Measured (seed 17): 2.5e-12 (dual UR5), 2.4e-11 (dual Franka), 4.0e-11 (three UR5)
        // m/s² or rad/s²: round-off of the KKT solve with joint inertias down to 1e-3 kg m².
        assert!(worst < 5e-10, "{name}: {worst:e}");
    }
}

/// The weighted metric makes the share unit-independent: lengths in mm (`r`, `L` × 1000,
/// torques × 1000) give the same forces and the same torques in the new unit.
#[test]
fn weighted_share_is_unit_independent() {
    let mut rng = SplitMix64(19);
    for m in [2, 3] {
        let r = rand_grasps(&mut rng, m);
        let f = rand_v6(&mut rng, 50.0, 10.0);
        let mut d = Distribution::new(m, 0.2).unwrap();
        let mut w = vec![Vector6::zeros(); m];
        d.distribute(&r, &f, 7.0, &mut w);
        let k = 1000.0;
        let r_mm: Vec<Vector3<f64>> = r.iter().map(|x| x * k).collect();
        let f_mm = Vector6::new(f[0], f[1], f[2], f[3] * k, f[4] * k, f[5] * k);
        let mut d_mm = Distribution::new(m, 0.2 * k).unwrap();
        let mut w_mm = vec![Vector6::zeros(); m];
        d_mm.distribute(&r_mm, &f_mm, 7.0, &mut w_mm);
        for i in 0..m {
            let back = Vector6::new(
                w_mm[i][0],
                w_mm[i][1],
                w_mm[i][2],
                w_mm[i][3] / k,
                w_mm[i][4] / k,
                w_mm[i][5] / k,
            );
            assert!(
                (back - w[i]).norm() < 1e-11 * (1.0 + w[i].norm()),
                "m = {m}"
            );
        }
    }
}

/// `J M⁻¹ Nᵀ τ0 = 0` for the Franka arms: the posture torque does not reach the tool; and a
/// 6-DOF arm ignores the posture task (`τ = Jᵀ w` exactly).
#[test]
fn null_space_torques_do_not_move_the_tool() {
    let mut rng = SplitMix64(11);
    let s = presets::dual_franka();
    let model = ObjectModel::new(&s.params).unwrap();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let n_q = model.n_q();
    let mut ws = model.workspace();
    let mut worst = 0.0f64;
    let mut ins = (f64::INFINITY, 0.0f64);
    for _ in 0..20 {
        let x_wo = near(&mut rng, &s.x_wo, 0.03, 0.1);
        let y = plant
            .initial_state(&x_wo, &rand_v6(&mut rng, 0.2, 0.5), &s.q_guess)
            .unwrap();
        let (q, qd) = split(&y, n_q);
        model
            .dynamics(&q, &qd, &x_wo, &Vector6::zeros(), &mut ws)
            .unwrap();
        for i in 0..2 {
            let s0 = model.offset(i);
            let rest: Vec<f64> = (0..7).map(|k| q[s0 + k] + rng.range(-1.0, 1.0)).collect();
            let post = PostureTask::new(20.0, 3.0, rest).unwrap();
            let mut tau = vec![0.0; n_q];
            joint_torques(
                &model,
                &mut ws,
                i,
                &Vector6::zeros(),
                &q,
                &qd,
                Some(&post),
                &mut tau,
            );
            let d = &ws.data[i];
            let j = DMatrix::from_column_slice(6, 7, d.J.as_slice());
            let tau_i = DVector::from_column_slice(&tau[s0..s0 + 7]);
            let minv_tau = d.M.clone().cholesky().unwrap().solve(&tau_i);
            // Scale: the unprojected τ0 through J M⁻¹.
            let mut tau0 = DVector::zeros(7);
            let mut g = vec![0.0; 7];
            let mut d2 = tandem::dynamics::spatial::ChainData::new(&model.arms()[i]);
            tandem::dynamics::spatial::gravity(
                &model.arms()[i],
                &q[s0..s0 + 7],
                &model.gravity(),
                &mut g,
                &mut d2,
            );
            for k in 0..7 {
                tau0[k] = post.kp * (post.q_rest[k] - q[s0 + k]) - post.kd * qd[s0 + k] + g[k];
            }
            let scale = (&j * d.M.clone().cholesky().unwrap().solve(&tau0)).norm();
            worst = worst.max((&j * minv_tau).norm() / scale);
            // Self-motion inertia I_ns = (nᵀ M⁻¹ n)⁻¹, n the unit null vector of J.
            let z = DVector::from_vec(rng.vec(7, 1.0));
            let jjt = &j * j.transpose();
            let nv = &z - j.transpose() * jjt.cholesky().unwrap().solve(&(&j * &z));
            let nv = nv.normalize();
            let ins_i = 1.0 / nv.dot(&d.M.clone().cholesky().unwrap().solve(&nv));
            ins = (ins.0.min(ins_i), ins.1.max(ins_i));
        }
    }
    let d = PostureTask::franka(vec![0.0; 7]);
    let wn = |i: f64| (d.kp / i).sqrt();
    let zeta = |i: f64| d.kd / (2.0 * (d.kp * i).sqrt());
    println!(
        "Franka: |J M⁻¹ Nᵀ τ0| / |J M⁻¹ τ0| ≤ {worst:.2e}; self-motion inertia {:.3}–{:.3} kg m²; default posture ω_n {:.2}–{:.2} rad/s, ζ {:.2}–{:.2}",
        ins.0,
        ins.1,
        wn(ins.1),
        wn(ins.0),
        zeta(ins.1),
        zeta(ins.0)
    );
    assert!(worst < 1e-12, "{worst:e}");

    // 6-DOF: the posture task is ignored.
    let s = presets::dual_ur5();
    let model = ObjectModel::new(&s.params).unwrap();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y = plant
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap();
    let (q, qd) = split(&y, 12);
    let mut ws = model.workspace();
    model
        .dynamics(&q, &qd, &s.x_wo, &Vector6::zeros(), &mut ws)
        .unwrap();
    let w = rand_v6(&mut rng, 10.0, 2.0);
    let post = PostureTask::new(20.0, 3.0, vec![0.0; 6]).unwrap();
    let (mut a, mut b) = (vec![0.0; 12], vec![0.0; 12]);
    joint_torques(&model, &mut ws, 1, &w, &q, &qd, Some(&post), &mut a);
    joint_torques(&model, &mut ws, 1, &w, &q, &qd, None, &mut b);
    assert_eq!(a, b);
    let jtw = ws.data[1].J.transpose() * w;
    for k in 0..6 {
        assert!((b[6 + k] - jtw[k]).abs() < 1e-14 * (1.0 + jtw.norm()));
    }
    assert!(a[..6].iter().all(|v| *v == 0.0));
}

fn rand_grasps(rng: &mut SplitMix64, m: usize) -> Vec<Vector3<f64>> {
    (0..m).map(|_| rand_v3(rng, 0.4)).collect()
}

/// `Σ G_iᵀ w_i = F` to round-off for random `F`, `r` (1, 2, 3 and 4 grasps), with and without a
/// squeeze; the internal part lies in the null space and is a projection; min-norm in the
/// metric (Pythagoras with any internal wrench added).
#[test]
fn distribution_is_exact_internal_and_minimum_norm() {
    let mut rng = SplitMix64(3);
    let mut worst_net = 0.0f64;
    let mut worst_int = 0.0f64;
    let mut worst_pyth = 0.0f64;
    for m in 1..=4 {
        for trial in 0..200 {
            let r = rand_grasps(&mut rng, m);
            let f = rand_v6(&mut rng, 50.0, 10.0);
            let len = [0.05, 0.2, 1.0, 5.0][trial % 4];
            let mut d = Distribution::new(m, len).unwrap();
            let squeeze = rng.range(0.0, 20.0);
            let mut w = vec![Vector6::zeros(); m];
            assert!(d.distribute(&r, &f, squeeze, &mut w));
            let scale = f.norm() + squeeze * (1.0 + r.iter().map(|x| x.norm()).fold(0.0, f64::max));
            worst_net = worst_net.max((Distribution::net(&r, &w) - f).norm() / scale);
            // Internal part: in the null space, idempotent, and w − P_N w is the min-norm share.
            let mut wi = vec![Vector6::zeros(); m];
            assert!(d.internal_part(&r, &w, &mut wi));
            let n_int = Distribution::net(&r, &wi).norm();
            worst_int = worst_int.max(n_int / scale);
            let mut wii = vec![Vector6::zeros(); m];
            d.internal_part(&r, &wi, &mut wii);
            for i in 0..m {
                assert!((wii[i] - wi[i]).norm() <= 1e-12 * scale);
            }
            let mut w0 = vec![Vector6::zeros(); m];
            d.distribute(&r, &f, 0.0, &mut w0);
            for i in 0..m {
                assert!((w[i] - wi[i] - w0[i]).norm() <= 1e-12 * scale);
            }
            // Min-norm: ‖w0 + n‖² = ‖w0‖² + ‖n‖² > ‖w0‖² for a random internal n ≠ 0.
            let raw: Vec<Vector6<f64>> = (0..m).map(|_| rand_v6(&mut rng, 10.0, 2.0)).collect();
            let mut nvec = vec![Vector6::zeros(); m];
            d.internal_part(&r, &raw, &mut nvec);
            let sum: Vec<Vector6<f64>> = (0..m).map(|i| w0[i] + nvec[i]).collect();
            let (a, b, c) = (
                d.metric_norm2(&sum),
                d.metric_norm2(&w0),
                d.metric_norm2(&nvec),
            );
            worst_pyth = worst_pyth.max((a - b - c).abs() / a);
            if m > 1 {
                assert!(a > b, "m = {m}: adding an internal wrench lowered the norm");
            } else {
                assert!(c < 1e-20 * (1.0 + b), "one grasp has no internal wrench");
            }
        }
    }
    println!(
        "distribution: |Σ Gᵀw − F| ≤ {worst_net:.1e}, internal net ≤ {worst_int:.1e}, Pythagoras ≤ {worst_pyth:.1e} (relative)"
    );
    // Measured 1.2e-14, 1.3e-14, 6.6e-15: a few ulps of the largest term, over metric
    // lengths 0.05–5 m (the factor A = G W⁻¹ Gᵀ has condition ≈ (L/|r|)² either way).
    assert!(worst_net < 1e-13 && worst_int < 1e-13 && worst_pyth < 1e-13);
}

/// Two grasps: the squeeze is equal and opposite forces of the commanded magnitude along the
/// grasp-to-grasp line, pushing inward, with no torques; three grasps push toward the centroid.
#[test]
fn squeeze_direction_and_magnitude() {
    let mut rng = SplitMix64(5);
    for _ in 0..100 {
        let r = rand_grasps(&mut rng, 2);
        let mut d = Distribution::new(2, rng.range(0.05, 2.0)).unwrap();
        let s = rng.range(1.0, 30.0);
        let mut w = vec![Vector6::zeros(); 2];
        assert!(d.distribute(&r, &Vector6::zeros(), s, &mut w));
        let u = (r[1] - r[0]).normalize();
        let f1 = w[0].fixed_rows::<3>(0).into_owned();
        let f2 = w[1].fixed_rows::<3>(0).into_owned();
        assert!((f1 - s * u).norm() < 1e-13 * s, "{f1} vs {}", s * u);
        assert!((f2 + s * u).norm() < 1e-13 * s);
        assert!(w[0].fixed_rows::<3>(3).norm() < 1e-13 * s);
        assert!(w[1].fixed_rows::<3>(3).norm() < 1e-13 * s);
    }
    // Three grasps on a symmetric triangle around the centroid: pure inward pushes of `s`.
    let r: Vec<Vector3<f64>> = (0..3)
        .map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / 3.0;
            Vector3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.1)
        })
        .collect();
    let mut d = Distribution::new(3, 0.2).unwrap();
    let mut w = vec![Vector6::zeros(); 3];
    d.distribute(&r, &Vector6::zeros(), 10.0, &mut w);
    let c = (r[0] + r[1] + r[2]) / 3.0;
    for i in 0..3 {
        let f = w[i].fixed_rows::<3>(0).into_owned();
        assert!((f - 10.0 * (c - r[i]).normalize()).norm() < 1e-12, "{f}");
    }
}

/// The SPEC-spatial box: chart about the path's centre, bounds with the path at about 60 % of
/// the box (0.1 m circle in 0.17 m; 10° pitch in 0.3 rad).
fn box_for(name: &str, s: &SpatialSetup) -> (Chart, Vector6<f64>) {
    let c = if name == "dual UR5" {
        Vector3::new(0.0, 0.0, 0.3)
    } else {
        s.x_wo.translation.vector
    };
    (
        Chart::new(c, UnitQuaternion::identity()),
        Vector6::new(0.17, 0.17, 0.05, 0.15, 0.3, 0.15),
    )
}

/// `f^U` really bounds `|F_j|` at random reachable poses inside the box and random
/// `x_2, α, α̇`, with `F = 𝓖_x + 𝓒_x α + M_x α̇ + F_d` computed from the model at that pose
/// (`𝓒_x α` from evaluations of `h_x` at `x_2 ± α`, `±α`, independent of the bound's own
/// polarization). Also the set-up time (release).
#[test]
fn fu_bound_bounds_the_model() {
    let mut rng = SplitMix64(13);
    let mut all: Vec<_> = setups().into_iter().take(2).collect();
    all.push(("dual Franka, damped", damped(presets::dual_franka())));
    for (name, s) in all {
        let model = ObjectModel::new(&s.params).unwrap();
        let (chart, k_c) = box_for(name, &s);
        let dist = [1.0, 1.0, 1.0, 0.2, 0.2, 0.2];
        let t0 = Instant::now();
        let fu = fu_bound(&model, &chart, &k_c, &dist, 1.5, &s.x_wo, &s.q_guess).unwrap();
        let dt = t0.elapsed().as_secs_f64();
        let fu1 = fu_bound(&model, &chart, &k_c, &dist, 1.0, &s.x_wo, &s.q_guess).unwrap();
        println!(
            "{name}: f^U set-up {:.0} ms, {} of {} poses usable\n  a = {:.3?}\n  b = {:.3?}\n  c = {:.3?}\n  d = {:.3?}",
            dt * 1e3,
            fu.poses,
            729 + bound::HALTON_POINTS,
            fu.a,
            fu.b,
            fu.c,
            fu.d
        );
        assert!(fu.poses > 100, "{name}: only {} poses", fu.poses);
        let mut ws = model.workspace();
        let mut q = s.q_guess.clone();
        assert!(closed_chain_ik(
            &model, &s.x_wo, &mut q, &s.q_guess, &mut ws
        ));
        let q0 = q.clone();
        let (mut tested, mut worst, mut worst1) = (0, 0.0f64, 0.0f64);
        for _ in 0..400 {
            let x1 = Vector6::from_fn(|j, _| rng.range(-k_c[j], k_c[j]));
            let x_wo = chart.pose(&x1);
            q.copy_from_slice(&q0);
            if !closed_chain_ik(&model, &x_wo, &mut q, &s.q_guess, &mut ws)
                || !usable(&model, &mut q, &s.q_guess, &mut ws)
            {
                continue;
            }
            let x2 = rand_v6(&mut rng, 0.3, 0.5);
            let alpha = rand_v6(&mut rng, 0.3, 0.5);
            let alpha_dot = rand_v6(&mut rng, 3.0, 5.0);
            let f_d = Vector6::from_fn(|j, _| rng.range(-dist[j], dist[j]));
            let mut h =
                |x: &Vector6<f64>| chart_dynamics(&model, &chart, &q, &x_wo, x, &mut ws).unwrap();
            let (m_x, h0) = h(&Vector6::zeros());
            let qf = |a: Vector6<f64>, b: Vector6<f64>| (a + b) * 0.5 - h0;
            let q_p = qf(h(&(x2 + alpha)).1, h(&(-(x2 + alpha))).1);
            let q_m = qf(h(&(x2 - alpha)).1, h(&(-(x2 - alpha))).1);
            let c_alpha = (q_p - q_m) * 0.25 + (h(&alpha).1 - h(&(-alpha)).1) * 0.5;
            let f = h0 + c_alpha + m_x * alpha_dot + f_d;
            let (nx2, na, nad) = (x2.norm(), alpha.norm(), alpha_dot.norm());
            for j in 0..6 {
                let b = fu.a[j] + fu.b[j] * nx2 * na + fu.c[j] * nad + fu.d[j] * na;
                let b1 = fu1.a[j] + fu1.b[j] * nx2 * na + fu1.c[j] * nad + fu1.d[j] * na;
                worst = worst.max(f[j].abs() / b);
                worst1 = worst1.max(f[j].abs() / b1);
                assert!(
                    f[j].abs() <= b,
                    "{name}: |F_{j}| = {} > f^U = {b}",
                    f[j].abs()
                );
            }
            tested += 1;
        }
        println!(
            "{name}: {tested} random poses, max |F_j|/f^U_j = {worst:.3} (safety 1.5), {worst1:.3} (safety 1)"
        );
        assert!(tested > 50);
    }
}

/// Nominal model: `𝓜` and `𝓖` are linear in the inertial parameters, so scaling every mass and
/// inertia by `1 + e` scales them by exactly `1 + e`.
#[test]
fn nominal_params_scale_the_model() {
    let s = presets::dual_franka();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let y = plant
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap();
    let (q, qd) = split(&y, 14);
    let truth = ObjectModel::new(&s.params).unwrap();
    let nom = ObjectModel::new(&nominal_params(&s.params, 0.2)).unwrap();
    let same = ObjectModel::new(&nominal_params(&s.params, 0.0)).unwrap();
    let (mut w1, mut w2, mut w3) = (truth.workspace(), nom.workspace(), same.workspace());
    let a = truth
        .dynamics(&q, &qd, &s.x_wo, &Vector6::zeros(), &mut w1)
        .unwrap();
    let b = nom
        .dynamics(&q, &qd, &s.x_wo, &Vector6::zeros(), &mut w2)
        .unwrap();
    let c = same
        .dynamics(&q, &qd, &s.x_wo, &Vector6::zeros(), &mut w3)
        .unwrap();
    assert_eq!(a, c);
    assert!((b.m - a.m * 1.2).norm() < 1e-12 * a.m.norm());
    assert!((b.g - a.g * 1.2).norm() < 1e-12 * a.g.norm());
    assert!((a.h - a.g).norm() < 1e-12 * a.g.norm(), "at rest 𝓱 = 𝓖");
}

/// A singular arm (UR5 wrist singularity, `q5 = 0`: joints 4 and 6 aligned) has no `Λ`:
/// `dynamics` says so instead of returning a huge inertia; near it (`q5 = 1e-3`) it still
/// answers, and `σ_min` shows how close it is.
#[test]
fn singular_arm_has_no_operational_space_inertia() {
    let s = presets::dual_ur5();
    let model = ObjectModel::new(&s.params).unwrap();
    let mut ws = model.workspace();
    let mut q = s.q_guess.clone();
    q[4] = 0.0;
    let qd = vec![0.0; 12];
    assert!(
        model
            .dynamics(&q, &qd, &s.x_wo, &Vector6::zeros(), &mut ws)
            .is_none()
    );
    q[4] = 1e-3;
    assert!(
        model
            .dynamics(&q, &qd, &s.x_wo, &Vector6::zeros(), &mut ws)
            .is_some()
    );
    println!(
        "UR5 at q5 = 1e-3: σ_min(J) = {:.2e}",
        model.sigma_min(&ws, 0)
    );
    assert!(model.sigma_min(&ws, 0) < 1e-2 && model.sigma_min(&ws, 1) > 0.1);
}

/// No allocation in `kinematics`, `dynamics`, `distribute`, `internal_part`, `joint_torques`.
#[test]
fn per_tick_functions_do_not_allocate() {
    for (name, s) in setups() {
        let model = ObjectModel::new(&s.params).unwrap();
        let plant = SpatialPlant::new(&s.params).unwrap();
        let twist = Vector6::new(0.1, -0.05, 0.02, 0.2, 0.1, -0.3);
        let y = plant.initial_state(&s.x_wo, &twist, &s.q_guess).unwrap();
        let n_q = model.n_q();
        let m = model.arms().len();
        let (q, qd) = split(&y, n_q);
        let mut ws = model.workspace();
        let mut dist = Distribution::new(m, 0.2).unwrap();
        let post = PostureTask::franka(s.q_guess[..model.arms()[0].chain.dof()].to_vec());
        let mut w = vec![Vector6::zeros(); m];
        let mut wi = vec![Vector6::zeros(); m];
        let mut r = vec![Vector3::zeros(); m];
        let mut tau = vec![0.0; n_q];
        let f = Vector6::new(1.0, 2.0, 30.0, 0.1, 0.2, 0.3);
        let mut tick = || {
            model.kinematics(&q, &qd, &mut ws);
            let od = model.dynamics(&q, &qd, &s.x_wo, &twist, &mut ws).unwrap();
            for i in 0..m {
                r[i] = ws.arms[i].r;
            }
            assert!(dist.distribute(&r, &(f + od.g), 5.0, &mut w));
            assert!(dist.internal_part(&r, &w, &mut wi));
            for i in 0..m {
                joint_torques(&model, &mut ws, i, &w[i], &q, &qd, Some(&post), &mut tau);
            }
        };
        tick();
        let n = count(|| {
            for _ in 0..10 {
                tick();
            }
        });
        assert_eq!(n, 0, "{name}: {n} allocations");
    }
}

fn names(e: ModelError, want: &str) {
    let msg = e.to_string();
    assert!(msg.contains(want), "{msg:?} does not name {want:?}");
}

/// Bad input is a `ModelError` naming the field.
#[test]
fn bad_input_names_the_field() {
    let s = presets::dual_ur5();
    let mut p = s.params.clone();
    p.grasps.pop();
    names(ObjectModel::new(&p).unwrap_err(), "grasps");
    let mut p = s.params.clone();
    p.arms.clear();
    p.grasps.clear();
    names(ObjectModel::new(&p).unwrap_err(), "arms");
    let mut p = s.params.clone();
    p.object.mass = -1.0;
    names(ObjectModel::new(&p).unwrap_err(), "object.mass");
    names(Distribution::new(2, 0.0).unwrap_err(), "metric_length");
    names(Distribution::new(2, f64::NAN).unwrap_err(), "metric_length");
    names(Distribution::new(0, 0.2).unwrap_err(), "m");
    names(
        PostureTask::new(0.0, 1.0, vec![0.0; 7]).unwrap_err(),
        "posture.kp",
    );
    names(
        PostureTask::new(1.0, -1.0, vec![0.0; 7]).unwrap_err(),
        "posture.kd",
    );
    names(
        PostureTask::new(1.0, 1.0, vec![0.0, f64::NAN]).unwrap_err(),
        "posture.q_rest[1]",
    );
    let model = ObjectModel::new(&s.params).unwrap();
    let post = PostureTask::new(1.0, 1.0, vec![0.0; 7]).unwrap();
    names(post.check(&model, 0).unwrap_err(), "posture.q_rest");
    let post = PostureTask::new(1.0, 1.0, vec![0.0, 0.0, 0.0, 0.0, 0.0, 100.0]).unwrap();
    names(post.check(&model, 1).unwrap_err(), "posture.q_rest[5]");
    names(post.check(&model, 2).unwrap_err(), "arm");
    let f = presets::dual_franka();
    let fm = ObjectModel::new(&f.params).unwrap();
    PostureTask::franka(f.q_guess[..7].to_vec())
        .check(&fm, 1)
        .unwrap();
    let chart = Chart::new(Vector3::new(0.0, 0.0, 0.3), UnitQuaternion::identity());
    let k = Vector6::new(0.1, 0.1, 0.05, 0.1, 0.2, 0.1);
    let d = [0.0; 6];
    let fu = |chart: &Chart, k: &Vector6<f64>, d: &[f64; 6], safety: f64, q: &[f64]| {
        fu_bound(&model, chart, k, d, safety, &s.x_wo, q).unwrap_err()
    };
    let mut kk = k;
    kk[1] = -0.1;
    names(fu(&chart, &kk, &d, 1.5, &s.q_guess), "k_c[1]");
    let mut kk = k;
    kk[4] = 3.2;
    names(fu(&chart, &kk, &d, 1.5, &s.q_guess), "k_c[4]");
    names(
        fu(
            &chart,
            &k,
            &[0.0, 0.0, -1.0, 0.0, 0.0, 0.0],
            1.5,
            &s.q_guess,
        ),
        "disturbance[2]",
    );
    names(fu(&chart, &k, &d, 0.0, &s.q_guess), "safety");
    names(fu(&chart, &k, &d, 1.5, &s.q_guess[..5]), "q_guess");
    // A box out of reach of every arm.
    let far = Chart::new(Vector3::new(5.0, 0.0, 0.3), UnitQuaternion::identity());
    names(fu(&far, &k, &d, 1.5, &s.q_guess), "k_c");
}

/// The per-tick cost of the model (printed, not asserted: the VM is shared).
#[test]
fn model_evaluation_cost() {
    let s = presets::dual_franka();
    let model = ObjectModel::new(&s.params).unwrap();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let twist = Vector6::new(0.1, -0.05, 0.02, 0.2, 0.1, -0.3);
    let y = plant.initial_state(&s.x_wo, &twist, &s.q_guess).unwrap();
    let (q, qd) = split(&y, 14);
    let mut ws = model.workspace();
    let t0 = Instant::now();
    for _ in 0..20000 {
        std::hint::black_box(model.dynamics(&q, &qd, &s.x_wo, &twist, &mut ws));
    }
    let t1 = Instant::now();
    for _ in 0..20000 {
        model.kinematics(&q, &qd, &mut ws);
        std::hint::black_box(&ws);
    }
    let t2 = Instant::now();
    println!(
        "TIMING dynamics {:.2} µs, kinematics {:.2} µs",
        (t1 - t0).as_secs_f64() / 2e4 * 1e6,
        (t2 - t1).as_secs_f64() / 2e4 * 1e6
    );
}
