//! Dense linear algebra, derma's own: the hand-written elimination for the small systems the
//! model matcher solves millions of times, and LU, Cholesky, Householder QR least squares,
//! one-sided Jacobi SVD and Householder–QL symmetric eigendecomposition for the rest (Golub &
//! Van Loan, "Matrix Computations", 4th ed., §3.2, §4.2, §5.2, §8.3, §8.6.3).

use super::NumericsError;
use std::ops::{Index, IndexMut, Mul};

/// A dense column-major matrix of f64.
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Matrix {
    /// The `rows × cols` matrix of zeros.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }

    /// The `rows × cols` matrix whose entry (i, j) is `f(i, j)`.
    pub fn from_fn(rows: usize, cols: usize, mut f: impl FnMut(usize, usize) -> f64) -> Self {
        let mut data = Vec::with_capacity(rows * cols);
        for j in 0..cols {
            for i in 0..rows {
                data.push(f(i, j));
            }
        }
        Self { rows, cols, data }
    }

    /// The n × n identity.
    pub fn identity(n: usize) -> Self {
        Self::from_fn(n, n, |i, j| (i == j) as u8 as f64)
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.cols
    }

    /// Column `j` as a slice.
    pub fn col(&self, j: usize) -> &[f64] {
        &self.data[j * self.rows..(j + 1) * self.rows]
    }

    fn col_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.data[j * self.rows..(j + 1) * self.rows]
    }

    /// Columns `p` < `q` as two mutable slices.
    fn col_pair(&mut self, p: usize, q: usize) -> (&mut [f64], &mut [f64]) {
        let r = self.rows;
        let (a, b) = self.data.split_at_mut(q * r);
        (&mut a[p * r..(p + 1) * r], &mut b[..r])
    }

    /// The transpose.
    pub fn transpose(&self) -> Matrix {
        Matrix::from_fn(self.cols, self.rows, |i, j| self[(j, i)])
    }

    /// The product A x.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        assert_eq!(x.len(), self.cols, "matrix-vector product: sizes");
        let mut y = vec![0.0; self.rows];
        for (j, &xj) in x.iter().enumerate() {
            for (yi, a) in y.iter_mut().zip(self.col(j)) {
                *yi += a * xj;
            }
        }
        y
    }
}

impl Index<(usize, usize)> for Matrix {
    type Output = f64;
    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        assert!(
            i < self.rows && j < self.cols,
            "index ({i}, {j}) outside {} × {}",
            self.rows,
            self.cols
        );
        &self.data[j * self.rows + i]
    }
}

impl IndexMut<(usize, usize)> for Matrix {
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut f64 {
        assert!(
            i < self.rows && j < self.cols,
            "index ({i}, {j}) outside {} × {}",
            self.rows,
            self.cols
        );
        &mut self.data[j * self.rows + i]
    }
}

impl Mul<&Matrix> for &Matrix {
    type Output = Matrix;
    fn mul(self, b: &Matrix) -> Matrix {
        assert_eq!(self.cols, b.rows, "matrix product: sizes");
        let mut c = Matrix::zeros(self.rows, b.cols);
        for j in 0..b.cols {
            let cj = c.col_mut(j);
            for k in 0..self.cols {
                let bkj = b[(k, j)];
                for (ci, a) in cj.iter_mut().zip(self.col(k)) {
                    *ci += a * bkj;
                }
            }
        }
        c
    }
}

impl Mul<&Matrix> for Matrix {
    type Output = Matrix;
    fn mul(self, b: &Matrix) -> Matrix {
        &self * b
    }
}

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
/// matcher's 3–12 unknowns it was faster than faer's general factorisation when that was
/// measured (BENCHMARKS.md, "Numerics"); badly scaled systems, whose pivots that threshold rejects, want
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

fn finite(what: &'static str, a: &Matrix, x: Vec<f64>) -> Result<Vec<f64>, NumericsError> {
    if x.iter().all(|x| x.is_finite()) {
        Ok(x)
    } else {
        Err(NumericsError::Singular {
            what,
            rows: a.nrows(),
            cols: a.ncols(),
            column: None,
        })
    }
}

