//! Spatial inertia of a rigid body about a frame's origin (Featherstone 2008, §2.13–2.14), linear
//! first.
//!
//! With mass `m` (kg), centre of mass `c` (m) and rotational inertia `I_c` about the centre of
//! mass (kg m²), all in the frame's axes, the inertia is stored as `(m, h = m c, I_O)` with
//! `I_O = I_c − m [c]²` the rotational inertia about the origin, and acts on a twist
//! `V = [v; ω]` as
//!
//! ```text
//! 𝕀 = [ m 1    −[h] ]      𝕀 V = [ m v − h × ω ;  I_O ω + h × v ]       (momentum, N s and N m s)
//!     [ [h]    I_O  ]
//! ```
//!
//! The representation is linear: the inertia of a union of bodies is the sum of the three parts,
//! which is what composite-body algorithms use.

use std::ops::{Add, AddAssign};

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3};

use super::motion::{Twist, Wrench, ang, lin, stack};
use super::so3::hat;

/// Spatial inertia `(m, h = m c, I_O)` about a frame's origin, in that frame's axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialInertia {
    /// Mass `m`, kg.
    pub mass: f64,
    /// First moment `h = m c`, kg m (`c` the centre of mass).
    pub h: Vector3<f64>,
    /// Rotational inertia about the origin `I_O = I_c − m [c]²`, kg m² (symmetric).
    pub inertia: Matrix3<f64>,
}

/// `R S Rᵀ` for a symmetric `S`, computing the six independent entries only.
#[inline]
pub fn rotate_symmetric(r: &Matrix3<f64>, s: &Matrix3<f64>) -> Matrix3<f64> {
    let a = r * s;
    let row =
        |i: usize, j: usize| a[(i, 0)] * r[(j, 0)] + a[(i, 1)] * r[(j, 1)] + a[(i, 2)] * r[(j, 2)];
    let (xx, xy, xz, yy, yz, zz) = (
        row(0, 0),
        row(0, 1),
        row(0, 2),
        row(1, 1),
        row(1, 2),
        row(2, 2),
    );
    Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
}

/// `−m [c]² = m (|c|² I − c cᵀ)`, the parallel-axis term, symmetric.
#[inline]
fn parallel_axis(m: f64, c: &Vector3<f64>) -> Matrix3<f64> {
    let (x, y, z) = (c.x, c.y, c.z);
    let (xx, yy, zz) = (x * x, y * y, z * z);
    Matrix3::new(
        m * (yy + zz),
        -m * x * y,
        -m * x * z,
        -m * x * y,
        m * (xx + zz),
        -m * y * z,
        -m * x * z,
        -m * y * z,
        m * (xx + yy),
    )
}

impl SpatialInertia {
    /// Zero inertia.
    pub fn zero() -> Self {
        SpatialInertia {
            mass: 0.0,
            h: Vector3::zeros(),
            inertia: Matrix3::zeros(),
        }
    }

    /// From mass `m`, centre of mass `c` and rotational inertia `I_c` about the centre of mass
    /// (symmetric), all in the frame: `(m, m c, I_c − m [c]²)`.
    pub fn from_com(mass: f64, com: &Vector3<f64>, inertia_com: &Matrix3<f64>) -> Self {
        SpatialInertia {
            mass,
            h: mass * com,
            inertia: inertia_com + parallel_axis(mass, com),
        }
    }

    /// A body given in its frame `L` (mass, `c_L`, `I_c` in `L` axes), expressed in `A` where the
    /// pose of `L` is `(R_AL, p_AL)`: `c_A = p_AL + R_AL c_L`, `I_O = R_AL I_c R_ALᵀ − m [c_A]²`.
    /// 27 + 18 multiplications for the rotation, the rest is O(10).
    #[inline]
    pub fn from_com_posed(
        mass: f64,
        com: &Vector3<f64>,
        inertia_com: &Matrix3<f64>,
        r_al: &Matrix3<f64>,
        p_al: &Vector3<f64>,
    ) -> Self {
        let c = p_al + r_al * com;
        SpatialInertia {
            mass,
            h: mass * c,
            inertia: rotate_symmetric(r_al, inertia_com) + parallel_axis(mass, &c),
        }
    }

