//! [`TwoLinkArm`]'s [`FixedArm::state_block`] of two arms in the two lanes of SSE2 registers
//! (part of the x86-64 baseline): lane 0 the first arm, lane 1 the second. Each lane performs
//! the scalar code's floating-point operations in its order (nalgebra's 2 × 2 products and
//! `dot` are two products and one sum; the sum commutes exactly), so the bits are the same;
//! negations are sign flips, as in the scalar code.

use std::arch::x86_64::{
    __m128d, _mm_add_pd, _mm_and_pd, _mm_cmpgt_pd, _mm_cmplt_pd, _mm_div_pd, _mm_movemask_pd,
    _mm_mul_pd, _mm_set_pd, _mm_set1_pd, _mm_setzero_pd, _mm_sqrt_pd, _mm_storeh_pd, _mm_storel_pd,
    _mm_storeu_pd, _mm_sub_pd, _mm_unpackhi_pd, _mm_unpacklo_pd, _mm_xor_pd,
};
use std::ops::{Add, Div, Mul, Neg, Sub};

use nalgebra::{Matrix2, SMatrix, SVector, Vector2};

use super::{ArmBlock, ArmSolve, FixedLinkArm, TwoLinkArm};

/// Two `f64` lanes.
#[derive(Clone, Copy)]
struct L(__m128d);

impl L {
    #[inline(always)]
    fn new(a: f64, b: f64) -> L {
        // SAFETY: SSE2 (x86-64 baseline).
        L(unsafe { _mm_set_pd(b, a) })
    }
    #[inline(always)]
    fn splat(x: f64) -> L {
        // SAFETY: SSE2 (x86-64 baseline).
        L(unsafe { _mm_set1_pd(x) })
    }
    #[inline(always)]
    fn of<A>(arms: [&A; 2], f: impl Fn(&A) -> f64) -> L {
        L::new(f(arms[0]), f(arms[1]))
    }
    /// Whether `x > 0` in both lanes (false for NaN, as the scalar comparison).
    #[inline(always)]
    fn both_positive(self) -> bool {
        // SAFETY: SSE2 (x86-64 baseline).
        unsafe { _mm_movemask_pd(_mm_cmpgt_pd(self.0, _mm_setzero_pd())) == 3 }
    }
    /// Whether `0 < x < ∞` in both lanes (`x > 0.0 && x.is_finite()` of each; false for NaN).
    #[inline(always)]
    fn both_positive_finite(self) -> bool {
        // SAFETY: SSE2 (x86-64 baseline).
        unsafe {
            let pos = _mm_cmpgt_pd(self.0, _mm_setzero_pd());
            let fin = _mm_cmplt_pd(self.0, _mm_set1_pd(f64::INFINITY));
            _mm_movemask_pd(_mm_and_pd(pos, fin)) == 3
        }
    }
    /// `√x` per lane (correctly rounded, as `f64::sqrt`).
    #[inline(always)]
    fn sqrt(self) -> L {
        // SAFETY: SSE2 (x86-64 baseline).
        L(unsafe { _mm_sqrt_pd(self.0) })
    }
}

macro_rules! op {
    ($tr:ident, $f:ident, $intr:ident) => {
        impl $tr for L {
            type Output = L;
            #[inline(always)]
            fn $f(self, o: L) -> L {
                // SAFETY: SSE2 (x86-64 baseline).
                L(unsafe { $intr(self.0, o.0) })
            }
        }
    };
}
op!(Add, add, _mm_add_pd);
op!(Sub, sub, _mm_sub_pd);
op!(Mul, mul, _mm_mul_pd);
op!(Div, div, _mm_div_pd);

impl Neg for L {
    type Output = L;
    #[inline(always)]
    fn neg(self) -> L {
        // SAFETY: SSE2 (x86-64 baseline); flips the sign bit, as scalar negation.
        L(unsafe { _mm_xor_pd(self.0, _mm_set1_pd(-0.0)) })
    }
}

