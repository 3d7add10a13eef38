//! Typed errors of derma-core: every variant names the file or value at fault and what was
//! expected, so that a user can fix the input without reading the code.

use std::path::PathBuf;

/// Errors raised by derma-core.
#[derive(Debug, thiserror::Error)]
pub enum CoreError {
    #[error("cannot read '{path}'")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot write '{path}'")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("'{path}' is not a readable image ({detail}); expected a PNG or OpenEXR file")]
    Image { path: PathBuf, detail: String },
    #[error("cannot encode '{path}': {detail}")]
    Encode { path: PathBuf, detail: String },
    #[error("'{path}' is not a usable mesh: {detail}")]
    Mesh { path: PathBuf, detail: String },
    #[error("'{path}': {message}")]
    Format { path: PathBuf, message: String },
    #[error("invalid value for {what}: {detail}")]
    Invalid { what: String, detail: String },
}

/// Result type of derma-core.
pub type Result<T> = std::result::Result<T, CoreError>;
