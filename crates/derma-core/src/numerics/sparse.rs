//! Sparse symmetric positive definite systems (Laplacians, screened Poisson problems, mesh
//! parameterisation, registration): a sparse Cholesky factorisation on faer (supernodal or
//! simplicial, with a fill-reducing ordering), factorised once and solved for many right-hand
//! sides; where one pattern is refactorised many times, its symbolic analysis is done once.

use super::NumericsError;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, SymbolicSparseColMat, Triplet};
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
        let a = lower_matrix(n, entries, "sparse Cholesky")?;
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

/// A sparse Cholesky factor P A Pᵀ = L Lᵀ kept column by column (simplicial, in a
/// fill-reducing order) for iterations that solve with one matrix hundreds of times: its
/// [`SimplicialCholesky::solve_pairs`] runs both columns of a 2-column right-hand side (u and
/// v of a parameterisation) through one pass over L, which a supernodal solve does not.
pub struct SimplicialCholesky {
    n: usize,
    /// perm[i]: the original index of row i of P A Pᵀ.
    perm: Vec<u32>,
    col_ptr: Vec<u32>,
    /// Row of each stored entry; a column's diagonal comes first.
    row_idx: Vec<u32>,
    values: Vec<f64>,
}

impl SimplicialCholesky {
    /// Factorises the n × n matrix given by (row, column, value) entries of its lower triangle
    /// (entries above the diagonal are ignored; repeated entries are summed).
    pub fn new(n: usize, entries: &[(usize, usize, f64)]) -> Result<Self, NumericsError> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::sparse::linalg::cholesky::{
            factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholeskyRaw,
            SymmetricOrdering,
        };
        use faer::sparse::linalg::SupernodalThreshold;
        let a = lower_matrix(n, entries, "simplicial Cholesky")?;
        let shape = |detail: String| NumericsError::Shape {
            what: "simplicial Cholesky",
            detail,
        };
        let symbolic = factorize_symbolic_cholesky(
            a.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
                ..Default::default()
            },
        )
        .map_err(|e| shape(format!("{e:?}")))?;
        let mut values = vec![0.0; symbolic.len_val()];
        let mut buffer = MemBuffer::new(
            symbolic.factorize_numeric_llt_scratch::<f64>(faer::Par::Seq, Default::default()),
        );
        symbolic
            .factorize_numeric_llt(
                &mut values,
                a.as_ref(),
                Side::Lower,
                Default::default(),
                faer::Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|_| NumericsError::NotPositiveDefinite {
                what: "simplicial Cholesky",
            })?;
        let SymbolicCholeskyRaw::Simplicial(raw) = symbolic.raw() else {
            return Err(shape("faer chose a supernodal factor".into()));
        };
        let narrow = |v: &[usize]| -> Vec<u32> { v.iter().map(|&x| x as u32).collect() };
        let perm = match symbolic.perm() {
            Some(p) => narrow(p.arrays().0),
            None => (0..n as u32).collect(),
        };
        let (col_ptr, row_idx) = (narrow(raw.col_ptr()), narrow(raw.row_idx()));
        if u32::try_from(values.len()).is_err()
            || (0..n).any(|j| row_idx[col_ptr[j] as usize] as usize != j)
        {
            return Err(shape("a factor without its diagonal first".into()));
        }
        Ok(Self {
            n,
            perm,
            col_ptr,
            row_idx,
            values,
        })
    }

    /// Solves A X = B in place for a 2-column B given as rows [b₀, b₁].
    pub fn solve_pairs(&self, b: &mut [[f64; 2]]) -> Result<(), NumericsError> {
        if b.len() != self.n {
            return Err(NumericsError::Shape {
                what: "simplicial Cholesky solve",
                detail: format!(
                    "right-hand side of {} for a {} × {} matrix",
                    b.len(),
                    self.n,
                    self.n
                ),
            });
        }
        let mut y: Vec<[f64; 2]> = self.perm.iter().map(|&i| b[i as usize]).collect();
        // L y = P b, column by column.
        for j in 0..self.n {
            let (s, e) = (self.col_ptr[j] as usize, self.col_ptr[j + 1] as usize);
            let d = self.values[s];
            let yj = [y[j][0] / d, y[j][1] / d];
            y[j] = yj;
            for k in s + 1..e {
                let (r, l) = (self.row_idx[k] as usize, self.values[k]);
                y[r][0] -= l * yj[0];
                y[r][1] -= l * yj[1];
            }
        }
        // Lᵀ z = y, from the last column.
        for j in (0..self.n).rev() {
            let (s, e) = (self.col_ptr[j] as usize, self.col_ptr[j + 1] as usize);
            let mut acc = y[j];
            for k in s + 1..e {
                let (r, l) = (self.row_idx[k] as usize, self.values[k]);
                acc[0] -= l * y[r][0];
                acc[1] -= l * y[r][1];
            }
            let d = self.values[s];
            y[j] = [acc[0] / d, acc[1] / d];
        }
        for (&i, z) in self.perm.iter().zip(&y) {
            b[i as usize] = *z;
        }
        Ok(())
    }
}

