//! The RBF weight-pass kernels (issue 12), beside the equations of [`super::network`]: the
//! [`Kernel`] choice and the CPU detection behind it, the portable kernels, and the AVX2
//! (`avx2.rs`) and AVX-512 (`avx512.rs`) builds on x86-64.

use crate::error::ModelError;

use super::MAX_OUTPUTS;

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;

/// Whether the AVX2 kernels may run on this CPU.
pub(crate) fn detect_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Name of the environment variable that forces a weight-pass kernel.
pub const KERNEL_ENV: &str = "TANDEM_KERNEL";

/// The weight-pass kernel of [`RbfNetwork`](super::RbfNetwork), chosen once at set-up (never one the CPU lacks).
///
/// Determinism policy (`docs/performance.md`): the same binary on the same machine with the
/// same kernel gives bitwise-identical runs. [`Kernel::Portable`] and [`Kernel::Avx2`] use the
/// same IEEE operations in the same order and give the same bits (results pinned to bits are
/// pinned to them). [`Kernel::Avx2Fma`] fuses `acc + w·S`, `e·w − c·S` and `n2 + w²` into
/// single-rounding FMAs, and [`Kernel::Avx512`] also regroups the grid pass (`(c a_i)·b`,
/// `a_i Σ b w`): each weight update differs by at most a few ulps per tick. [`Kernel::Batched`]
/// applies the same exact update 16 ticks at a time (the decay as a running product, the
/// outputs of held terms through dot products of the factors). The AVX-512 kernels also
/// evaluate `S(Z)`'s exponentials with their own vector `exp` (within 1 ulp). The results agree
/// with the portable reference to a relative tolerance (tested: `1e-12` on the weights and
/// outputs after 1000 ticks of the paper network). [`Kernel::BatchedF32`] stores the weights in
/// single precision and has its own tolerance (tested: `2e-6`). The default is the fastest
/// double-precision kernel the CPU has ([`Kernel::default_for_cpu`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Plain Rust, any CPU; the reference.
    Portable,
    /// AVX2, no FMA: bit-identical to [`Kernel::Portable`]. The default where available.
    Avx2,
    /// AVX2 with FMA: faster, not bit-identical (within the stated tolerance).
    Avx2Fma,
    /// AVX-512F (512-bit registers, fused multiply-adds, blocks of 8 nodes): not
    /// bit-identical (within the stated tolerance).
    Avx512,
    /// AVX-512F with the update of [`RbfNetwork::tick_at_outputs`](super::RbfNetwork::tick_at_outputs) held and applied
    /// [`BATCH_DEPTH`](super::BATCH_DEPTH) ticks at a time (module `batched`: exact algebra, a read-only pass on
    /// most ticks): not bit-identical (within the stated tolerance). The default on Intel CPUs
    /// with AVX-512F ([`Kernel::default_for_cpu`]). Its other passes are those of
    /// [`Kernel::Avx512`].
    Batched,
    /// [`Kernel::Batched`] with the weights kept in **single precision** (`f32`) while the
    /// controller runs: half the bytes of every pass, `f32` arithmetic in the passes, `f64`
    /// for the decay, the terms' coefficients and the final sums. Not within the `f64`
    /// kernels' tolerance: its own, stated and tested (`docs/performance.md`). Opt-in.
    BatchedF32,
}

impl Kernel {
    /// Every kernel, in order of preference for bit-identity.
    pub const ALL: [Kernel; 6] = [
        Kernel::Portable,
        Kernel::Avx2,
        Kernel::Avx2Fma,
        Kernel::Avx512,
        Kernel::Batched,
        Kernel::BatchedF32,
    ];

