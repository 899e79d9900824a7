//! Cross-checks of `tandem::dynamics::spatial` (STYLE habit 8, layers (a)–(c) and (f)):
//!
//! * closed forms: the planar 2-link arm of SPEC §2.1 built as a spatial chain against
//!   `tandem::dynamics::planar` (M, C, C q̇, G, J, J̇ q̇, RNEA);
//! * internal consistency: CRBA against RNEA columns, ABA against Cholesky forward dynamics,
//!   forward ∘ inverse, `C q̇ + g` against RNEA at `q̈ = 0`, the base pose against a chain that
//!   absorbs it, the energy rate `d/dt (T + U) = q̇ᵀ τ`;
//! * finite differences: `J` against 5-point central differences of the tool pose, `J̇ q̇`
//!   against differences of `J` along `q̇`, `Ṁ` against differences of `M` (`Ṁ − 2C` skew,
//!   proptest), Christoffel symmetry `C(q, u) w = C(q, w) u`;
//! * an independent implementation: the `dynibo` crate (0.5.3, dev-dependency only) on random
//!   6- and 7-DOF chains written out as URDF, and on any URDF file ([`dynibo_check_file`]).
//!
//! All random draws come from seeded `SplitMix64` generators. Tolerances are stated where used,
//! with the reason.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3, Vector4, Vector6,
};
use proptest::prelude::*;
use tandem::dynamics::planar::Arm;
use tandem::dynamics::spatial;
use tandem::dynamics::spatial::ChainData;
use tandem::geometry::so3;
use tandem::math::random::SplitMix64;
use tandem::model::planar::arm::{ArmParams, Elbow, LinkParams};
use tandem::model::spatial::{Chain, JointKind, RigidBody, SpatialArm};

#[path = "support/chains.rs"]
mod chains;
use chains::{chain_to_urdf, joint, panda_like, ur5_like};

// ---------------------------------------------------------------------------------------------
// Model builders
// ---------------------------------------------------------------------------------------------

/// A random unit vector: an axis-aligned one (either sign) one time in three, else uniform.
fn random_axis(rng: &mut SplitMix64) -> Vector3<f64> {
    if rng.next_f64() < 1.0 / 3.0 {
        let mut a = Vector3::zeros();
        a[(rng.next_f64() * 3.0) as usize % 3] = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 };
        a
    } else {
        loop {
            let v = Vector3::from_fn(|_, _| rng.range(-1.0, 1.0));
            let n = v.norm();
            if n > 0.2 && n <= 1.0 {
                return v / n;
            }
        }
    }
}

fn random_rotation(rng: &mut SplitMix64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(
        rng.range(-3.1, 3.1),
        rng.range(-1.5, 1.5),
        rng.range(-3.1, 3.1),
    )
}

/// A random rigid body: mass in [0.5, 5] kg, COM within 0.15 m of the frame origin and a
/// rotational inertia `Q diag(s2+s3, s1+s3, s1+s2) Qᵀ` from positive second moments `s_i`,
/// so it is SPD and satisfies the triangle inequality.
fn random_body(rng: &mut SplitMix64, name: &str) -> RigidBody {
    let m = rng.range(0.5, 5.0);
    let s = Vector3::from_fn(|_, _| m * rng.range(0.0005, 0.01));
    let d = Matrix3::from_diagonal(&Vector3::new(s.y + s.z, s.x + s.z, s.x + s.y));
    let q = random_rotation(rng).to_rotation_matrix().into_inner();
    let i = q * d * q.transpose();
    RigidBody {
        name: name.to_string(),
        mass: m,
        com: Vector3::from_fn(|_, _| rng.range(-0.15, 0.15)),
        inertia: 0.5 * (i + i.transpose()),
    }
}

/// A random serial chain: random joint origins (offsets up to 0.3 m, any rpy), random axes
/// (some axis-aligned), about one prismatic joint in six when `prismatic`, random bodies, and a
/// fixed tool offset.
fn random_chain(rng: &mut SplitMix64, n: usize, prismatic: bool) -> Chain {
    let mut joints = Vec::new();
    let mut bodies = Vec::new();
    for k in 0..n {
        let kind = if prismatic && rng.next_f64() < 1.0 / 6.0 {
            JointKind::Prismatic
        } else {
            JointKind::Revolute
        };
        let t = Translation3::new(
            rng.range(-0.3, 0.3),
            rng.range(-0.3, 0.3),
            rng.range(-0.1, 0.3),
        );
        joints.push(joint(
            &format!("j{k}"),
            kind,
            Isometry3::from_parts(t, random_rotation(rng)),
            random_axis(rng),
        ));
        bodies.push(random_body(rng, &format!("l{k}")));
    }
    let chain = Chain {
        name: "random".to_string(),
        base_link: "base".to_string(),
        tool_link: "tool".to_string(),
        joints,
        bodies,
        tool: Isometry3::from_parts(Translation3::new(0.02, -0.03, 0.11), random_rotation(rng)),
    };
    chain.validate().expect("random chain is valid");
    chain
}

fn at_identity(chain: Chain) -> SpatialArm {
    SpatialArm {
        chain,
        base: Isometry3::identity(),
    }
}

fn random_base(rng: &mut SplitMix64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(0.0, 0.5),
        ),
        random_rotation(rng),
    )
}

/// The same arm with `X_WB` moved into the first joint's placement and the base at identity.
fn absorb_base(arm: &SpatialArm) -> SpatialArm {
    let mut chain = arm.chain.clone();
    chain.joints[0].placement = arm.base * chain.joints[0].placement;
    at_identity(chain)
}

struct State {
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    tau: Vec<f64>,
    f_t: Vector6<f64>,
}

fn random_state(rng: &mut SplitMix64, n: usize) -> State {
    State {
        q: rng.vec(n, std::f64::consts::PI),
        qd: rng.vec(n, 2.0),
        qdd: rng.vec(n, 3.0),
        tau: rng.vec(n, 20.0),
        f_t: Vector6::from_fn(|_, _| rng.range(-10.0, 10.0)),
    }
}

/// `max |a − b| / max(max |b|, floor)`.
fn rel_err(a: &[f64], b: &[f64], floor: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(floor, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

const G_EARTH: f64 = 9.80665;

fn g_down() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -G_EARTH)
}

fn rnea_vec(
    arm: &SpatialArm,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    g: &Vector3<f64>,
    f: Option<&Vector6<f64>>,
    d: &mut ChainData,
) -> Vec<f64> {
    let mut tau = vec![0.0; q.len()];
    spatial::rnea(arm, q, qd, qdd, g, f, &mut tau, d);
    tau
}

fn test_arms(seed: u64) -> Vec<SpatialArm> {
    let mut rng = SplitMix64(seed);
    let mut arms = vec![at_identity(panda_like()), at_identity(ur5_like())];
    for &n in &[1, 2, 3, 6, 7, 7] {
        let chain = random_chain(&mut rng, n, true);
        arms.push(SpatialArm {
            chain,
            base: random_base(&mut rng),
        });
    }
    arms
}