/// The matrix from (row, column, value) entries of its lower triangle, repeats summed.
fn lower_matrix(
    n: usize,
    entries: &[(usize, usize, f64)],
    what: &'static str,
) -> Result<SparseColMat<usize, f64>, NumericsError> {
    if let Some(&(r, c, _)) = entries.iter().find(|(r, c, _)| *r >= n || *c >= n) {
        return Err(NumericsError::Shape {
            what,
            detail: format!("entry ({r}, {c}) outside a {n} × {n} matrix"),
        });
    }
    let lower: Vec<Triplet<usize, usize, f64>> = entries
        .iter()
        .filter(|(r, c, _)| r >= c)
        .map(|&(r, c, v)| Triplet::new(r, c, v))
        .collect();
    SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &lower).map_err(|e| {
        NumericsError::Shape {
            what,
            detail: format!("{e:?}"),
        }
    })
}

/// The lower-triangle pattern of a sparse symmetric matrix with its symbolic Cholesky
/// analysis (ordering, elimination tree, supernodes), for matrices refactorised many times with
/// new values on the same pattern.
pub struct SparsePattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: SymbolicLlt<usize>,
}

impl SparsePattern {
    /// The pattern of the n × n matrix with entries at `(row, column)` (lower triangle; the
    /// diagonal must be among them; entries above it are ignored; repeats are merged).
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Self, NumericsError> {
        if let Some(&(r, c)) = entries.iter().find(|(r, c)| *r >= n || *c >= n) {
            return Err(NumericsError::Shape {
                what: "sparse pattern",
                detail: format!("entry ({r}, {c}) outside a {n} × {n} matrix"),
            });
        }
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        for &(r, c) in entries.iter().filter(|(r, c)| r >= c) {
            cols[c].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (c, rows) in cols.iter_mut().enumerate() {
            rows.push(c);
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend_from_slice(rows);
            col_ptr.push(row_idx.len());
        }
        let sym = SymbolicSparseColMat::new_checked(n, n, col_ptr.clone(), None, row_idx.clone());
        let symbolic =
            SymbolicLlt::try_new(sym.as_ref(), Side::Lower).map_err(|e| NumericsError::Shape {
                what: "sparse pattern",
                detail: format!("{e:?}"),
            })?;
        Ok(Self {
            n,
            col_ptr,
            row_idx,
            symbolic,
        })
    }

    /// Stored entries (the length of a values array).
    pub fn len(&self) -> usize {
        self.row_idx.len()
    }

    /// Whether it stores nothing.
    pub fn is_empty(&self) -> bool {
        self.row_idx.is_empty()
    }

    /// Where entry (row, column) of the lower triangle lives in a values array.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let (r, c) = if row >= col { (row, col) } else { (col, row) };
        let (a, b) = (*self.col_ptr.get(c)?, *self.col_ptr.get(c + 1)?);
        self.row_idx[a..b].binary_search(&r).ok().map(|k| a + k)
    }

