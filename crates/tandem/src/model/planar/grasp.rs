//! Grasps: where each arm holds the object, SPEC §2.3 and paper (11).
//!
//! Arm `i` holds the object at `r_i` (object frame). In the plane the end-effector is pinned:
//! position tied, rotation free,
//!
//! $$x_i = p_o + R(θ) r_i, \qquad J_i(x_o) = [\,I_2 \mid (R(θ) r_i)^\perp\,] \in \mathbb R^{2×3},$$
//!
//! and the wrench the arms put on the object is `F_o = −Jᵀ F_e` (SPEC erratum: the paper prints
//! `−J F_e`), with `F_e` the stacked forces the object exerts on the end-effectors.

use nalgebra::{Matrix2x3, Rotation2, Vector2, Vector3};

/// One grasp point `r_i` in the object frame, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grasp {
    /// `p_OGi`: grasp point in the object frame, m.
    pub r: Vector2<f64>,
}

#[inline]
fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

impl Grasp {
    /// Grasp point in the world, `p_o + R(θ) r_i`, m.
    pub fn point(&self, x_o: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(x_o.x, x_o.y) + crate::math::trig::rotation2(x_o.z) * self.r
    }
    /// `R(θ) r_i`, m.
    pub fn arm_w(&self, theta: f64) -> Vector2<f64> {
        crate::math::trig::rotation2(theta) * self.r
    }
    /// Grasp Jacobian `J_i(θ)` (2 × 3): `ẋ_i = J_i ẋ_o`.
    pub fn jacobian(&self, theta: f64) -> Matrix2x3<f64> {
        Self::jacobian_from_arm(self.arm_w(theta))
    }
    /// `J_i` from a precomputed `R(θ) r_i` (saves the trigonometry in a hot loop).
    pub fn jacobian_from_arm(rw: Vector2<f64>) -> Matrix2x3<f64> {
        let d = perp(rw);
        Matrix2x3::new(1.0, 0.0, d.x, 0.0, 1.0, d.y)
    }
    /// `J̇_i ẋ_o = −R(θ) r_i θ̇²`, m/s².
    pub fn jdot_xdot(&self, theta: f64, theta_dot: f64) -> Vector2<f64> {
        -self.arm_w(theta) * theta_dot * theta_dot
    }
}

/// Least-squares object pose from end-effector positions through the grasps (2-D Procrustes):
/// minimises `Σ |p + R(θ) r_i − x_i|²`. Used by controllers to estimate `x_o` from encoders
/// (SPEC §2.5) and to fit the object-level reference `x_r` to the arms' references (SPEC §3.1).
/// With two symmetric grasps this is the midpoint and the direction angle. `θ` is returned on
/// the branch nearest `theta_hint` (so it is continuous along a run).
pub fn fit_pose(grasps: &[Grasp], points: &[Vector2<f64>], theta_hint: f64) -> Vector3<f64> {
    fit_pose_rot(grasps, points, theta_hint).0
}

/// [`fit_pose`], also returning `R(θ)` (from the fit's cosine and sine: no trigonometry).
pub fn fit_pose_rot(
    grasps: &[Grasp],
    points: &[Vector2<f64>],
    theta_hint: f64,
) -> (Vector3<f64>, Rotation2<f64>) {
    let r_bar = grasps.iter().map(|g| g.r).sum::<Vector2<f64>>() / grasps.len() as f64;
    procrustes(
        grasps.iter().map(|g| g.r - r_bar),
        r_bar,
        points,
        theta_hint,
    )
}

/// The 2-D Procrustes fit behind [`fit_pose_rot`] and [`GraspSet::fit_pose`], from the centred
/// grasp points `a_i = r_i − r̄`: with `b_i = x_i − x̄`, `θ = atan2(Σ a_i×b_i, Σ a_i·b_i)` on the
/// branch nearest `theta_hint`, `R(θ)` from the same cosine and sine (no trigonometry),
/// `p = x̄ − R r̄`.
#[inline]
fn procrustes(
    centred: impl Iterator<Item = Vector2<f64>>,
    r_bar: Vector2<f64>,
    points: &[Vector2<f64>],
    theta_hint: f64,
) -> (Vector3<f64>, Rotation2<f64>) {
    let xbar = mean(points, points.len());
    let (mut s, mut c) = (0.0, 0.0);
    for (a, x) in centred.zip(points) {
        let b = x - xbar;
        c += a.dot(&b);
        s += a.x * b.y - a.y * b.x;
    }
    procrustes_finish(s, c, xbar, r_bar, theta_hint)
}

