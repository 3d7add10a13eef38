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
    user: Option<(TriMesh, Carry)>,
}

impl<'a> Skin<'a> {
    /// The head's own skin.
    pub fn of_head(head: &'a Head) -> Skin<'a> {
        Skin { head, user: None }
    }

    /// The user's `mesh` (read from `path`, in mm in the frame `head` was fitted in), following
    /// the outer skin ([`Carry::outer`]); refused when most of it lies off the fitted skin.
    pub fn user(head: &'a Head, mesh: TriMesh, path: &Path) -> Result<Skin<'a>> {
        let carry = Carry::outer(head, &mesh);
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

    /// Offsets of the head's skin vertices from offsets `model(m)` of the region's model
    /// vertices (zero outside the region).
    fn dense(&self, region: &EyeRegion, model: &impl Fn(usize) -> Vec3) -> Vec<Vec3> {
        region
            .skin_to_model
            .iter()
            .map(|&m| {
                if m == u32::MAX {
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

    /// Positions and normals of the vertices `which` of this skin in frame `f`: the model's own
    /// on the head's skin; on a user's mesh its rest normal plus the change the model makes to
    /// the skin's normals (carried like the positions), renormalised — not normals recomputed
    /// from the moved triangles, which show the linear model's lid folds as facets.
    pub fn frame(&self, region: &EyeRegion, f: &Frame, which: &[u32]) -> (Vec<Vec3>, Vec<Vec3>) {
        let mesh = self.mesh();
        match &self.user {
            None => which
                .iter()
                .map(|&s| {
                    let m = region.skin_to_model[s as usize];
                    if m == u32::MAX {
                        (mesh.positions[s as usize], mesh.normals[s as usize])
                    } else {
                        (f.positions[m as usize], f.normals[m as usize])
                    }
                })
                .unzip(),
            Some((_, carry)) => {
                let moved = self.dense(region, &|m| f.positions[m] - region.rest[m]);
                let turned = self.dense(region, &|m| f.normals[m] - region.rest_normals[m]);
                which
                    .iter()
                    .map(|&s| {
                        let s = s as usize;
                        let n = mesh.normals.get(s).copied().unwrap_or(Vec3::Z);
                        (
                            mesh.positions[s] + carry.offset(s, &moved),
                            (n + carry.offset(s, &turned)).normalize_or(n),
                        )
                    })
                    .unzip()
            }
        }
    }
}
