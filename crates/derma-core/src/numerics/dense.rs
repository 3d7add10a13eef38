//! Dense linear algebra: the hand-written elimination for the small systems the model matcher
//! solves millions of times, and faer's LU, Cholesky, QR least squares, SVD and symmetric
//! eigendecomposition for everything larger (Golub & Van Loan, "Matrix Computations", 4th ed.).

use super::NumericsError;
use faer::linalg::solvers::{Solve, SolveLstsq};
use faer::Side;

/// A dense column-major matrix of f64 (faer's `Mat`).
pub type Matrix = faer::Mat<f64>;

/// A `rows × cols` matrix from row-major data.
pub fn matrix_from_rows(rows: usize, cols: usize, data: &[f64]) -> Result<Matrix, NumericsError> {
    if data.len() != rows * cols {
        return Err(NumericsError::Shape {
            what: "matrix from rows",
            detail: format!(
                "{} values for {rows} × {cols} (expected {})",
                data.len(),
                rows * cols
            ),
        });
    }
    Ok(Matrix::from_fn(rows, cols, |i, j| data[i * cols + j]))
}

/// Solves A x = b for a small square A (row-major n × n) by Gaussian elimination with partial
/// pivoting; `None` when a pivot falls below 10⁻¹⁴ of the largest diagonal entry. For the
/// matcher's 3–12 unknowns it is 1.3–9× faster than faer's factorisations (BENCHMARKS.md,
/// "Numerics"); badly scaled systems, whose pivots that threshold rejects, want
/// [`cholesky_solve`] instead.
pub fn solve(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut x = b.to_vec();
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| m[i * n + col].abs().total_cmp(&m[j * n + col].abs()))?;
        let scale = (0..n)
            .map(|k| m[k * n + k].abs())
            .fold(0.0, f64::max)
            .max(1e-300);
        if m[piv * n + col].abs() <= 1e-14 * scale {
            return None;
        }
        if piv != col {
            for k in 0..n {
                m.swap(piv * n + k, col * n + k);
            }
            x.swap(piv, col);
        }
        for r in col + 1..n {
            let f = m[r * n + col] / m[col * n + col];
            if f != 0.0 {
                for k in col..n {
                    m[r * n + k] -= f * m[col * n + k];
                }
                x[r] -= f * x[col];
            }
        }
    }
    for col in (0..n).rev() {
        let mut s = x[col];
        for k in col + 1..n {
            s -= m[col * n + k] * x[k];
        }
        x[col] = s / m[col * n + col];
    }
    Some(x)
}

fn column(b: &[f64]) -> faer::Mat<f64> {
    faer::Mat::from_fn(b.len(), 1, |i, _| b[i])
}

fn check_square(what: &'static str, a: &Matrix, b: &[f64]) -> Result<(), NumericsError> {
    if a.nrows() != a.ncols() || a.nrows() != b.len() {
        return Err(NumericsError::Shape {
            what,
            detail: format!(
                "{} × {} matrix with a right-hand side of {}",
                a.nrows(),
                a.ncols(),
                b.len()
            ),
        });
    }
    Ok(())
}

fn finite(what: &'static str, x: faer::Mat<f64>) -> Result<Vec<f64>, NumericsError> {
    let v: Vec<f64> = (0..x.nrows()).map(|i| x[(i, 0)]).collect();
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(NumericsError::Singular { what })
    }
}

/// Solves A x = b by LU with partial pivoting (any square A).
pub fn lu_solve(a: &Matrix, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
    check_square("LU solve", a, b)?;
    let lu = a.partial_piv_lu();
    finite("LU", lu.solve(column(b)))
}

/// Solves A x = b for a symmetric positive definite A by Cholesky (LLᵀ; the lower half is read).
pub fn cholesky_solve(a: &Matrix, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
    check_square("Cholesky solve", a, b)?;
    let llt = a
        .llt(Side::Lower)
        .map_err(|_| NumericsError::NotPositiveDefinite { what: "Cholesky" })?;
    finite("Cholesky", llt.solve(column(b)))
}

/// The x minimising ‖A x − b‖² for a tall A (rows ≥ cols) of full column rank, by QR.
pub fn least_squares(a: &Matrix, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
    if a.nrows() < a.ncols() || a.nrows() != b.len() {
        return Err(NumericsError::Shape {
            what: "least squares",
            detail: format!(
                "{} × {} matrix (rows ≥ cols needed) with a right-hand side of {}",
                a.nrows(),
                a.ncols(),
                b.len()
            ),
        });
    }
    finite("least-squares", a.qr().solve_lstsq(column(b)))
}

