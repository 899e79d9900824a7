//! Small dense linear algebra on caller-owned buffers (no allocation).
//!
//! The matrices here are tiny (a few rows: an arm's joint-space inertia, the grasp-space
//! inverse inertia); an in-place Cholesky on a `DMatrix` or a fixed `SMatrix` avoids the
//! allocation that `nalgebra::Cholesky::new(m.clone())` would make inside a step.

use nalgebra::{DMatrix, Dim, Matrix, RawStorage, RawStorageMut};

/// In-place Cholesky factorisation `A = L Lᵀ` of the leading `n × n` block of a symmetric
/// matrix; the lower triangle of `a` is overwritten with `L` (the upper triangle is left as is).
///
/// Returns the smallest pivot `L_kk²` divided by the largest diagonal entry of `A` (a cheap
/// conditioning indicator), or `Err(k)` when pivot `k` is not positive (not positive definite).
#[inline]
pub fn cholesky_in_place<R: Dim, C: Dim, S: RawStorageMut<f64, R, C>>(
    a: &mut Matrix<f64, R, C, S>,
    n: usize,
) -> Result<f64, usize> {
    let mut max_diag: f64 = 0.0;
    for k in 0..n {
        max_diag = max_diag.max(a[(k, k)].abs());
    }
    let mut min_pivot = f64::INFINITY;
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= a[(j, k)] * a[(j, k)];
        }
        if !(d > 0.0) || !d.is_finite() {
            return Err(j);
        }
        min_pivot = min_pivot.min(d);
        let ljj = d.sqrt();
        a[(j, j)] = ljj;
        for i in (j + 1)..n {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= a[(i, k)] * a[(j, k)];
            }
            a[(i, j)] = s / ljj;
        }
    }
    Ok(if max_diag > 0.0 {
        min_pivot / max_diag
    } else {
        0.0
    })
}

/// Solve `L Lᵀ x = b` in place (`b` becomes `x`) with the factor from [`cholesky_in_place`].
#[inline]
pub fn cholesky_solve_in_place<R: Dim, C: Dim, S: RawStorageMut<f64, R, C>>(
    l: &Matrix<f64, R, C, S>,
    n: usize,
    b: &mut [f64],
) {
    // Forward substitution L y = b.
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
    // Back substitution Lᵀ x = y.
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in (i + 1)..n {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
}

/// In-place `A = L D Lᵀ` of an `n × n` symmetric positive definite matrix (square-root-free
/// Cholesky): the strict lower triangle becomes the unit lower factor `L`, the diagonal `D`,
/// and `inv_d[j] = 1/D_j`.
/// Returns the smallest pivot `D_j` over the largest diagonal entry (the same ratio as
/// [`cholesky_in_place`]'s, whose pivots before the square root are these `D_j`), or `Err(k)`
/// at the first pivot that is not positive and finite. Per column one division and no square
/// root: on the planar plant's dependency chain (a grasp-space `K` factored every RK4 stage)
/// the column costs a division and a multiply where the Cholesky's costs a square root and a
/// division. Equal to the Cholesky factorisation up to round-off.
#[inline(always)]
pub fn ldl_in_place<R: Dim, C: Dim, S: RawStorageMut<f64, R, C>>(
    a: &mut Matrix<f64, R, C, S>,
    n: usize,
    inv_d: &mut [f64],
) -> Result<f64, usize> {
    let inv_d = &mut inv_d[..n];
    let mut max_diag: f64 = 0.0;
    for k in 0..n {
        max_diag = max_diag.max(a[(k, k)].abs());
    }
    let mut min_pivot = f64::INFINITY;
    // `u[k] = L_jk D_k` of the current row `j`.
    let mut u = [0.0; LDL_MAX];
    assert!(n <= LDL_MAX, "ldl_in_place: n = {n} > {LDL_MAX}");
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            // `a[(j, k)]` holds `L_jk` and `a[(k, k)]` holds `D_k`.
            u[k] = a[(j, k)] * a[(k, k)];
            d -= u[k] * a[(j, k)];
        }
        if !(d > 0.0) || !d.is_finite() {
            return Err(j);
        }
        min_pivot = min_pivot.min(d);
        let inv = 1.0 / d;
        inv_d[j] = inv;
        a[(j, j)] = d;
        for i in (j + 1)..n {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= a[(i, k)] * u[k];
            }
            a[(i, j)] = s * inv;
        }
    }
    Ok(if max_diag > 0.0 {
        min_pivot / max_diag
    } else {
        0.0
    })
}

