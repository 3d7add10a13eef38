//! Scans with known correspondence, for testing registration: smooth random warps (sums of
//! Gaussian radial basis bumps), a placement into another unit and pose, and vertices slid
//! along their surface so no scan vertex sits where a template vertex does.

use derma_core::rng::Philox;
use glam::{Mat3, Vec3};

/// A smooth warp x ↦ x + Σ oₖ exp(−|x − cₖ|² / 2σ²).
#[derive(Clone, Debug)]
pub struct Warp {
    centres: Vec<Vec3>,
    offsets: Vec<Vec3>,
    sigma: f32,
}

impl Warp {
    /// `n` bumps of width `sigma` (mm) centred on points drawn from `points`, with random
    /// directions, scaled so the largest displacement over `points` is `peak_mm`.
    pub fn random(seed: u64, points: &[Vec3], n: usize, sigma: f32, peak_mm: f32) -> Warp {
        let rng = Philox::new(seed, 0);
        let mut centres = Vec::with_capacity(n);
        let mut offsets = Vec::with_capacity(n);
        for k in 0..n as u64 {
            let u = rng.uniform4(k, 0);
            centres.push(points[(u[0] * points.len() as f32) as usize % points.len()]);
            let d = rng.normal2(k, 1);
            let e = rng.normal2(k, 2);
            offsets.push(Vec3::new(d[0], d[1], e[0]));
        }
        let mut w = Warp {
            centres,
            offsets,
            sigma,
        };
        let peak = points
            .iter()
            .map(|p| (w.apply(*p) - *p).length())
            .fold(0.0f32, f32::max);
        for o in &mut w.offsets {
            *o *= peak_mm / peak.max(1e-6);
        }
        w
    }

    /// The warped point.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        let s2 = 2.0 * self.sigma * self.sigma;
        p + self
            .centres
            .iter()
            .zip(&self.offsets)
            .map(|(c, o)| *o * (-(p - *c).length_squared() / s2).exp())
            .sum::<Vec3>()
    }
}

/// A rigid placement with a change of unit: x ↦ (R x + t) / mm_per_unit.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    /// Rotation.
    pub rotation: Mat3,
    /// Translation (mm).
    pub translation: Vec3,
    /// Millimetres per output unit (10: centimetres).
    pub mm_per_unit: f32,
}

impl Placement {
    /// The placed point, in the output unit.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        (self.rotation * p + self.translation) / self.mm_per_unit
    }
}

/// Slides each vertex along its tangent plane by up to `fraction` of `spacing` (mm), in a random
/// direction: the surface stays (to second order), the vertices move off the template's.
pub fn slide(positions: &mut [Vec3], normals: &[Vec3], spacing: f32, fraction: f32, seed: u64) {
    let rng = Philox::new(seed, 1);
    for (i, (p, n)) in positions.iter_mut().zip(normals).enumerate() {
        let u = rng.uniform4(i as u64, 0);
        let a = Vec3::new(u[0] - 0.5, u[1] - 0.5, u[2] - 0.5);
        let t = (a - n.normalize_or_zero() * a.dot(n.normalize_or_zero())).normalize_or_zero();
        *p += t * (u[3] * fraction * spacing);
    }
}
