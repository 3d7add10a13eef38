//! Hair strands grown from follicles (issue: brows and stubble; thesis §5.3.4 gives the
//! follicle, §5.3.7 the curve walked along a vector field): a fibre lying on the skin along a
//! cubic Bézier, painted as hair colour with its coverage and a cylinder's relief.
//!
//! Distances are measured in the tangent plane at the painted point, as for wrinkles, so a
//! strand follows the curved skin. A fibre narrower than a texel is widened to
//! [`super::MIN_TEXELS`] texels and its coverage scaled by r / r_eff, which keeps the hair's
//! area (a strand is one-dimensional, so the scale is linear in the radius).

use super::bezier::CubicBezier;
use super::{BioSample, Feature, PaintPoint};
use glam::Vec3;
use serde::Serialize;

/// Largest normal-direction separation (mm) at which a strand still paints.
pub const NORMAL_REACH: f32 = 3.0;

/// Share of a grown hair's length over which it tapers to its tip (authored: a hair that was
/// never cut ends in a fine point; its last fifth narrows visibly).
pub const TIP_TAPER: f32 = 0.2;

#[derive(Clone, Debug, Serialize)]
/// A hair strand: a fibre of radius `radius` along `curve`, from its root at `curve.p[0]`.
pub struct Strand {
    /// Its centre line (mm), root first.
    pub curve: CubicBezier,
    /// Fibre radius (mm) as painted (widened to a texel's share).
    pub radius: f32,
    /// Coverage and relief scale that keeps a widened fibre's area.
    #[serde(skip)]
    pub amp: f32,
    /// Whether the tip tapers (grown hair) or is cut square (shaven stubble).
    pub tapered: bool,
    /// See [`CubicBezier::chord_deviation`].
    #[serde(skip)]
    pub chord_deviation: f32,
    /// Its bounds (the grid's cells are coarser than a stubble hair; most texels stop here).
    #[serde(skip)]
    lo: Vec3,
    #[serde(skip)]
    hi: Vec3,
}

/// Tightest curvature radius (mm) of skin a strand lies on, for its sag below the skin (authored:
/// the brow ridge, the jaw's curve and the nose's side are several centimetres across; 10 mm
/// leaves a margin).
const MIN_SKIN_RADIUS_MM: f32 = 10.0;

/// What every strand of a kind shares.
pub struct StrandParams {
    /// Hair colour (linear RGB), from the hair's melanins.
    pub color: [f32; 3],
}

impl Strand {
    /// A fibre of radius `radius` (mm) along `curve`, on texels of `pitch_mm`.
    pub fn new(curve: CubicBezier, radius: f32, tapered: bool, pitch_mm: f32) -> Self {
        let r_eff = radius.max(super::MIN_TEXELS * pitch_mm);
        let chord_deviation = curve.chord_deviation();
        // Texels it paints lie on the skin within `r_eff` of the curve in the tangent plane: in
        // space within r_eff plus the curve's sag below the skin, span² / 8R on skin of
        // curvature radius R.
        let span = curve.p[0].distance(curve.p[3]) + 2.0 * chord_deviation;
        let m = Vec3::splat(r_eff + span * span / (8.0 * MIN_SKIN_RADIUS_MM));
        let (lo, hi) = curve.bounds();
        Self {
            curve,
            radius: r_eff,
            amp: radius / r_eff,
            tapered,
            chord_deviation,
            lo: lo - m,
            hi: hi + m,
        }
    }

    /// The fibre's half-width at curve parameter `t` (a fraction of the full radius).
    #[inline]
    fn taper(&self, t: f32) -> f32 {
        if self.tapered && t > 1.0 - TIP_TAPER {
            (1.0 - t) / TIP_TAPER
        } else {
            1.0
        }
    }
}

