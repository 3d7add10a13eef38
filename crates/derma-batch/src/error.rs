//! The batch's one error type: what its files and the main job report, wrapped (an identity's
//! failed set is an `Invalid` naming the identity; ARCHITECTURE.md, "one error style").

/// Everything a batch reports.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// Files, images and formats (derma-core).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A value that cannot be used.
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// The main job.
    #[error(transparent)]
    Skin(#[from] derma_skin::SkinError),
}

/// The batch's result type.
pub type Result<T> = std::result::Result<T, BatchError>;
