//! A fitted head's face units carried onto the user's own mesh (its topology and UVs kept)
//! through the dense correspondence: each vertex takes the offsets of the fitted skin's point
//! nearest it, interpolated barycentrically (the EyeMove thesis' B map, eq. 3.4).

use crate::{Head, MorphTarget};
use derma_core::mesh::TriMesh;
use glam::Vec3;
use rayon::prelude::*;

/// How far (mm) a mesh vertex may lie from the fitted skin and still follow it.
pub const REACH_MM: f32 = 10.0;

/// The head's 52 face units as morph targets of `mesh` (mm, the frame the head was fitted in):
/// vertices farther than [`REACH_MM`] from the fitted skin do not move. Also the share of the
/// mesh's vertices that follow (near 0: not the mesh the head was fitted to, or another unit).
pub fn face_units(head: &Head, mesh: &TriMesh) -> (Vec<MorphTarget>, f32) {
    let corr = super::scan_to_template(head, mesh);
    let share = corr.iter().filter(|c| c.is_some()).count() as f32 / corr.len().max(1) as f32;
    let units = head
        .face_units()
        .par_iter()
        .map(|u| {
            let mut dense = vec![Vec3::ZERO; head.skin.positions.len()];
            for &(v, d) in &u.skin {
                dense[v as usize] = d;
            }
            let skin = corr
                .iter()
                .enumerate()
                .filter_map(|(i, c)| {
                    let (t, b) = (*c)?;
                    let [a, p, q] = head.skin.triangles[t as usize].map(|k| dense[k as usize]);
                    let d = a * (1.0 - b[0] - b[1]) + p * b[0] + q * b[1];
                    (d.length_squared() > 1e-10).then_some((i as u32, d))
                })
                .collect();
            MorphTarget {
                name: u.name.clone(),
                skin,
                parts: Vec::new(),
            }
        })
        .collect();
    (units, share)
}

/// Below this share of a mesh's vertices near the fitted skin, it is not the fitted mesh.
pub const MIN_SHARE: f32 = 0.5;

#[cfg(test)]
mod tests {
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
