//! The template's first placement on a scan: a similarity from landmark pairs (Umeyama 1991,
//! "Least-squares estimation of transformation parameters between two point patterns", PAMI
//! 13(4)), or from the nose tip, then refined by a trimmed similarity ICP (Besl & McKay 1992).

use super::options::{FitError, Similarity};
use super::scan::Scan;
use derma_core::numerics::{dense, Matrix};
use glam::{Mat3, Vec3};

/// The landmarks an alignment from landmarks needs at least.
pub const REQUIRED: [&str; 7] = [
    "canthus_inner_left",
    "canthus_inner_right",
    "canthus_outer_left",
    "canthus_outer_right",
    "nose_tip",
    "mouth_corner_left",
    "mouth_corner_right",
];

/// The similarity that best maps `src` onto `dst` in least squares with weights (Umeyama 1991,
/// eqs. 40–42), or None for fewer than three non-collinear pairs.
pub fn umeyama(src: &[Vec3], dst: &[Vec3], w: &[f32]) -> Option<Similarity> {
    let total: f64 = w.iter().map(|&x| x as f64).sum();
    if src.len() < 3 || total <= 0.0 {
        return None;
    }
    let mean = |p: &[Vec3]| -> [f64; 3] {
        let mut m = [0.0; 3];
        for (q, &wi) in p.iter().zip(w) {
            for k in 0..3 {
                m[k] += wi as f64 * q[k] as f64;
            }
        }
        m.map(|x| x / total)
    };
    let (ms, md) = (mean(src), mean(dst));
    let mut cov = [[0.0f64; 3]; 3];
    let mut var = 0.0;
    for ((s, d), &wi) in src.iter().zip(dst).zip(w) {
        let s = [0, 1, 2].map(|k| s[k] as f64 - ms[k]);
        let d = [0, 1, 2].map(|k| d[k] as f64 - md[k]);
        for (i, ci) in cov.iter_mut().enumerate() {
            for (j, cij) in ci.iter_mut().enumerate() {
                *cij += wi as f64 * d[i] * s[j];
            }
        }
        var += wi as f64 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    }
    let cov = Matrix::from_fn(3, 3, |i, j| cov[i][j] / total);
    let var = var / total;
    let svd = dense::svd(&cov).ok()?;
    if svd.s[1] <= 1e-9 * svd.s[0].max(1e-30) {
        return None;
    }
    let (u, v) = (&svd.u, &svd.v);
    let det = |m: &Matrix| {
        m[(0, 0)] * (m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)])
            - m[(0, 1)] * (m[(1, 0)] * m[(2, 2)] - m[(1, 2)] * m[(2, 0)])
            + m[(0, 2)] * (m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)])
    };
    let sgn = if det(u) * det(v) < 0.0 { -1.0 } else { 1.0 };
    let d = [1.0, 1.0, sgn];
    let r = |i: usize, j: usize| (0..3).map(|k| u[(i, k)] * d[k] * v[(j, k)]).sum::<f64>();
    let rotation = Mat3::from_cols(
        Vec3::new(r(0, 0) as f32, r(1, 0) as f32, r(2, 0) as f32),
        Vec3::new(r(0, 1) as f32, r(1, 1) as f32, r(2, 1) as f32),
        Vec3::new(r(0, 2) as f32, r(1, 2) as f32, r(2, 2) as f32),
    );
    let scale = ((0..3).map(|k| svd.s[k] * d[k]).sum::<f64>() / var) as f32;
    let ms = Vec3::new(ms[0] as f32, ms[1] as f32, ms[2] as f32);
    let md = Vec3::new(md[0] as f32, md[1] as f32, md[2] as f32);
    Some(Similarity {
        scale,
        rotation,
        translation: md - scale * (rotation * ms),
    })
}

/// Trimmed similarity ICP: `points` (with normals) of the template, already placed by `start`,
/// are matched to their closest scan points within a shrinking distance and compatible normals,
/// and the similarity is re-solved; returns the refined similarity (applied after `start`'s
/// frame, i.e. the whole map) and the share of points matched at the end.
pub fn icp(
    scan: &Scan,
    points: &[Vec3],
    normals: &[Vec3],
    start: Similarity,
    iterations: usize,
    max_distance: f32,
) -> (Similarity, f32) {
    let mut t = start;
    let mut share = 0.0;
    for it in 0..iterations {
        let tau = max_distance * (1.0 - 0.6 * it as f32 / iterations.max(1) as f32);
        let (mut src, mut dst) = (Vec::new(), Vec::new());
        for (p, n) in points.iter().zip(normals) {
            let q = t.apply(*p);
            let nq = t.rotation * *n;
            if let Some(c) = scan.matched(q, nq, tau) {
                src.push(*p);
                dst.push(c.point);
            }
        }
        share = src.len() as f32 / points.len().max(1) as f32;
        let w = vec![1.0; src.len()];
        // The scale may move by at most ×2 from the start's (a scan in any unit).
        match umeyama(&src, &dst, &w) {
            Some(s) if (0.5..2.0).contains(&(s.scale / start.scale)) => t = s,
            _ => break,
        }
    }
    (t, share)
}

/// The corners a placement detects on the scan: both canthi of each eye and the mouth corners.
pub const CORNERS: [&str; 6] = [
    "canthus_inner_left",
    "canthus_outer_left",
    "canthus_inner_right",
    "canthus_outer_right",
    "mouth_corner_left",
    "mouth_corner_right",
];

/// How far (mm) from where the placed template puts a corner the scan is searched for it.
pub const CORNER_SEARCH_MM: f32 = 6.0;