    /// The name `TANDEM_KERNEL` accepts: `portable`, `avx2`, `avx2fma`, `avx512`, `batched`,
    /// `batched-f32`.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Portable => "portable",
            Kernel::Avx2 => "avx2",
            Kernel::Avx2Fma => "avx2fma",
            Kernel::Avx512 => "avx512",
            Kernel::Batched => "batched",
            Kernel::BatchedF32 => "batched-f32",
        }
    }

    /// Whether this CPU can run the kernel.
    pub fn is_available(self) -> bool {
        match self {
            Kernel::Portable => true,
            Kernel::Avx2 => detect_avx2(),
            Kernel::Avx2Fma => detect_avx2() && detect_fma(),
            Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32 => detect_avx512f(),
        }
    }

    /// Whether the kernel gives the same bits as [`Kernel::Portable`].
    pub fn is_bit_identical_to_portable(self) -> bool {
        !matches!(
            self,
            Kernel::Avx2Fma | Kernel::Avx512 | Kernel::Batched | Kernel::BatchedF32
        )
    }

    /// The default: the fastest double-precision kernel the CPU has. With AVX-512F that is
    /// `batched` on Intel's cores, where a read-only pass over the weights takes about a third
    /// of a read-modify-write pass, and `avx512` on AMD's, where both take the same time and
    /// the batched flush's arithmetic does not pay (measured: `docs/performance.md`). Else AVX2
    /// (bit-identical to the reference), else portable. The vendor is read from `cpuid`, so
    /// the choice is fixed for a machine. [`Kernel::BatchedF32`] is never the default: it
    /// changes the precision of the stored weights.
    pub fn default_for_cpu() -> Kernel {
        if Kernel::Batched.is_available() {
            if detect_amd() {
                Kernel::Avx512
            } else {
                Kernel::Batched
            }
        } else if Kernel::Avx2.is_available() {
            Kernel::Avx2
        } else {
            Kernel::Portable
        }
    }

    /// `Ok` if the CPU can run the kernel, else an error naming [`KERNEL_ENV`] and listing the
    /// kernels it can run.
    pub fn check_available(self) -> Result<Kernel, ModelError> {
        if self.is_available() {
            Ok(self)
        } else {
            Err(ModelError::geometry(
                KERNEL_ENV,
                format!(
                    "kernel `{}` needs CPU features this machine lacks; available: {}",
                    self.name(),
                    Self::available_list()
                ),
            ))
        }
    }

    /// A kernel by name; an unknown name, or one this CPU cannot run, is an error that names
    /// [`KERNEL_ENV`] and lists the valid (available) names.
    pub fn parse(name: &str) -> Result<Kernel, ModelError> {
        let name = name.trim();
        match Self::ALL.into_iter().find(|k| k.name() == name) {
            Some(k) => k.check_available(),
            None => Err(ModelError::geometry(
                KERNEL_ENV,
                format!(
                    "unknown kernel `{name}`; valid: {} (available on this CPU: {})",
                    Self::ALL.map(Kernel::name).join(", "),
                    Self::available_list()
                ),
            )),
        }
    }

    /// The kernel `TANDEM_KERNEL` forces, or [`Kernel::default_for_cpu`] if it is unset or empty.
    pub fn from_env() -> Result<Kernel, ModelError> {
        match std::env::var(KERNEL_ENV) {
            Ok(v) if !v.trim().is_empty() => Self::parse(&v),
            _ => Ok(Self::default_for_cpu()),
        }
    }

    fn available_list() -> String {
        Self::ALL
            .into_iter()
            .filter(|k| k.is_available())
            .map(Kernel::name)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Whether the AVX-512 kernels may run on this CPU (AVX-512F; its FMAs are part of it).
pub(crate) fn detect_avx512f() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether `cpuid` names AMD as the vendor.
pub(crate) fn detect_amd() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `cpuid` leaf 0 exists on every x86_64 CPU (the vendor string).
        #[allow(unused_unsafe)]
        let r = unsafe { std::arch::x86_64::__cpuid(0) };
        let mut v = [0u8; 12];
        v[..4].copy_from_slice(&r.ebx.to_le_bytes());
        v[4..8].copy_from_slice(&r.edx.to_le_bytes());
        v[8..].copy_from_slice(&r.ecx.to_le_bytes());
        &v == b"AuthenticAMD"
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the CPU has FMA.
pub(crate) fn detect_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

// ---- kernels ------------------------------------------------------------------------------
//
// A block is BLOCK = 4 consecutive nodes, i.e. 4·M consecutive weights (node-major). Lane
// i ∈ [0, 4M) of a block is weight i: node i / M, output i % M. Every sum runs per lane and is
// reduced per output in the fixed order of `reduce`, so all kernels (fused, output-only,
// update-only; portable and AVX2, where lane 4r + t is lane t of register r) produce the same
// bits.

/// Nodes per block (one AVX2 register of `S`).
pub(crate) const BLOCK: usize = 4;
/// Lanes of the largest block.
pub(crate) const MAX_LANES: usize = BLOCK * MAX_OUTPUTS;

/// Per-output sums of the lanes: `(v[j] + v[2M + j]) + (v[M + j] + v[3M + j])`.
#[inline(always)]
pub(crate) fn reduce<const M: usize>(v: &[f64; MAX_LANES]) -> [f64; M] {
    // Plain loops here and below: the kernels that inline these are `target_feature`
    // functions, where `array::from_fn`'s closure is called, not inlined.
    let mut out = [0.0; M];
    for (j, o) in out.iter_mut().enumerate() {
        *o = (v[j] + v[2 * M + j]) + (v[M + j] + v[3 * M + j]);
    }
    out
}

/// Nodes per block of the AVX-512 kernel (one register of `S`).
#[cfg(target_arch = "x86_64")]
pub(crate) const BLOCK512: usize = 8;

/// Per-output sums of the 8 node lanes of an AVX-512 block (lane `t·M + j` is node `t`,
/// output `j`), in the fixed order `((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7))`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn reduce512<const M: usize>(v: &[f64; BLOCK512 * MAX_OUTPUTS]) -> [f64; M] {
    let mut out = [0.0; M];
    for (j, o) in out.iter_mut().enumerate() {
        let l = |t: usize| v[t * M + j];
        *o = ((l(0) + l(4)) + (l(2) + l(6))) + ((l(1) + l(5)) + (l(3) + l(7)));
    }
    out
}

