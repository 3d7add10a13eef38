//! Scattering feature centres over the surface by a density field (thesis §5.1, ChoosePoint),
//! with the bias the thesis notes fixed: a texel's chance is its field value times the surface
//! area it covers, so densities are per mm² of skin, not per texel of UV space.

use crate::surface::{Frame, Surface};
use derma_core::rng::Philox;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// A sampled point on the surface.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Position on the surface (mm).
    pub position: Vec3,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Tangent frame there.
    pub frame: Frame,
}

/// Draws points with probability proportional to field × area.
pub struct Sampler<'a> {
    surface: &'a Surface,
    texels: Vec<u32>,
    cumulative: Vec<f64>,
}

impl<'a> Sampler<'a> {
    /// `weight(i)` is the field value (already raised to any power) at scatter texel `i`. Each
    /// texel's share (weight × area) is found in parallel, the running sum then in texel order,
    /// so the sums do not depend on the number of threads.
    pub fn new(surface: &'a Surface, weight: impl Fn(usize) -> f32 + Sync) -> Self {
        // None: off the surface, or of no weight.
        let shares: Vec<Option<f64>> = (0..surface.len())
            .into_par_iter()
            .map(|i| {
                let w = if surface.covered(i) {
                    weight(i).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (!(w <= 0.0)).then(|| {
                    w as f64 * surface.frame(i).texel_area(surface.width, surface.height) as f64
                })
            })
            .collect();
        let mut texels = Vec::new();
        let mut cumulative = Vec::new();
        let mut acc = 0.0f64;
        for (i, share) in shares.iter().enumerate() {
            if let Some(share) = share {
                acc += share;
                texels.push(i as u32);
                cumulative.push(acc);
            }
        }
        Self {
            surface,
            texels,
            cumulative,
        }
    }

    /// ∫ field dA in mm².
    pub fn weighted_area_mm2(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// Number of features for a peak density in 1/cm² (the expectation, rounded).
    pub fn count(&self, density_per_cm2: f32) -> usize {
        (self.weighted_area_mm2() * density_per_cm2 as f64 / 100.0).round() as usize
    }

    /// Point `index` of stream `rng`, using sub-stream 0 of that index.
    pub fn sample(&self, rng: &Philox, index: u64) -> Option<SurfacePoint> {
        let total = self.weighted_area_mm2();
        if total <= 0.0 {
            return None;
        }
        let w = rng.u32x4(index);
        // 53-bit uniform for the texel choice (a 24-bit one would skip texels on large surfaces).
        let u = (((w[0] as u64) << 21) ^ (w[1] as u64 >> 11)) as f64 / (1u64 << 53) as f64;
        let target = u * total;
        let k = self
            .cumulative
            .partition_point(|&c| c <= target)
            .min(self.texels.len() - 1);
        let i = self.texels[k] as usize;
        let s = self.surface;
        let frame = s.frame(i);
        let (ju, jv) = (
            derma_core::rng::unit_f32(w[2]) - 0.5,
            derma_core::rng::unit_f32(w[3]) - 0.5,
        );
        let (du, dv) = (1.0 / s.width as f32, 1.0 / s.height as f32);
        let mut position = s.position(i) + frame.dpdu * (ju * du) + frame.dpdv * (jv * dv);
        let mut uv = s.uv(i) + Vec2::new(ju * du, jv * dv);
        if let Some([px, py]) = s.period() {
            position.x = position.x.rem_euclid(px);
            position.y = position.y.rem_euclid(py);
            uv = Vec2::new(uv.x.rem_euclid(1.0), uv.y.rem_euclid(1.0));
        }
        Some(SurfacePoint {
            position,
            uv,
            frame,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_scale_with_area_not_texels() {
        // The same density on a 10×10 mm and a 40×20 mm patch, at different resolutions.
        let a = Surface::patch(64, 64, [10.0, 10.0], false);
        let b = Surface::patch(32, 128, [40.0, 20.0], false);
        let sa = Sampler::new(&a, |_| 1.0);
        let sb = Sampler::new(&b, |_| 1.0);
        assert_eq!(sa.count(100.0), 100); // 1 cm² × 100/cm²
        assert_eq!(sb.count(100.0), 800);
        // Half the field → half the features.
        assert_eq!(Sampler::new(&a, |_| 0.5).count(100.0), 50);
    }

    #[test]
    fn samples_follow_the_field() {
        // Field 1 on the left half, 0 on the right: every sample lands on the left.
        let s = Surface::patch(32, 32, [10.0, 10.0], false);
        let sm = Sampler::new(&s, |i| if i % 32 < 16 { 1.0 } else { 0.0 });
        let rng = Philox::new(1, 2);
        let mut left_quarter = 0i32;
        for k in 0..2000 {
            let p = sm.sample(&rng, k).unwrap();
            assert!(p.position.x < 5.0 + 1e-4);
            if p.position.x < 2.5 {
                left_quarter += 1;
            }
        }
        // uniform within the allowed half: about 1000 of 2000 in its left half
        assert!((left_quarter - 1000).abs() < 120, "{left_quarter}");
    }
}
