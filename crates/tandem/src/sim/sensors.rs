//! Simulated sensors (SPEC §2.5): joint encoders (`q`, `q̇` of every joint of every arm) and one
//! 2-D force sensor per end-effector (`F_i`, the force the object exerts on end-effector `i`, as
//! the plant's grasp multipliers give it). The controller sees only these readings.
//!
//! # Channel model
//!
//! Every scalar channel (one joint angle, one joint rate, one force component) is sampled with
//! period `h` and carries the same four optional imperfections, set per channel group by
//! [`ChannelNoise`]. With `u_k` the true value at sample `k`:
//!
//! ```text
//! low-pass:  x̄_k = x̄_{k−1} + α (u_k − x̄_{k−1}),   α = 1 − e^{−h/τ}   (τ = 0: x̄_k = u_k)
//! reading:   r_k = x̄_k + b + σ n_k,                n_k ~ N(0, 1) i.i.d.
//! dropout:   y_k = r_k        with probability 1 − p
//!            y_k = y_{k−1}    with probability p     (the previous reading is held)
//! ```
//!
//! `α` is the exact discretisation of `τ ẋ̄ = u − x̄` for an input held at `u_k` over the sample
//! interval, so a unit step seen from `x̄ = 0` gives `x̄_k = 1 − e^{−k h/τ}` exactly at the samples
//! (it is computed as `−expm1(−h/τ)` to keep digits when `h ≪ τ`).
//!
//! Design choices (SPEC §2.5 leaves them open):
//! - **Filter, then noise.** `τ` models the sensor's bandwidth (lag) and `σ` the noise on the
//!   published reading, so `σ` is the standard deviation of the reading about the filtered truth
//!   whatever `τ` is, and the two parameters do not interact.
//! - **Dropout holds the output, not the physics.** The filter keeps running through a dropped
//!   sample (it models the sensor's own dynamics); only the published value is stale.
//! - **Granularity.** Encoder dropout is per joint and per quantity (`q` and `q̇` drop
//!   independently); a force sensor drops both components of its reading together (one packet).
//!   Noise is independent on every scalar channel, including the two force components. Bias is
//!   one scalar per group, added to every channel of the group (both force components).
//! - **No filter start-up transient.** [`Sensors::reset`] sets every filter state to the given
//!   true values; if `sample` is called before any `reset`, the first sample primes the filters
//!   with that sample's truth.
//! - **Ideal channels are exact.** With `σ = 0, b = 0, τ = 0, p = 0` a reading is the truth
//!   bit for bit, and no random number is drawn for that channel.
//!
//! Gaussian samples come from the Box–Muller transform written out here (no `rand_distr`): with
//! `u₁ ∈ (0, 1]`, `u₂ ∈ [0, 1)` uniform on a 2⁻⁵³ grid,
//! `n = √(−2 ln u₁) · (cos 2πu₂, sin 2πu₂)` gives two independent standard normals; the second one
//! is kept for the next draw. Tails are cut at `√(106 ln 2) ≈ 8.6 σ` (probability ≈ 1e−17).
//!
//! # Seeding and determinism
//!
//! All randomness comes from [`SensorParams::seed`]. Six independent random processes — noise
//! and dropout of the `q`, `q̇` and force groups — each own a ChaCha8 stream:
//! `ChaCha8Rng::seed_from_u64(seed)` followed by `set_stream(k)` with `k` = 0 (q noise),
//! 1 (q dropout), 2 (q̇ noise), 3 (q̇ dropout), 4 (force noise), 5 (force dropout). ChaCha streams of
//! one key are independent sequences. Hence:
//! - the same seed and parameters give bitwise-identical readings (for a given platform and
//!   toolchain: `ln`, `sin_cos` come from the platform's math library);
//! - switching noise or dropout on in one group does not change the random realisation of any
//!   other group, and dropout does not change the noise realisation (noise is drawn even for a
//!   dropped sample);
//! - [`Sensors::reset`] re-seeds every stream, so a reset sensor replays the same sequence.
//!
//! Sweeps give each run its own `seed` (for example a base seed plus the run index).
//!
//! No allocation happens in [`Sensors::sample`] or [`Sensors::reset`]: buffers and filter states
//! are sized in [`Sensors::new`].

use nalgebra::{Vector2, Vector6};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{ModelError, non_negative, positive};
use crate::math::random::{Gaussian, stream_rng, uniform};

/// Imperfections of one group of scalar channels (all joint angles, all joint rates, or all force
/// components). The default is an ideal channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChannelNoise {
    /// Standard deviation `σ ≥ 0` of the additive white Gaussian noise, in the channel's unit
    /// (rad, rad/s or N).
    pub std_dev: f64,
    /// Constant bias `b` added to every channel of the group, in the channel's unit.
    pub bias: f64,
    /// Time constant `τ ≥ 0` of the first-order low-pass, s; 0 = no filter.
    pub tau: f64,
    /// Probability `p ∈ [0, 1)` that a sample is dropped (the previous reading is held).
    pub dropout: f64,
}

impl ChannelNoise {
    /// Check `std_dev ≥ 0`, `bias` finite, `tau ≥ 0`, `0 ≤ dropout < 1` (all finite); errors name
    /// the parameter as `{group}.{field}`, e.g. `encoder_q.std_dev`.
    pub fn validate(&self, group: &str) -> Result<(), ModelError> {
        non_negative(&format!("{group}.std_dev"), self.std_dev)?;
        if !self.bias.is_finite() {
            return Err(ModelError::invalid(
                format!("{group}.bias"),
                self.bias,
                "must be finite",
            ));
        }
        non_negative(&format!("{group}.tau"), self.tau)?;
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(ModelError::invalid(
                format!("{group}.dropout"),
                self.dropout,
                "must be in [0, 1)",
            ));
        }
        Ok(())
    }

    /// `true` when the channel is ideal (reading = truth).
    pub fn is_ideal(&self) -> bool {
        self.std_dev == 0.0 && self.bias == 0.0 && self.tau == 0.0 && self.dropout == 0.0
    }
}

