//! The biological parameters of a patch of skin (thesis §5.2): what derma paints per texel and
//! what the optics simulate; the fair-skin defaults follow BioSpec (Krishnaswamy & Baranoski 2004).

use serde::{Deserialize, Serialize};

/// The bio parameters of one texel that determine its colour (thesis §5.2, with the thesis'
/// cm thicknesses expressed in micrometres as derma's configs are).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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