    /// The factorisation of the matrix with these values (in [`SparsePattern::slot`] order).
    pub fn factor(&self, values: &[f64]) -> Result<SparseCholesky, NumericsError> {
        if values.len() != self.len() {
            return Err(NumericsError::Shape {
                what: "sparse factorisation",
                detail: format!("{} values for a pattern of {}", values.len(), self.len()),
            });
        }
        let sym = SymbolicSparseColMat::new_checked(
            self.n,
            self.n,
            self.col_ptr.clone(),
            None,
            self.row_idx.clone(),
        );
        let a = SparseColMat::new(sym, values.to_vec());
        let llt = Llt::try_new_with_symbolic(self.symbolic.clone(), a.as_ref(), Side::Lower)
            .map_err(|_| NumericsError::NotPositiveDefinite {
                what: "sparse Cholesky",
            })?;
        Ok(SparseCholesky { n: self.n, llt })
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
    fn simplicial_pair_solves_match_the_supernodal_factor() {
        // A 2-D screened grid Laplacian (12 × 12), so that the ordering permutes and L fills.
        let w = 12;
        let n = w * w;
        let mut entries = Vec::new();
        for i in 0..n {
            entries.push((i, i, 4.05 + (i % 3) as f64 * 0.1));
            if i % w > 0 {
                entries.push((i, i - 1, -1.0));
            }
            if i >= w {
                entries.push((i, i - w, -1.0));
            }
        }
        let b0: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
        let b1: Vec<f64> = (0..n).map(|i| ((i * 3) % 11) as f64 * 0.3).collect();
        let want = SparseCholesky::new(n, &entries)
            .unwrap()
            .solve_many(&[&b0, &b1])
            .unwrap();
        let simplicial = SimplicialCholesky::new(n, &entries).unwrap();
        assert_ne!(simplicial.perm, (0..n as u32).collect::<Vec<_>>());
        let mut pairs: Vec<[f64; 2]> = b0.iter().zip(&b1).map(|(a, b)| [*a, *b]).collect();
        simplicial.solve_pairs(&mut pairs).unwrap();
        for (i, x) in pairs.iter().enumerate() {
            assert!(
                (x[0] - want[0][i]).abs() < 1e-12,
                "{} vs {}",
                x[0],
                want[0][i]
            );
            assert!(
                (x[1] - want[1][i]).abs() < 1e-12,
                "{} vs {}",
                x[1],
                want[1][i]
            );
        }
        assert!(simplicial.solve_pairs(&mut pairs[1..]).is_err());
        assert!(SimplicialCholesky::new(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
    }

    #[test]
    fn indefinite_and_misshapen_inputs_are_errors() {
        assert!(SparseCholesky::new(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
        assert!(SparseCholesky::new(2, &[(0, 2, 1.0)]).is_err());
        let c = SparseCholesky::new(1, &[(0, 0, 4.0)]).unwrap();
        assert_eq!(c.solve(&[2.0]).unwrap(), vec![0.5]);
        assert!(c.solve(&[1.0, 2.0]).is_err());
    }

    #[test]
    fn a_reused_pattern_factorises_like_a_fresh_matrix() {
        let n = 30;
        let mut pairs = Vec::new();
        for i in 0..n {
            pairs.push((i, i));
            if i > 0 {
                pairs.push((i, i - 1));
            }
            if i > 4 {
                pairs.push((i, i - 5));
            }
        }
        let pattern = SparsePattern::new(n, &pairs).unwrap();
        let b: Vec<f64> = (0..n).map(|i| (i % 4) as f64 - 1.5).collect();
        for scale in [1.0, 3.0] {
            let mut values = vec![0.0; pattern.len()];
            let mut entries = Vec::new();
            for &(r, c) in &pairs {
                let v = if r == c {
                    4.0 * scale + r as f64 * 0.01
                } else {
                    -0.7
                };
                values[pattern.slot(r, c).unwrap()] += v;
                entries.push((r, c, v));
            }
            let x = pattern.factor(&values).unwrap().solve(&b).unwrap();
            let want = SparseCholesky::new(n, &entries).unwrap().solve(&b).unwrap();
            for (a, w) in x.iter().zip(&want) {
                assert!((a - w).abs() < 1e-12);
            }
        }
        assert_eq!(pattern.slot(0, 1), pattern.slot(1, 0));
        assert!(pattern.slot(7, 0).is_none());
        assert!(pattern.factor(&[1.0]).is_err());
    }
}
