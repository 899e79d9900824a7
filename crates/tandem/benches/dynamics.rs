//! Per-arm rigid-body algorithms (SPEC-spatial S2) side by side with the `dynibo` crate
//! (0.5.3) on the same model and state, in the same run.
//!
//! Models: `panda_like` (7 DOF, Franka-Panda-like modified-DH kinematics and inertias) and
//! `ur5_like` (6 DOF), both from `tests/support/chains.rs`; dynibo loads the same chains written
//! as URDF to a temp file. One fixed state, gravity 9.80665 m/s² along −z (dynibo's).
//!
//! * `rnea`: `τ = M q̈ + C q̇ + g` (dynibo `inverse_dynamics`, no loads);
//! * `crba`: `M` (dynibo `mass_matrix`);
//! * `aba`: `q̈` (dynibo `forward_dynamics`, ABA);
//! * `kinematics`: poses, tool `J`, `J̇ q̇` (dynibo `jacobian` + `jacobian_derivative`, which also
//!   build the poses);
//! * `terms`: kinematics + `M` + `C q̇ + g`, the plant's fused pass (dynibo: `mass_matrix` +
//!   `inverse_dynamics` at `q̈ = 0` + `jacobian` + `jacobian_derivative`, the same outputs).
//!
//! # Performance log
//! Instructions per call from callgrind (`valgrind --tool=callgrind <bench binary> --bench
//! --profile-time 1 '<id>$'`, inclusive cost of the closure divided by its call count; stable
//! under load) and criterion medians on the shared 2-core VM with other engineers' builds
//! running (load 3–7: the times are inflated and noisy, the same-run ratios are the signal).
//! Baseline x86-64 build (SSE2, no FMA) unless said.
//!
//! | date       | change | model | kinematics | RNEA | CRBA | ABA | terms |
//! |------------|--------|-------|-----------:|-----:|-----:|----:|------:|
//! | 2026-12-01 | first version (world axes about the base) | panda7 | 3 753 Ir, 0.55 µs | 6 424 Ir, 0.89 µs | 5 890 Ir, 0.79 µs | 9 725 Ir, 1.34 µs | 8 711 Ir, 1.10 µs |
//! | 2026-12-01 | no bounds checks, inlined sin_cos, fused terms | panda7 | 3 336 Ir | 5 857 Ir, 0.80 µs | 5 379 Ir, 0.90 µs | 9 258 Ir | 7 714 Ir, 1.17 µs |
//! | 2026-12-01 | same, `-C target-cpu=x86-64-v3` (AVX2, FMA) | panda7 | 3 007 Ir | 4 933 Ir | 4 748 Ir | 7 601 Ir | 6 661 Ir |
//! | 2026-12-01 | dynibo 0.5.3 (same run) | panda7 | 6 447 Ir, 1.3–1.5 µs | 7 229 Ir, 1.1–1.6 µs | 9 207 Ir, 1.45–1.66 µs | 19 450 Ir, 3.6–4.7 µs | ≈ 22 900 Ir, 4.1–6.1 µs |
//! | 2026-12-01 | tandem, final | ur5_6 | 2 902 Ir | 5 016 Ir | 4 500 Ir | 7 934 Ir | 6 502 Ir, 0.64–0.97 µs |
//! | 2026-12-01 | dynibo 0.5.3 (same run) | ur5_6 | 5 662 Ir | 6 363 Ir | 7 448 Ir | 16 896 Ir | ≈ 19 500 Ir, 2.3–3.7 µs |
//!
//! dynibo's `terms` is the sum of its four calls (mass matrix, inverse dynamics at `q̈ = 0`,
//! Jacobian, Jacobian derivative).
use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Vector3};
use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::model::spatial::{Chain, SpatialArm};

#[path = "../tests/support/chains.rs"]
mod chains;

struct Case {
    name: &'static str,
    arm: SpatialArm,
    robot: dynibo::Robot,
    tool: dynibo::LinkId,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    tau: Vec<f64>,
}

