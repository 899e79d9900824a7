//! Gaussian RBF network (8), (41), (44) — interim grid implementation (to be replaced by the
//! full module with general centres).

use crate::error::{ModelError, positive};

/// A grid of centres: the Cartesian product of `levels` over `n_inputs` inputs; input 0 varies
/// slowest, the last input fastest.
#[derive(Clone, Debug)]
pub struct RbfGrid {
    n_inputs: usize,
    levels: Vec<f64>,
    inv_w2: f64,
    factors: Vec<f64>,
}

impl RbfGrid {
    /// Same levels on every input; `width2 = ϑ²`.
    pub fn uniform(n_inputs: usize, levels: &[f64], width2: f64) -> Result<Self, ModelError> {
        positive("width2", width2)?;
        Ok(RbfGrid {
            n_inputs,
            levels: levels.to_vec(),
            inv_w2: 1.0 / width2,
            factors: vec![0.0; n_inputs * levels.len()],
        })
    }
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.levels.len().pow(self.n_inputs as u32)
    }
    /// `S(Z)` as a Kronecker product of per-input factors, into `s`.
    pub fn eval_into(&mut self, z: &[f64], s: &mut [f64]) {
        let l = self.levels.len();
        for i in 0..self.n_inputs {
            for (k, c) in self.levels.iter().enumerate() {
                let d = z[i] - c;
                self.factors[i * l + k] = (-d * d * self.inv_w2).exp();
            }
        }
        s[0] = 1.0;
        let mut len = 1;
        for i in 0..self.n_inputs {
            for p in (0..len).rev() {
                let v = s[p];
                for k in 0..l {
                    s[p * l + k] = v * self.factors[i * l + k];
                }
            }
            len *= l;
        }
    }
}

/// Weights of an adaptive network with `n_out` outputs, interleaved by node.
#[derive(Clone, Debug)]
pub struct AdaptiveRbf {
    n_out: usize,
    w: Vec<f64>,
    theta: Vec<f64>,
    sigma: Vec<f64>,
}

impl AdaptiveRbf {
    /// Zero weights.
    pub fn new(
        n_nodes: usize,
        n_out: usize,
        theta: &[f64],
        sigma: &[f64],
    ) -> Result<Self, ModelError> {
        for j in 0..n_out {
            positive(&format!("theta[{j}]"), theta[j])?;
            positive(&format!("sigma[{j}]"), sigma[j])?;
        }
        Ok(AdaptiveRbf {
            n_out,
            w: vec![0.0; n_nodes * n_out],
            theta: theta[..n_out].to_vec(),
            sigma: sigma[..n_out].to_vec(),
        })
    }
    /// Zero the weights.
    pub fn reset(&mut self) {
        self.w.fill(0.0);
    }
    /// The weights, interleaved by node (`w[k·n_out + j]` is node k of output j).
    pub fn weights(&self) -> &[f64] {
        &self.w
    }
    /// `‖Ŵ_j‖`.
    pub fn weight_norm(&self, j: usize) -> f64 {
        self.w
            .iter()
            .skip(j)
            .step_by(self.n_out)
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt()
    }
    /// Outputs with the current weights, then the exact held-input update of (44).
    pub fn tick(
        &mut self,
        s: &[f64],
        q: f64,
        z2: &[f64],
        h: f64,
        out: &mut [f64],
        norms: &mut [f64],
    ) {
        let n = self.n_out;
        let mut decay = [0.0; 8];
        let mut gain = [0.0; 8];
        for j in 0..n {
            let a = self.theta[j] * self.sigma[j] * h;
            decay[j] = (-a).exp();
            // −(1 − e^{−Θσh})/σ · Q z2_j (multiplies S_k).
            gain[j] = (-a).exp_m1() / self.sigma[j] * q * z2[j];
            out[j] = 0.0;
            norms[j] = 0.0;
        }
        for (k, sk) in s.iter().enumerate() {
            for j in 0..n {
                let w = &mut self.w[k * n + j];
                out[j] += *w * sk;
                *w = decay[j] * *w + gain[j] * sk;
                norms[j] += *w * *w;
            }
        }
        for v in norms.iter_mut().take(n) {
            *v = v.sqrt();
        }
    }
}