/// The largest `n` of [`ldl_in_place`] (its row buffer is on the stack).
pub const LDL_MAX: usize = 16;

/// Solve `L D Lᵀ x = b` in place with the factor of [`ldl_in_place`]: forward substitution by
/// the unit `L`, the scaling by `1/D` (multiplications), back substitution by `Lᵀ`. No division.
#[inline(always)]
pub fn ldl_solve_in_place<R: Dim, C: Dim, S: RawStorage<f64, R, C>>(
    l: &Matrix<f64, R, C, S>,
    inv_d: &[f64],
    n: usize,
    b: &mut [f64],
) {
    let (inv_d, b) = (&inv_d[..n], &mut b[..n]);
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s;
    }
    for i in 0..n {
        b[i] *= inv_d[i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in (i + 1)..n {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s;
    }
}

/// In-place Cholesky `A = L Lᵀ` of an `n × n` symmetric matrix stored **row-major** in a flat
/// slice (`a[i n + j]`); the lower triangle (`j ≤ i`) becomes `L`, the strict upper triangle is
/// left as is. Returns the smallest pivot over the largest diagonal entry, or `Err(k)` at the
/// first pivot that is not positive and finite. Rows are contiguous, so the inner products run
/// over contiguous memory (the hot kernel of the spatial plant's grasp-space solve).
#[inline(always)]
pub fn cholesky_rows(a: &mut [f64], n: usize) -> Result<f64, usize> {
    let a = &mut a[..n * n];
    let mut max_diag: f64 = 0.0;
    for k in 0..n {
        max_diag = max_diag.max(a[k * n + k].abs());
    }
    let mut min_pivot = f64::INFINITY;
    for i in 0..n {
        let (done, rest) = a.split_at_mut(i * n);
        let row_i = &mut rest[..n];
        for j in 0..i {
            let row_j = &done[j * n..j * n + j + 1];
            let s = row_i[j] - dot(&row_i[..j], &row_j[..j]);
            row_i[j] = s / row_j[j];
        }
        let d = row_i[i] - dot(&row_i[..i], &row_i[..i]);
        if !(d > 0.0) || !d.is_finite() {
            return Err(i);
        }
        min_pivot = min_pivot.min(d);
        row_i[i] = d.sqrt();
    }
    Ok(if max_diag > 0.0 {
        min_pivot / max_diag
    } else {
        0.0
    })
}

/// `Σ a_k b_k` over equal-length slices.
#[inline(always)]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = 0.0;
    for k in 0..n {
        s += a[k] * b[k];
    }
    s
}

/// Forward substitution `L X = B` in place for `m` right-hand sides, with `L` from
/// [`cholesky_rows`] (row-major `n × n`) and `B` row-major `n × m` (`b[i m + c]`).
#[inline(always)]
pub fn forward_rows(l: &[f64], n: usize, b: &mut [f64], m: usize) {
    let l = &l[..n * n];
    let b = &mut b[..n * m];
    for i in 0..n {
        let (done, rest) = b.split_at_mut(i * m);
        let row = &mut rest[..m];
        for k in 0..i {
            let lik = l[i * n + k];
            let src = &done[k * m..k * m + m];
            for c in 0..m {
                row[c] -= lik * src[c];
            }
        }
        let inv = 1.0 / l[i * n + i];
        for v in row.iter_mut() {
            *v *= inv;
        }
    }
}

/// Back substitution `Lᵀ x = y` in place for one right-hand side, with `L` from
/// [`cholesky_rows`].
#[inline(always)]
pub fn backward_rows(l: &[f64], n: usize, x: &mut [f64]) {
    let l = &l[..n * n];
    let x = &mut x[..n];
    for i in (0..n).rev() {
        let mut s = x[i];
        for k in (i + 1)..n {
            s -= l[k * n + i] * x[k];
        }
        x[i] = s / l[i * n + i];
    }
}

/// Convenience: `true` when every entry of a dynamic matrix is finite.
pub fn all_finite(m: &DMatrix<f64>) -> bool {
    m.iter().all(|v| v.is_finite())
}

