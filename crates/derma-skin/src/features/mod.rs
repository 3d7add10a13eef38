//! Biological features (thesis §4.8.5, §5.3): each maps the feature's parameters and a point on
//! the surface to changes of the bio parameters there. One module per feature; the order in
//! which kinds are applied is the table's ([`crate::kinds::KINDS`]).

pub mod bezier;
pub mod cyst;
pub mod follicle;
pub mod freckle;
pub mod lips;
pub mod mole;
pub mod perimeter;
pub mod pore;
pub mod profile;
pub mod relief;
pub mod relief_lanes;
pub mod strand;
pub mod wrinkle;

use derma_shading::BioTexel;
use glam::Vec3;
use serde::Serialize;

/// Every bio parameter of one texel while it is painted (thesis §5.2): the tissue the optics
/// turn into colour, plus displacement, an extra colour and a lip mask that the material stage
/// uses for roughness. `repr(C)`: thirteen f32 in field order, no padding, so a set's samples
/// can be handed out as an (h, w, 13) float32 array without a copy (derma-py).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
#[repr(C)]
pub struct BioSample {
    /// Melanin, blood, oxygenation and layer thicknesses: what an
    /// [`derma_shading::Appearance`] turns into colour.
    pub tissue: BioTexel,
    /// Displacement p_z from the mean skin surface, mm.
    pub height_mm: f32,
    /// Extra colour p_c (linear RGB) and its coverage α (thesis §5.2), e.g. hair.
    pub extra: [f32; 4],
    /// Lip field value ∆(p) where lips were painted.
    pub lips: f32,
    /// Displacement (mm) the expression wrinkles add at full activation (features/wrinkle.rs):
    /// `height_mm + m · furrow_mm` is the surface at furrow activation m.
    pub furrow_mm: f32,
}

impl BioSample {
    /// Composites colour `rgb` with coverage `a` over the extra colour ("over" operator).
    #[inline]
    pub fn add_extra(&mut self, rgb: [f32; 3], a: f32) {
        let a = a.clamp(0.0, 1.0);
        let keep = 1.0 - a;
        let out_a = a + self.extra[3] * keep;
        if out_a <= 0.0 {
            return;
        }
        for k in 0..3 {
            self.extra[k] = (rgb[k] * a + self.extra[k] * self.extra[3] * keep) / out_a;
        }
        self.extra[3] = out_a;
    }
}

/// The point being painted: position (mm) and surface normal.
#[derive(Clone, Copy, Debug)]
pub struct PaintPoint {
    /// Position (mm).
    pub p: Vec3,
    /// Unit surface normal.
    pub n: Vec3,
}

/// A scattered feature: where it is and what it does.
pub trait Feature: Clone + Serialize + Send + Sync {
    /// Parameters shared by every feature of the kind.
    type Params: Sync;
    /// Axis-aligned bounds of its influence (mm).
    fn bounds(&self) -> (Vec3, Vec3);
    /// The same feature moved by `d` (ghost copies across the edges of a tileable patch).
    fn translated(&self, d: Vec3) -> Self;
    /// Modifies the bio parameters at `q`.
    fn apply(&self, params: &Self::Params, q: &PaintPoint, s: &mut BioSample);
}

/// Anti-aliasing of features smaller than a texel: the radius is widened to at least
/// `MIN_TEXELS` texels and the amplitude scaled by (r / r_eff)², which keeps the feature's
/// integral ∫ þ dA (its total melanin, height…) while stopping it from vanishing between texel
/// centres or aliasing to isolated dots.
pub const MIN_TEXELS: f32 = 0.75;

/// (r_eff, amplitude factor) for radius `r` on texels of `pitch_mm`.
#[inline]
pub fn widen(r: f32, pitch_mm: f32) -> (f32, f32) {
    let r_min = MIN_TEXELS * pitch_mm;
    if r >= r_min || r <= 0.0 {
        (r.max(1e-6), 1.0)
    } else {
        (r_min, (r / r_min) * (r / r_min))
    }
}

/// Bounds of a sphere.
#[inline]
pub fn sphere_bounds(c: Vec3, r: f32) -> (Vec3, Vec3) {
    (c - Vec3::splat(r), c + Vec3::splat(r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widening_conserves_the_integral() {
        // ∫ þ(d/r) 2πd dd ∝ r²; amplitude × r_eff² must equal 1 × r².
        let (r_eff, amp) = widen(0.04, 0.2);
        assert!((r_eff - 0.15).abs() < 1e-6);
        assert!((amp * r_eff * r_eff - 0.04 * 0.04).abs() < 1e-9);
        assert_eq!(widen(1.0, 0.2), (1.0, 1.0));
    }

    #[test]
    fn extra_color_composites_over() {
        let mut s = BioSample::default();
        s.add_extra([1.0, 0.0, 0.0], 0.5);
        s.add_extra([0.0, 0.0, 1.0], 0.5);
        assert!((s.extra[3] - 0.75).abs() < 1e-6);
        // blue over (half) red: colour = (0.5·blue + 0.25·red) / 0.75
        assert!((s.extra[0] - 1.0 / 3.0).abs() < 1e-6 && (s.extra[2] - 2.0 / 3.0).abs() < 1e-6);
    }
}
