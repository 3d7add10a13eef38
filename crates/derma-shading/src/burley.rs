//! Burley's normalized diffusion profile (Burley 2015, eq. 3; the model is derma-render's
//! [`derma_render::burley`]) fitted to a simulated radial profile (thesis §4.7.1): the surface
//! albedo A, the shape d and the scatter distance engines take (Christensen & Burley 2015).

use derma_core::numerics::{levenberg_marquardt, LmOptions};
use derma_optics::tally::ProfileBins;
use derma_render::burley::{cdf, mean_free_path};

/// One channel's fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BurleyFit {
    /// Surface albedo A.
    pub albedo: f64,
    /// Shape parameter d, mm.
    pub d_mm: f64,
    /// Mean free path ℓ (Christensen & Burley 2015's scatter distance), mm.
    pub mfp_mm: f64,
    /// RMS of the r-weighted residual relative to the r-weighted data (d'Eon et al. 2007's
    /// error ∫ r (R − R_fit)² dr).
    pub relative_rms: f64,
}

/// Ring averages of the profile with shape `d` and albedo 1.
fn ring_means(bins: &ProfileBins, d: f64, out: &mut [f64]) {
    let dr = bins.d_max_mm / bins.bins as f64;
    for (i, o) in out.iter_mut().enumerate() {
        let (a, b) = (i as f64 * dr, (i + 1) as f64 * dr);
        *o = (cdf(b, d) - cdf(a, d)) / bins.ring_area(i);
    }
}

/// Fits A and d to ring averages `data` (mm⁻²) of one channel, weighting ring i by r_i Δr;
/// `lm` sets the final Levenberg–Marquardt polish.
pub fn fit(bins: &ProfileBins, data: &[f64], lm: LmOptions) -> BurleyFit {
    let n = bins.bins;
    let dr = bins.d_max_mm / n as f64;
    let sw: Vec<f64> = (0..n)
        .map(|i| ((i as f64 + 0.5) * dr * dr).sqrt())
        .collect();
    let mut phi = vec![0.0; n];
    // For fixed d the best A is linear; scan log d, then polish (A, d) together.
    let mut best = (f64::MAX, 1.0, 0.0);
    for k in 0..=80 {
        let d = 0.003 * (30.0f64 / 0.003).powf(k as f64 / 80.0);
        ring_means(bins, d, &mut phi);
        let (mut pp, mut py) = (0.0, 0.0);
        for i in 0..n {
            pp += sw[i] * sw[i] * phi[i] * phi[i];
            py += sw[i] * sw[i] * phi[i] * data[i];
        }
        let a = (py / pp.max(1e-300)).max(0.0);
        let c: f64 = (0..n)
            .map(|i| (sw[i] * (a * phi[i] - data[i])).powi(2))
            .sum();
        if c < best.0 {
            best = (c, d, a);
        }
    }
    let mut res = |p: &[f64], r: &mut [f64], jac: Option<&mut [f64]>| {
        ring_means(bins, p[1], &mut phi);
        for i in 0..n {
            r[i] = sw[i] * (p[0] * phi[i] - data[i]);
        }
        if let Some(j) = jac {
            let h = 1e-6 * p[1];
            let mut p2 = vec![0.0; n];
            ring_means(bins, p[1] + h, &mut p2);
            for i in 0..n {
                j[i * 2] = sw[i] * phi[i];
                j[i * 2 + 1] = sw[i] * p[0] * (p2[i] - phi[i]) / h;
            }
        }
    };
    let (p, cost) = levenberg_marquardt(
        &mut res,
        &[best.2, best.1],
        &[0.0, 0.001],
        &[2.0, 100.0],
        n,
        lm,
    );
    let data_sq: f64 = (0..n).map(|i| (sw[i] * data[i]).powi(2)).sum();
    BurleyFit {
        albedo: p[0],
        d_mm: p[1],
        mfp_mm: mean_free_path(p[0], p[1]),
        relative_rms: (cost / data_sq.max(1e-300)).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_its_own_profile() {
        let bins = ProfileBins {
            bins: 64,
            d_max_mm: 8.0,
        };
        for &(a, d) in &[(0.55, 0.12), (0.3, 0.9), (0.7, 0.05)] {
            let mut data = vec![0.0; 64];
            ring_means(&bins, d, &mut data);
            data.iter_mut().for_each(|v| *v *= a);
            let f = fit(&bins, &data, LmOptions::default());
            assert!(((f.albedo - a) / a).abs() < 1e-3, "{f:?}");
            assert!(((f.d_mm - d) / d).abs() < 1e-3, "{f:?}");
            assert!(f.relative_rms < 1e-4);
        }
    }
}
