//! Typed errors of derma-core: every variant names the file or value at fault and what was
//! expected, so that a user can fix the input without reading the code.

use std::path::PathBuf;

/// Errors raised by derma-core.
#[derive(Debug, thiserror::Error)]
pub enum CoreError {
    /// A file could not be read.
    #[error("cannot read '{path}'")]
    Read {
        /// The file.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
    /// A file or directory could not be written.
    #[error("cannot write '{path}'")]
    Write {
        /// The file or directory.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
    /// A file is not an image derma reads.
    #[error("'{path}' is not a readable image ({detail}); expected a PNG or OpenEXR file")]
    Image {
        /// The file.
        path: PathBuf,
        /// What the decoder found.
        detail: String,
    },
    /// An image or a JSON file could not be encoded.
    #[error("cannot encode '{path}': {detail}")]
    Encode {
        /// The file being written.
        path: PathBuf,
        /// What went wrong.
        detail: String,
    },
    /// A mesh file cannot be used.
    #[error("'{path}' is not a usable mesh: {detail}")]
    Mesh {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        detail: String,
    },
    /// A derma file (a table, say) is malformed.
    #[error("'{path}': {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// A value is out of its range or inconsistent.
    #[error(transparent)]
    Invalid(#[from] Invalid),
}

/// A value derma cannot use — the one vocabulary every crate's errors wrap (as their
/// `Invalid` variant): what the value is, named as the user knows it (a flag, config key,
/// Python argument, field, file or setting), what was expected and what was given. Front ends
/// that know a flag's name for a library's setting say so in `what`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{what}: expected {expected}, got {got}")]
pub struct Invalid {
    /// Which value (a flag, key, argument, field, file or setting).
    pub what: String,
    /// What would have been accepted.
    pub expected: String,
    /// What was given (or found).
    pub got: String,
}

impl Invalid {
    /// `what` expected `expected`, got `got`.
    pub fn new(
        what: impl Into<String>,
        expected: impl Into<String>,
        got: impl std::fmt::Display,
    ) -> Self {
        Self {
            what: what.into(),
            expected: expected.into(),
            got: got.to_string(),
        }
    }
}

/// Result type of derma-core.
pub type Result<T> = std::result::Result<T, CoreError>;