/// The dot product of two slices (over the shorter's length), summed in order.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves U x = y in place for the upper triangle of the leading n × n block of `u`.
fn back_substitute(u: &Matrix, x: &mut [f64]) {
    for i in (0..x.len()).rev() {
        let s = x[i] - (i + 1..x.len()).map(|k| u[(i, k)] * x[k]).sum::<f64>();
        x[i] = s / u[(i, i)];
    }
}

/// Solves A x = b by LU with partial pivoting (any square A; G&VL Algorithm 3.4.1).
pub fn lu_solve(a: &Matrix, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
    check_square("LU solve", a, b)?;
    let n = a.nrows();
    let mut m = a.clone();
    let mut x = b.to_vec();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| m[(i, k)].abs().total_cmp(&m[(j, k)].abs()))
            .unwrap_or(k);
        if m[(p, k)] == 0.0 {
            return Err(NumericsError::Singular {
                what: "LU",
                rows: n,
                cols: n,
                column: Some(k),
            });
        }
        if p != k {
            for j in 0..n {
                m.data.swap(j * n + p, j * n + k);
            }
            x.swap(p, k);
        }
        let pivot = m[(k, k)];
        for i in k + 1..n {
            m[(i, k)] /= pivot;
        }
        for j in k + 1..n {
            let mkj = m[(k, j)];
            if mkj != 0.0 {
                for i in k + 1..n {
                    let l = m[(i, k)];
                    m[(i, j)] -= l * mkj;
                }
            }
        }
        let xk = x[k];
        for i in k + 1..n {
            x[i] -= m[(i, k)] * xk;
        }
    }
    back_substitute(&m, &mut x);
    finite("LU", a, x)
}

