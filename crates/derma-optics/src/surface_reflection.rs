//! The skin surface's own reflection: the light the rough stratum-corneum interface sends back
//! without entering (thesis §4.5.1's surface, BioSpec's folds), as a sampled BRDF for renderers'
//! specular lobe. The same transport runs over a specimen that absorbs all light that enters.

use crate::cpu::run_cpu;
use crate::error::Result;
use crate::layer::{Bottom, Layer, Stack};
use crate::run::Run;
use crate::specimen::{SurfaceModel, LAYER_INDEX};
use crate::tally::{BrdfBins, R_SPECULAR};
use derma_core::progress::Progress;

/// Absorption of the stand-in tissue, per mm: the first interaction absorbs the photon outright
/// (μa/μt = 1), and 1 mm of it lets e⁻¹⁰⁰⁰ through.
const BLACK_MUA_PER_MM: f64 = 1000.0;

/// The skin's surface over black tissue of the stratum corneum's index (`specimen.rs`): what
/// comes back is the surface's reflection alone.
pub fn surface_stack(surface: SurfaceModel) -> Stack {
    Stack {
        layers: vec![Layer::plain(
            1.0,
            BLACK_MUA_PER_MM,
            0.0,
            0.0,
            LAYER_INDEX[0],
        )],
        n_above: 1.0,
        bottom: Bottom::Lambertian { albedo: 0.0 },
        surface: surface.surface(),
    }
}

/// The surface's sampled BRDF.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceReflection {
    /// The bins.
    pub bins: BrdfBins,
    /// BRDF per bin (sr⁻¹, wavelength-independent: the indices do not vary with it here), in
    /// [`BrdfBins::index`] order.
    pub brdf: Vec<f64>,
    /// Reflected weight per photon under cosine-weighted incidence: the surface's hemispherical
    /// albedo under diffuse light.
    pub albedo: f64,
}

