//! Typed errors of the optics crate, naming the file, key or value at fault and what was
//! expected (a layer, a grid axis, a shard, a table).

use std::path::PathBuf;

/// Errors of the optics, each naming the value or file at fault.
#[derive(Debug, thiserror::Error)]
pub enum OpticsError {
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// A file that could not be read or written.
    #[error("{path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's reason.
        #[source]
        source: std::io::Error,
    },
    /// From derma-core (atomic writes, tables).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// The GPU backend could not run.
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
}

/// Result type of derma-optics.
pub type Result<T> = std::result::Result<T, OpticsError>;
