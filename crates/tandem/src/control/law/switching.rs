//! Smooth switching between the NN region and the robust region, paper (37)–(38).
//!
//! $$
//! Q(Z) = M(Z)\,I,\qquad M(Z) = \prod_{k=1}^{N_{in}} m_k(Z_k),
//! $$
//! $$
//! m_k(z) = \begin{cases}
//!   1 & |z| \le d_{1,k}\\
//!   (1 - s)\,\exp\!\big((s/\omega_k)^2\big),\quad s = \dfrac{z^2 - d_{1,k}^2}{d_{2,k}^2 - d_{1,k}^2}
//!     & d_{1,k} < |z| < d_{2,k}\\
//!   0 & |z| \ge d_{2,k}
//! \end{cases}
//! $$
//!
//! The middle branch is the paper's (38): `(d2² − z²)/(d2² − d1²) = 1 − s` and the exponent
//! `(z² − d1²)/(ω(d2² − d1²)) = s/ω`.
//!
//! SPEC §3.4: `Q` is a scalar times the identity (every output sees the same `M(Z)`, as the
//! paper's `M_i(Z)` are all built from the same `Z`); the paper gives no `d1, d2, ω`, so the
//! defaults are `d1 = 1`, `d2 = 1.5`, `ω = 1` for every input, all configurable per input.
//!
//! Properties (tested): `m` is continuous (`s = 0` gives 1 at `|z| = d1`, `s = 1` gives 0 at
//! `|z| = d2`), lies in `[0, 1]`, and is non-increasing in `|z|` when `ω ≥ 1`:
//! `dm/ds = exp((s/ω)²)·(2s(1 − s)/ω² − 1)` and `2s(1 − s) ≤ 1/2`, so `dm/ds < 0` on `(0, 1)`
//! (any `ω > 1/√2` would do; the paper and SPEC require `ω ≥ 1`, and so does the validation).
//! `m` is not differentiable at `|z| = d2` (slope `−exp(1/ω²)` from inside, 0 outside); the
//! paper's proof only needs continuity of `Q`.

use crate::error::{ModelError, positive};

/// Switching parameters of one NN input: the inner radius `d1`, the outer radius `d2` and the
/// shape `ω` of (38). Validated: `0 < d1 < d2`, `ω ≥ 1`, all finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchParams {
    d1: f64,
    d2: f64,
    omega: f64,
    /// `1 / (d2² − d1²)`, cached.
    inv_span: f64,
}

impl Default for SwitchParams {
    /// SPEC §3.4 defaults: `d1 = 1`, `d2 = 1.5`, `ω = 1`.
    fn default() -> Self {
        Self::new(1.0, 1.5, 1.0).expect("defaults are valid")
    }
}

impl SwitchParams {
    /// Validate and build. Errors name the parameter (`d1`, `d2`, `omega`) and the condition.
    pub fn new(d1: f64, d2: f64, omega: f64) -> Result<Self, ModelError> {
        positive("d1", d1)?;
        if !(d2.is_finite() && d2 > d1) {
            return Err(ModelError::invalid(
                "d2",
                d2,
                format!("must be finite and satisfy d1 < d2 (d1 = {d1})"),
            ));
        }
        if !(omega.is_finite() && omega >= 1.0) {
            return Err(ModelError::invalid(
                "omega",
                omega,
                "must be finite and >= 1 (m(z) is monotone from 1 to 0 only for omega >= 1)",
            ));
        }
        Ok(Self {
            d1,
            d2,
            omega,
            inv_span: 1.0 / (d2 * d2 - d1 * d1),
        })
    }

    /// Inner radius `d1` (m(z) = 1 for `|z| ≤ d1`).
    pub fn d1(&self) -> f64 {
        self.d1
    }

    /// Outer radius `d2` (m(z) = 0 for `|z| ≥ d2`).
    pub fn d2(&self) -> f64 {
        self.d2
    }

