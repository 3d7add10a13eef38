//! From biology to render parameters.
//!
//! The [`Appearance`] trait turns the bio parameters derma paints per texel (melanin, blood,
//! oxygenation, layer thicknesses…) into what a renderer takes. Its first implementation,
//! [`SpectralKubelkaMunk`], computes a layered Kubelka–Munk diffuse reflectance per wavelength
//! from published chromophore spectra ([`chromophore`]) and integrates it with the CIE 1931
//! observer under D65 to linear sRGB. A lookup table with simplex interpolation
//! ([`lut`]) makes it fast enough for 16-megapixel texture sets.

pub mod appearance;
/// Chromophore spectra and Fresnel reflectance live in the optics crate; re-exported here.
pub use derma_optics::{chromophore, fresnel};
pub mod kubelka_munk;
pub mod lut;
pub mod spectral_km;

pub use appearance::{Appearance, BioTexel};
pub use spectral_km::{SkinLayers, SpectralKubelkaMunk};
