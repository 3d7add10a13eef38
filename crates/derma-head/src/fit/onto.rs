//! A fitted head's motion carried onto the user's own mesh (its topology and UVs kept) through
//! the dense correspondence: each vertex takes the offsets of the fitted skin's point nearest
//! it, interpolated barycentrically (the EyeMove thesis' B map, eq. 3.4).

use crate::{Head, MorphTarget};
use derma_core::mesh::TriMesh;
use glam::Vec3;
use rayon::prelude::*;

/// How far (mm) a mesh vertex may lie from the fitted skin and still follow it.
pub const REACH_MM: f32 = 10.0;

/// How much nearer (mm) the eye socket's hidden surface must be than the outer skin for a mesh
/// point to count as lying on the socket ([`Carry::outer`]).
pub const SOCKET_MARGIN_MM: f32 = 0.5;

/// Smoothing passes of a carried field over the mesh's edges ([`Carry::field`]).
pub const SMOOTHING: usize = 2;

/// Below this share of a mesh's vertices near the fitted skin, it is not the fitted mesh.
pub const MIN_SHARE: f32 = 0.5;

/// Where each vertex of a user's mesh lies on a fitted head's skin: the B map that carries any
/// per-skin-vertex offset field onto the mesh.
pub struct Carry {
    /// Per mesh vertex: the skin triangle's corners and the barycentric weights of corners 1
    /// and 2 (`None`: nothing within [`REACH_MM`]).
    corr: Vec<Option<([u32; 3], [f32; 2])>>,
    /// Per mesh vertex, the first vertex at its position (the mesh welded across UV seams).
    weld: Vec<u32>,
    /// Per welded vertex, its welded neighbours along the mesh's edges.
    rings: Vec<Vec<u32>>,
}

impl Carry {
    /// The map of `mesh` (mm, the frame the head was fitted in) onto `head`'s skin: vertices
    /// farther than [`REACH_MM`] from it do not move.
    pub fn new(head: &Head, mesh: &TriMesh) -> Carry {
        let skin = &head.skin;
        let bvh = derma_core::bvh::Bvh::new(&skin.positions, &skin.triangles);
        let corr = mesh
            .positions
            .par_iter()
            .map(|p| {
                bvh.closest(*p, REACH_MM)
                    .map(|c| (skin.triangles[c.triangle as usize], c.bary))
            })
            .collect();
        Carry::with_rings(corr, mesh)
    }

    /// As [`Carry::new`] onto the skin's outer surface alone: the eye sockets' charts (the
    /// conjunctiva and the lids' backs, hidden surfaces that swing far with the lid margins)
    /// carry nothing. A mesh point by a thin lid follows the lid's outside; one that lies on
    /// the socket itself (a modelled socket, nearer it than the outside by over
    /// [`SOCKET_MARGIN_MM`]) stays put.
    pub fn outer(head: &Head, mesh: &TriMesh) -> Carry {
        let skin = &head.skin;
        let socket = |t: &[u32; 3]| {
            t.iter()
                .all(|&i| head.regions.in_socket(skin.uvs[i as usize]))
        };
        let outer: Vec<[u32; 3]> = skin
            .triangles
            .iter()
            .copied()
            .filter(|t| !socket(t))
            .collect();
        let all = derma_core::bvh::Bvh::new(&skin.positions, &skin.triangles);
        let out = derma_core::bvh::Bvh::new(&skin.positions, &outer);
        let corr = mesh
            .positions
            .par_iter()
            .map(|p| {
                let o = out.closest(*p, REACH_MM)?;
                let a = all.closest(*p, REACH_MM)?;
                (o.distance <= a.distance + SOCKET_MARGIN_MM)
                    .then(|| (outer[o.triangle as usize], o.bary))
            })
            .collect();
        Carry::with_rings(corr, mesh)
    }

    fn with_rings(corr: Vec<Option<([u32; 3], [f32; 2])>>, mesh: &TriMesh) -> Carry {
        let weld = super::scan::welded(&mesh.positions);
        let rings = rings(mesh, &weld);
        Carry { corr, weld, rings }
    }

