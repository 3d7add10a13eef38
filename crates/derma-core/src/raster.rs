//! UV-space rasterisation of a mesh into a per-texel surface buffer (thesis §4.8.7, UVtoManifold):
//! each covered texel maps to one point on the surface; uncovered texels are filled by dilation.

use crate::mesh::TriMesh;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Marker for a texel that no triangle covers.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// Per-texel surface samples of a mesh rasterised in UV space. Row 0 is the top of the image
/// (v = 1); texel (x, y) is sampled at its centre u = (x+½)/w, v = 1 − (y+½)/h.
pub struct UvRaster {
    /// Width of the raster in texels.
    pub width: usize,
    /// Height of the raster in texels.
    pub height: usize,
    /// Triangle covering each texel, or [`NO_TRIANGLE`].
    pub triangle: Vec<u32>,
    /// Barycentric weights (of corners 1 and 2) of the texel centre in its triangle.
    pub bary: Vec<[f32; 2]>,
    /// Number of distinct triangles whose UV footprint overlaps another triangle's interior.
    pub overlapping_triangles: usize,
    /// Number of triangles with UVs outside [0, 1]² (their outside part is not painted).
    pub triangles_outside_unit_square: usize,
}

/// Rows per parallel band: small enough to balance two cores, large enough to amortise binning.
const BAND_ROWS: usize = 32;

impl UvRaster {
    /// Rasterises every triangle of `mesh` into a `width` × `height` grid (texel-centre sampling,
    /// inclusive edges; a texel claimed twice by triangle interiors counts as a UV overlap).
    pub fn new(mesh: &TriMesh, width: usize, height: usize) -> UvRaster {
        let n = width * height;
        let nbands = height.div_ceil(BAND_ROWS);
        // Bin triangles by the bands their UV bounding boxes touch.
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nbands];
        let mut outside = 0usize;
        for (ti, t) in mesh.triangles.iter().enumerate() {
            let uv = t.map(|i| mesh.uvs[i as usize]);
            let (lo, hi) = (uv[0].min(uv[1]).min(uv[2]), uv[0].max(uv[1]).max(uv[2]));
            if lo.x < -1e-4 || lo.y < -1e-4 || hi.x > 1.0 + 1e-4 || hi.y > 1.0 + 1e-4 {
                outside += 1;
            }
            let y0 = ((1.0 - hi.y) * height as f32 - 0.5).floor().max(0.0) as usize;
            let y1 = (((1.0 - lo.y) * height as f32 - 0.5).ceil().max(0.0) as usize)
                .min(height.saturating_sub(1));
            if y0 > y1 || y0 >= height {
                continue;
            }
            for bin in &mut bins[y0 / BAND_ROWS..=y1 / BAND_ROWS] {
                bin.push(ti as u32);
            }
        }
        let mut triangle = vec![NO_TRIANGLE; n];
        let mut bary = vec![[0.0f32; 2]; n];
        let conflicts: Vec<Vec<u32>> = triangle
            .par_chunks_mut(BAND_ROWS * width)
            .zip(bary.par_chunks_mut(BAND_ROWS * width))
            .enumerate()
            .map(|(b, (tri, bar))| {
                let row0 = b * BAND_ROWS;
                let rows = tri.len() / width;
                let mut inside_margin = vec![0.0f32; tri.len()];
                let mut conflicts = Vec::new();
                for &ti in &bins[b] {
                    let t = mesh.triangles[ti as usize];
                    let uv =
                        t.map(|i| mesh.uvs[i as usize] * Vec2::new(width as f32, height as f32));
                    // texel-space coordinates with y down
                    let p = uv.map(|q| Vec2::new(q.x, height as f32 - q.y));
                    let area = (p[1] - p[0]).perp_dot(p[2] - p[0]);
                    if area.abs() < 1e-12 {
                        continue;
                    }
                    let lo = p[0].min(p[1]).min(p[2]);
                    let hi = p[0].max(p[1]).max(p[2]);
                    let x0 = (lo.x - 0.5).ceil().max(0.0) as usize;
                    let x1 = ((hi.x - 0.5).floor() as i64).min(width as i64 - 1);
                    let ya = ((lo.y - 0.5).ceil().max(row0 as f32)) as usize;
                    let yb = ((hi.y - 0.5).floor() as i64).min((row0 + rows) as i64 - 1);
                    if x1 < x0 as i64 || yb < ya as i64 {
                        continue;
                    }
                    for y in ya..=(yb as usize) {
                        for x in x0..=(x1 as usize) {
                            let c = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                            let w1 = (c - p[0]).perp_dot(p[2] - p[0]) / area;
                            let w2 = (p[1] - p[0]).perp_dot(c - p[0]) / area;
                            let w0 = 1.0 - w1 - w2;
                            let margin = w0.min(w1).min(w2);
                            if margin < -1e-6 {
                                continue;
                            }
                            let k = (y - row0) * width + x;
                            if tri[k] != NO_TRIANGLE {
                                // Shared edges touch with margin ≈ 0; interiors overlapping is a UV overlap.
                                if margin > 1e-3 && inside_margin[k] > 1e-3 {
                                    conflicts.push(ti);
                                    conflicts.push(tri[k]);
                                }
                                if margin <= inside_margin[k] {
                                    continue;
                                }
                            }
                            tri[k] = ti;
                            inside_margin[k] = margin;
                            bar[k] = [w1, w2];
                        }
                    }
                }
                conflicts
            })
            .collect();
        let mut all: Vec<u32> = conflicts.into_iter().flatten().collect();
        all.sort_unstable();
        all.dedup();
        UvRaster {
            width,
            height,
            triangle,
            bary,
            overlapping_triangles: all.len(),
            triangles_outside_unit_square: outside,
        }
    }

    #[inline]
    /// Whether texel `i` lies on a triangle.
    pub fn covered(&self, i: usize) -> bool {
        self.triangle[i] != NO_TRIANGLE
    }

    /// Surface point (mesh units) of covered texel `i` on `mesh`, the mesh rasterised:
    /// its triangle's corners weighted by the texel centre's barycentric coordinates (positions
    /// are computed, not stored: 12 bytes a texel, 200 MB at 4096²).
    #[inline]
    pub fn position(&self, mesh: &TriMesh, i: usize) -> Vec3 {
        let t = mesh.triangles[self.triangle[i] as usize];
        let [w1, w2] = self.bary[i];
        let w0 = 1.0 - w1 - w2;
        let c = t.map(|k| mesh.positions[k as usize]);
        c[0] * w0 + c[1] * w1 + c[2] * w2
    }

    /// Fraction of texels covered by some triangle.
    pub fn coverage(&self) -> f64 {
        self.triangle.iter().filter(|&&t| t != NO_TRIANGLE).count() as f64
            / self.triangle.len().max(1) as f64
    }
}

