//! Typed errors of the optics crate.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum OpticsError {
    #[error("invalid optical input: {0}")]
    Invalid(String),
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("{path}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
}

pub type Result<T> = std::result::Result<T, OpticsError>;
