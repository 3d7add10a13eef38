//! Moles, melanocytic naevi (thesis §5.3.3): p_m += þ_sig(d, r)·M and a raised centre. The
//! thesis writes p_z += h·p_m; we use the mole's own melanin þ_sig·M (not the baseline's), so the
//! height has no step where the mole's support ends. Outlines are randomised ([`Perimeter`]).

use super::perimeter::Perimeter;
use super::profile::{sigmoid_profile, SIGMOID_SUPPORT};
use super::{sphere_bounds, widen, BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
/// A mole (thesis §5.3.3): melanin added and the surface raised in a sigmoid spot with an irregular edge.
pub struct Mole {
    /// Centre on the surface (mm).
    pub center: Vec3,
    /// Radius r (mm) as drawn.
    pub radius: f32,
    /// Maximum melanocyte ratio M.
    pub melanin: f32,
    /// Height per unit melanocyte ratio h (mm).
    pub height: f32,
    /// The irregular edge.
    pub perimeter: Perimeter,
    #[serde(skip)]
    /// Radius widened to at least [`super::MIN_TEXELS`] texels (anti-aliasing).
    pub r_eff: f32,
    #[serde(skip)]
    /// Amplitude factor that keeps the widened spot's integral.
    pub amp: f32,
}

impl Feature for Mole {
    type Params = ();
    fn bounds(&self) -> (Vec3, Vec3) {
        sphere_bounds(
            self.center,
            SIGMOID_SUPPORT * self.r_eff * self.perimeter.max_scale(),
        )
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
        let r = self.r_eff * self.perimeter.scale(off);
        if d < SIGMOID_SUPPORT * r {
            let m = sigmoid_profile(d, r) * self.melanin * self.amp;
            s.tissue.melanin += m;
            s.height_mm += self.height * m;
        }
    }
}

impl Mole {
    // The centre, its tangent frame, the kind's config, the feature's random draws (z, u, v)
    // and the texel pitch: the thesis' inputs, kept apart so each stays named.
    #[allow(clippy::too_many_arguments)]
    /// From the sampled centre and frame, the kind's config, a standard normal `z`, uniforms `u` and `v`, and the texel pitch.
    pub fn new(
        center: Vec3,
        t: Vec3,
        b: Vec3,
        cfg: &crate::config::MoleConfig,
        z: f32,
        u: [f32; 4],
        u_shape: [f32; 4],
        pitch_mm: f32,
    ) -> Self {
        let radius = (cfg.radius_sigma_mm * z).abs().max(1e-4);
        let melanin = cfg.melanin.min + (cfg.melanin.max - cfg.melanin.min) * u[0];
        let height = cfg.height_mm.min + (cfg.height_mm.max - cfg.height_mm.min) * u[1];
        let perimeter = Perimeter::new(
            cfg.perimeter_roughness,
            [u[2], u[3], u_shape[0], u_shape[1]],
            [u_shape[2], u_shape[3], u[2] * 0.37 + 0.1, u[3] * 0.53 + 0.2],
            t,
            b,
        );
        let (r_eff, amp) = widen(radius, pitch_mm);
        Self {
            center,
            radius,
            melanin,
            height,
            perimeter,
            r_eff,
            amp,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mole_adds_melanin_and_height_inside_only() {
        let cfg = crate::config::MoleConfig {
            perimeter_roughness: 0.0,
            ..Default::default()
        };
        let m = Mole::new(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            &cfg,
            2.5,
            [0.5, 0.5, 0.0, 0.0],
            [0.0; 4],
            0.01,
        );
        assert!((m.radius - 1.0).abs() < 1e-6);
        let at = |x: f32| {
            let mut s = BioSample {
                tissue: derma_shading::BioTexel {
                    melanin: 0.02,
                    ..Default::default()
                },
                ..Default::default()
            };
            m.apply(
                &(),
                &PaintPoint {
                    p: Vec3::new(x, 0.0, 0.0),
                    n: Vec3::Z,
                },
                &mut s,
            );
            s
        };
        let c = at(0.0);
        assert!((c.tissue.melanin - (0.02 + m.melanin)).abs() < 1e-6);
        assert!((c.height_mm - m.height * m.melanin).abs() < 1e-6);
        assert!(
            at(0.5).tissue.melanin > at(1.0).tissue.melanin
                && at(1.0).tissue.melanin > at(1.5).tissue.melanin
        );
        assert_eq!(at(2.5).tissue.melanin, 0.02);
    }
}
