//! Temporary closed-loop driver for the spatial controller (until the generic loop lands).
use nalgebra::{Isometry3, Translation3, Vector3, Vector6};
use tandem::control::spatial::*;
use tandem::integrate::Rk4;
use tandem::plant::spatial::SpatialPlant;
use tandem::reference::se3_path::Se3Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let law = args.get(1).map(|s| s.as_str()).unwrap_or("nn");
    let setup_name = args.get(2).map(|s| s.as_str()).unwrap_or("ur5");
    let dur: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let setup = if setup_name == "franka" { tandem::fixtures::dual_franka() } else { tandem::fixtures::dual_ur5() };
    let plant = SpatialPlant::new(&setup.params).unwrap();
    let path = Se3Path::spec_s6();
    let s0 = path.sample(0.0);
    let law_p = match law {
        "pd" => SpatialLaw::Pd(SpatialPdGains::paper()),
        "ctc" => SpatialLaw::Ctc(SpatialCtcGains::default()),
        _ => SpatialLaw::Nn(if setup_name == "franka" { SpatialNnGains::dual_franka() } else { SpatialNnGains::dual_ur5() }),
    };
    let mut p = SpatialControllerParams::spec_s6(law_p);
    if args.iter().any(|a| a == "noadm") { p.admittance = None; }
    let t0 = std::time::Instant::now();
    let (mut c, warn) = SpatialController::new(&p, &setup.params, path.clone(), dur, &setup.q_guess).unwrap();
    eprintln!("setup {:.3} s, warnings {:?}", t0.elapsed().as_secs_f64(), warn);
    if let Some(nn) = c.adaptive() { eprintln!("fu {:?}", nn.fu()); }
    let x0 = Isometry3::from_parts(Translation3::from(s0.p + Vector3::new(-0.01, 0.0, 0.0)), s0.r);
    let mut y = plant.initial_state(&x0, &Vector6::zeros(), &setup.q_guess).unwrap();
    let mut ws = plant.workspace();
    let mut input = plant.zero_input();
    let n = plant.n_q();
    let m = plant.arms().len();
    let mut rk = Rk4::new(y.len());
    let mut dy = vec![0.0; y.len()];
    let mut wr = vec![0.0; 6 * m];
    let mut rec = SpatialTickRecord::new(m);
    let h = 1e-3;
    plant.derivative(&y, &input, &mut ws, &mut dy);
    for i in 0..m { wr[6*i..6*i+6].copy_from_slice(ws.tool_wrench(i).as_slice()); }
    {
        let q = y[..n].to_vec(); let qd = y[n+7..2*n+7].to_vec();
        c.start(0.0, &Measurements { q: &q, qd: &qd, wrenches: &wr });
    }
    let steps = (dur / h).round() as usize;
    let tw = std::time::Instant::now();
    let mut qv = vec![0.0; n]; let mut qdv = vec![0.0; n];
    for k in 0..steps {
        let t = k as f64 * h;
        plant.derivative(&y, &input, &mut ws, &mut dy);
        for i in 0..m { wr[6*i..6*i+6].copy_from_slice(ws.tool_wrench(i).as_slice()); }
        qv.copy_from_slice(&y[..n]); qdv.copy_from_slice(&y[n+7..2*n+7]);
        c.tick(t, &Measurements { q: &qv, qd: &qdv, wrenches: &wr }, &mut input.tau, &mut rec);
        if k == 0 {
            let om = tandem::control::spatial::model::ObjectModel::new(&setup.params).unwrap();
            let mut ows = om.workspace();
            let (_, o, _) = plant.split(&y);
            let d = om.dynamics(&qv, &qdv, &o.pose(), &o.twist(), &mut ows).unwrap();
            eprintln!("M diag {:?}", d.m.diagonal().as_slice());
            eprintln!("M eig {:?}", d.m.symmetric_eigenvalues().as_slice());
            eprintln!("M {:.3}", d.m);
            eprintln!("G {:?}", d.g.as_slice());
        }
        if k % 100 == 0 {
            let zp = rec.z1.fixed_rows::<3>(0).norm();
            let zr = rec.z1.fixed_rows::<3>(3).norm();
            let (_, o, _) = plant.split(&y);
            let s = path.sample(t);
            let ep = (o.p - s.p).norm();
            println!("t {t:6.2} |z1p| {:9.3e} |z1r| {:9.3e} |p-pd| {:9.3e} Q {:.3} margin {:.3} F {:8.2?} wn {:8.2e} tau_max {:7.2}", zp, zr, ep, rec.q_switch, rec.margin,
                rec.wrench.as_slice(), rec.w_norm.norm(), input.tau.iter().fold(0.0f64, |a, v| a.max(v.abs())));
        }
        if plant.step(&mut rk, t, &mut y, &input, &mut ws, h, 1).is_err() { println!("plant fault at {t}"); break; }
    }
    eprintln!("wall {:.3} s for {dur} s; events {:?}", tw.elapsed().as_secs_f64(), c.events());
}