    /// Shape parameter `ω ≥ 1`.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// `m(z)` of (38), in `[0, 1]`. A NaN input gives 0 (the robust branch), never NaN.
    #[inline]
    pub fn m(&self, z: f64) -> f64 {
        let a = z.abs();
        if a <= self.d1 {
            1.0
        } else if a < self.d2 {
            // s ∈ (0, 1): the transition band of (38).
            let s = (z * z - self.d1 * self.d1) * self.inv_span;
            let r = s / self.omega;
            ((1.0 - s) * (r * r).exp()).clamp(0.0, 1.0)
        } else {
            // |z| ≥ d2, or NaN: outside Ω2 the robust term takes over.
            0.0
        }
    }
}

/// `M(Z) = Π_k m_k(Z_k)` for one set of per-input parameters, (37).
///
/// Owns one [`SwitchParams`] per NN input (SPEC §3.4: `Z = [x_1, x_2, α, α̇]`, `4n` inputs).
#[derive(Debug, Clone, PartialEq)]
pub struct Switching {
    params: Vec<SwitchParams>,
}

impl Switching {
    /// One parameter set per input, in the order of `Z`.
    pub fn new(params: Vec<SwitchParams>) -> Result<Self, ModelError> {
        if params.is_empty() {
            return Err(ModelError::geometry(
                "switching.params",
                "needs at least one input",
            ));
        }
        Ok(Self { params })
    }

    /// The same parameters for all `n_inputs` inputs.
    pub fn uniform(n_inputs: usize, params: SwitchParams) -> Result<Self, ModelError> {
        Self::new(vec![params; n_inputs])
    }

    /// Number of inputs `N_in`.
    pub fn n_inputs(&self) -> usize {
        self.params.len()
    }

    /// Per-input parameters, in the order of `Z`.
    pub fn params(&self) -> &[SwitchParams] {
        &self.params
    }