// ---------------------------------------------------------------------------------------------
// Finite differences
// ---------------------------------------------------------------------------------------------

/// 5-point central difference `[−f(2h) + 8f(h) − 8f(−h) + f(−2h)] / 12h` of a vector function
/// of one parameter: truncation `h⁴/30 |f⁽⁵⁾|`, rounding about `1.5 ε |f| / h`.
fn d5<F: FnMut(f64) -> DVector<f64>>(mut f: F, h: f64) -> DVector<f64> {
    (-f(2.0 * h) + 8.0 * f(h) - 8.0 * f(-h) + f(-2.0 * h)) / (12.0 * h)
}

/// Tool pose as a 6-vector relative to a reference pose: `[p_T; Log(R_T R_refᵀ)]` (the
/// rotation vector in world axes, so its derivative at the reference is `ω`).
fn tool_chart(d: &ChainData, r_ref: &UnitQuaternion<f64>) -> DVector<f64> {
    let p = d.X_WT.translation.vector;
    let w = so3::log_quat(&(d.X_WT.rotation * r_ref.inverse()));
    DVector::from_row_slice(&[p.x, p.y, p.z, w.x, w.y, w.z])
}

#[test]
fn jacobian_matches_finite_differences_of_the_tool_pose() {
    // h = 1e-3 rad: truncation h⁴/30 · |f⁽⁵⁾| ≈ 3e-14 × (reach ≈ 1–2 m), rounding ≈ 1.5 ε/h ≈
    // 3e-13 per metre; tolerance 2e-11 (absolute, m/rad and rad/rad) leaves a margin of ~50.
    let h = 1e-3;
    let mut rng = SplitMix64(101);
    let mut worst: f64 = 0.0;
    for arm in test_arms(100) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        for _ in 0..5 {
            let s = random_state(&mut rng, n);
            spatial::kinematics(&arm, &s.q, None, &mut d);
            let jac = d.J.clone();
            let r_ref = d.X_WT.rotation;
            let mut dd = ChainData::new(&arm);
            for k in 0..n {
                let col = d5(
                    |t| {
                        let mut q = s.q.clone();
                        q[k] += t;
                        spatial::kinematics(&arm, &q, None, &mut dd);
                        tool_chart(&dd, &r_ref)
                    },
                    h,
                );
                let e = (jac.column(k) - col).amax();
                worst = worst.max(e);
                assert!(e < 2e-11, "{}: column {k}: {e:e}", arm.chain.name);
            }
        }
    }
    println!("J vs finite differences: max abs error {worst:.2e}");
}

#[test]
fn jdot_qdot_matches_finite_differences_of_the_jacobian() {
    // J̇ q̇ = d/dt J(q + t q̇) q̇ at t = 0 (q̈ = 0); 5-point differences of J along q̇ with
    // h = δ / |q̇|₁, δ = 2e-3 rad the largest joint-space step. Per unit of
    // s = |q̇|₁ |q̇|_∞ · reach: truncation ≈ δ⁴/30 ≈ 5e-13, rounding ≈ 1.5 ε / δ ≈ 2e-13
    // (measured: 1e-13); tolerance 5e-12 s.
    let mut rng = SplitMix64(102);
    let mut worst: f64 = 0.0;
    for arm in test_arms(100) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let mut dd = ChainData::new(&arm);
        for _ in 0..5 {
            let s = random_state(&mut rng, n);
            spatial::kinematics(&arm, &s.q, Some(&s.qd), &mut d);
            let qd1: f64 = s.qd.iter().map(|v| v.abs()).sum();
            let qdi = s.qd.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let h = 2e-3 / qd1;
            let jdot = d5(
                |t| {
                    let q: Vec<f64> = s.q.iter().zip(&s.qd).map(|(q, v)| q + t * v).collect();
                    spatial::kinematics(&arm, &q, None, &mut dd);
                    DVector::from_column_slice(dd.J.as_slice())
                },
                h,
            );
            let jdot = DMatrix::from_column_slice(6, n, jdot.as_slice());
            let want = jdot * DVector::from_column_slice(&s.qd);
            let e = (DVector::from_column_slice(d.jdqd.as_slice()) - want).amax() / (qd1 * qdi);
            worst = worst.max(e);
            assert!(e < 5e-12, "{}: J̇q̇ error {e:e}", arm.chain.name);
            // And J q̇ is the tool twist (the body twist moved to the tool point).
            // Body twists are about the base origin.
            let v = d.body_twists()[n - 1];
            let p = d.X_WT.translation.vector - arm.base.translation.vector;
            let w = Vector3::new(v[3], v[4], v[5]);
            let vt = Vector3::new(v[0], v[1], v[2]) + w.cross(&p);
            let jq = &d.J * DVector::from_column_slice(&s.qd);
            assert!((jq.fixed_rows::<3>(0) - vt).amax() < 1e-13);
            assert!((jq.fixed_rows::<3>(3) - w).amax() < 1e-13);
        }
    }
    println!("J̇q̇ vs finite differences: max error / (|q̇|₁ |q̇|_∞) {worst:.2e}");
}

#[test]
fn poses_follow_the_chain_convention() {
    // X_WL_k = X_WL_{k−1} X_PJ[k] J_k(q_k) composed with nalgebra's own Isometry3 products.
    let mut rng = SplitMix64(103);
    for arm in test_arms(100) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let s = random_state(&mut rng, n);
        spatial::kinematics(&arm, &s.q, None, &mut d);
        let mut x = arm.base;
        for (k, j) in arm.chain.joints.iter().enumerate() {
            let jq = match j.kind {
                JointKind::Revolute => Isometry3::from_parts(
                    Translation3::identity(),
                    UnitQuaternion::from_axis_angle(&j.axis, s.q[k]),
                ),
                JointKind::Prismatic => Isometry3::from_parts(
                    Translation3::from(j.axis.into_inner() * s.q[k]),
                    UnitQuaternion::identity(),
                ),
            };
            x = x * j.placement * jq;
            let e = (x.to_homogeneous() - d.X_WL[k].to_homogeneous()).amax();
            assert!(e < 1e-14, "body {k}: {e:e}");
        }
        x *= arm.chain.tool;
        assert!((x.to_homogeneous() - d.X_WT.to_homogeneous()).amax() < 1e-14);
    }
}

// ---------------------------------------------------------------------------------------------
// Internal consistency
// ---------------------------------------------------------------------------------------------

