//! The errors of the photo crate: bad correspondences, cameras, meshes and images, each naming
//! the file, field or value and what was expected.

use std::path::PathBuf;

/// An error of `derma-photo`.
#[derive(Debug, thiserror::Error)]
pub enum PhotoError {
    /// Input from the core (files, images, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// A correspondence file that does not parse or says something impossible.
    #[error("correspondences {path}: {detail}")]
    Correspondences {
        /// The file.
        path: PathBuf,
        /// What is wrong and what was expected.
        detail: String,
    },
    /// Camera resection that cannot be done from the points given.
    #[error("camera of photo '{photo}': {detail}")]
    Camera {
        /// The photo.
        photo: String,
        /// What is wrong.
        detail: String,
    },
    /// A mesh that the unwrap or the baking cannot take.
    #[error("mesh: {0}")]
    Mesh(String),
    /// A value derma cannot use (derma-core's vocabulary: what, expected, got).
    #[error(transparent)]
    Invalid(#[from] derma_core::Invalid),
    /// A result `--strict` refuses: what the bake would have warned about.
    #[error("refused (strict): {0}")]
    Strict(String),
    /// A numerical failure.
    #[error(transparent)]
    Numerics(#[from] derma_core::numerics::NumericsError),
}

/// Results of this crate.
pub type Result<T, E = PhotoError> = std::result::Result<T, E>;