/// A thin singular value decomposition A = U diag(s) Vᵀ.
#[derive(Clone, Debug)]
pub struct Svd {
    /// Left singular vectors, rows × k (k = min(rows, cols)), as columns.
    pub u: Matrix,
    /// Singular values, non-negative and non-increasing.
    pub s: Vec<f64>,
    /// Right singular vectors, cols × k, as columns.
    pub v: Matrix,
}

/// The thin SVD of `a`.
pub fn svd(a: &Matrix) -> Result<Svd, NumericsError> {
    let d = a
        .thin_svd()
        .map_err(|_| NumericsError::NoConvergence { what: "SVD" })?;
    Ok(Svd {
        u: d.U().to_owned(),
        s: d.S().column_vector().iter().copied().collect(),
        v: d.V().to_owned(),
    })
}

/// An eigendecomposition of a symmetric matrix A = V diag(values) Vᵀ.
#[derive(Clone, Debug)]
pub struct Eigen {
    /// Eigenvalues, non-decreasing.
    pub values: Vec<f64>,
    /// Orthonormal eigenvectors as columns, in the order of `values`.
    pub vectors: Matrix,
}

/// The eigendecomposition of a symmetric `a` (the lower half is read), e.g. a covariance
/// matrix for principal components.
pub fn symmetric_eigen(a: &Matrix) -> Result<Eigen, NumericsError> {
    if a.nrows() != a.ncols() {
        return Err(NumericsError::Shape {
            what: "symmetric eigen",
            detail: format!("{} × {} is not square", a.nrows(), a.ncols()),
        });
    }
    let e = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| NumericsError::NoConvergence {
            what: "eigendecomposition",
        })?;
    Ok(Eigen {
        values: e.S().column_vector().iter().copied().collect(),
        vectors: e.U().to_owned(),
    })
}