/// `true` when every entry is finite, branch-free: `v − v` is `0` for a finite `v` and NaN for
/// an infinite or NaN one, and a sum of zeros stays `0` while one NaN makes it NaN (the checks
/// of a control tick run over some hundred values; a short-circuiting `all` over chained
/// iterators cost more than the arithmetic it guards).
#[inline]
#[allow(clippy::eq_op)] // v − v is the point: it is NaN exactly for non-finite v.
pub fn finite_slice(v: &[f64]) -> bool {
    v.iter().map(|x| x - x).sum::<f64>() == 0.0
}

// The fixed 6 × 6 kernels below loop over the full `0..6` with `if` guards instead of
// `k + 1..6`: constant trip counts let the compiler unroll every loop and fold the guards, so
// no loop bookkeeping is left (the operations and their order are those of the plain loops).

/// Solve `A x = b` for a 6 × 6 matrix given by rows (`a[i][j] = A_ij`) by Gaussian
/// elimination with partial pivoting (the LU of `nalgebra::LU`, written out on fixed arrays:
/// no generic views, no bounds checks, unrolled). `None` if a pivot is exactly zero (a
/// singular matrix); a non-finite entry gives non-finite entries in `x` (the caller checks).
#[inline]
pub fn lu_solve6(mut a: [[f64; 6]; 6], mut x: [f64; 6]) -> Option<[f64; 6]> {
    lu_solve6_in_place(&mut a, &mut x).then_some(x)
}

/// [`lu_solve6`] in place: `a` is overwritten by its factors, `x` (given `b`) by the solution;
/// `false` (and `x` unusable) for a zero pivot. No copies of the matrix.
#[inline]
pub fn lu_solve6_in_place(a: &mut [[f64; 6]; 6], x: &mut [f64; 6]) -> bool {
    // Reciprocal pivots: the back substitution multiplies (a chain of six divisions would
    // dominate its latency).
    let mut inv_piv = [0.0; 6];
    for k in 0..6 {
        let (mut p, mut best) = (k, a[k][k].abs());
        for i in 0..6 {
            if i > k {
                let v = a[i][k].abs();
                if v > best {
                    (p, best) = (i, v);
                }
            }
        }
        if best == 0.0 {
            return false;
        }
        if p != k {
            a.swap(p, k);
            x.swap(p, k);
        }
        let inv = 1.0 / a[k][k];
        inv_piv[k] = inv;
        for i in 0..6 {
            if i > k {
                let l = a[i][k] * inv;
                for j in 0..6 {
                    if j > k {
                        a[i][j] -= l * a[k][j];
                    }
                }
                x[i] -= l * x[k];
            }
        }
    }
    for ii in 0..6 {
        let i = 5 - ii;
        let mut s = x[i];
        for j in 0..6 {
            if j > i {
                s -= a[i][j] * x[j];
            }
        }
        x[i] = s * inv_piv[i];
    }
    true
}

/// The Cholesky factor `A = L Lᵀ` of a 6 × 6 symmetric positive definite matrix on fixed
/// arrays (`l[i][j]`, `j ≤ i`), and its solves. The distribution keeps one per tick and reuses
/// it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cholesky6 {
    l: [[f64; 6]; 6],
    /// `1/L_ii` (the solves multiply: a chain of divisions would dominate their latency).
    inv_d: [f64; 6],
}

impl Cholesky6 {
    /// Factor the lower triangle of `a` (rows: `a[i][j] = A_ij`, `j ≤ i` read); `None` unless
    /// every pivot is positive (a NaN pivot included).
    #[inline]
    pub fn new(a: &[[f64; 6]; 6]) -> Option<Self> {
        let mut c = Cholesky6 {
            l: [[0.0; 6]; 6],
            inv_d: [0.0; 6],
        };
        c.refactor(a).then_some(c)
    }

