//! β-carotene and bilirubin, the yellow pigments BioSpec adds to melanin and blood (Krishnaswamy
//! & Baranoski 2004, §3): molar extinction on derma's 10 nm grid and absorption at a concentration.
//!
//! Spectra: PhotochemCAD 2.1a (Du et al. 1998, Photochem Photobiol 68:141; Dixon et al. 2005,
//! Photochem Photobiol 81:212) as tabulated by S. Prahl (OMLC, 2017): β-carotene in hexane
//! (R.-C. A. Fuh, 1995), scaled to 139 500 M⁻¹cm⁻¹ at 451 nm (the value OMLC takes from Zechmeister);
//! bilirubin in chloroform (J. Li, 1997), scaled to 55 000 M⁻¹cm⁻¹ at 450.8 nm (Agati & Fusi
//! 1990). Each grid value is the mean of the five samples within ±0.5 nm of the node. Beyond
//! 520 nm both tables sit at their noise floor (±1000 for β-carotene, ±100 for bilirubin, around
//! zero): 0 there.
//!
//! Concentrations: BioSpec's defaults as its author's renderer (RISE) sets them: β-carotene
//! 2.1·10⁻⁴ g/L in the stratum corneum and epidermis, 7·10⁻⁵ g/L in the dermis; bilirubin
//! 0.05 g/L of blood. 0.05 g/L is 5 mg/dL, above the normal adult serum range (0.3–1.2 mg/dL):
//! kept as BioSpec's baseline, and a parameter.
//!
//! Magnitudes at 450 nm (the peak of both): β-carotene at 2.1·10⁻⁴ g/L absorbs 0.0125 mm⁻¹,
//! an optical depth of 0.0014 through 0.11 mm of stratum corneum and epidermis; bilirubin at
//! 0.05 g/L absorbs 1.08 mm⁻¹ in whole blood, 0.013 mm⁻¹ at 1.2 % dermal blood, against
//! 0.12 mm⁻¹ of bloodless dermis and 0.40–0.47 mm⁻¹ of its hemoglobin (fully to 75 % oxygenated).
//! Measured with the Monte Carlo skin (docs/optics.md): b* +0.25 on light skin, +0.02 on dark;
//! L* and a* within 0.04.

use crate::chromophore::molar_absorption;
use serde::{Deserialize, Serialize};

/// Molar mass of β-carotene, C₄₀H₅₆ (g/mol).
pub const BETA_CAROTENE_G_PER_MOL: f64 = 536.87;
/// Molar mass of bilirubin, C₃₃H₃₆N₄O₆ (g/mol).
pub const BILIRUBIN_G_PER_MOL: f64 = 584.66;

/// β-carotene molar extinction (M⁻¹cm⁻¹) at 380, 390, …, 780 nm.
pub const BETA_CAROTENE_EXTINCTION_10NM: [f64; 41] = [
    30419.0, 41534.0, 59526.0, 73148.0, 96950.0, 107379.0, 120529.0, 138968.0, 120959.0, 108469.0,
    110025.0, 76354.0, 33161.0, 10308.0, 3283.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
];

/// Bilirubin molar extinction (M⁻¹cm⁻¹) at 380, 390, …, 780 nm.
pub const BILIRUBIN_EXTINCTION_10NM: [f64; 41] = [
    11579.0, 16396.0, 23212.0, 30835.0, 39312.0, 46843.0, 52060.0, 54784.0, 53851.0, 46109.0,
    29682.0, 14046.0, 4745.0, 1314.0, 349.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
];

/// An extinction table at `lambda_nm`, linear between the 10 nm nodes (0 outside 380–780 nm).
pub fn at(table: &[f64; 41], lambda_nm: f64) -> f64 {
    let x = (lambda_nm - 380.0) / 10.0;
    if !(0.0..=40.0).contains(&x) {
        return 0.0;
    }
    let i = (x.floor() as usize).min(39);
    let f = x - i as f64;
    table[i] * (1.0 - f) + table[i + 1] * f
}

/// The yellow pigments' concentrations (g/L), a parameter of the skin specimen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YellowPigments {
    /// β-carotene in the stratum corneum and the epidermis.
    pub carotene_epidermis_g_per_l: f64,
    /// β-carotene in the dermis' tissue.
    pub carotene_dermis_g_per_l: f64,
    /// Bilirubin in whole blood.
    pub bilirubin_blood_g_per_l: f64,
}

