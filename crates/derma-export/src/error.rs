//! The errors of the export crate: texture sets, meshes, rigs and options that cannot be used,
//! each naming the file or value and what was expected, and the viewer's server failing.

use std::path::PathBuf;

/// An error of `derma-export`.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Input from the core (files, images, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A texture set, mesh or option that cannot be used.
    #[error("{path}: {detail}")]
    Input {
        /// The file or directory.
        path: PathBuf,
        /// What is wrong and what was expected.
        detail: String,
    },
    /// Any other invalid value.
    #[error("{0}")]
    Invalid(String),
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

/// The head: the fitted one in `dir` (`derma head fit`), or the built-in one.
pub fn head(dir: Option<&std::path::Path>) -> Result<&'static derma_head::Head> {
    derma_head::fitted::or_builtin(dir).map_err(|e| ExportError::Input {
        path: dir.map(PathBuf::from).unwrap_or_default(),
        detail: e.to_string(),
    })
}

/// Results of this crate.
pub type Result<T, E = ExportError> = std::result::Result<T, E>;