/// Parameters of all simulated sensors: one [`ChannelNoise`] per channel group, and the seed.
/// The default is ideal sensors with seed 0.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorParams {
    /// Joint-angle encoders (every joint of every arm), rad.
    pub encoder_q: ChannelNoise,
    /// Joint-rate channels (every joint of every arm), rad/s.
    pub encoder_qd: ChannelNoise,
    /// End-effector force sensors (both components of every planar `F_i`; the three force
    /// components of a spatial wrist force/torque sensor), N.
    pub force: ChannelNoise,
    /// The three torque components of a spatial wrist force/torque sensor, N m (unused by
    /// planar plants).
    pub torque: ChannelNoise,
    /// Seed of every random stream (see the [module docs](self#seeding-and-determinism)).
    pub seed: u64,
}

impl SensorParams {
    /// Validate every group; errors name the field, e.g. `force.dropout`.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.encoder_q.validate("encoder_q")?;
        self.encoder_qd.validate("encoder_qd")?;
        self.force.validate("force")?;
        self.torque.validate("torque")
    }
}

// Stream numbers of the six random processes (documented in the module docs; changing them
// changes every noisy run).
const STREAM_Q: u64 = 0;
const STREAM_QD: u64 = 2;
const STREAM_FORCE: u64 = 4;
const STREAM_TORQUE: u64 = 6;

/// One group of scalar channels sharing a [`ChannelNoise`], split into sensors of `width`
/// channels that drop out together.
#[derive(Clone, Debug)]
struct Group {
    noise: ChannelNoise,
    /// Filter gain α = 1 − e^{−h/τ} (1 when τ = 0).
    alpha: f64,
    /// Channels per sensor (1 for an encoder channel, 2 for a force sensor).
    width: usize,
    /// No filter (`τ = 0`), bias, noise or dropout: a sample is the truth, bit for bit.
    ideal: bool,
    /// Stream number of the noise; the dropout stream is `stream + 1`.
    stream: u64,
    /// Low-pass states x̄, one per channel.
    filter: Vec<f64>,
    /// Published readings y, one per channel.
    reading: Vec<f64>,
    /// Whether each sensor's last sample was dropped.
    dropped: Vec<bool>,
    gauss: Gaussian,
    drop_rng: ChaCha8Rng,
}

impl Group {
    fn new(
        noise: &ChannelNoise,
        n_channels: usize,
        width: usize,
        h: f64,
        seed: u64,
        stream: u64,
    ) -> Self {
        let alpha = if noise.tau == 0.0 {
            1.0
        } else {
            -(-h / noise.tau).exp_m1()
        };
        Self {
            noise: *noise,
            alpha,
            width,
            ideal: alpha == 1.0
                && noise.bias == 0.0
                && !(noise.std_dev > 0.0)
                && !(noise.dropout > 0.0),
            stream,
            filter: vec![0.0; n_channels],
            reading: vec![0.0; n_channels],
            dropped: vec![false; n_channels.checked_div(width).unwrap_or(0)],
            gauss: Gaussian {
                rng: stream_rng(seed, stream),
                spare: None,
            },
            drop_rng: stream_rng(seed, stream + 1),
        }
    }

    /// Restart both random streams from `seed`.
    fn reseed(&mut self, seed: u64) {
        self.gauss = Gaussian {
            rng: stream_rng(seed, self.stream),
            spare: None,
        };
        self.drop_rng = stream_rng(seed, self.stream + 1);
    }

    /// Filter states ← truth; readings ← truth + bias (no noise).
    fn reset(&mut self, truth: impl Fn(usize) -> f64) {
        for (c, (x, y)) in self
            .filter
            .iter_mut()
            .zip(self.reading.iter_mut())
            .enumerate()
        {
            *x = truth(c);
            *y = *x;
            if self.noise.bias != 0.0 {
                *y += self.noise.bias;
            }
        }
    }

    /// One sample: truth(c) → filter → + bias + noise → (unless dropped) reading.
    fn sample(&mut self, truth: impl Fn(usize) -> f64) {
        self.sample_with(truth, None)
    }

    /// [`Group::sample`] of an ideal group whose truth is the slice `u` (channel `c` is
    /// `u[c]`): filter states and readings ← `u`, as the general path leaves them.
    #[inline]
    fn sample_ideal_slice(&mut self, u: &[f64]) {
        self.filter.copy_from_slice(u);
        self.reading.copy_from_slice(u);
        self.dropped.fill(false);
    }