    /// [`Cholesky6::new`] into `self` (no copy of the factor); `false` (and `self` unusable)
    /// unless every pivot is positive.
    #[inline]
    pub fn refactor(&mut self, a: &[[f64; 6]; 6]) -> bool {
        let Cholesky6 { l, inv_d } = self;
        for j in 0..6 {
            let mut d = a[j][j];
            for k in 0..6 {
                if k < j {
                    d -= l[j][k] * l[j][k];
                }
            }
            if !(d > 0.0) {
                return false;
            }
            let ljj = d.sqrt();
            l[j][j] = ljj;
            let inv = 1.0 / ljj;
            inv_d[j] = inv;
            for i in 0..6 {
                if i > j {
                    let mut s = a[i][j];
                    for k in 0..6 {
                        if k < j {
                            s -= l[i][k] * l[j][k];
                        }
                    }
                    l[i][j] = s * inv;
                }
            }
        }
        true
    }

    /// `x = A⁻¹ b` (forward then back substitution).
    #[inline]
    pub fn solve(&self, b: &[f64; 6]) -> [f64; 6] {
        let (l, inv_d) = (&self.l, &self.inv_d);
        let mut y = [0.0; 6];
        for i in 0..6 {
            let mut s = b[i];
            for k in 0..6 {
                if k < i {
                    s -= l[i][k] * y[k];
                }
            }
            y[i] = s * inv_d[i];
        }
        for ii in 0..6 {
            let i = 5 - ii;
            let mut s = y[i];
            for k in 0..6 {
                if k > i {
                    s -= l[k][i] * y[k];
                }
            }
            y[i] = s * inv_d[i];
        }
        y
    }
}

