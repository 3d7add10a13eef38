//! Procedural biological skin textures (the "feature phase" of Van den Berg's thesis, ch. 4.8
//! and 5): scatter biological features over a surface from an artist's probability fields,
//! paint the biological parameters per texel, and convert them into a renderer's texture set.
//!
//! ```no_run
//! use derma_skin::{config::SkinConfig, generate::{generate, Inputs}};
//! let cfg = SkinConfig { size: 512, ..SkinConfig::default() };
//! let result = generate(&cfg, &Inputs::default(), &derma_skin::generate::NoProgress).unwrap();
//! println!("{} features", result.features.total());
//! ```
//!
//! Data flow: [`surface`] (texel → point on the surface) → [`field`] (probability and vector
//! fields) → [`scatter`] (feature centres by density per unit area) → [`features`] (each
//! biological feature, thesis §5.3) in a [`index::Grid`] → [`paint`] (bio maps, by priority)
//! → [`texture_set`] (render maps through `derma_shading::Appearance`) → files.

pub mod config;
pub mod detail;
pub mod features;
pub mod field;
pub mod generate;
pub mod index;
pub mod noise;
pub mod normal_map;
pub mod paint;
pub mod placement;
pub mod preview;
pub mod scatter;
pub mod surface;
pub mod template;
pub mod texture_set;

/// Errors of the skin pipeline, each naming the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum SkinError {
    #[error("config '{file}': {detail}")]
    Config { file: String, detail: String },
    #[error("field '{name}': {detail}")]
    Field { name: String, detail: String },
    #[error("mesh '{path}': {detail}")]
    Mesh { path: String, detail: String },
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    #[error("output of {width}x{height} texels needs about {need_gib:.1} GiB of memory; {have_gib:.1} GiB are available: choose a smaller --size")]
    TooLarge {
        width: usize,
        height: usize,
        need_gib: f64,
        have_gib: f64,
    },
}

pub type Result<T> = std::result::Result<T, SkinError>;
