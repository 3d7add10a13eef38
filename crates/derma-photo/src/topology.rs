//! Mesh connectivity for the unwrap and the colour fill (Tarini et al. 2002 §3.1: the face mesh
//! must be topologically a disc): welding, edges, boundary loops, one-rings and the disc check.

use crate::error::{PhotoError, Result};
use derma_core::mesh::TriMesh;
use glam::Vec3;
use std::collections::HashMap;

/// The weld of an input vertex that no triangle uses.
pub const UNUSED: u32 = u32::MAX;

/// A welded triangle mesh with its connectivity.
#[derive(Clone, Debug)]
pub struct Topology {
    /// Welded positions.
    pub positions: Vec<Vec3>,
    /// Triangles over the welded positions.
    pub triangles: Vec<[u32; 3]>,
    /// For each input vertex, its welded vertex ([`UNUSED`] for a vertex no triangle uses).
    pub weld: Vec<u32>,
    /// Boundary loops, each a closed list of vertices in order.
    pub boundary_loops: Vec<Vec<u32>>,
    /// Each vertex's neighbours (the one-ring).
    pub neighbours: Vec<Vec<u32>>,
    /// Number of distinct edges.
    pub edges: usize,
    /// Connected components.
    pub components: usize,
}

impl Topology {
    /// Welds vertices at identical positions (UV seams of a file split them) and builds the
    /// connectivity. Errors on edges shared by more than two triangles.
    pub fn new(mesh: &TriMesh) -> Result<Topology> {
        let mut index: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
        let mut positions = Vec::new();
        let weld: Vec<u32> = mesh
            .positions
            .iter()
            .map(|p| {
                *index
                    .entry(p.to_array().map(f32::to_bits))
                    .or_insert_with(|| {
                        positions.push(*p);
                        (positions.len() - 1) as u32
                    })
            })
            .collect();
        let triangles: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| weld[i as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect();
        // Keep only the vertices some triangle uses.
        let mut remap = vec![UNUSED; positions.len()];
        let mut used = Vec::with_capacity(positions.len());
        for t in &triangles {
            for &v in t {
                if remap[v as usize] == UNUSED {
                    remap[v as usize] = used.len() as u32;
                    used.push(positions[v as usize]);
                }
            }
        }
        let positions = used;
        let triangles: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|v| remap[v as usize]))
            .collect();
        let weld: Vec<u32> = weld.iter().map(|&w| remap[w as usize]).collect();
        // Directed edges: an interior edge appears once each way, a boundary edge once.
        let mut directed: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * triangles.len());
        for t in &triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        if let Some(((a, b), _)) = directed.iter().find(|(_, &c)| c > 1) {
            return Err(PhotoError::Mesh(format!(
                "the edge between vertices {a} and {b} is used twice in the same direction (a non-manifold edge or inconsistently oriented triangles); a disc-topology surface is expected"
            )));
        }
        let mut next: HashMap<u32, u32> = HashMap::new();
        let mut edges = 0usize;
        for &(a, b) in directed.keys() {
            if directed.contains_key(&(b, a)) {
                if a < b {
                    edges += 1;
                }
            } else {
                edges += 1;
                if next.insert(a, b).is_some() {
                    return Err(PhotoError::Mesh(format!(
                        "vertex {a} lies on the boundary twice (a bow-tie vertex); a disc-topology surface is expected"
                    )));
                }
            }
        }
        let mut boundary_loops = Vec::new();
        let mut starts: Vec<u32> = next.keys().copied().collect();
        starts.sort_unstable();
        let mut seen = std::collections::HashSet::new();
        for s in starts {
            if seen.contains(&s) {
                continue;
            }
            let mut lp = vec![s];
            seen.insert(s);
            let mut v = next[&s];
            while v != s {
                seen.insert(v);
                lp.push(v);
                v = next[&v];
            }
            boundary_loops.push(lp);
        }
        let mut neighbours = vec![Vec::new(); positions.len()];
        for t in &triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if !neighbours[a as usize].contains(&b) {
                    neighbours[a as usize].push(b);
                }
                if !neighbours[b as usize].contains(&a) {
                    neighbours[b as usize].push(a);
                }
            }
        }
        let components = count_components(&neighbours);
        Ok(Topology {
            positions,
            triangles,
            weld,
            boundary_loops,
            neighbours,
            edges,
            components,
        })
    }

    /// Euler characteristic V − E + F (1 for a disc).
    pub fn euler(&self) -> i64 {
        self.positions.len() as i64 - self.edges as i64 + self.triangles.len() as i64
    }

    /// Checks that the mesh is one disc: one component, one boundary loop, no handles.
    pub fn check_disc(&self) -> Result<()> {
        let loops = self.boundary_loops.len();
        if self.components != 1 {
            return Err(PhotoError::Mesh(format!(
                "{} connected components; a single-chart unwrap needs one connected surface",
                self.components
            )));
        }
        if loops != 1 {
            return Err(PhotoError::Mesh(format!(
                "{loops} boundary loops; a single-chart unwrap needs a disc (exactly one boundary loop{}): {}",
                if loops == 0 {
                    ", e.g. cut the closed surface open around the neck"
                } else {
                    ", e.g. close the eye and mouth openings or cut the extra loops into one"
                },
                self.boundary_loops
                    .iter()
                    .map(|l| format!("{} vertices", l.len()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let genus = (2 - loops as i64 - self.euler()) / 2;
        if genus != 0 {
            return Err(PhotoError::Mesh(format!(
                "the surface has {genus} handle(s) (Euler characteristic {}); a disc has none",
                self.euler()
            )));
        }
        Ok(())
    }
}

/// Closes every boundary loop but the longest (the outer boundary) with a fan around a new
/// vertex at the loop's centroid, as scanners close eye and mouth openings; returns the mesh
/// (welded, without UVs) and the number of holes closed.
pub fn fill_holes(mesh: &TriMesh) -> Result<(TriMesh, usize)> {
    let t = Topology::new(mesh)?;
    let length = |l: &Vec<u32>| -> f32 {
        (0..l.len())
            .map(|i| {
                (t.positions[l[(i + 1) % l.len()] as usize] - t.positions[l[i] as usize]).length()
            })
            .sum()
    };
    let outer = (0..t.boundary_loops.len())
        .max_by(|&a, &b| length(&t.boundary_loops[a]).total_cmp(&length(&t.boundary_loops[b])));
    let mut out = TriMesh {
        positions: t.positions.clone(),
        triangles: t.triangles.clone(),
        ..Default::default()
    };
    let mut closed = 0;
    for (i, l) in t.boundary_loops.iter().enumerate() {
        if Some(i) == outer {
            continue;
        }
        let c = l.iter().map(|&v| t.positions[v as usize]).sum::<Vec3>() / l.len() as f32;
        out.positions.push(c);
        let ci = (out.positions.len() - 1) as u32;
        // Boundary edges run a → next(a) inside their triangle; the fan runs the other way.
        for k in 0..l.len() {
            out.triangles.push([l[(k + 1) % l.len()], l[k], ci]);
        }
        closed += 1;
    }
    out.compute_normals();
    Ok((out, closed))
}

fn count_components(neighbours: &[Vec<u32>]) -> usize {
    let mut label = vec![false; neighbours.len()];
    let mut count = 0;
    let mut stack = Vec::new();
    for s in 0..neighbours.len() {
        if label[s] || neighbours[s].is_empty() {
            continue;
        }
        count += 1;
        label[s] = true;
        stack.push(s as u32);
        while let Some(v) = stack.pop() {
            for &n in &neighbours[v as usize] {
                if !label[n as usize] {
                    label[n as usize] = true;
                    stack.push(n);
                }
            }
        }
    }
    count
}

/// A regular grid of n × n quads (two triangles each) over [0, 1]², z = f(x, y): a disc.
pub fn grid_mesh(n: usize, f: impl Fn(f32, f32) -> f32) -> TriMesh {
    let mut m = TriMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            m.positions.push(Vec3::new(x, y, f(x, y)));
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            m.triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            m.triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m.compute_normals();
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_is_a_disc() {
        let t = Topology::new(&grid_mesh(8, |_, _| 0.0)).unwrap();
        assert_eq!(t.euler(), 1);
        assert_eq!(t.boundary_loops.len(), 1);
        assert_eq!(t.boundary_loops[0].len(), 32);
        t.check_disc().unwrap();
    }

    #[test]
    fn filling_a_hole_makes_a_disc_again() {
        let mut m = grid_mesh(8, |_, _| 0.0);
        let mid = 2 * (4 * 8 + 4);
        m.triangles.drain(mid..mid + 2);
        let (f, n) = fill_holes(&m).unwrap();
        assert_eq!(n, 1);
        let t = Topology::new(&f).unwrap();
        t.check_disc().unwrap();
        // Same orientation as the rest: the fan's normals point along the grid's.
        let nz: Vec<f32> = f.triangles[f.triangles.len() - 4..]
            .iter()
            .map(|tr| {
                let [a, b, c] = tr.map(|i| f.positions[i as usize]);
                (b - a).cross(c - a).z
            })
            .collect();
        assert!(nz.iter().all(|z| *z > 0.0), "{nz:?}");
    }

    #[test]
    fn a_hole_is_counted_and_named() {
        let mut m = grid_mesh(8, |_, _| 0.0);
        // Remove the two triangles of the middle quad.
        let mid = 2 * (4 * 8 + 4);
        m.triangles.drain(mid..mid + 2);
        let t = Topology::new(&m).unwrap();
        let e = t.check_disc().unwrap_err().to_string();
        assert!(e.contains("2 boundary loops"), "{e}");
    }

    #[test]
    fn the_built_in_skin_welds_into_one_disc() {
        // The head chart, mouth cavity and eye sockets are joined at the lips and lids; the
        // only boundary is the neck.
        let head = derma_head::Head::builtin();
        let t = Topology::new(&head.skin).unwrap();
        t.check_disc().unwrap();
        assert!(
            t.positions.len() < head.skin.positions.len(),
            "UV seams are welded"
        );
        let mut closed = grid_mesh(4, |_, _| 0.0);
        closed.triangles.clear();
        assert!(Topology::new(&closed).unwrap().check_disc().is_err());
    }
}
