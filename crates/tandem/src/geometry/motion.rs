//! Spatial motion and force vectors, linear first (SPEC-spatial S1), their cross products, and
//! the adjoint maps of a rigid transform.
//!
//! A twist `V = [v; ω]` in frame `A` is the velocity `v` of the body point at `A`'s origin and the
//! angular velocity `ω`, both in `A` axes; a wrench `F = [f; τ]` is a force `f` and a moment `τ`
//! about `A`'s origin. With `X_AB = (R, p)` the pose of `B` in `A` (Featherstone 2008, §2.8, with
//! the blocks reordered linear first):
//!
//! ```text
//! V_A = Ad(X_AB) V_B,     Ad(X)    = [ R   [p]R ]      v_A = R v_B + p × (R ω_B),  ω_A = R ω_B
//!                                    [ 0    R   ]
//! F_A = Ad*(X_AB) F_B,    Ad*(X)   = [ R    0   ]      f_A = R f_B,  τ_A = R τ_B + p × (R f_B)
//!                                    [ [p]R R   ]
//! ```
//!
//! `Ad* = Ad⁻ᵀ` keeps power invariant (`F_A · V_A = F_B · V_B`). The cross products (Featherstone
//! eqs. 2.31–2.33): `V × M = ad(V) M` for motions and `V ×* F = −ad(V)ᵀ F` for forces,
//!
//! ```text
//! ad(V)  = [ [ω] [v] ]      V × M  = [ω × m_v + v × m_ω;  ω × m_ω]
//!          [ 0   [ω] ]
//! ad*(V) = [ [ω]  0  ]      V ×* F = [ω × f;  ω × τ + v × f]
//!          [ [v] [ω] ]
//! ```
//!
//! Every `apply` form costs a few 3-vector operations; the 6 × 6 matrices are for tests and for
//! callers that need them.

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3, Vector6};

use super::so3::hat;

/// A twist `[v; ω]` (m/s, rad/s), linear first.
pub type Twist = Vector6<f64>;
/// A wrench `[f; τ]` (N, N m), linear first.
pub type Wrench = Vector6<f64>;

/// The linear (first) half of a spatial vector.
#[inline(always)]
pub fn lin(x: &Vector6<f64>) -> Vector3<f64> {
    Vector3::new(x[0], x[1], x[2])
}

/// The angular (second) half of a spatial vector.
#[inline(always)]
pub fn ang(x: &Vector6<f64>) -> Vector3<f64> {
    Vector3::new(x[3], x[4], x[5])
}

/// `[a; b]`.
#[inline(always)]
pub fn stack(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// Motion cross product `V × M = [ω × m_v + v × m_ω; ω × m_ω]`.
#[inline]
pub fn cross_motion(v: &Twist, m: &Vector6<f64>) -> Vector6<f64> {
    let (vl, va) = (lin(v), ang(v));
    let (ml, ma) = (lin(m), ang(m));
    stack(&(va.cross(&ml) + vl.cross(&ma)), &va.cross(&ma))
}

/// Force cross product `V ×* F = [ω × f; ω × τ + v × f]`.
#[inline]
pub fn cross_force(v: &Twist, f: &Wrench) -> Wrench {
    let (vl, va) = (lin(v), ang(v));
    let (fl, fa) = (lin(f), ang(f));
    stack(&va.cross(&fl), &(va.cross(&fa) + vl.cross(&fl)))
}

/// The matrix `ad(V)` of [`cross_motion`].
pub fn cross_motion_matrix(v: &Twist) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    let w = hat(&ang(v));
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&w);
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(&hat(&lin(v)));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&w);
    m
}

/// The matrix `ad*(V) = −ad(V)ᵀ` of [`cross_force`].
pub fn cross_force_matrix(v: &Twist) -> Matrix6<f64> {
    -cross_motion_matrix(v).transpose()
}

/// `Ad(X_AB) V_B`: a twist in `B` re-expressed in `A` (about `A`'s origin, `A` axes).
#[inline]
pub fn transform_motion(x: &Isometry3<f64>, v: &Twist) -> Twist {
    let w = x.rotation * ang(v);
    stack(&(x.rotation * lin(v) + x.translation.vector.cross(&w)), &w)
}

/// `Ad(X_AB)⁻¹ V_A = Ad(X_BA) V_A`: a twist in `A` re-expressed in `B`.
#[inline]
pub fn inverse_transform_motion(x: &Isometry3<f64>, v: &Twist) -> Twist {
    let w = ang(v);
    let vl = lin(v) + w.cross(&x.translation.vector);
    stack(
        &x.rotation.inverse_transform_vector(&vl),
        &x.rotation.inverse_transform_vector(&w),
    )
}

/// `Ad*(X_AB) F_B`: a wrench in `B` re-expressed in `A`.
#[inline]
pub fn transform_force(x: &Isometry3<f64>, f: &Wrench) -> Wrench {
    let fa = x.rotation * lin(f);
    stack(
        &fa,
        &(x.rotation * ang(f) + x.translation.vector.cross(&fa)),
    )
}

/// `Ad*(X_AB)⁻¹ F_A = Ad*(X_BA) F_A`: a wrench in `A` re-expressed in `B`.
#[inline]
pub fn inverse_transform_force(x: &Isometry3<f64>, f: &Wrench) -> Wrench {
    let fl = lin(f);
    let t = ang(f) - x.translation.vector.cross(&fl);
    stack(
        &x.rotation.inverse_transform_vector(&fl),
        &x.rotation.inverse_transform_vector(&t),
    )
}

