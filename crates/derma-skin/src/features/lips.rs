//! Lips (thesis §5.3.6): p_b = B·∆(p), p_p = H·∆(p) with ∆ the lip field. Read literally that
//! would zero the blood outside the lips; we blend towards the lip values by ∆,
//! x ← x + (X − x)·∆, which equals the thesis where ∆ = 1. The thin vermilion epidermis is blended
//! the same way, and ∆ is kept as the lip mask for the material stage.

use super::BioSample;

/// Lip values B, H and epidermis thickness.
pub struct LipParams {
    /// Blood ratio B inside the lips.
    pub blood: f32,
    /// Pheomelanin ratio H inside the lips.
    pub pheomelanin: f32,
    /// Epidermis thickness inside the lips, µm.
    pub epidermis_um: f32,
}

#[inline]
/// Blends the lip parameters into `s` by the lip field value ∆(p) (thesis §5.3.6) and records it for the material stage.
pub fn apply_lips(prm: &LipParams, field: f32, s: &mut BioSample) {
    if field <= 0.0 {
        return;
    }
    let f = field.min(1.0);
    s.tissue.blood += (prm.blood - s.tissue.blood) * f;
    s.tissue.pheomelanin += (prm.pheomelanin - s.tissue.pheomelanin) * f;
    s.tissue.epidermis_um += (prm.epidermis_um - s.tissue.epidermis_um) * f;
    s.lips = f;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_field_gives_the_thesis_values() {
        let prm = LipParams {
            blood: 0.08,
            pheomelanin: 0.6,
            epidermis_um: 40.0,
        };
        let mut s = BioSample {
            tissue: derma_shading::BioTexel {
                blood: 0.01,
                pheomelanin: 0.3,
                epidermis_um: 80.0,
                ..Default::default()
            },
            ..Default::default()
        };
        apply_lips(&prm, 1.0, &mut s);
        assert_eq!(
            (
                s.tissue.blood,
                s.tissue.pheomelanin,
                s.tissue.epidermis_um,
                s.lips
            ),
            (0.08, 0.6, 40.0, 1.0)
        );
        let mut s = BioSample {
            tissue: derma_shading::BioTexel {
                blood: 0.01,
                ..Default::default()
            },
            ..Default::default()
        };
        apply_lips(&prm, 0.5, &mut s);
        assert!((s.tissue.blood - 0.045).abs() < 1e-7);
    }
}
