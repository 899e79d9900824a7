//! The spatial cooperative controller (SPEC-spatial S5): the iBLF on six outputs, the
//! controller's set-up checks, and the closed loop on two UR5-class and two Franka-class arms
//! along the SPEC-spatial S6 path.

use nalgebra::{SVector, Vector6};
use tandem::iblf::{Iblf, v1};

/// Six smooth signals: `x_r,j(t)` and `z_j(t)` as sums of sines well inside the bounds.
struct Smooth6 {
    a: [[f64; 3]; 6],
    w: [[f64; 3]; 6],
    c: [f64; 6],
}

impl Smooth6 {
    fn x(&self, j: usize, t: f64) -> f64 {
        self.c[j] + (0..3).map(|i| self.a[j][i] * (self.w[j][i] * t + i as f64).sin()).sum::<f64>()
    }
    fn v(&self, j: usize, t: f64) -> f64 {
        (0..3)
            .map(|i| self.a[j][i] * self.w[j][i] * (self.w[j][i] * t + i as f64).cos())
            .sum()
    }
    fn a(&self, j: usize, t: f64) -> f64 {
        (0..3)
            .map(|i| -self.a[j][i] * self.w[j][i] * self.w[j][i] * (self.w[j][i] * t + i as f64).sin())
            .sum()
    }
}

/// `d/dt f` by the 4th-order central difference.
fn d4(f: &dyn Fn(f64) -> f64, t: f64, h: f64) -> f64 {
    (f(t - 2.0 * h) - 8.0 * f(t - h) + 8.0 * f(t + h) - f(t + 2.0 * h)) / (12.0 * h)
}

#[test]
fn v1_derivative_is_32_on_six_outputs() {
    // V1 = Σ_j V1_j(z_j, x_r,j) (27) along smooth x_r(t), x_1(t) on the S6 bounds; its time
    // derivative by finite differences equals (32) summed over the six outputs, with α and
    // g(x_1) from the controller's Iblf<6> (not the free functions).
    let k = [0.167, 0.167, 0.1, 0.29, 0.29, 0.29];
    let kappa = [8.0, 8.0, 8.0, 6.0, 10.0, 12.0];
    let iblf = Iblf::<6>::new(SVector::from(k), SVector::from(kappa)).unwrap();
    let xr = Smooth6 {
        a: std::array::from_fn(|j| [0.2 * k[j], 0.1 * k[j], 0.05 * k[j]]),
        w: std::array::from_fn(|j| [0.7 + 0.1 * j as f64, 1.9, 3.1]),
        c: std::array::from_fn(|j| 0.2 * k[j] * if j % 2 == 0 { 1.0 } else { -1.0 }),
    };
    let z = Smooth6 {
        a: std::array::from_fn(|j| [0.15 * k[j], 0.1 * k[j], 0.05 * k[j]]),
        w: std::array::from_fn(|j| [1.3, 2.3 + 0.2 * j as f64, 5.0]),
        c: [0.0; 6],
    };
    let v_total = |t: f64| (0..6).map(|j| v1(z.x(j, t), xr.x(j, t), k[j])).sum::<f64>();
    let mut worst: f64 = 0.0;
    for i in 0..200 {
        let t = 0.05 * i as f64;
        let x_r = Vector6::from_fn(|j, _| xr.x(j, t));
        let xd_r = Vector6::from_fn(|j, _| xr.v(j, t));
        let xdd_r = Vector6::from_fn(|j, _| xr.a(j, t));
        let z1 = Vector6::from_fn(|j, _| z.x(j, t));
        let x1 = x_r + z1;
        let x2 = xd_r + Vector6::from_fn(|j, _| z.v(j, t));
        let ev = iblf.eval(&x1, &x2, &x_r, &xd_r, &xdd_r);
        assert!(!ev.any_saturated());
        let z2 = ev.z2(&x2);
        let v32: f64 = (0..6)
            .map(|j| -kappa[j] * ev.gain[j] * z1[j] * z1[j] + ev.gain[j] * z1[j] * z2[j])
            .sum();
        let fd = d4(&v_total, t, 1e-3);
        let scale: f64 = (0..6)
            .map(|j| ev.gain[j] * z1[j].abs() * (kappa[j] * z1[j].abs() + z2[j].abs()))
            .sum::<f64>()
            + 1e-15;
        let rel = (fd - v32).abs() / scale;
        worst = worst.max(rel);
        // 4th-order FD at h = 1 ms on signals up to 5 rad/s: truncation ≈ (5e-3)^4/30 ≈ 2e-11
        // of the derivative's scale; round-off ≈ 1e-16 · V1/h ≪ that.
        assert!(rel < 1e-8, "t = {t}: fd {fd} vs (32) {v32} (rel {rel:.2e})");
    }
    eprintln!("V̇1 on six outputs: max relative |FD − (32)| = {worst:.2e}");
}
