//! The skin surface's specular lobe for renderers: glTF's GGX (roughness, F0) fitted, as thesis
//! §4.6–4.7 fits render models, to the light derma-optics' rough surface reflects without entering.
//!
//! Why the surface alone: the base colour (the table's `albedo`) already holds all the light that
//! entered the skin and came back, so the specular map must hold the rest, the surface's own
//! reflection. Fitting GGX to the whole simulated BRDF instead counts subsurface light twice and
//! drives the fit to its bounds (F0 at 0.2 on 731 of the committed table's 1008 entries, kd 0 in
//! green and blue on dark skin: docs/matching.md).

use crate::appearance::SurfaceSpecular;
use crate::brdf_fit::{fit_brdf, FitGeometry, FitOptions, Weighting};
use crate::error::Result;
use crate::ggx::GltfGgx;
use derma_core::progress::Progress;
use derma_optics::specimen::SurfaceModel;
use derma_optics::surface_reflection::surface_reflection;
use derma_optics::tally::BrdfBins;
use serde::{Deserialize, Serialize};

/// Photons of the surface simulation: 4·10⁶ leave ~1.3·10⁵ reflected over the 972 bins of the
/// default grid, and fits from different seeds agree to 0.002 in roughness (test below).
pub const SURFACE_PHOTONS: u64 = 4_000_000;

/// The match table's metadata key of the fit.
pub const META_KEY: &str = "surface_specular";

/// A fitted surface lobe, as the match table's metadata keeps it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceFit {
    /// The surface model simulated (the precompute grid's).
    pub surface: SurfaceModel,
    /// glTF perceptual roughness (α = r²).
    pub roughness: f64,
    /// Normal-incidence reflectance of the Schlick term (KHR_materials_specular: 0.04 ×
    /// specularColorFactor).
    pub f0: f64,
    /// Mean diffuse weight the fit gave (kd of `(1 − F) kd/π`): the surface's multiply scattered
    /// light that a single lobe does not shape; renderers leave it out (it is under 1 %).
    pub kd: f64,
    /// Relative weighted RMS of the fit ([`crate::brdf_fit::BrdfFit::relative_rms`]).
    pub relative_rms: f64,
    /// The surface's simulated albedo under diffuse light.
    pub albedo: f64,
    /// Photons simulated.
    pub photons: u64,
    /// Their seed.
    pub seed: u64,
}

impl SurfaceFit {
    /// What renderers take.
    pub fn specular(&self) -> SurfaceSpecular {
        SurfaceSpecular {
            roughness: self.roughness as f32,
            f0: self.f0 as f32,
        }
    }
}

/// Simulates the reflection of `surface` into `bins` and fits glTF's GGX to it with the match
/// table's `weighting` and zenith cutoff.
pub fn fit_surface(
    surface: SurfaceModel,
    bins: BrdfBins,
    weighting: Weighting,
    max_zenith_deg: f64,
    seed: u64,
    progress: &dyn Progress,
) -> Result<SurfaceFit> {
    let r = surface_reflection(surface, bins, SURFACE_PHOTONS, seed, progress)?;
    let data: Vec<[f64; 3]> = r.brdf.iter().map(|&v| [v; 3]).collect();
    let geom = FitGeometry::with_cutoff(bins, weighting, max_zenith_deg);
    let f = fit_brdf(&GltfGgx, &geom, &data, &FitOptions::default(), 0);
    Ok(SurfaceFit {
        surface,
        roughness: f.params[3],
        f0: f.params[4],
        kd: (f.params[0] + f.params[1] + f.params[2]) / 3.0,
        relative_rms: f.relative_rms,
        albedo: r.albedo,
        photons: SURFACE_PHOTONS,
        seed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const BINS: BrdfBins = derma_optics::simulate::DEFAULT_BRDF_BINS;

    #[test]
    fn the_fit_finds_the_optics_own_surface() {
        // The Monte Carlo surface is a GGX microsurface of α = 0.75 (glTF roughness √0.75 =
        // 0.866) with the stratum corneum's index 1.55 (F0 = (0.55/2.55)² = 0.0465): glTF's
        // GGX is the same lobe in single scattering with Schlick's Fresnel, so the fit must land
        // near both; the walk's multiple scattering and Schlick's shape move them a little.
        let quiet = &derma_core::progress::Silent;
        let f = fit_surface(SurfaceModel::Smith, BINS, Weighting::Cosine, 90.0, 1, quiet).unwrap();
        println!("{f:?}");
        assert!((f.roughness - 0.75f64.sqrt()).abs() < 0.05, "{f:?}");
        assert!((f.f0 - 0.0465).abs() < 0.012, "{f:?}");
        assert!(f.kd < 0.01 && f.relative_rms < 0.15, "{f:?}");
        // Another seed: the photon noise left in the parameters.
        let g = fit_surface(SurfaceModel::Smith, BINS, Weighting::Cosine, 90.0, 2, quiet).unwrap();
        assert!((f.roughness - g.roughness).abs() < 0.002, "{f:?} {g:?}");
        assert!((f.f0 - g.f0).abs() < 0.001, "{f:?} {g:?}");
    }
}
