//! The four-layer skin specimen of BioSpec (thesis §2.1, §4.4; Krishnaswamy & Baranoski 2004):
//! air, stratum corneum, epidermis, papillary and reticular dermis over a white hypodermis.

use crate::bio::BioTexel;
use crate::chromophore;
use crate::layer::{Bottom, Layer, Stack, Surface, N_ABSORBERS};
use crate::microfacet::BIOSPEC_FOLD_ASPECT;
use crate::yellow_pigments::YellowPigments;
use derma_core::color::{wavelength_nm, N_WAVELENGTHS};
use serde::{Deserialize, Serialize};

/// Refractive indices of stratum corneum, epidermis, papillary and reticular dermis: 1.55,
/// 1.4, 1.36, 1.38 (BioSpec defaults, Krishnaswamy & Baranoski 2004, as used by RISE).
pub const LAYER_INDEX: [f64; 4] = [1.55, 1.4, 1.36, 1.38];
/// Papillary and reticular dermis thickness: 0.2 mm and 1.8 mm (BioSpec defaults).
pub const DERMIS_MM: [f64; 2] = [0.2, 1.8];
/// Blood volume fractions of BioSpec's papillary (1.2 %) and reticular (0.91 %) dermis. The
/// painted blood ratio p_b is the papillary value; the reticular dermis keeps BioSpec's ratio.
pub const RETICULAR_BLOOD_PER_PAPILLARY: f64 = 0.91 / 1.2;
/// Henyey–Greenstein anisotropy of stratum corneum and epidermis, 0.917 and 0.781: the
/// alternative to Bruls & van der Leun's (1984) measured phase functions that BioSpec's author
/// lists.
pub const G_STRATUM_CORNEUM: f64 = 0.917;
/// See [`G_STRATUM_CORNEUM`].
pub const G_EPIDERMIS: f64 = 0.781;

/// Dermal anisotropy g(λ) = 0.62 + 0.29·10⁻³ λ (λ in nm; van Gemert, Jacques, Sterenborg & Star
/// 1989, "Skin optics", IEEE TBME 36(12), fit to dermis data 300–1300 nm).
pub fn dermis_g(lambda_nm: f64) -> f64 {
    0.62 + 0.29e-3 * lambda_nm
}

/// Which absorber each tallied class is (indices into [`crate::layer::ABSORBER_NAMES`]).
const EU: usize = 0;
const PHEO: usize = 1;
const HBO2: usize = 2;
const HB: usize = 3;
const BASE: usize = 4;

/// Layer names, top first.
pub const SKIN_LAYER_NAMES: [&str; 4] = [
    "stratum corneum",
    "epidermis",
    "papillary dermis",
    "reticular dermis",
];

fn layer_from_parts(
    thickness_mm: f64,
    parts: [f64; N_ABSORBERS],
    reduced_scattering: f64,
    g: f64,
    n: f64,
) -> Layer {
    let mua: f64 = parts.iter().sum();
    let absorber_share = if mua > 0.0 {
        parts.map(|p| p / mua)
    } else {
        [0.0; N_ABSORBERS]
    };
    Layer {
        thickness_mm,
        mua,
        // Reduced scattering σs′ = μs (1 − g) (Donner & Jensen give σs′).
        mus: reduced_scattering / (1.0 - g),
        g,
        n,
        absorber_share,
    }
}

/// The skin stack at wavelength `lambda_nm`. Absorption and reduced scattering follow Donner &
/// Jensen 2006 (the same spectra as the analytic appearance model, so both agree on the
/// biology): the stratum corneum has no melanin (thesis §2.1) and baseline absorption only; the
/// epidermis mixes melanosomes (volume fraction p_m, eu/pheomelanin by p_p) with baseline
/// tissue; the dermis mixes whole blood (p_b, oxygenation p_o) with baseline tissue. The stratum
/// corneum scatters like the epidermis (Donner & Jensen give one epidermal σs′). BioSpec's
/// yellow pigments (`yellow`) add β-carotene to every layer's tissue and bilirubin to the blood;
/// their absorbed energy is tallied with the baseline tissue's.
pub fn skin_stack(
    bio: &BioTexel,
    yellow: &YellowPigments,
    lambda_nm: f64,
    blood_oxy_deoxy: [f64; 2],
) -> Stack {
    skin_stack_with_epidermal_blood(bio, yellow, 0.0, lambda_nm, blood_oxy_deoxy)
}

