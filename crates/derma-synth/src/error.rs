//! Typed errors of derma-synth, naming the texture or value at fault and what was expected.

#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
    #[error("invalid {what}: {detail}")]
    Invalid { what: String, detail: String },
}

pub type Result<T> = std::result::Result<T, SynthError>;

/// Shorthand for [`SynthError::Invalid`].
pub fn invalid(what: impl Into<String>, detail: impl Into<String>) -> SynthError {
    SynthError::Invalid {
        what: what.into(),
        detail: detail.into(),
    }
}