    /// `M(Z) = Π_k m_k(Z_k) ∈ [0, 1]`; stops at the first factor that is 0. No allocation.
    ///
    /// Inside the NN region (every `|Z_k| ≤ d_1,k`, the usual case) every factor is exactly 1
    /// and so is the product: one branch-free pass of compares answers it, the product runs
    /// only otherwise (the same value either way: `m · 1 = m`).
    ///
    /// # Panics
    /// If `z.len() != self.n_inputs()`.
    #[inline]
    pub fn eval(&self, z: &[f64]) -> f64 {
        assert_eq!(z.len(), self.params.len(), "switching: input length");
        let inside = self
            .params
            .iter()
            .zip(z)
            .fold(true, |all, (p, &zk)| all & (zk.abs() <= p.d1));
        if inside {
            return 1.0;
        }
        let mut m = 1.0;
        for (p, &zk) in self.params.iter().zip(z) {
            m *= p.m(zk);
            if m == 0.0 {
                break;
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn inside_and_outside() {
        let p = SwitchParams::default();
        for z in [0.0, 0.3, -0.99, 1.0, -1.0] {
            assert_eq!(p.m(z), 1.0);
        }
        for z in [
            1.5,
            -1.5,
            2.0,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            assert_eq!(p.m(z), 0.0);
        }
        let m = p.m(1.25);
        assert!(m > 0.0 && m < 1.0);
    }

    #[test]
    fn continuity_at_d1_and_d2() {
        for &(d1, d2, w) in &[(1.0, 1.5, 1.0), (0.2, 0.21, 3.0), (2.0, 7.0, 1.0)] {
            let p = SwitchParams::new(d1, d2, w).unwrap();
            // Just outside d1: s ≈ 2 d1 δ / (d2² − d1²), m ≈ 1 − s.
            let dz = 1e-9;
            let slope_bound = 2.0 * d1 / (d2 * d2 - d1 * d1) * 1.01;
            assert!((1.0 - p.m(d1 + dz)) <= slope_bound * dz + 1e-15);
            // Just inside d2: m ≈ e^{1/ω²} · 2 d2 δ / (d2² − d1²).
            let slope_bound = (1.0 / (w * w)).exp() * 2.0 * d2 / (d2 * d2 - d1 * d1) * 1.01;
            assert!(p.m(d2 - dz) <= slope_bound * dz + 1e-15);
            assert!(p.m(d2 - dz) > 0.0);
        }
    }

    #[test]
    fn validation_names_the_parameter() {
        let e = SwitchParams::new(1.0, 1.0, 1.0).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, reason, .. }
            if param == "d2" && reason.contains("d1 < d2")));
        let e = SwitchParams::new(0.0, 1.0, 1.0).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, .. } if param == "d1"));
        let e = SwitchParams::new(1.0, 2.0, 0.9).unwrap_err();
        assert!(matches!(&e, ModelError::Invalid { param, reason, .. }
            if param == "omega" && reason.contains("monotone")));
        assert!(SwitchParams::new(1.0, f64::NAN, 1.0).is_err());
        assert!(Switching::new(vec![]).is_err());
    }

    #[test]
    fn product_over_inputs() {
        let p = SwitchParams::default();
        let s = Switching::uniform(4, p).unwrap();
        assert_eq!(s.eval(&[0.0, 0.5, -1.0, 0.9]), 1.0);
        assert_eq!(s.eval(&[0.0, 0.5, -1.6, 0.9]), 0.0);
        let z = [1.1, 0.0, -1.3, 1.2];
        let want = p.m(1.1) * p.m(-1.3) * p.m(1.2);
        assert!((s.eval(&z) - want).abs() <= 1e-16);
    }

    proptest! {
        #[test]
        fn monotone_and_bounded(
            d1 in 1e-3f64..10.0,
            gap in 1e-3f64..10.0,
            w in 1.0f64..20.0,
            a in 0.0f64..1.0,
            b in 0.0f64..1.0,
        ) {
            let p = SwitchParams::new(d1, d1 + gap, w).unwrap();
            // Sample |z| on a range covering all three branches.
            let top = (d1 + gap) * 1.2;
            let (lo, hi) = if a <= b { (a * top, b * top) } else { (b * top, a * top) };
            let (mlo, mhi) = (p.m(lo), p.m(hi));
            prop_assert!((0.0..=1.0).contains(&mlo) && (0.0..=1.0).contains(&mhi));
            // Allow a few ulps: adjacent floats can round either way.
            prop_assert!(mhi <= mlo + 4.0 * f64::EPSILON, "m({hi}) = {mhi} > m({lo}) = {mlo}");
            prop_assert_eq!(p.m(-lo), mlo);
        }
    }

    #[test]
    fn eval_is_the_plain_product_bit_for_bit() {
        // The inside-the-region shortcut returns exactly the product of the factors, in the
        // product's order and with its early stop, for inputs inside, in the band, outside and
        // non-finite, with per-input parameters.
        let params: Vec<_> = (0..12)
            .map(|k| SwitchParams::new(0.5 + 0.1 * k as f64, 1.0 + 0.15 * k as f64, 1.0 + k as f64))
            .collect::<Result<_, _>>()
            .unwrap();
        let s = Switching::new(params.clone()).unwrap();
        let plain = |z: &[f64]| {
            let mut m = 1.0;
            for (p, &zk) in params.iter().zip(z) {
                m *= p.m(zk);
                if m == 0.0 {
                    break;
                }
            }
            m
        };
        let values = [
            0.0,
            -0.0,
            0.3,
            -0.55,
            0.6,
            0.9,
            -1.2,
            2.5,
            1e300,
            f64::NAN,
            f64::INFINITY,
        ];
        let mut z = [0.0; 12];
        for i in 0..12 * values.len() * values.len() {
            for (k, zk) in z.iter_mut().enumerate() {
                *zk = values[(i * (k + 3) + k * k + i / 7) % values.len()];
            }
            if i % 3 == 0 {
                z.iter_mut().for_each(|v| *v *= 0.4);
            }
            assert_eq!(s.eval(&z).to_bits(), plain(&z).to_bits(), "{z:?}");
        }
    }
}
