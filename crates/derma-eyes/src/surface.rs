//! The skin an eye animation moves: the head's own skin, or a user's mesh (its topology and UVs
//! kept) following a fitted head's skin through the fit's B map (EyeMove thesis §3.6, eq. 3.4).

use crate::evaluate::Frame;
use crate::region::EyeRegion;
use crate::Result;
use derma_core::mesh::TriMesh;
use derma_head::fit::onto::{Carry, MIN_SHARE, REACH_MM};
use derma_head::Head;
use glam::Vec3;
use std::path::Path;

/// The skin an animation moves.
pub struct Skin<'a> {
    head: &'a Head,
    user: Option<User>,
}

/// A user's mesh, its map onto the fitted skin and the skin's rest normals carried onto it.
struct User {
    mesh: TriMesh,
    carry: Carry,
    rest_normals: Vec<Vec3>,
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
            return Err(derma_core::Invalid::new(
                format!("the vertices of '{}'", path.display()),
                format!(
                    "at least {:.0} % within {REACH_MM} mm of the fitted head (is it the mesh the head was fitted to, read in the same unit?)",
                    100.0 * MIN_SHARE
                ),
                format!("only {:.0} %", 100.0 * share),
            )
            .into());
        }
        Ok(Skin {
            head,
            user: Some(User {
                rest_normals: carry.field(&head.skin.normals),
                mesh,
                carry,
            }),
        })
    }

    /// The mesh that moves (rest positions, mm).
    pub fn mesh(&self) -> &TriMesh {
        match &self.user {
            Some(u) => &u.mesh,
            None => &self.head.skin,
        }
    }

    /// This skin posed by the head's own face units (the rig the eye model learnt from) at
    /// `weights`: the reference an eye-model frame is judged against.
    pub fn posed(&self, weights: &[(&str, f32)]) -> Vec<Vec3> {
        let posed = self.head.posed_skin(weights);
        match &self.user {
            None => posed.positions,
            Some(User { mesh, carry, .. }) => {
                let dense: Vec<Vec3> = posed
                    .positions
                    .iter()
                    .zip(&self.head.skin.positions)
                    .map(|(a, b)| *a - *b)
                    .collect();
                mesh.positions
                    .iter()
                    .zip(carry.field(&dense))
                    .map(|(p, d)| *p + d)
                    .collect()
            }
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
            Some(u) => derma_head::fit::onto::sparse(u.carry.field(&dense)),
            None => derma_head::fit::onto::sparse(dense),
        }
    }

    /// Positions and normals of the vertices `which` of this skin in frame `f`: the model's own
    /// on the head's skin; on a user's mesh its rest normal turned as the skin's normal turns at
    /// its point (rest and posed skin normals carried like the positions) — not normals
    /// recomputed from the moved triangles, which show the linear model's lid folds as facets.
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
            Some(u) => {
                let moved = u
                    .carry
                    .field(&self.dense(region, &|m| f.positions[m] - region.rest[m]));
                // The turn of the skin's normals, carried as rest and posed normals: the user's
                // rest normal turns as the skin's at its point does.
                let mut posed = self.head.skin.normals.clone();
                for (s, &m) in region.skin_to_model.iter().enumerate() {
                    if m != u32::MAX {
                        posed[s] = f.normals[m as usize];
                    }
                }
                let posed = u.carry.field(&posed);
                which
                    .iter()
                    .map(|&s| {
                        let s = s as usize;
                        let n = mesh.normals.get(s).copied().unwrap_or(Vec3::Z);
                        let (a, b) = (u.rest_normals[s], posed[s]);
                        let turn = match (a.try_normalize(), b.try_normalize()) {
                            (Some(a), Some(b)) => glam::Quat::from_rotation_arc(a, b),
                            _ => glam::Quat::IDENTITY,
                        };
                        (mesh.positions[s] + moved[s], turn * n)
                    })
                    .unzip()
            }
        }
    }
}
