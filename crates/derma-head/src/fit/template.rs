//! The built-in head as a deformable template: the coarse skin's control vertices (the
//! unknowns of the registration), the subdivided points they move by Catmull–Clark stencils
//! (Catmull & Clark 1978, through [`crate::subdivision`]).

use crate::asset::Asset;
use crate::subdivision::{subdivide, QuadMesh, Stencils};
use glam::{Vec2, Vec3};
use std::collections::{BTreeMap, HashMap};

/// The template the fit deforms.
pub struct Template {
    /// The coarse skin (local numbering).
    pub coarse: QuadMesh,
    /// Asset vertex of each coarse local vertex.
    pub coarse_ids: Vec<u32>,
    /// Undirected edges of the coarse skin (the stiffness term's arcs).
    pub edges: Vec<[u32; 2]>,
    /// The once-subdivided skin: the points matched to the scan.
    pub level1: QuadMesh,
    /// Coarse → level 1.
    pub stencils1: Stencils,
    /// Per level-1 vertex: on the outer skin (its UVs in the skin chart), so matched to the
    /// scan; the mouth cavity and eye sockets are not.
    pub outer1: Vec<bool>,
    /// The twice-subdivided skin (the head's skin mesh, topologically).
    pub level2: QuadMesh,
    /// Coarse → level 2.
    pub stencils2: Stencils,
    /// Per level-2 vertex: on the outer skin.
    pub outer2: Vec<bool>,
    /// Named landmarks as level-2 vertices (Catmull–Clark keeps a cage vertex's index).
    pub landmarks: BTreeMap<String, usize>,
}

fn outer(q: &QuadMesh, chart: [f32; 4]) -> Vec<bool> {
    let inside =
        |uv: Vec2| uv.x >= chart[0] && uv.x <= chart[2] && uv.y >= chart[1] && uv.y <= chart[3];
    let mut o = vec![false; q.positions.len()];
    for f in &q.quads {
        for &(v, t) in f {
            if inside(q.uvs[t as usize]) {
                o[v as usize] = true;
            }
        }
    }
    o
}

impl Template {
    /// The template of an asset (the built-in head's).
    pub fn of(a: &Asset) -> Template {
        let (coarse, coarse_ids) = crate::local_quads(a, &crate::SKIN_GROUPS);
        let mut edges: Vec<[u32; 2]> = coarse
            .quads
            .iter()
            .flat_map(|f| {
                (0..4).map(move |k| {
                    let (a, b) = (f[k].0, f[(k + 1) % 4].0);
                    [a.min(b), a.max(b)]
                })
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let (level1, stencils1) = subdivide(&coarse, 1);
        let (level2, s12) = subdivide(&level1, 1);
        let stencils2 = s12.after(&stencils1);
        let chart = a.meta.charts["skin"];
        let outer1 = outer(&level1, chart);
        let outer2 = outer(&level2, chart);
        let local: HashMap<u32, usize> = coarse_ids
            .iter()
            .enumerate()
            .map(|(i, &v)| (v, i))
            .collect();
        let landmarks = a
            .meta
            .landmarks
            .iter()
            .map(|(n, v)| (n.clone(), local[v]))
            .collect();
        Template {
            coarse,
            coarse_ids,
            edges,
            level1,
            stencils1,
            outer1,
            level2,
            stencils2,
            outer2,
            landmarks,
        }
    }

    /// Landmark `name`'s position on the template (panics on a name the asset lacks).
    pub fn landmark(&self, name: &str) -> Vec3 {
        self.level2.positions[self.landmarks[name]]
    }

    /// Per level-1 vertex (at `positions`): within `band` mm of a margin of the outer skin
    /// (where it meets the eye sockets or the mouth cavity).
    pub fn margin_band(&self, positions: &[Vec3], band: f32) -> Vec<bool> {
        let margin: Vec<Vec3> = Self::margin(&self.level1, &self.outer1)
            .into_iter()
            .map(|i| positions[i])
            .collect();
        positions
            .iter()
            .map(|p| {
                margin
                    .iter()
                    .any(|m| (*m - *p).length_squared() < band * band)
            })
            .collect()
    }

    /// The outer skin's vertices on a margin (where it meets the eye sockets or the mouth
    /// cavity) of a level's quads `q` with its outer flags.
    pub fn margin(q: &QuadMesh, outer: &[bool]) -> Vec<usize> {
        let mut on_margin = vec![false; outer.len()];
        for f in &q.quads {
            if f.iter().any(|c| !outer[c.0 as usize]) {
                for c in f {
                    on_margin[c.0 as usize] |= outer[c.0 as usize];
                }
            }
        }
        (0..outer.len()).filter(|&i| on_margin[i]).collect()
    }

    /// Area-weighted vertex normals of a quad mesh's topology at `positions`.
    pub fn normals(q: &QuadMesh, positions: &[Vec3]) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; positions.len()];
        for f in &q.quads {
            let [a, b, c, d] = f.map(|c| positions[c.0 as usize]);
            let g = (c - a).cross(d - b);
            for c in f {
                n[c.0 as usize] += g;
            }
        }
        n.iter().map(|v| v.normalize_or_zero()).collect()
    }
}
