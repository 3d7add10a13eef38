//! What the transport records (thesis §4.5.2, §4.7.1): reflected, transmitted and absorbed
//! weight (per layer and absorber), per-wavelength totals, a sampled BRDF and the radial exit
//! profile. Tallies of independent photon batches add; merging in batch order is deterministic.

use crate::layer::N_ABSORBERS;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

/// Bins of the sampled BRDF: incoming zenith θi and outgoing zenith θo uniform on [0, π/2),
/// azimuth difference folded onto [0, π] (isotropic specimens are mirror symmetric).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BrdfBins {
    /// Bins of the incident zenith θi over [0, π/2).
    pub theta_in: usize,
    /// Bins of the outgoing zenith θo over [0, π/2).
    pub theta_out: usize,
    /// Bins of the azimuth difference Δφ over [0, π] (the BRDF is symmetric in ±Δφ).
    pub phi: usize,
}

impl BrdfBins {
    /// Number of bins.
    pub fn len(&self) -> usize {
        self.theta_in * self.theta_out * self.phi
    }

    /// True when any dimension has no bins.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The θi bin of zenith `theta` (radians).
    pub fn theta_in_bin(&self, theta: f64) -> usize {
        ((theta / FRAC_PI_2 * self.theta_in as f64) as usize).min(self.theta_in - 1)
    }

    /// Flat index of bin (θi, θo, Δφ).
    pub fn index(&self, ti: usize, to: usize, p: usize) -> usize {
        (ti * self.theta_out + to) * self.phi + p
    }

    /// Bin of an outgoing direction (z up, x towards the light's azimuth).
    pub fn out_bin(&self, dir_up: [f64; 3]) -> (usize, usize) {
        let theta = dir_up[2].clamp(-1.0, 1.0).acos();
        let to = ((theta / FRAC_PI_2 * self.theta_out as f64) as usize).min(self.theta_out - 1);
        let phi = dir_up[1].atan2(dir_up[0]).abs();
        let p = ((phi / std::f64::consts::PI * self.phi as f64) as usize).min(self.phi - 1);
        (to, p)
    }

    /// Projected solid angle ∫cosθ dω of an outgoing bin, counting both mirror halves of the
    /// folded azimuth: (sin²θ₁ − sin²θ₀) · Δφ. Dividing by it turns reflected energy per unit
    /// incident flux into a BRDF (thesis §3.1.6 divides by the solid angle, sinζ; the extra
    /// cosine makes the tally the BRDF itself, so that it is reciprocal).
    pub fn projected_solid_angle(&self, to: usize) -> f64 {
        let dt = FRAC_PI_2 / self.theta_out as f64;
        let (t0, t1) = (to as f64 * dt, (to as f64 + 1.0) * dt);
        (t1.sin().powi(2) - t0.sin().powi(2)) * std::f64::consts::PI / self.phi as f64
    }

    /// Centre angles (θi, θo, Δφ) of a bin, in radians.
    pub fn centre(&self, ti: usize, to: usize, p: usize) -> (f64, f64, f64) {
        (
            (ti as f64 + 0.5) * FRAC_PI_2 / self.theta_in as f64,
            (to as f64 + 0.5) * FRAC_PI_2 / self.theta_out as f64,
            (p as f64 + 0.5) * std::f64::consts::PI / self.phi as f64,
        )
    }
}

/// Bins of the radial exit profile: `bins` rings of equal width up to `d_max_mm`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProfileBins {
    /// Number of rings.
    pub bins: usize,
    /// Outer radius, mm.
    pub d_max_mm: f64,
}

impl ProfileBins {
    /// The ring of radius `r` (mm), or `None` beyond the last.
    pub fn bin(&self, r: f64) -> Option<usize> {
        let b = (r / self.d_max_mm * self.bins as f64) as usize;
        (b < self.bins).then_some(b)
    }

    /// Area of ring `b` in mm².
    pub fn ring_area(&self, b: usize) -> f64 {
        let dr = self.d_max_mm / self.bins as f64;
        std::f64::consts::PI * dr * dr * ((b + 1).pow(2) - b.pow(2)) as f64
    }
}

/// Most bins along one BRDF angle: 1/4° in zenith, 1/2° in azimuth — far finer than a million
/// photons can fill, and a bound on the tally's size.
pub const MAX_BRDF_BINS: usize = 360;
/// Most rings of a radial profile.
pub const MAX_PROFILE_BINS: usize = 1 << 16;

