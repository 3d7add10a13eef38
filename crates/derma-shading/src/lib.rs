//! From biology to render parameters.
//!
//! The [`Appearance`] trait turns the bio parameters derma paints per texel (melanin, blood,
//! oxygenation, layer thicknesses…) into what a renderer takes. Its first implementation,
//! [`SpectralKubelkaMunk`], computes a layered Kubelka–Munk diffuse reflectance per wavelength
//! from published chromophore spectra ([`chromophore`]) and integrates it with the CIE 1931
//! observer under D65 to linear sRGB. A lookup table with simplex interpolation
//! ([`lut`]) makes it fast enough for 16-megapixel texture sets.

#![warn(missing_docs)]

pub mod annealing;
pub mod appearance;
pub mod ashikhmin_shirley;
pub mod brdf_fit;
pub mod burley;
pub mod error;
/// Chromophore spectra and Fresnel reflectance live in the optics crate; re-exported here.
pub use derma_optics::{chromophore, fresnel};
pub mod ggx;
pub mod kelemen;
pub mod kubelka_munk;
pub mod lut;
pub mod match_report;
pub mod match_table;
pub mod microfacet_terms;
pub mod model_kind;
pub mod render_model;
pub mod skin_color_lut;
pub mod skin_dual_lobe;
pub mod spectral_km;
pub mod sum_of_gaussians;
pub mod table_appearance;

pub use appearance::{Appearance, BioTexel, Subsurface};
pub use error::{Result, ShadingError};
pub use match_table::MatchTable;
pub use spectral_km::{SkinLayers, SpectralKubelkaMunk};
pub use table_appearance::TableAppearance;
