//! Randomised perimeters for moles and freckles (ours; thesis §7.4 notes that its round
//! features look artificial). The radius varies with the angle around the centre as
//! r(θ) = r · (1 + Σₖ aₖ cos(kθ + φₖ)), k = 2…5, with aₖ ∝ roughness / k so that low harmonics
//! dominate (lobed, asymmetric outlines like real naevi and lentigines).

use glam::Vec3;
use serde::Serialize;

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
/// An irregular edge: four random harmonics of the polar angle in the tangent plane.
pub struct Perimeter {
    /// Relative amplitude of harmonics 2–5.
    pub amplitude: [f32; 4],
    /// Their phases (radians).
    pub phase: [f32; 4],
    /// Tangent-plane axes at the centre, for the angle θ.
    pub t: Vec3,
    /// See `t`.
    pub b: Vec3,
}

impl Perimeter {
    /// Builds one from four uniforms for amplitudes and four for phases.
    pub fn new(roughness: f32, u_amp: [f32; 4], u_phase: [f32; 4], t: Vec3, b: Vec3) -> Self {
        // Σ aₖ ≤ roughness · (1/2 + 1/3 + 1/4 + 1/5) / 1.283 = roughness keeps r(θ) ≥ r(1 − roughness).
        let amplitude = std::array::from_fn(|k| roughness * u_amp[k] / ((k + 2) as f32 * 1.2834));
        let phase = u_phase.map(|u| u * std::f32::consts::TAU);
        Self {
            amplitude,
            phase,
            t,
            b,
        }
    }

    /// r(θ)/r in the direction of offset `d` (from the centre) in the tangent plane.
    #[inline]
    pub fn scale(&self, d: Vec3) -> f32 {
        if self.amplitude.iter().all(|&a| a == 0.0) {
            return 1.0;
        }
        let theta = d.dot(self.b).atan2(d.dot(self.t));
        let mut s = 1.0;
        for k in 0..4 {
            s += self.amplitude[k] * ((k + 2) as f32 * theta + self.phase[k]).cos();
        }
        s
    }

    /// Largest possible r(θ)/r (for bounds).
    pub fn max_scale(&self) -> f32 {
        1.0 + self.amplitude.iter().sum::<f32>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perimeter_stays_within_bounds_and_varies() {
        let p = Perimeter::new(0.3, [1.0; 4], [0.1, 0.5, 0.7, 0.9], Vec3::X, Vec3::Y);
        let mut lo = f32::INFINITY;
        let mut hi = 0.0f32;
        for i in 0..360 {
            let a = (i as f32).to_radians();
            let s = p.scale(Vec3::new(a.cos(), a.sin(), 0.0));
            lo = lo.min(s);
            hi = hi.max(s);
        }
        assert!(lo >= 0.7 - 1e-4 && hi <= p.max_scale() + 1e-4);
        assert!(hi - lo > 0.1, "outline should not be round");
        let round = Perimeter::new(0.0, [1.0; 4], [0.0; 4], Vec3::X, Vec3::Y);
        assert_eq!(round.scale(Vec3::new(0.3, 0.7, 0.0)), 1.0);
    }
}
