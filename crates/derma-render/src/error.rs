//! The errors of the render crate: texture sets, meshes and scenes that cannot be used, each
//! naming the file or value and what was expected, and GPU failures.

/// An error of `derma-render`.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Input from the core (files, images, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// The GPU could not be used.
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
}

/// Results of this crate.
pub type Result<T, E = RenderError> = std::result::Result<T, E>;
