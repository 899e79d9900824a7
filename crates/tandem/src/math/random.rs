//! Seeded random numbers, the ground floor of every stochastic part of tandem.
//!
//! * [`splitmix64`] and [`SplitMix64`]: a 64-bit hash and a tiny generator for per-run seeds,
//!   fault streams and reproducible test states (Steele, Lea, Flood 2014).
//! * The sensor noise streams (crate-internal): ChaCha8 streams keyed by a seed and a stream
//!   number, 53-bit uniforms and Box–Muller normals ([`crate::sim::sensors`] documents the
//!   stream numbers and the sampling).

use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// SplitMix64 step: a well-mixed 64-bit hash of `z` (Steele, Lea, Flood 2014). Used to derive
/// independent per-run seeds from a run index, and by [`SplitMix64`].
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A tiny seeded generator for reproducible test states (SplitMix64; not for statistics —
/// the sensors use ChaCha).
#[derive(Clone, Copy, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Uniform in `[0, 1)`, 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        let z = splitmix64(self.0);
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next_f64()
    }
    /// `n` values uniform in `[−a, a)`.
    pub fn vec(&mut self, n: usize, a: f64) -> Vec<f64> {
        (0..n).map(|_| self.range(-a, a)).collect()
    }
}

/// 2⁻⁵³.
pub(crate) const TWO_POW_M53: f64 = 1.0 / (1u64 << 53) as f64;

/// Uniform on `[0, 1)`, 53 random bits.
#[inline]
pub(crate) fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * TWO_POW_M53
}

/// A seeded ChaCha8 stream `stream` of key `seed_from_u64(seed)`.
pub(crate) fn stream_rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Standard normal samples by Box–Muller, keeping the second value of each pair.
#[derive(Clone, Debug)]
pub(crate) struct Gaussian {
    pub(crate) rng: ChaCha8Rng,
    pub(crate) spare: Option<f64>,
}

impl Gaussian {
    pub(crate) fn next(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        // u1 ∈ (0, 1] so ln u1 is finite; u2 ∈ [0, 1).
        let u1 = ((self.rng.next_u64() >> 11) + 1) as f64 * TWO_POW_M53;
        let u2 = uniform(&mut self.rng);
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}