#[test]
fn crba_matches_rnea_columns() {
    // M e_k = rnea(q, q̇, e_k) − rnea(q, q̇, 0) (any q̇, any g: they cancel). Both are sums of
    // the same O(1) products: rounding only, tolerance 1e-13 relative to max |M|.
    let mut rng = SplitMix64(201);
    let mut worst: f64 = 0.0;
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        for _ in 0..5 {
            let s = random_state(&mut rng, n);
            spatial::crba(&arm, &s.q, &mut d);
            let m = d.M.clone();
            assert_eq!(m, m.transpose());
            let g = g_down();
            let t0 = rnea_vec(&arm, &s.q, &s.qd, &vec![0.0; n], &g, None, &mut d);
            for k in 0..n {
                let mut e = vec![0.0; n];
                e[k] = 1.0;
                let tk = rnea_vec(&arm, &s.q, &s.qd, &e, &g, None, &mut d);
                let col: Vec<f64> = tk.iter().zip(&t0).map(|(a, b)| a - b).collect();
                let err =
                    rel_err(&col, m.column(k).as_slice(), 0.0) * m.column(k).amax() / m.amax();
                worst = worst.max(err);
                assert!(err < 1e-13, "{} column {k}: {err:e}", arm.chain.name);
            }
            assert!(m.clone().cholesky().is_some(), "M is SPD");
        }
    }
    println!("CRBA vs RNEA columns: {worst:.2e}");
}

#[test]
fn terms_match_the_separate_algorithms() {
    let mut rng = SplitMix64(202);
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let mut e = ChainData::new(&arm);
        let g = g_down();
        for _ in 0..3 {
            let s = random_state(&mut rng, n);
            spatial::terms(&arm, &s.q, &s.qd, &g, &mut d);
            spatial::crba(&arm, &s.q, &mut e);
            assert_eq!(d.M, e.M);
            let b = rnea_vec(&arm, &s.q, &s.qd, &vec![0.0; n], &g, None, &mut e);
            assert!(rel_err(d.bias.as_slice(), &b, 1.0) < 1e-15);
            spatial::kinematics(&arm, &s.q, Some(&s.qd), &mut e);
            assert_eq!(d.J, e.J);
            // terms reads J̇ q̇ off the RNEA's accelerations: same sums, other rounding.
            assert!((d.jdqd - e.jdqd).amax() < 1e-14 * e.jdqd.amax().max(1.0));
            assert_eq!(d.X_WT, e.X_WT);
            assert_eq!(d.X_WL, e.X_WL);
        }
    }
}

#[test]
fn aba_matches_cholesky_and_inverts_rnea() {
    // ABA and M⁻¹(τ − b) are different O(n)/O(n³) factorisations of the same system: they agree
    // to about cond(M) ε. Measured cond(M) over these states: ≤ 8e2 (Panda-like), ≤ 4e4 (the
    // UR5-like arm's light wrist), ≤ 6e3 (random chains), so cond·ε ≤ 9e-12: tolerance 5e-11
    // relative to max(|q̈|, 1) (and to max(|τ|, 1) for rnea ∘ aba).
    let mut rng = SplitMix64(203);
    let mut worst: f64 = 0.0;
    let mut worst_inv: f64 = 0.0;
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let g = g_down();
        for _ in 0..5 {
            let s = random_state(&mut rng, n);
            for f in [None, Some(&s.f_t)] {
                let mut a = vec![0.0; n];
                let mut c = vec![0.0; n];
                spatial::aba(&arm, &s.q, &s.qd, &s.tau, &g, f, &mut a, &mut d);
                spatial::forward_dynamics(&arm, &s.q, &s.qd, &s.tau, &g, f, &mut c, &mut d);
                let e = rel_err(&a, &c, 1.0);
                worst = worst.max(e);
                assert!(e < 5e-11, "{}: ABA vs Cholesky {e:e}", arm.chain.name);
                // forward ∘ inverse: rnea(q, q̇, aba(τ)) = τ.
                let t = rnea_vec(&arm, &s.q, &s.qd, &a, &g, f, &mut d);
                let e = rel_err(&t, &s.tau, 1.0);
                worst_inv = worst_inv.max(e);
                assert!(e < 5e-11, "{}: rnea ∘ aba {e:e}", arm.chain.name);
                // inverse ∘ forward: aba(q, q̇, rnea(q̈)) = q̈.
                let t = rnea_vec(&arm, &s.q, &s.qd, &s.qdd, &g, f, &mut d);
                spatial::aba(&arm, &s.q, &s.qd, &t, &g, f, &mut a, &mut d);
                let e = rel_err(&a, &s.qdd, 1.0);
                worst_inv = worst_inv.max(e);
                assert!(e < 5e-11, "{}: aba ∘ rnea {e:e}", arm.chain.name);
            }
            assert_eq!(d.singular_pivots(), 0);
        }
    }
    println!("ABA vs Cholesky: {worst:.2e}; forward∘inverse: {worst_inv:.2e}");
}

#[test]
fn tool_wrench_enters_as_minus_j_transpose() {
    // rnea(F_T) − rnea(0) = −Jᵀ F_T.
    let mut rng = SplitMix64(204);
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let g = g_down();
        let s = random_state(&mut rng, n);
        let t0 = rnea_vec(&arm, &s.q, &s.qd, &s.qdd, &g, None, &mut d);
        let t1 = rnea_vec(&arm, &s.q, &s.qd, &s.qdd, &g, Some(&s.f_t), &mut d);
        spatial::kinematics(&arm, &s.q, None, &mut d);
        let jtf = d.J.transpose() * s.f_t;
        let diff: Vec<f64> = t1.iter().zip(&t0).map(|(a, b)| b - a).collect();
        assert!(
            rel_err(&diff, jtf.as_slice(), 1.0) < 1e-13,
            "{}",
            arm.chain.name
        );
    }
}

#[test]
fn coriolis_and_gravity_reassemble_the_rnea() {
    // C q̇ + g = rnea(q, q̇, 0); g = rnea(q, 0, 0); Christoffel symmetry C(q,u) w = C(q,w) u.
    let mut rng = SplitMix64(205);
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let g = g_down();
        let mut c = DMatrix::zeros(n, n);
        let mut gv = vec![0.0; n];
        for _ in 0..5 {
            let s = random_state(&mut rng, n);
            spatial::coriolis_matrix(&arm, &s.q, &s.qd, &mut c, &mut d);
            spatial::gravity(&arm, &s.q, &g, &mut gv, &mut d);
            let zero = vec![0.0; n];
            let g_rnea = rnea_vec(&arm, &s.q, &zero, &zero, &g, None, &mut d);
            assert!(rel_err(&gv, &g_rnea, 1.0) < 1e-14, "{}: g", arm.chain.name);
            let b = rnea_vec(&arm, &s.q, &s.qd, &zero, &g, None, &mut d);
            let cq = &c * DVector::from_column_slice(&s.qd);
            let sum: Vec<f64> = cq.iter().zip(&gv).map(|(a, b)| a + b).collect();
            assert!(
                rel_err(&sum, &b, 1.0) < 1e-13,
                "{}: C q̇ + g",
                arm.chain.name
            );
            let (u, w) = (rng.vec(n, 1.0), rng.vec(n, 1.0));
            let mut cu = DMatrix::zeros(n, n);
            let mut cw = DMatrix::zeros(n, n);
            spatial::coriolis_matrix(&arm, &s.q, &u, &mut cu, &mut d);
            spatial::coriolis_matrix(&arm, &s.q, &w, &mut cw, &mut d);
            let a = &cu * DVector::from_column_slice(&w);
            let b = &cw * DVector::from_column_slice(&u);
            assert!(
                rel_err(a.as_slice(), b.as_slice(), 1.0) < 1e-13,
                "{}: Γ symmetry",
                arm.chain.name
            );
        }
    }
}

