//! One set of invariant checks for every closed-chain plant, through the shared
//! [`ClosedChain`] interface (the crate docs, "Architecture"): the planar paper plant and the
//! spatial dual-UR5 plant run the same generic code.

mod support;

use nalgebra::{Vector3, Vector6};
use tandem::math::integrate::Rk4;
use tandem::plant::ClosedChain;
use tandem::plant::planar::Plant;
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;

/// Integrate `steps` steps of `h` with zero torque and return (largest |ΔE| relative to the
/// peak kinetic energy, largest position residual (m), largest second residual — planar: the
/// velocity residual, m/s; spatial: the rotation residual, rad — and the last sensor wrenches).
fn coast<P: ClosedChain>(plant: &P, y0: &[f64], h: f64, steps: usize) -> (f64, f64, f64, Vec<f64>) {
    let mut y = y0.to_vec();
    let mut ws = plant.workspace();
    let input = plant.zero_input();
    let mut rk = Rk4::new(plant.state_dim());
    let e0 = plant.energy(&y, &mut ws).total();
    let (mut de, mut t_max, mut res, mut res2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for k in 0..steps {
        assert!(plant.advance(&mut rk, k as f64 * h, &mut y, &input, &mut ws, h, 1));
        let e = plant.energy(&y, &mut ws);
        de = de.max((e.total() - e0).abs());
        t_max = t_max.max(e.kinetic);
        let (a, b) = plant.constraint_residual(&y, &mut ws);
        res = res.max(a);
        res2 = res2.max(b);
    }
    let mut dy = vec![0.0; plant.state_dim()];
    assert!(plant.derivative(&y, &input, &mut ws, &mut dy));
    let mut w = vec![0.0; P::WRENCH_DIM * plant.n_arms()];
    plant.sensor_wrenches(&ws, &mut w);
    let (q, qd) = plant.joints(&y);
    assert_eq!((q.len(), qd.len()), (plant.n_q(), plant.n_q()));
    (de / t_max.max(1e-300), res, res2, w)
}

#[test]
fn planar_and_spatial_plants_share_the_invariant_checks() {
    // Planar: the paper's plant, undamped, falling from the NN start for 0.5 s.
    let planar = Plant::new(&support::undamped(presets::paper())).unwrap();
    let y0 = planar
        .initial_state(presets::paper_start(), Vector3::zeros(), None)
        .unwrap();
    let (de, res, res2, w) = coast(&planar, &y0, 1e-3, 500);
    println!("planar: relative energy drift {de:.2e}, residual {res:.2e} m, {res2:.2e} m/s");
    // Measured: 3.4e-8, 3.7e-9 m, 1.2e-7 m/s (a free fall whips the 2-link arms around).
    assert!(de < 1e-6 && res < 1e-8 && res2 < 1e-6);
    assert_eq!(w.len(), 4);
    // Spatial: two UR5-class arms + box, undamped, falling for 0.5 s.
    let mut s = presets::dual_ur5();
    s.params.object.damping = Vector6::zeros();
    let spatial = SpatialPlant::new(&s.params).unwrap();
    let y0 = spatial
        .initial_state(&s.x_wo, &Vector6::zeros(), &s.q_guess)
        .unwrap();
    let (de, res, res2, w) = coast(&spatial, &y0, 1e-3, 500);
    println!("spatial: relative energy drift {de:.2e}, residual {res:.2e} m, {res2:.2e} rad");
    // Measured: 1.1e-8, 2.0e-9 m, 2.2e-9 rad (free fall; under a holding law the drift stays at
    // 1e-13, tests/spatial_plant.rs).
    assert!(de < 1e-6 && res < 1e-8 && res2 < 1e-8);
    assert_eq!(w.len(), 12);
    // The wrist sensors read in tool axes: the wrench's norm is frame-independent.
    let mut ws = spatial.workspace();
    let mut dy = vec![0.0; spatial.state_dim()];
    assert!(spatial.derivative(&y0, &spatial.zero_input(), &mut ws, &mut dy));
    for i in 0..2 {
        let world = ws.wrenches[i];
        let tool = ws.tool_wrench(i);
        assert!((world.fixed_rows::<3>(0).norm() - tool.fixed_rows::<3>(0).norm()).abs() < 1e-12);
        assert!((world.fixed_rows::<3>(3).norm() - tool.fixed_rows::<3>(3).norm()).abs() < 1e-12);
    }
}