/// [`skin_stack`] with whole blood also in the living epidermis, volume fraction
/// `epidermal_blood` (the two-layer model of Donner et al. 2008 and Jimenez et al. 2010 §6,
/// table 1, has epidermal hemoglobin C_he; it displaces baseline tissue like melanin does).
pub fn skin_stack_with_epidermal_blood(
    bio: &BioTexel,
    yellow: &YellowPigments,
    epidermal_blood: f64,
    lambda_nm: f64,
    blood_oxy_deoxy: [f64; 2],
) -> Stack {
    let pm = bio.melanin as f64;
    let pp = bio.pheomelanin as f64;
    let pb = bio.blood as f64;
    let po = bio.oxygenation as f64;
    let base = chromophore::baseline(lambda_nm);
    let sp_epi = chromophore::epidermis_reduced_scattering(lambda_nm);
    let sp_derm = chromophore::dermis_reduced_scattering(lambda_nm);
    let g_derm = dermis_g(lambda_nm);
    let carotene_epi = yellow.epidermis(lambda_nm);
    let carotene_derm = yellow.dermis(lambda_nm);
    let bilirubin = yellow.blood(lambda_nm);

    let mut sc = [0.0; N_ABSORBERS];
    sc[BASE] = base + carotene_epi;
    let mut epi = [0.0; N_ABSORBERS];
    epi[EU] = pm * (1.0 - pp) * chromophore::eumelanin(lambda_nm);
    epi[PHEO] = pm * pp * chromophore::pheomelanin(lambda_nm);
    epi[HBO2] = epidermal_blood * po * blood_oxy_deoxy[0];
    epi[HB] = epidermal_blood * (1.0 - po) * blood_oxy_deoxy[1];
    epi[BASE] = (1.0 - pm - epidermal_blood).max(0.0) * base + carotene_epi;
    let dermis = |blood: f64| {
        let mut d = [0.0; N_ABSORBERS];
        d[HBO2] = blood * po * blood_oxy_deoxy[0];
        d[HB] = blood * (1.0 - po) * blood_oxy_deoxy[1];
        d[BASE] = (1.0 - blood) * base + carotene_derm + blood * bilirubin;
        d
    };
    let layers = vec![
        layer_from_parts(
            bio.stratum_corneum_um as f64 * 1e-3,
            sc,
            sp_epi,
            G_STRATUM_CORNEUM,
            LAYER_INDEX[0],
        ),
        layer_from_parts(
            bio.epidermis_um as f64 * 1e-3,
            epi,
            sp_epi,
            G_EPIDERMIS,
            LAYER_INDEX[1],
        ),
        layer_from_parts(DERMIS_MM[0], dermis(pb), sp_derm, g_derm, LAYER_INDEX[2]),
        layer_from_parts(
            DERMIS_MM[1],
            dermis(pb * RETICULAR_BLOOD_PER_PAPILLARY),
            sp_derm,
            g_derm,
            LAYER_INDEX[3],
        ),
    ];
    Stack {
        layers,
        n_above: 1.0,
        // The white, diffusely reflecting hypodermis (thesis §2.1).
        bottom: Bottom::Lambertian { albedo: 1.0 },
        surface: SurfaceModel::default().surface(),
    }
}

/// How the skin's surface folds (BioSpec's Trowbridge–Reitz micro-facets, aspect 0.75) meet
/// light: as a Smith microsurface (the default) or as the thesis samples them (§4.5.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceModel {
    /// GGX normals of α = 0.75 sampled by visible area, Smith shadowing and masking, the
    /// masked light scattered again (Heitz 2018; Heitz et al. 2016): energy conserving.
    #[default]
    Smith,
    /// The thesis' and BioSpec's sampling: no shadowing or masking, normals not weighted by
    /// visible area; light leaving the skin piles up at grazing angles. For comparison.
    Thesis,
}

impl SurfaceModel {
    /// The surface of the skin stack.
    pub fn surface(self) -> Surface {
        match self {
            SurfaceModel::Smith => Surface::Smith {
                alpha: BIOSPEC_FOLD_ASPECT,
            },
            SurfaceModel::Thesis => Surface::TrowbridgeReitz {
                sigma: BIOSPEC_FOLD_ASPECT,
            },
        }
    }

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SurfaceModel::Smith => "smith",
            SurfaceModel::Thesis => "thesis",
        }
    }
}