/// `Ṁ` along `q̇` by 5-point differences of CRBA (step δ = 2e-3 rad in joint space).
fn mdot(arm: &SpatialArm, q: &[f64], qd: &[f64], d: &mut ChainData) -> DMatrix<f64> {
    let n = q.len();
    let qd1: f64 = qd.iter().map(|v| v.abs()).sum::<f64>().max(1e-3);
    let h = 2e-3 / qd1;
    let v = d5(
        |t| {
            let qt: Vec<f64> = q.iter().zip(qd).map(|(q, v)| q + t * v).collect();
            spatial::crba(arm, &qt, d);
            DVector::from_column_slice(d.M.as_slice())
        },
        h,
    );
    DMatrix::from_column_slice(n, n, v.as_slice())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(3),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Property 1: `Ṁ − 2C` is skew-symmetric, with `Ṁ` from finite differences of CRBA
    /// (so this also checks `Ṁ = C + Cᵀ`). 5-point differences with a 2e-3 rad joint step:
    /// error ≈ (δ⁴/30 + 1.5 ε/δ) |M| |q̇|₁ ≈ 1e-12 |M| |q̇|₁; tolerance 2e-11 |M| |q̇|₁.
    #[test]
    fn mdot_minus_two_c_is_skew(seed in 0u64..1_000_000, n in 1usize..8) {
        let mut rng = SplitMix64(seed);
        let arm = SpatialArm { chain: random_chain(&mut rng, n, true), base: random_base(&mut rng) };
        let mut d = ChainData::new(&arm);
        let s = random_state(&mut rng, n);
        let md = mdot(&arm, &s.q, &s.qd, &mut d);
        let mut c = DMatrix::zeros(n, n);
        spatial::coriolis_matrix(&arm, &s.q, &s.qd, &mut c, &mut d);
        spatial::crba(&arm, &s.q, &mut d);
        let qd1: f64 = s.qd.iter().map(|v| v.abs()).sum();
        let scale = d.M.amax() * qd1.max(1e-3);
        let n_mat = &md - 2.0 * &c;
        let sym = (&n_mat + n_mat.transpose()).amax() / scale;
        prop_assert!(sym < 2e-11, "Ṁ − 2C not skew: {sym:e}");
        let e = (&md - &c - c.transpose()).amax() / scale;
        prop_assert!(e < 2e-11, "Ṁ ≠ C + Cᵀ: {e:e}");
    }
}

#[test]
fn energy_rate_equals_power() {
    // d/dt (T + U) along q(t) = q + t q̇ + ½ t² q̈ equals q̇ᵀ τ with τ = rnea(q, q̇, q̈) and no
    // tool wrench. 5-point differences in t with h = δ / max(|q̇|₁, √|q̈|₁), δ = 2e-3, so the
    // joint-space steps stay ≤ δ: truncation ≈ δ⁴/30 (|T| + |U|)/h, rounding ≈ 1.5 ε (|T| + |U|)/h
    // (measured: the rounding dominates, ≈ 1e-10 for |T| + |U| ≈ 300 J); tolerance
    // 10 ε (|T| + |U|)/h + 1e-10 max(Σ|q̇ τ|, 1).
    let mut rng = SplitMix64(206);
    let mut worst: f64 = 0.0;
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let g = g_down();
        for _ in 0..5 {
            let s = random_state(&mut rng, n);
            let tau = rnea_vec(&arm, &s.q, &s.qd, &s.qdd, &g, None, &mut d);
            let power: f64 = s.qd.iter().zip(&tau).map(|(a, b)| a * b).sum();
            let qd1: f64 = s.qd.iter().map(|v| v.abs()).sum();
            let qdd1: f64 = s.qdd.iter().map(|v| v.abs()).sum();
            let h = 2e-3 / qd1.max(qdd1.sqrt());
            let (te0, ue0) = spatial::energy(&arm, &s.q, &s.qd, &g, &mut d);
            let rate = d5(
                |t| {
                    let q: Vec<f64> = (0..n)
                        .map(|k| s.q[k] + t * s.qd[k] + 0.5 * t * t * s.qdd[k])
                        .collect();
                    let qd: Vec<f64> = (0..n).map(|k| s.qd[k] + t * s.qdd[k]).collect();
                    let (te, ue) = spatial::energy(&arm, &q, &qd, &g, &mut d);
                    DVector::from_element(1, te + ue)
                },
                h,
            )[0];
            let p_abs = tau
                .iter()
                .zip(&s.qd)
                .map(|(a, b)| (a * b).abs())
                .sum::<f64>();
            let tol = 10.0 * f64::EPSILON * (te0.abs() + ue0.abs()) / h + 1e-10 * p_abs.max(1.0);
            let e = (rate - power).abs();
            worst = worst.max(e / tol);
            assert!(e < tol, "{}: dE/dt {rate} vs q̇ᵀτ {power}", arm.chain.name);
            // T = ½ q̇ᵀ M q̇.
            let (te, _) = spatial::energy(&arm, &s.q, &s.qd, &g, &mut d);
            spatial::crba(&arm, &s.q, &mut d);
            let v = DVector::from_column_slice(&s.qd);
            let t2 = 0.5 * v.dot(&(&d.M * &v));
            assert!((te - t2).abs() < 1e-13 * t2.max(1.0));
        }
    }
    println!("energy rate vs power: worst error / tolerance {worst:.2}");
}

#[test]
fn base_pose_equals_a_chain_that_absorbs_it() {
    let mut rng = SplitMix64(207);
    for arm in test_arms(200) {
        let n = arm.chain.dof();
        let abs = absorb_base(&arm);
        let mut d = ChainData::new(&arm);
        let mut e = ChainData::new(&abs);
        let g = g_down();
        let s = random_state(&mut rng, n);
        spatial::terms(&arm, &s.q, &s.qd, &g, &mut d);
        spatial::terms(&abs, &s.q, &s.qd, &g, &mut e);
        assert!((&d.M - &e.M).amax() < 1e-13 * d.M.amax());
        assert!(rel_err(d.bias.as_slice(), e.bias.as_slice(), 1.0) < 1e-13);
        assert!((&d.J - &e.J).amax() < 1e-14);
        assert!((d.jdqd - e.jdqd).amax() < 1e-13 * d.jdqd.amax().max(1.0));
        assert!((d.X_WT.to_homogeneous() - e.X_WT.to_homogeneous()).amax() < 1e-14);
    }
}

