//! Generic layered slabs for validation (MCML's geometry: Wang, Jacques & Zheng 1995): layers
//! given as d (mm), μa and μs (cm⁻¹, the units of the tissue-optics literature), g, n; a normally
//! incident pencil beam; specular and diffuse reflectance, transmittance, absorbance.

use crate::error::{OpticsError, Result};
use crate::layer::{Bottom, Layer, Stack, Surface};
use crate::tally::{Tally, ABSORBED, R_DIFFUSE, R_SPECULAR, TRANSMITTED};
use serde::{Deserialize, Serialize};

/// Parses `d_mm,mua_per_cm,mus_per_cm,g,n` into a layer (coefficients converted to mm⁻¹).
pub fn parse_layer(text: &str) -> Result<Layer> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 5 {
        return Err(OpticsError::Invalid(derma_core::Invalid::new(
            format!("layer '{text}'"),
            "5 comma-separated values (d_mm,mua_per_cm,mus_per_cm,g,n)",
            parts.len(),
        )));
    }
    let names = ["d_mm", "mua_per_cm", "mus_per_cm", "g", "n"];
    let mut v = [0.0; 5];
    for i in 0..5 {
        v[i] = parts[i].parse::<f64>().map_err(|_| {
            OpticsError::Invalid(derma_core::Invalid::new(
                format!("{} in layer '{text}'", names[i]),
                "a number",
                format!("'{}'", parts[i]),
            ))
        })?;
    }
    Ok(Layer::plain(v[0], v[1] / 10.0, v[2] / 10.0, v[3], v[4]))
}

/// A slab between two clear media with smooth boundaries.
pub fn slab_stack(layers: Vec<Layer>, n_above: f64, n_below: f64) -> Stack {
    Stack {
        layers,
        n_above,
        bottom: Bottom::Medium { n: n_below },
        surface: Surface::Smooth,
    }
}

/// The four totals of a slab run and their standard errors, as `derma optics slab --json`
/// prints them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlabTotals {
    /// Standard error of the specular reflectance.
    pub r_specular: f64,
    /// Standard error of the diffuse reflectance.
    pub r_diffuse: f64,
    /// Standard error of the total transmittance.
    pub t_total: f64,
    /// Standard error of the absorbance.
    pub absorbed: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
/// Totals of a slab run, per launched photon, as `derma optics slab --json` prints them.
pub struct SlabResult {
    /// Specular (surface) reflectance.
    pub r_specular: f64,
    /// Diffuse reflectance.
    pub r_diffuse: f64,
    /// Total transmittance.
    pub t_total: f64,
    /// Absorbance.
    pub absorbed: f64,
    /// Standard errors of the four totals.
    pub stderr: SlabTotals,
    /// Absorbed fraction per layer, top first.
    pub absorbed_per_layer: Vec<f64>,
    /// R + T + A − launched weight (photons + roulette's net creation), per photon.
    pub bookkeeping_error: f64,
    /// Photons launched.
    pub photons: u64,
    /// Throughput of the transport.
    pub photons_per_s: f64,
    /// Wall-clock seconds of the transport.
    pub seconds: f64,
    /// The device it ran on.
    pub device: String,
}

impl SlabResult {
    /// The totals of tally `t`, which took `seconds` on `device`.
    pub fn from_tally(t: &Tally, seconds: f64, device: &str) -> Self {
        let n = t.photons.max(1) as f64;
        Self {
            r_specular: t.mean(R_SPECULAR),
            r_diffuse: t.mean(R_DIFFUSE),
            t_total: t.mean(TRANSMITTED),
            absorbed: t.mean(ABSORBED),
            stderr: SlabTotals {
                r_specular: t.stderr(R_SPECULAR),
                r_diffuse: t.stderr(R_DIFFUSE),
                t_total: t.stderr(TRANSMITTED),
                absorbed: t.stderr(ABSORBED),
            },
            absorbed_per_layer: t
                .absorbed
                .iter()
                .map(|a| a.iter().sum::<f64>() / n)
                .collect(),
            bookkeeping_error: t.bookkeeping_error() / n,
            photons: t.photons,
            photons_per_s: t.photons as f64 / seconds.max(1e-9),
            seconds,
            device: device.to_string(),
        }
    }
}
