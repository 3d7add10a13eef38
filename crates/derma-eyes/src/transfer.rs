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

/// B of eq. 3.4: for each vertex of a target mesh registered onto the subject (same space), the
/// subject triangle it snaps to and its barycentric weights, as rows of (subject vertex, weight).
pub fn barycentric_map(subject: &[Vec3], triangles: &[[u32; 3]], target: &[Vec3]) -> Rows {
    use rayon::prelude::*;
    let bvh = derma_core::bvh::Bvh::new(subject, triangles);
    target
        .par_iter()
        .map(|&p| match bvh.closest(p, f32::INFINITY) {
            Some(c) => {
                let t = triangles[c.triangle as usize];
                let w = [1.0 - c.bary[0] - c.bary[1], c.bary[0], c.bary[1]];
                (0..3)
                    .filter(|&k| w[k] > 0.0)
                    .map(|k| (t[k], w[k]))
                    .collect()
            }
            None => Vec::new(),
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