/// `A x = b` for a 2×2 `A` by nalgebra's LU with partial pivoting (`A.lu().solve(&b)`) in the
/// same floating-point operations, bit for bit, without its generic loops: the pivot is the
/// first of the largest `|A_i0|`; `l = A_10/A_00` as `A_10 · (1/A_00)` (after the swap);
/// `u_11 = A_11 − u_01 l`; then `L y = P b` and `U x = y`. `None` when a pivot of `U` is zero,
/// as nalgebra (its non-finite results pass through, as nalgebra's do).
#[inline]
pub fn lu_solve_2x2(
    a: &nalgebra::Matrix2<f64>,
    b: &nalgebra::Vector2<f64>,
) -> Option<nalgebra::Vector2<f64>> {
    let (a00, a01, a10, a11) = (a[(0, 0)], a[(0, 1)], a[(1, 0)], a[(1, 1)]);
    // Step 0 (nalgebra's `icamax`: a strictly larger |A_10| swaps the rows).
    let swap = a10.abs() > a00.abs();
    let (u00, u01, lo, hi, b0, b1) = if swap {
        (a10, a11, a00, a01, b.y, b.x)
    } else {
        (a00, a01, a10, a11, b.x, b.y)
    };
    if u00 == 0.0 {
        // nalgebra skips the step; U's first pivot is zero and the solve fails.
        return None;
    }
    // `gauss_step`: the column scaled by the reciprocal pivot, then the axpy `1·y + (−p)·x·1`.
    let l = lo * (1.0 / u00);
    let u11 = -u01 * l + hi;
    // L y = P b (unit diagonal: `b_0 / 1`), then U x = y.
    let y1 = -b0 * l + b1;
    if u11 == 0.0 {
        return None;
    }
    let x1 = y1 / u11;
    let x0 = (-x1 * u01 + b0) / u00;
    Some(nalgebra::Vector2::new(x0, x1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lu_solve_2x2_gives_nalgebras_lu_bits() {
        // Random matrices of every scale and sign, ties of |A_00| and |A_10|, zeros (±0),
        // singular ones, infinities and NaN: the same Option and the same bits as nalgebra.
        let mut rng = crate::math::random::SplitMix64(99);
        let special = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            2.5,
            f64::INFINITY,
            f64::NAN,
            1e-300,
            -3e300,
        ];
        for k in 0..200_000 {
            let mut v = [0.0; 6];
            for x in v.iter_mut() {
                *x = match k % 4 {
                    0 => rng.range(-1.0, 1.0),
                    1 => rng.range(-1.0, 1.0) * 10f64.powi((rng.range(-30.0, 30.0)) as i32),
                    2 => special[(rng.next_f64() * special.len() as f64) as usize % special.len()],
                    _ => (rng.range(-3.0, 3.0)).round(),
                };
            }
            if k % 7 == 0 {
                v[2] = -v[0]; // |A_10| = |A_00|
            }
            let a = nalgebra::Matrix2::new(v[0], v[1], v[2], v[3]);
            let b = nalgebra::Vector2::new(v[4], v[5]);
            let want = a.lu().solve(&b);
            let got = lu_solve_2x2(&a, &b);
            match (want, got) {
                (None, None) => {}
                (Some(w), Some(g)) => {
                    for j in 0..2 {
                        assert!(
                            w[j].to_bits() == g[j].to_bits() || (w[j].is_nan() && g[j].is_nan()),
                            "{a} {b}: {w} vs {g}"
                        );
                    }
                }
                (w, g) => panic!("{a} {b}: {w:?} vs {g:?}"),
            }
        }
    }

    #[test]
    fn finite_slice_finds_every_non_finite_value() {
        assert!(finite_slice(&[]));
        assert!(finite_slice(&[
            0.0,
            -0.0,
            f64::MAX,
            -f64::MAX,
            f64::MIN_POSITIVE,
            1e-320
        ]));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for k in 0..4 {
                let mut v = [1.0, f64::MAX, -3.0, 1e300];
                v[k] = bad;
                assert!(!finite_slice(&v), "{v:?}");
            }
        }
    }

    /// The fixed-size 6 × 6 LU and Cholesky solve random systems to round-off and agree with
    /// nalgebra's factorisations; singular and indefinite inputs are refused.
    #[test]
    fn fixed_six_by_six_solvers_match_nalgebra() {
        let mut r = crate::math::random::SplitMix64(5);
        for _ in 0..20 {
            let g = nalgebra::Matrix6::from_iterator(r.vec(36, 1.0));
            let b = nalgebra::Vector6::from_iterator(r.vec(6, 1.0));
            let rows: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| g[(i, j)]));
            let x = lu_solve6(rows, b.into()).unwrap();
            let want = g.lu().solve(&b).unwrap();
            let x = nalgebra::Vector6::from(x);
            // Both backward stable: they agree to a few ulps times the condition number.
            let cond = g.norm() * g.try_inverse().unwrap().norm();
            assert!(
                (x - want).norm() <= 1e-14 * cond * want.norm(),
                "LU {x} vs {want}"
            );
            assert!((g * x - b).norm() <= 1e-13 * g.norm() * x.norm());
            let spd = g * g.transpose() + nalgebra::Matrix6::identity();
            let rows: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| spd[(i, j)]));
            let y = nalgebra::Vector6::from(Cholesky6::new(&rows).unwrap().solve(&b.into()));
            let want = spd.cholesky().unwrap().solve(&b);
            let cond = spd.norm() * spd.try_inverse().unwrap().norm();
            assert!(
                (y - want).norm() <= 1e-14 * cond * want.norm(),
                "Cholesky {y} vs {want}"
            );
        }
        let mut sing = [[1.0; 6]; 6];
        assert_eq!(lu_solve6(sing, [1.0; 6]), None);
        sing[0][0] = -1.0;
        assert_eq!(Cholesky6::new(&sing), None);
        let mut nan = [[0.0; 6]; 6];
        (0..6).for_each(|i| nan[i][i] = 1.0);
        nan[3][3] = f64::NAN;
        assert_eq!(Cholesky6::new(&nan), None);
    }

    /// The row-major kernels solve `A X = B` for a random SPD `A` to round-off, and agree with
    /// the column-major Cholesky.
    #[test]
    fn row_major_kernels_solve_spd_systems() {
        let n = 7;
        let mut r = crate::math::random::SplitMix64(11);
        let g: Vec<f64> = r.vec(n * n, 1.0);
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..n).map(|k| g[i * n + k] * g[j * n + k]).sum::<f64>()
                    + if i == j { 0.5 } else { 0.0 };
            }
        }
        let a0 = a.clone();
        let mut l = a.clone();
        cholesky_rows(&mut l, n).unwrap();
        let m = 3;
        let b: Vec<f64> = r.vec(n * m, 1.0);
        for c in 0..m {
            let mut x: Vec<f64> = (0..n).map(|i| b[i * m + c]).collect();
            let mut xb = b.clone();
            forward_rows(&l, n, &mut xb, m);
            let mut y: Vec<f64> = (0..n).map(|i| xb[i * m + c]).collect();
            backward_rows(&l, n, &mut y);
            let dm = DMatrix::from_row_slice(n, n, &a0);
            let mut lc = dm.clone();
            cholesky_in_place(&mut lc, n).unwrap();
            cholesky_solve_in_place(&lc, n, &mut x);
            for i in 0..n {
                let res: f64 = (0..n).map(|k| a0[i * n + k] * y[k]).sum::<f64>() - b[i * m + c];
                assert!(res.abs() < 1e-12, "{res}");
                assert!((x[i] - y[i]).abs() < 1e-12 * (1.0 + x[i].abs()));
            }
        }
        let mut bad = a0.clone();
        bad[2 * n + 2] = -1.0;
        assert_eq!(cholesky_rows(&mut bad, n), Err(2));
    }
    use nalgebra::{DVector, Matrix3};

    #[test]
    fn cholesky_solves_spd_system() {
        let a = Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let b = [1.0, -2.0, 0.5];
        let mut l = a;
        cholesky_in_place(&mut l, 3).unwrap();
        let mut x = b;
        cholesky_solve_in_place(&l, 3, &mut x);
        let r = a * nalgebra::Vector3::from(x) - nalgebra::Vector3::from(b);
        assert!(r.norm() < 1e-14, "residual {r}");
        let d = DVector::from_row_slice(&x);
        assert!(d.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn ldl_agrees_with_the_cholesky_factor_and_solve() {
        // Random SPD matrices of sizes 1..=8 and condition numbers up to ~1e8: L D Lᵀ against
        // L_c L_cᵀ (L_c = L √D), the same pivot ratio, the same solution to the conditioning's
        // round-off, and the same refusals.
        let mut r = crate::math::random::SplitMix64(77);
        for trial in 0..400 {
            let n = 1 + trial % 8;
            let g = DMatrix::from_fn(n, n, |_, _| r.range(-1.0, 1.0));
            let scale = 10f64.powf(r.range(-4.0, 4.0));
            let a = (&g * g.transpose() + DMatrix::identity(n, n) * 10f64.powf(r.range(-8.0, 0.0)))
                * scale;
            let mut c = a.clone();
            let pc = cholesky_in_place(&mut c, n).unwrap();
            let mut l = a.clone();
            let mut inv_d = [0.0; LDL_MAX];
            let pl = ldl_in_place(&mut l, n, &mut inv_d).unwrap();
            let cond = {
                let e = a.clone().symmetric_eigenvalues();
                e.max() / e.min()
            };
            // The smallest pivot comes out of a cancellation: round-off ~ cond · ε of it.
            assert!(
                (pc - pl).abs() <= 1e-14 * cond * pc.abs(),
                "pivot ratio {pc} vs {pl} (cond {cond:e})"
            );
            for i in 0..n {
                let d = l[(i, i)];
                assert!((inv_d[i] * d - 1.0).abs() <= 2.0 * f64::EPSILON);
                assert!((d.sqrt() - c[(i, i)]).abs() <= 1e-14 * cond * c[(i, i)]);
                for j in 0..i {
                    // L_c = L √D: column j scales by √D_j.
                    let lc = l[(i, j)] * l[(j, j)].sqrt();
                    assert!(
                        (lc - c[(i, j)]).abs() <= 1e-13 * cond * (c[(i, j)].abs() + c[(j, j)]),
                        "n {n} ({i}, {j}): {lc} vs {}",
                        c[(i, j)]
                    );
                }
            }
            let b: Vec<f64> = (0..n).map(|_| r.range(-1.0, 1.0)).collect();
            let (mut xc, mut xl) = (b.clone(), b.clone());
            cholesky_solve_in_place(&c, n, &mut xc);
            ldl_solve_in_place(&l, &inv_d, n, &mut xl);
            let norm = xc.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (u, v) in xc.iter().zip(&xl) {
                assert!(
                    (u - v).abs() <= 1e-14 * cond * norm,
                    "{u} vs {v} (cond {cond:e})"
                );
            }
        }
        let mut bad = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(ldl_in_place(&mut bad, 3, &mut [0.0; 3]), Err(1));
        let mut nan = Matrix3::new(1.0, 0.0, 0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(ldl_in_place(&mut nan, 3, &mut [0.0; 3]), Err(1));
    }

    #[test]
    fn cholesky_rejects_indefinite() {
        let mut a = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(cholesky_in_place(&mut a, 3), Err(1));
    }
}
