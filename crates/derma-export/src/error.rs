//! The errors of the export crate: texture sets, meshes, rigs and options that cannot be used,
//! each naming the file or value and what was expected, and the viewer's server failing.

/// An error of `derma-export`.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Input from the core (files, images, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// The renderer failed (GPU, scene, maps).
    #[error(transparent)]
    Render(#[from] derma_render::RenderError),
    /// The GPU could not be used.
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
    /// A rig that cannot be loaded or evaluated.
    #[error(transparent)]
    Rig(#[from] derma_rig::RigError),
    /// The texture set could not be made or written.
    #[error(transparent)]
    Skin(#[from] derma_skin::SkinError),
    /// An eye texture that cannot be read.
    #[error(transparent)]
    Eyes(#[from] derma_eyes::EyesError),
    /// The viewer's server failed.
    #[error("serving the viewer: {0}")]
    Serve(#[from] std::io::Error),
}

impl From<derma_head::fit::store::StoreError> for ExportError {
    fn from(e: derma_head::fit::store::StoreError) -> Self {
        let derma_head::fit::store::StoreError::File { path, detail } = e;
        derma_core::CoreError::Format {
            path,
            message: detail,
        }
        .into()
    }
}

/// Results of this crate.
pub type Result<T, E = ExportError> = std::result::Result<T, E>;