    /// [`Group::sample`], with the dropouts taken from `drops` (one per sensor, another group's
    /// last draws: one packet) instead of drawn.
    fn sample_with(&mut self, truth: impl Fn(usize) -> f64, drops: Option<&[bool]>) {
        if self.ideal && drops.is_none() {
            // The general path below with α = 1, no bias, no noise, no dropout: filter state
            // and reading are the truth (no random draw is made there either).
            for (c, (x, y)) in self
                .filter
                .iter_mut()
                .zip(self.reading.iter_mut())
                .enumerate()
            {
                let u = truth(c);
                *x = u;
                *y = u;
            }
            self.dropped.fill(false);
            return;
        }
        let ChannelNoise {
            std_dev,
            bias,
            dropout,
            ..
        } = self.noise;
        let alpha = self.alpha;
        let width = self.width;
        for (s, (xs, ys)) in self
            .filter
            .chunks_exact_mut(width)
            .zip(self.reading.chunks_exact_mut(width))
            .enumerate()
        {
            // One dropout draw per sensor, only when dropout is on.
            let dropped = match drops {
                Some(d) => d[s],
                None => dropout > 0.0 && uniform(&mut self.drop_rng) < dropout,
            };
            self.dropped[s] = dropped;
            for (j, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
                let u = truth(s * width + j);
                // Low-pass (exact discretisation); τ = 0 passes u through bit for bit.
                *x = if alpha == 1.0 {
                    u
                } else {
                    *x + alpha * (u - *x)
                };
                // Noise is drawn even when the sample is dropped (stream independence).
                let n = if std_dev > 0.0 {
                    std_dev * self.gauss.next()
                } else {
                    0.0
                };
                if !dropped {
                    let mut r = *x;
                    if bias != 0.0 {
                        r += bias;
                    }
                    if std_dev > 0.0 {
                        r += n;
                    }
                    *y = r;
                }
            }
        }
    }
}

/// Simulated encoders and force sensors: parameters, filter states, random streams and the
/// latest readings, all sized at construction. See the [module docs](self) for the model.
///
/// Readings are flat: `q()` and `qd()` list the joints of arm 0, then arm 1, … (the plant's
/// order); [`force`](Self::force) gives arm `i`'s reading of `F_i`.
#[derive(Clone, Debug)]
pub struct Sensors {
    params: SensorParams,
    h_sample: f64,
    n_arms: usize,
    /// Channels per wrench: 2 (planar force) or 6 (spatial force/torque).
    wrench_dim: usize,
    q: Group,
    qd: Group,
    force: Group,
    /// Torque channels of spatial force/torque sensors (empty for planar sensors).
    torque: Group,
    /// Whether the filters hold a state (set by `reset` or the first `sample`).
    primed: bool,
}

impl Sensors {
    /// Sensors for `n_joints_total` joints (all arms together) and `n_arms` force sensors,
    /// sampled every `h_sample > 0` seconds. Validates `params`. The only allocation.
    ///
    /// Readings start at zero until [`reset`](Self::reset) or the first
    /// [`sample`](Self::sample).
    pub fn new(
        params: &SensorParams,
        n_joints_total: usize,
        n_arms: usize,
        h_sample: f64,
    ) -> Result<Self, ModelError> {
        Self::with_wrench_dim(params, n_joints_total, n_arms, 2, h_sample)
    }

    /// Sensors with wrist force/torque sensors of `wrench_dim` channels each: 2 (a planar force,
    /// [`new`](Self::new)) or 6 (a spatial wrist sensor `[f; τ]` in its own axes: `force`
    /// noise on the first three channels, `torque` noise on the last three; one packet, so
    /// a dropout holds all six).
    pub fn with_wrench_dim(
        params: &SensorParams,
        n_joints_total: usize,
        n_arms: usize,
        wrench_dim: usize,
        h_sample: f64,
    ) -> Result<Self, ModelError> {
        params.validate()?;
        if wrench_dim != 2 && wrench_dim != 6 {
            return Err(ModelError::geometry(
                "wrench_dim",
                format!("is {wrench_dim}: a force sensor has 2 (planar) or 6 (spatial) channels"),
            ));
        }
        let (nf, wf, nt) = if wrench_dim == 2 {
            (2 * n_arms, 2, 0)
        } else {
            (3 * n_arms, 3, 3 * n_arms)
        };
        positive("h_sample", h_sample)?;
        let seed = params.seed;
        Ok(Self {
            params: params.clone(),
            h_sample,
            n_arms,
            q: Group::new(
                &params.encoder_q,
                n_joints_total,
                1,
                h_sample,
                seed,
                STREAM_Q,
            ),
            qd: Group::new(
                &params.encoder_qd,
                n_joints_total,
                1,
                h_sample,
                seed,
                STREAM_QD,
            ),
            force: Group::new(&params.force, nf, wf, h_sample, seed, STREAM_FORCE),
            torque: Group::new(&params.torque, nt, 3, h_sample, seed, STREAM_TORQUE),
            wrench_dim,
            primed: false,
        })
    }

    /// Start over from the true values: every filter state is set to the truth, every reading to
    /// truth + bias (no noise), and every random stream is re-seeded from
    /// [`SensorParams::seed`]. Call at the start of a run.
    ///
    /// # Panics
    /// If `q.len()` or `qd.len()` differs from [`n_joints`](Self::n_joints) or `forces.len()`
    /// from [`n_arms`](Self::n_arms).
    pub fn reset(&mut self, q: &[f64], qd: &[f64], forces: &[Vector2<f64>]) {
        assert_eq!(self.wrench_dim, 2, "Sensors::reset takes planar forces");
        self.check_dims(q, qd, forces.len());
        self.reset_inner(q, qd, |c| forces[c / 2][c % 2], |_| 0.0);
    }

    fn reset_inner(
        &mut self,
        q: &[f64],
        qd: &[f64],
        f: impl Fn(usize) -> f64,
        t: impl Fn(usize) -> f64,
    ) {
        let seed = self.params.seed;
        self.q.reseed(seed);
        self.qd.reseed(seed);
        self.force.reseed(seed);
        self.torque.reseed(seed);
        self.q.reset(|c| q[c]);
        self.qd.reset(|c| qd[c]);
        self.force.reset(f);
        self.torque.reset(t);
        self.primed = true;
    }