/// The eigenpair (λ, x) of the smallest λ in A x = λ B x for a symmetric `a` and a symmetric
/// positive definite `b`, x scaled so that xᵀ B x = 1: B is whitened by its own
/// eigendecomposition, C = Λ^{-½} Qᵀ A Q Λ^{-½} (Golub & Van Loan §8.7.2). B's eigenvalues below
/// 10⁻¹² of its largest are raised to that floor.
pub fn smallest_generalized_eigenpair(
    a: &Matrix,
    b: &Matrix,
) -> Result<(f64, Vec<f64>), NumericsError> {
    let n = a.nrows();
    if b.nrows() != n || b.ncols() != n || a.ncols() != n {
        return Err(NumericsError::Shape {
            what: "generalized eigenproblem",
            detail: format!(
                "A {} × {}, B {} × {}",
                a.nrows(),
                a.ncols(),
                b.nrows(),
                b.ncols()
            ),
        });
    }
    let eb = symmetric_eigen(b)?;
    let top = eb.values.iter().copied().fold(0.0, f64::max);
    if top <= 0.0 {
        return Err(NumericsError::Shape {
            what: "generalized eigenproblem",
            detail: "B is not positive definite".into(),
        });
    }
    let w = Matrix::from_fn(n, n, |i, j| {
        eb.vectors[(i, j)] / eb.values[j].max(1e-12 * top).sqrt()
    });
    let c = w.transpose() * a * &w;
    let ec = symmetric_eigen(&c)?;
    let y = ec.vectors.col(0);
    let x = &w * y;
    Ok((ec.values[0], (0..n).map(|i| x[i]).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A symmetric positive definite n × n matrix with a known structure (row-major).
    fn spd(n: usize) -> Vec<f64> {
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] =
                    1.0 / (1.0 + (i as f64 - j as f64).abs()) + if i == j { n as f64 } else { 0.0 };
            }
        }
        a
    }

    #[test]
    fn solve_small_system() {
        let a = [4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0];
        let x = solve(&a, &[1.0, 2.0, 3.0], 3).unwrap();
        for r in 0..3 {
            let s: f64 = (0..3).map(|k| a[r * 3 + k] * x[k]).sum();
            assert!((s - [1.0, 2.0, 3.0][r]).abs() < 1e-12);
        }
        assert!(solve(&[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0], 2).is_none());
    }

    #[test]
    fn every_solver_agrees_with_elimination() {
        for n in [1, 3, 7, 12] {
            let a = spd(n);
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let want = solve(&a, &b, n).unwrap();
            let m = matrix_from_rows(n, n, &a).unwrap();
            for got in [
                lu_solve(&m, &b).unwrap(),
                cholesky_solve(&m, &b).unwrap(),
                least_squares(&m, &b).unwrap(),
            ] {
                for (g, w) in got.iter().zip(&want) {
                    assert!((g - w).abs() < 1e-12, "n = {n}: {got:?} vs {want:?}");
                }
            }
        }
        let singular = matrix_from_rows(2, 2, &[1.0, 2.0, 2.0, 4.0]).unwrap();
        assert!(cholesky_solve(&singular, &[1.0, 1.0]).is_err());
        assert!(lu_solve(&singular, &[1.0, 1.0]).is_err());
        assert!(lu_solve(&singular, &[1.0]).is_err());
    }

    #[test]
    fn least_squares_fits_a_line() {
        // y = 1 + 2x with symmetric noise ±0.1: the normal equations give the line exactly.
        let xs = [0.0, 1.0, 2.0, 3.0];
        let ys = [1.1, 2.9, 5.1, 6.9];
        let a = Matrix::from_fn(4, 2, |i, j| if j == 0 { 1.0 } else { xs[i] });
        let p = least_squares(&a, &ys).unwrap();
        // Closed form: slope = Σ(x−x̄)(y−ȳ)/Σ(x−x̄)², intercept = ȳ − slope·x̄.
        assert!(
            (p[1] - 1.96).abs() < 1e-12 && (p[0] - 1.06).abs() < 1e-12,
            "{p:?}"
        );
    }

    #[test]
    fn svd_reconstructs_and_orders() {
        let data = [3.0, 1.0, 1.0, -1.0, 3.0, 1.0];
        let a = matrix_from_rows(2, 3, &data).unwrap();
        let d = svd(&a).unwrap();
        // The singular values of this matrix are √12 and √10 (eigenvalues of AAᵀ = [[11,1],[1,11]]).
        assert!((d.s[0] - 12f64.sqrt()).abs() < 1e-12 && (d.s[1] - 10f64.sqrt()).abs() < 1e-12);
        for i in 0..2 {
            for j in 0..3 {
                let v: f64 = (0..2).map(|k| d.u[(i, k)] * d.s[k] * d.v[(j, k)]).sum();
                assert!((v - data[i * 3 + j]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn symmetric_eigen_of_a_known_matrix() {
        // [[2,1],[1,2]]: eigenvalues 1 and 3, eigenvectors (1,−1)/√2 and (1,1)/√2.
        let a = matrix_from_rows(2, 2, &[2.0, 1.0, 1.0, 2.0]).unwrap();
        let e = symmetric_eigen(&a).unwrap();
        assert!((e.values[0] - 1.0).abs() < 1e-12 && (e.values[1] - 3.0).abs() < 1e-12);
        let v = &e.vectors;
        assert!((v[(0, 1)].abs() - 0.5f64.sqrt()).abs() < 1e-12);
        assert!(
            (v[(0, 0)] + v[(1, 0)]).abs() < 1e-12,
            "first eigenvector ∝ (1, −1)"
        );
    }

    #[test]
    fn generalized_eigenpair_satisfies_its_equation() {
        let n = 5;
        let a = Matrix::from_fn(n, n, |i, j| {
            spd(n)[i * n + j] - if i == j { 3.0 } else { 0.0 }
        });
        let b = Matrix::from_fn(n, n, |i, j| if i == j { 1.0 + i as f64 } else { 0.1 });
        let (l, x) = smallest_generalized_eigenpair(&a, &b).unwrap();
        let xv = Matrix::from_fn(n, 1, |i, _| x[i]);
        let (ax, bx) = (&a * &xv, &b * &xv);
        for i in 0..n {
            assert!((ax[(i, 0)] - l * bx[(i, 0)]).abs() < 1e-9, "row {i}");
        }
        let xbx: f64 = (0..n).map(|i| x[i] * bx[(i, 0)]).sum();
        assert!((xbx - 1.0).abs() < 1e-9);
        // The smallest: no other generalized Rayleigh quotient below it.
        for k in 0..n {
            let e = Matrix::from_fn(n, 1, |i, _| (i == k) as u8 as f64 + 0.1);
            let q = (e.transpose() * &a * &e)[(0, 0)] / (e.transpose() * &b * &e)[(0, 0)];
            assert!(q >= l - 1e-12);
        }
    }
}
