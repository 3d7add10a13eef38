//! The errors of the eyes crate: tracked data, models and images that cannot be used, each
//! naming the file, field or value and what was expected.

use std::path::PathBuf;

/// An error of `derma-eyes`.
#[derive(Debug, thiserror::Error)]
pub enum EyesError {
    /// Input from the core (files, images, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A tracked-data file that does not parse or says something impossible.
    #[error("tracked data {path}: {detail}")]
    Tracked {
        /// The file.
        path: PathBuf,
        /// What is wrong and what was expected.
        detail: String,
    },
    /// A model file that does not parse or does not fit the data it is used with.
    #[error("model {path}: {detail}")]
    Model {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// A numerical failure.
    #[error(transparent)]
    Numerics(#[from] derma_core::numerics::NumericsError),
    /// The GPU could not be used.
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
}

/// Results of this crate.
pub type Result<T, E = EyesError> = std::result::Result<T, E>;

impl From<derma_head::fit::store::StoreError> for EyesError {
    fn from(e: derma_head::fit::store::StoreError) -> Self {
        let derma_head::fit::store::StoreError::File { path, detail } = e;
        derma_core::CoreError::Format {
            path,
            message: detail,
        }
        .into()
    }
}