// ---------------------------------------------------------------------------------------------
// The planar arm of SPEC §2.1 as a spatial chain
// ---------------------------------------------------------------------------------------------

/// A planar arm (`tandem::dynamics::planar`) as a spatial chain: joint axes along world z, link `k` along its
/// body x axis (joint `k+1` at `(l_k, 0, 0)`), COM at `(l_c, 0, 0)`, rotational inertia
/// `diag(I, I, I)` (only `I_zz` matters in the plane), the base at `(x, y, 0)` turned by the
/// base angle about z, the tool at the last link's tip.
fn planar_chain(p: &ArmParams) -> SpatialArm {
    let mut joints = Vec::new();
    let mut bodies = Vec::new();
    let mut offset = 0.0;
    for (k, l) in p.links.iter().enumerate() {
        joints.push(joint(
            &format!("q{}", k + 1),
            JointKind::Revolute,
            Isometry3::translation(offset, 0.0, 0.0),
            Vector3::z(),
        ));
        bodies.push(RigidBody {
            name: format!("link{}", k + 1),
            mass: l.mass,
            com: Vector3::new(l.com, 0.0, 0.0),
            inertia: Matrix3::identity() * l.inertia,
        });
        offset = l.length;
    }
    let chain = Chain {
        name: "planar".to_string(),
        base_link: "base".to_string(),
        tool_link: "ee".to_string(),
        joints,
        bodies,
        tool: Isometry3::translation(offset, 0.0, 0.0),
    };
    chain.validate().unwrap();
    SpatialArm {
        chain,
        base: Isometry3::from_parts(
            Translation3::new(p.base[0], p.base[1], 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p.base_angle),
        ),
    }
}

fn planar_cases() -> Vec<ArmParams> {
    let mut paper = ArmParams::paper([0.35, -0.1], Elbow::Positive);
    let paper0 = paper.clone();
    paper.base_angle = 0.4;
    let mut three = ArmParams::paper([-0.2, 0.05], Elbow::Negative);
    three.links.push(LinkParams {
        mass: 0.5,
        length: 0.2,
        com: 0.08,
        inertia: 0.004,
    });
    three.base_angle = -0.7;
    vec![paper0, paper, three]
}

#[test]
fn planar_arm_reproduces_the_closed_forms() {
    // The spatial algorithms against SPEC §2.1's closed forms (2 links, `Arm::dynamics` takes its
    // closed-form fast path) and the planar general algorithm (3 links): M, C (the Christoffel
    // matrix itself, which is unique), C q̇, G, J (the x, y linear rows), J̇ q̇, the tool position
    // and RNEA with an end-effector force, all to 1e-12 relative (rounding only).
    let g = tandem::model::planar::arm::GRAVITY;
    let g_w = Vector3::new(0.0, -g, 0.0);
    let mut rng = SplitMix64(301);
    let mut worst: f64 = 0.0;
    for p in planar_cases() {
        let planar = Arm::new("arm", &p).unwrap();
        let sp = planar_chain(&p);
        let n = p.links.len();
        let mut t = planar.terms();
        let mut d = ChainData::new(&sp);
        let mut c = DMatrix::zeros(n, n);
        let mut gv = vec![0.0; n];
        for _ in 0..20 {
            let s = random_state(&mut rng, n);
            planar.dynamics(&s.q, &s.qd, g, &mut t);
            spatial::terms(&sp, &s.q, &s.qd, &g_w, &mut d);
            spatial::coriolis_matrix(&sp, &s.q, &s.qd, &mut c, &mut d);
            spatial::gravity(&sp, &s.q, &g_w, &mut gv, &mut d);
            let mut check = |what: &str, a: &[f64], b: &[f64]| {
                let e = rel_err(a, b, 1e-3);
                worst = worst.max(e);
                assert!(e < 1e-12, "{n} links, {what}: {e:e}\n{a:?}\n{b:?}");
            };
            check("M", d.M.as_slice(), t.M.as_slice());
            check("C", c.as_slice(), t.C.as_slice());
            let cq = &t.C * DVector::from_column_slice(&s.qd);
            let b_want: Vec<f64> = cq.iter().zip(t.G.iter()).map(|(a, b)| a + b).collect();
            check("C q̇ + G", d.bias.as_slice(), &b_want);
            check("G", &gv, t.G.as_slice());
            let j_xy: Vec<f64> = (0..n).flat_map(|k| [d.J[(0, k)], d.J[(1, k)]]).collect();
            check("J", &j_xy, t.J.as_slice());
            // The rest of J: no z motion, rotation about z with rate Σ q̇.
            for k in 0..n {
                let rest = Vector4::new(d.J[(2, k)], d.J[(3, k)], d.J[(4, k)], d.J[(5, k)]);
                assert!((rest - Vector4::new(0.0, 0.0, 0.0, 1.0)).amax() < 1e-15);
            }
            check("J̇ q̇", &[d.jdqd[0], d.jdqd[1]], t.jdot_qdot.as_slice());
            let p_t = d.X_WT.translation.vector;
            check("p_ee", &[p_t.x, p_t.y], t.p_ee.as_slice());
            // RNEA with an end-effector force F (the force on the end-effector from outside).
            let f = nalgebra::Vector2::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
            let mut tau_p = vec![0.0; n];
            planar.rnea(&s.q, &s.qd, &s.qdd, f, g, &mut t, &mut tau_p);
            let f6 = Vector6::new(f.x, f.y, 0.0, 0.0, 0.0, 0.0);
            let tau_s = rnea_vec(&sp, &s.q, &s.qd, &s.qdd, &g_w, Some(&f6), &mut d);
            check("RNEA", &tau_s, &tau_p);
            // And the energy.
            let (te, ue) = spatial::energy(&sp, &s.q, &s.qd, &g_w, &mut d);
            planar.dynamics(&s.q, &s.qd, g, &mut t);
            let (tp, up) = planar.energy(&s.qd, g, &t);
            check("energy", &[te, ue], &[tp, up]);
        }
    }
    println!("planar closed forms: max relative error {worst:.2e}");
}

// ---------------------------------------------------------------------------------------------
// Against dynibo
// ---------------------------------------------------------------------------------------------
//
// dynibo 0.5.3 (a dev-dependency only: it pins nalgebra 0.34, so every value crosses through
// plain `f64` slices, arrays and component indexing) loads URDF from a file, fixes gravity at
// 9.80665 m/s² along world −z, and uses its own conventions, converted here:
// * twists and Jacobian columns are **angular first** (`[ω; v]`) and Jacobians are taken at the
//   target link's origin: the URDF carries the tool frame as a massless link `tool` on a fixed
//   joint, so its origin is our tool point; rows 3..6 of dynibo's `J` are our rows 0..3;
// * `jacobian_derivative` is `J̇` at the same point (the classical `J̇ q̇ = p̈ − J q̈`): we
//   compare `J̇ q̇` after the same row swap;
// * external loads are **resisting** wrenches `[τ; f]` in the link's own axes at its origin, added
//   to the inverse-dynamics torques: our `F_T` (applied to the tool, world axes, about the tool
//   origin) becomes `−R_WTᵀ F_T` on link `tool`;
// * matrices are column-major flat slices; generalized order is dynibo's joint order, mapped to
//   ours by joint name (other dynibo joints, if any, are held at zero).

