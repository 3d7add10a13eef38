//! Absorption and scattering spectra of the skin's chromophores and tissues (mm⁻¹, λ in nm), as
//! used by Donner & Jensen 2006 ("A spectral BSSRDF for shading human skin", EGSR) and Jacques.

use crate::hemoglobin_table::HEMOGLOBIN_EXTINCTION_10NM;
use derma_core::color::N_WAVELENGTHS;

/// Eumelanin absorption σa,eu = 6.6·10¹⁰ λ^−3.33 mm⁻¹ (Donner & Jensen 2006 eq. 1, after Jacques).
pub fn eumelanin(lambda_nm: f64) -> f64 {
    6.6e10 * lambda_nm.powf(-3.33)
}

/// Pheomelanin absorption σa,pheo = 2.9·10¹⁴ λ^−4.75 mm⁻¹ (Donner & Jensen 2006 eq. 2).
pub fn pheomelanin(lambda_nm: f64) -> f64 {
    2.9e14 * lambda_nm.powf(-4.75)
}

/// Baseline (bloodless, melanin-free) tissue absorption 0.0244 + 8.53 exp(−(λ−154)/66.2) mm⁻¹
/// (Jacques 1998, OMLC "skin optics summary"; Donner & Jensen 2006 eq. 3).
pub fn baseline(lambda_nm: f64) -> f64 {
    0.0244 + 8.53 * (-(lambda_nm - 154.0) / 66.2).exp()
}

/// Hemoglobin concentration of whole blood, 150 g/L (Prahl, OMLC; BioSpec default).
pub const HEMOGLOBIN_G_PER_L: f64 = 150.0;
/// Molar mass of hemoglobin, 64 500 g/mol (Prahl, OMLC "Optical absorption of hemoglobin").
pub const HEMOGLOBIN_G_PER_MOL: f64 = 64_500.0;

/// Absorption (mm⁻¹) of a chromophore of molar extinction `epsilon` (M⁻¹cm⁻¹) at `g_per_l`
/// and molar mass `g_per_mol`: μa = ln(10) ε C / M (Prahl, OMLC), converted cm⁻¹ → mm⁻¹.
pub fn molar_absorption(epsilon: f64, g_per_l: f64, g_per_mol: f64) -> f64 {
    std::f64::consts::LN_10 * epsilon * g_per_l / g_per_mol / 10.0
}

/// Absorption of whole blood at grid sample `i` with oxygen saturation `oxygenation`
/// ([`molar_absorption`] of the tabulated molar extinction).
pub fn blood(i: usize, oxygenation: f64) -> f64 {
    let [e_oxy, e_deoxy] = HEMOGLOBIN_EXTINCTION_10NM[i];
    let e = oxygenation * e_oxy + (1.0 - oxygenation) * e_deoxy;
    molar_absorption(e, HEMOGLOBIN_G_PER_L, HEMOGLOBIN_G_PER_MOL)
}

/// Reduced scattering of the epidermis σs′ = 14.74 λ^−0.22 + 2.2·10¹¹ λ^−4 mm⁻¹ (Donner & Jensen
/// 2006 eq. 4, Mie + Rayleigh). The dermis scatters half as much (same paper, §4).
pub fn epidermis_reduced_scattering(lambda_nm: f64) -> f64 {
    14.74 * lambda_nm.powf(-0.22) + 2.2e11 * lambda_nm.powi(-4)
}

/// Dermis reduced scattering: half the epidermal value (Donner & Jensen 2006, §4).
pub fn dermis_reduced_scattering(lambda_nm: f64) -> f64 {
    0.5 * epidermis_reduced_scattering(lambda_nm)
}

/// Samples a function of wavelength on derma's 10 nm grid.
pub fn on_grid(f: impl Fn(f64) -> f64) -> [f64; N_WAVELENGTHS] {
    std::array::from_fn(|i| f(derma_core::color::wavelength_nm(i)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_values_at_550nm_match_donner_jensen() {
        // Reference values at 550 nm (mm⁻¹): eumelanin 49.4, pheomelanin 27.9, baseline 0.046,
        // σs′ 6.08 (Donner & Jensen 2006 formulas evaluated; see SKIN-OPTICS-REFERENCES).
        assert!((eumelanin(550.0) - 49.4).abs() < 0.2);
        assert!((pheomelanin(550.0) - 27.9).abs() < 0.2);
        assert!((baseline(550.0) - 0.046).abs() < 0.002);
        assert!((epidermis_reduced_scattering(550.0) - 6.08).abs() < 0.05);
    }

    #[test]
    fn blood_has_soret_and_q_bands() {
        // Oxy-hemoglobin: Soret peak at 410–420 nm, Q bands at 540 and 580 nm with a dip at 560;
        // absorption in the red (650 nm) two orders of magnitude lower than in the green.
        let idx = |nm: usize| (nm - 380) / 10;
        let b = |nm| blood(idx(nm), 1.0);
        assert!(b(410) > b(380) && b(410) > b(450));
        assert!(b(540) > b(560) && b(580) > b(560));
        assert!(b(540) / b(650) > 50.0);
        // Prahl: ε_HbO2(540 nm) = 53 236 → μa = 2.303·53236·150/64500 = 285 cm⁻¹ = 28.5 mm⁻¹.
        assert!((b(540) - 28.5).abs() < 0.1);
        // Deoxy absorbs more than oxy in the red (the colour of venous blood).
        assert!(blood(idx(650), 0.0) > 5.0 * blood(idx(650), 1.0));
    }
}
