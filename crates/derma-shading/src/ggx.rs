//! The glTF 2.0 metallic-roughness BRDF for a dielectric with `KHR_materials_specular`: Lambert
//! diffuse and a GGX/Trowbridge–Reitz microfacet lobe (Walter et al. 2007) mixed by Schlick's
//! Fresnel (glTF 2.0 specification, Appendix B; KHR_materials_specular, "Implementation").
//!
//! f = (1 − F) · kd/π + F · D · V, with F = F0 + (1 − F0)(1 − h·l)⁵, α = roughness². F0 is
//! 0.04 × `specularColorFactor` for glTF's default ior 1.5, so F0 ↔ the extension's factor.

use crate::microfacet_terms::{ggx_d, ggx_smith_visibility, schlick};
use crate::render_model::{Basis, Dirs, RenderModel, ShapeParam};
use std::f64::consts::FRAC_1_PI;

/// glTF's GGX with `KHR_materials_specular` (module docs).
pub struct GltfGgx;

const SHAPE: [ShapeParam; 2] = [
    // glTF roughness r (α = r²).
    ShapeParam {
        name: "roughness",
        lo: 0.05,
        hi: 1.0,
        log: false,
    },
    ShapeParam {
        name: "f0",
        lo: 0.0,
        hi: 0.2,
        log: false,
    },
];

impl RenderModel for GltfGgx {
    fn name(&self) -> &'static str {
        "ggx"
    }
    fn shape(&self) -> &'static [ShapeParam] {
        &SHAPE
    }
    fn lobes(&self) -> &'static [(&'static str, f64)] {
        &[]
    }
    #[inline]
    fn basis(&self, theta: &[f64], d: &Dirs) -> Basis {
        let alpha = theta[0] * theta[0];
        let f = schlick(theta[1], d.h_l);
        Basis {
            offset: f * ggx_d(d.n_h, alpha) * ggx_smith_visibility(d.n_l, d.n_v, alpha),
            diffuse: (1.0 - f) * FRAC_1_PI,
            lobes: [0.0; 3],
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
        let p = [0.6, 0.4, 0.3, 0.5, 0.04];
        assert_reciprocal(&GltfGgx, &p);
        // White diffuse, F0 = 0.04: the glTF mix weights the diffuse by 1 − F(h·l) per half
        // vector, not by 1 − (the lobe's directional albedo), so it is energy conserving only
        // to within about 1 % (the specification calls the mix an approximation).
        let w = [1.0, 1.0, 1.0, 0.5, 0.04];
        for ti in [0.0, 0.5, 1.0] {
            let a = albedo(&GltfGgx, &w, ti);
            assert!(a[0] <= 1.01 && a[0] > 0.8, "θi={ti}: {a:?}");
        }
        // …and overshoots at grazing incidence (80°: ≈ 1.08), where Schlick's F(h·l) is large
        // for the mirror half vectors but small for the rest.
        let a = albedo(&GltfGgx, &w, 1.4);
        assert!(a[0] > 1.0 && a[0] < 1.1, "{a:?}");
    }

    #[test]
    fn closed_form_at_normal_incidence() {
        // l = v = n: h·l = 1 → F = F0; D = 1/(π α²); V = 1/4.
        let (r, f0, kd) = (0.5f64, 0.04, 0.5);
        let a = r * r;
        let want =
            (1.0 - f0) * kd / std::f64::consts::PI + f0 / (std::f64::consts::PI * a * a) / 4.0;
        let got = eval(
            &GltfGgx,
            &[kd, kd, kd, r, f0],
            &Dirs::from_angles(0.0, 0.0, 0.0),
        );
        assert!((got[0] - want).abs() < 1e-12, "{got:?} vs {want}");
    }
}
