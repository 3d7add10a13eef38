//! The microfacet terms every renderer of this crate shares: the GGX / Trowbridge–Reitz
//! distribution (Walter et al. 2007), Schlick's Fresnel (Schlick 1994) and the height-correlated
//! Smith visibility (Heitz 2014, eq. 99) — the CPU's forms of lighting.wgsl's functions.

use std::f32::consts::PI;

/// GGX / Trowbridge–Reitz distribution D(h) at n·h = `nh` for α = `a` (roughness²).
#[inline]
pub fn ggx_d(nh: f32, a: f32) -> f32 {
    let a2 = a * a;
    let d = nh * nh * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Height-correlated Smith visibility G₂ / (4 n·l n·v) (Heitz 2014, eq. 99).
#[inline]
pub fn smith_vis(nl: f32, nv: f32, a: f32) -> f32 {
    let a2 = a * a;
    let gv = nl * (nv * nv * (1.0 - a2) + a2).sqrt();
    let gl = nv * (nl * nl * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl).max(1e-5)
}

/// Schlick's Fresnel at cos θ = `vh` (an integer power: finite even where a rounded cosine
/// passes 1, unlike WGSL's pow).
#[inline]
pub fn schlick(f0: f32, vh: f32) -> f32 {
    f0 + (1.0 - f0) * (1.0 - vh).powi(5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ggx_integrates_to_one_and_schlick_spans_f0_to_one() {
        // ∫ D (n·h) dω = 1 over the hemisphere (Walter et al. 2007, eq. 4).
        let (a, n) = (0.3, 4000);
        let s: f32 = (0..n)
            .map(|i| {
                let t = (i as f32 + 0.5) / n as f32 * 0.5 * PI;
                ggx_d(t.cos(), a) * t.cos() * t.sin() * 2.0 * PI * (0.5 * PI / n as f32)
            })
            .sum();
        assert!((s - 1.0).abs() < 1e-2, "{s}");
        assert_eq!(schlick(0.04, 1.0), 0.04);
        assert_eq!(schlick(0.04, 0.0), 1.0);
        // Smith visibility of a smooth surface at normal incidence: 1 / (4 n·l n·v) = ¼.
        assert!((smith_vis(1.0, 1.0, 0.0) - 0.25).abs() < 1e-6);
    }
}
