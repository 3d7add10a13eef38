//! Cubic Bézier curves in 3D and the closest point on them (thesis §4.8.1): bracketed by coarse
//! sampling, then refined by golden-section search (Press et al., Numerical Recipes §10.2, the
//! thesis' reference [23]).

use glam::Vec3;

/// A cubic Bézier curve with control points `p` (Foley et al., §11.2).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CubicBezier {
    /// Control points P₀ … P₃ (mm).
    pub p: [Vec3; 4],
}

/// Distance from `p` to the segment [a, b].
#[inline]
pub fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// Golden ratio conjugate (√5 − 1)/2.
const INV_PHI: f32 = 0.618_034;
/// Coarse samples used to bracket the global minimum before the golden-section search.
const BRACKET_SAMPLES: usize = 16;

impl CubicBezier {
    /// B(t) = (1−t)³P₀ + 3(1−t)²tP₁ + 3(1−t)t²P₂ + t³P₃.
    #[inline]
    pub fn eval(&self, t: f32) -> Vec3 {
        let s = 1.0 - t;
        self.p[0] * (s * s * s)
            + self.p[1] * (3.0 * s * s * t)
            + self.p[2] * (3.0 * s * t * t)
            + self.p[3] * (t * t * t)
    }

    /// Length by summing 64 chords.
    pub fn length(&self) -> f32 {
        (0..64)
            .map(|i| (self.eval((i + 1) as f32 / 64.0) - self.eval(i as f32 / 64.0)).length())
            .sum()
    }

    /// (t, squared distance) of the closest point to `q` under `dist2`.
    pub fn closest_by(&self, dist2: impl Fn(Vec3) -> f32) -> (f32, f32) {
        let mut best = (0.0f32, f32::INFINITY);
        for i in 0..=BRACKET_SAMPLES {
            let t = i as f32 / BRACKET_SAMPLES as f32;
            let d = dist2(self.eval(t));
            if d < best.1 {
                best = (t, d);
            }
        }
        let h = 1.0 / BRACKET_SAMPLES as f32;
        let (mut a, mut b) = ((best.0 - h).max(0.0), (best.0 + h).min(1.0));
        let mut c = b - INV_PHI * (b - a);
        let mut d = a + INV_PHI * (b - a);
        let (mut fc, mut fd) = (dist2(self.eval(c)), dist2(self.eval(d)));
        // 14 iterations shrink the bracket (width 1/8) by 0.618¹⁴ ≈ 1.2·10⁻³ → |Δt| < 2·10⁻⁴.
        for _ in 0..14 {
            if fc < fd {
                b = d;
                d = c;
                fd = fc;
                c = b - INV_PHI * (b - a);
                fc = dist2(self.eval(c));
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + INV_PHI * (b - a);
                fd = dist2(self.eval(d));
            }
        }
        let t = 0.5 * (a + b);
        let f = dist2(self.eval(t));
        if f < best.1 {
            (t, f)
        } else {
            best
        }
    }

    /// (t, squared distance) of the point of the curve closest to `q` measured in the tangent
    /// plane at `q` (normal `n`): the separation minus its component along the normal, so a
    /// curve lying on a curved surface is found though its chords sink below it. Points farther
    /// than `reach` along the normal are on another part of the surface and count as 10⁶ mm².
    #[inline]
    pub fn closest_tangential(&self, q: Vec3, n: Vec3, reach: f32) -> (f32, f32) {
        self.closest_by(|c| {
            let sep = q - c;
            let sn = sep.dot(n);
            (sep - n * sn).length_squared() + if sn.abs() > reach { 1e6 } else { 0.0 }
        })
    }

    /// Largest distance of the curve from its chord P₀P₃, bounded by the control points (the
    /// curve lies in their convex hull).
    pub fn chord_deviation(&self) -> f32 {
        let [p0, p1, p2, p3] = self.p;
        segment_distance(p1, p0, p3).max(segment_distance(p2, p0, p3))
    }

    /// Whether the curve certainly stays farther than `r` from `q` in the tangent plane at `q`:
    /// the tangential distance to the chord minus the chord deviation `dev` exceeds `r`
    /// (projection onto a plane is a contraction), so most points skip the closest-point search.
    #[inline]
    pub fn tangentially_beyond(&self, q: Vec3, n: Vec3, dev: f32, r: f32) -> bool {
        let flat = |v: Vec3| v - n * v.dot(n);
        let (a, b) = (flat(self.p[0] - q), flat(self.p[3] - q));
        segment_distance(Vec3::ZERO, a, b) - dev > r
    }

    /// Axis-aligned bounds of the control polygon (which contains the curve).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let lo = self.p[0].min(self.p[1]).min(self.p[2]).min(self.p[3]);
        let hi = self.p[0].max(self.p[1]).max(self.p[2]).max(self.p[3]);
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_on_a_straight_curve() {
        // Control points evenly spaced on a line → B(t) = P₀ + t(P₃ − P₀).
        let b = CubicBezier {
            p: [
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(3.0, 0.0, 0.0),
            ],
        };
        let q = Vec3::new(1.2, 0.5, 0.0);
        let (t, d2) = b.closest_by(|p| (p - q).length_squared());
        assert!((t - 0.4).abs() < 1e-3, "{t}");
        assert!((d2.sqrt() - 0.5).abs() < 1e-3);
        assert!((b.length() - 3.0).abs() < 1e-4);
    }

    #[test]
    fn golden_section_agrees_with_dense_search() {
        let b = CubicBezier {
            p: [
                Vec3::ZERO,
                Vec3::new(1.0, 2.0, 0.0),
                Vec3::new(3.0, -2.0, 0.0),
                Vec3::new(4.0, 0.5, 0.0),
            ],
        };
        for k in 0..50 {
            let q = Vec3::new(-0.5 + 0.1 * k as f32, 0.3 * ((k * 7) % 5) as f32 - 0.6, 0.0);
            let (_, d2) = b.closest_by(|p| (p - q).length_squared());
            let dense = (0..=20000)
                .map(|i| (b.eval(i as f32 / 20000.0) - q).length_squared())
                .fold(f32::INFINITY, f32::min);
            assert!(
                d2.sqrt() - dense.sqrt() < 2e-3,
                "q {q}: {} vs {}",
                d2.sqrt(),
                dense.sqrt()
            );
        }
    }
}
