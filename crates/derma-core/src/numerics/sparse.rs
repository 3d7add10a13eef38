//! Sparse symmetric positive definite systems (Laplacians, screened Poisson problems, mesh
//! parameterisation): a sparse Cholesky factorisation on faer (supernodal or simplicial,
//! with a fill-reducing ordering), factorised once and solved for many right-hand sides.

use super::NumericsError;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use faer::Side;

/// A factorised sparse symmetric positive definite matrix.
pub struct SparseCholesky {
    n: usize,
    llt: faer::sparse::linalg::solvers::Llt<usize, f64>,
}

impl SparseCholesky {
    /// Factorises the n × n matrix given by (row, column, value) entries of its lower triangle
    /// (entries above the diagonal are ignored; repeated entries are summed).
    pub fn new(n: usize, entries: &[(usize, usize, f64)]) -> Result<Self, NumericsError> {
        if let Some(&(r, c, _)) = entries.iter().find(|(r, c, _)| *r >= n || *c >= n) {
            return Err(NumericsError::Shape {
                what: "sparse Cholesky",
                detail: format!("entry ({r}, {c}) outside a {n} × {n} matrix"),
            });
        }
        let lower: Vec<Triplet<usize, usize, f64>> = entries
            .iter()
            .filter(|(r, c, _)| r >= c)
            .map(|&(r, c, v)| Triplet::new(r, c, v))
            .collect();
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &lower).map_err(|e| {
            NumericsError::Shape {
                what: "sparse Cholesky",
                detail: format!("{e:?}"),
            }
        })?;
        let llt = a
            .sp_cholesky(Side::Lower)
            .map_err(|_| NumericsError::NotPositiveDefinite {
                what: "sparse Cholesky",
            })?;
        Ok(Self { n, llt })
    }

    /// The solutions of A X = B for several right-hand sides at once (one pass over the factor
    /// for all of them: faster than one solve each).
    pub fn solve_many(&self, b: &[&[f64]]) -> Result<Vec<Vec<f64>>, NumericsError> {
        if let Some(bad) = b.iter().find(|c| c.len() != self.n) {
            return Err(NumericsError::Shape {
                what: "sparse Cholesky solve",
                detail: format!(
                    "right-hand side of {} for a {} × {} matrix",
                    bad.len(),
                    self.n,
                    self.n
                ),
            });
        }
        let x = self
            .llt
            .solve(faer::Mat::from_fn(self.n, b.len(), |i, j| b[j][i]));
        Ok((0..b.len())
            .map(|j| (0..self.n).map(|i| x[(i, j)]).collect())
            .collect())
    }

    /// The solution x of A x = b.
    pub fn solve(&self, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
        if b.len() != self.n {
            return Err(NumericsError::Shape {
                what: "sparse Cholesky solve",
                detail: format!(
                    "right-hand side of {} for a {} × {} matrix",
                    b.len(),
                    self.n,
                    self.n
                ),
            });
        }
        let x = self.llt.solve(faer::Mat::from_fn(self.n, 1, |i, _| b[i]));
        Ok((0..self.n).map(|i| x[(i, 0)]).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_laplacian_matches_dense_elimination() {
        // A 1-D screened Laplacian (tridiagonal: 2 + ε on the diagonal, −1 beside it).
        let n = 50;
        let mut entries = Vec::new();
        let mut dense = vec![0.0; n * n];
        for i in 0..n {
            entries.push((i, i, 2.01));
            dense[i * n + i] = 2.01;
            if i > 0 {
                entries.push((i, i - 1, -1.0));
                dense[i * n + i - 1] = -1.0;
                dense[(i - 1) * n + i] = -1.0;
            }
        }
        let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
        let chol = SparseCholesky::new(n, &entries).unwrap();
        let x = chol.solve(&b).unwrap();
        let want = super::super::dense::solve(&dense, &b, n).unwrap();
        for (a, w) in x.iter().zip(&want) {
            assert!((a - w).abs() < 1e-10, "{a} vs {w}");
        }
        // Several right-hand sides at once give each one's solution.
        let b2: Vec<f64> = b.iter().map(|v| 3.0 - v).collect();
        let many = chol.solve_many(&[&b, &b2]).unwrap();
        assert_eq!(many[0], x);
        let want2 = super::super::dense::solve(&dense, &b2, n).unwrap();
        for (a, w) in many[1].iter().zip(&want2) {
            assert!((a - w).abs() < 1e-10, "{a} vs {w}");
        }
        assert!(chol.solve_many(&[&b, &b2[1..]]).is_err());
    }

    #[test]
    fn indefinite_and_misshapen_inputs_are_errors() {
        assert!(SparseCholesky::new(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
        assert!(SparseCholesky::new(2, &[(0, 2, 1.0)]).is_err());
        let c = SparseCholesky::new(1, &[(0, 0, 4.0)]).unwrap();
        assert_eq!(c.solve(&[2.0]).unwrap(), vec![0.5]);
        assert!(c.solve(&[1.0, 2.0]).is_err());
    }
}
