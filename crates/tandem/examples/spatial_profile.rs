//! A fixed amount of spatial-plant work for instruction counting (load-independent profiling):
//!
//! ```sh
//! cargo build --release -p tandem --example spatial_profile
//! valgrind --tool=callgrind target/release/examples/spatial_profile dual_ur5 1000
//! valgrind --tool=callgrind target/release/examples/spatial_profile dual_ur5 0   # set-up only
//! ```
//!
//! The difference of the two totals over 1000 is the instructions per derivative
//! (`docs/performance.md`). Setups: `dual_ur5`, `dual_franka`, `three_ur5`.
use nalgebra::Vector6;
use tandem::plant::spatial::SpatialPlant;
use tandem::presets;

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "dual_ur5".into());
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let s = match name.as_str() {
        "dual_franka" => presets::dual_franka(),
        "three_ur5" => presets::three_ur5(),
        _ => presets::dual_ur5(),
    };
    let plant = SpatialPlant::new(&s.params).expect("valid plant");
    let twist = Vector6::new(0.02, -0.01, 0.03, 0.1, -0.05, 0.2);
    let y = plant
        .initial_state(&s.x_wo, &twist, &s.q_guess)
        .expect("reachable start");
    let mut ws = plant.workspace();
    let input = plant.zero_input();
    let mut dy = vec![0.0; plant.state_dim()];
    for _ in 0..n {
        plant.derivative(std::hint::black_box(&y), &input, &mut ws, &mut dy);
    }
    println!("{name}: {n} derivatives, q̈_1 = {:.6}", dy[plant.n_q() + 7]);
}