/// Index of the per-photon totals.
pub const R_SPECULAR: usize = 0;
/// Index of the diffuse reflectance.
pub const R_DIFFUSE: usize = 1;
/// Index of the transmittance.
pub const TRANSMITTED: usize = 2;
/// Index of the absorbance.
pub const ABSORBED: usize = 3;

/// Accumulated weight of a batch of photons. All weights are in units of one launched photon.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tally {
    /// Photons tallied.
    pub photons: u64,
    /// Σ over photons of (specular R, diffuse R, T, A).
    pub sum: [f64; 4],
    /// Σ of squares of the per-photon values, for standard errors.
    pub sum_sq: [f64; 4],
    /// Absorbed weight per layer and absorber class.
    pub absorbed: Vec<[f64; N_ABSORBERS]>,
    /// Net weight created (+) or destroyed (−) by Russian roulette; zero in expectation.
    pub roulette: f64,
    /// Photons launched per wavelength, and their (specular R, diffuse R, T, A) sums.
    pub per_lambda_count: Vec<u64>,
    /// See `per_lambda_count`.
    pub per_lambda: Vec<[f64; 4]>,
    /// Incoming photons per θi bin and reflected weight per BRDF bin and channel.
    pub brdf_in: Vec<u64>,
    /// See `brdf_in`: `[bin × channels + channel]`.
    pub brdf: Vec<f64>,
    /// Channels per BRDF bin.
    pub brdf_channels: usize,
    /// Diffusely reflected weight per wavelength and ring (wavelength-major).
    pub profile: Vec<f64>,
}

impl Tally {
    /// An empty tally for `layers` layers, `n_lambda` wavelengths and the given BRDF (with its channel count) and profile bins.
    pub fn new(
        layers: usize,
        n_lambda: usize,
        brdf: Option<(BrdfBins, usize)>,
        profile: Option<ProfileBins>,
    ) -> Self {
        let (brdf_in, brdf, brdf_channels) = match brdf {
            Some((b, ch)) => (vec![0; b.theta_in], vec![0.0; b.len() * ch], ch),
            None => (Vec::new(), Vec::new(), 0),
        };
        Self {
            photons: 0,
            sum: [0.0; 4],
            sum_sq: [0.0; 4],
            absorbed: vec![[0.0; N_ABSORBERS]; layers],
            roulette: 0.0,
            per_lambda_count: vec![0; n_lambda],
            per_lambda: vec![[0.0; 4]; n_lambda],
            brdf_in,
            brdf,
            brdf_channels,
            profile: profile.map_or(Vec::new(), |p| vec![0.0; p.bins * n_lambda]),
        }
    }

    /// Adds another tally of the same shape (the caller merges in a fixed order).
    pub fn merge(&mut self, o: &Tally) {
        self.photons += o.photons;
        for k in 0..4 {
            self.sum[k] += o.sum[k];
            self.sum_sq[k] += o.sum_sq[k];
        }
        for (a, b) in self.absorbed.iter_mut().zip(&o.absorbed) {
            for c in 0..N_ABSORBERS {
                a[c] += b[c];
            }
        }
        self.roulette += o.roulette;
        for (a, b) in self.per_lambda_count.iter_mut().zip(&o.per_lambda_count) {
            *a += b;
        }
        for (a, b) in self.per_lambda.iter_mut().zip(&o.per_lambda) {
            for k in 0..4 {
                a[k] += b[k];
            }
        }
        for (a, b) in self.brdf_in.iter_mut().zip(&o.brdf_in) {
            *a += b;
        }
        for (a, b) in self.brdf.iter_mut().zip(&o.brdf) {
            *a += b;
        }
        for (a, b) in self.profile.iter_mut().zip(&o.profile) {
            *a += b;
        }
    }

    /// Mean per launched photon of total `k`.
    pub fn mean(&self, k: usize) -> f64 {
        self.sum[k] / self.photons.max(1) as f64
    }

    /// Standard error of the mean of total `k`.
    pub fn stderr(&self, k: usize) -> f64 {
        let n = self.photons as f64;
        if n < 2.0 {
            return f64::NAN;
        }
        let var = (self.sum_sq[k] - self.sum[k] * self.sum[k] / n) / (n - 1.0);
        (var.max(0.0) / n).sqrt()
    }

    /// Weight that entered the books: launched photons plus roulette's net creation.
    pub fn weight_total(&self) -> f64 {
        self.photons as f64 + self.roulette
    }

    /// R + T + A − (photons + roulette): zero up to rounding.
    pub fn bookkeeping_error(&self) -> f64 {
        self.sum.iter().sum::<f64>() - self.weight_total()
    }
}
