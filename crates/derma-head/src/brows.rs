//! Brow cards: the skin around the brows lifted a fraction of a millimetre off it, on which a
//! texture set's brow hairs stand as an alpha-tested card (the set's hair coverage over the
//! skin's own UVs), so brows can take light and parallax apart from the skin they are painted on.
//!
//! Which skin: every triangle whose centroid lies in a box around each brow placed by the
//! landmarks, wide enough for the hairs the brow's follicles grow (docs/skin.md, "Hair"): from
//! 10 mm medial of the inner canthus to 24 mm beyond the outer one, 8–34 mm above the eye centre.

use crate::Head;
use derma_core::mesh::TriMesh;
use glam::Vec3;

/// How far the card lies off the skin (mm): about three hair diameters (authored).
pub const LIFT_MM: f32 = 0.3;

/// The brow cards of a head: a mesh and, for each of its vertices, the skin vertex it was lifted
/// from (for the skin's face-unit offsets).
pub struct BrowCards {
    /// The cards, with the skin's UVs and normals.
    pub mesh: TriMesh,
    /// Skin vertex of each card vertex.
    pub source: Vec<u32>,
}

impl BrowCards {
    /// The cards lifted off `skin` (the head's skin, posed or not: same topology as
    /// `head.skin`), with the triangles chosen on the head at rest.
    pub fn of(head: &Head, skin: &TriMesh) -> BrowCards {
        let rest = &head.skin;
        let near_brow = |c: Vec3| {
            let side = head.regions.side(c.x);
            let (eye, ci, co) = (side.eye, side.canthus_inner, side.canthus_outer);
            let ax = c.x.abs();
            (eye.y + 8.0..=eye.y + 34.0).contains(&c.y)
                && (ci.x.abs() - 10.0..=co.x.abs() + 24.0).contains(&ax)
                && c.z > eye.z - 25.0
        };
        let mut index = vec![u32::MAX; rest.positions.len()];
        let (mut mesh, mut source) = (TriMesh::default(), Vec::new());
        for t in &rest.triangles {
            let c = t.iter().map(|&v| rest.positions[v as usize]).sum::<Vec3>() / 3.0;
            if !near_brow(c) {
                continue;
            }
            let tri = t.map(|v| {
                let i = &mut index[v as usize];
                if *i == u32::MAX {
                    *i = source.len() as u32;
                    source.push(v);
                    let n = skin.normals[v as usize];
                    mesh.positions
                        .push(skin.positions[v as usize] + n * LIFT_MM);
                    mesh.normals.push(n);
                    mesh.uvs.push(skin.uvs[v as usize]);
                }
                *i
            });
            mesh.triangles.push(tri);
        }
        BrowCards { mesh, source }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cards_cover_both_brows_just_off_the_skin() {
        let head = Head::builtin();
        let cards = BrowCards::of(head, &head.skin);
        assert!(
            cards.mesh.triangles.len() > 100,
            "{}",
            cards.mesh.triangles.len()
        );
        let left = cards.mesh.positions.iter().filter(|p| p.x > 0.0).count();
        assert!(left > 0 && left < cards.mesh.positions.len());
        let eye_y = head.regions.side(1.0).eye.y;
        for (p, &s) in cards.mesh.positions.iter().zip(&cards.source) {
            let q = head.skin.positions[s as usize];
            assert!((p.distance(q) - LIFT_MM).abs() < 1e-4);
            assert!(p.y > eye_y);
        }
        // Every card vertex keeps its skin vertex's UV.
        for (uv, &s) in cards.mesh.uvs.iter().zip(&cards.source) {
            assert_eq!(*uv, head.skin.uvs[s as usize]);
        }
    }
}
