//! One still frame of the eye-region model (thesis §3.9, Algorithm 1) for a posed head: gaze
//! (yaw, pitch), lid closure and face units in, the skin's region vertices out — what
//! `derma render --gaze --blink` draws, so the lids and the skin around the eyes follow the
//! globes as in `derma eyes animate`. The face units the model takes as inputs (the region's
//! units, g̃₁₁…) come from the pose, so a squint or a raised brow moves the lids with it.

use crate::evaluate::{Evaluator, Frame};
use crate::gaze::{verge, Fick, Gaze};
use crate::model::{Components, EyeModel};
use crate::rigdata::Rig;
use derma_head::Head;

/// Distance (mm) of the fixated point in front of the eyes: far enough that the eyes are
/// parallel to within a degree (as `derma eyes animate`'s default drive).
pub const FIXATION_MM: f32 = 1000.0;

/// The pose a still frame shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyePose {
    /// Gaze yaw (°, positive to the subject's left, +X) and pitch (° up) of the cyclopean eye.
    pub gaze: (f32, f32),
    /// Lid closure in [0, 1]: 0 open as the model's baseline for the gaze, 1 a full blink.
    pub closure: f32,
}

impl EyePose {
    /// Looking ahead, lids open.
    pub const REST: EyePose = EyePose {
        gaze: (0.0, 0.0),
        closure: 0.0,
    };
}

/// The eye-region model of `head`, trained once on its rig (300 poses, as `derma eyes
/// animate` trains it when given no model).
pub struct StillModel {
    pub(crate) rig: Rig,
    pub(crate) model: EyeModel,
    pub(crate) evaluator: Evaluator,
    pub(crate) lashes: Vec<LashAnchors>,
}

/// A lash part and, per vertex, the lid-margin model vertex it rides on (the nearest at rest).
pub struct LashAnchors {
    /// The part's name (`eyelashes_left`…).
    pub name: String,
    /// Its rest mesh.
    pub mesh: derma_core::mesh::TriMesh,
    /// Per vertex, its margin model vertex.
    pub near: Vec<u32>,
}

/// The lash parts of `head` anchored to the lid margins of `region`.
pub fn lash_anchors(head: &Head, region: &crate::region::EyeRegion) -> Vec<LashAnchors> {
    let margin: Vec<u32> = region.margins.iter().flatten().flatten().copied().collect();
    head.parts
        .iter()
        .filter(|p| p.name.starts_with("eyelashes"))
        .map(|p| LashAnchors {
            name: p.name.clone(),
            mesh: p.mesh.clone(),
            near: p
                .mesh
                .positions
                .iter()
                .map(|q| {
                    *margin
                        .iter()
                        .min_by(|&&a, &&b| {
                            (region.rest[a as usize] - *q)
                                .length_squared()
                                .total_cmp(&(region.rest[b as usize] - *q).length_squared())
                        })
                        .expect("margins")
                })
                .collect(),
        })
        .collect()
}

impl LashAnchors {
    /// The lashes moved as their margin vertices moved from `rest` to `positions`.
    pub fn moved(
        &self,
        rest: &[glam::Vec3],
        positions: &[glam::Vec3],
    ) -> derma_core::mesh::TriMesh {
        let mut m = self.mesh.clone();
        for (p, &n) in m.positions.iter_mut().zip(&self.near) {
            *p += positions[n as usize] - rest[n as usize];
        }
        m
    }
}

impl StillModel {
    /// [`crate::animate::idle_track`] for this model on `head`: a blink of the model's full
    /// amplitude about the left globe closes the eye.
    pub fn idle_track(
        &self,
        head: &Head,
        seconds: f32,
        fps: f32,
        activity: crate::blink::Activity,
        seed: u64,
    ) -> Vec<[f32; 3]> {
        let eye = head.eyes[0];
        let full = crate::animate::full_blink_amplitude(&self.model, eye.centre.y, eye.radius);
        crate::animate::idle_track(seconds, fps, activity, seed, full)
    }

    /// Trains the model of `head` and binds it (skin thickness over the globes
    /// [`crate::sliding::THICKNESS`]).
    pub fn new(head: &Head) -> crate::Result<StillModel> {
        let rig = Rig::new(head)?;
        let model = EyeModel::fit(&rig.samples(300, 1), Components::default())?;
        let thickness = crate::sliding::THICKNESS;
        let evaluator = Evaluator::new(&model, &rig.region, head, thickness)?;
        let lashes = lash_anchors(head, &rig.region);
        Ok(StillModel {
            rig,
            model,
            evaluator,
            lashes,
        })
    }

