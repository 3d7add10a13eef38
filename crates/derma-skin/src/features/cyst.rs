//! Cysts (thesis §5.3.2): small benign bumps that change only the displacement,
//! p_z += þ_sig(d, r)·h, with r = |0.2·Norm(0,1) + 0.01| and h = ½U by default.

use super::profile::{sigmoid_profile, SIGMOID_SUPPORT};
use super::{sphere_bounds, widen, BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
/// A cyst (thesis §5.3.2): a raised sigmoid bump.
pub struct Cyst {
    /// Centre on the surface (mm).
    pub center: Vec3,
    /// Radius r (mm) as drawn.
    pub radius: f32,
    /// Maximum height h (mm) as drawn.
    pub height: f32,
    #[serde(skip)]
    /// Radius widened to at least [`super::MIN_TEXELS`] texels (anti-aliasing).
    pub r_eff: f32,
    #[serde(skip)]
    /// Amplitude factor that keeps the widened bump's integral.
    pub amp: f32,
}

impl Cyst {
    /// From the sampled centre, a standard normal `z`, a uniform `u` and the texel pitch.
    pub fn new(
        center: Vec3,
        cfg: &crate::config::CystConfig,
        z: f32,
        u: f32,
        pitch_mm: f32,
    ) -> Self {
        let radius = (cfg.radius_sigma_mm * z + cfg.radius_offset_mm)
            .abs()
            .max(1e-4);
        let height = cfg.height_max_mm * u;
        let (r_eff, amp) = widen(radius, pitch_mm);
        Self {
            center,
            radius,
            height,
            r_eff,
            amp,
        }
    }
}

impl Feature for Cyst {
    type Params = ();
    fn bounds(&self) -> (Vec3, Vec3) {
        sphere_bounds(self.center, SIGMOID_SUPPORT * self.r_eff)
    }
    fn translated(&self, d: Vec3) -> Self {
        Self {
            center: self.center + d,
            ..self.clone()
        }
    }
    #[inline]
    fn apply(&self, _: &(), q: &PaintPoint, s: &mut BioSample) {
        let d = q.p.distance(self.center);
        if d < SIGMOID_SUPPORT * self.r_eff {
            s.height_mm += sigmoid_profile(d, self.r_eff) * self.height * self.amp;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cyst_raises_height_by_the_sigmoid_profile() {
        let cfg = crate::config::CystConfig::default();
        let c = Cyst::new(Vec3::ZERO, &cfg, 2.0, 0.8, 0.01);
        assert!((c.radius - 0.41).abs() < 1e-5 && (c.height - 0.4).abs() < 1e-6);
        let mut s = BioSample::default();
        c.apply(
            &(),
            &PaintPoint {
                p: Vec3::ZERO,
                n: Vec3::Z,
            },
            &mut s,
        );
        assert!((s.height_mm - 0.4).abs() < 1e-6);
        let mut s = BioSample::default();
        c.apply(
            &(),
            &PaintPoint {
                p: Vec3::new(0.41, 0.0, 0.0),
                n: Vec3::Z,
            },
            &mut s,
        );
        assert!((s.height_mm - 0.4 * sigmoid_profile(1.0, 1.0)).abs() < 1e-6);
        assert!(s.tissue.melanin == 0.0 && s.tissue.blood == 0.0);
    }
}