    /// [`reset`](Self::reset) for 6-axis sensors: `wrenches[i]` is arm `i`'s true wrench
    /// `[f; τ]` in the sensor's axes, (N, N m).
    ///
    /// # Panics
    /// On a length mismatch, or if the sensors are planar.
    pub fn reset_wrenches(&mut self, q: &[f64], qd: &[f64], wrenches: &[Vector6<f64>]) {
        assert_eq!(
            self.wrench_dim, 6,
            "Sensors::reset_wrenches takes 6-axis sensors"
        );
        self.check_dims(q, qd, wrenches.len());
        self.reset_inner(
            q,
            qd,
            |c| wrenches[c / 3][c % 3],
            |c| wrenches[c / 3][3 + c % 3],
        );
    }

    /// [`sample`](Self::sample) for 6-axis sensors (`wrenches` as in
    /// [`reset_wrenches`](Self::reset_wrenches)). No allocation.
    ///
    /// # Panics
    /// On a length mismatch, or if the sensors are planar.
    pub fn sample_wrenches(&mut self, q: &[f64], qd: &[f64], wrenches: &[Vector6<f64>]) {
        if !self.primed {
            self.reset_wrenches(q, qd, wrenches);
        }
        assert_eq!(
            self.wrench_dim, 6,
            "Sensors::sample_wrenches takes 6-axis sensors"
        );
        self.check_dims(q, qd, wrenches.len());
        self.q.sample(|c| q[c]);
        self.qd.sample(|c| qd[c]);
        self.force.sample(|c| wrenches[c / 3][c % 3]);
        let Sensors { force, torque, .. } = self;
        torque.sample_with(|c| wrenches[c / 3][3 + c % 3], Some(&force.dropped));
    }

    /// Wrist force/torque reading `[f; τ]` of arm `arm` in the sensor's axes, (N, N m).
    ///
    /// # Panics
    /// If `arm >= n_arms()` or the sensors are planar.
    pub fn wrench(&self, arm: usize) -> Vector6<f64> {
        assert_eq!(self.wrench_dim, 6, "Sensors::wrench reads 6-axis sensors");
        let f = &self.force.reading[3 * arm..3 * arm + 3];
        let t = &self.torque.reading[3 * arm..3 * arm + 3];
        Vector6::new(f[0], f[1], f[2], t[0], t[1], t[2])
    }

    /// Channels per wrench: 2 (planar) or 6 (spatial).
    pub fn wrench_dim(&self) -> usize {
        self.wrench_dim
    }

    /// [`reset`](Self::reset) / [`reset_wrenches`](Self::reset_wrenches) from flat wrenches
    /// (`wrench_dim` channels per arm, arm order: planar `[F_x, F_y]`, spatial `[f; τ]` in the
    /// sensors' axes), so one loop serves both plants.
    ///
    /// # Panics
    /// On a length mismatch.
    pub fn reset_flat(&mut self, q: &[f64], qd: &[f64], wrenches: &[f64]) {
        let w = self.wrench_dim;
        assert_eq!(
            wrenches.len(),
            w * self.n_arms,
            "Sensors: wrenches has the wrong length"
        );
        self.check_dims(q, qd, wrenches.len() / w);
        if w == 2 {
            self.reset_inner(q, qd, |c| wrenches[c], |_| 0.0);
        } else {
            self.reset_inner(
                q,
                qd,
                |c| wrenches[6 * (c / 3) + c % 3],
                |c| wrenches[6 * (c / 3) + 3 + c % 3],
            );
        }
    }

    /// [`sample`](Self::sample) / [`sample_wrenches`](Self::sample_wrenches) from flat
    /// wrenches (as in [`reset_flat`](Self::reset_flat)); the same readings, bit for bit. No
    /// allocation.
    ///
    /// # Panics
    /// On a length mismatch.
    pub fn sample_flat(&mut self, q: &[f64], qd: &[f64], wrenches: &[f64]) {
        if !self.primed {
            self.reset_flat(q, qd, wrenches);
        }
        let w = self.wrench_dim;
        assert_eq!(
            wrenches.len(),
            w * self.n_arms,
            "Sensors: wrenches has the wrong length"
        );
        self.check_dims(q, qd, wrenches.len() / w);
        if w == 2 && self.q.ideal && self.qd.ideal && self.force.ideal {
            // Ideal planar sensors: the readings are the truth (Group::sample's ideal path).
            self.q.sample_ideal_slice(q);
            self.qd.sample_ideal_slice(qd);
            self.force.sample_ideal_slice(wrenches);
            return;
        }
        self.q.sample(|c| q[c]);
        self.qd.sample(|c| qd[c]);
        if w == 2 {
            self.force.sample(|c| wrenches[c]);
        } else {
            self.force.sample(|c| wrenches[6 * (c / 3) + c % 3]);
            let Sensors { force, torque, .. } = self;
            torque.sample_with(|c| wrenches[6 * (c / 3) + 3 + c % 3], Some(&force.dropped));
        }
    }

    /// Every wrist reading, flat (`wrench_dim` channels per arm, as
    /// [`reset_flat`](Self::reset_flat) takes them). No allocation.
    pub fn read_wrenches(&self, out: &mut [f64]) {
        if self.wrench_dim == 2 {
            out.copy_from_slice(&self.force.reading);
        } else {
            for i in 0..self.n_arms {
                out[6 * i..6 * i + 3].copy_from_slice(&self.force.reading[3 * i..3 * i + 3]);
                out[6 * i + 3..6 * i + 6].copy_from_slice(&self.torque.reading[3 * i..3 * i + 3]);
            }
        }
    }

