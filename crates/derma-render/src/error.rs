//! The errors of the render crate: texture sets, meshes and scenes that cannot be used, each
//! naming the file or value and what was expected, and GPU failures.

use std::path::PathBuf;

/// An error of `derma-render`.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Input from the core (files, images, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A texture set, mesh or option that cannot be used.
    #[error("{path}: {detail}")]
    Input {
        /// The file or directory.
        path: PathBuf,
        /// What is wrong and what was expected.
        detail: String,
    },
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// The GPU could not be used.
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
}

/// Results of this crate.
pub type Result<T, E = RenderError> = std::result::Result<T, E>;
