//! Hair follicles (thesis §5.3.4): inside the stalk r_i the extra colour is the hair colour and
//! the displacement is set to the shaven-stalk height; between r_i and r_o the hair colour fades
//! (see [`follicle_alpha`]). Interaction (thesis §4.8.5): the sebaceous gland next to each
//! follicle displaces blood vessels, so blood is reduced within the gland radius.

use super::profile::{follicle_alpha, smooth_bump};
use super::{sphere_bounds, widen, BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
/// A hair follicle (thesis §5.3.4): a hair stalk's colour and height, and the sebaceous gland's blood reduction around it.
pub struct Follicle {
    /// Centre on the surface (mm).
    pub center: Vec3,
    #[serde(skip)]
    /// Stalk radius r_i (mm), widened like `r_outer`.
    pub r_inner: f32,
    #[serde(skip)]
    /// Visible radius r_o (mm), widened to at least [`super::MIN_TEXELS`] texels.
    pub r_outer: f32,
    #[serde(skip)]
    /// Amplitude factor that keeps the widened follicle's integral.
    pub amp: f32,
    /// Reach of the feature: max(r_o, gland radius).
    #[serde(skip)]
    pub reach: f32,
}

/// Parameters shared by a follicle set (scalp or eyebrow).
pub struct FollicleParams {
    /// Hair colour p_c, linear RGB.
    pub hair_color: [f32; 3],
    /// Displacement of the stalk, mm.
    pub height_mm: f32,
    /// Share of the blood removed at the gland.
    pub blood_reduction: f32,
    /// Radius of the blood reduction, mm.
    pub gland_radius_mm: f32,
}

impl Follicle {
    /// A follicle at `center` with the kind's config, on texels of `pitch_mm`.
    pub fn new(center: Vec3, cfg: &crate::config::FollicleConfig, pitch_mm: f32) -> Self {
        let (r_outer, amp) = widen(cfg.outer_radius_mm, pitch_mm);
        // The stalk keeps its share of the (widened) disc so coverage is conserved too.
        let r_inner = cfg.inner_radius_mm * r_outer / cfg.outer_radius_mm.max(1e-6);
        Self {
            center,
            r_inner,
            r_outer,
            amp,
            reach: r_outer.max(cfg.gland_radius_mm),
        }
    }
}

impl Feature for Follicle {
    type Params = FollicleParams;
    fn bounds(&self) -> (Vec3, Vec3) {
        sphere_bounds(self.center, self.reach)
    }
    fn translated(&self, d: Vec3) -> Self {
        Self {
            center: self.center + d,
            ..self.clone()
        }
    }
    #[inline]
    fn apply(&self, prm: &FollicleParams, q: &PaintPoint, s: &mut BioSample) {
        let d = q.p.distance(self.center);
        if d >= self.reach {
            return;
        }
        s.tissue.blood *= 1.0 - prm.blood_reduction * smooth_bump(d, prm.gland_radius_mm);
        if d < self.r_outer {
            let a = follicle_alpha(d, self.r_inner, self.r_outer) * self.amp;
            s.add_extra(prm.hair_color, a);
            if d <= self.r_inner {
                s.height_mm = s.height_mm.max(prm.height_mm * self.amp);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follicle_colors_the_stalk_and_reduces_blood() {
        let cfg = crate::config::FollicleConfig::default();
        let prm = FollicleParams {
            hair_color: [0.1, 0.05, 0.02],
            height_mm: 0.02,
            blood_reduction: 0.5,
            gland_radius_mm: 0.3,
        };
        let f = Follicle::new(Vec3::ZERO, &cfg, 0.001);
        let mut s = BioSample {
            tissue: derma_shading::BioTexel {
                blood: 0.02,
                ..Default::default()
            },
            ..Default::default()
        };
        f.apply(
            &prm,
            &PaintPoint {
                p: Vec3::new(0.01, 0.0, 0.0),
                n: Vec3::Z,
            },
            &mut s,
        );
        assert!((s.extra[3] - 1.0).abs() < 1e-6 && (s.extra[0] - 0.1).abs() < 1e-6);
        assert!((s.height_mm - 0.02).abs() < 1e-7);
        assert!(s.tissue.blood < 0.02 && s.tissue.blood > 0.01);
        // Outside r_o but inside the gland: blood reduced, no colour.
        let mut s = BioSample {
            tissue: derma_shading::BioTexel {
                blood: 0.02,
                ..Default::default()
            },
            ..Default::default()
        };
        f.apply(
            &prm,
            &PaintPoint {
                p: Vec3::new(0.2, 0.0, 0.0),
                n: Vec3::Z,
            },
            &mut s,
        );
        assert_eq!(s.extra[3], 0.0);
        assert!(s.tissue.blood < 0.02);
    }
}
