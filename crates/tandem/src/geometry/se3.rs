//! The rigid-motion group SE(3): exponential and logarithm of twists, linear first.
//!
//! With `ξ = [ρ; φ]` (`ρ` m, `φ` rad; the twist coordinates of a screw motion applied for unit
//! time, linear first as everywhere in tandem):
//!
//! ```text
//! Exp([ρ; φ]) = (R, p) = (Exp_SO3(φ), J_l(φ) ρ)
//! Log(R, p)   = [J_l⁻¹(φ) p; φ]                 with φ = Log_SO3(R), |φ| ≤ π
//! ```
//!
//! `J_l` is the left Jacobian of SO(3) ([`super::so3::left_jacobian`]), the same matrix that
//! maps `ρ` to the translation (Barfoot, *State Estimation for Robotics*, 2017, §7.1.3). Both
//! maps inherit the accuracy of [`super::so3`] at `θ → 0` and `θ → π`; `J_l⁻¹` is regular up to
//! `θ = 2π`, so `Log` is defined for every pose. `Log(X_ref⁻¹ X)` is a pose error whose
//! rotation part is the rotation vector (not a small-angle approximation).

use nalgebra::{Isometry3, Translation3, Vector3, Vector6};

use super::motion::{ang, lin, stack};
use super::so3;

/// `Exp([ρ; φ]) = (Exp(φ), J_l(φ) ρ)` as an isometry.
pub fn exp(xi: &Vector6<f64>) -> Isometry3<f64> {
    let phi = ang(xi);
    let p = so3::left_jacobian(&phi) * lin(xi);
    Isometry3::from_parts(Translation3::from(p), so3::exp_quat(&phi))
}

/// `Log(X) = [J_l⁻¹(φ) p; φ]` with `φ = Log(R)`, `|φ| ≤ π`.
pub fn log(x: &Isometry3<f64>) -> Vector6<f64> {
    let phi: Vector3<f64> = so3::log_quat(&x.rotation);
    let rho = so3::left_jacobian_inv(&phi) * x.translation.vector;
    stack(&rho, &phi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::motion::adjoint_motion;
    use crate::math::random::SplitMix64;

    #[test]
    fn exp_log_round_trip() {
        let mut rng = SplitMix64(41);
        for t in [0.0, 1e-12, 1e-6, 0.5, 1.0, 2.0, std::f64::consts::PI - 1e-9] {
            for _ in 0..20 {
                let w = Vector3::from_fn(|_, _| rng.range(-1.0, 1.0)).normalize() * t;
                let r = Vector3::from_fn(|_, _| rng.range(-1.0, 1.0));
                let xi = stack(&r, &w);
                let back = log(&exp(&xi));
                assert!(
                    (back - xi).amax() < 1e-14,
                    "θ = {t}: {:e}",
                    (back - xi).amax()
                );
                let x = exp(&xi);
                let xx = exp(&log(&x));
                assert!((x.to_homogeneous() - xx.to_homogeneous()).amax() < 1e-14);
            }
        }
    }

    #[test]
    fn exp_is_the_screw_motion() {
        // X(t) = Exp(t ξ) is a one-parameter subgroup: its spatial twist Ẋ X⁻¹ is ξ itself, so
        // Log(X(1+h) X(1−h)⁻¹)/2h = ξ (exactly, up to rounding ε/h ≈ 1e-10).
        let xi = Vector6::new(0.3, -0.2, 0.5, 0.7, -0.4, 0.9);
        let h = 1e-6;
        let a = exp(&(xi * (1.0 + h)));
        let b = exp(&(xi * (1.0 - h)));
        let d = log(&(a * b.inverse())) / (2.0 * h);
        assert!((d - xi).amax() < 1e-9, "{d}");
        // Ad(Exp(ξ)) ξ = ξ: a screw is invariant under its own motion.
        let x = exp(&xi);
        assert!((adjoint_motion(&x) * xi - xi).amax() < 1e-14);
    }
}
