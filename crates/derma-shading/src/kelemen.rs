//! The Kelemen & Szirmay-Kalos (2001) specular BRDF ("A microfacet based coupled specular-matte
//! BRDF model with importance sampling", Eurographics short papers) as used for skin by d'Eon &
//! Luebke 2007 (GPU Gems 3, ch. 14) and Jimenez et al. 2010: f = kd/π + ρs · D_Beckmann(m) · F /
//! |l + v|², with |l + v|² = 4 (h·l)² replacing Cook–Torrance's G/(n·l n·v), F Schlick with
//! F0 = 0.028 (d'Eon & Luebke 2007, §14.3: skin's index 1.4).

use crate::microfacet_terms::{beckmann_d, schlick};
use crate::render_model::{Basis, Dirs, RenderModel, ShapeParam};
use std::f64::consts::FRAC_1_PI;

/// F0 of skin in the Kelemen model: 0.028 (d'Eon & Luebke 2007, §14.3).
pub const SKIN_F0: f64 = 0.028;

/// The Kelemen & Szirmay-Kalos model (module docs).
pub struct KelemenSzirmayKalos;

const SHAPE: [ShapeParam; 1] = [ShapeParam {
    name: "m",
    lo: 0.05,
    hi: 1.0,
    log: false,
}];

impl RenderModel for KelemenSzirmayKalos {
    fn name(&self) -> &'static str {
        "kelemen"
    }
    fn shape(&self) -> &'static [ShapeParam] {
        &SHAPE
    }
    fn lobes(&self) -> &'static [(&'static str, f64)] {
        &[("rho_s", 10.0)]
    }
    #[inline]
    fn basis(&self, theta: &[f64], d: &Dirs) -> Basis {
        if d.n_l <= 0.0 || d.n_v <= 0.0 {
            return Basis::default();
        }
        let hl2 = (d.h_l * d.h_l).max(1e-12);
        Basis {
            offset: 0.0,
            diffuse: FRAC_1_PI,
            lobes: [
                beckmann_d(d.n_h, theta[0]) * schlick(SKIN_F0, d.h_l) / (4.0 * hl2),
                0.0,
                0.0,
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render_model::checks::{albedo, assert_reciprocal};
    use crate::render_model::eval;

    #[test]
    fn reciprocal_and_energy_bounded() {
        assert_reciprocal(&KelemenSzirmayKalos, &[0.5, 0.4, 0.3, 1.0, 0.3]);
        // d'Eon & Luebke's skin values (m = 0.3, ρs = 0.18): the specular lobe alone reflects
        // well under 10 % at any incidence; a white diffuse part adds exactly 1.
        for ti in [0.0, 0.7, 1.3] {
            let s = albedo(&KelemenSzirmayKalos, &[0.0, 0.0, 0.0, 0.18, 0.3], ti);
            assert!(s[0] > 0.0 && s[0] < 0.1, "θi={ti}: {s:?}");
            let d = albedo(&KelemenSzirmayKalos, &[1.0, 1.0, 1.0, 0.0, 0.3], ti);
            assert!((d[0] - 1.0).abs() < 1e-3, "{d:?}");
        }
    }

    #[test]
    fn closed_form_at_normal_incidence() {
        // h = n, h·l = 1: ρs · 1/(π m²) · 0.028 / 4.
        let (rho, m) = (0.18, 0.3);
        let want = rho / (std::f64::consts::PI * m * m) * SKIN_F0 / 4.0;
        let got = eval(
            &KelemenSzirmayKalos,
            &[0.0, 0.0, 0.0, rho, m],
            &Dirs::from_angles(0.0, 0.0, 0.0),
        );
        assert!((got[2] - want).abs() < 1e-12);
    }
}
