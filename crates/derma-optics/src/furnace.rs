//! The white furnace for the skin's surface: a lossless scattering slab under the skin's rough
//! surface over a white floor returns every photon, so its sampled BRDF must conserve energy in
//! both directions: for each incidence the reflected light sums to one (directional albedo), and
//! for each outgoing direction, by reciprocity, the light arriving there from all incidences
//! sums to at most one (Heitz 2014 §3, the weak white furnace; Heitz et al. 2016 §7).

use crate::cpu::run_cpu;
use crate::error::Result;
use crate::layer::{Bottom, Layer, Stack};
use crate::run::Run;
use crate::specimen::SurfaceModel;
use crate::tally::BrdfBins;
use derma_core::progress::Progress;
use std::f64::consts::FRAC_PI_2;

/// The furnace slab: 0.2 mm of non-absorbing tissue (μs 5 /mm, g 0.9, n 1.4: the epidermis' index
/// and anisotropy of `specimen.rs`, one mean free path thick) over a white Lambertian floor.
pub fn furnace_stack(surface: SurfaceModel) -> Stack {
    Stack {
        layers: vec![Layer::plain(0.2, 0.0, 5.0, 0.9, 1.4)],
        n_above: 1.0,
        bottom: Bottom::Lambertian { albedo: 1.0 },
        surface: surface.surface(),
    }
}

/// A furnace run's sampled BRDF, azimuth-averaged, per zenith pair.
#[derive(Clone, Debug, PartialEq)]
pub struct Furnace {
    /// The bins (θi, θo of 90°/n each).
    pub bins: BrdfBins,
    /// π · f̄(θi, θo): 1 everywhere for a Lambertian reflector; `[ti][to]`.
    pub pi_brdf: Vec<Vec<f64>>,
    /// Standard error of each value of `pi_brdf` (photon counting).
    pub stderr: Vec<Vec<f64>>,
    /// Σ_o f̄(θi, o) Ω⊥(o) per incidence bin: 1 if the energy comes back.
    pub directional_albedo: Vec<f64>,
    /// Σ_i f̄(i, θo) Ω⊥(i) per outgoing bin: at most 1 when the BRDF is reciprocal and
    /// conserves energy for light arriving from θo.
    pub reciprocal_albedo: Vec<f64>,
    /// Reflected (specular + diffuse) weight per photon: 1 for a lossless specimen.
    pub returned: f64,
}

/// Projected solid angle of the ring of zeniths [θ₀, θ₁) of bin `k` of `n`: π (sin²θ₁ − sin²θ₀).
fn ring(k: usize, n: usize) -> f64 {
    let d = FRAC_PI_2 / n as f64;
    std::f64::consts::PI * (((k + 1) as f64 * d).sin().powi(2) - (k as f64 * d).sin().powi(2))
}

/// Runs the furnace with `photons` photons (cosine-weighted incidence, thesis §4.5.2).
pub fn furnace(
    surface: SurfaceModel,
    photons: u64,
    seed: u64,
    zenith_bins: usize,
    progress: &dyn Progress,
) -> Result<Furnace> {
    let bins = BrdfBins {
        theta_in: zenith_bins,
        theta_out: zenith_bins,
        phi: 1,
    };
    let run = Run::brdf(furnace_stack(surface), photons, seed, bins);
    let t = run_cpu(&run, progress)?;
    let n = zenith_bins;
    let mut pi_brdf = vec![vec![0.0; n]; n];
    let mut stderr = vec![vec![0.0; n]; n];
    for ti in 0..n {
        let count = t.brdf_in[ti].max(1) as f64;
        for to in 0..n {
            let w = t.brdf[bins.index(ti, to, 0)];
            // Exits are unit-weight events here (nothing is absorbed), so the count of a bin is
            // its weight and its error is Poisson.
            let scale = std::f64::consts::PI / (count * ring(to, n));
            pi_brdf[ti][to] = w * scale;
            stderr[ti][to] = w.sqrt() * scale;
        }
    }
    let directional_albedo = (0..n)
        .map(|ti| {
            (0..n).map(|to| pi_brdf[ti][to] * ring(to, n)).sum::<f64>() / std::f64::consts::PI
        })
        .collect();
    let reciprocal_albedo = (0..n)
        .map(|to| {
            (0..n).map(|ti| pi_brdf[ti][to] * ring(ti, n)).sum::<f64>() / std::f64::consts::PI
        })
        .collect();
    let returned =
        (t.sum[crate::tally::R_SPECULAR] + t.sum[crate::tally::R_DIFFUSE]) / t.photons as f64;
    Ok(Furnace {
        bins,
        pi_brdf,
        stderr,
        directional_albedo,
        reciprocal_albedo,
        returned,
    })
}

/// The furnace plot: π·f̄ against θo for incidences in `show` (bin indices), one series per
/// incidence and model.
pub fn plot(runs: &[(SurfaceModel, &Furnace)], show: &[usize]) -> derma_core::plot::Plot {
    use derma_core::plot::{Plot, Series};
    let mut series = Vec::new();
    for (model, f) in runs {
        let n = f.bins.theta_out;
        let (name, colors) = match model {
            SurfaceModel::Smith => ("Smith", ["#08519c", "#3182bd", "#6baed6", "#9ecae1"]),
            SurfaceModel::Thesis => ("thesis", ["#a50f15", "#de2d26", "#fb6a4a", "#fcae91"]),
        };
        for (k, &ti) in show.iter().enumerate() {
            let ci = (ti as f64 + 0.5) * 90.0 / n as f64;
            series.push(Series::new(
                format!("{name}, θi {ci:.0}°"),
                colors[k % colors.len()],
                (0..n).map(|to| ((to as f64 + 0.5) * 90.0 / n as f64, f.pi_brdf[ti][to])),
            ));
        }
    }
    Plot::new(
        "White furnace: lossless slab, skin surface, white floor",
        "outgoing zenith θo (°)",
        "π · BRDF (azimuth mean)",
        series,
    )
}
