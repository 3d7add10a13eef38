//! The batch's one error type: what its files, the main job and the exporter report, wrapped
//! (ARCHITECTURE.md, "one error style").

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
    /// The set's GLB.
    #[error(transparent)]
    Export(#[from] derma_export::ExportError),
}

/// The batch's result type.
pub type Result<T> = std::result::Result<T, BatchError>;