    /// The model's input g̃ for `pose` with face units `units` (by name; the model reads the
    /// region's squint units as inputs and its blink and wide units as lid openings, others
    /// are ignored) on `head`.
    pub fn gaze(&self, head: &Head, pose: EyePose, units: &[(&str, f32)]) -> Gaze {
        let centres = [head.eyes[0].centre, head.eyes[1].centre];
        let mid = 0.5 * (centres[0] + centres[1]);
        let cyc = Fick {
            h: pose.gaze.0,
            v: pose.gaze.1,
            t: 0.0,
        };
        let eyes = verge(centres, mid + FIXATION_MM * cyc.direction());
        let weight = |name: &str| {
            units
                .iter()
                .filter(|(n, _)| *n == name)
                .map(|(_, w)| *w)
                .sum::<f32>()
                .clamp(0.0, 1.0)
        };
        // Closure c is the peak of a blink of c × the full amplitude (blink.rs); a pose's
        // eyeBlink units close the lids as far, its eyeWide units open them toward the widest
        // opening of the training (normalised 1), less as they close.
        let lids = [0, 1].map(|e| {
            let side = ["Left", "Right"][e];
            let c = pose
                .closure
                .max(weight(&format!("eyeBlink{side}")))
                .clamp(0.0, 1.0);
            let wide = weight(&format!("eyeWide{side}")) * (1.0 - c);
            self.model
                .baseline_aperture(e, eyes[e].h, eyes[e].v, 1.0 - c)
                .map(|b| b + wide * (1.0 - b))
        });
        Gaze {
            eyes,
            lids,
            units: self.model.units.iter().map(|u| weight(u)).collect(),
        }
    }

    /// `skin` (the head's skin, posed by `units` or at rest) with its eye-region vertices where
    /// the model puts them for `pose` plus the offsets of the units outside the region, and the lash parts riding on the lid margins (name,
    /// moved mesh).
    pub fn pose_skin(
        &self,
        head: &Head,
        pose: EyePose,
        units: &[(&str, f32)],
        skin: &mut derma_core::mesh::TriMesh,
    ) -> Vec<(String, derma_core::mesh::TriMesh)> {
        let g = self.gaze(head, pose, units);
        let mut f = Frame::default();
        self.evaluator.frame(&g, &mut f);
        // The model replaces what the region's own units (gaze, blink, squint, wide) do to its
        // vertices; the other units (a raised brow, a smile's cheeks) still add their offsets.
        let mut own = vec![glam::Vec3::ZERO; skin.positions.len()];
        for u in head.face_units() {
            let w: f32 = units
                .iter()
                .filter(|(n, _)| *n == u.name)
                .map(|(_, w)| *w)
                .sum();
            if w != 0.0 && crate::region::REGION_UNITS.contains(&u.name.as_str()) {
                for &(v, d) in &u.skin {
                    if let Some(o) = own.get_mut(v as usize) {
                        *o += w * d;
                    }
                }
            }
        }
        for (v, &m) in self.rig.region.skin_to_model.iter().enumerate() {
            if m != u32::MAX && v < skin.positions.len() {
                let others = skin.positions[v] - head.skin.positions[v] - own[v];
                skin.positions[v] = f.positions[m as usize] + others;
            }
        }
        skin.compute_normals();
        self.lashes
            .iter()
            .map(|l| (l.name.clone(), l.moved(&self.rig.region.rest, &f.positions)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The height (mm) of the left upper lid's margin at its middle vertex.
    fn lid_height(skin: &derma_core::mesh::TriMesh, m: &StillModel) -> f32 {
        let chain = &m.rig.region.margins[0][0];
        let mid = chain[chain.len() / 2];
        let v = m
            .rig
            .region
            .skin_to_model
            .iter()
            .position(|&k| k == mid)
            .expect("the margin is on the skin");
        skin.positions[v].y
    }

    #[test]
    fn the_lids_follow_the_gaze_and_close_with_a_blink() {
        let head = Head::builtin();
        let m = StillModel::new(head).unwrap();
        let at = |pose: EyePose| {
            let mut skin = head.skin.clone();
            let lashes = m.pose_skin(head, pose, &[], &mut skin);
            assert_eq!(lashes.len(), 2);
            (lid_height(&skin, &m), lashes[0].1.positions[0].y)
        };
        let (rest, lash_rest) = at(EyePose::REST);
        let (up, _) = at(EyePose {
            gaze: (0.0, 20.0),
            closure: 0.0,
        });
        let (down, _) = at(EyePose {
            gaze: (0.0, -20.0),
            closure: 0.0,
        });
        let (shut, lash_shut) = at(EyePose {
            gaze: (0.0, 0.0),
            closure: 1.0,
        });
        eprintln!("upper lid y: rest {rest:.2}, up {up:.2}, down {down:.2}, shut {shut:.2} mm");
        // The rig-trained model lifts the lid little in upgaze (the built-in eyeLookUp units
        // do) and lowers it more in downgaze.
        assert!(up > rest + 0.2 && down < rest - 0.8, "{up} {rest} {down}");
        assert!(shut < rest - 5.0, "{shut} {rest}");
        // The lashes ride down with the lid.
        assert!(lash_shut < lash_rest - 1.0, "{lash_rest} → {lash_shut}");
        // At rest the model gives back the rest mesh.
        let rest_lid = lid_height(&head.skin, &m);
        assert!((rest - rest_lid).abs() < 0.1, "{rest} {rest_lid}");
    }
}
