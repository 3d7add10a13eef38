//! Burley's normalized diffusion profile (Burley 2015, "Extending the Disney BRDF to a BSDF with
//! integrated subsurface scattering", SIGGRAPH course notes, eq. 3), the model the renderer's
//! subsurface blur draws and derma-shading fits: the profile, its energy, its marginal along a
//! line, and the scatter distance engines take (Christensen & Burley 2015).
//!
//! R(r) = A (e^{−r/d} + e^{−r/(3d)}) / (8π d r); its integral over the plane is A, and the energy
//! inside radius r is A (1 − e^{−r/d}/4 − 3 e^{−r/(3d)}/4), so ring averages are exact.

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