impl Default for YellowPigments {
    fn default() -> Self {
        Self::BIOSPEC
    }
}

impl YellowPigments {
    /// [`YellowPigments::NONE`], the serde default of files written before these pigments.
    pub fn none() -> YellowPigments {
        YellowPigments::NONE
    }

    /// BioSpec's baselines (see the module comment).
    pub const BIOSPEC: YellowPigments = YellowPigments {
        carotene_epidermis_g_per_l: 2.1e-4,
        carotene_dermis_g_per_l: 7e-5,
        bilirubin_blood_g_per_l: 0.05,
    };

    /// None at all: the specimen of derma's tables before these pigments were added.
    pub const NONE: YellowPigments = YellowPigments {
        carotene_epidermis_g_per_l: 0.0,
        carotene_dermis_g_per_l: 0.0,
        bilirubin_blood_g_per_l: 0.0,
    };

    /// Absorption (mm⁻¹) β-carotene adds to the stratum corneum and the epidermis.
    pub fn epidermis(&self, lambda_nm: f64) -> f64 {
        molar_absorption(
            at(&BETA_CAROTENE_EXTINCTION_10NM, lambda_nm),
            self.carotene_epidermis_g_per_l,
            BETA_CAROTENE_G_PER_MOL,
        )
    }

    /// Absorption (mm⁻¹) β-carotene adds to bloodless dermis.
    pub fn dermis(&self, lambda_nm: f64) -> f64 {
        molar_absorption(
            at(&BETA_CAROTENE_EXTINCTION_10NM, lambda_nm),
            self.carotene_dermis_g_per_l,
            BETA_CAROTENE_G_PER_MOL,
        )
    }

    /// Absorption (mm⁻¹) bilirubin adds to whole blood.
    pub fn blood(&self, lambda_nm: f64) -> f64 {
        molar_absorption(
            at(&BILIRUBIN_EXTINCTION_10NM, lambda_nm),
            self.bilirubin_blood_g_per_l,
            BILIRUBIN_G_PER_MOL,
        )
    }

    /// Each concentration finite and in [0, 100] g/L (whole blood holds 150 g/L of hemoglobin;
    /// no pigment here comes near it).
    pub fn validate(&self) -> crate::Result<()> {
        for (name, v) in [
            (
                "carotene_epidermis_g_per_l",
                self.carotene_epidermis_g_per_l,
            ),
            ("carotene_dermis_g_per_l", self.carotene_dermis_g_per_l),
            ("bilirubin_blood_g_per_l", self.bilirubin_blood_g_per_l),
        ] {
            if !(0.0..=100.0).contains(&v) {
                return Err(crate::OpticsError::Invalid(derma_core::Invalid::new(
                    format!("yellow pigment {name}"),
                    "a concentration in 0–100 g/L",
                    format!("{v} g/L"),
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_match_the_scaled_literature_values() {
        // The tables peak near 450 nm at the cited molar extinctions (within the ±0.5 nm mean).
        let c = at(&BETA_CAROTENE_EXTINCTION_10NM, 450.0);
        assert!((c - 139_500.0).abs() < 1_500.0, "{c}");
        let b = at(&BILIRUBIN_EXTINCTION_10NM, 450.0);
        assert!((b - 55_000.0).abs() < 1_000.0, "{b}");
        // Yellow pigments: nothing left in the red.
        assert_eq!(at(&BETA_CAROTENE_EXTINCTION_10NM, 600.0), 0.0);
        assert_eq!(at(&BILIRUBIN_EXTINCTION_10NM, 650.0), 0.0);
    }

    #[test]
    fn absorption_at_biospec_baselines_matches_the_module_figures() {
        // Bilirubin 0.05 g/L in whole blood at 450 nm: ln10 · 54 784 · 0.05 / 584.66 / 10.
        let y = YellowPigments::BIOSPEC;
        let want = std::f64::consts::LN_10 * 54_784.0 * 0.05 / 584.66 / 10.0;
        assert!((y.blood(450.0) - want).abs() < 1e-12);
        assert!((y.blood(450.0) - 1.08).abs() < 0.01);
        assert!((y.epidermis(450.0) - 0.0125).abs() < 0.0005);
        assert_eq!(YellowPigments::NONE.blood(450.0), 0.0);
        assert!(YellowPigments {
            bilirubin_blood_g_per_l: -1.0,
            ..y
        }
        .validate()
        .is_err());
    }
}
