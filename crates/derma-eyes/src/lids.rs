//! Eyelid shapes as curves (thesis §3.5): each lid margin, from the inner to the outer canthus,
//! as the control points of an interpolating cubic spline (17–22 points per lid in the thesis;
//! derma uses 20), resampled at equal arc length from a tracked or rigged margin, and the lid
//! aperture read off the curves (§3.3: upper and lower displacements from the closure plane).

use glam::{Vec2, Vec3};

/// Control points per lid (the thesis: 17 to 22 capture the shape faithfully).
pub const CONTROL_POINTS: usize = 20;

/// The modelling camera P of §3.2, here orthographic and frontal: u = (x, y) in head millimetres,
/// depth z. It is invertible given the depth, as the thesis requires, and keeps apertures in
/// millimetres so they compare with anatomical data directly.
pub fn project(p: Vec3) -> Vec2 {
    Vec2::new(p.x, p.y)
}

/// `n` points at equal arc length along the polyline `chain` (both ends kept).
pub fn resample(chain: &[Vec2], n: usize) -> Vec<Vec2> {
    resample_params(chain, n)
        .into_iter()
        .map(|(i, t)| chain[i].lerp(chain[i + 1], t))
        .collect()
}

/// Where [`resample`]'s points fall: (segment, fraction along it) — to carry the same samples
/// onto 3D positions of the chain.
pub fn resample_params(chain: &[Vec2], n: usize) -> Vec<(usize, f32)> {
    let mut acc = vec![0.0f32];
    for w in chain.windows(2) {
        acc.push(acc.last().copied().unwrap_or(0.0) + (w[1] - w[0]).length());
    }
    let total = *acc.last().unwrap_or(&0.0);
    (0..n)
        .map(|k| {
            let s = total * k as f32 / (n - 1).max(1) as f32;
            let i = acc.partition_point(|&a| a <= s).clamp(1, chain.len() - 1);
            let span = (acc[i] - acc[i - 1]).max(1e-12);
            (i - 1, ((s - acc[i - 1]) / span).clamp(0.0, 1.0))
        })
        .collect()
}

/// A point on the interpolating (Catmull–Rom) cubic spline through `cps` at parameter
/// t ∈ [0, 1] over the whole curve (ends duplicated).
pub fn spline(cps: &[Vec2], t: f32) -> Vec2 {
    let n = cps.len();
    let f = t.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (f.floor() as usize).min(n - 2);
    let s = f - i as f32;
    let p = |k: isize| cps[k.clamp(0, n as isize - 1) as usize];
    let (p0, p1, p2, p3) = (
        p(i as isize - 1),
        p(i as isize),
        p(i as isize + 1),
        p(i as isize + 2),
    );
    let s2 = s * s;
    let s3 = s2 * s;
    0.5 * (2.0 * p1
        + (p2 - p0) * s
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * s2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * s3)
}

/// Height (y) of a lid curve at the horizontal midpoint between its ends (the canthi), where
/// the thesis measures the lid displacement.
pub fn mid_height(cps: &[Vec2]) -> f32 {
    let (a, b) = (cps[0], cps[cps.len() - 1]);
    let x = 0.5 * (a.x + b.x);
    // The curve is a graph over x between the canthi: bisect the spline parameter.
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    let increasing = b.x > a.x;
    for _ in 0..30 {
        let m = 0.5 * (lo + hi);
        if (spline(cps, m).x < x) == increasing {
            lo = m;
        } else {
            hi = m;
        }
    }
    spline(cps, 0.5 * (lo + hi)).y
}

/// The palpebral opening (mm): upper minus lower lid height at the mid-fissure.
pub fn opening(upper: &[Vec2], lower: &[Vec2]) -> f32 {
    mid_height(upper) - mid_height(lower)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_is_uniform_and_the_spline_interpolates() {
        let chain: Vec<Vec2> = (0..=40)
            .map(|i| {
                let x = i as f32 * 0.75;
                Vec2::new(x, 5.0 * (std::f32::consts::PI * x / 30.0).sin())
            })
            .collect();
        let cps = resample(&chain, CONTROL_POINTS);
        assert_eq!(cps[0], chain[0]);
        assert!((cps[CONTROL_POINTS - 1] - chain[40]).length() < 1e-4);
        let d: Vec<f32> = cps.windows(2).map(|w| (w[1] - w[0]).length()).collect();
        let mean = d.iter().sum::<f32>() / d.len() as f32;
        assert!(d.iter().all(|x| (x - mean).abs() < 0.02 * mean), "{d:?}");
        for (k, c) in cps.iter().enumerate() {
            let t = k as f32 / (CONTROL_POINTS - 1) as f32;
            assert!((spline(&cps, t) - *c).length() < 1e-5);
        }
        // A half-sine lid of height 5 mm: the mid height is its peak.
        assert!(
            (mid_height(&cps) - 5.0).abs() < 0.01,
            "{}",
            mid_height(&cps)
        );
        let lower: Vec<Vec2> = cps.iter().map(|p| Vec2::new(p.x, -0.5 * p.y)).collect();
        assert!((opening(&cps, &lower) - 7.5).abs() < 0.02);
    }
}
