//! Typed errors of derma-rig: each names the map, target, weight or file at fault and what was
//! expected.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    #[error(transparent)]
    Shading(#[from] derma_shading::ShadingError),
    #[error(
        "map '{what}' is {got_w}×{got_h}; expected {want_w}×{want_h} (the neutral map's size)"
    )]
    Size {
        what: String,
        got_w: usize,
        got_h: usize,
        want_w: usize,
        want_h: usize,
    },
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
    #[error("invalid {what}: {detail}")]
    Invalid { what: String, detail: String },
    #[error("'{path}': {detail}")]
    File { path: PathBuf, detail: String },
}

pub type Result<T> = std::result::Result<T, RigError>;

/// Shorthand for [`RigError::Invalid`].
pub fn invalid(what: impl Into<String>, detail: impl Into<String>) -> RigError {
    RigError::Invalid {
        what: what.into(),
        detail: detail.into(),
    }
}