/// The eye and mouth corners found on `scan` near `placed` (the template's [`CORNERS`], in
/// order, placed on the scan by the alignment): each opening's corner is its extreme point
/// along the line through the opening's two placed corners — among the scan's border vertices
/// where the opening is a hole (open eyes, parted lips), else among its crease vertices (the
/// most concave fifth within reach: a closed lid's or lips' meeting line). `None` where the
/// scan has no vertex within [`CORNER_SEARCH_MM`], or the extreme lies on the search's rim
/// ([`CORNER_RIM`]).
pub fn detect_corners(scan: &Scan, placed: &[Vec3; 6]) -> [Option<Vec3>; 6] {
    let mesh = &scan.mesh;
    // Concavity: how far the mean of a vertex's neighbours lies along its normal.
    let mut sum = vec![Vec3::ZERO; mesh.positions.len()];
    let mut count = vec![0u32; mesh.positions.len()];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b, c) = (
                t[k] as usize,
                t[(k + 1) % 3] as usize,
                t[(k + 2) % 3] as usize,
            );
            sum[a] += mesh.positions[b] + mesh.positions[c];
            count[a] += 2;
        }
    }
    let concavity = |i: usize| -> f32 {
        if count[i] == 0 {
            return f32::NEG_INFINITY;
        }
        (sum[i] / count[i] as f32 - mesh.positions[i]).dot(scan.vertex_normals[i])
    };
    std::array::from_fn(|k| {
        let p0 = placed[k];
        let near: Vec<usize> = (0..mesh.positions.len())
            .filter(|&i| mesh.positions[i].distance(p0) < CORNER_SEARCH_MM)
            .collect();
        let border: Vec<usize> = near
            .iter()
            .copied()
            .filter(|&i| scan.border_vertex[i])
            .collect();
        let pool = if border.len() >= 3 {
            border
        } else {
            let mut c: Vec<(f32, usize)> = near.iter().map(|&i| (concavity(i), i)).collect();
            c.sort_by(|a, b| b.0.total_cmp(&a.0));
            c.truncate((c.len() / 5).max(1));
            c.into_iter().map(|x| x.1).collect()
        };
        // A corner on the rim of the search is the search's edge, not the opening's corner.
        opening_corner(&mesh.positions, &pool, placed, k)
            .map(|i| mesh.positions[i])
            .filter(|c| c.distance(p0) < CORNER_RIM * CORNER_SEARCH_MM)
    })
}

/// The share of [`CORNER_SEARCH_MM`] within which a found corner counts (beyond it, the
/// opening's corner lies outside the search).
pub const CORNER_RIM: f32 = 0.75;

/// The corner `k` of an opening, by one rule for a scan, the template and the fitted skin:
/// among `candidates` (indices into `positions`) within [`CORNER_SEARCH_MM`] of `corners[k]`
/// (the [`CORNERS`] as placed or fitted), the one farthest along the line from the opening's
/// other corner (inner ↔ outer canthus, left ↔ right mouth corner: `k ^ 1`).
pub fn opening_corner(
    positions: &[Vec3],
    candidates: &[usize],
    corners: &[Vec3; 6],
    k: usize,
) -> Option<usize> {
    let (p0, other) = (corners[k], corners[k ^ 1]);
    let axis = (p0 - other).normalize_or_zero();
    let along = |i: usize| (positions[i] - other).dot(axis);
    candidates
        .iter()
        .copied()
        .filter(|&i| positions[i].distance(p0) < CORNER_SEARCH_MM)
        .max_by(|&a, &b| along(a).total_cmp(&along(b)))
}

/// Checks given landmarks lie on the scan: each within `limit` mm of its surface.
pub fn check_on_surface(scan: &Scan, named: &[(String, Vec3)], limit: f32) -> Result<(), FitError> {
    for (name, p) in named {
        if !p.is_finite() {
            return Err(FitError::Landmark {
                name: name.clone(),
                detail: format!("{:?} is not a finite point", p.to_array()),
            });
        }
        let d = scan
            .bvh
            .closest(*p, f32::INFINITY)
            .map(|c| c.distance)
            .unwrap_or(f32::INFINITY);
        if d > limit {
            return Err(FitError::Landmark {
                name: name.clone(),
                detail: format!(
                    "it is {d:.1} mm from the scan's surface (at most {limit:.0} mm expected); are the landmarks in the scan's units and frame?"
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn umeyama_recovers_a_known_similarity() {
        let src: Vec<Vec3> = (0..12)
            .map(|i| {
                let f = i as f32;
                Vec3::new(
                    (f * 1.7).sin() * 40.0,
                    (f * 0.9).cos() * 30.0,
                    f * 3.0 - 10.0,
                )
            })
            .collect();
        let truth = Similarity {
            scale: 0.1,
            rotation: Mat3::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1),
            translation: Vec3::new(5.0, -2.0, 30.0),
        };
        let dst: Vec<Vec3> = src.iter().map(|p| truth.apply(*p)).collect();
        let s = umeyama(&src, &dst, &vec![1.0; src.len()]).expect("well posed");
        assert!((s.scale - 0.1).abs() < 1e-5);
        for p in &src {
            assert!((s.apply(*p) - truth.apply(*p)).length() < 1e-3);
        }
        // Collinear points do not fix a rotation.
        let line: Vec<Vec3> = (0..5).map(|i| Vec3::X * i as f32).collect();
        assert!(umeyama(&line, &line, &[1.0; 5]).is_none());
    }
}