    /// The centre of mass `c = h/m` (the origin for a massless body).
    pub fn com(&self) -> Vector3<f64> {
        if self.mass > 0.0 {
            self.h / self.mass
        } else {
            Vector3::zeros()
        }
    }

    /// Momentum `𝕀 V = [m v − h × ω; I_O ω + h × v]`.
    #[inline]
    pub fn apply(&self, v: &Twist) -> Wrench {
        let (vl, va) = (lin(v), ang(v));
        stack(
            &(self.mass * vl - self.h.cross(&va)),
            &(self.inertia * va + self.h.cross(&vl)),
        )
    }

    /// Kinetic energy `½ Vᵀ 𝕀 V`, J.
    #[inline]
    pub fn kinetic_energy(&self, v: &Twist) -> f64 {
        0.5 * v.dot(&self.apply(v))
    }

    /// The same inertia expressed in `A`, given `X_AB` with `self` expressed in `B`
    /// (`𝕀_A = Ad*(X_AB) 𝕀_B Ad(X_AB)⁻¹`): with `y = R h`,
    /// `h_A = y + m p`, `I_A = R I_O Rᵀ − [p][y] − [y + m p][p]`.
    pub fn transform(&self, x_ab: &Isometry3<f64>) -> SpatialInertia {
        let r = x_ab.rotation.to_rotation_matrix().into_inner();
        let p = x_ab.translation.vector;
        let y = r * self.h;
        let hp = hat(&p);
        let ha = y + self.mass * p;
        SpatialInertia {
            mass: self.mass,
            h: ha,
            inertia: rotate_symmetric(&r, &self.inertia) - hp * hat(&y) - hat(&ha) * hp,
        }
    }

    /// The 6 × 6 matrix `[[m 1, −[h]], [[h], I_O]]`.
    pub fn to_matrix(&self) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        let hh = hat(&self.h);
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * self.mass));
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-hh));
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&hh);
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.inertia);
        m
    }
}

impl Add for SpatialInertia {
    type Output = SpatialInertia;
    #[inline]
    fn add(self, o: SpatialInertia) -> SpatialInertia {
        SpatialInertia {
            mass: self.mass + o.mass,
            h: self.h + o.h,
            inertia: self.inertia + o.inertia,
        }
    }
}

impl AddAssign for SpatialInertia {
    #[inline]
    fn add_assign(&mut self, o: SpatialInertia) {
        self.mass += o.mass;
        self.h += o.h;
        self.inertia += o.inertia;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::motion::{adjoint_force, adjoint_motion};
    use crate::math::random::SplitMix64;
    use nalgebra::{Translation3, UnitQuaternion, Vector6};

    fn body(rng: &mut SplitMix64) -> SpatialInertia {
        let m = rng.range(0.5, 3.0);
        let c = Vector3::from_fn(|_, _| rng.range(-0.3, 0.3));
        let q = UnitQuaternion::new(Vector3::from_fn(|_, _| rng.range(-2.0, 2.0)));
        let d = Matrix3::from_diagonal(&Vector3::new(0.02, 0.03, 0.04));
        let r = q.to_rotation_matrix().into_inner();
        SpatialInertia::from_com(m, &c, &(r * d * r.transpose()))
    }

    #[test]
    fn transform_matches_the_adjoint_sandwich() {
        let mut rng = SplitMix64(21);
        for _ in 0..50 {
            let i = body(&mut rng);
            let x = Isometry3::from_parts(
                Translation3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.4),
                UnitQuaternion::new(Vector3::from_fn(|_, _| rng.range(-2.0, 2.0))),
            );
            let want = adjoint_force(&x) * i.to_matrix() * adjoint_motion(&x.inverse());
            assert!((i.transform(&x).to_matrix() - want).abs().max() < 1e-13);
            let r = x.rotation.to_rotation_matrix().into_inner();
            let (c, ic) = (i.com(), i.inertia - parallel_axis(i.mass, &i.com()));
            let posed = SpatialInertia::from_com_posed(i.mass, &c, &ic, &r, &x.translation.vector);
            assert!((posed.to_matrix() - want).abs().max() < 1e-13);
            let v = Vector6::from_fn(|_, _| rng.range(-1.0, 1.0));
            assert!((i.apply(&v) - i.to_matrix() * v).norm() < 1e-14);
            assert!(i.to_matrix().symmetric_eigenvalues().min() > 0.0);
        }
    }
}