/// The lanes `x = (x₀, x₁)`, `y = (y₀, y₁)` as the vectors `(x₀, y₀)`, `(x₁, y₁)`.
#[inline(always)]
fn split(x: L, y: L) -> [Vector2<f64>; 2] {
    let (mut a, mut b) = (Vector2::zeros(), Vector2::zeros());
    // SAFETY: SSE2 (x86-64 baseline); unaligned stores into two-element vectors.
    unsafe {
        _mm_storeu_pd(a.as_mut_ptr(), _mm_unpacklo_pd(x.0, y.0));
        _mm_storeu_pd(b.as_mut_ptr(), _mm_unpackhi_pd(x.0, y.0));
    }
    [a, b]
}

#[inline(always)]
pub(super) fn state_block_pair(
    arms: [&TwoLinkArm; 2],
    q: [[f64; 2]; 2],
    qd: [[f64; 2]; 2],
    g: f64,
) -> Option<[(ArmBlock<2>, ArmSolve<2>); 2]> {
    let [a, b] = arms;
    // TwoLinkArm::pose: φ_1 = base angle + q_1, φ_2 = φ_1 + q_2 (scalars), one sin_cos2
    // per link of the two arms.
    let phi1 = [a.base_angle + q[0][0], b.base_angle + q[1][0]];
    let phi2 = [phi1[0] + q[0][1], phi1[1] + q[1][1]];
    let (s1, c1) = crate::math::trig::sin_cos2_pd(phi1[0], phi1[1]);
    let (s12, c12) = crate::math::trig::sin_cos2_pd(phi2[0], phi2[1]);
    let (s1, c1, s12, c12) = (L(s1), L(c1), L(s12), L(c12));
    // cos q2 = u_1 · u_12, sin q2 = u_1 × u_12.
    let c2 = c1 * c12 + s1 * s12;
    let s2 = c1 * s12 - s1 * c12;
    // pose_from_dirs: e_2 = l_2 u_12, e = l_1 u_1 + e_2, J = [[−e_y, −e_2y], [e_x, e_2x]].
    let (l1, l2) = (L::of(arms, |r| r.l1), L::of(arms, |r| r.l2));
    let (e2x, e2y) = (l2 * c12, l2 * s12);
    let (ex, ey) = (l1 * c1 + e2x, l1 * s1 + e2y);
    let j = [-ey, -e2y, ex, e2x];
    // terms: w_1 = q̇_1, w_2 = q̇_1 + q̇_2; v_1 = (l_1 w_1) u_1^⊥, v_2 = (l_2 w_2) u_12^⊥.
    let (qd0, qd1) = (L::new(qd[0][0], qd[1][0]), L::new(qd[0][1], qd[1][1]));
    let (w1, w2) = (qd0, qd0 + qd1);
    let (lw1, lw2) = (l1 * w1, l2 * w2);
    let vx = lw1 * -s1 + lw2 * -s12;
    let vy = lw1 * c1 + lw2 * c12;
    // mcg.
    let (p1, p2, p3) = (
        L::of(arms, |r| r.p1),
        L::of(arms, |r| r.p2),
        L::of(arms, |r| r.p3),
    );
    let m12 = p3 + p2 * c2;
    let m00 = p1 + L::splat(2.0) * p2 * c2;
    let h = p2 * s2;
    let c = [-h * qd1, -h * w2, h * qd0, L::splat(0.0)];
    let gl = L::splat(g);
    let g2c = L::of(arms, |r| r.g2) * gl * c12;
    let gv = [L::of(arms, |r| r.g1) * gl * c1 + g2c, g2c];
    let p2c2 = p2 * c2;
    // J̇_e q̇ = −(l_1 w_1 w_1) u_1 − (l_2 w_2 w_2) u_12; p_E = base + l_1 u_1 + l_2 u_12.
    let (aa, bb) = (-(lw1 * w1), lw2 * w2);
    let jdq = [aa * c1 - bb * c12, aa * s1 - bb * s12];
    let p_ee = [
        L::of(arms, |r| r.base.x) + l1 * c1 + l2 * c12,
        L::of(arms, |r| r.base.y) + l1 * s1 + l2 * s12,
    ];
    let det = L::of(arms, |r| r.det0) - p2c2 * p2c2;
    if !det.both_positive() {
        return None;
    }
    // M⁻¹ = [[M_11, −M_01], [−M_10, M_00]] · (1 / det M).
    // SAFETY: SSE2 (x86-64 baseline).
    let inv = L(unsafe { _mm_div_pd(_mm_set1_pd(1.0), det.0) });
    let mi = [p3 * inv, -m12 * inv, -m12 * inv, m00 * inv];
    // Y = M⁻¹ J_eᵀ: Y_rc = M⁻¹_r0 J_c0 + M⁻¹_r1 J_c1; K = J_e Y.
    let y = [
        mi[0] * j[0] + mi[1] * j[1],
        mi[0] * j[2] + mi[1] * j[3],
        mi[2] * j[0] + mi[3] * j[1],
        mi[2] * j[2] + mi[3] * j[3],
    ];
    let k = [
        j[0] * y[0] + j[1] * y[2],
        j[0] * y[1] + j[1] * y[3],
        j[2] * y[0] + j[3] * y[2],
        j[2] * y[1] + j[3] * y[3],
    ];
    // C q̇.
    let bias = [c[0] * qd0 + c[1] * qd1, c[2] * qd0 + c[3] * qd1];

    // Out of the lanes: (x, y) lanes → the first arm's vector (x₀, y₀), the second's
    // (x₁, y₁), one unpack each; a matrix from its columns (nalgebra is column-major).
    let m = |m: [L; 4]| {
        let ([a0, b0], [a1, b1]) = (split(m[0], m[2]), split(m[1], m[3]));
        [
            Matrix2::from_columns(&[a0, a1]),
            Matrix2::from_columns(&[b0, b1]),
        ]
    };
    let ([ya, yb], [ka, kb], [ja, jb], [ma, mb]) = (m(y), m(k), m(j), m(mi));
    let [pa, pb] = split(p_ee[0], p_ee[1]);
    let [va, vb] = split(vx, vy);
    let [da, db] = split(jdq[0], jdq[1]);
    let [ba, bb] = split(bias[0], bias[1]);
    let [ga, gb] = split(gv[0], gv[1]);
    let out = |y, k, j, p_ee, v_ee, jdot_qdot, m, bias, g| {
        (
            ArmBlock {
                a0: Vector2::zeros(),
                y,
                k,
                j,
                p_ee,
                v_ee,
                jdot_qdot,
            },
            ArmSolve {
                m,
                inv_diag: Vector2::zeros(),
                bias,
                g,
            },
        )
    };
    Some([
        out(ya, ka, ja, pa, va, da, ma, ba, ga),
        out(yb, kb, jb, pb, vb, db, mb, bb, gb),
    ])
}

