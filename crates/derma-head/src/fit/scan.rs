//! The user's scan as the registration sees it: its triangles in a hierarchy for closest
//! points, their orientation, and its open borders (holes, the neck cut), where matches are
//! refused as Amberg et al. 2007 (§3.2) do.

use derma_core::bvh::{Bvh, Closest};
use derma_core::mesh::TriMesh;
use glam::Vec3;
use std::collections::HashMap;

/// A scan prepared for matching.
pub struct Scan {
    /// The mesh (mm).
    pub mesh: TriMesh,
    /// Its triangles' hierarchy.
    pub bvh: Bvh,
    /// Unit normal of each triangle, by winding.
    pub face_normals: Vec<Vec3>,
    /// Per triangle: it touches the border (an edge used by one triangle only).
    pub on_border: Vec<bool>,
    /// Per vertex: it lies on the border.
    pub border_vertex: Vec<bool>,
    /// Area-weighted vertex normals of the scan's own triangles (whatever normals its file
    /// carries).
    pub vertex_normals: Vec<Vec3>,
}

/// Cosine of the largest angle between a template normal and the scan's for a match (60°).
pub const NORMAL_COS: f32 = 0.5;

impl Scan {
    /// Prepares a mesh (in mm).
    pub fn new(mesh: TriMesh) -> Scan {
        let bvh = Bvh::new(&mesh.positions, &mesh.triangles);
        let face_normals = mesh
            .triangles
            .iter()
            .map(|t| mesh.face_cross(*t).normalize_or_zero())
            .collect();
        // Vertices split at UV seams or for flat shading share their position: the border is
        // the welded surface's.
        let weld = welded(&mesh.positions);
        let mut uses: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 2);
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (weld[t[k] as usize], weld[t[(k + 1) % 3] as usize]);
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let mut border_welded = vec![false; mesh.positions.len()];
        for (&(a, b), &n) in &uses {
            if n == 1 {
                border_welded[a as usize] = true;
                border_welded[b as usize] = true;
            }
        }
        let border_vertex: Vec<bool> = weld.iter().map(|&w| border_welded[w as usize]).collect();
        let on_border = mesh
            .triangles
            .iter()
            .map(|t| t.iter().any(|&i| border_vertex[i as usize]))
            .collect();
        let mut vertex_normals = vec![Vec3::ZERO; mesh.positions.len()];
        for t in &mesh.triangles {
            let f = mesh.face_cross(*t);
            for &i in t {
                vertex_normals[i as usize] += f;
            }
        }
        vertex_normals
            .iter_mut()
            .for_each(|n| *n = n.normalize_or_zero());
        Scan {
            mesh,
            bvh,
            face_normals,
            on_border,
            border_vertex,
            vertex_normals,
        }
    }

    /// The median edge length (mm).
    pub fn median_edge_mm(&self) -> f32 {
        let p = &self.mesh.positions;
        let mut e: Vec<f32> = self
            .mesh
            .triangles
            .iter()
            .map(|t| (p[t[1] as usize] - p[t[0] as usize]).length())
            .collect();
        if e.is_empty() {
            return 0.0;
        }
        let k = e.len() / 2;
        *e.select_nth_unstable_by(k, f32::total_cmp).1
    }

    /// The closest scan point to `p` within `tau` mm whose surface faces the same way as `n`
    /// (within 60°) and that is not on the border; None otherwise.
    pub fn matched(&self, p: Vec3, n: Vec3, tau: f32) -> Option<Closest> {
        let c = self.bvh.closest(p, tau)?;
        let t = c.triangle as usize;
        (!self.on_border[t] && self.face_normals[t].dot(n) >= NORMAL_COS).then_some(c)
    }
}

/// Per vertex, the first vertex at exactly its position (bitwise): the mesh welded.
pub(crate) fn welded(positions: &[Vec3]) -> Vec<u32> {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            *first
                .entry(p.to_array().map(f32::to_bits))
                .or_insert(i as u32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_vertices_do_not_make_a_border() {
        // Two triangles of a square sharing an edge whose vertices are split (as flat-shaded or
        // UV-seamed exports write them): the shared edge is not a border.
        let m = TriMesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::X,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::Y,
            ],
            normals: vec![Vec3::Z; 6],
            uvs: Vec::new(),
            triangles: vec![[0, 1, 2], [3, 4, 5]],
        };
        let s = Scan::new(m);
        // Every vertex is on the square's outline, but the diagonal is interior: the outline has
        // four edges, each used once; the diagonal twice.
        assert!(s.border_vertex.iter().all(|&b| b));
        let weld = welded(&s.mesh.positions);
        assert_eq!(weld, vec![0, 1, 2, 1, 4, 2]);
    }
}