/// `Σ v_i / n`. With `n` a power of two (the usual pair of grasps) by the reciprocal, which is
/// then exact: `x/n` and `x·(1/n)` are the same real number, rounded once, so the same bits
/// without a division.
#[inline(always)]
fn mean(v: &[Vector2<f64>], n: usize) -> Vector2<f64> {
    let sum = v.iter().sum::<Vector2<f64>>();
    if n.is_power_of_two() {
        sum * (1.0 / n as f64)
    } else {
        sum / n as f64
    }
}

/// The end of [`procrustes`] from its sums `s = Σ a_i×b_i`, `c = Σ a_i·b_i` and the mean point
/// `x̄`: `θ = atan2(s, c)` on the branch nearest `theta_hint`, `R(θ)` from `(c, s)`,
/// `p = x̄ − R r̄` (shared with [`GraspSet::fit_pose_rates`], which forms the sums itself).
#[inline(always)]
fn procrustes_finish(
    s: f64,
    c: f64,
    xbar: Vector2<f64>,
    r_bar: Vector2<f64>,
    theta_hint: f64,
) -> (Vector3<f64>, Rotation2<f64>) {
    let mut theta = s.atan2(c);
    // Unwrap toward the hint (a run moves far less than π between calls).
    let (pi, tau) = (std::f64::consts::PI, std::f64::consts::TAU);
    // In closed form: a loop of ±2π steps never ends for a huge hint (the step is lost).
    if theta_hint.is_finite() && (theta - theta_hint).abs() > pi {
        theta += tau * ((theta_hint - theta) / tau).round();
    }
    let h2 = s * s + c * c;
    let rot = if h2 > 0.0 {
        let k = 1.0 / h2.sqrt();
        Rotation2::from_matrix_unchecked(nalgebra::Matrix2::new(c * k, -s * k, s * k, c * k))
    } else {
        Rotation2::identity()
    };
    let p = xbar - rot * r_bar;
    (Vector3::new(p.x, p.y, theta), rot)
}

/// `𝐉ᵀ𝐉 = Σ J_iᵀ J_i` for pinned grasps with world arms `ρ_i = R(θ) r_i`: the structured matrix
/// `[[m, 0, a], [0, m, b], [a, b, c]]` with `(a, b) = Σ ρ_i^⊥`, `c = Σ |ρ_i|²`, solved by
/// eliminating the two translations (no factorisation, no square root).
#[derive(Clone, Copy, Debug)]
struct Gram {
    m: f64,
    a: f64,
    b: f64,
    /// Schur complement `c − (a² + b²)/m` (> 0 unless every grasp point coincides).
    schur: f64,
}

impl Gram {
    fn new(grasps: &[Grasp], rot: &Rotation2<f64>) -> Option<Self> {
        let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
        for g in grasps {
            let d = perp(rot * g.r);
            a += d.x;
            b += d.y;
            c += d.norm_squared();
        }
        let m = grasps.len() as f64;
        if m == 0.0 {
            return None;
        }
        let schur = c - (a * a + b * b) / m;
        (schur > 1e-12 * c).then_some(Gram { m, a, b, schur })
    }
    fn solve(&self, v: &Vector3<f64>) -> Vector3<f64> {
        let z = (v.z - (self.a * v.x + self.b * v.y) / self.m) / self.schur;
        Vector3::new((v.x - self.a * z) / self.m, (v.y - self.b * z) / self.m, z)
    }
}

/// Least-squares object velocity from end-effector velocities: `ẋ_o = (Σ J_iᵀJ_i)⁻¹ Σ J_iᵀ ẋ_i`.
/// Returns `None` if the grasps do not determine the object's motion (fewer than two distinct
/// points).
pub fn fit_velocity(grasps: &[Grasp], theta: f64, vels: &[Vector2<f64>]) -> Option<Vector3<f64>> {
    fit_velocity_rot(grasps, &crate::math::trig::rotation2(theta), vels)
}

