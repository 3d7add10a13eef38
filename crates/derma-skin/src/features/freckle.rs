//! Freckles, ephelides (thesis §5.3.5): a = clamp(1 − 1.2 d/r), p_m += a·M·U, p_p += a·H·U, with
//! r ~ Norm(0.8, 0.4), M = 0.12U, H = 0.015(M + U); centres from the freckle field raised to the
//! power i. The per-freckle uniform U is drawn once per freckle (a per-texel U would be white
//! noise). Outlines are randomised ([`Perimeter`]).

use super::perimeter::Perimeter;
use super::profile::freckle_amount;
use super::{sphere_bounds, widen, BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
/// A freckle (thesis §5.3.5): melanin and pheomelanin added in a soft spot with an irregular edge.
pub struct Freckle {
    /// Centre on the surface (mm).
    pub center: Vec3,
    /// Radius r (mm) as drawn.
    pub radius: f32,
    /// M·U: melanin added at the centre.
    pub melanin: f32,
    /// H·U: pheomelanin ratio added at the centre.
    pub pheomelanin: f32,
    /// The irregular edge.
    pub perimeter: Perimeter,
    #[serde(skip)]
    /// Radius widened to at least [`super::MIN_TEXELS`] texels (anti-aliasing).
    pub r_eff: f32,
    #[serde(skip)]
    /// Amplitude factor that keeps the widened spot's integral.
    pub amp: f32,
}

impl Freckle {
    // The centre, its tangent frame, the kind's config, the feature's random draws (z, u, v)
    // and the texel pitch: the thesis' inputs, kept apart so each stays named.
    #[allow(clippy::too_many_arguments)]
    /// From the sampled centre and frame, the kind's config, a standard normal `z`, uniforms `u` and `v`, and the texel pitch.
    pub fn new(
        center: Vec3,
        t: Vec3,
        b: Vec3,
        cfg: &crate::config::FreckleConfig,
        z: f32,
        u: [f32; 4],
        u_shape: [f32; 4],
        pitch_mm: f32,
    ) -> Self {
        let radius = (cfg.radius_mean_mm + cfg.radius_sigma_mm * z).max(0.1);
        let m = cfg.melanin_max * u[0];
        let h = cfg.pheomelanin_scale * (m + u[1]);
        let uu = u[2];
        let perimeter = Perimeter::new(
            cfg.perimeter_roughness,
            [u_shape[0], u_shape[1], u[3], 1.0 - u[3]],
            [u_shape[2], u_shape[3], u[1], u[0]],
            t,
            b,
        );
        let (r_eff, amp) = widen(radius, pitch_mm);
        Self {
            center,
            radius,
            melanin: m * uu,
            pheomelanin: h * uu,
            perimeter,
            r_eff,
            amp,
        }
    }
}

impl Feature for Freckle {
    type Params = ();
    fn bounds(&self) -> (Vec3, Vec3) {
        sphere_bounds(self.center, self.r_eff * self.perimeter.max_scale() / 1.2)
    }
    fn translated(&self, d: Vec3) -> Self {
        Self {
            center: self.center + d,
            ..self.clone()
        }
    }
    #[inline]
    fn apply(&self, _: &(), q: &PaintPoint, s: &mut BioSample) {
        let off = q.p - self.center;
        let d = off.length();
        if d * 1.2 >= self.r_eff * self.perimeter.max_scale() {
            return;
        }
        let a = freckle_amount(d, self.r_eff * self.perimeter.scale(off)) * self.amp;
        s.tissue.melanin += a * self.melanin;
        s.tissue.pheomelanin = (s.tissue.pheomelanin + a * self.pheomelanin).min(1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn freckle_follows_the_thesis_amount() {
        let cfg = crate::config::FreckleConfig {
            perimeter_roughness: 0.0,
            ..Default::default()
        };
        // z = 0 → r = 0.8; u0 = 0.5 → M = 0.06; u1 = 0.5 → H = 0.015·0.56; U = u2 = 1.
        let f = Freckle::new(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            &cfg,
            0.0,
            [0.5, 0.5, 1.0, 0.0],
            [0.0; 4],
            0.01,
        );
        assert!((f.radius - 0.8).abs() < 1e-6 && (f.melanin - 0.06).abs() < 1e-6);
        assert!((f.pheomelanin - 0.015 * 0.56).abs() < 1e-6);
        let mut s = BioSample::default();
        f.apply(
            &(),
            &PaintPoint {
                p: Vec3::new(0.4, 0.0, 0.0),
                n: Vec3::Z,
            },
            &mut s,
        );
        // a = 1 − 1.2·0.5 = 0.4
        assert!((s.tissue.melanin - 0.4 * 0.06).abs() < 1e-6);
        let mut s = BioSample::default();
        f.apply(
            &(),
            &PaintPoint {
                p: Vec3::new(0.7, 0.0, 0.0),
                n: Vec3::Z,
            },
            &mut s,
        );
        assert_eq!(s.tissue.melanin, 0.0);
    }
}
