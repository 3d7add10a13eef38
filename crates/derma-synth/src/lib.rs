//! derma-synth: exemplar-based synthesis of skin detail, after Shen et al., "GPU-based skin
//! texture synthesis for digital human model" (`../shared/seeds/gpu-skin-texture-synthesis-shen.txt`).
//!
//! So far: the multi-channel texture type the synthesis works on ([`texture`]) and the quality
//! metrics that judge it without neural networks ([`quality`]): a patch-statistics distance,
//! a verbatim-copy ratio and a seam energy.

pub mod error;
pub mod quality;
pub mod texture;

pub use error::{Result, SynthError};
pub use texture::Texture;
