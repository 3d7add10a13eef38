//! Moving a trained model to other vertices (thesis §3.6): character transfer through a sparse
//! barycentric map B from a registered target mesh onto the captured subject's mesh (eq. 3.4),
//! and extrapolation B⁺ of untracked vertices as inverse-distance-weighted sums of nearby tracked
//! ones in the starting frame (eq. 3.5).

use glam::Vec3;

/// Weights of nearby tracked vertices per extrapolated vertex (rows of B⁺ beyond the identity).
pub type Rows = Vec<Vec<(u32, f32)>>;

/// Neighbours per extrapolated vertex.
pub const NEIGHBOURS: usize = 4;

/// B⁺ rows: for each target (position, eye) the `NEIGHBOURS` nearest sources of the same eye in
/// the starting frame, weights ∝ 1 / distance, normalised (§3.6). A target that coincides with
/// a source copies it.
pub fn extrapolation(
    sources: &[Vec3],
    source_eye: &[u8],
    targets: &[Vec3],
    target_eye: &[u8],
) -> Rows {
    use rayon::prelude::*;
    targets
        .par_iter()
        .zip(target_eye)
        .map(|(&p, &te)| {
            let mut best: Vec<(f32, u32)> = Vec::with_capacity(NEIGHBOURS + 1);
            for (j, (&q, &se)) in sources.iter().zip(source_eye).enumerate() {
                if se != te {
                    continue;
                }
                let d = (p - q).length();
                if best.len() < NEIGHBOURS || d < best[best.len() - 1].0 {
                    let at = best.partition_point(|b| b.0 <= d);
                    best.insert(at, (d, j as u32));
                    best.truncate(NEIGHBOURS);
                }
            }
            if let Some(&(d, j)) = best.first() {
                if d < 1e-6 {
                    return vec![(j, 1.0)];
                }
            }
            let sum: f32 = best.iter().map(|b| 1.0 / b.0).sum();
            best.iter().map(|b| (b.1, 1.0 / b.0 / sum)).collect()
        })
        .collect()
}

/// The closest point of triangle (a, b, c) to p as barycentric weights (Ericson, "Real-Time
/// Collision Detection", §5.1.5).
pub fn closest_barycentric(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> [f32; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}

/// B of eq. 3.4: for each vertex of a target mesh registered onto the subject (same space), the
/// subject triangle it snaps to and its barycentric weights, as rows of (subject vertex, weight).
pub fn barycentric_map(subject: &[Vec3], triangles: &[[u32; 3]], target: &[Vec3]) -> Rows {
    use rayon::prelude::*;
    target
        .par_iter()
        .map(|&p| {
            let mut best = (f32::MAX, [0u32; 3], [1.0f32, 0.0, 0.0]);
            for t in triangles {
                let [a, b, c] = t.map(|i| subject[i as usize]);
                let w = closest_barycentric(p, a, b, c);
                let q = a * w[0] + b * w[1] + c * w[2];
                let d = (q - p).length_squared();
                if d < best.0 {
                    best = (d, *t, w);
                }
            }
            (0..3)
                .filter(|&k| best.2[k] > 0.0)
                .map(|k| (best.1[k], best.2[k]))
                .collect()
        })
        .collect()
}

/// Applies rows of B to per-vertex 2D values (ũ = B u).
pub fn apply(rows: &Rows, u: &[glam::Vec2]) -> Vec<glam::Vec2> {
    rows.iter()
        .map(|r| r.iter().map(|&(j, w)| w * u[j as usize]).sum())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn barycentric_map_reproduces_linear_motion_and_extrapolation_is_a_partition_of_unity() {
        // A 5 × 5 grid subject; targets at random-ish points on it.
        let n = 5;
        let subject: Vec<Vec3> = (0..n * n)
            .map(|i| Vec3::new((i % n) as f32, (i / n) as f32, 0.0))
            .collect();
        let mut tris = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = (y * n + x) as u32;
                tris.push([i, i + 1, i + n as u32]);
                tris.push([i + 1, i + n as u32 + 1, i + n as u32]);
            }
        }
        let target: Vec<Vec3> = (0..30)
            .map(|k| Vec3::new((k as f32 * 0.37) % 4.0, (k as f32 * 0.61) % 4.0, 0.2))
            .collect();
        let b = barycentric_map(&subject, &tris, &target);
        // A linear motion field u(p) = A p + c maps exactly.
        let f = |p: Vec3| Vec2::new(0.3 * p.x - 0.1 * p.y + 2.0, 0.05 * p.x + 0.7 * p.y);
        let u: Vec<Vec2> = subject.iter().map(|&p| f(p)).collect();
        for (t, m) in target.iter().zip(apply(&b, &u)) {
            assert!((m - f(*t)).length() < 1e-4, "{m} {}", f(*t));
        }
        let e = extrapolation(&subject[..10], &[0; 10], &subject[10..], &[0; 15]);
        assert_eq!(e.len(), 15);
        for r in &e {
            let s: f32 = r.iter().map(|w| w.1).sum();
            assert!((s - 1.0).abs() < 1e-5 && r.iter().all(|w| w.0 < 10 && w.1 > 0.0));
        }
    }
}
