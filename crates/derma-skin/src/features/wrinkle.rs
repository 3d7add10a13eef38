//! Wrinkles (thesis §5.3.7): a profiled shape around a cubic Bézier curve built by walking a
//! vector field from a random start point; p_z −= þ_wrinkle(d / T(t, w))·h with the taper T.
//!
//! On a curved surface the curve's chord sinks below the skin (a 40 mm forehead wrinkle on an
//! 80 mm radius sags 2.5 mm, more than its width), so the distance is measured in the tangent
//! plane at the painted point: the separation minus its component along the surface normal.
//! Points farther than [`NORMAL_REACH`] along the normal are on another part of the surface.
//!
//! Each wrinkle also paints its expression furrow: at full activation of its region
//! (`derma_head::wrinkle_regions`) the crease is [`EXPRESSION_DEEPEN`]× deeper and
//! [`EXPRESSION_NARROW`]× narrower, and `furrow_mm` holds that profile less the rest one.

use super::bezier::CubicBezier;
use super::profile::{wrinkle_profile, wrinkle_taper};
use super::{BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

/// Largest normal-direction separation (mm) at which a wrinkle still paints.
pub const NORMAL_REACH: f32 = 6.0;

/// Depth of a wrinkle's furrow at full expression over its depth at rest. AUTHORED: skin
/// shortened across a crease folds into it, so the crease deepens and sharpens (Jimenez et al.
/// 2011 paint such per-expression maps by hand); 4× takes the default 0.03–0.12 mm creases (at
/// 40 years) to 0.12–0.48 mm, lines that read in a head-and-shoulders render where the rest
/// creases barely do (checked by eye in `derma render --pose browInnerUp=1`).
pub const EXPRESSION_DEEPEN: f32 = 4.0;
/// Half-width of a wrinkle's furrow at full expression over its half-width at rest (AUTHORED,
/// with [`EXPRESSION_DEEPEN`]).
pub const EXPRESSION_NARROW: f32 = 0.75;

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
    #[serde(skip)]
    /// The expression furrow's half-width factor over `width` and its amplitude factor (the
    /// narrower furrow is widened to a texel as the crease is, keeping its cross-section).
    pub expression: (f32, f32),
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
        let narrow = EXPRESSION_NARROW * width;
        let narrow_eff = narrow.max(super::MIN_TEXELS * pitch_mm);
        let chord_deviation = curve.chord_deviation();
        Self {
            curve,
            width: w_eff,
            depth,
            amp: width / w_eff,
            expression: (narrow_eff / w_eff, EXPRESSION_DEEPEN * narrow / narrow_eff),
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
        let d = d2.sqrt();
        let rest = wrinkle_profile(d / w) * self.amp;
        let (narrow, amp) = self.expression;
        let furrow = wrinkle_profile(d / (w * narrow)) * amp;
        s.height_mm -= rest * self.depth;
        s.furrow_mm -= (furrow - rest) * self.depth;
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
    fn expression_furrow_is_deeper_and_narrower() {
        let w = straight();
        let at = |y: f32| {
            let mut s = BioSample::default();
            let q = PaintPoint {
                p: Vec3::new(15.0, y, 0.0),
                n: Vec3::Z,
            };
            w.apply(&(), &q, &mut s);
            (s.height_mm, s.height_mm + s.furrow_mm)
        };
        // On the line: EXPRESSION_DEEPEN × the rest depth.
        let (rest, full) = at(0.0);
        assert!(
            (full - EXPRESSION_DEEPEN * rest).abs() < 1e-5,
            "{rest} {full}"
        );
        // Beyond the narrower half-width (1 mm × EXPRESSION_NARROW) the furrow is gone and the
        // flank lifts back.
        let (rest, full) = at(0.5 * (1.0 + EXPRESSION_NARROW));
        assert!(rest < 0.0 && full == 0.0);
        // The cross-section's area grows by deepen × narrow (∫þ over the half-width scales).
        let area =
            |f: fn((f32, f32)) -> f32| (0..2000).map(|k| f(at(k as f32 * 5e-4))).sum::<f32>();
        let ratio = area(|h| h.1) / area(|h| h.0);
        assert!(
            (ratio - EXPRESSION_DEEPEN * EXPRESSION_NARROW).abs() < 0.03,
            "{ratio}"
        );
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
