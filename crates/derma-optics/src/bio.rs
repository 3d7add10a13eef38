//! The biological parameters of a patch of skin (thesis §5.2): what derma paints per texel and
//! what the optics simulate; the fair-skin defaults follow BioSpec (Krishnaswamy & Baranoski 2004).

use serde::{Deserialize, Serialize};

/// The names of the bio parameters, as fields, table axes, EXR channels and config keys.
pub mod names {
    /// Melanosome volume fraction of the epidermis.
    pub const MELANIN: &str = "melanin";
    /// Pheomelanin share of the melanin.
    pub const PHEOMELANIN: &str = "pheomelanin";
    /// Whole-blood volume fraction of the dermis.
    pub const BLOOD: &str = "blood";
    /// Oxygenated share of the hemoglobin.
    pub const OXYGENATION: &str = "oxygenation";
    /// Stratum corneum thickness (µm).
    pub const STRATUM_CORNEUM_UM: &str = "stratum_corneum_um";
    /// Living epidermis thickness (µm).
    pub const EPIDERMIS_UM: &str = "epidermis_um";
    /// The channel of a hemoglobin map (`hemoglobin.exr`, the rig's maps): the dermal blood
    /// volume fraction, called hemoglobin as in Jimenez et al. 2010.
    pub const HEMOGLOBIN: &str = "hemoglobin";
}

/// The bio parameters of one texel that determine its colour (thesis §5.2, with the thesis'
/// cm thicknesses expressed in micrometres as derma's configs are). `repr(C)`: six f32 in field
/// order (derma-skin's samples are viewed as float arrays by derma-py).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[repr(C)]
pub struct BioTexel {
    /// Melanosome volume fraction of the epidermis, p_m ∈ [0, 1].
    pub melanin: f32,
    /// Pheomelanin share of the melanin, p_p ∈ [0, 1] (0 = eumelanin only).
    pub pheomelanin: f32,
    /// Whole-blood volume fraction of the dermis, p_b ∈ [0, 1].
    pub blood: f32,
    /// Oxygenated share of the hemoglobin, p_o ∈ [0, 1].
    pub oxygenation: f32,
    /// Stratum corneum thickness p_SCT in µm.
    pub stratum_corneum_um: f32,
    /// Living epidermis thickness p_ET in µm.
    pub epidermis_um: f32,
}

impl BioTexel {
    /// A texel from its fields in the order of [`Self::to_array`].
    pub fn from_array(v: [f32; 6]) -> Self {
        Self {
            melanin: v[0],
            pheomelanin: v[1],
            blood: v[2],
            oxygenation: v[3],
            stratum_corneum_um: v[4],
            epidermis_um: v[5],
        }
    }

    /// The fields in the order of the precompute grid's axes (`precompute::AXES`).
    #[inline]
    pub fn to_array(&self) -> [f32; 6] {
        [
            self.melanin,
            self.pheomelanin,
            self.blood,
            self.oxygenation,
            self.stratum_corneum_um,
            self.epidermis_um,
        ]
    }

    /// The names of the fields, in the order of [`Self::to_array`] (the precompute grid's axes,
    /// bio.exr's channels and the config's keys use them).
    pub const NAMES: [&'static str; 6] = [
        names::MELANIN,
        names::PHEOMELANIN,
        names::BLOOD,
        names::OXYGENATION,
        names::STRATUM_CORNEUM_UM,
        names::EPIDERMIS_UM,
    ];

    /// Checks that every fraction lies in [0, 1] and every thickness in (0, 2000] µm; the
    /// error names the field and its value.
    pub fn validate(&self) -> crate::Result<()> {
        let v = self.to_array();
        for (i, (&name, &x)) in Self::NAMES.iter().zip(&v).enumerate() {
            let ok = if i < 4 {
                (0.0..=1.0).contains(&x)
            } else {
                x.is_finite() && x > 0.0 && x <= 2000.0
            };
            if !ok {
                let want = if i < 4 {
                    "a fraction in [0, 1]"
                } else {
                    "a thickness in (0, 2000] µm"
                };
                return Err(crate::OpticsError::Invalid(derma_core::Invalid::new(
                    name, want, x,
                )));
            }
        }
        Ok(())
    }

    /// Typical fair adult facial skin: BioSpec defaults (Krishnaswamy & Baranoski 2004, as used by
    /// the RISE renderer): melanosomes 10 % of the epidermis would be dark skin, so the fair value
    /// 2 % from Jacques 1998 ("skin optics summary": 1.3–6.3 % for light-skinned adults) is used;
    /// blood 1.2 % (BioSpec papillary dermis), oxygenation 0.75, SC 10 µm, epidermis 100 µm.
    pub const FAIR: BioTexel = BioTexel {
        melanin: 0.02,
        pheomelanin: 0.3,
        blood: 0.012,
        oxygenation: 0.75,
        stratum_corneum_um: 10.0,
        epidermis_um: 100.0,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_the_field() {
        BioTexel::FAIR.validate().unwrap();
        let e = BioTexel {
            melanin: 1.5,
            ..BioTexel::FAIR
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("melanin: expected a fraction in [0, 1], got 1.5"),
            "{e}"
        );
        let e = BioTexel {
            epidermis_um: 0.0,
            ..BioTexel::FAIR
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("epidermis_um: ") && e.contains("got 0"), "{e}");
        assert!(BioTexel {
            blood: f32::NAN,
            ..BioTexel::FAIR
        }
        .validate()
        .is_err());
    }
}
