//! Typed errors of derma-rig: each names the map, target, weight or file at fault and what was
//! expected.

use std::path::PathBuf;

/// Errors of derma-rig.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// From derma-core (image files).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// From derma-shading (the skin-colour LUT).
    #[error(transparent)]
    Shading(#[from] derma_shading::ShadingError),
    /// A map whose size differs from the rig's.
    #[error(
        "map '{what}' is {got_w}×{got_h}; expected {want_w}×{want_h} (the neutral map's size)"
    )]
    Size {
        /// Which map.
        what: String,
        /// Its width.
        got_w: usize,
        /// Its height.
        got_h: usize,
        /// The rig's width.
        want_w: usize,
        /// The rig's height.
        want_h: usize,
    },
    /// A fitted head directory that could not be read.
    #[error(transparent)]
    Head(#[from] derma_head::fit::store::StoreError),
    /// The GPU evaluation could not run.
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
    /// A file with bad content.
    #[error("'{path}': {detail}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        detail: String,
    },
}

/// Result type of derma-rig.
pub type Result<T> = std::result::Result<T, RigError>;

/// Shorthand for [`RigError::Invalid`].
pub fn invalid(what: impl Into<String>, detail: impl Into<String>) -> RigError {
    RigError::Invalid {
        what: what.into(),
        detail: detail.into(),
    }
}
