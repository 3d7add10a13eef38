//! Numerics shared by every crate: small dense solves, non-negative least squares,
//! Levenberg–Marquardt, and the decompositions larger problems need (LU, Cholesky, least
//! squares by QR, SVD, symmetric eigen, sparse Cholesky), all derma's own.
//!
//! The model matcher's systems are tiny (3–12 unknowns, solved millions of times), where the
//! hand-written elimination of [`dense::solve`] is fastest (BENCHMARKS.md, "Numerics"). The
//! rest are textbook algorithms ([`dense`], [`sparse`]) run on one thread, so results never
//! depend on the thread count; they replaced a linear-algebra library whose build cost a new
//! user a quarter of the first build (BENCHMARKS.md, "first build").

pub mod bessel;
pub mod dense;
pub mod fastmath;
pub mod lanes;
pub mod levenberg_marquardt;
pub mod nnls;
pub mod quadrature;
pub mod robust;
pub mod sparse;

pub use dense::{solve, Eigen, Matrix, Svd};
pub use levenberg_marquardt::{levenberg_marquardt, DenseSolver, LmOptions, ResidualFn};
pub use nnls::nnls_normal;
pub use quadrature::simpson;
pub use sparse::{SparseCholesky, SparsePattern};

/// Where a singular matrix showed it, for [`NumericsError::Singular`]'s message.
fn at_column(column: Option<usize>) -> String {
    match column {
        Some(c) => format!(" (column {c} depends on those before it)"),
        None => ": the solution is not finite".into(),
    }
}

/// Why a decomposition or solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NumericsError {
    /// The matrix is singular (or numerically so).
    #[error("the {rows} × {cols} {what} matrix is singular{}", at_column(*.column))]
    Singular {
        /// Which matrix.
        what: &'static str,
        /// Its rows.
        rows: usize,
        /// Its columns.
        cols: usize,
        /// The column found dependent on those before it (`None`: the solution came out not
        /// finite).
        column: Option<usize>,
    },
    /// A Cholesky factorisation met a non-positive pivot.
    #[error("the {n} × {n} {what} matrix is not positive definite: the pivot of column {column} is {pivot:e}")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
        /// Its order.
        n: usize,
        /// The column (of the matrix as given) whose pivot is not positive.
        column: usize,
        /// That pivot.
        pivot: f64,
    },
    /// An iterative decomposition (SVD, eigen) did not converge.
    #[error("the {what} of a {rows} × {cols} matrix did not converge in {iterations} iterations")]
    NoConvergence {
        /// Which decomposition.
        what: &'static str,
        /// The matrix's rows.
        rows: usize,
        /// Its columns.
        cols: usize,
        /// The iterations (Jacobi sweeps, QL steps) it took before giving up.
        iterations: usize,
    },
    /// Operands whose sizes do not fit together.
    #[error("{what}: {detail}")]
    Shape {
        /// Which operation.
        what: &'static str,
        /// The sizes found.
        detail: String,
    },
}