/// Runs `photons` photons of cosine-weighted incidence (thesis §4.5.2) onto the skin's surface
/// `surface` over black tissue and bins what the surface reflects.
pub fn surface_reflection(
    surface: SurfaceModel,
    bins: BrdfBins,
    photons: u64,
    seed: u64,
    progress: &dyn Progress,
) -> Result<SurfaceReflection> {
    let run = Run::brdf(surface_stack(surface), photons, seed, bins);
    let t = run_cpu(&run, progress)?;
    let brdf = (0..bins.len())
        .map(|k| {
            let ti = k / (bins.theta_out * bins.phi);
            let to = (k / bins.phi) % bins.theta_out;
            t.brdf[k] / (t.brdf_in[ti].max(1) as f64 * bins.projected_solid_angle(to))
        })
        .collect();
    Ok(SurfaceReflection {
        bins,
        brdf,
        albedo: t.sum[R_SPECULAR] / t.photons.max(1) as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fresnel::fresnel_unpolarised;

    /// 9 × 9 × 12: the precompute grid's default bins.
    const BINS: BrdfBins = crate::simulate::DEFAULT_BRDF_BINS;

    #[test]
    fn a_smooth_surface_reflects_fresnel_into_the_mirror_bin_only() {
        // A smooth interface of the stratum corneum's index sends 1.55's Fresnel reflectance
        // into the mirror direction and nothing elsewhere: the binning and normalisation check.
        let mut s = surface_stack(SurfaceModel::Smith);
        s.surface = crate::layer::Surface::Smooth;
        let run = Run::brdf(s, 200_000, 3, BINS);
        let t = run_cpu(&run, &derma_core::progress::Silent).unwrap();
        for ti in 0..BINS.theta_in {
            let n_in = t.brdf_in[ti] as f64;
            let reflected: f64 = (0..BINS.theta_out)
                .flat_map(|to| (0..BINS.phi).map(move |p| BINS.index(ti, to, p)))
                .map(|k| t.brdf[k])
                .sum();
            let mirror: f64 = (0..BINS.phi).map(|p| t.brdf[BINS.index(ti, ti, p)]).sum();
            assert_eq!(reflected, mirror, "θi bin {ti}: all in θo = θi");
            // Fresnel over the bin's incidences (uniform in sinθ) against the mean reflected.
            let (s0, s1) = (
                (ti as f64 / 18.0 * std::f64::consts::PI).sin(),
                ((ti + 1) as f64 / 18.0 * std::f64::consts::PI).sin(),
            );
            let want: f64 = (0..100)
                .map(|k| {
                    let s = s0 + (s1 - s0) * (k as f64 + 0.5) / 100.0;
                    fresnel_unpolarised((1.0 - s * s).sqrt(), 1.0, LAYER_INDEX[0])
                })
                .sum::<f64>()
                / 100.0;
            assert!(
                (reflected / n_in - want).abs() < 0.01 + 0.1 * want,
                "θi bin {ti}: {} vs {want}",
                reflected / n_in
            );
        }
    }

    /// Walter et al. 2007's single-scattering reflection of a GGX dielectric with
    /// height-correlated Smith masking (Heitz 2014 eq. 99): F(i·h) D(h) G₂ / (4 cosθi cosθo).
    fn single_scattering(ti: f64, to: f64, phi: f64, alpha: f64) -> f64 {
        let i = [ti.sin(), 0.0, ti.cos()];
        let o = [to.sin() * phi.cos(), to.sin() * phi.sin(), to.cos()];
        let h = [i[0] + o[0], i[1] + o[1], i[2] + o[2]];
        let l = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let h = [h[0] / l, h[1] / l, h[2] / l];
        let ih = i[0] * h[0] + i[2] * h[2];
        let g2 = 1.0
            / (1.0
                + crate::microsurface::lambda(i[2], alpha)
                + crate::microsurface::lambda(o[2], alpha));
        fresnel_unpolarised(ih, 1.0, LAYER_INDEX[0]) * crate::microsurface::d_ggx(h[2], alpha) * g2
            / (4.0 * i[2] * o[2])
    }

    #[test]
    fn the_rough_surface_reflects_what_single_scattering_does_and_a_little_more() {
        let r = surface_reflection(
            SurfaceModel::Smith,
            BINS,
            1_000_000,
            1,
            &derma_core::progress::Silent,
        )
        .unwrap();
        let alpha = crate::microfacet::BIOSPEC_FOLD_ASPECT;
        // Directional albedo per incidence bin: the Monte Carlo against Walter's single
        // scattering (midpoint rule over each bin, cosθo-weighted); the walk's multiple
        // scattering only adds (Heitz et al. 2016: a few percent at α 0.75).
        let step = std::f64::consts::FRAC_PI_2 / 9.0;
        for ti in 0..9 {
            let mc: f64 = (0..9)
                .flat_map(|to| (0..12).map(move |p| (to, p)))
                .map(|(to, p)| r.brdf[BINS.index(ti, to, p)] * BINS.projected_solid_angle(to))
                .sum();
            let theta_i = (ti as f64 + 0.5) * step;
            let mut ss = 0.0;
            let n = 90;
            for a in 0..n {
                let to = (a as f64 + 0.5) * std::f64::consts::FRAC_PI_2 / n as f64;
                for b in 0..2 * n {
                    let phi = (b as f64 + 0.5) * std::f64::consts::PI / n as f64;
                    ss += single_scattering(theta_i, to, phi, alpha) * to.cos() * to.sin();
                }
            }
            ss *= (std::f64::consts::FRAC_PI_2 / n as f64) * (std::f64::consts::PI / n as f64);
            println!("θi bin {ti}: Monte Carlo {mc:.4}, single scattering {ss:.4}");
            assert!(
                mc > 0.97 * ss && mc < ss + 0.02,
                "θi bin {ti}: {mc} vs {ss}"
            );
        }
        println!("albedo {}", r.albedo);
    }
}
