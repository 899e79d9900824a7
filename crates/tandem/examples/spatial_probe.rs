use nalgebra::Vector6;
use tandem::fixtures;
use tandem::plant::spatial::SpatialPlant;
fn main() {
    let n: usize = std::env::args().nth(1).unwrap().parse().unwrap();
    let s = fixtures::dual_ur5();
    let plant = SpatialPlant::new(&s.params).unwrap();
    let twist = Vector6::new(0.02, -0.01, 0.03, 0.1, -0.05, 0.2);
    let y = plant.initial_state(&s.x_wo, &twist, &s.q_guess).unwrap();
    let mut ws = plant.workspace();
    let input = plant.zero_input();
    let mut dy = vec![0.0; plant.state_dim()];
    for _ in 0..n {
        plant.derivative(std::hint::black_box(&y), &input, &mut ws, &mut dy);
    }
    println!("{}", dy[0]);
}
