//! Micro-normals of the skin surface: flattened spheres whose normals follow Trowbridge & Reitz
//! (1975), sampled with the inverse-CDF formula of the thesis (§4.5.1) as BioSpec does.

/// Zenith cosine of a micro-normal for a uniform `rho` ∈ [0, 1) and aspect ratio σ (thesis
/// §4.5.1): cos²α = (σ² / √(σ⁴ − σ⁴ρ + ρ) − 1) / (σ² − 1). As σ → 1 (spheres) the formula tends
/// to cos²α = ρ, the limit used there to avoid 0/0.
pub fn tr_cos_zenith(rho: f64, sigma: f64) -> f64 {
    let s2 = sigma * sigma;
    let cos2 = if (s2 - 1.0).abs() < 1e-6 {
        rho
    } else {
        let s4 = s2 * s2;
        (s2 / (s4 - s4 * rho + rho).sqrt() - 1.0) / (s2 - 1.0)
    };
    cos2.clamp(0.0, 1.0).sqrt()
}

/// BioSpec's aspect ratio of the surface folds, 0.75 (Krishnaswamy & Baranoski 2004, as used
/// by the RISE renderer's BioSpec skin defaults).
pub const BIOSPEC_FOLD_ASPECT: f64 = 0.75;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_and_limits() {
        for sigma in [0.3, 0.75, 0.999999, 1.0] {
            assert!(
                tr_cos_zenith(0.0, sigma).abs() < 1e-6,
                "ρ = 0 gives a grazing normal"
            );
            assert!(
                (tr_cos_zenith(1.0, sigma) - 1.0).abs() < 1e-6,
                "ρ → 1 gives the pole"
            );
        }
        // Continuity at σ = 1 (the limit branch against the formula just off it).
        for rho in [0.1, 0.5, 0.9] {
            let a = tr_cos_zenith(rho, 1.0);
            let b = tr_cos_zenith(rho, 1.0 - 1e-3);
            assert!((a - b).abs() < 1e-3, "{a} vs {b}");
        }
    }

    #[test]
    fn flatter_folds_have_normals_nearer_the_pole() {
        // Monotone in ρ (a valid inverse CDF) and more concentrated for smaller σ.
        let mut last = -1.0;
        for k in 0..=100 {
            let c = tr_cos_zenith(k as f64 / 100.0, 0.75);
            assert!(c >= last);
            last = c;
        }
        // ρ = ½ with σ = 0.75: cos²α = (0.5625/√0.6582 − 1)/(0.5625 − 1) = 0.7010.
        assert!((tr_cos_zenith(0.5, 0.75).powi(2) - 0.7010).abs() < 1e-3);
        assert!(tr_cos_zenith(0.5, 0.4) > tr_cos_zenith(0.5, 0.75));
    }
}
