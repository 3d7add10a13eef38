//! Catmull–Clark subdivision of quad meshes (Catmull & Clark 1978, "Recursively generated
//! B-spline surfaces on arbitrary topological meshes", CAD 10(6)), as linear stencils.
//!
//! Positions follow the Catmull–Clark rules with boundary edges kept as cubic B-spline curves
//! (edge point = midpoint, vertex point = (a + 6v + b)/8). The scheme is linear in the vertex
//! positions, so the same stencils carry morph-target offsets along. Texture coordinates are
//! subdivided linearly per face corner (face-varying), so UV seams and chart borders stay exact.

use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// A quad mesh: positions, texture coordinates and quads of (position, uv) corner indices.
#[derive(Clone, Debug, Default)]
pub struct QuadMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Texture coordinates (indexed separately: one vertex may have several at seams).
    pub uvs: Vec<Vec2>,
    /// Quads, counter-clockwise seen from outside.
    pub quads: Vec<[(u32, u32); 4]>,
}

/// Each new vertex as a weighted sum of the original vertices.
#[derive(Clone, Debug)]
pub struct Stencils {
    /// Row `i`: (original vertex, weight) pairs of new vertex `i`; weights sum to 1.
    pub rows: Vec<Vec<(u32, f32)>>,
}

impl Stencils {
    /// The identity on `n` vertices.
    pub fn identity(n: usize) -> Self {
        Self {
            rows: (0..n as u32).map(|i| vec![(i, 1.0)]).collect(),
        }
    }

    /// `self` applied after `first` (first maps level 0 → 1, self maps 1 → 2): level 0 → 2.
    pub fn after(&self, first: &Stencils) -> Stencils {
        let rows = self
            .rows
            .iter()
            .map(|row| {
                let mut acc: Vec<(u32, f32)> = Vec::new();
                for &(j, w) in row {
                    for &(k, u) in &first.rows[j as usize] {
                        acc.push((k, w * u));
                    }
                }
                merge(acc)
            })
            .collect();
        Stencils { rows }
    }

    /// Applies the stencils to per-vertex values.
    pub fn apply(&self, values: &[Vec3]) -> Vec<Vec3> {
        self.rows
            .iter()
            .map(|row| row.iter().map(|&(j, w)| values[j as usize] * w).sum())
            .collect()
    }
}