/// Write `chain` (base absorbed, see [`chain_to_urdf`]) to a fresh temp file.
fn write_urdf(chain: &Chain, tag: &str) -> std::path::PathBuf {
    let path = std::env::temp_dir().join(format!("tandem-dyn-{}-{tag}.urdf", std::process::id()));
    std::fs::write(&path, chain_to_urdf(chain)).unwrap();
    path
}

/// dynibo's frame type from ours (nalgebra 0.34 values built from components).
fn to_dynibo_frame(x: &Isometry3<f64>) -> dynibo::Frame {
    let mut t = dynibo::Frame::identity().translation.vector;
    let mut aa = t;
    let v = x.translation.vector;
    let w = x.rotation.scaled_axis();
    for k in 0..3 {
        t[k] = v[k];
        aa[k] = w[k];
    }
    dynibo::Frame::new(t, aa)
}

/// Largest relative errors of one comparison run, per quantity.
#[derive(Debug, Default)]
struct DyniboErrors {
    pose: f64,
    m: f64,
    rnea: f64,
    rnea_wrench: f64,
    gravity: f64,
    cqd: f64,
    aba: f64,
    jacobian: f64,
    jdqd: f64,
}

impl std::fmt::Display for DyniboErrors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pose {:.1e}, M {:.1e}, RNEA {:.1e}, RNEA+F_T {:.1e}, g {:.1e}, C q̇ {:.1e}, ABA {:.1e}, J {:.1e}, J̇ q̇ {:.1e}",
            self.pose,
            self.m,
            self.rnea,
            self.rnea_wrench,
            self.gravity,
            self.cqd,
            self.aba,
            self.jacobian,
            self.jdqd
        )
    }
}

