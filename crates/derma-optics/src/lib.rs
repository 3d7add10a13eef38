//! Light in layered skin.
//!
//! The skin optics of derma: chromophore spectra ([`chromophore`]), the BioSpec four-layer
//! specimen built from bio parameters ([`specimen`]), a Monte Carlo photon transport that follows
//! thesis §4.4–4.5 ([`transport`]) on the CPU ([`cpu`]) and the GPU (`gpu`, the `gpu` feature), its tallies
//! ([`tally`]: sampled BRDF, spectrum, radial profile, absorption per layer and chromophore),
//! and the precompute grid over bio parameters ([`precompute`]).
//!
//! Data flow: a [`BioTexel`] → [`specimen::skin_stacks`] (a [`Stack`] per wavelength) →
//! [`simulate::simulate_skin`] on a [`Device`] ([`backend::run_on`]: [`cpu::run_cpu`] or
//! `gpu::run_gpu`, the same random stream per photon) → a [`Tally`] → a
//! [`simulate::SkinResult`] (spectrum, colour, BRDF, profile; [`plots`] draws them). Over a grid:
//! [`precompute::run_shard`] per shard → [`precompute::merge`] → a `.dtab` for derma-shading.

#![warn(missing_docs)]

pub mod backend;
pub mod bio;
pub mod chromophore;
pub mod cpu;
pub mod error;
pub mod fresnel;
pub mod furnace;
#[cfg(feature = "gpu")]
pub mod gpu;
mod hemoglobin_table;
pub mod layer;
pub mod microfacet;
pub mod microsurface;
pub mod photon_rng;
pub mod plots;
pub mod precompute;
pub mod run;
pub mod simulate;
pub mod slab;
pub mod specimen;
pub mod surface_reflection;
pub mod tally;
pub mod transport;
pub mod transport_lanes;
pub mod yellow_pigments;

pub use bio::BioTexel;
pub use derma_core::gpu::Device;
pub use error::{OpticsError, Result};
pub use layer::{Bottom, Layer, Stack, Surface};
pub use run::Run;
pub use simulate::{simulate_skin, SkinResult, SkinSimConfig};
pub use tally::Tally;

/// Most layers a stack may have (the GPU kernel's fixed arrays).
pub const MAX_LAYERS: usize = 8;