/// The motion adjoint `Ad(X) = [[R, [p]R], [0, R]]` (6 × 6).
pub fn adjoint_motion(x: &Isometry3<f64>) -> Matrix6<f64> {
    let r: Matrix3<f64> = x.rotation.to_rotation_matrix().into_inner();
    let pr = hat(&x.translation.vector) * r;
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(&pr);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    m
}

/// The force (dual) adjoint `Ad*(X) = Ad(X)⁻ᵀ = [[R, 0], [[p]R, R]]` (6 × 6).
pub fn adjoint_force(x: &Isometry3<f64>) -> Matrix6<f64> {
    let r: Matrix3<f64> = x.rotation.to_rotation_matrix().into_inner();
    let pr = hat(&x.translation.vector) * r;
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&pr);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    m
}

/// Shift a twist's reference point: the velocity of the body point at `r` (from the current
/// reference point, same axes) is `v + ω × r`; returns `[v + ω × r; ω]`.
#[inline]
pub fn shift_motion(v: &Twist, r: &Vector3<f64>) -> Twist {
    let w = ang(v);
    stack(&(lin(v) + w.cross(r)), &w)
}

/// Shift a wrench's reference point: the moment about the point at `r` (from the current
/// reference point, same axes) is `τ − r × f`; returns `[f; τ − r × f]`.
#[inline]
pub fn shift_force(f: &Wrench, r: &Vector3<f64>) -> Wrench {
    let fl = lin(f);
    stack(&fl, &(ang(f) - r.cross(&fl)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::random::SplitMix64;
    use nalgebra::{Translation3, UnitQuaternion};

    fn iso(rng: &mut SplitMix64) -> Isometry3<f64> {
        let axis = Vector3::from_fn(|_, _| rng.range(-1.0, 1.0));
        Isometry3::from_parts(
            Translation3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            ),
            UnitQuaternion::new(axis * 2.0),
        )
    }

    fn v6(rng: &mut SplitMix64) -> Vector6<f64> {
        Vector6::from_fn(|_, _| rng.range(-1.0, 1.0))
    }

    #[test]
    fn adjoint_of_a_product_is_the_product_of_adjoints() {
        let mut rng = SplitMix64(11);
        for _ in 0..50 {
            let (x, y) = (iso(&mut rng), iso(&mut rng));
            let e = adjoint_motion(&(x * y)) - adjoint_motion(&x) * adjoint_motion(&y);
            assert!(e.abs().max() < 1e-14);
            let e = adjoint_force(&(x * y)) - adjoint_force(&x) * adjoint_force(&y);
            assert!(e.abs().max() < 1e-14);
            let e = adjoint_motion(&x.inverse()) - adjoint_motion(&x).try_inverse().unwrap();
            assert!(e.abs().max() < 1e-13);
        }
    }

    #[test]
    fn force_adjoint_is_the_inverse_transpose() {
        let mut rng = SplitMix64(12);
        for _ in 0..50 {
            let x = iso(&mut rng);
            let inv_t = adjoint_motion(&x).try_inverse().unwrap().transpose();
            assert!((adjoint_force(&x) - inv_t).abs().max() < 1e-13);
            // Power is invariant.
            let (v, f) = (v6(&mut rng), v6(&mut rng));
            let p0 = f.dot(&v);
            let p1 = transform_force(&x, &f).dot(&transform_motion(&x, &v));
            assert!((p0 - p1).abs() < 1e-14);
        }
    }

    #[test]
    fn apply_forms_match_matrices() {
        let mut rng = SplitMix64(13);
        for _ in 0..50 {
            let x = iso(&mut rng);
            let (v, m) = (v6(&mut rng), v6(&mut rng));
            assert!((transform_motion(&x, &v) - adjoint_motion(&x) * v).norm() < 1e-14);
            assert!((transform_force(&x, &v) - adjoint_force(&x) * v).norm() < 1e-14);
            let back = inverse_transform_motion(&x, &transform_motion(&x, &v));
            assert!((back - v).norm() < 1e-14);
            let back = inverse_transform_force(&x, &transform_force(&x, &v));
            assert!((back - v).norm() < 1e-14);
            assert!((cross_motion(&v, &m) - cross_motion_matrix(&v) * m).norm() < 1e-15);
            assert!((cross_force(&v, &m) - cross_force_matrix(&v) * m).norm() < 1e-15);
            // (V × M) · F = −M · (V ×* F)
            let f = v6(&mut rng);
            assert!((cross_motion(&v, &m).dot(&f) + m.dot(&cross_force(&v, &f))).abs() < 1e-15);
            // Ad(X) ad(V) Ad(X)⁻¹ = ad(Ad(X) V).
            let lhs = adjoint_motion(&x) * cross_motion_matrix(&v) * adjoint_motion(&x.inverse());
            let rhs = cross_motion_matrix(&transform_motion(&x, &v));
            assert!((lhs - rhs).abs().max() < 1e-13);
        }
    }

    #[test]
    fn shifts_match_pure_translations() {
        let mut rng = SplitMix64(14);
        let (v, r) = (v6(&mut rng), Vector3::new(0.3, -0.2, 0.9));
        let x = Isometry3::translation(r.x, r.y, r.z);
        assert!((shift_motion(&v, &r) - inverse_transform_motion(&x, &v)).norm() < 1e-15);
        assert!((shift_force(&v, &r) - inverse_transform_force(&x, &v)).norm() < 1e-15);
    }
}
