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

/// Below this share of a mesh's vertices near the fitted skin, it is not the fitted mesh.
pub const MIN_SHARE: f32 = 0.5;

/// Where each vertex of a user's mesh lies on a fitted head's skin: the B map that carries any
/// per-skin-vertex offset field onto the mesh.
pub struct Carry {
    /// Per mesh vertex: the skin triangle's corners and the barycentric weights of corners 1
    /// and 2 (`None`: nothing within [`REACH_MM`]).
    corr: Vec<Option<([u32; 3], [f32; 2])>>,
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
        Carry { corr }
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
        Carry { corr }
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

    /// The offsets of the mesh's vertices that move (sparse, by vertex) from `dense` offsets of
    /// the skin's vertices.
    pub fn offsets(&self, dense: &[Vec3]) -> Vec<(u32, Vec3)> {
        (0..self.corr.len())
            .filter_map(|i| {
                let d = self.offset(i, dense);
                (d.length_squared() > 1e-10).then_some((i as u32, d))
            })
            .collect()
    }
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
