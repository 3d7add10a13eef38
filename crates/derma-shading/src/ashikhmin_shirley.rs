//! The Ashikhmin–Shirley BRDF (Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model",
//! J. Graphics Tools 5(2), eqs. 4–5), isotropic (n_u = n_v = n), the model the thesis matched
//! BioSpec to (thesis §6.1, §7.2).
//!
//! ρs = (n + 1)/(8π) · (n·h)ⁿ / ((h·k) max(n·k1, n·k2)) · F(k·h), F Schlick with Rs;
//! ρd = 28 Rd / (23π) · (1 − Rs) · (1 − (1 − n·k1/2)⁵)(1 − (1 − n·k2/2)⁵).

use crate::microfacet_terms::schlick;
use crate::render_model::{Basis, Dirs, RenderModel, ShapeParam};
use std::f64::consts::PI;

/// The Ashikhmin–Shirley model (module docs).
pub struct AshikhminShirley;

const SHAPE: [ShapeParam; 2] = [
    ShapeParam {
        name: "exponent",
        lo: 1.0,
        hi: 10000.0,
        log: true,
    },
    ShapeParam {
        name: "rs",
        lo: 0.0,
        hi: 1.0,
        log: false,
    },
];

#[inline]
fn pow5(x: f64) -> f64 {
    let x2 = x * x;
    x2 * x2 * x
}

impl RenderModel for AshikhminShirley {
    fn name(&self) -> &'static str {
        "ashikhmin-shirley"
    }
    fn shape(&self) -> &'static [ShapeParam] {
        &SHAPE
    }
    fn lobes(&self) -> &'static [(&'static str, f64)] {
        &[]
    }
    #[inline]
    fn basis(&self, theta: &[f64], d: &Dirs) -> Basis {
        let (n, rs) = (theta[0], theta[1]);
        if d.n_l <= 0.0 || d.n_v <= 0.0 {
            return Basis::default();
        }
        let spec = (n + 1.0) / (8.0 * PI) * d.n_h.max(0.0).powf(n)
            / (d.h_l.max(1e-12) * d.n_l.max(d.n_v))
            * schlick(rs, d.h_l);
        let diffuse = 28.0 / (23.0 * PI)
            * (1.0 - rs)
            * (1.0 - pow5(1.0 - d.n_l / 2.0))
            * (1.0 - pow5(1.0 - d.n_v / 2.0));
        Basis {
            offset: spec,
            diffuse,
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
        assert_reciprocal(&AshikhminShirley, &[0.5, 0.4, 0.3, 20.0, 0.05]);
        // The diffuse term alone (Rd = 1, Rs = 0) has the closed-form directional albedo
        // 1 − (1 − cosθi/2)⁵ (its normalisation 28/23π makes ∫ over the view exactly that):
        // ≤ 1 everywhere, as the paper's energy argument (§3) requires.
        for ti in [0.0f64, 0.6, 1.2] {
            let d = diffuse_albedo(ti);
            let want = 1.0 - (1.0 - ti.cos() / 2.0).powi(5);
            assert!((d - want).abs() < 2e-3, "θi={ti}: {d:?} vs {want}");
            let s = albedo(&AshikhminShirley, &[0.9, 0.9, 0.9, 10.0, 0.05], ti);
            assert!(s[0] <= 1.0 + 5e-3, "θi={ti}: {s:?}");
        }
    }

    /// ∫ ρd cosθo dωo for Rd = 1, Rs = 0 (the diffuse term alone; Schlick with Rs = 0 still
    /// leaves a specular (1 − k·h)⁵ part, so the full model cannot isolate it).
    fn diffuse_albedo(ti: f64) -> f64 {
        let n = 2000;
        (0..n)
            .map(|a| {
                let u = (a as f64 + 0.5) / n as f64;
                let d = Dirs::from_angles(ti, u.sqrt().asin(), 1.0);
                AshikhminShirley.basis(&[10.0, 0.0], &d).diffuse * PI / n as f64
            })
            .sum()
    }

    #[test]
    fn closed_form_at_normal_incidence() {
        // k1 = k2 = h = n: ρs = (n+1)/(8π)·Rs; ρd = 28Rd/(23π)(1−Rs)(1 − 1/32)².
        let (e, rs, rd) = (20.0, 0.05, 0.5);
        let want = (e + 1.0) / (8.0 * PI) * rs
            + 28.0 * rd / (23.0 * PI) * (1.0 - rs) * (1.0 - 1.0 / 32.0f64).powi(2);
        let got = eval(
            &AshikhminShirley,
            &[rd, rd, rd, e, rs],
            &Dirs::from_angles(0.0, 0.0, 0.0),
        );
        assert!((got[1] - want).abs() < 1e-12, "{got:?} vs {want}");
    }
}
