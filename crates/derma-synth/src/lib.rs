//! derma-synth: exemplar-based synthesis of skin detail, after Shen et al., "GPU-based skin
//! texture synthesis for digital human model" (`../shared/seeds/gpu-skin-texture-synthesis-shen.txt`).
//!
//! [`synthesize()`] grows a texture of any size from one or more exemplars: white noise, a patch
//! pass ([`patch_pass`]), optimisation passes with a two-band E-step ([`optimize`]), then a texel-level
//! coherent [`correction`]. Every
//! best-match search is the integer search of [`search`], over each query's k-coherence
//! candidates ([`coherence`]; or every exemplar window), run by a [`Matcher`]: the CPU
//! one ([`CpuMatcher`], rayon) or, with the `gpu` feature, the GPU one (`gpu::GpuMatcher`, WGSL), which give identical
//! answers, so a seed gives the same texture on either. [`quality`] holds the metrics that
//! judge the result without neural networks.

#![warn(missing_docs)]

mod bands;
pub mod canvas;
mod clash_rounds;
pub mod coherence;
pub mod correction;
mod e_step;
pub mod error;
pub mod exemplar;
pub mod files;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "gpu")]
mod gpu_correction;
#[cfg(feature = "gpu")]
pub mod gpu_e_step;
#[cfg(feature = "gpu")]
mod gpu_matcher;
#[cfg(feature = "gpu")]
mod gpu_optimize;
#[cfg(feature = "gpu")]
mod gpu_patch_pass;
pub mod guide;
pub mod job;
mod key;
pub mod matcher;
pub mod optimize;
mod pass_context;
pub mod patch_pass;
pub mod quality;
#[cfg(feature = "gpu")]
mod resident;
pub mod search;
pub mod settle;
pub mod synthesize;
pub mod synthesizer;
pub mod texture;

pub use error::{Result, SynthError};
pub use exemplar::{Exemplar, ExemplarSet, Quantizer};
#[cfg(feature = "gpu")]
pub use gpu::GpuMatcher;
pub use guide::Guide;
pub use matcher::{CpuMatcher, Matcher, PatchPlan};
pub use search::{Match, Plane, Query, Search, Tolerance, WindowQuery, MAX_GUESSES};
pub use synthesize::{synthesize, SynthOptions, Synthesis};
pub use synthesizer::{matcher_for, Synthesizer};
pub use texture::Texture;