    /// Take one sample of the true `q`, `q̇` (rad, rad/s, length [`n_joints`](Self::n_joints))
    /// and end-effector forces `F_i` (N, length [`n_arms`](Self::n_arms)); call once every
    /// [`h_sample`](Self::h_sample) seconds. `(q, q̇, F_i)` → readings.
    ///
    /// Before any [`reset`](Self::reset), the first call primes the filters with this truth.
    /// Non-finite truth passes through to the readings (and the filter states).
    ///
    /// # Panics
    /// On a length mismatch, as [`reset`](Self::reset).
    pub fn sample(&mut self, q: &[f64], qd: &[f64], forces: &[Vector2<f64>]) {
        if !self.primed {
            self.reset(q, qd, forces);
        }
        self.check_dims(q, qd, forces.len());
        self.q.sample(|c| q[c]);
        self.qd.sample(|c| qd[c]);
        self.force.sample(|c| forces[c / 2][c % 2]);
    }

    fn check_dims(&self, q: &[f64], qd: &[f64], n_forces: usize) {
        assert_eq!(q.len(), self.n_joints(), "Sensors: q has the wrong length");
        assert_eq!(
            qd.len(),
            self.n_joints(),
            "Sensors: qd has the wrong length"
        );
        assert_eq!(
            n_forces, self.n_arms,
            "Sensors: forces has the wrong length"
        );
    }

    /// Joint-angle readings, rad, length [`n_joints`](Self::n_joints).
    pub fn q(&self) -> &[f64] {
        &self.q.reading
    }

    /// Joint-rate readings, rad/s, length [`n_joints`](Self::n_joints).
    pub fn qd(&self) -> &[f64] {
        &self.qd.reading
    }

    /// Force-sensor reading of arm `arm` (`F_i`, N, world frame).
    ///
    /// # Panics
    /// If `arm >= n_arms()`.
    pub fn force(&self, arm: usize) -> Vector2<f64> {
        let f = &self.force.reading[2 * arm..2 * arm + 2];
        Vector2::new(f[0], f[1])
    }

    /// All force readings, flat `[F_0x, F_0y, F_1x, F_1y, …]`, N, length `2 · n_arms`.
    pub fn forces_flat(&self) -> &[f64] {
        &self.force.reading
    }

    /// The parameters the sensors were built with.
    pub fn params(&self) -> &SensorParams {
        &self.params
    }

    /// Sampling period `h`, s.
    pub fn h_sample(&self) -> f64 {
        self.h_sample
    }

    /// Number of joints over all arms.
    pub fn n_joints(&self) -> usize {
        self.q.reading.len()
    }

