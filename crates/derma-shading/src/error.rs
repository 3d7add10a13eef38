//! Errors of the shading crate.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum ShadingError {
    #[error("{path}: {message}")]
    Table { path: PathBuf, message: String },
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    #[error(transparent)]
    Optics(#[from] derma_optics::OpticsError),
}

pub type Result<T> = std::result::Result<T, ShadingError>;
