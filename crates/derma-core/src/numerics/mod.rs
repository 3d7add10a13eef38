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
pub mod robust;
pub mod sparse;

pub use dense::{solve, Eigen, Matrix, Svd};
pub use levenberg_marquardt::{levenberg_marquardt, DenseSolver, LmOptions, ResidualFn};
pub use nnls::nnls_normal;
pub use sparse::{SparseCholesky, SparsePattern};

/// Why a decomposition or solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NumericsError {
    /// The matrix is singular (or numerically so).
    #[error("the {what} matrix is singular")]
    Singular {
        /// Which matrix.
        what: &'static str,
    },
    /// A Cholesky factorisation met a non-positive pivot.
    #[error("the {what} matrix is not positive definite")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
    },
    /// An iterative decomposition (SVD, eigen) did not converge.
    #[error("the {what} did not converge")]
    NoConvergence {
        /// Which decomposition.
        what: &'static str,
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
