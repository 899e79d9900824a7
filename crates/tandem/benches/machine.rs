//! Machine bounds for the roofline table of `docs/performance.md`: the memory rate of the
//! weight pass's access pattern (read, modify and write back every element of a buffer once,
//! `x ← a·x + b·x`, in 512-bit registers where the CPU has AVX-512, else 256-bit) for buffers
//! that live in L1 (32 KB), at the edge of L1 (48 KB: the paper network's weights in `f32`) and
//! in L2 (96 KB: the paper network's weights in `f64`; 192 KB), a read-only
//! pass, and the clock (a chain of dependent integer adds: one a cycle).
//!
//! Bytes moved = 2 × buffer (read + write) for the update pass, 1 × for the read pass; divide
//! by the median time. The buffers start on a 64-byte boundary, as the network's weights do
//! (`control::rbf::Aligned`): an unaligned 64-byte load touches two cache lines; with plain `Vec`s
//! (16-byte aligned), as before 2026-12-02 09:00 UTC, the read rates were 20–38 % lower.
//!
//! `machine/fma512_12x1000`: 12 000 AVX-512 fused multiply-adds in 12 independent chains
//! (every chain summed into the result, so none is dead code): the FMA throughput, in FMAs a
//! cycle = 12 000 / (time × clock).
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

/// `x ← a·x + b·x` over the buffer (each element read and written once).
fn update(x: &mut [f64], a: f64, b: f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: AVX-512F detected just above.
            return unsafe { update_avx512(x, a, b) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: AVX2 and FMA detected just above.
            return unsafe { update_avx2(x, a, b) };
        }
    }
    update_plain(x, a, b);
}

#[inline(always)]
fn update_plain(x: &mut [f64], a: f64, b: f64) {
    for v in x.iter_mut() {
        *v = a * *v + b * *v;
    }
}

/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn update_avx512(x: &mut [f64], a: f64, b: f64) {
    update_plain(x, a, b);
}

/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn update_avx2(x: &mut [f64], a: f64, b: f64) {
    update_plain(x, a, b);
}

/// `Σ x` in 8 independent partial sums (a read-only pass).
fn read(x: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: AVX-512F detected just above.
        return unsafe { read_avx512(x) };
    }
    read_plain(x)
}

#[inline(always)]
fn read_plain(x: &[f64]) -> f64 {
    let mut acc = [0.0; 32];
    for c in x.chunks_exact(32) {
        for (a, v) in acc.iter_mut().zip(c) {
            *a += v;
        }
    }
    acc.iter().sum()
}

/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn read_avx512(x: &[f64]) -> f64 {
    read_plain(x)
}

/// `len` ones starting on a 64-byte boundary (a cache line; an AVX-512 load never straddles
/// two), inside an over-allocated `Vec`: `(buffer, offset)`.
fn aligned_ones(len: usize) -> (Vec<f64>, usize) {
    let v = vec![1.0f64; len + 7];
    let off = v.as_ptr().align_offset(64).min(7);
    (v, off)
}

/// 12 chains × 1000 AVX-512 FMAs `acc ← acc·x + y`; every chain feeds the result.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn fma512(x: f64, y: f64) -> f64 {
    use std::arch::x86_64::{_mm512_add_pd, _mm512_fmadd_pd, _mm512_set1_pd, _mm512_storeu_pd};
    let (xv, yv) = (_mm512_set1_pd(x), _mm512_set1_pd(y));
    let mut acc = [_mm512_set1_pd(1.0); 12];
    for _ in 0..1000 {
        for a in acc.iter_mut() {
            *a = _mm512_fmadd_pd(*a, xv, yv);
        }
    }
    let mut s = acc[0];
    for a in &acc[1..] {
        s = _mm512_add_pd(s, *a);
    }
    let mut out = [0.0; 8];
    // SAFETY: `out` holds 8 f64.
    unsafe { _mm512_storeu_pd(out.as_mut_ptr(), s) };
    out.iter().sum()
}

fn bench(c: &mut Criterion) {
    for kb in [32usize, 48, 96, 192] {
        let n = kb * 1024 / 8;
        let (mut buf, off) = aligned_ones(n);
        let x = &mut buf[off..off + n];
        let mut g = c.benchmark_group("machine/update_pass");
        g.throughput(Throughput::Bytes(2 * (kb * 1024) as u64));
        g.bench_function(format!("{kb}KB"), |b| {
            b.iter(|| update(black_box(&mut *x), black_box(0.5), black_box(0.5)))
        });
        g.finish();
        let mut g = c.benchmark_group("machine/read_pass");
        g.throughput(Throughput::Bytes((kb * 1024) as u64));
        g.bench_function(format!("{kb}KB"), |b| b.iter(|| read(black_box(&*x))));
        g.finish();
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        c.bench_function("machine/fma512_12x1000", |b| {
            // SAFETY: AVX-512F detected just above.
            b.iter(|| unsafe { fma512(black_box(0.999_999), black_box(1e-9)) })
        });
    }
    // 10 000 dependent adds (x86-64: 1000 blocks of 10 `add r, r'` in one asm statement, each
    // waiting for the last; register operands, since recent cores fold add-immediate chains at
    // rename): one a cycle, so the time in ns / 10 000 is the clock period.
    #[cfg(target_arch = "x86_64")]
    c.bench_function("machine/clock_10k_dependent_adds", |b| {
        b.iter(|| {
            let mut v = black_box(1u64);
            let one = black_box(1u64);
            for _ in 0..1000 {
                // SAFETY: register arithmetic only.
                unsafe {
                    std::arch::asm!(
                        "add {0}, {1}", "add {0}, {1}", "add {0}, {1}", "add {0}, {1}",
                        "add {0}, {1}", "add {0}, {1}", "add {0}, {1}", "add {0}, {1}",
                        "add {0}, {1}", "add {0}, {1}",
                        inout(reg) v,
                        in(reg) one,
                        options(pure, nomem, nostack),
                    );
                }
            }
            black_box(v)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
