//! Small dense linear algebra on caller-owned buffers (no allocation).
//!
//! The matrices here are tiny (a few rows: an arm's joint-space inertia, the grasp-space
//! inverse inertia); an in-place Cholesky on a `DMatrix` or a fixed `SMatrix` avoids the
//! allocation that `nalgebra::Cholesky::new(m.clone())` would make inside a step.

use nalgebra::{DMatrix, Dim, Matrix, RawStorageMut};

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

/// Convenience: `true` when every entry of a dynamic matrix is finite.
pub fn all_finite(m: &DMatrix<f64>) -> bool {
    m.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
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
    fn cholesky_rejects_indefinite() {
        let mut a = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(cholesky_in_place(&mut a, 3), Err(1));
    }
}