    /// Number of arms (force sensors).
    pub fn n_arms(&self) -> usize {
        self.n_arms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: f64 = 1e-3;

    #[test]
    fn the_ideal_group_fast_path_gives_the_general_path_bits() {
        // An ideal group (no filter, bias, noise or dropout) takes the copy path; the general
        // path on the same group must give the same filter states, readings and dropouts.
        let ideal = ChannelNoise::default();
        for width in [1, 2, 3] {
            let mut fast = Group::new(&ideal, 6, width, H, 7, 0);
            assert!(fast.ideal);
            let mut general = fast.clone();
            general.ideal = false;
            for k in 0..100 {
                let truth =
                    |c: usize| (k as f64 * 0.37 + c as f64).sin() * 10f64.powi(c as i32 - 3);
                fast.sample(truth);
                general.sample(truth);
                let bits = |g: &Group| {
                    (g.filter.iter().chain(&g.reading))
                        .map(|v| v.to_bits())
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(&fast), bits(&general));
                assert_eq!(fast.dropped, general.dropped);
            }
        }
        // Sensors::sample_flat's whole-slice copy for ideal planar sensors: the general path's
        // bits.
        let mut fast = Sensors::new(&SensorParams::default(), 4, 2, H).unwrap();
        let mut general = fast.clone();
        for g in [&mut general.q, &mut general.qd, &mut general.force] {
            g.ideal = false;
        }
        for k in 1..50 {
            let (q, qd, f) = truth(k);
            let w: Vec<f64> = f.iter().flat_map(|v| [v.x, v.y]).collect();
            fast.sample_flat(&q, &qd, &w);
            general.sample_flat(&q, &qd, &w);
            for (a, b) in [
                (&fast.q, &general.q),
                (&fast.qd, &general.qd),
                (&fast.force, &general.force),
            ] {
                let bits = |g: &Group| {
                    (g.filter.iter().chain(&g.reading))
                        .map(|v| v.to_bits())
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(a), bits(b));
                assert_eq!(a.dropped, b.dropped);
            }
        }
        // Any imperfection leaves the general path.
        for n in [
            noisy(0.1, 0.0, 0.0, 0.0),
            noisy(0.0, 0.1, 0.0, 0.0),
            noisy(0.0, 0.0, 0.01, 0.0),
            noisy(0.0, 0.0, 0.0, 0.1),
        ] {
            assert!(!Group::new(&n, 6, 2, H, 7, 0).ideal);
        }
    }

    fn noisy(std_dev: f64, bias: f64, tau: f64, dropout: f64) -> ChannelNoise {
        ChannelNoise {
            std_dev,
            bias,
            tau,
            dropout,
        }
    }

    /// A smooth, never-repeating truth signal for sample k: 4 joints, 2 arms.
    fn truth(k: usize) -> ([f64; 4], [f64; 4], [Vector2<f64>; 2]) {
        let t = k as f64 * H;
        let q = [t.sin(), 0.3 + t, (2.0 * t).cos(), -1.0 + 0.1 * t * t];
        let qd = [t.cos(), 1.0, -2.0 * (2.0 * t).sin(), 0.2 * t];
        let f = [
            Vector2::new(3.0 * t, -4.0 + t.sin()),
            Vector2::new(-3.0 * t, 5.0 * t.cos()),
        ];
        (q, qd, f)
    }

    /// Run `n` samples and record every reading (q, q̇, forces) as bits.
    fn record(params: &SensorParams, n: usize) -> Vec<u64> {
        let mut s = Sensors::new(params, 4, 2, H).unwrap();
        let (q, qd, f) = truth(0);
        s.reset(&q, &qd, &f);
        let mut out = Vec::new();
        for k in 1..=n {
            let (q, qd, f) = truth(k);
            s.sample(&q, &qd, &f);
            out.extend(
                s.q()
                    .iter()
                    .chain(s.qd())
                    .chain(s.forces_flat())
                    .map(|v| v.to_bits()),
            );
        }
        out
    }

    fn all_noisy(seed: u64) -> SensorParams {
        SensorParams {
            encoder_q: noisy(1e-3, 1e-4, 0.0, 0.1),
            encoder_qd: noisy(1e-2, 0.0, 0.005, 0.0),
            force: noisy(0.5, -0.2, 0.002, 0.05),
            seed,
            ..Default::default()
        }
    }

    #[test]
    fn ideal_sensors_are_exact() {
        let params = SensorParams::default();
        assert!(
            params.encoder_q.is_ideal() && params.encoder_qd.is_ideal() && params.force.is_ideal()
        );
        let mut s = Sensors::new(&params, 4, 2, H).unwrap();
        for k in 0..1000 {
            let (q, qd, f) = truth(k);
            s.sample(&q, &qd, &f);
            assert_eq!(s.q(), &q);
            assert_eq!(s.qd(), &qd);
            assert_eq!(s.force(0), f[0]);
            assert_eq!(s.force(1), f[1]);
        }
    }

    #[test]
    fn same_seed_is_bitwise_identical_different_seed_differs() {
        let a = record(&all_noisy(7), 2000);
        let b = record(&all_noisy(7), 2000);
        assert_eq!(a, b);
        let c = record(&all_noisy(8), 2000);
        assert_ne!(a, c);
        // Differs almost everywhere, not in a few places.
        let same = a.iter().zip(&c).filter(|(x, y)| x == y).count();
        assert!(same < a.len() / 10, "{same} of {} readings equal", a.len());
    }

    /// A reset re-seeds: the sequence after a second reset replays the first.
    #[test]
    fn reset_replays_the_sequence() {
        let params = all_noisy(3);
        let mut s = Sensors::new(&params, 4, 2, H).unwrap();
        let run = |s: &mut Sensors| {
            let (q, qd, f) = truth(0);
            s.reset(&q, &qd, &f);
            let mut v = Vec::new();
            for k in 1..200 {
                let (q, qd, f) = truth(k);
                s.sample(&q, &qd, &f);
                v.extend(
                    s.q()
                        .iter()
                        .chain(s.qd())
                        .chain(s.forces_flat())
                        .map(|x| x.to_bits()),
                );
            }
            v
        };
        let first = run(&mut s);
        assert_eq!(first, run(&mut s));
    }

    /// Streams are independent: enabling encoder noise/dropout or force dropout leaves the force
    /// noise realisation unchanged.
    #[test]
    fn groups_draw_from_independent_streams() {
        let force_only = SensorParams {
            force: noisy(0.5, 0.0, 0.0, 0.0),
            seed: 11,
            ..Default::default()
        };
        let mut everything = all_noisy(11);
        everything.force = force_only.force;
        let mut a = Sensors::new(&force_only, 4, 2, H).unwrap();
        let mut b = Sensors::new(&everything, 4, 2, H).unwrap();
        for k in 0..500 {
            let (q, qd, f) = truth(k);
            a.sample(&q, &qd, &f);
            b.sample(&q, &qd, &f);
            assert_eq!(a.forces_flat(), b.forces_flat());
        }
        // With dropout on, every reading that is updated carries the same noise as without.
        let mut dropping = force_only.clone();
        dropping.force.dropout = 0.5;
        let mut c = Sensors::new(&force_only, 4, 2, H).unwrap();
        let mut d = Sensors::new(&dropping, 4, 2, H).unwrap();
        let mut updated = 0;
        for k in 0..500 {
            let (q, qd, f) = truth(k);
            c.sample(&q, &qd, &f);
            let before = d.force(0);
            d.sample(&q, &qd, &f);
            if d.force(0) != before {
                assert_eq!(d.force(0), c.force(0));
                updated += 1;
            }
        }
        assert!(updated > 150, "{updated}");
    }

    /// Mean and standard deviation of 1e5 noise samples (σ = 0.1, zero bias) on a constant truth.
    /// Estimator standard errors: mean σ/√N = 3.2e-4; standard deviation ≈ σ/√(2N) = 2.2e-4 for
    /// Gaussian data. We allow 5 standard errors (two-sided false-alarm probability 6e-7, and the
    /// seed is fixed). Shape checks: P(|n| < σ) = 0.6827 (binomial s.e. 1.5e-3), excess kurtosis
    /// 0 (s.e. √(24/N) = 0.015), and lag-1 autocorrelation 0 (s.e. 1/√N): all at 5 s.e.
    #[test]
    fn noise_statistics() {
        let sigma = 0.1;
        let truth_q = 0.7;
        let params = SensorParams {
            encoder_q: noisy(sigma, 0.0, 0.0, 0.0),
            seed: 2024,
            ..Default::default()
        };
        let mut s = Sensors::new(&params, 1, 0, H).unwrap();
        let n = 100_000;
        let mut e = Vec::with_capacity(n);
        for _ in 0..n {
            s.sample(&[truth_q], &[0.0], &[]);
            e.push(s.q()[0] - truth_q);
        }
        let nf = n as f64;
        let mean = e.iter().sum::<f64>() / nf;
        let var = e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (nf - 1.0);
        let sd = var.sqrt();
        let m4 = e.iter().map(|x| (x - mean).powi(4)).sum::<f64>() / nf;
        let kurt = m4 / (var * var) - 3.0;
        let within = e.iter().filter(|x| x.abs() < sigma).count() as f64 / nf;
        let rho1 = e
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f64>()
            / (nf - 1.0)
            / var;
        println!(
            "noise: mean {mean:.3e}, sd {sd:.5}, P(|n|<σ) {within:.4}, excess kurtosis {kurt:.4}, ρ₁ {rho1:.4}"
        );
        assert!(mean.abs() < 5.0 * sigma / nf.sqrt());
        assert!((sd - sigma).abs() < 5.0 * sigma / (2.0 * nf).sqrt());
        assert!((within - 0.682_689_492).abs() < 5.0 * (0.6827 * 0.3173 / nf).sqrt());
        assert!(kurt.abs() < 5.0 * (24.0 / nf).sqrt());
        assert!(rho1.abs() < 5.0 / nf.sqrt());
    }

    /// The two components of a force sensor carry independent noise (correlation within 5/√N).
    #[test]
    fn force_components_are_independent() {
        let params = SensorParams {
            force: noisy(1.0, 0.0, 0.0, 0.0),
            seed: 5,
            ..Default::default()
        };
        let mut s = Sensors::new(&params, 0, 1, H).unwrap();
        let n = 100_000;
        let zero = [Vector2::zeros()];
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            s.sample(&[], &[], &zero);
            let f = s.force(0);
            sxy += f.x * f.y;
            sxx += f.x * f.x;
            syy += f.y * f.y;
        }
        let corr = sxy / (sxx * syy).sqrt();
        println!("force x–y noise correlation {corr:.4}");
        assert!(corr.abs() < 5.0 / (n as f64).sqrt());
    }