impl DyniboErrors {
    fn max(&self) -> f64 {
        [
            self.pose,
            self.m,
            self.rnea,
            self.rnea_wrench,
            self.gravity,
            self.cqd,
            self.aba,
            self.jacobian,
            self.jdqd,
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// Compare `arm` with dynibo loaded from `urdf` at `cases` random states: `M`, RNEA (with and
/// without a tool wrench), `g`, `C q̇`, ABA, the tool pose, `J` and `J̇ q̇`, all relative to the
/// quantity's scale (max |·|, floor 1). `tool_link` names the URDF link whose origin is the
/// arm's tool frame; the arm's joint names must be dynibo's; dynibo's root link is placed at
/// `dynibo_base` (usually `arm.base`). This is the entry point for file cases, e.g. once the
/// URDF loader lands:
///
/// ```ignore
/// let arm = SpatialArm { chain: /* loaded from models/ur5.urdf, base → tool0 */, base };
/// let e = dynibo_check_file(&arm, Path::new("models/ur5.urdf"), "tool0", &arm.base, 7, 50);
/// assert!(e.max() < 1e-10, "{e:?}");
/// ```
fn dynibo_check_file(
    arm: &SpatialArm,
    urdf: &std::path::Path,
    tool_link: &str,
    dynibo_base: &Isometry3<f64>,
    seed: u64,
    cases: usize,
) -> DyniboErrors {
    let mut robot = dynibo::Robot::from_urdf(urdf).expect("dynibo loads the URDF");
    robot.set_base_frame(to_dynibo_frame(dynibo_base)).unwrap();
    let tool = robot.link_id(tool_link).unwrap();
    let n = arm.chain.dof();
    let gn = robot.joint_count();
    let idx: Vec<usize> = arm
        .chain
        .joints
        .iter()
        .map(|j| {
            (0..gn)
                .find(|&i| robot.joint_name(i).unwrap() == j.name)
                .unwrap_or_else(|| panic!("dynibo has no joint {}", j.name))
        })
        .collect();
    let to_g = |x: &[f64]| {
        let mut y = vec![0.0; gn];
        for k in 0..n {
            y[idx[k]] = x[k];
        }
        y
    };
    let from_g = |y: &[f64]| -> Vec<f64> { (0..n).map(|k| y[idx[k]]).collect() };

    let g = g_down();
    let mut d = ChainData::new(arm);
    let mut rng = SplitMix64(seed);
    let mut e = DyniboErrors::default();
    let mut out = vec![0.0; gn];
    let mut mass = vec![0.0; gn * gn];
    let mut jac = vec![0.0; 6 * gn];
    let mut jdot = vec![0.0; 6 * gn];
    for _ in 0..cases {
        let s = random_state(&mut rng, n);
        let (q, qd, qdd, tau) = (to_g(&s.q), to_g(&s.qd), to_g(&s.qdd), to_g(&s.tau));

        // Poses.
        spatial::terms(arm, &s.q, &s.qd, &g, &mut d);
        let x = robot.forward_kinematics(&q, tool).unwrap().to_homogeneous();
        let ours = d.X_WT.to_homogeneous();
        let xs: Vec<f64> = (0..12).map(|i| x[(i % 3, i / 3)]).collect();
        let os: Vec<f64> = (0..12).map(|i| ours[(i % 3, i / 3)]).collect();
        e.pose = e.pose.max(rel_err(&os, &xs, 1.0));

        // M.
        robot.mass_matrix(&q, &mut mass).unwrap();
        let m_ref: Vec<f64> = (0..n * n)
            .map(|c| mass[idx[c / n] * gn + idx[c % n]])
            .collect();
        e.m = e.m.max(rel_err(d.M.as_slice(), &m_ref, 1.0));

        // C q̇ and g.
        robot.velocity_product_forces(&q, &qd, &mut out).unwrap();
        let cqd_ref = from_g(&out);
        robot.gravity(&q, &[], &mut out).unwrap();
        let g_ref = from_g(&out);
        let mut gv = vec![0.0; n];
        spatial::gravity(arm, &s.q, &g, &mut gv, &mut d);
        e.gravity = e.gravity.max(rel_err(&gv, &g_ref, 1.0));
        spatial::terms(arm, &s.q, &s.qd, &g, &mut d);
        let cqd: Vec<f64> = (0..n).map(|k| d.bias[k] - gv[k]).collect();
        e.cqd = e.cqd.max(rel_err(&cqd, &cqd_ref, 1.0));

        // Jacobian and J̇ q̇ at the tool, angular-first rows swapped.
        robot.jacobian(&q, tool, &mut jac).unwrap();
        robot.jacobian_derivative(&q, &qd, tool, &mut jdot).unwrap();
        let mut j_ref = vec![0.0; 6 * n];
        let mut jdqd_ref = [0.0; 6];
        for k in 0..n {
            for r in 0..6 {
                let rr = (r + 3) % 6;
                j_ref[6 * k + r] = jac[6 * idx[k] + rr];
            }
        }
        for r in 0..6 {
            let rr = (r + 3) % 6;
            jdqd_ref[r] = (0..gn).map(|c| jdot[6 * c + rr] * qd[c]).sum();
        }
        e.jacobian = e.jacobian.max(rel_err(d.J.as_slice(), &j_ref, 1.0));
        e.jdqd = e.jdqd.max(rel_err(d.jdqd.as_slice(), &jdqd_ref, 1.0));

        // RNEA, without and with a tool wrench.
        robot
            .inverse_dynamics(&q, &qd, &qdd, &[], &mut out)
            .unwrap();
        let t_ours = rnea_vec(arm, &s.q, &s.qd, &s.qdd, &g, None, &mut d);
        e.rnea = e.rnea.max(rel_err(&t_ours, &from_g(&out), 1.0));
        let r_wt = d.X_WT.rotation;
        let f_loc = r_wt.inverse() * Vector3::new(s.f_t[0], s.f_t[1], s.f_t[2]);
        let t_loc = r_wt.inverse() * Vector3::new(s.f_t[3], s.f_t[4], s.f_t[5]);
        let mut w = dynibo::Wrench::zeros();
        for k in 0..3 {
            w.force[k] = -f_loc[k];
            w.torque[k] = -t_loc[k];
        }
        let loads = [dynibo::IndexedLoad {
            link: tool,
            wrench: w,
        }];
        robot
            .inverse_dynamics(&q, &qd, &qdd, &loads, &mut out)
            .unwrap();
        let t_ours = rnea_vec(arm, &s.q, &s.qd, &s.qdd, &g, Some(&s.f_t), &mut d);
        e.rnea_wrench = e.rnea_wrench.max(rel_err(&t_ours, &from_g(&out), 1.0));

        // ABA, with the tool wrench.
        robot
            .forward_dynamics(&q, &qd, &tau, &loads, &mut out)
            .unwrap();
        let mut a = vec![0.0; n];
        spatial::aba(arm, &s.q, &s.qd, &s.tau, &g, Some(&s.f_t), &mut a, &mut d);
        e.aba = e.aba.max(rel_err(&a, &from_g(&out), 1.0));
    }
    e
}

#[test]
fn dynibo_agrees_on_random_6_and_7_dof_chains() {
    // Random chains (rpy origins, oblique axes, prismatic joints, random inertias), written as
    // URDF with the base absorbed into the first joint; each compared on 20 states. Both
    // libraries round differently (quaternions vs matrices, world vs local recursions):
    // agreement is rounding-limited; tolerance 1e-10 relative to each quantity's scale.
    let mut rng = SplitMix64(401);
    let mut worst = DyniboErrors::default();
    for (c, &(n, prismatic)) in [(6, false), (7, false), (6, true), (7, true), (7, false)]
        .iter()
        .enumerate()
    {
        let arm = SpatialArm {
            chain: random_chain(&mut rng, n, prismatic),
            base: random_base(&mut rng),
        };
        // (1) base at identity: the absorbing chain against its own URDF;
        // (2) our base pose X_WB against dynibo's root at identity with the base absorbed into
        //     the first joint (brief: the base placement must equal an absorbing chain);
        // (3) our base pose against dynibo's own base frame set to X_WB.
        let abs = absorb_base(&arm);
        let path = write_urdf(&abs.chain, &format!("random{c}"));
        let e1 = dynibo_check_file(
            &abs,
            &path,
            "tool",
            &Isometry3::identity(),
            10 + c as u64,
            20,
        );
        let e2 = dynibo_check_file(
            &arm,
            &path,
            "tool",
            &Isometry3::identity(),
            20 + c as u64,
            20,
        );
        let path_b = write_urdf(&arm.chain, &format!("random{c}-base"));
        let e3 = dynibo_check_file(&arm, &path_b, "tool", &arm.base, 30 + c as u64, 20);
        std::fs::remove_file(&path).ok();
        std::fs::remove_file(&path_b).ok();
        for e in [&e1, &e2, &e3] {
            assert!(e.max() < 1e-10, "chain {c} (n = {n}): {e}");
            worst.pose = worst.pose.max(e.pose);
            worst.m = worst.m.max(e.m);
            worst.rnea = worst.rnea.max(e.rnea);
            worst.rnea_wrench = worst.rnea_wrench.max(e.rnea_wrench);
            worst.gravity = worst.gravity.max(e.gravity);
            worst.cqd = worst.cqd.max(e.cqd);
            worst.aba = worst.aba.max(e.aba);
            worst.jacobian = worst.jacobian.max(e.jacobian);
            worst.jdqd = worst.jdqd.max(e.jdqd);
        }
    }
    println!("dynibo, random chains: {worst}");
}

#[test]
fn dynibo_agrees_on_the_panda_and_ur5_like_arms() {
    // The benchmark's 7- and 6-DOF models (modified-DH placements, axis z), at a non-identity
    // base set in dynibo as its base frame.
    let mut rng = SplitMix64(402);
    for chain in [panda_like(), ur5_like()] {
        let arm = SpatialArm {
            chain,
            base: random_base(&mut rng),
        };
        let path = write_urdf(&arm.chain, &arm.chain.name);
        let e = dynibo_check_file(&arm, &path, "tool", &arm.base, 5, 50);
        std::fs::remove_file(&path).ok();
        println!("dynibo, {}: {e}", arm.chain.name);
        assert!(e.max() < 1e-10, "{e}");
    }
}

/// tandem's own model files (SPEC-spatial S2), read by tandem's URDF loader and by dynibo's
/// (urdf-rs) from the same file, at a non-identity base: every quantity agrees to ≤ 1e-10.
#[test]
fn dynibo_agrees_on_the_embedded_ur5_and_franka_models() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut rng = SplitMix64(77);
    for (file, chain, tool) in [
        (
            "ur5.urdf",
            tandem::model::spatial::urdf::ur5(),
            tandem::model::spatial::urdf::UR5_TOOL,
        ),
        (
            "franka.urdf",
            tandem::model::spatial::urdf::franka(),
            tandem::model::spatial::urdf::FRANKA_TOOL,
        ),
    ] {
        let arm = SpatialArm {
            chain,
            base: random_base(&mut rng),
        };
        let e = dynibo_check_file(&arm, &dir.join(file), tool, &arm.base, 11, 100);
        println!("dynibo, {file}: {e}");
        assert!(e.max() < 1e-10, "{file}: {e}");
    }
}

/// SPEC Table I's 2-link arm written as a URDF (`tests/data/planar2.urdf`: joint axes along z,
/// links along x) and read by tandem's loader, with gravity in the plane (−y, 9.8): M, C q̇ + G,
/// G, the in-plane Jacobian, J̇ q̇, the tip and RNEA with a tip force equal SPEC §2.1's closed
/// forms to 1e-12 relative (only I_zz enters the plane; the file's I_xx, I_yy make the tensor
/// positive definite and cannot couple in: no out-of-plane motion).
#[test]
fn planar_arm_from_urdf_reproduces_the_closed_forms() {
    let text = include_str!("data/planar2.urdf");
    let (chain, warnings) = tandem::model::spatial::urdf::load_chain(text, "base", "tool").unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let g = tandem::model::planar::arm::GRAVITY;
    let g_w = Vector3::new(0.0, -g, 0.0);
    let mut rng = SplitMix64(911);
    for elbow in [Elbow::Positive, Elbow::Negative] {
        let p = ArmParams::paper([0.38, 0.0], elbow);
        let planar = Arm::new("arm", &p).unwrap();
        let sp = SpatialArm {
            chain: chain.clone(),
            base: Isometry3::translation(0.38, 0.0, 0.0),
        };
        let mut t = planar.terms();
        let mut d = ChainData::new(&sp);
        let mut gv = vec![0.0; 2];
        for _ in 0..50 {
            let s = random_state(&mut rng, 2);
            planar.dynamics(&s.q, &s.qd, g, &mut t);
            spatial::terms(&sp, &s.q, &s.qd, &g_w, &mut d);
            spatial::gravity(&sp, &s.q, &g_w, &mut gv, &mut d);
            let check = |what: &str, a: &[f64], b: &[f64]| {
                let e = rel_err(a, b, 1e-3);
                assert!(e < 1e-12, "{what}: {e:e}\n{a:?}\n{b:?}");
            };
            check("M", d.M.as_slice(), t.M.as_slice());
            let cq = &t.C * DVector::from_column_slice(&s.qd);
            let b_want: Vec<f64> = cq.iter().zip(t.G.iter()).map(|(a, b)| a + b).collect();
            check("C q̇ + G", d.bias.as_slice(), &b_want);
            check("G", &gv, t.G.as_slice());
            let j_xy: Vec<f64> = (0..2).flat_map(|k| [d.J[(0, k)], d.J[(1, k)]]).collect();
            check("J", &j_xy, t.J.as_slice());
            check("J̇ q̇", &[d.jdqd[0], d.jdqd[1]], t.jdot_qdot.as_slice());
            let p_t = d.X_WT.translation.vector;
            check("p_ee", &[p_t.x, p_t.y], t.p_ee.as_slice());
            let f = nalgebra::Vector2::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
            let mut tau_p = vec![0.0; 2];
            planar.rnea(&s.q, &s.qd, &s.qdd, f, g, &mut t, &mut tau_p);
            let f6 = Vector6::new(f.x, f.y, 0.0, 0.0, 0.0, 0.0);
            let tau_s = rnea_vec(&sp, &s.q, &s.qd, &s.qdd, &g_w, Some(&f6), &mut d);
            check("RNEA", &tau_s, &tau_p);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Robustness
// ---------------------------------------------------------------------------------------------

#[test]
fn large_finite_inputs_give_finite_outputs() {
    // Joint angles far outside ±π (up to 1e9 rad: the trigonometry's range reduction and its
    // fallback), fast joints, large torques and wrenches: every output finite. Prismatic joints
    // stay within ±2 m (a slider at 1e9 m is not a physical input).
    let mut rng = SplitMix64(501);
    for arm in test_arms(500) {
        let n = arm.chain.dof();
        let mut d = ChainData::new(&arm);
        let g = g_down();
        let mut c = DMatrix::zeros(n, n);
        for scale in [1.0, 1e3, 1e6] {
            let mut q = rng.vec(n, 1e3 * scale);
            for (qk, j) in q.iter_mut().zip(&arm.chain.joints) {
                if j.kind == JointKind::Prismatic {
                    *qk = qk.rem_euclid(4.0) - 2.0;
                }
            }
            let qd = rng.vec(n, 50.0);
            let qdd = rng.vec(n, 1e3);
            let tau = rng.vec(n, 1e4);
            let f = Vector6::from_fn(|_, _| rng.range(-1e4, 1e4));
            let mut out = vec![0.0; n];
            let t = rnea_vec(&arm, &q, &qd, &qdd, &g, Some(&f), &mut d);
            assert!(t.iter().all(|v| v.is_finite()));
            spatial::aba(&arm, &q, &qd, &tau, &g, Some(&f), &mut out, &mut d);
            assert!(out.iter().all(|v| v.is_finite()));
            spatial::forward_dynamics(&arm, &q, &qd, &tau, &g, Some(&f), &mut out, &mut d);
            assert!(out.iter().all(|v| v.is_finite()));
            spatial::terms(&arm, &q, &qd, &g, &mut d);
            assert!(
                d.M.iter()
                    .chain(d.bias.iter())
                    .chain(d.J.iter())
                    .all(|v| v.is_finite())
            );
            assert!(d.jdqd.iter().all(|v| v.is_finite()));
            spatial::coriolis_matrix(&arm, &q, &qd, &mut c, &mut d);
            assert!(c.iter().all(|v| v.is_finite()));
            let (te, ue) = spatial::energy(&arm, &q, &qd, &g, &mut d);
            assert!(te.is_finite() && ue.is_finite());
            assert_eq!(d.singular_pivots(), 0);
        }
    }
}

#[test]
fn invalid_massless_chain_does_not_panic_or_give_nan() {
    // `Chain::validate` rejects massless moving bodies; the algorithms must still neither
    // panic nor produce NaN, and must count the singular pivots.
    let mut rng = SplitMix64(502);
    let mut chain = random_chain(&mut rng, 6, true);
    for b in chain.bodies.iter_mut().skip(3) {
        *b = RigidBody::massless(b.name.clone());
    }
    let mut all_massless = chain.clone();
    for b in all_massless.bodies.iter_mut() {
        *b = RigidBody::massless(b.name.clone());
    }
    for chain in [chain, all_massless] {
        assert!(chain.validate().is_err());
        let arm = at_identity(chain);
        let mut d = ChainData::new(&arm);
        let s = random_state(&mut rng, 6);
        let mut out = vec![0.0; 6];
        spatial::aba(
            &arm,
            &s.q,
            &s.qd,
            &s.tau,
            &g_down(),
            Some(&s.f_t),
            &mut out,
            &mut d,
        );
        assert!(out.iter().all(|v| v.is_finite()), "{out:?}");
        spatial::forward_dynamics(&arm, &s.q, &s.qd, &s.tau, &g_down(), None, &mut out, &mut d);
        assert!(out.iter().all(|v| v.is_finite()), "{out:?}");
        assert!(d.singular_pivots() > 0);
    }
}