fn case(name: &'static str, chain: Chain) -> Case {
    let path =
        std::env::temp_dir().join(format!("tandem-bench-{}-{name}.urdf", std::process::id()));
    std::fs::write(&path, chains::chain_to_urdf(&chain)).unwrap();
    let robot = dynibo::Robot::from_urdf(&path).unwrap();
    std::fs::remove_file(&path).ok();
    let tool = robot.link_id("tool").unwrap();
    let n = chain.dof();
    // dynibo's generalized order must be ours (checked by name).
    for (k, j) in chain.joints.iter().enumerate() {
        assert_eq!(robot.joint_name(k).unwrap(), j.name);
    }
    let pick = |a: f64, b: f64| (0..n).map(|k| a + b * (k as f64 * 1.7).sin()).collect();
    Case {
        name,
        arm: SpatialArm {
            chain,
            base: Isometry3::identity(),
        },
        robot,
        tool,
        q: pick(0.3, 0.8),
        qd: pick(-0.2, 1.1),
        qdd: pick(0.5, 2.0),
        tau: pick(1.0, 10.0),
    }
}

fn bench(c: &mut Criterion) {
    let g = Vector3::new(0.0, 0.0, -9.80665);
    for mut k in [
        case("panda7", chains::panda_like()),
        case("ur5_6", chains::ur5_like()),
    ] {
        let n = k.arm.chain.dof();
        let mut d = ChainData::new(&k.arm);
        let mut out = vec![0.0; n];
        let mut mass = vec![0.0; n * n];
        let mut jac = vec![0.0; 6 * n];
        let mut jdot = vec![0.0; 6 * n];
        let zero = vec![0.0; n];
        let name = k.name;
        let mut group = c.benchmark_group(format!("dynamics/{name}"));

        group.bench_function("rnea/tandem", |b| {
            b.iter(|| {
                spatial::rnea(
                    &k.arm,
                    black_box(&k.q),
                    &k.qd,
                    &k.qdd,
                    &g,
                    None,
                    &mut out,
                    &mut d,
                )
            })
        });
        group.bench_function("rnea/dynibo", |b| {
            b.iter(|| {
                k.robot
                    .inverse_dynamics(black_box(&k.q), &k.qd, &k.qdd, &[], &mut out)
                    .unwrap()
            })
        });
        group.bench_function("crba/tandem", |b| {
            b.iter(|| spatial::crba(&k.arm, black_box(&k.q), &mut d))
        });
        group.bench_function("crba/dynibo", |b| {
            b.iter(|| k.robot.mass_matrix(black_box(&k.q), &mut mass).unwrap())
        });
        group.bench_function("aba/tandem", |b| {
            b.iter(|| {
                spatial::aba(
                    &k.arm,
                    black_box(&k.q),
                    &k.qd,
                    &k.tau,
                    &g,
                    None,
                    &mut out,
                    &mut d,
                )
            })
        });
        group.bench_function("aba/dynibo", |b| {
            b.iter(|| {
                k.robot
                    .forward_dynamics(black_box(&k.q), &k.qd, &k.tau, &[], &mut out)
                    .unwrap()
            })
        });
        group.bench_function("forward_dynamics_cholesky/tandem", |b| {
            b.iter(|| {
                spatial::forward_dynamics(
                    &k.arm,
                    black_box(&k.q),
                    &k.qd,
                    &k.tau,
                    &g,
                    None,
                    &mut out,
                    &mut d,
                )
            })
        });
        group.bench_function("kinematics/tandem", |b| {
            b.iter(|| spatial::kinematics(&k.arm, black_box(&k.q), Some(&k.qd), &mut d))
        });
        group.bench_function("kinematics/dynibo", |b| {
            b.iter(|| {
                k.robot.jacobian(black_box(&k.q), k.tool, &mut jac).unwrap();
                k.robot
                    .jacobian_derivative(&k.q, &k.qd, k.tool, &mut jdot)
                    .unwrap();
            })
        });
        group.bench_function("terms/tandem", |b| {
            b.iter(|| spatial::terms(&k.arm, black_box(&k.q), &k.qd, &g, &mut d))
        });
        group.bench_function("terms/dynibo", |b| {
            b.iter(|| {
                k.robot.mass_matrix(black_box(&k.q), &mut mass).unwrap();
                k.robot
                    .inverse_dynamics(&k.q, &k.qd, &zero, &[], &mut out)
                    .unwrap();
                k.robot.jacobian(&k.q, k.tool, &mut jac).unwrap();
                k.robot
                    .jacobian_derivative(&k.q, &k.qd, k.tool, &mut jdot)
                    .unwrap();
            })
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(40);
    targets = bench
}
criterion_main!(benches);