/// `S` of the last, partial block, zero-padded (the padding lanes then add exact zeros).
#[inline(always)]
pub(crate) fn s_tail(s: &[f64]) -> [f64; BLOCK] {
    let lo = s.len() / BLOCK * BLOCK;
    let mut out = [0.0; BLOCK];
    out[..s.len() - lo].copy_from_slice(&s[lo..]);
    out
}

/// `e_j`, `c_j` spread over the lanes of a block.
#[inline(always)]
pub(crate) fn lane_pattern<const M: usize>(v: &[f64; M]) -> [f64; MAX_LANES] {
    let mut out = [0.0; MAX_LANES];
    for (i, o) in out[..BLOCK * M].iter_mut().enumerate() {
        *o = v[i % M];
    }
    out
}

/// One block of the fused pass: per lane `acc += old·S`, `w = e·old − c·S`, `n2 += w·w`
/// (plain IEEE operations in this order, no FMA).
#[inline(always)]
pub(crate) fn tick_block<const M: usize, const OUT: bool>(
    wb: &mut [f64],
    sb: &[f64; BLOCK],
    ep: &[f64; MAX_LANES],
    cp: &[f64; MAX_LANES],
    acc: &mut [f64; MAX_LANES],
    n2: &mut [f64; MAX_LANES],
) {
    for (i, w) in wb.iter_mut().enumerate().take(BLOCK * M) {
        let s = sb[i / M];
        let old = *w;
        if OUT {
            acc[i] += old * s;
        }
        let new = ep[i] * old - cp[i] * s;
        *w = new;
        n2[i] += new * new;
    }
}

/// Portable fused pass: `acc_j = Σ w S` (if `OUT`), `w ← e_j w − c_j S`, `n2_j = Σ w²`.
pub(crate) fn kernel_tick<const M: usize, const OUT: bool>(
    w: &mut [f64],
    s: &[f64],
    e: &[f64; M],
    c: &[f64; M],
) -> ([f64; M], [f64; M]) {
    let (ep, cp) = (lane_pattern(e), lane_pattern(c));
    let mut acc = [0.0; MAX_LANES];
    let mut n2 = [0.0; MAX_LANES];
    let full = s.len() / BLOCK;
    let (w_full, w_tail) = w.split_at_mut(full * BLOCK * M);
    for (wb, sb) in w_full
        .chunks_exact_mut(BLOCK * M)
        .zip(s.chunks_exact(BLOCK))
    {
        let sb: &[f64; BLOCK] = sb.try_into().expect("BLOCK lanes");
        tick_block::<M, OUT>(wb, sb, &ep, &cp, &mut acc, &mut n2);
    }
    if !w_tail.is_empty() {
        // Partial block through a zero-padded copy: padding lanes stay exactly 0.
        let mut tmp = [0.0; MAX_LANES];
        tmp[..w_tail.len()].copy_from_slice(w_tail);
        tick_block::<M, OUT>(&mut tmp, &s_tail(s), &ep, &cp, &mut acc, &mut n2);
        w_tail.copy_from_slice(&tmp[..w_tail.len()]);
    }
    (reduce(&acc), reduce(&n2))
}

/// One read-only block: `acc += w·S` (if `OUT`), `n2 += w·w` (if `NORM`).
#[inline(always)]
pub(crate) fn read_block<const M: usize, const OUT: bool, const NORM: bool>(
    wb: &[f64],
    sb: &[f64; BLOCK],
    acc: &mut [f64; MAX_LANES],
    n2: &mut [f64; MAX_LANES],
) {
    for (i, &x) in wb.iter().enumerate().take(BLOCK * M) {
        if OUT {
            acc[i] += x * sb[i / M];
        }
        if NORM {
            n2[i] += x * x;
        }
    }
}

/// Portable read-only pass: `acc_j = Σ w S` (if `OUT`), `n2_j = Σ w²` (if `NORM`).
pub(crate) fn kernel_read<const M: usize, const OUT: bool, const NORM: bool>(
    w: &[f64],
    s: &[f64],
    n_nodes: usize,
) -> ([f64; M], [f64; M]) {
    let mut acc = [0.0; MAX_LANES];
    let mut n2 = [0.0; MAX_LANES];
    let full = n_nodes / BLOCK;
    let (w_full, w_tail) = w.split_at(full * BLOCK * M);
    let zeros = [0.0; BLOCK];
    for (b, wb) in w_full.chunks_exact(BLOCK * M).enumerate() {
        let sb: [f64; BLOCK] = if OUT {
            s[b * BLOCK..(b + 1) * BLOCK]
                .try_into()
                .expect("BLOCK lanes")
        } else {
            zeros
        };
        read_block::<M, OUT, NORM>(wb, &sb, &mut acc, &mut n2);
    }
    if !w_tail.is_empty() {
        let mut tmp = [0.0; MAX_LANES];
        tmp[..w_tail.len()].copy_from_slice(w_tail);
        let sb = if OUT { s_tail(s) } else { zeros };
        read_block::<M, OUT, NORM>(&tmp, &sb, &mut acc, &mut n2);
    }
    (reduce(&acc), reduce(&n2))
}