    /// The share of the mesh's vertices that follow the skin (near 0: not the mesh the head was
    /// fitted to, or read in another unit; below [`MIN_SHARE`] callers refuse it).
    pub fn share(&self) -> f32 {
        self.corr.iter().filter(|c| c.is_some()).count() as f32 / self.corr.len().max(1) as f32
    }

    /// The mesh's vertices.
    pub fn len(&self) -> usize {
        self.corr.len()
    }

    /// True for a mesh with no vertices.
    pub fn is_empty(&self) -> bool {
        self.corr.is_empty()
    }

    /// The offset of mesh vertex `i` from `dense` offsets of the skin's vertices.
    pub fn offset(&self, i: usize, dense: &[Vec3]) -> Vec3 {
        match self.corr[i] {
            Some((t, b)) => {
                let [a, p, q] = t.map(|k| dense[k as usize]);
                a * (1.0 - b[0] - b[1]) + p * b[0] + q * b[1]
            }
            None => Vec3::ZERO,
        }
    }

    /// The offsets of every mesh vertex from `dense` offsets of the skin's vertices, smoothed
    /// over the mesh's own edges ([`SMOOTHING`] Jacobi passes, each vertex halfway to its
    /// neighbours' mean, the mesh welded across its UV seams): where the skin folds,
    /// neighbouring mesh vertices may land on either side of the crease and take motions that
    /// differ by the fold's depth, and a mesh coarser than the skin would show that as a
    /// sawtooth.
    pub fn field(&self, dense: &[Vec3]) -> Vec<Vec3> {
        let mut f: Vec<Vec3> = (0..self.corr.len())
            .into_par_iter()
            .map(|i| self.offset(i, dense))
            .collect();
        for _ in 0..SMOOTHING {
            f = (0..f.len())
                .into_par_iter()
                .map(|i| {
                    let ring = &self.rings[i];
                    if self.corr[i].is_none() || ring.is_empty() {
                        return f[i];
                    }
                    let mean =
                        ring.iter().map(|&j| f[j as usize]).sum::<Vec3>() / ring.len() as f32;
                    0.5 * (f[i] + mean)
                })
                .collect();
        }
        // Seam copies take their welded vertex's offset.
        self.weld.iter().map(|&w| f[w as usize]).collect()
    }

    /// The offsets of the mesh's vertices that move (sparse, by vertex) from `dense` offsets of
    /// the skin's vertices, each its own point's (unsmoothed: a face unit keeps its magnitude).
    pub fn offsets(&self, dense: &[Vec3]) -> Vec<(u32, Vec3)> {
        sparse((0..self.corr.len()).map(|i| self.offset(i, dense)))
    }
}

/// The nonzero offsets of a field, by vertex.
pub fn sparse(field: impl IntoIterator<Item = Vec3>) -> Vec<(u32, Vec3)> {
    field
        .into_iter()
        .enumerate()
        .filter(|(_, d)| d.length_squared() > 1e-10)
        .map(|(i, d)| (i as u32, d))
        .collect()
}

/// Per welded vertex of `mesh` (`weld`: each vertex's first at its position), its welded
/// neighbours along the mesh's edges (sorted, each once; empty for seam copies).
fn rings(mesh: &TriMesh, weld: &[u32]) -> Vec<Vec<u32>> {
    let mut r = vec![Vec::new(); mesh.positions.len()];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (weld[t[k] as usize], weld[t[(k + 1) % 3] as usize]);
            r[a as usize].push(b);
            r[b as usize].push(a);
        }
    }
    for ring in &mut r {
        ring.sort_unstable();
        ring.dedup();
    }
    r
}