    #[test]
    fn bias_adds_exactly() {
        let b = 0.125;
        let params = SensorParams {
            encoder_q: noisy(0.0, b, 0.0, 0.0),
            encoder_qd: noisy(0.0, -b, 0.0, 0.0),
            force: noisy(0.0, 2.0 * b, 0.0, 0.0),
            seed: 1,
            ..Default::default()
        };
        let mut s = Sensors::new(&params, 4, 2, H).unwrap();
        for k in 0..100 {
            let (q, qd, f) = truth(k);
            s.sample(&q, &qd, &f);
            for j in 0..4 {
                assert_eq!(s.q()[j], q[j] + b);
                assert_eq!(s.qd()[j], qd[j] - b);
            }
            for (i, fi) in f.iter().enumerate() {
                assert_eq!(s.force(i), fi.add_scalar(2.0 * b));
            }
        }
    }

    /// Unit step from a filter reset at 0: reading_k = 1 − e^{−k h/τ} at every sample, for every
    /// group (force: both components).
    #[test]
    fn low_pass_step_response() {
        let tau = 0.05;
        let lp = noisy(0.0, 0.0, tau, 0.0);
        let params = SensorParams {
            encoder_q: lp,
            encoder_qd: lp,
            force: lp,
            seed: 0,
            ..Default::default()
        };
        let mut s = Sensors::new(&params, 2, 1, H).unwrap();
        s.reset(&[0.0; 2], &[0.0; 2], &[Vector2::zeros()]);
        let mut worst: f64 = 0.0;
        for k in 1..=1000 {
            s.sample(&[1.0; 2], &[1.0; 2], &[Vector2::new(1.0, 1.0)]);
            let expect = 1.0 - (-(k as f64) * H / tau).exp();
            for &r in s.q().iter().chain(s.qd()).chain(s.forces_flat()) {
                worst = worst.max((r - expect).abs());
            }
        }
        println!("low-pass step response: worst deviation {worst:.2e}");
        assert!(worst < 1e-13);
    }

    /// After a reset at the truth a filtered channel reads the truth at once (no start-up
    /// transient from zero) and stays there on a constant input; before any reset the first sample
    /// primes the filter.
    #[test]
    fn filters_start_at_the_truth() {
        let params = SensorParams {
            encoder_q: noisy(0.0, 0.0, 0.1, 0.0),
            ..Default::default()
        };
        let mut s = Sensors::new(&params, 1, 0, H).unwrap();
        s.sample(&[2.5], &[0.0], &[]);
        assert_eq!(s.q(), &[2.5]);
        s.reset(&[-1.0], &[0.0], &[]);
        assert_eq!(s.q(), &[-1.0]);
        for _ in 0..100 {
            s.sample(&[-1.0], &[0.0], &[]);
            assert_eq!(s.q(), &[-1.0]);
        }
    }

