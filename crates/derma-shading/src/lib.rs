//! From biology to render parameters: what colour and subsurface scattering the skin that
//! derma paints has, and how render BRDF models match the optics' simulated skin.
//!
//! - [`Appearance`]: bio parameters ([`BioTexel`]) → base colour and optional [`Subsurface`].
//!   [`TableAppearance`] (the default) interpolates a [`MatchTable`] fitted to derma's Monte Carlo
//!   skin; [`SpectralKubelkaMunk`] is the analytic alternative (chromophore spectra, layered
//!   Kubelka–Munk, CIE 1931 under D65, served from a simplex [`lut`]).
//! - Model matching (thesis §4.6): a precompute table from derma-optics →
//!   [`match_table::fit_table`] fits every render BRDF model ([`model_kind`], one module each:
//!   [`ggx`], [`ashikhmin_shirley`], [`kelemen`], [`skin_dual_lobe`]; [`brdf_fit`] with
//!   [`annealing`] and derma-core's Levenberg–Marquardt) and the subsurface profiles
//!   ([`burley`], [`sum_of_gaussians`]) per entry → a match table `.dtab` (the committed one is
//!   `data/match-table.dtab`), with [`match_report`]'s residuals and plots.
//! - [`SkinColorLut`]: melanin × hemoglobin → colour (Jimenez et al. 2010), simulated with the
//!   same optics; the rig colours with it.
//! - [`hair`]: a hair fibre's colour from its eumelanin and pheomelanin (d'Eon et al. 2011,
//!   Chiang et al. 2016), for the strands derma-skin grows.

#![warn(missing_docs)]

pub mod annealing;
pub mod appearance;
pub mod ashikhmin_shirley;
pub mod brdf_fit;
pub mod burley;
pub mod error;
pub mod fit_job;
/// Chromophore spectra and Fresnel reflectance live in the optics crate; re-exported here.
pub use derma_optics::{chromophore, fresnel};
pub mod ggx;
pub mod hair;
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
pub mod surface_fit;
pub mod table_appearance;

pub use appearance::{Appearance, BioTexel, Subsurface, SurfaceSpecular};
pub use error::{Result, ShadingError};
pub use match_table::MatchTable;
pub use model_kind::ModelKind;
pub use skin_color_lut::{LutOptions, SkinColorLut};
pub use spectral_km::{SkinLayers, SpectralKubelkaMunk};
pub use table_appearance::TableAppearance;