/// The head's 52 face units as morph targets of `mesh` (mm, the frame the head was fitted in):
/// vertices farther than [`REACH_MM`] from the fitted skin do not move. Also the share of the
/// mesh's vertices that follow ([`Carry::share`]).
pub fn face_units(head: &Head, mesh: &TriMesh) -> (Vec<MorphTarget>, f32) {
    let carry = Carry::new(head, mesh);
    let units = head
        .face_units()
        .par_iter()
        .map(|u| {
            let mut dense = vec![Vec3::ZERO; head.skin.positions.len()];
            for &(v, d) in &u.skin {
                dense[v as usize] = d;
            }
            MorphTarget {
                name: u.name.clone(),
                skin: carry.offsets(&dense),
                parts: Vec::new(),
            }
        })
        .collect();
    (units, carry.share())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_smoothed_field_keeps_linear_motion_and_seams_closed() {
        // The head's own skin, its seams split (as a user's UV'd mesh is): a field linear in
        // position is kept by the smoothing wherever every neighbour is carried (a linear field's
        // ring mean is its value on a symmetric ring, near it on any), and the copies of a seam
        // vertex move alike.
        let head = crate::Head::builtin();
        let skin = &head.skin;
        let carry = super::Carry::new(head, skin);
        let lin: Vec<glam::Vec3> = skin
            .positions
            .iter()
            .map(|p| glam::Vec3::new(0.01 * p.x, 0.0, 0.02 * p.y))
            .collect();
        let f = carry.field(&lin);
        let worst = (0..f.len())
            .map(|i| (f[i] - lin[i]).length())
            .fold(0.0f32, f32::max);
        assert!(worst < 0.05, "a linear field moved by {worst}");
        let mut seams = 0;
        for (i, &w) in carry.weld.iter().enumerate() {
            if w as usize != i {
                seams += 1;
                assert_eq!(f[i], f[w as usize], "seam copy {i} of {w}");
            }
        }
        assert!(seams > 0, "the head's skin has UV seams");
        // A sawtooth (every other vertex of a ring offset) is evened out.
        let saw: Vec<glam::Vec3> = (0..skin.positions.len())
            .map(|i| glam::Vec3::Y * (i % 2) as f32)
            .collect();
        let g = carry.field(&saw);
        let spread = |v: &[glam::Vec3]| {
            let m = v.iter().map(|d| d.y).sum::<f32>() / v.len() as f32;
            v.iter().map(|d| (d.y - m).abs()).sum::<f32>() / v.len() as f32
        };
        assert!(
            spread(&g) < 0.5 * spread(&saw),
            "{} of {}",
            spread(&g),
            spread(&saw)
        );
    }

    #[test]
    fn the_outer_map_carries_the_outside_and_leaves_the_socket() {
        // The built-in head's own skin as a user's mesh: its outer vertices follow themselves,
        // its socket vertices (nearer the socket than the outside) do not move.
        let head = crate::Head::builtin();
        let skin = &head.skin;
        let carry = super::Carry::outer(head, skin);
        let field: Vec<glam::Vec3> = skin.positions.iter().map(|p| *p * 0.01).collect();
        let (mut outer, mut socket_still, mut socket) = (0.0f32, 0, 0);
        for i in 0..skin.positions.len() {
            let got = carry.offset(i, &field);
            if head.regions.in_socket(skin.uvs[i]) {
                socket += 1;
                socket_still += usize::from(got == glam::Vec3::ZERO);
            } else {
                outer = outer.max((got - field[i]).length());
            }
        }
        assert!(outer < 1e-4, "an outer vertex off its own field by {outer}");
        // Most of the socket lies well inside; its rim, by the margins, follows the outside.
        assert!(
            socket > 1000 && socket_still * 2 > socket,
            "{socket_still} of {socket}"
        );
    }

    #[test]
    fn the_heads_own_skin_gets_its_own_face_units() {
        let head = crate::Head::builtin();
        let (units, share) = super::face_units(head, &head.skin);
        assert_eq!(share, 1.0);
        let smile = |us: &[crate::MorphTarget]| {
            let u = us.iter().find(|u| u.name == "mouthSmileLeft").unwrap();
            let mut d = vec![glam::Vec3::ZERO; head.skin.positions.len()];
            for &(v, o) in &u.skin {
                d[v as usize] = o;
            }
            d
        };
        let (got, want) = (smile(&units), smile(head.face_units()));
        let worst = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
    }
}
