//! Microfacet building blocks shared by the render models: GGX/Trowbridge–Reitz and Beckmann
//! normal distributions, Smith masking, Schlick's Fresnel (Walter et al. 2007, "Microfacet models
//! for refraction through rough surfaces", EGSR, eqs. 33–34 and 23–27; Schlick 1994).

use std::f64::consts::PI;

/// GGX distribution D(h) = α² / (π ((n·h)²(α² − 1) + 1)²) (Walter et al. 2007, eq. 33).
#[inline]
pub fn ggx_d(n_h: f64, alpha: f64) -> f64 {
    if n_h <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = n_h * n_h * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// Height-correlated Smith visibility for GGX, V = G₂ / (4 n·l n·v) (Heitz 2014, "Understanding
/// the masking-shadowing function", eq. 99; the form written in the glTF 2.0 specification,
/// Appendix B.3.2).
#[inline]
pub fn ggx_smith_visibility(n_l: f64, n_v: f64, alpha: f64) -> f64 {
    if n_l <= 0.0 || n_v <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let gv = n_l * (n_v * n_v * (1.0 - a2) + a2).sqrt();
    let gl = n_v * (n_l * n_l * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl)
}

/// Beckmann distribution D(h) = exp(−tan²θh / m²) / (π m² cos⁴θh) (Walter et al. 2007, eq. 25).
#[inline]
pub fn beckmann_d(n_h: f64, m: f64) -> f64 {
    if n_h <= 0.0 {
        return 0.0;
    }
    let c2 = n_h * n_h;
    let tan2 = (1.0 - c2) / c2;
    (-tan2 / (m * m)).exp() / (PI * m * m * c2 * c2)
}

/// Schlick's approximation F = F0 + (1 − F0)(1 − cosθ)⁵ (Schlick 1994, "An inexpensive BRDF
/// model for physically-based rendering", eq. 15).
#[inline]
pub fn schlick(f0: f64, cos_theta: f64) -> f64 {
    let x = (1.0 - cos_theta).clamp(0.0, 1.0);
    let x2 = x * x;
    f0 + (1.0 - f0) * x2 * x2 * x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ D(h) (n·h) dω_h = 1 (the projected microfacet area is the macro-surface's).
    fn projected_area(d: impl Fn(f64) -> f64) -> f64 {
        let n = 20000;
        (0..n)
            .map(|i| {
                // μ = cosθh uniform on (0,1]: dω = 2π dμ.
                let mu = (i as f64 + 0.5) / n as f64;
                d(mu) * mu * 2.0 * PI / n as f64
            })
            .sum()
    }

    #[test]
    fn distributions_are_normalised() {
        for a in [0.1, 0.3, 0.6, 1.0] {
            let g = projected_area(|mu| ggx_d(mu, a));
            let b = projected_area(|mu| beckmann_d(mu, a));
            assert!((g - 1.0).abs() < 2e-3, "ggx α={a}: {g}");
            assert!((b - 1.0).abs() < 2e-3, "beckmann m={a}: {b}");
        }
    }

    #[test]
    fn closed_forms() {
        // At normal incidence D_GGX(1) = 1/(π α²); α = 1 is uniform: 1/π.
        assert!((ggx_d(1.0, 0.5) - 1.0 / (PI * 0.25)).abs() < 1e-12);
        assert!((ggx_d(0.3, 1.0) - 1.0 / PI).abs() < 1e-12);
        assert!((beckmann_d(1.0, 0.3) - 1.0 / (PI * 0.09)).abs() < 1e-12);
        // V at normal view and light: 1/(4) · 1/(1·1) → 0.5/(1+1) = 0.25 for any α.
        assert!((ggx_smith_visibility(1.0, 1.0, 0.7) - 0.25).abs() < 1e-12);
        assert_eq!(schlick(0.04, 1.0), 0.04);
        assert_eq!(schlick(0.04, 0.0), 1.0);
    }
}