impl std::str::FromStr for SurfaceModel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "smith" => Ok(SurfaceModel::Smith),
            "thesis" => Ok(SurfaceModel::Thesis),
            _ => Err(format!("surface '{s}': expected smith or thesis")),
        }
    }
}

/// The skin stack on derma's 10 nm grid, 380–780 nm.
pub fn skin_stacks(bio: &BioTexel, yellow: &YellowPigments) -> Vec<Stack> {
    skin_stacks_with_epidermal_blood(bio, yellow, 0.0)
}

/// [`skin_stacks`] with epidermal blood (see [`skin_stack_with_epidermal_blood`]).
pub fn skin_stacks_with_epidermal_blood(
    bio: &BioTexel,
    yellow: &YellowPigments,
    epidermal_blood: f64,
) -> Vec<Stack> {
    (0..N_WAVELENGTHS)
        .map(|i| {
            let blood = [chromophore::blood(i, 1.0), chromophore::blood(i, 0.0)];
            skin_stack_with_epidermal_blood(bio, yellow, epidermal_blood, wavelength_nm(i), blood)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skin_stack_is_valid_and_blood_sits_in_the_dermis() {
        let stacks = skin_stacks(&BioTexel::FAIR, &YellowPigments::NONE);
        assert_eq!(stacks.len(), N_WAVELENGTHS);
        for s in &stacks {
            s.validate().unwrap();
            assert_eq!(s.layers[0].absorber_share[HBO2], 0.0);
            assert_eq!(s.layers[0].absorber_share[EU], 0.0);
            assert!(s.layers[2].absorber_share[HBO2] > 0.0);
            for l in &s.layers {
                let sum: f64 = l.absorber_share.iter().sum();
                assert!((sum - 1.0).abs() < 1e-12);
            }
        }
        // 550 nm: epidermis μa = 0.02·(0.7·49.4 + 0.3·27.9) + 0.98·0.046 ≈ 0.904 mm⁻¹.
        let s = &stacks[17];
        assert!(
            (s.layers[1].mua - 0.904).abs() < 0.01,
            "{}",
            s.layers[1].mua
        );
        // Reticular dermis holds 0.91/1.2 of the papillary blood.
        let r = s.layers[3].mua - s.layers[3].absorber_share[BASE] * s.layers[3].mua;
        let p = s.layers[2].mua - s.layers[2].absorber_share[BASE] * s.layers[2].mua;
        assert!((r / p - 0.91 / 1.2).abs() < 1e-9);
        // van Gemert's dermal g at 550 nm: 0.62 + 0.1595.
        assert!((s.layers[2].g - 0.7795).abs() < 1e-9);
    }

    #[test]
    fn yellow_pigments_add_blue_absorption_to_tissue_and_blood_only() {
        let bio = BioTexel::FAIR;
        let y = YellowPigments::BIOSPEC;
        let blood = |l: f64| {
            let i = ((l - 380.0) / 10.0) as usize;
            [chromophore::blood(i, 1.0), chromophore::blood(i, 0.0)]
        };
        let with = skin_stack(&bio, &y, 450.0, blood(450.0));
        let without = skin_stack(&bio, &YellowPigments::NONE, 450.0, blood(450.0));
        let pb = bio.blood as f64;
        let d = with.layers[2].mua - without.layers[2].mua;
        assert!(
            (d - (y.dermis(450.0) + pb * y.blood(450.0))).abs() < 1e-12,
            "{d}"
        );
        let e = with.layers[1].mua - without.layers[1].mua;
        assert!((e - y.epidermis(450.0)).abs() < 1e-12);
        // The melanin and blood shares keep their absolute absorption.
        let eu = |s: &Stack| s.layers[1].absorber_share[EU] * s.layers[1].mua;
        assert!((eu(&with) - eu(&without)).abs() < 1e-12);
        // Nothing changes in the red.
        let r = skin_stack(&bio, &y, 650.0, blood(650.0));
        let r0 = skin_stack(&bio, &YellowPigments::NONE, 650.0, blood(650.0));
        for k in 0..4 {
            assert_eq!(r.layers[k].mua, r0.layers[k].mua);
        }
    }
}