/// For every texel, the index of the nearest covered texel (itself if covered), found by an
/// 8-connected breadth-first search from all covered texels in index order (deterministic).
/// Used to fill the gutter between UV charts so that mip-mapping shows no seams. Returns `None`
/// when no texel is covered.
pub fn dilation_sources(covered: &[bool], width: usize, height: usize) -> Option<Vec<u32>> {
    let n = width * height;
    let mut src = vec![u32::MAX; n];
    let mut queue: std::collections::VecDeque<u32> =
        std::collections::VecDeque::with_capacity(n / 4);
    for (i, &c) in covered.iter().enumerate() {
        if c {
            src[i] = i as u32;
        }
    }
    // Seed the frontier with covered texels that border an uncovered one.
    for i in 0..n {
        if !covered[i] {
            continue;
        }
        let (x, y) = ((i % width) as i64, (i / width) as i64);
        let border = (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (nx, ny) = (x + dx, y + dy);
                nx >= 0
                    && ny >= 0
                    && nx < width as i64
                    && ny < height as i64
                    && !covered[(ny as usize) * width + nx as usize]
            })
        });
        if border {
            queue.push_back(i as u32);
        }
    }
    if src.iter().all(|&s| s == u32::MAX) {
        return None;
    }
    while let Some(i) = queue.pop_front() {
        let i = i as usize;
        let (x, y) = ((i % width) as i64, (i / width) as i64);
        for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= width as i64 || ny >= height as i64 {
                    continue;
                }
                let j = ny as usize * width + nx as usize;
                if src[j] == u32::MAX {
                    src[j] = src[i];
                    queue.push_back(j as u32);
                }
            }
        }
    }
    Some(src)
}

/// Copies each texel's value from its dilation source.
pub fn apply_dilation<T: Copy>(values: &mut [T], sources: &[u32]) {
    for i in 0..values.len() {
        let s = sources[i] as usize;
        if s != i {
            values[i] = values[s];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(uv_offset: f32, scale: f32) -> TriMesh {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        ];
        let uvs = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]
        .map(|u| u * scale + Vec2::splat(uv_offset))
        .to_vec();
        let mut m = TriMesh {
            positions,
            uvs,
            normals: vec![],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        m.compute_normals();
        m
    }

    #[test]
    fn full_quad_covers_every_texel_once_and_interpolates_positions() {
        let r = UvRaster::new(&quad(0.0, 1.0), 16, 16);
        assert_eq!(r.coverage(), 1.0);
        assert_eq!(r.overlapping_triangles, 0);
        // texel (0, 0) is at u = 1/32, v = 1 − 1/32 → x = 10/32 mm, y = 10·31/32 mm
        let p = r.position(&quad(0.0, 1.0), 0);
        assert!(
            (p.x - 10.0 / 32.0).abs() < 1e-4 && (p.y - 10.0 * 31.0 / 32.0).abs() < 1e-4,
            "{p}"
        );
    }

    #[test]
    fn overlapping_uvs_are_counted() {
        let mut m = quad(0.0, 1.0);
        let extra = quad(0.0, 1.0);
        let base = m.positions.len() as u32;
        m.positions.extend(extra.positions);
        m.uvs.extend(extra.uvs);
        m.normals.extend(extra.normals);
        m.triangles
            .extend(extra.triangles.iter().map(|t| t.map(|i| i + base)));
        let r = UvRaster::new(&m, 16, 16);
        assert_eq!(r.overlapping_triangles, 4);
    }

    #[test]
    fn dilation_fills_from_nearest_covered() {
        let r = UvRaster::new(&quad(0.25, 0.5), 16, 16);
        assert!((r.coverage() - 0.25).abs() < 1e-9);
        let covered: Vec<bool> = (0..256).map(|i| r.covered(i)).collect();
        let src = dilation_sources(&covered, 16, 16).unwrap();
        let mut v: Vec<f32> = (0..256)
            .map(|i| if covered[i] { (i % 16) as f32 } else { -1.0 })
            .collect();
        apply_dilation(&mut v, &src);
        assert!(v.iter().all(|&x| x >= 0.0));
        // texel (0, 8) is left of the chart whose leftmost column is x = 4
        assert_eq!(v[8 * 16], 4.0);
    }
}