/// [`FixedLinkArm`]'s [`FixedArm::state_block`](super::FixedArm::state_block) of two arms in
/// the lanes: the scalar code's loops, each operation once for both arms in its order
/// (nalgebra's `dot` and the `N × N` by `N × 2` product `M⁻¹ J_eᵀ` as left-to-right sums of
/// products, as nalgebra's small-matrix `gemv` does them; additions of `0.0` kept, as they
/// are not no-ops for `−0.0`); `None` when either arm's `M` is not positive definite.
#[inline(always)]
pub(super) fn fixed_state_block_pair<const N: usize>(
    arms: [&FixedLinkArm<N>; 2],
    q: [[f64; N]; 2],
    qd: [[f64; N]; 2],
    g: f64,
) -> Option<[(ArmBlock<N>, ArmSolve<N>); 2]> {
    let zero = L::splat(0.0);
    // link_dirs: the running sums (the angles as scalars, per arm; the rates in lanes),
    // then each link's direction of the two arms by one sin_cos2 (the same bits as
    // sin_cos of each angle, as the scalar code's).
    let mut phi = [[0.0; N]; 2];
    for (s, (arm, qs)) in [(arms[0], &q[0]), (arms[1], &q[1])].into_iter().enumerate() {
        let mut a = arm.base_angle;
        for k in 0..N {
            a += qs[k];
            phi[s][k] = a;
        }
    }
    let mut phids = [zero; N];
    let mut ad = zero;
    for k in 0..N {
        ad = ad + L::new(qd[0][k], qd[1][k]);
        phids[k] = ad;
    }
    // Forward pass: joint points, COMs, acc_k = J̇_{c_k} q̇ + (0, g).
    let mut pts = [[zero; 2]; N];
    let mut com = [[zero; 2]; N];
    let mut acc = [[zero; 2]; N];
    let (mut px, mut py) = (L::of(arms, |r| r.base.x), L::of(arms, |r| r.base.y));
    let (mut pdx, mut pdy) = (zero, zero);
    let (mut jx, mut jy) = (zero, zero);
    let gl = L::splat(g);
    for k in 0..N {
        let (s, c) = crate::math::trig::sin_cos2_pd(phi[0][k], phi[1][k]);
        let (s, c) = (L(s), L(c));
        let phid = phids[k];
        let (lc, l) = (L::of(arms, |r| r.lc[k]), L::of(arms, |r| r.l[k]));
        let w2 = phid * phid;
        pts[k] = [px, py];
        com[k] = [px + lc * c, py + lc * s];
        let t = lc * w2;
        acc[k] = [(jx - t * c) + zero, (jy - t * s) + gl];
        px = px + l * c;
        py = py + l * s;
        let lp = l * phid;
        pdx = pdx + lp * -s;
        pdy = pdy + lp * c;
        let lpp = lp * phid;
        jx = jx - lpp * c;
        jy = jy - lpp * s;
    }
    // J_e columns perp(p − P_i); r_ki = c_k − P_i.
    let mut j = [[zero; N]; 2];
    for i in 0..N {
        j[0][i] = -(py - pts[i][1]);
        j[1][i] = px - pts[i][0];
    }
    let mut r = [[[zero; 2]; N]; N];
    for k in 0..N {
        for i in 0..=k {
            r[k][i] = [com[k][0] - pts[i][0], com[k][1] - pts[i][1]];
        }
    }
    let mut mm = [[zero; N]; N];
    let mut rhs = [[zero; 2]; N];
    let mut bias_v = [zero; N];
    for i in 0..N {
        for jj in i..N {
            let mut mij = zero;
            for k in jj..N {
                let (m, ine) = (L::of(arms, |a| a.m[k]), L::of(arms, |a| a.inertia[k]));
                let dot = r[k][i][0] * r[k][jj][0] + r[k][i][1] * r[k][jj][1];
                mij = mij + (m * dot + ine);
            }
            mm[i][jj] = mij;
            mm[jj][i] = mij;
        }
        let mut bias = zero;
        for k in i..N {
            let m = L::of(arms, |a| a.m[k]);
            let dot = -r[k][i][1] * acc[k][0] + r[k][i][0] * acc[k][1];
            bias = bias + m * dot;
        }
        bias_v[i] = bias;
        rhs[i] = [j[0][i], j[1][i]];
    }
    let mut sm = [[zero; N]; N];
    let mut inv_diag = [zero; N];
    if N == 3 {
        // Closed-form inverse adj M / det M, Sylvester's minors.
        let (m00, m01, m02) = (mm[0][0], mm[0][1], mm[0][2]);
        let (m11, m12, m22) = (mm[1][1], mm[1][2], mm[2][2]);
        let c00 = m11 * m22 - m12 * m12;
        let c01 = m02 * m12 - m01 * m22;
        let c02 = m01 * m12 - m02 * m11;
        let c11 = m00 * m22 - m02 * m02;
        let c12 = m01 * m02 - m00 * m12;
        let c22 = m00 * m11 - m01 * m01;
        let det = m00 * c00 + m01 * c01 + m02 * c02;
        if !(m00.both_positive() && c22.both_positive() && det.both_positive_finite()) {
            return None;
        }
        let inv = L::splat(1.0) / det;
        for (rr, cc, v) in [
            (0, 0, c00),
            (0, 1, c01),
            (0, 2, c02),
            (1, 1, c11),
            (1, 2, c12),
            (2, 2, c22),
        ] {
            sm[rr][cc] = v * inv;
            sm[cc][rr] = v * inv;
        }
        // M⁻¹ J_eᵀ: nalgebra's gemv, y = col_0 x_0, then y += col_k x_k.
        let mut y = [[zero; 2]; N];
        for cc in 0..2 {
            for rr in 0..N {
                let mut sum = sm[rr][0] * rhs[0][cc];
                for k in 1..N {
                    sum = sum + sm[rr][k] * rhs[k][cc];
                }
                y[rr][cc] = sum;
            }
        }
        rhs = y;
    } else {
        // Cholesky M = L Lᵀ (upper triangle left as M's), then both substitutions.
        let mut lo = mm;
        for jj in 0..N {
            let mut dd = lo[jj][jj];
            for k in 0..jj {
                dd = dd - lo[jj][k] * lo[jj][k];
            }
            if !dd.both_positive_finite() {
                return None;
            }
            let ljj = dd.sqrt();
            lo[jj][jj] = ljj;
            inv_diag[jj] = L::splat(1.0) / ljj;
            for i in (jj + 1)..N {
                let mut sum = lo[i][jj];
                for k in 0..jj {
                    sum = sum - lo[i][k] * lo[jj][k];
                }
                lo[i][jj] = sum / ljj;
            }
        }
        for cc in 0..2 {
            let mut b = [zero; N];
            for i in 0..N {
                b[i] = rhs[i][cc];
            }
            for i in 0..N {
                let mut sum = b[i];
                for k in 0..i {
                    sum = sum - lo[i][k] * b[k];
                }
                b[i] = sum * inv_diag[i];
            }
            for i in (0..N).rev() {
                let mut sum = b[i];
                for k in (i + 1)..N {
                    sum = sum - lo[k][i] * b[k];
                }
                b[i] = sum * inv_diag[i];
            }
            for i in 0..N {
                rhs[i][cc] = b[i];
            }
        }
        sm = lo;
    }
    let y = rhs;
    let mut kb = [[zero; 2]; 2];
    for a in 0..2 {
        for b in 0..2 {
            let mut sum = zero;
            for rr in 0..N {
                sum = sum + j[a][rr] * y[rr][b];
            }
            kb[a][b] = sum;
        }
    }

    // Out of the lanes: each lane stored straight into its arm's field.
    let zb = || {
        (
            ArmBlock {
                a0: SVector::zeros(),
                y: SMatrix::zeros(),
                k: Matrix2::zeros(),
                j: SMatrix::zeros(),
                p_ee: Vector2::zeros(),
                v_ee: Vector2::zeros(),
                jdot_qdot: Vector2::zeros(),
            },
            ArmSolve {
                m: SMatrix::zeros(),
                inv_diag: SVector::zeros(),
                bias: SVector::zeros(),
                g: SVector::zeros(),
            },
        )
    };
    let (mut oa, mut ob) = (zb(), zb());
    #[inline(always)]
    fn put(x: L, a: &mut f64, b: &mut f64) {
        // SAFETY: SSE2 (x86-64 baseline); stores of one lane each into an `f64`.
        unsafe {
            _mm_storel_pd(a, x.0);
            _mm_storeh_pd(b, x.0);
        }
    }
    for rr in 0..N {
        for cc in 0..2 {
            put(y[rr][cc], &mut oa.0.y[(rr, cc)], &mut ob.0.y[(rr, cc)]);
            put(j[cc][rr], &mut oa.0.j[(cc, rr)], &mut ob.0.j[(cc, rr)]);
        }
        for cc in 0..N {
            put(sm[rr][cc], &mut oa.1.m[(rr, cc)], &mut ob.1.m[(rr, cc)]);
        }
        if N != 3 {
            put(inv_diag[rr], &mut oa.1.inv_diag[rr], &mut ob.1.inv_diag[rr]);
        }
        put(bias_v[rr], &mut oa.1.bias[rr], &mut ob.1.bias[rr]);
    }
    for rr in 0..2 {
        for cc in 0..2 {
            put(kb[rr][cc], &mut oa.0.k[(rr, cc)], &mut ob.0.k[(rr, cc)]);
        }
    }
    put(px, &mut oa.0.p_ee.x, &mut ob.0.p_ee.x);
    put(py, &mut oa.0.p_ee.y, &mut ob.0.p_ee.y);
    put(pdx, &mut oa.0.v_ee.x, &mut ob.0.v_ee.x);
    put(pdy, &mut oa.0.v_ee.y, &mut ob.0.v_ee.y);
    put(jx, &mut oa.0.jdot_qdot.x, &mut ob.0.jdot_qdot.x);
    put(jy, &mut oa.0.jdot_qdot.y, &mut ob.0.jdot_qdot.y);
    Some([oa, ob])
}
