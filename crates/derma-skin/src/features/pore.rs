//! Pores (ours; thesis §7.4 lists them among the missing features): the openings of
//! pilosebaceous follicles on the face, shallow funnels a tenth of a millimetre across that
//! dominate the micro-relief of cheek and nose skin. Modelled as a depression with the smooth
//! profile (1 − (d/r)²)² and slightly more melanin at the ostium, which reads darker as real
//! pores do. Sizes: visible facial pores are roughly 0.05–0.25 mm across; the default radius is 0.08 mm.

use super::profile::smooth_bump;
use super::{sphere_bounds, widen, BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
/// A pore (ours; thesis §7.4 lists them as missing): a small pit with a slightly darker ostium.
pub struct Pore {
    /// Centre on the surface (mm).
    pub center: Vec3,
    /// Radius (mm) as drawn.
    pub radius: f32,
    #[serde(skip)]
    /// Radius widened to at least [`super::MIN_TEXELS`] texels (anti-aliasing).
    pub r_eff: f32,
    #[serde(skip)]
    /// Amplitude factor that keeps the widened pit's integral.
    pub amp: f32,
}

/// Shared pore parameters.
pub struct PoreParams {
    /// Depth at the centre, mm.
    pub depth_mm: f32,
    /// Melanin added at the centre (volume fraction).
    pub melanin_add: f32,
}

impl Pore {
    /// A pore at `center` with radius mean + σ·`z`, on texels of `pitch_mm`.
    pub fn new(center: Vec3, cfg: &crate::config::PoreConfig, z: f32, pitch_mm: f32) -> Self {
        let radius = (cfg.radius_mean_mm + cfg.radius_sigma_mm * z).max(0.01);
        let (r_eff, amp) = widen(radius, pitch_mm);
        Self {
            center,
            radius,
            r_eff,
            amp,
        }
    }
}

impl Feature for Pore {
    type Params = PoreParams;
    fn bounds(&self) -> (Vec3, Vec3) {
        sphere_bounds(self.center, self.r_eff)
    }
    fn translated(&self, d: Vec3) -> Self {
        Self {
            center: self.center + d,
            ..self.clone()
        }
    }
    #[inline]
    fn apply(&self, prm: &PoreParams, q: &PaintPoint, s: &mut BioSample) {
        let d = q.p.distance(self.center);
        if d < self.r_eff {
            let w = smooth_bump(d, self.r_eff) * self.amp;
            s.height_mm -= prm.depth_mm * w;
            s.tissue.melanin += prm.melanin_add * w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pore_is_a_depression() {
        let cfg = crate::config::PoreConfig::default();
        let p = Pore::new(Vec3::ZERO, &cfg, 0.0, 0.001);
        let prm = PoreParams {
            depth_mm: 0.03,
            melanin_add: 0.01,
        };
        let mut s = BioSample::default();
        p.apply(
            &prm,
            &PaintPoint {
                p: Vec3::ZERO,
                n: Vec3::Z,
            },
            &mut s,
        );
        assert!((s.height_mm + 0.03).abs() < 1e-7 && (s.tissue.melanin - 0.01).abs() < 1e-7);
        let mut s = BioSample::default();
        p.apply(
            &prm,
            &PaintPoint {
                p: Vec3::new(0.08, 0.0, 0.0),
                n: Vec3::Z,
            },
            &mut s,
        );
        assert_eq!(s.height_mm, 0.0);
    }
}
