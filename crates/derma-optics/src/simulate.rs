//! The skin simulation of one set of bio parameters (thesis PrecalculateBioModel, §4.8.6):
//! photons spread evenly over 380–780 nm, incident zenith from the arcsin distribution
//! (§4.5.2), recording the sampled BRDF (linear sRGB under D65), the diffuse reflectance
//! spectrum and colour, the radial exit profile per wavelength and as RGB (§4.7.1), and the
//! absorbed fractions per layer and chromophore.

use crate::bio::BioTexel;
use crate::error::Result;
use crate::layer::{ABSORBER_NAMES, N_ABSORBERS};
use crate::run::Run;
use crate::specimen::{skin_stacks, SurfaceModel, SKIN_LAYER_NAMES};
use crate::tally::{BrdfBins, ProfileBins, Tally, R_DIFFUSE, R_SPECULAR, TRANSMITTED};
use crate::transport::Incidence;
use crate::yellow_pigments::YellowPigments;
use derma_core::color::{
    cmf, reflectance_to_xyz, wavelength_nm, xyz_to_linear_srgb, Spectrum, D65_10NM, N_WAVELENGTHS,
};
use derma_core::gpu::Device;
use derma_core::progress::{Progress, Unit};
use serde::{Deserialize, Serialize};

/// What to record and how many photons.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkinSimConfig {
    /// Photons, spread evenly over the wavelength samples.
    pub photons: u64,
    /// Seed of the photons' streams.
    pub seed: u64,
    /// Bins of the sampled BRDF.
    pub brdf: BrdfBins,
    /// Bins of the radial exit profile.
    pub profile: ProfileBins,
    /// The skin surface's model (absent in older files: the thesis' sampling they were made with).
    #[serde(default = "thesis_surface")]
    pub surface: SurfaceModel,
    /// β-carotene and bilirubin (absent in older files: none, as they were made).
    #[serde(default = "YellowPigments::none")]
    pub yellow: YellowPigments,
}

fn thesis_surface() -> SurfaceModel {
    SurfaceModel::Thesis
}

/// The default BRDF bins of a skin simulation and a precompute grid: 9 × 9 zeniths of 10° and
/// 12 azimuths of 15°.
pub const DEFAULT_BRDF_BINS: BrdfBins = BrdfBins {
    theta_in: 9,
    theta_out: 9,
    phi: 12,
};

impl Default for SkinSimConfig {
    /// 10⁶ photons; BRDF bins of 10° in both zeniths and 15° in azimuth difference; radial
    /// profile in 64 rings of 0.125 mm up to D_max = 8 mm (skin's red diffusion profile is
    /// ~1 mm wide; d'Eon et al. 2007 fit Gaussians up to a few mm).
    fn default() -> Self {
        Self {
            photons: 1_000_000,
            seed: 1,
            brdf: DEFAULT_BRDF_BINS,
            profile: ProfileBins {
                bins: 64,
                d_max_mm: 8.0,
            },
            surface: SurfaceModel::Smith,
            yellow: YellowPigments::BIOSPEC,
        }
    }
}

/// Linear-sRGB weight of each wavelength sample, so that Σ_λ w(λ) R(λ) is the colour of
/// reflectance R under D65 (white = (1, 1, 1)); the CIE 1931 observer of derma-core.
pub fn rgb_weights() -> Vec<[f64; 3]> {
    let norm: f64 = (0..N_WAVELENGTHS).map(|i| D65_10NM[i] * cmf(i)[1]).sum();
    (0..N_WAVELENGTHS)
        .map(|i| {
            let c = cmf(i);
            let s = D65_10NM[i] / norm;
            xyz_to_linear_srgb([c[0] * s, c[1] * s, c[2] * s])
        })
        .collect()
}

/// Results of one skin simulation. Fractions are per launched photon.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkinResult {
    /// The simulated bio parameters.
    pub bio: BioTexel,
    /// What was simulated.
    pub config: SkinSimConfig,
    /// The device it ran on (`cpu` or `gpu`).
    pub device: Device,
    /// Wall-clock seconds of the transport.
    pub seconds: f64,
    /// The wavelength samples, nm.
    pub wavelengths_nm: Vec<f64>,
    /// Diffuse (subsurface) reflectance per wavelength under the arcsin-distributed incidence,
    /// i.e. the albedo under uniform diffuse light, specular surface reflection excluded.
    pub r_diffuse: Vec<f64>,
    /// Standard error of `r_diffuse` per wavelength.
    pub r_diffuse_stderr: Vec<f64>,
    /// Surface (specular) reflectance per wavelength.
    pub r_specular: Vec<f64>,
    /// CIE 1931 XYZ of the diffuse reflectance under D65 (Y = 1 for white).
    pub xyz: [f64; 3],
    /// The same colour in linear sRGB.
    pub linear_srgb: [f64; 3],
    /// Bins of `brdf_rgb`.
    pub brdf_bins: BrdfBins,
    /// Sampled BRDF (sr⁻¹), linear sRGB, indexed `[(θi · nθo + θo) · nφ + φ]`.
    pub brdf_rgb: Vec<[f64; 3]>,
    /// Bins of the profiles.
    pub profile_bins: ProfileBins,
    /// Radial exit profile R(r) (mm⁻², per launched photon of that wavelength), wavelength-major.
    pub profile: Vec<Vec<f64>>,
    /// Radial exit profile in linear sRGB under D65, mm⁻².
    pub profile_rgb: Vec<[f64; 3]>,
    /// Names of the four layers, top first.
    pub layer_names: Vec<String>,
    /// Names of the absorber classes of `absorbed`.
    pub absorber_names: Vec<String>,
    /// Absorbed fraction per layer and absorber.
    pub absorbed: Vec<[f64; N_ABSORBERS]>,
    /// Specular (surface) reflectance, all wavelengths.
    pub reflected_specular: f64,
    /// Diffuse (subsurface) reflectance, all wavelengths.
    pub reflected_diffuse: f64,
    /// Weight not reflected by the hypodermis (zero for BioSpec's white hypodermis).
    pub transmitted: f64,
    /// Net weight from Russian roulette per photon (zero in expectation).
    pub roulette: f64,
    /// R + T + A − launched weight, per photon.
    pub bookkeeping_error: f64,
}

