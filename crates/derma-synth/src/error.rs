//! Typed errors of derma-synth, naming the texture, exemplar or value at fault and what was
//! expected.

/// Errors of derma-synth.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// From derma-core (image files).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// The GPU search could not run.
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
    /// A value out of range or inconsistent.
    #[error("invalid {what}: {detail}")]
    Invalid {
        /// Which value.
        what: String,
        /// What is wrong and what was expected.
        detail: String,
    },
}

/// Result type of derma-synth.
pub type Result<T> = std::result::Result<T, SynthError>;

/// Shorthand for [`SynthError::Invalid`].
pub fn invalid(what: impl Into<String>, detail: impl Into<String>) -> SynthError {
    SynthError::Invalid {
        what: what.into(),
        detail: detail.into(),
    }
}