impl Feature for Strand {
    type Params = StrandParams;
    fn bounds(&self) -> (Vec3, Vec3) {
        (self.lo, self.hi)
    }
    fn translated(&self, d: Vec3) -> Self {
        let mut s = self.clone();
        s.curve.p = s.curve.p.map(|p| p + d);
        s.lo += d;
        s.hi += d;
        s
    }
    #[inline]
    fn apply(&self, prm: &StrandParams, q: &PaintPoint, s: &mut BioSample) {
        if q.p.cmplt(self.lo).any() || q.p.cmpgt(self.hi).any() {
            return;
        }
        if self
            .curve
            .tangentially_beyond(q.p, q.n, self.chord_deviation, self.radius)
        {
            return;
        }
        let (t, d2) = self.curve.closest_tangential(q.p, q.n, NORMAL_REACH);
        let r = self.radius * self.taper(t);
        if r <= 0.0 || d2 >= r * r {
            return;
        }
        // A cylinder seen from above: its height the half-chord of its circle, its coverage
        // falling towards the edges where the fibre thins; widened, both keep their cross-
        // section (coverage ∝ amp, height ∝ amp² as the fibre's area is).
        let across = (1.0 - d2 / (r * r)).sqrt();
        s.add_extra(prm.color, self.amp * across.min(1.0).sqrt());
        s.height_mm += self.amp * self.amp * r * across;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(radius: f32, pitch: f32, tapered: bool) -> Strand {
        let p = [0.0f32, 2.0, 4.0, 6.0].map(|x| Vec3::new(x, 0.0, 0.0));
        Strand::new(CubicBezier { p }, radius, tapered, pitch)
    }

    fn paint(s: &Strand, x: f32, y: f32) -> BioSample {
        let mut b = BioSample::default();
        let q = PaintPoint {
            p: Vec3::new(x, y, 0.0),
            n: Vec3::Z,
        };
        s.apply(
            &StrandParams {
                color: [0.1, 0.05, 0.02],
            },
            &q,
            &mut b,
        );
        b
    }

    #[test]
    fn a_strand_covers_its_fibre_and_raises_a_cylinder() {
        let s = straight(0.05, 0.001, true);
        let on = paint(&s, 3.0, 0.0);
        assert!((on.extra[3] - 1.0).abs() < 1e-6 && (on.extra[0] - 0.1).abs() < 1e-6);
        assert!((on.height_mm - 0.05).abs() < 1e-6);
        assert_eq!(paint(&s, 3.0, 0.06).extra[3], 0.0);
        // Behind the root and past the tip: nothing; near the tip the fibre has narrowed.
        assert_eq!(paint(&s, -0.2, 0.0).extra[3], 0.0);
        assert_eq!(paint(&s, 5.9, 0.03).extra[3], 0.0);
        assert!(paint(&straight(0.05, 0.001, false), 5.9, 0.03).extra[3] > 0.0);
    }

    #[test]
    fn widening_keeps_the_hair_s_area() {
        // Coverage integrated across the fibre: the same for a fine and a widened strand.
        let across = |s: &Strand| -> f32 {
            let n = 4000;
            (0..n)
                .map(|k| paint(s, 3.0, -0.5 + k as f32 / n as f32).extra[3] / n as f32)
                .sum()
        };
        let (fine, wide) = (straight(0.04, 0.001, false), straight(0.04, 0.2, false));
        assert!(wide.radius > 0.1 && wide.amp < 0.3);
        let (a, b) = (across(&fine), across(&wide));
        assert!((a - b).abs() < 0.05 * a, "{a} vs {b}");
    }

    #[test]
    fn a_strand_follows_a_curved_surface() {
        // On a sphere of radius 40 mm a 6 mm strand on the surface sags 0.11 mm below its chord:
        // measured in the tangent plane the middle of the strand is still covered.
        let r = 40.0f32;
        let on = |a: f32| Vec3::new(r * a.sin(), 0.0, r * a.cos());
        let p = [0.0, 0.05, 0.1, 0.15].map(on);
        let s = Strand::new(CubicBezier { p }, 0.04, false, 0.001);
        let q = on(0.075);
        let mut b = BioSample::default();
        let pp = PaintPoint {
            p: q,
            n: q.normalize(),
        };
        s.apply(&StrandParams { color: [0.1; 3] }, &pp, &mut b);
        assert!(b.extra[3] > 0.9, "{}", b.extra[3]);
    }
}