/// Builds the run for `bio`.
pub fn skin_run(bio: &BioTexel, cfg: &SkinSimConfig) -> Run {
    let nl = N_WAVELENGTHS as f64;
    Run {
        stacks: skin_stacks(bio, &cfg.yellow)
            .into_iter()
            .map(|mut s| {
                s.surface = cfg.surface.surface();
                s
            })
            .collect(),
        photons: cfg.photons,
        seed: cfg.seed,
        incidence: Incidence::ArcsinZenith,
        brdf: Some(cfg.brdf),
        profile: Some(cfg.profile),
        channel_weights: rgb_weights()
            .into_iter()
            .map(|w| w.iter().map(|c| c * nl).collect())
            .collect(),
    }
}

/// Turns a tally of [`skin_run`] into results.
pub fn skin_result(
    bio: &BioTexel,
    cfg: &SkinSimConfig,
    t: &Tally,
    device: Device,
    seconds: f64,
) -> SkinResult {
    let n = t.photons.max(1) as f64;
    let per = |k: usize| -> Vec<f64> {
        (0..N_WAVELENGTHS)
            .map(|i| t.per_lambda[i][k] / t.per_lambda_count[i].max(1) as f64)
            .collect()
    };
    let r_diffuse = per(R_DIFFUSE);
    // Binomial-style error per wavelength from the per-λ mean (weights ≤ 1, exits are 0/1-like).
    let r_diffuse_stderr = (0..N_WAVELENGTHS)
        .map(|i| {
            let m = t.per_lambda_count[i].max(1) as f64;
            (r_diffuse[i] * (1.0 - r_diffuse[i]).max(0.0) / m).sqrt()
        })
        .collect();
    let spec: Spectrum = std::array::from_fn(|i| r_diffuse[i]);
    let xyz = reflectance_to_xyz(&spec);
    let b = cfg.brdf;
    let brdf_rgb = (0..b.len())
        .map(|k| {
            let ti = k / (b.theta_out * b.phi);
            let to = (k / b.phi) % b.theta_out;
            let nin = t.brdf_in[ti].max(1) as f64;
            let d = nin * b.projected_solid_angle(to);
            std::array::from_fn(|c| t.brdf[k * 3 + c] / d)
        })
        .collect();
    let pb = cfg.profile;
    let profile: Vec<Vec<f64>> = (0..N_WAVELENGTHS)
        .map(|i| {
            let m = t.per_lambda_count[i].max(1) as f64;
            (0..pb.bins)
                .map(|r| t.profile[i * pb.bins + r] / (m * pb.ring_area(r)))
                .collect()
        })
        .collect();
    let w = rgb_weights();
    let profile_rgb = (0..pb.bins)
        .map(|r| std::array::from_fn(|c| (0..N_WAVELENGTHS).map(|i| w[i][c] * profile[i][r]).sum()))
        .collect();
    SkinResult {
        bio: *bio,
        config: *cfg,
        device,
        seconds,
        wavelengths_nm: (0..N_WAVELENGTHS).map(wavelength_nm).collect(),
        r_diffuse,
        r_diffuse_stderr,
        r_specular: per(R_SPECULAR),
        xyz,
        linear_srgb: xyz_to_linear_srgb(xyz),
        brdf_bins: b,
        brdf_rgb,
        profile_bins: pb,
        profile,
        profile_rgb,
        layer_names: SKIN_LAYER_NAMES.iter().map(|s| s.to_string()).collect(),
        absorber_names: ABSORBER_NAMES.iter().map(|s| s.to_string()).collect(),
        absorbed: t.absorbed.iter().map(|a| a.map(|v| v / n)).collect(),
        reflected_specular: t.mean(R_SPECULAR),
        reflected_diffuse: t.mean(R_DIFFUSE),
        transmitted: t.mean(TRANSMITTED),
        roulette: t.roulette / n,
        bookkeeping_error: t.bookkeeping_error() / n,
    }
}

/// Simulates `bio` on `device` (the CPU, or the GPU through [`crate::gpu`]); reports a stage
/// of `cfg.photons` photons. The result records the device it ran on.
pub fn simulate_skin(
    bio: &BioTexel,
    cfg: &SkinSimConfig,
    device: Device,
    progress: &dyn Progress,
) -> Result<SkinResult> {
    bio.validate()?;
    cfg.yellow.validate()?;
    let run = skin_run(bio, cfg);
    progress.stage("simulate", cfg.photons, Unit::Photons);
    let t0 = std::time::Instant::now();
    let (tally, device) = crate::backend::run_on(&run, device, progress)?;
    Ok(skin_result(
        bio,
        cfg,
        &tally,
        device,
        t0.elapsed().as_secs_f64(),
    ))
}
