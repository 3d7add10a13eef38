//! Burley's normalized diffusion profile (Burley 2015, "Extending the Disney BRDF to a BSDF with
//! integrated subsurface scattering", SIGGRAPH course notes, eq. 3) fitted to a simulated radial
//! profile (thesis §4.7.1), and the scatter distance engines take (Christensen & Burley 2015).
//!
//! R(r) = A (e^{−r/d} + e^{−r/(3d)}) / (8π d r); its integral over the plane is A, and the energy
//! inside radius r is A (1 − e^{−r/d}/4 − 3 e^{−r/(3d)}/4), so ring averages are exact.

use derma_core::numerics::{levenberg_marquardt, LmOptions};
use derma_optics::tally::ProfileBins;
use std::f64::consts::PI;

/// R(r) in mm⁻² for albedo `a` and shape `d` (mm).
pub fn profile(r: f64, a: f64, d: f64) -> f64 {
    a * ((-r / d).exp() + (-r / (3.0 * d)).exp()) / (8.0 * PI * d * r)
}

/// Fraction of the reflected energy inside radius r.
pub fn cdf(r: f64, d: f64) -> f64 {
    1.0 - 0.25 * (-r / d).exp() - 0.75 * (-r / (3.0 * d)).exp()
}

/// Christensen & Burley 2015 ("Approximate reflectance profiles for efficient subsurface
/// scattering", Pixar TM 15-04, eq. 6, diffuse surface transmission): ℓ = d · s(A) with
/// s = 1.9 − A + 3.5 (A − 0.8)², ℓ the mean free path that artists set as the scatter distance.
pub fn mean_free_path(a: f64, d: f64) -> f64 {
    d * (1.9 - a + 3.5 * (a - 0.8) * (a - 0.8))
}

/// The profile's marginal along one axis, m(x) = ∫ R(√(x² + y²)) dy for albedo 1 and shape
/// `d` (mm⁻¹): with ∫ e^{−ρ/d}/ρ dy = 2 K₀(|x|/d), m(x) = (K₀(|x|/d) + K₀(|x|/(3d))) / (4π d),
/// whose integral over the line is 1. A separable screen-space blur (Jimenez et al. 2015)
/// convolves with m along x, then along y.
pub fn marginal(x: f64, d: f64) -> f64 {
    let x = x.abs().max(1e-12);
    (derma_core::numerics::bessel::k0(x / d) + derma_core::numerics::bessel::k0(x / (3.0 * d)))
        / (4.0 * PI * d)
}

/// The one-sided cumulative marginal F(u) = ∫₀ᵘ m(t) dt for d = 1 (so F(∞) = ½) at `n` nodes
/// evenly spaced on [0, `u_max`]; for another shape, F_d(x) = F(x / d). Midpoint rule on a
/// 10⁻³ grid (K₀'s logarithmic singularity at 0 costs < 10⁻⁴).
pub fn marginal_cdf_table(n: usize, u_max: f64) -> Vec<f64> {
    let h = 1e-3;
    let mut out = Vec::with_capacity(n);
    let (mut acc, mut t) = (0.0, 0.0);
    for i in 0..n {
        let u = u_max * i as f64 / (n - 1) as f64;
        while t + h <= u {
            acc += marginal(t + 0.5 * h, 1.0) * h;
            t += h;
        }
        out.push(acc + marginal(0.5 * (t + u), 1.0) * (u - t));
    }
    out
}

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
    fn normalised_and_cdf_consistent() {
        // ∫ R 2πr dr = A: midpoint rule on a fine grid out to 60 d.
        let (a, d) = (0.6, 0.4);
        let n = 200_000;
        let h = 60.0 * d / n as f64;
        let s: f64 = (0..n)
            .map(|i| {
                let r = (i as f64 + 0.5) * h;
                profile(r, a, d) * 2.0 * PI * r * h
            })
            .sum();
        assert!((s - a).abs() < 1e-4, "{s}");
        assert!(
            (cdf(1.3, d) * a - {
                let m = 100_000;
                let h = 1.3 / m as f64;
                (0..m)
                    .map(|i| {
                        let r = (i as f64 + 0.5) * h;
                        profile(r, a, d) * 2.0 * PI * r * h
                    })
                    .sum::<f64>()
            })
            .abs()
                < 1e-5
        );
        assert_eq!(cdf(0.0, d), 0.0);
    }

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

    #[test]
    fn marginal_is_the_line_integral_of_the_profile_and_sums_to_one() {
        let d = 0.7;
        for x in [0.05, 0.4, 1.5, 4.0] {
            // ∫ R(√(x² + y²)) dy by the midpoint rule out to |y| = 60 d.
            let h = 1e-4;
            let direct: f64 = (0..600_000)
                .map(|i| {
                    let y = (i as f64 + 0.5) * h;
                    2.0 * profile((x * x + y * y).sqrt(), 1.0, d) * h
                })
                .sum();
            let m = marginal(x, d);
            assert!(((m - direct) / m).abs() < 2e-3, "x {x}: {m} vs {direct}");
        }
        let f = marginal_cdf_table(241, 60.0);
        assert!((f[240] - 0.5).abs() < 2e-3, "{}", f[240]);
        assert!(f.windows(2).all(|w| w[1] >= w[0]));
        assert_eq!(f[0], 0.0);
    }

    #[test]
    fn mean_free_path_matches_the_fit_formula() {
        // A = 0.8: s = 1.1.
        assert!((mean_free_path(0.8, 2.0) - 2.2).abs() < 1e-12);
    }
}
