//! Hair colour from its melanins: a fibre's absorption from its eumelanin and pheomelanin
//! concentrations (d'Eon et al. 2011, "An energy-conserving hair reflectance model", §6.1) and
//! the colour of hair with that absorption, inverting Chiang et al. 2016 ("A practical and
//! controllable hair and fur model for production path tracing", §4.2), the mapping Blender's
//! Principled Hair BSDF uses, so a melanin here gives the colour it gives there.

use serde::{Deserialize, Serialize};

/// Absorption per unit eumelanin concentration, normalised to the fibre's cross-section (pbrt-v3's
/// convention), in linear R, G, B
/// (d'Eon et al. 2011, §6.1; pbrt-v3's `HairBSDF::SigmaAFromConcentration` uses the same).
pub const EUMELANIN_SIGMA_A: [f32; 3] = [0.419, 0.697, 1.37];
/// Absorption per unit pheomelanin concentration (d'Eon et al. 2011, §6.1).
pub const PHEOMELANIN_SIGMA_A: [f32; 3] = [0.187, 0.4, 1.05];
/// Azimuthal roughness β_N at which colour and absorption are related: 0.3, the default of
/// Chiang et al. 2016 and of Blender's Principled Hair BSDF.
pub const AZIMUTHAL_ROUGHNESS: f32 = 0.3;

/// The melanins of a hair fibre, as concentrations in the units of d'Eon et al. 2011 (pbrt-v3
/// §9.9 gives blonde ≈ 0.3, brown ≈ 1.3 and black ≈ 8 eumelanin).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HairMelanin {
    /// Eumelanin (brown–black).
    pub eumelanin: f32,
    /// Pheomelanin (red–yellow).
    pub pheomelanin: f32,
}

impl HairMelanin {
    /// σ_a = eumelanin · σ_eu + pheomelanin · σ_pheo, normalised to the fibre's cross-section.
    pub fn absorption(&self) -> [f32; 3] {
        std::array::from_fn(|k| {
            self.eumelanin.max(0.0) * EUMELANIN_SIGMA_A[k]
                + self.pheomelanin.max(0.0) * PHEOMELANIN_SIGMA_A[k]
        })
    }

    /// The hair's colour (linear RGB) at [`AZIMUTHAL_ROUGHNESS`].
    pub fn color(&self) -> [f32; 3] {
        color_of_absorption(self.absorption(), AZIMUTHAL_ROUGHNESS)
    }

    /// The hair of a person of skin tone `ita_deg` (authored; hair and skin colour vary
    /// independently in people, so this is a default that reads as plausible, not a law): light
    /// brown (0.5) at ITA 62.5°, brown (0.9) at 48°, 1.6 at 34.5°, 2.5 at 19°, 4.5 at −10°
    /// and black (8, pbrt-v3's black) at −40°, linear in ITA between; pheomelanin 0.15,
    /// a little warmth in every shade.
    pub fn for_skin_tone(ita_deg: f32) -> HairMelanin {
        const NODES: [(f32, f32); 6] = [
            (62.5, 0.5),
            (48.0, 0.9),
            (34.5, 1.6),
            (19.0, 2.5),
            (-10.0, 4.5),
            (-40.0, 8.0),
        ];
        let eumelanin = if ita_deg >= NODES[0].0 {
            NODES[0].1
        } else if ita_deg <= NODES[5].0 {
            NODES[5].1
        } else {
            let k = NODES
                .windows(2)
                .position(|w| ita_deg >= w[1].0)
                .unwrap_or(4);
            let ((a, ea), (b, eb)) = (NODES[k], NODES[k + 1]);
            ea + (eb - ea) * (a - ita_deg) / (a - b)
        };
        HairMelanin {
            eumelanin,
            pheomelanin: 0.15,
        }
    }
}

/// Chiang et al. 2016 §4.2's polynomial in the azimuthal roughness β_N:
/// 5.969 − 0.215β + 2.532β² − 10.73β³ + 5.574β⁴ + 0.245β⁵.
fn chiang_polynomial(beta_n: f32) -> f32 {
    let b = beta_n;
    5.969 - 0.215 * b + 2.532 * b * b - 10.73 * b.powi(3) + 5.574 * b.powi(4) + 0.245 * b.powi(5)
}

