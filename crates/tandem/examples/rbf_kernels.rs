//! 1000 fused NN ticks of the paper network (4096 × 3) with the kernel `TANDEM_KERNEL` selects;
//! for instruction counts: `valgrind --tool=callgrind target/release/examples/rbf_kernels`.
use nalgebra::Vector3;
use tandem::control::rbf::{NnUpdate, Rbf, RbfNetwork};

fn main() {
    let rbf = Rbf::paper();
    let mut ws = rbf.workspace();
    let upd = NnUpdate::new(
        Vector3::new(120.0, 150.0, 120.0),
        Vector3::repeat(0.001),
        1e-3,
    )
    .expect("valid update");
    let mut net = RbfNetwork::<3>::for_basis(&rbf).expect("valid network");
    let mut z = [0.0; 12];
    let mut sum = 0.0;
    for k in 0..1000 {
        z[0] = 0.19 + 1e-4 * k as f64;
        let f = net.tick_at_outputs(
            &rbf,
            &z,
            &mut ws,
            1.0,
            &Vector3::new(0.01, -0.02, 0.005),
            &upd,
        );
        sum += f[0];
    }
    println!("kernel {}: {sum:e}", net.kernel());
}
