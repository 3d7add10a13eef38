//! Wrinkles (thesis §5.3.7): a profiled shape around a cubic Bézier curve built by walking a
//! vector field from a random start point; p_z −= þ_wrinkle(d / T(t, w))·h with the taper T.
//!
//! On a curved surface the curve's chord sinks below the skin (a 40 mm forehead wrinkle on an
//! 80 mm radius sags 2.5 mm, more than its width), so the distance is measured in the tangent
//! plane at the painted point: the separation minus its component along the surface normal.
//! Points farther than [`NORMAL_REACH`] along the normal are on another part of the surface.

use super::bezier::CubicBezier;
use super::profile::{wrinkle_profile, wrinkle_taper};
use super::{BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

/// Largest normal-direction separation (mm) at which a wrinkle still paints.
pub const NORMAL_REACH: f32 = 6.0;

#[derive(Clone, Debug, Serialize)]
/// A wrinkle (thesis §5.3.7): a crease along a cubic Bézier on the surface.
pub struct Wrinkle {
    /// Its centre line (mm).
    pub curve: CubicBezier,
    /// Maximum half-width w (mm).
    pub width: f32,
    /// Maximum depth h (mm).
    pub depth: f32,
    #[serde(skip)]
    /// Amplitude factor that keeps a widened crease's cross-section.
    pub amp: f32,
    /// Largest distance of the curve from its chord P₀P₃ (bounded by the control points, since
    /// the curve lies in their convex hull): lets most texels skip the closest-point search.
    #[serde(skip)]
    pub chord_deviation: f32,
}

impl Wrinkle {
    /// A crease along `curve` of half-width `width` and depth `depth` (mm), on texels of `pitch_mm`.
    pub fn new(curve: CubicBezier, width: f32, depth: f32, pitch_mm: f32) -> Self {
        // A crease narrower than a texel keeps its cross-section integral (depth × width).
        let w_eff = width.max(super::MIN_TEXELS * pitch_mm);
        let chord_deviation = curve.chord_deviation();
        Self {
            curve,
            width: w_eff,
            depth,
            amp: width / w_eff,
            chord_deviation,
        }
    }
}

impl Feature for Wrinkle {
    type Params = ();
    fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.curve.bounds();
        let m = Vec3::splat(self.width + NORMAL_REACH);
        (lo - m, hi + m)
    }
    fn translated(&self, d: Vec3) -> Self {
        let mut w = self.clone();
        w.curve.p = w.curve.p.map(|p| p + d);
        w
    }
    #[inline]
    fn apply(&self, _: &(), q: &PaintPoint, s: &mut BioSample) {
        if self
            .curve
            .tangentially_beyond(q.p, q.n, self.chord_deviation, self.width)
        {
            return;
        }
        let (t, d2) = self.curve.closest_tangential(q.p, q.n, NORMAL_REACH);
        let w = wrinkle_taper(t, self.width);
        if w <= 0.0 || d2 >= w * w {
            return;
        }
        s.height_mm -= wrinkle_profile(d2.sqrt() / w) * self.depth * self.amp;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight() -> Wrinkle {
        let p = [0.0f32, 10.0, 20.0, 30.0].map(|x| Vec3::new(x, 0.0, 0.0));
        Wrinkle::new(CubicBezier { p }, 1.0, 0.1, 0.01)
    }

    #[test]
    fn wrinkle_carves_the_tapered_profile() {
        let w = straight();
        let depth_at = |x: f32, y: f32| {
            let mut s = BioSample::default();
            w.apply(
                &(),
                &PaintPoint {
                    p: Vec3::new(x, y, 0.0),
                    n: Vec3::Z,
                },
                &mut s,
            );
            -s.height_mm
        };
        // Middle of the curve: full width, full depth on the line.
        assert!((depth_at(15.0, 0.0) - 0.1).abs() < 1e-4);
        assert!((depth_at(15.0, 0.5) - 0.1 * wrinkle_profile(0.5)).abs() < 1e-3);
        assert_eq!(depth_at(15.0, 1.1), 0.0);
        // Near the end the taper narrows it: at t = 0.9, T = 0.2 mm.
        assert_eq!(depth_at(27.0, 0.3), 0.0);
        assert!(depth_at(27.0, 0.1) > 0.0);
    }

    #[test]
    fn sagging_chord_still_paints_the_surface_above_it() {
        // The painted point lies 2.5 mm above the chord along the normal (a curved forehead).
        let w = straight();
        let mut s = BioSample::default();
        w.apply(
            &(),
            &PaintPoint {
                p: Vec3::new(15.0, 0.0, 2.5),
                n: Vec3::Z,
            },
            &mut s,
        );
        assert!((s.height_mm + 0.1).abs() < 1e-4);
    }
}