    /// Dropout rate p = 0.3 over 1e5 samples of a changing signal (a held sample is visible as a
    /// stale reading). The count is Binomial(N, p): s.e. of the rate √(p(1−p)/N) = 1.45e-3; we
    /// allow 5 s.e. Also: a force sensor drops both components together, and the held value is
    /// exactly the previous reading.
    #[test]
    fn dropout_rate_and_hold() {
        let p = 0.3;
        let params = SensorParams {
            encoder_q: noisy(0.0, 0.0, 0.0, p),
            force: noisy(0.0, 0.0, 0.0, p),
            seed: 99,
            ..Default::default()
        };
        let mut s = Sensors::new(&params, 1, 1, H).unwrap();
        s.reset(&[0.0], &[0.0], &[Vector2::zeros()]);
        let n = 100_000;
        let (mut dq, mut df) = (0usize, 0usize);
        for k in 1..=n {
            let v = k as f64;
            let (q_prev, f_prev) = (s.q()[0], s.force(0));
            s.sample(&[v], &[0.0], &[Vector2::new(v, -v)]);
            if s.q()[0] == v {
            } else {
                assert_eq!(s.q()[0], q_prev);
                dq += 1;
            }
            let f = s.force(0);
            if f == Vector2::new(v, -v) {
            } else {
                assert_eq!(f, f_prev, "both components held together");
                df += 1;
            }
        }
        let nf = n as f64;
        let (rq, rf) = (dq as f64 / nf, df as f64 / nf);
        let bound = 5.0 * (p * (1.0 - p) / nf).sqrt();
        println!("dropout: encoder rate {rq:.4}, force rate {rf:.4} (p = {p}, bound ±{bound:.4})");
        assert!((rq - p).abs() < bound && (rf - p).abs() < bound);
    }

    #[test]
    fn validation_names_the_field() {
        let bad = |f: fn(&mut SensorParams), name: &str| {
            let mut p = SensorParams::default();
            f(&mut p);
            match Sensors::new(&p, 2, 1, H) {
                Err(ModelError::Invalid { param, .. }) => assert_eq!(param, name),
                other => panic!("{name}: {other:?}"),
            }
        };
        bad(|p| p.encoder_q.std_dev = -1.0, "encoder_q.std_dev");
        bad(|p| p.encoder_qd.tau = -0.1, "encoder_qd.tau");
        bad(|p| p.force.dropout = 1.0, "force.dropout");
        bad(|p| p.force.dropout = -0.1, "force.dropout");
        bad(|p| p.encoder_q.bias = f64::NAN, "encoder_q.bias");
        bad(
            |p| p.encoder_qd.std_dev = f64::INFINITY,
            "encoder_qd.std_dev",
        );
        assert!(matches!(
            Sensors::new(&SensorParams::default(), 2, 1, 0.0),
            Err(ModelError::Invalid { ref param, .. }) if param == "h_sample"
        ));
    }

    /// 6-axis wrist sensors: ideal channels are exact; force and torque channels carry their
    /// own σ; a dropout holds all six channels of a sensor together (one packet).
    #[test]
    fn six_axis_sensors_share_packets_and_keep_their_own_noise() {
        let truth = |k: usize| {
            let t = k as f64 * H;
            [
                Vector6::new(t.sin(), 2.0 * t, -1.0, 0.1 * t, t.cos(), 0.5),
                Vector6::new(-t, 3.0, t * t, -0.2, 0.3 * t, (2.0 * t).sin()),
            ]
        };
        let q = [0.1, 0.2];
        let mut ideal = Sensors::with_wrench_dim(&SensorParams::default(), 2, 2, 6, H).unwrap();
        for k in 0..100 {
            let w = truth(k);
            ideal.sample_wrenches(&q, &q, &w);
            assert_eq!(ideal.wrench(0), w[0]);
            assert_eq!(ideal.wrench(1), w[1]);
        }
        let params = SensorParams {
            force: noisy(0.5, 0.0, 0.0, 0.3),
            torque: noisy(0.01, 0.0, 0.0, 0.0),
            seed: 3,
            ..Default::default()
        };
        let mut s = Sensors::with_wrench_dim(&params, 2, 2, 6, H).unwrap();
        s.reset_wrenches(&q, &q, &truth(0));
        let (mut sf, mut st, mut n) = (0.0, 0.0, 0usize);
        let mut prev = [s.wrench(0), s.wrench(1)];
        let (mut held, mut partial) = (0usize, 0usize);
        for k in 1..20000 {
            let w = truth(k);
            s.sample_wrenches(&q, &q, &w);
            for i in 0..2 {
                let r = s.wrench(i);
                let same = (0..6).filter(|&c| r[c] == prev[i][c]).count();
                if same == 6 {
                    held += 1;
                } else if same > 0 {
                    partial += 1;
                } else {
                    let e = r - w[i];
                    sf += e.fixed_rows::<3>(0).norm_squared();
                    st += e.fixed_rows::<3>(3).norm_squared();
                    n += 3;
                }
                prev[i] = r;
            }
        }
        assert_eq!(partial, 0, "a packet must drop whole");
        // 40 000 sensor samples at p = 0.3: 12 000 ± 92 (1σ) held.
        assert!((held as f64 - 12000.0).abs() < 600.0, "held {held}");
        let (sd_f, sd_t) = ((sf / n as f64).sqrt(), (st / n as f64).sqrt());
        // ~84 000 channel samples each: relative standard error of σ̂ ≈ 0.25 %.
        assert!((sd_f / 0.5 - 1.0).abs() < 0.02, "force σ {sd_f}");
        assert!((sd_t / 0.01 - 1.0).abs() < 0.02, "torque σ {sd_t}");
        assert!(Sensors::with_wrench_dim(&params, 2, 2, 3, H).is_err());
    }
}