/// [`fit_velocity`] with `R(θ)` given.
pub fn fit_velocity_rot(
    grasps: &[Grasp],
    rot: &Rotation2<f64>,
    vels: &[Vector2<f64>],
) -> Option<Vector3<f64>> {
    let gram = Gram::new(grasps, rot)?;
    let mut b = Vector3::zeros();
    for (g, v) in grasps.iter().zip(vels) {
        b += Grasp::jacobian_from_arm(rot * g.r).transpose() * v;
    }
    Some(gram.solve(&b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_grasp_jacobians_match_the_paper() {
        // Paper Section V-A: J_1 = [1 0 (l_o/2) sinθ; 0 1 −(l_o/2) cosθ], J_2 with opposite signs.
        let lo = 0.1;
        let g1 = Grasp {
            r: Vector2::new(-lo / 2.0, 0.0),
        };
        let g2 = Grasp {
            r: Vector2::new(lo / 2.0, 0.0),
        };
        let th: f64 = 0.3;
        let j1 = g1.jacobian(th);
        let j2 = g2.jacobian(th);
        assert!((j1[(0, 2)] - lo / 2.0 * th.sin()).abs() < 1e-16);
        assert!((j1[(1, 2)] + lo / 2.0 * th.cos()).abs() < 1e-16);
        assert!((j2[(0, 2)] + lo / 2.0 * th.sin()).abs() < 1e-16);
        assert!((j2[(1, 2)] - lo / 2.0 * th.cos()).abs() < 1e-16);
    }

    #[test]
    fn grasp_jacobian_and_bias_match_finite_differences() {
        let g = Grasp {
            r: Vector2::new(0.07, -0.02),
        };
        let x = Vector3::new(0.1, -0.2, 0.4);
        let xd = Vector3::new(0.3, -0.1, 1.7);
        let h = 1e-6;
        let fd = (g.point(&(x + h * xd)) - g.point(&(x - h * xd))) / (2.0 * h);
        assert!((g.jacobian(x.z) * xd - fd).norm() < 1e-9);
        // d/dt (J ẋ) at constant ẋ equals J̇ ẋ.
        let fd2 = (g.jacobian(x.z + h * xd.z) * xd - g.jacobian(x.z - h * xd.z) * xd) / (2.0 * h);
        assert!((g.jdot_xdot(x.z, xd.z) - fd2).norm() < 1e-8);
    }

    #[test]
    fn pose_and_velocity_fit_invert_the_grasp_map() {
        let gs = [
            Grasp {
                r: Vector2::new(-0.05, 0.0),
            },
            Grasp {
                r: Vector2::new(0.05, 0.01),
            },
            Grasp {
                r: Vector2::new(0.0, 0.04),
            },
        ];
        let x = Vector3::new(0.12, 0.3, -2.9);
        let xd = Vector3::new(-0.2, 0.5, 0.8);
        let pts: Vec<_> = gs.iter().map(|g| g.point(&x)).collect();
        let vs: Vec<_> = gs.iter().map(|g| g.jacobian(x.z) * xd).collect();
        let est = fit_pose(&gs, &pts, -3.0);
        assert!((est - x).norm() < 1e-13, "{est} vs {x}");
        let vest = fit_velocity(&gs, x.z, &vs).unwrap();
        assert!((vest - xd).norm() < 1e-13);
    }
}

/// Distribution of an object wrench over the arms (SPEC §3.2):
/// `τ_x = (𝐉ᵀ)⁺ τ + P_N λ`, where `𝐉` stacks the grasp Jacobians, `(𝐉ᵀ)⁺ = 𝐉(𝐉ᵀ𝐉)⁻¹` gives the
/// minimum-norm share and `P_N = I − 𝐉(𝐉ᵀ𝐉)⁻¹𝐉ᵀ` projects onto the null space of `𝐉ᵀ`
/// (internal forces, which do not move the object). `τ_x,i` is the force arm `i` applies to the
/// object, so `𝐉ᵀ τ_x = τ` exactly.
///
/// `squeeze` is the internal force magnitude `s` (N): arm `i` pushes toward the object centre
/// with `−s R(θ) r̂_i`, projected onto the null space. Writes one 2-vector per arm into `out`.
/// Returns `false` if `𝐉ᵀ𝐉` is singular (fewer than two distinct grasp points).
pub fn distribute_wrench(
    grasps: &[Grasp],
    theta: f64,
    tau: &Vector3<f64>,
    squeeze: f64,
    out: &mut [Vector2<f64>],
) -> bool {
    distribute_wrench_rot(
        grasps,
        &crate::math::trig::rotation2(theta),
        tau,
        squeeze,
        out,
    )
}

/// [`distribute_wrench`] with `R(θ)` given.
pub fn distribute_wrench_rot(
    grasps: &[Grasp],
    rot: &Rotation2<f64>,
    tau: &Vector3<f64>,
    squeeze: f64,
    out: &mut [Vector2<f64>],
) -> bool {
    let Some(gram) = Gram::new(grasps, rot) else {
        return false;
    };
    // Minimum-norm share: τ_x,i = J_i (𝐉ᵀ𝐉)⁻¹ τ.
    let w = gram.solve(tau);
    // Squeeze λ_i = −s R r̂_i; its range-space part 𝐉(𝐉ᵀ𝐉)⁻¹𝐉ᵀλ is removed.
    let squeeze_of = |rw: Vector2<f64>| {
        let n = rw.norm();
        if n > 0.0 {
            -squeeze * rw / n
        } else {
            Vector2::zeros()
        }
    };
    let mut jt_lambda = Vector3::zeros();
    if squeeze != 0.0 {
        for g in grasps {
            let rw = rot * g.r;
            jt_lambda += Grasp::jacobian_from_arm(rw).transpose() * squeeze_of(rw);
        }
    }
    let v = gram.solve(&jt_lambda);
    for (g, o) in grasps.iter().zip(out.iter_mut()) {
        let rw = rot * g.r;
        let j = Grasp::jacobian_from_arm(rw);
        let lam = if squeeze != 0.0 {
            squeeze_of(rw)
        } else {
            Vector2::zeros()
        };
        *o = j * (w - v) + lam;
    }
    true
}

/// Two symmetric grasps (the paper's) and three uneven ones, for the tests below.
#[cfg(test)]
fn test_grasp_sets() -> [Vec<Grasp>; 2] {
    let g = |x, y| Grasp {
        r: Vector2::new(x, y),
    };
    [
        vec![g(-0.05, 0.0), g(0.05, 0.0)],
        vec![g(-0.05, 0.0), g(0.05, 0.01), g(0.0, -0.025)],
    ]
}

#[cfg(test)]
mod distribution_tests {
    use super::*;

    #[test]
    fn distributed_wrench_reproduces_tau_and_squeeze_is_internal() {
        for grasps in test_grasp_sets() {
            let tau = Vector3::new(1.5, 9.8, -0.3);
            let mut out = vec![Vector2::zeros(); grasps.len()];
            let mut sq = vec![Vector2::zeros(); grasps.len()];
            assert!(distribute_wrench(&grasps, 0.4, &tau, 0.0, &mut out));
            assert!(distribute_wrench(&grasps, 0.4, &tau, 5.0, &mut sq));
            let jt = |f: &[Vector2<f64>]| {
                grasps.iter().zip(f).fold(Vector3::zeros(), |a, (g, x)| {
                    a + g.jacobian(0.4).transpose() * x
                })
            };
            // 𝐉ᵀ τ_x = τ to round-off, with and without squeeze.
            assert!((jt(&out) - tau).norm() < 1e-13);
            assert!((jt(&sq) - tau).norm() < 1e-13);
            // The squeeze part lies in the null space of 𝐉ᵀ and is not zero.
            let diff: Vec<_> = out.iter().zip(&sq).map(|(a, b)| b - a).collect();
            assert!(jt(&diff).norm() < 1e-13);
            assert!(diff.iter().map(|d| d.norm()).sum::<f64>() > 1.0);
        }
    }
}

/// The grasp maps a controller needs every tick, precomputed once in the object frame.
///
/// The least-squares velocity fit and the wrench distribution are rotation-covariant: turning
/// the whole scene by `θ` turns every force and velocity with it. So both are built once at
/// `θ = 0` — per grasp a 3 × 2 fit block, a 2 × 3 share block and the null-space squeeze
/// direction — and a tick only rotates into and out of the object frame: a few multiplies
/// instead of a Gram matrix solve, square roots and divisions per grasp.
#[derive(Clone, Debug)]
pub struct GraspSet {
    grasps: Vec<Grasp>,
    /// `ẋ_o^O = Σ_i fit_i · (Rᵀ ẋ_i)` (then the linear part rotated back).
    fit: Vec<nalgebra::Matrix3x2<f64>>,
    /// `τ_x,i^O = share_i · τ^O` (minimum-norm share).
    share: Vec<Matrix2x3<f64>>,
    /// Null-space squeeze per newton of squeeze, object frame.
    squeeze: Vec<Vector2<f64>>,
    /// Mean grasp point `r̄` and the centred points `r_i − r̄` (pose fit).
    r_bar: Vector2<f64>,
    centred: Vec<Vector2<f64>>,
}

impl GraspSet {
    /// Precompute the maps; `None` if the grasps do not determine the object's motion.
    pub fn new(grasps: Vec<Grasp>) -> Option<Self> {
        let m = grasps.len();
        let id = Rotation2::identity();
        let mut fit = vec![nalgebra::Matrix3x2::zeros(); m];
        let mut vels = vec![Vector2::zeros(); m];
        for i in 0..m {
            for k in 0..2 {
                vels.iter_mut().for_each(|v| *v = Vector2::zeros());
                vels[i][k] = 1.0;
                fit[i].set_column(k, &fit_velocity_rot(&grasps, &id, &vels)?);
            }
        }
        let mut share = vec![Matrix2x3::zeros(); m];
        let mut out = vec![Vector2::zeros(); m];
        for k in 0..3 {
            let mut tau = Vector3::zeros();
            tau[k] = 1.0;
            if !distribute_wrench_rot(&grasps, &id, &tau, 0.0, &mut out) {
                return None;
            }
            for i in 0..m {
                share[i].set_column(k, &out[i]);
            }
        }
        let mut squeeze = vec![Vector2::zeros(); m];
        distribute_wrench_rot(&grasps, &id, &Vector3::zeros(), 1.0, &mut squeeze);
        let r_bar = grasps.iter().map(|g| g.r).sum::<Vector2<f64>>() / m as f64;
        let centred = grasps.iter().map(|g| g.r - r_bar).collect();
        Some(GraspSet {
            grasps,
            fit,
            share,
            squeeze,
            r_bar,
            centred,
        })
    }

    /// The grasps.
    pub fn grasps(&self) -> &[Grasp] {
        &self.grasps
    }

    /// [`fit_pose_rot`] with the centred grasp points precomputed (no `hypot`, no `round`).
    #[inline]
    pub fn fit_pose(
        &self,
        points: &[Vector2<f64>],
        theta_hint: f64,
    ) -> (Vector3<f64>, Rotation2<f64>) {
        procrustes(self.centred.iter().copied(), self.r_bar, points, theta_hint)
    }

    /// The pose fit and its exact first and second time derivatives, for points that need not
    /// move rigidly (the arms' admittance references): with `b_i = x_i − x̄`, `c = Σ a_i·b_i`,
    /// `s = Σ a_i×b_i` (`a_i` the centred grasp points), `θ = atan2(s, c)`,
    /// `θ̇ = (c ṡ − s ċ)/(c² + s²)`, `θ̈ = (c s̈ − s c̈)/(c² + s²) − θ̇·2(c ċ + s ṡ)/(c² + s²)`,
    /// `p = x̄ − R r̄`, `ṗ = x̄̇ − (R r̄)^⊥ θ̇`, `p̈ = x̄̈ − (R r̄)^⊥ θ̈ + R r̄ θ̇²`.
    /// (The least-squares velocity fit [`GraspSet::fit_velocity`] is the same for a rigid set
    /// but not for a deforming one.) Returns `(x, ẋ, ẍ, R(θ))`.
    pub fn fit_pose_rates(
        &self,
        points: &[Vector2<f64>],
        vels: &[Vector2<f64>],
        accs: &[Vector2<f64>],
        theta_hint: f64,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>, Rotation2<f64>) {
        // One pass forms the pose fit's sums `c`, `s` (the same operations as [`procrustes`],
        // so the same bits as [`GraspSet::fit_pose`]) and their rates.
        let n = points.len();
        let (xbar, vbar, abar) = (mean(points, n), mean(vels, n), mean(accs, n));
        let (mut c, mut s, mut cd, mut sd, mut cdd, mut sdd) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (((a, p), v), ac) in self.centred.iter().zip(points).zip(vels).zip(accs) {
            let (b, bd, bdd) = (p - xbar, v - vbar, ac - abar);
            c += a.dot(&b);
            s += a.x * b.y - a.y * b.x;
            cd += a.dot(&bd);
            sd += a.x * bd.y - a.y * bd.x;
            cdd += a.dot(&bdd);
            sdd += a.x * bdd.y - a.y * bdd.x;
        }
        let (x, rot) = procrustes_finish(s, c, xbar, self.r_bar, theta_hint);
        let nn = c * c + s * s;
        let (th_d, th_dd) = if nn > 0.0 {
            let th_d = (c * sd - s * cd) / nn;
            (
                th_d,
                (c * sdd - s * cdd) / nn - th_d * 2.0 * (c * cd + s * sd) / nn,
            )
        } else {
            (0.0, 0.0)
        };
        let rr = rot * self.r_bar;
        let rp = perp(rr);
        let pd = vbar - rp * th_d;
        let pdd = abar - rp * th_dd + rr * (th_d * th_d);
        (
            x,
            Vector3::new(pd.x, pd.y, th_d),
            Vector3::new(pdd.x, pdd.y, th_dd),
            rot,
        )
    }

    /// [`fit_velocity`] at the orientation `rot`.
    #[inline]
    pub fn fit_velocity(&self, rot: &Rotation2<f64>, vels: &[Vector2<f64>]) -> Vector3<f64> {
        let mut v = Vector3::zeros();
        for (f, x) in self.fit.iter().zip(vels) {
            v += f * rot.inverse_transform_vector(x);
        }
        let lin = rot * Vector2::new(v.x, v.y);
        Vector3::new(lin.x, lin.y, v.z)
    }

    /// [`distribute_wrench`] at the orientation `rot`, with squeeze `squeeze` (N).
    #[inline]
    pub fn distribute(
        &self,
        rot: &Rotation2<f64>,
        tau: &Vector3<f64>,
        squeeze: f64,
        out: &mut [Vector2<f64>],
    ) {
        let f = rot.inverse_transform_vector(&Vector2::new(tau.x, tau.y));
        let tau_o = Vector3::new(f.x, f.y, tau.z);
        for ((s, q), o) in self.share.iter().zip(&self.squeeze).zip(out.iter_mut()) {
            *o = rot * (s * tau_o + q * squeeze);
        }
    }
}

#[cfg(test)]
mod grasp_set_tests {
    use super::*;

    #[test]
    fn pose_fit_rates_are_the_derivatives_of_the_pose_fit() {
        // Points that translate, rotate and deform (the second point slides along the axis):
        // central differences of the fitted pose (h = 1e-5 s; truncation ~h²·|x'''| ≈ 1e-10,
        // round-off ~ε/h ≈ 1e-11) against the closed-form rates.
        let set = GraspSet::new(vec![
            Grasp {
                r: Vector2::new(-0.045, 0.0),
            },
            Grasp {
                r: Vector2::new(0.045, 0.0),
            },
        ])
        .unwrap();
        let pts = |t: f64| {
            let th = 0.3 * (1.3 * t).sin();
            let c = Vector2::new(0.1 * t.cos(), 0.2 * (0.7 * t).sin());
            let half = 0.045 + 0.004 * (2.0 * t).sin();
            let u = Vector2::new(th.cos(), th.sin());
            [c - u * 0.045, c + u * half]
        };
        let h = 1e-5;
        for k in 0..20 {
            let t = 0.37 * k as f64;
            let p0 = pts(t);
            let (pp, pm) = (pts(t + h), pts(t - h));
            let v: Vec<_> = (0..2).map(|i| (pp[i] - pm[i]) / (2.0 * h)).collect();
            let a: Vec<_> = (0..2)
                .map(|i| (pp[i] - 2.0 * p0[i] + pm[i]) / (h * h))
                .collect();
            let (x, xd, xdd, _) = set.fit_pose_rates(&p0, &v, &a, 0.0);
            let fx = |q: [Vector2<f64>; 2]| set.fit_pose(&q, x.z).0;
            let fd = (fx(pp) - fx(pm)) / (2.0 * h);
            let fdd = (fx(pp) - 2.0 * x + fx(pm)) / (h * h);
            assert!((xd - fd).norm() < 1e-7, "ẋ {xd} vs {fd}");
            // The second difference of the fit and the input accelerations both carry ~ε/h²
            // ≈ 1e-6 round-off.
            assert!((xdd - fdd).norm() < 1e-4, "ẍ {xdd} vs {fdd}");
        }
    }

    #[test]
    fn pose_fit_rates_give_the_pose_fit_bit_for_bit() {
        // fit_pose_rates forms the pose fit's sums itself (one pass with the rates): the pose
        // and R(θ) must be fit_pose's bits, for two grasps (mean by the exact reciprocal) and
        // three (by the division); and the mean must equal the plain division's bits.
        for grasps in test_grasp_sets() {
            let set = GraspSet::new(grasps.clone()).unwrap();
            let m = grasps.len();
            for k in 0..50 {
                let th = -3.0 + 0.13 * k as f64;
                let f = |i: usize, a: f64| (a * (i as f64 + 1.3) + th).sin() * 0.37;
                let pts: Vec<_> = (0..m).map(|i| Vector2::new(f(i, 1.1), f(i, 0.7))).collect();
                let vels: Vec<_> = (0..m).map(|i| Vector2::new(f(i, 2.3), f(i, 0.3))).collect();
                let accs: Vec<_> = (0..m).map(|i| Vector2::new(f(i, 0.9), f(i, 3.1))).collect();
                let (x, _, _, rot) = set.fit_pose_rates(&pts, &vels, &accs, th);
                let (xa, ra) = set.fit_pose(&pts, th);
                assert_eq!(x.map(f64::to_bits), xa.map(f64::to_bits), "{grasps:?} {th}");
                assert_eq!(
                    rot.matrix().map(f64::to_bits),
                    ra.matrix().map(f64::to_bits)
                );
                let plain = pts.iter().sum::<Vector2<f64>>() / m as f64;
                assert_eq!(mean(&pts, m).map(f64::to_bits), plain.map(f64::to_bits));
            }
        }
    }

    #[test]
    fn precomputed_maps_equal_the_direct_solves_at_any_angle() {
        for grasps in test_grasp_sets() {
            let set = GraspSet::new(grasps.clone()).unwrap();
            let m = grasps.len();
            for k in 0..50 {
                let th = -3.0 + 0.13 * k as f64;
                let rot = Rotation2::new(th);
                let vels: Vec<_> = (0..m)
                    .map(|i| Vector2::new((i as f64 + th).sin(), (2.0 * th - i as f64).cos()))
                    .collect();
                let pts: Vec<_> = grasps
                    .iter()
                    .zip(&vels)
                    .map(|(g, v)| Vector2::new(0.1, -0.2) + rot * g.r + 1e-3 * v)
                    .collect();
                let (pa, ra) = set.fit_pose(&pts, th);
                let (pb, rb) = fit_pose_rot(&grasps, &pts, th);
                assert!(
                    (pa - pb).norm() < 1e-13 && (ra.matrix() - rb.matrix()).norm() < 1e-13,
                    "{pa} vs {pb}"
                );
                let a = set.fit_velocity(&rot, &vels);
                let b = fit_velocity_rot(&grasps, &rot, &vels).unwrap();
                assert!((a - b).norm() < 1e-13 * (1.0 + b.norm()), "{a} vs {b}");
                let tau = Vector3::new(th.cos() * 9.0, 20.0, 0.3 * th);
                let (mut x, mut y) = (vec![Vector2::zeros(); m], vec![Vector2::zeros(); m]);
                set.distribute(&rot, &tau, 5.0, &mut x);
                assert!(distribute_wrench_rot(&grasps, &rot, &tau, 5.0, &mut y));
                for (p, q) in x.iter().zip(&y) {
                    assert!((p - q).norm() < 1e-12 * (1.0 + q.norm()), "{p} vs {q}");
                }
            }
        }
    }
}
