//! The skin an eye animation moves: the head's own skin, or a user's mesh (its topology and UVs
//! kept) following a fitted head's skin through the fit's B map (EyeMove thesis §3.6, eq. 3.4).

use crate::evaluate::Frame;
use crate::region::EyeRegion;
use crate::{EyesError, Result};
use derma_core::mesh::TriMesh;
use derma_head::fit::onto::{Carry, MIN_SHARE, REACH_MM};
use derma_head::Head;
use glam::Vec3;
use std::path::Path;

/// The skin an animation moves.
pub struct Skin<'a> {
    head: &'a Head,
    user: Option<(TriMesh, Carry<'a>)>,
}

impl<'a> Skin<'a> {
    /// The head's own skin.
    pub fn of_head(head: &'a Head) -> Skin<'a> {
        Skin { head, user: None }
    }

    /// The user's `mesh` (read from `path`, in mm in the frame `head` was fitted in), refused
    /// when most of it lies off the fitted skin.
    pub fn user(head: &'a Head, mesh: TriMesh, path: &Path) -> Result<Skin<'a>> {
        let carry = Carry::new(head, &mesh);
        let share = carry.share();
        if share < MIN_SHARE {
            return Err(EyesError::Invalid(format!(
                "{}: only {:.0} % of its vertices lie within {REACH_MM} mm of the fitted head; is it the mesh the head was fitted to, read in the same unit?",
                path.display(),
                100.0 * share
            )));
        }
        Ok(Skin {
            head,
            user: Some((mesh, carry)),
        })
    }

    /// The mesh that moves (rest positions, mm).
    pub fn mesh(&self) -> &TriMesh {
        match &self.user {
            Some((m, _)) => m,
            None => &self.head.skin,
        }
    }

    /// True for a user's mesh.
    pub fn is_user(&self) -> bool {
        self.user.is_some()
    }

    /// Offsets of the head's skin vertices from offsets `model(m)` of the region's model
    /// vertices (zero outside the region). A user's mesh follows the outer skin alone: the
    /// socket's hidden inner surfaces (conjunctiva, the lids' backs) swing far with the lid
    /// margins, and a mesh point that lies nearest them (a modelled socket, a closed eye's
    /// surface) stays put rather than sweep through the globe.
    fn dense(&self, region: &EyeRegion, model: &impl Fn(usize) -> Vec3) -> Vec<Vec3> {
        let outer_only = self.user.is_some();
        region
            .skin_to_model
            .iter()
            .map(|&m| {
                if m == u32::MAX || (outer_only && region.inner[m as usize]) {
                    Vec3::ZERO
                } else {
                    model(m as usize)
                }
            })
            .collect()
    }

    /// The offsets of this skin's vertices that move (sparse, by vertex), from offsets
    /// `model(m)` of the region's model vertices.
    pub fn offsets(&self, region: &EyeRegion, model: impl Fn(usize) -> Vec3) -> Vec<(u32, Vec3)> {
        let dense = self.dense(region, &model);
        match &self.user {
            Some((_, carry)) => carry.offsets(&dense),
            None => dense
                .iter()
                .enumerate()
                .filter(|(_, d)| d.length_squared() > 1e-12)
                .map(|(i, d)| (i as u32, *d))
                .collect(),
        }
    }

    /// Positions of the vertices `which` of this skin in frame `f`; with the model's normals on
    /// the head's own skin (`None` on a user's mesh: recompute them from the moved triangles).
    pub fn frame(
        &self,
        region: &EyeRegion,
        f: &Frame,
        which: &[u32],
    ) -> (Vec<Vec3>, Option<Vec<Vec3>>) {
        let rest = &self.mesh().positions;
        match &self.user {
            None => {
                let mut normals = Vec::with_capacity(which.len());
                let positions = which
                    .iter()
                    .map(|&s| {
                        let m = region.skin_to_model[s as usize];
                        if m == u32::MAX {
                            normals.push(self.head.skin.normals[s as usize]);
                            rest[s as usize]
                        } else {
                            normals.push(f.normals[m as usize]);
                            f.positions[m as usize]
                        }
                    })
                    .collect();
                (positions, Some(normals))
            }
            Some((_, carry)) => {
                let dense = self.dense(region, &|m| f.positions[m] - region.rest[m]);
                let positions = which
                    .iter()
                    .map(|&s| rest[s as usize] + carry.offset(s as usize, &dense))
                    .collect();
                (positions, None)
            }
        }
    }
}