/// The colour whose absorption is `sigma_a`: c = exp(−√σ_a · P(β_N)), the inverse of
/// Chiang et al.'s σ_a = (ln c / P(β_N))².
pub fn color_of_absorption(sigma_a: [f32; 3], beta_n: f32) -> [f32; 3] {
    let p = chiang_polynomial(beta_n);
    sigma_a.map(|s| (-s.max(0.0).sqrt() * p).exp())
}

/// Chiang et al. 2016's absorption for a colour: σ_a = (ln c / P(β_N))².
pub fn absorption_of_color(color: [f32; 3], beta_n: f32) -> [f32; 3] {
    let p = chiang_polynomial(beta_n);
    color.map(|c| (c.clamp(1e-6, 1.0).ln() / p).powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absorption_is_linear_in_the_melanins_with_d_eon_s_coefficients() {
        let m = HairMelanin {
            eumelanin: 1.3,
            pheomelanin: 0.0,
        };
        let s = m.absorption();
        for k in 0..3 {
            assert!((s[k] - 1.3 * EUMELANIN_SIGMA_A[k]).abs() < 1e-6);
        }
        let both = HairMelanin {
            eumelanin: 1.0,
            pheomelanin: 2.0,
        }
        .absorption();
        assert!((both[1] - (0.697 + 0.8)).abs() < 1e-6);
    }

    #[test]
    fn colour_and_absorption_invert_each_other_as_chiang_states() {
        // P(0.3) = 5.888 to three decimals (the polynomial evaluated by hand).
        assert!((chiang_polynomial(0.3) - 5.888).abs() < 1e-3);
        for c in [[0.05, 0.02, 0.005], [0.6, 0.4, 0.2], [0.9, 0.9, 0.9]] {
            for beta in [0.2, 0.3, 0.8] {
                let back = color_of_absorption(absorption_of_color(c, beta), beta);
                for k in 0..3 {
                    assert!(
                        (back[k] - c[k]).abs() < 1e-4 * c[k].max(1e-3),
                        "{c:?} {beta}"
                    );
                }
            }
        }
        // No melanin: white hair; more eumelanin: darker in every channel.
        assert_eq!(
            HairMelanin {
                eumelanin: 0.0,
                pheomelanin: 0.0
            }
            .color(),
            [1.0; 3]
        );
        let (a, b) = (
            HairMelanin {
                eumelanin: 0.3,
                pheomelanin: 0.0,
            }
            .color(),
            HairMelanin {
                eumelanin: 1.3,
                pheomelanin: 0.0,
            }
            .color(),
        );
        assert!((0..3).all(|k| b[k] < a[k]));
    }

    #[test]
    fn hair_is_red_before_blue_and_pheomelanin_makes_it_redder() {
        let brown = HairMelanin {
            eumelanin: 1.3,
            pheomelanin: 0.0,
        }
        .color();
        assert!(brown[0] > brown[1] && brown[1] > brown[2], "{brown:?}");
        let red = HairMelanin {
            eumelanin: 0.3,
            pheomelanin: 3.0,
        }
        .color();
        let blonde = HairMelanin {
            eumelanin: 0.3,
            pheomelanin: 0.0,
        }
        .color();
        assert!(red[0] / red[1] > blonde[0] / blonde[1]);
    }

    #[test]
    fn darker_skin_tones_default_to_darker_hair() {
        let e: Vec<f32> = [70.0, 62.5, 55.0, 48.0, 30.0, 0.0, -40.0, -60.0]
            .map(|ita| HairMelanin::for_skin_tone(ita).eumelanin)
            .to_vec();
        assert!(e.windows(2).all(|w| w[1] >= w[0]), "{e:?}");
        assert_eq!(e[1], 0.5);
        assert!((HairMelanin::for_skin_tone(48.0).eumelanin - 0.9).abs() < 1e-6);
        assert_eq!(e[7], 8.0);
    }
}