/// Sorts by vertex and sums duplicate entries.
fn merge(mut acc: Vec<(u32, f32)>) -> Vec<(u32, f32)> {
    acc.sort_by_key(|e| e.0);
    let mut out: Vec<(u32, f32)> = Vec::with_capacity(acc.len());
    for (k, w) in acc {
        match out.last_mut() {
            Some(last) if last.0 == k => last.1 += w,
            _ => out.push((k, w)),
        }
    }
    out
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// One Catmull–Clark step. New vertex order: the original vertices (moved), then one per edge
/// (in order of first appearance), then one per face; landmark indices of the original mesh
/// therefore stay valid.
pub fn catmull_clark(m: &QuadMesh) -> (QuadMesh, Stencils) {
    let n = m.positions.len();
    let mut edge_id: HashMap<(u32, u32), u32> = HashMap::new();
    let mut edge_faces: Vec<Vec<u32>> = Vec::new();
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for (f, q) in m.quads.iter().enumerate() {
        for i in 0..4 {
            let k = key(q[i].0, q[(i + 1) % 4].0);
            let id = *edge_id.entry(k).or_insert_with(|| {
                edges.push(k);
                edge_faces.push(Vec::new());
                (edges.len() - 1) as u32
            });
            edge_faces[id as usize].push(f as u32);
        }
    }
    let ne = edges.len();
    let face_row =
        |f: u32| -> Vec<(u32, f32)> { m.quads[f as usize].iter().map(|c| (c.0, 0.25)).collect() };
    let is_boundary = |e: usize| edge_faces[e].len() != 2;
    // Edge points.
    let edge_rows: Vec<Vec<(u32, f32)>> = (0..ne)
        .map(|e| {
            let (a, b) = edges[e];
            if is_boundary(e) {
                return merge(vec![(a, 0.5), (b, 0.5)]);
            }
            let mut acc = vec![(a, 0.25), (b, 0.25)];
            for &f in &edge_faces[e] {
                acc.extend(face_row(f).into_iter().map(|(k, w)| (k, w * 0.25)));
            }
            merge(acc)
        })
        .collect();
    // Vertex points.
    let mut vert_faces: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (f, q) in m.quads.iter().enumerate() {
        for c in q {
            vert_faces[c.0 as usize].push(f as u32);
        }
    }
    let mut vert_edges: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (e, &(a, b)) in edges.iter().enumerate() {
        vert_edges[a as usize].push(e as u32);
        vert_edges[b as usize].push(e as u32);
    }
    let vert_rows: Vec<Vec<(u32, f32)>> = (0..n as u32)
        .map(|v| {
            let ve = &vert_edges[v as usize];
            if ve.is_empty() {
                return vec![(v, 1.0)];
            }
            let other = |e: u32| {
                let (a, b) = edges[e as usize];
                if a == v {
                    b
                } else {
                    a
                }
            };
            let bnd: Vec<u32> = ve
                .iter()
                .filter(|&&e| is_boundary(e as usize))
                .map(|&e| other(e))
                .collect();
            if !bnd.is_empty() {
                return if bnd.len() == 2 {
                    merge(vec![(v, 0.75), (bnd[0], 0.125), (bnd[1], 0.125)])
                } else {
                    vec![(v, 1.0)]
                };
            }
            // (Q + 2R + (k − 3)S) / k, k the valence.
            let k = ve.len() as f32;
            let mut acc = vec![(v, (k - 3.0) / k)];
            let nf = vert_faces[v as usize].len() as f32;
            for &f in &vert_faces[v as usize] {
                acc.extend(face_row(f).into_iter().map(|(j, w)| (j, w / (nf * k))));
            }
            for &e in ve {
                // R: mean of edge midpoints, weighted 2/k.
                acc.push((v, 1.0 / (k * k)));
                acc.push((other(e), 1.0 / (k * k)));
            }
            merge(acc)
        })
        .collect();
    let mut rows = vert_rows;
    rows.extend(edge_rows);
    rows.extend((0..m.quads.len() as u32).map(face_row));
    let stencils = Stencils { rows };
    let positions = stencils.apply(&m.positions);
    // Face-varying linear UVs.
    let mut uvs = m.uvs.clone();
    let mut uv_edge: HashMap<(u32, u32), u32> = HashMap::new();
    let mut quads = Vec::with_capacity(m.quads.len() * 4);
    for (f, q) in m.quads.iter().enumerate() {
        let fv = (n + ne + f) as u32;
        let ft = uvs.len() as u32;
        uvs.push(q.iter().map(|c| m.uvs[c.1 as usize]).sum::<Vec2>() * 0.25);
        let mut mid = [(0u32, 0u32); 4];
        for i in 0..4 {
            let (a, b) = (q[i], q[(i + 1) % 4]);
            let ev = n as u32 + edge_id[&key(a.0, b.0)];
            let et = *uv_edge.entry(key(a.1, b.1)).or_insert_with(|| {
                uvs.push((m.uvs[a.1 as usize] + m.uvs[b.1 as usize]) * 0.5);
                (uvs.len() - 1) as u32
            });
            mid[i] = (ev, et);
        }
        for i in 0..4 {
            quads.push([q[i], mid[i], (fv, ft), mid[(i + 3) % 4]]);
        }
    }
    (
        QuadMesh {
            positions,
            uvs,
            quads,
        },
        stencils,
    )
}

/// Vertices of `m` after `levels` Catmull–Clark steps, counted without subdividing: each step
/// adds a point per edge and per face (V' = V + E + F), splits each edge in two and adds four
/// per face (E' = 2E + 4F), and makes four quads of each (F' = 4F).
pub fn vertex_count(m: &QuadMesh, levels: usize) -> usize {
    let mut edges: Vec<(u32, u32)> = m
        .quads
        .iter()
        .flat_map(|q| {
            (0..4).map(move |k| (q[k].0.min(q[(k + 1) % 4].0), q[k].0.max(q[(k + 1) % 4].0)))
        })
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let (mut v, mut e, mut f) = (m.positions.len(), edges.len(), m.quads.len());
    for _ in 0..levels {
        (v, e, f) = (v + e + f, 2 * e + 4 * f, 4 * f);
    }
    v
}

/// `levels` Catmull–Clark steps and the composed stencils from the original vertices.
pub fn subdivide(m: &QuadMesh, levels: usize) -> (QuadMesh, Stencils) {
    let mut mesh = m.clone();
    let mut total = Stencils::identity(m.positions.len());
    for _ in 0..levels {
        let (next, s) = catmull_clark(&mesh);
        total = s.after(&total);
        mesh = next;
    }
    (mesh, total)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube of side 2 centred at the origin, as six quads (closed, all valence 3).
    fn cube() -> QuadMesh {
        let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let positions = vec![
            p(-1., -1., -1.),
            p(1., -1., -1.),
            p(1., 1., -1.),
            p(-1., 1., -1.),
            p(-1., -1., 1.),
            p(1., -1., 1.),
            p(1., 1., 1.),
            p(-1., 1., 1.),
        ];
        let f = [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [2, 3, 7, 6],
            [1, 2, 6, 5],
            [0, 4, 7, 3],
        ];
        QuadMesh {
            positions,
            uvs: vec![Vec2::ZERO],
            quads: f.iter().map(|q| q.map(|v| (v, 0))).collect(),
        }
    }

    #[test]
    fn cube_corner_moves_to_the_catmull_clark_value() {
        // A valence-3 corner (1,1,1): Q = mean of the face centres (1,0,0), (0,1,0), (0,0,1) =
        // 1/3 per axis; R = mean of the edge midpoints (1,1,0), (1,0,1), (0,1,1) = 2/3 per axis;
        // (Q + 2R + (3 − 3)S)/3 = 5/9 per axis.
        let (m, s) = catmull_clark(&cube());
        assert!(
            (m.positions[6] - Vec3::splat(5.0 / 9.0)).length() < 1e-6,
            "{}",
            m.positions[6]
        );
        // Every stencil is an affine combination.
        for row in &s.rows {
            let sum: f32 = row.iter().map(|e| e.1).sum();
            assert!((sum - 1.0).abs() < 1e-5);
        }
        assert_eq!(m.quads.len(), 24);
        assert_eq!(m.positions.len(), 8 + 12 + 6);
    }

    #[test]
    fn two_levels_compose_to_the_same_positions() {
        let (m2, s) = subdivide(&cube(), 2);
        let direct = s.apply(&cube().positions);
        for (a, b) in m2.positions.iter().zip(&direct) {
            assert!((*a - *b).length() < 1e-5);
        }
        // Converging to the limit surface: all points inside the cube, none collapsed.
        assert!(m2.positions.iter().all(|p| p.abs().max_element() <= 1.0));
        assert!(m2.positions.iter().all(|p| p.length() > 0.5));
    }

    #[test]
    fn boundary_of_an_open_grid_follows_the_bspline_rule() {
        // A 1×3 strip of quads: the middle boundary vertex (1,0) of the bottom row gets
        // (a + 6v + b)/8 along the boundary.
        let positions: Vec<Vec3> = (0..8)
            .map(|i| {
                Vec3::new(
                    (i % 4) as f32,
                    (i / 4) as f32,
                    if i == 1 { 1.0 } else { 0.0 },
                )
            })
            .collect();
        let quads = (0..3u32)
            .map(|i| [(i, 0), (i + 1, 0), (i + 5, 0), (i + 4, 0)])
            .collect();
        let m = QuadMesh {
            positions,
            uvs: vec![Vec2::ZERO],
            quads,
        };
        let (d, _) = catmull_clark(&m);
        let want =
            (Vec3::new(0., 0., 0.) + 6.0 * Vec3::new(1., 0., 1.) + Vec3::new(2., 0., 0.)) / 8.0;
        assert!((d.positions[1] - want).length() < 1e-6);
    }

    #[test]
    fn vertex_counts_match_the_subdivided_mesh() {
        let c = cube();
        for levels in 0..3 {
            assert_eq!(
                vertex_count(&c, levels),
                subdivide(&c, levels).0.positions.len()
            );
        }
    }
}
