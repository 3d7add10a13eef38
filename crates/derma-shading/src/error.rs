//! Typed errors of the shading crate, naming the table, fit or value at fault and what was
//! expected.

/// Errors of the shading crate, each naming the table or value at fault.
#[derive(Debug, thiserror::Error)]
pub enum ShadingError {
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// From derma-core (files, tables).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// From the optics (simulations for the LUT).
    #[error(transparent)]
    Optics(#[from] derma_optics::OpticsError),
}

/// Result type of derma-shading.
pub type Result<T> = std::result::Result<T, ShadingError>;