/// Solves A x = b for a symmetric positive definite A by Cholesky (LLᵀ; the lower half is read;
/// G&VL Algorithm 4.2.2).
pub fn cholesky_solve(a: &Matrix, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
    check_square("Cholesky solve", a, b)?;
    let n = a.nrows();
    let mut l = Matrix::zeros(n, n);
    for j in 0..n {
        let d = a[(j, j)] - (0..j).map(|k| l[(j, k)] * l[(j, k)]).sum::<f64>();
        if !(d > 0.0) {
            return Err(NumericsError::NotPositiveDefinite {
                what: "Cholesky",
                n,
                column: j,
                pivot: d,
            });
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..n {
            let s = a[(i, j)] - (0..j).map(|k| l[(i, k)] * l[(j, k)]).sum::<f64>();
            l[(i, j)] = s / d;
        }
    }
    let mut x = b.to_vec();
    for i in 0..n {
        let s = x[i] - (0..i).map(|k| l[(i, k)] * x[k]).sum::<f64>();
        x[i] = s / l[(i, i)];
    }
    for i in (0..n).rev() {
        let s = x[i] - (i + 1..n).map(|k| l[(k, i)] * x[k]).sum::<f64>();
        x[i] = s / l[(i, i)];
    }
    finite("Cholesky", a, x)
}

/// The x minimising ‖A x − b‖² for a tall A (rows ≥ cols) of full column rank, by Householder
/// QR (G&VL §5.2.2 and Algorithm 5.3.2); a rank-deficient A is [`NumericsError::Singular`].
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
    let (m, n) = (a.nrows(), a.ncols());
    let mut r = a.clone();
    let mut y = b.to_vec();
    // A column whose part outside the span of those before it is rounding noise (m ε of its
    // length) makes the rank deficient.
    let length = |x: &[f64]| {
        let big = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if big == 0.0 || !big.is_finite() {
            return big;
        }
        x.iter().map(|v| (v / big) * (v / big)).sum::<f64>().sqrt() * big
    };
    let lengths: Vec<f64> = (0..n).map(|j| length(a.col(j))).collect();
    for k in 0..n {
        // As in the tridiagonal reduction: v from the column scaled by its largest entry.
        let big = r.col(k)[k..].iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut v: Vec<f64> = r.col(k)[k..]
            .iter()
            .map(|x| x / big.max(f64::MIN_POSITIVE))
            .collect();
        let norm = dot(&v, &v).sqrt() * big;
        if !(norm > m as f64 * f64::EPSILON * lengths[k]) {
            return Err(NumericsError::Singular {
                what: "least-squares",
                rows: m,
                cols: n,
                column: Some(k),
            });
        }
        let scaled = norm / big;
        v[0] -= if v[0] > 0.0 { -scaled } else { scaled };
        let scale = 2.0 / dot(&v, &v);
        for j in k..n {
            let cj = &mut r.col_mut(j)[k..m];
            let s = scale * dot(&v, cj);
            cj.iter_mut().zip(&v).for_each(|(c, vi)| *c -= s * vi);
        }
        let s = scale * dot(&v, &y[k..]);
        y[k..].iter_mut().zip(&v).for_each(|(c, vi)| *c -= s * vi);
    }
    y.truncate(n);
    back_substitute(&r, &mut y);
    finite("least-squares", a, y)
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

/// Sweeps of the Jacobi SVD, and QL steps per eigenvalue, after which the iteration is declared
/// not to converge. Both converge quadratically and a few suffice for the sizes derma meets;
/// LAPACK's dgesvj allows 30 sweeps and EISPACK's tql2 30 steps per eigenvalue, twice that here.
const MAX_SWEEPS: usize = 60;

/// The thin SVD of `a`, by one-sided Jacobi rotations of its columns (Hestenes 1958; G&VL
/// §8.6.3): orthogonalise the columns pairwise, then σⱼ = ‖aⱼ‖ and uⱼ = aⱼ / σⱼ. Left vectors
/// of (numerically) zero singular values are completed to an orthonormal set.
pub fn svd(a: &Matrix) -> Result<Svd, NumericsError> {
    if a.nrows() < a.ncols() {
        // Errors name the matrix as given, not its transpose.
        let t = svd(&a.transpose()).map_err(|e| match e {
            NumericsError::NoConvergence {
                what,
                rows,
                cols,
                iterations,
            } => NumericsError::NoConvergence {
                what,
                rows: cols,
                cols: rows,
                iterations,
            },
            e => e,
        })?;
        return Ok(Svd {
            u: t.v,
            s: t.s,
            v: t.u,
        });
    }
    let (m, n) = (a.nrows(), a.ncols());
    // Scaled by its largest entry, so the columns' squared norms neither overflow nor underflow;
    // the singular values are scaled back at the end.
    let big = a.data.iter().fold(0.0f64, |b, x| b.max(x.abs()));
    let unscale = if big > 0.0 && big.is_finite() {
        big
    } else {
        1.0
    };
    let mut w = Matrix::from_fn(m, n, |i, j| a[(i, j)] / unscale);
    let mut v = Matrix::identity(n);
    let mut converged = false;
    // Columns count as orthogonal below √m ε of their lengths (the rounding of a dot product of
    // m terms; LAPACK's dgesvj uses the same).
    let tolerance = (m as f64).sqrt() * f64::EPSILON;
    for _ in 0..MAX_SWEEPS {
        let mut rotated = false;
        for p in 0..n {
            for q in p + 1..n {
                let (wp, wq) = w.col_pair(p, q);
                let (alpha, beta, gamma) = (dot(wp, wp), dot(wq, wq), dot(wp, wq));
                if gamma == 0.0 || gamma.abs() <= tolerance * alpha.sqrt() * beta.sqrt() {
                    continue;
                }
                rotated = true;
                // The rotation that makes columns p and q orthogonal: t = tan θ, the smaller
                // root of t² + 2ζt − 1 = 0.
                let zeta = (beta - alpha) / (2.0 * gamma);
                let t = zeta.signum() / (zeta.abs() + zeta.hypot(1.0));
                let c = 1.0 / t.hypot(1.0);
                let s = c * t;
                rotate(wp, wq, c, s);
                let (vp, vq) = v.col_pair(p, q);
                rotate(vp, vq, c, s);
            }
        }
        if !rotated {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(NumericsError::NoConvergence {
            what: "SVD",
            rows: m,
            cols: n,
            iterations: MAX_SWEEPS,
        });
    }
    let norms: Vec<f64> = (0..n).map(|j| dot(w.col(j), w.col(j)).sqrt()).collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| norms[j].total_cmp(&norms[i]).then(i.cmp(&j)));
    let top = norms.iter().copied().fold(0.0, f64::max);
    let mut u = Matrix::zeros(m, n);
    let mut vs = Matrix::zeros(n, n);
    let mut s = Vec::with_capacity(n);
    let mut missing = Vec::new();
    for (k, &j) in order.iter().enumerate() {
        s.push(norms[j] * unscale);
        vs.col_mut(k).copy_from_slice(v.col(j));
        // Below m·ε·σ₁ a singular value cannot be told from rounding (the rank cut-off of
        // LAPACK-style codes; NumPy's matrix_rank uses max(m, n)·ε·σ₁).
        if norms[j] > m as f64 * f64::EPSILON * top {
            let inv = 1.0 / norms[j];
            u.col_mut(k)
                .iter_mut()
                .zip(w.col(j))
                .for_each(|(d, x)| *d = x * inv);
        } else {
            missing.push(k);
        }
    }
    for k in missing {
        complete_column(&mut u, k, &s);
    }
    Ok(Svd { u, s, v: vs })
}

/// Columns (x, y) ← (c x − s y, s x + c y).
fn rotate(x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
    for (a, b) in x.iter_mut().zip(y.iter_mut()) {
        let (p, q) = (*a, *b);
        *a = c * p - s * q;
        *b = s * p + c * q;
    }
}

/// Fills column k of `u` with a unit vector orthogonal to its columns with a non-zero singular
/// value and to those completed before it: the coordinate axis that keeps the most of its
/// length through two rounds of Gram–Schmidt (at least 1/√m of it: the squared residuals of
/// all axes sum to the number of columns still free).
fn complete_column(u: &mut Matrix, k: usize, s: &[f64]) {
    let m = u.nrows();
    let top = s.iter().copied().fold(0.0, f64::max);
    let filled: Vec<usize> = (0..u.ncols())
        .filter(|&j| j != k && (s[j] > m as f64 * f64::EPSILON * top || j < k))
        .collect();
    let residual = |axis: usize| {
        let mut x = vec![0.0; m];
        x[axis] = 1.0;
        for _ in 0..2 {
            for &j in &filled {
                let d = dot(&x, u.col(j));
                x.iter_mut().zip(u.col(j)).for_each(|(a, b)| *a -= d * b);
            }
        }
        x
    };
    let mut best: Option<(f64, Vec<f64>)> = None;
    for axis in 0..m {
        let x = residual(axis);
        let len = dot(&x, &x).sqrt();
        if best.as_ref().is_none_or(|(l, _)| len > *l) {
            best = Some((len, x));
        }
    }
    if let Some((len, x)) = best {
        u.col_mut(k)
            .iter_mut()
            .zip(&x)
            .for_each(|(d, a)| *d = a / len);
    }
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
/// matrix for principal components: Householder reduction to tridiagonal form (G&VL §8.3.1),
/// then implicitly shifted QL iterations on the tridiagonal (G&VL §8.3.3, the QL ordering of
/// Bowdler, Martin, Reinsch & Wilkinson 1968), the rotations accumulated into the eigenvectors.
pub fn symmetric_eigen(a: &Matrix) -> Result<Eigen, NumericsError> {
    if a.nrows() != a.ncols() {
        return Err(NumericsError::Shape {
            what: "symmetric eigen",
            detail: format!("{} × {} is not square", a.nrows(), a.ncols()),
        });
    }
    let n = a.nrows();
    let mut t = Matrix::from_fn(n, n, |i, j| if i >= j { a[(i, j)] } else { a[(j, i)] });
    let mut z = Matrix::identity(n);
    let (mut d, mut e) = tridiagonalise(&mut t, &mut z);
    tridiagonal_ql(&mut d, &mut e, &mut z)?;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| d[i].total_cmp(&d[j]).then(i.cmp(&j)));
    let mut vectors = Matrix::zeros(n, n);
    for (k, &j) in order.iter().enumerate() {
        vectors.col_mut(k).copy_from_slice(z.col(j));
    }
    Ok(Eigen {
        values: order.iter().map(|&j| d[j]).collect(),
        vectors,
    })
}

/// Reduces the symmetric `t` (both halves stored) to tridiagonal form by Householder
/// reflections Hₖ = I − β v vᵀ applied on both sides, multiplying them into `q` from the right.
/// Returns the diagonal and the sub-diagonal (the last entry 0).
fn tridiagonalise(t: &mut Matrix, q: &mut Matrix) -> (Vec<f64>, Vec<f64>) {
    let n = t.nrows();
    let mut v = vec![0.0; n];
    let mut p = vec![0.0; n];
    for k in 0..n.saturating_sub(2) {
        // The reflector from the column scaled by its largest entry, so that squares neither
        // underflow nor overflow (H does not depend on v's scale).
        let big = t.col(k)[k + 1..].iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if big == 0.0 {
            continue;
        }
        v.fill(0.0);
        v[k + 1..]
            .iter_mut()
            .zip(&t.col(k)[k + 1..])
            .for_each(|(vi, x)| *vi = x / big);
        let norm = dot(&v[k + 1..], &v[k + 1..]).sqrt();
        let scaled = if v[k + 1] > 0.0 { -norm } else { norm };
        let alpha = scaled * big;
        v[k + 1] -= scaled;
        let beta = 2.0 / dot(&v[k + 1..], &v[k + 1..]);
        // p = β T v, w = p − (β/2)(pᵀv) v, T ← T − v wᵀ − w vᵀ on the trailing block.
        for i in k + 1..n {
            p[i] = beta * (k + 1..n).map(|j| t[(i, j)] * v[j]).sum::<f64>();
        }
        let half = 0.5 * beta * dot(&p[k + 1..], &v[k + 1..]);
        for i in k + 1..n {
            p[i] -= half * v[i];
        }
        for j in k + 1..n {
            let (vj, wj) = (v[j], p[j]);
            let col = t.col_mut(j);
            for i in k + 1..n {
                col[i] -= v[i] * wj + p[i] * vj;
            }
        }
        for i in k + 2..n {
            t[(i, k)] = 0.0;
            t[(k, i)] = 0.0;
        }
        t[(k + 1, k)] = alpha;
        t[(k, k + 1)] = alpha;
        // Q ← Q H: each row r of Q loses β (q_r · v) vᵀ.
        for r in 0..n {
            let s = beta * (k + 1..n).map(|j| q[(r, j)] * v[j]).sum::<f64>();
            if s != 0.0 {
                for j in k + 1..n {
                    q[(r, j)] -= s * v[j];
                }
            }
        }
    }
    let d = (0..n).map(|i| t[(i, i)]).collect();
    let e = (0..n)
        .map(|i| if i + 1 < n { t[(i + 1, i)] } else { 0.0 })
        .collect();
    (d, e)
}

/// Diagonalises the symmetric tridiagonal matrix with diagonal `d` and sub-diagonal `e` (e[i]
/// couples i and i + 1) by implicitly shifted QL steps, each a chase of plane rotations from the
/// bottom of an unreduced block to its top with the Wilkinson-like shift of its leading 2 × 2;
/// the rotations are applied to the columns of `z`. On return `d` holds the eigenvalues.
fn tridiagonal_ql(d: &mut [f64], e: &mut [f64], z: &mut Matrix) -> Result<(), NumericsError> {
    let n = d.len();
    // A coupling is negligible beside its own diagonal pair or beside the whole matrix: the
    // second test ends the iteration on clusters of eigenvalues near zero, which rounding at the
    // matrix's scale would otherwise keep coupled (the result stays backward stable).
    let scale = (0..n).map(|i| d[i].abs() + e[i].abs()).fold(0.0, f64::max);
    let negligible = |e: f64, a: f64, b: f64| e <= f64::EPSILON * (a.abs() + b.abs()).max(scale);
    for l in 0..n {
        let mut steps = 0;
        loop {
            // The first negligible coupling at or after l ends the block [l, m].
            let mut m = l;
            while m + 1 < n && !negligible(e[m].abs(), d[m], d[m + 1]) {
                m += 1;
            }
            if m == l {
                break;
            }
            steps += 1;
            if steps > MAX_SWEEPS {
                return Err(NumericsError::NoConvergence {
                    what: "eigendecomposition",
                    rows: n,
                    cols: n,
                    iterations: steps,
                });
            }
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = g.hypot(1.0);
            g = d[m] - d[l] + e[l] / (g + r.copysign(g));
            let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
            let mut deflated = false;
            for i in (l..m).rev() {
                let f = s * e[i];
                let b = c * e[i];
                r = f.hypot(g);
                e[i + 1] = r;
                if r == 0.0 {
                    // The rotation vanished: the block splits at i + 1; start it again.
                    d[i + 1] -= p;
                    e[m] = 0.0;
                    deflated = true;
                    break;
                }
                s = f / r;
                c = g / r;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                let (zi, zi1) = z.col_pair(i, i + 1);
                rotate(zi, zi1, c, s);
            }
            if deflated {
                continue;
            }
            d[l] -= p;
            e[l] = g;
            e[m] = 0.0;
        }
    }
    Ok(())
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
    // B's eigenvalues floored at 10⁻¹² of the largest (its condition capped at 10¹²), so a
    // nearly singular direction of B is not divided by zero.
    let w = Matrix::from_fn(n, n, |i, j| {
        eb.vectors[(i, j)] / eb.values[j].max(1e-12 * top).sqrt()
    });
    let c = w.transpose() * a * &w;
    let ec = symmetric_eigen(&c)?;
    Ok((ec.values[0], w.mul_vec(ec.vectors.col(0))))
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
        // The second column is twice the first: the errors name the size and the column.
        let singular = matrix_from_rows(2, 2, &[1.0, 2.0, 2.0, 4.0]).unwrap();
        let e = cholesky_solve(&singular, &[1.0, 1.0]).unwrap_err();
        assert_eq!(
            e,
            NumericsError::NotPositiveDefinite {
                what: "Cholesky",
                n: 2,
                column: 1,
                pivot: 0.0
            }
        );
        assert!(e.to_string().contains("2 × 2") && e.to_string().contains("column 1"));
        let e = lu_solve(&singular, &[1.0, 1.0]).unwrap_err();
        assert_eq!(
            e,
            NumericsError::Singular {
                what: "LU",
                rows: 2,
                cols: 2,
                column: Some(1)
            }
        );
        assert_eq!(
            e.to_string(),
            "the 2 × 2 LU matrix is singular (column 1 depends on those before it)"
        );
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

    /// A deterministic symmetric n × n matrix with spread, clustered and repeated eigenvalues
    /// (a full-rank random-like part plus 0–3 on the diagonal).
    fn symmetric(n: usize) -> Matrix {
        Matrix::from_fn(n, n, |i, j| {
            let (a, b) = (i.min(j) as f64, i.max(j) as f64);
            ((a * 1.7 + b * 0.31).sin() + (a * b * 0.013).cos()) * 0.5
                + if i == j { (i % 4) as f64 } else { 0.0 }
        })
    }

    #[test]
    fn symmetric_eigen_diagonalises_larger_matrices() {
        for n in [1, 2, 5, 40, 130] {
            let a = symmetric(n);
            let e = symmetric_eigen(&a).unwrap();
            assert!(
                e.values.windows(2).all(|w| w[0] <= w[1]),
                "n = {n}: not sorted"
            );
            let scale = e.values.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1.0);
            let av = &a * &e.vectors;
            let vtv = e.vectors.transpose() * &e.vectors;
            for j in 0..n {
                for i in 0..n {
                    let r = av[(i, j)] - e.values[j] * e.vectors[(i, j)];
                    assert!(
                        r.abs() < 1e-12 * scale * n as f64,
                        "n = {n}: A v − λ v = {r}"
                    );
                    let id = (i == j) as u8 as f64;
                    assert!((vtv[(i, j)] - id).abs() < 1e-12 * n as f64, "n = {n}: VᵀV");
                }
            }
            // The trace is the sum of the eigenvalues.
            let trace: f64 = (0..n).map(|i| a[(i, i)]).sum();
            assert!((trace - e.values.iter().sum::<f64>()).abs() < 1e-10 * scale * n as f64);
        }
        // A repeated eigenvalue: 3 I plus a rank-one e eᵀ gives 3 (n − 1 times) and 3 + n.
        let n = 6;
        let a = Matrix::from_fn(n, n, |i, j| 1.0 + if i == j { 3.0 } else { 0.0 });
        let e = symmetric_eigen(&a).unwrap();
        for v in &e.values[..n - 1] {
            assert!((v - 3.0).abs() < 1e-12, "{:?}", e.values);
        }
        assert!((e.values[n - 1] - 9.0).abs() < 1e-12);
        // A Gram matrix of 120 points in 4 dimensions with noise at 10⁻¹²: four large
        // eigenvalues and 116 near 10⁻¹², the shape principal components meet (fewer distinct
        // poses than frames). The cluster must converge, not stall on rounding.
        let pts: Vec<[f64; 4]> = (0..120)
            .map(|i| std::array::from_fn(|k| ((i * (k + 3)) as f64 * 0.11).sin()))
            .collect();
        let g = Matrix::from_fn(120, 120, |i, j| {
            let d: f64 = (0..4).map(|k| pts[i][k] * pts[j][k]).sum();
            d + if i == j {
                1e-12
            } else {
                1e-6 * ((i * j) as f64).sin() * 1e-6
            }
        });
        let e = symmetric_eigen(&g).unwrap();
        let av = &g * &e.vectors;
        for j in 0..120 {
            for i in 0..120 {
                let r = av[(i, j)] - e.values[j] * e.vectors[(i, j)];
                assert!(r.abs() < 1e-12 * e.values[119], "cluster: A v − λ v = {r}");
            }
        }
        assert!(
            e.values[115].abs() < 1e-9 && e.values[116] > 1e-3,
            "{:?}",
            &e.values[110..]
        );
        // Entries whose squares underflow (10⁻¹⁷⁰) or overflow (10¹⁶⁰): the reflectors are
        // built from scaled columns, so the spectrum scales exactly with the matrix.
        let base = symmetric_eigen(&symmetric(7)).unwrap();
        for scale in [1e-170, 1e160] {
            let scaled = Matrix::from_fn(7, 7, |i, j| symmetric(7)[(i, j)] * scale);
            let e = symmetric_eigen(&scaled).unwrap();
            for (got, want) in e.values.iter().zip(&base.values) {
                assert!(
                    (got / scale - want).abs() < 1e-12 * 4.0,
                    "{scale:e}: {got:e} vs {want}"
                );
            }
        }
        // Only the lower half is read.
        let mut upper_junk = symmetric(5);
        upper_junk[(0, 3)] = 99.0;
        assert_eq!(
            symmetric_eigen(&upper_junk).unwrap().values,
            symmetric_eigen(&symmetric(5)).unwrap().values
        );
    }

    #[test]
    fn svd_of_tall_and_rank_deficient_matrices() {
        for (m, n, rank) in [(24, 12, 12), (24, 12, 11), (3, 3, 2), (3, 3, 0), (7, 1, 1)] {
            // Rank `rank`: a sum of `rank` outer products.
            let a = Matrix::from_fn(m, n, |i, j| {
                (0..rank)
                    .map(|k| ((i * 3 + k) as f64 * 0.7).sin() * ((j + 2 * k) as f64 * 1.3).cos())
                    .sum()
            });
            let d = svd(&a).unwrap();
            assert!(d.s.windows(2).all(|w| w[0] >= w[1]) && d.s.iter().all(|&x| x >= 0.0));
            let top = d.s[0].max(1e-300);
            for s in &d.s[rank..] {
                assert!(*s < 1e-12 * top.max(1.0), "{m}×{n} rank {rank}: {:?}", d.s);
            }
            let utu = d.u.transpose() * &d.u;
            let vtv = d.v.transpose() * &d.v;
            for i in 0..n {
                for j in 0..n {
                    let id = (i == j) as u8 as f64;
                    assert!((utu[(i, j)] - id).abs() < 1e-12, "{m}×{n} rank {rank}: UᵀU");
                    assert!((vtv[(i, j)] - id).abs() < 1e-12, "{m}×{n} rank {rank}: VᵀV");
                }
            }
            for i in 0..m {
                for j in 0..n {
                    let r: f64 = (0..n).map(|k| d.u[(i, k)] * d.s[k] * d.v[(j, k)]).sum();
                    assert!((r - a[(i, j)]).abs() < 1e-12 * top.max(1.0));
                }
            }
        }
    }

    #[test]
    fn svd_completes_spread_null_spaces_and_survives_extreme_scales() {
        // The centring matrix I − 11ᵀ/5: rank 4, its null vector (1, …, 1)/√5 spread over every
        // axis, so no coordinate axis keeps half its length after Gram–Schmidt.
        let c = Matrix::from_fn(5, 5, |i, j| (i == j) as u8 as f64 - 0.2);
        let d = svd(&c).unwrap();
        let utu = d.u.transpose() * &d.u;
        for i in 0..5 {
            for j in 0..5 {
                let id = (i == j) as u8 as f64;
                assert!((utu[(i, j)] - id).abs() < 1e-12, "UᵀU at ({i}, {j})");
            }
        }
        assert!(d.s[4] < 1e-12 && (d.s[0] - 1.0).abs() < 1e-12);
        // Entries whose squares overflow or underflow: the same singular values, scaled.
        let a = Matrix::from_fn(6, 3, |i, j| {
            ((i * 3 + j) as f64 * 0.9).sin() + (i == j) as u8 as f64
        });
        let base = svd(&a).unwrap().s;
        for scale in [1e160, 1e-170] {
            let scaled = Matrix::from_fn(6, 3, |i, j| a[(i, j)] * scale);
            let got = svd(&scaled).unwrap().s;
            for (g, b) in got.iter().zip(&base) {
                assert!(
                    (g / scale - b).abs() < 1e-12 * 4.0,
                    "{scale:e}: {got:?} vs {base:?}"
                );
            }
            let ys: Vec<f64> = (0..6).map(|i| i as f64 * scale).collect();
            assert!(
                least_squares(&scaled, &ys).is_ok(),
                "{scale:e}: called singular"
            );
        }
    }

    #[test]
    fn least_squares_matches_the_normal_equations() {
        // A tall, well-conditioned 30 × 5 problem: QR against the normal equations by Cholesky.
        let (m, n) = (30, 5);
        let a = Matrix::from_fn(m, n, |i, j| {
            ((i * 5 + j * 11) as f64 * 0.37).sin() + (i == j) as u8 as f64
        });
        let b: Vec<f64> = (0..m).map(|i| (i as f64 * 0.23).cos()).collect();
        let x = least_squares(&a, &b).unwrap();
        let ata = a.transpose() * &a;
        let atb = a.transpose().mul_vec(&b);
        let want = cholesky_solve(&ata, &atb).unwrap();
        for (g, w) in x.iter().zip(&want) {
            assert!((g - w).abs() < 1e-10, "{x:?} vs {want:?}");
        }
        let rank_deficient = Matrix::from_fn(4, 2, |i, _| i as f64);
        assert_eq!(
            least_squares(&rank_deficient, &[0.0, 1.0, 2.0, 3.0]).unwrap_err(),
            NumericsError::Singular {
                what: "least-squares",
                rows: 4,
                cols: 2,
                column: Some(1)
            }
        );
    }
}
