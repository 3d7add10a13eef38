//! Procedural biological skin textures (the "feature phase" of Van den Berg's thesis, ch. 4.8
//! and 5): scatter biological features over a surface from an artist's probability fields,
//! paint the biological parameters per texel, and convert them into a renderer's texture set.
//!
//! ```no_run
//! # fn main() -> derma_skin::Result<()> {
//! use derma_skin::{SkinConfig, SkinGenerator};
//! let set = SkinGenerator::new(SkinConfig { size: 512, ..SkinConfig::default() }).run()?;
//! println!("{} features", set.features.total());
//! set.write(std::path::Path::new("out"), &derma_core::progress::Silent)?;
//! # Ok(())
//! # }
//! ```
//!
//! Data flow ([`SkinGenerator`]): [`surface`] (texel → point on the surface) → [`field`]
//! (probability and vector fields) → [`scatter`] (feature centres by density per unit area) →
//! [`features`] (each biological feature, thesis §5.3), one entry per kind in [`kinds`], placed
//! and indexed by [`placement`] → [`paint`] (bio maps, kinds in table order) → [`detail`]
//! (optional exemplar micro-detail) → [`texture_set`] (render maps through
//! `derma_shading::Appearance`) → [`TextureSet::write`]: the files of [`outputs`], with
//! [`report`]'s manifest.json and report.json.

#![warn(missing_docs)]

pub mod albedo_compare;
pub mod builtin_head;
pub mod calibration;
pub mod color_stats;
pub mod config;
pub mod detail;
pub mod feature_set;
pub mod features;
pub mod field;
pub mod generate;
pub mod index;
pub mod kinds;
pub mod manifest;
pub mod measured;
pub mod mottling;
pub mod noise;
pub mod normal_map;
pub mod outputs;
pub mod paint;
pub mod placement;
pub mod preview;
pub mod regional;
pub mod report;
pub mod scatter;
mod stream;
pub mod surface;
pub mod texture_set;

/// Errors of the skin pipeline, each naming the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum SkinError {
    /// A config as a whole is invalid (TOML syntax, values out of range).
    #[error("{origin}: {detail}")]
    Config {
        /// Where the config came from: "config 'FILE'", or "the options" given in code or flags.
        origin: String,
        /// What is wrong, naming the keys.
        detail: String,
    },
    /// One config key has a bad value.
    #[error("config key '{key}': {detail}")]
    Key {
        /// The key, e.g. "surface.unit".
        key: String,
        /// What is wrong and what was expected.
        detail: String,
    },
    /// An input file or directory is missing or unusable.
    #[error("'{path}': {detail}")]
    Input {
        /// The file or directory.
        path: std::path::PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// A field is missing, malformed or badly defined.
    #[error("field '{name}': {detail}")]
    Field {
        /// The field's name.
        name: String,
        /// What is wrong.
        detail: String,
    },
    /// A mesh cannot be painted.
    #[error("mesh '{path}': {detail}")]
    Mesh {
        /// The mesh file.
        path: String,
        /// What is wrong with it.
        detail: String,
    },
    /// From derma-core (files, meshes).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// The GPU renderer failed (the preview's shaded views).
    #[error(transparent)]
    Render(#[from] derma_render::RenderError),
    /// The GPU was chosen and cannot be used (a build without it, or no adapter).
    #[error(transparent)]
    Gpu(#[from] derma_core::gpu::GpuError),
    /// The texture set would not fit in memory.
    #[error("output of {width}x{height} texels needs about {need_gib:.1} GiB of memory; {have_gib:.1} GiB are available: choose a smaller size")]
    TooLarge {
        /// Width asked for.
        width: usize,
        /// Height asked for.
        height: usize,
        /// Memory it needs, GiB.
        need_gib: f64,
        /// Memory available, GiB.
        have_gib: f64,
    },
}

impl SkinError {
    /// A derma-head error (its only fallible parts write files) as a skin error.
    pub fn from_head(e: derma_head::HeadError) -> Self {
        match e {
            derma_head::HeadError::Core(c) => SkinError::Core(c),
        }
    }
}

/// Result type of derma-skin.
pub type Result<T> = std::result::Result<T, SkinError>;

pub use config::SkinConfig;
pub use generate::{AppearanceChoice, SkinGenerator, TextureSet, Written};

impl From<derma_head::fit::store::StoreError> for SkinError {
    fn from(e: derma_head::fit::store::StoreError) -> Self {
        let derma_head::fit::store::StoreError::File { path, detail } = e;
        SkinError::Input { path, detail }
    }
}
