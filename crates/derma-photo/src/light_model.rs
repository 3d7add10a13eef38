//! The lighting models de-lighting chooses among (docs/photo.md, "De-lighting"): the shading of a
//! photo as a linear combination of per-vertex terms — one constant (exposure and white balance
//! only: the lighting kept), SH bands 0, 0–1 or 0–2 through the mesh's shadowed or open transfer
//! (Ramamoorthi & Hanrahan 2001; Sloan et al. 2002), and a key light with hard, soft or no
//! shadows. Which model explains a photo set is decided by held-out misfit ([`crate::delight`]).

use derma_core::sh::{open_transfer, SH9};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

/// The most coefficients a photo's shading has per channel: SH bands 0–2, then the key's.
pub const PARAMS: usize = SH9 + 1;

/// The key light's shadows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Key {
    /// No key light.
    None,
    /// A distant point light: hard shadows.
    Hard,
    /// A disc light [`SOFT_KEY_DEG`] in radius: penumbrae (an area light, a softbox, the sun
    /// through haze).
    Soft,
    /// A key light without cast shadows (a light from the camera's side, or a diffuse
    /// surface lit without shadowing).
    Open,
}

/// A lighting model: which terms a photo's shading has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Model {
    /// SH coefficients of the soft light: 0 (one constant per channel: exposure and white
    /// balance alone, the lighting kept), 1 (the sky's occlusion), 4 (bands 0–1) or 9 (bands
    /// 0–2).
    pub soft: usize,
    /// Whether the soft light sees the mesh's occlusion (the shadowed transfer) or not (the
    /// open transfer: no ambient occlusion).
    pub occlusion: bool,
    /// The key light.
    pub key: Key,
}

impl Model {
    /// The model de-lighting starts from: SH bands 0–1 through the shadowed transfer and a
    /// hard-shadowed key.
    pub const START: Model = Model {
        soft: 4,
        occlusion: true,
        key: Key::Hard,
    };

    /// The lighting kept: one constant per photo and channel (exposure and white balance).
    pub const KEPT: Model = Model {
        soft: 0,
        occlusion: false,
        key: Key::None,
    };

    /// The candidates, in the order ties go: the sky's occlusion (the physical prior where the
    /// photos' ratios cannot tell: an even light); the lighting kept; soft light alone; soft
    /// light with a key of hard, soft or no shadows. (Band 2 and the open transfer were
    /// candidates and were dropped: the held-out ratios cannot see the shading all photos
    /// share, and band 2 traded it for the albedo; docs/photo.md.)
    pub fn candidates() -> Vec<Model> {
        let m = |soft, occlusion, key| Model {
            soft,
            occlusion,
            key,
        };
        vec![
            m(1, true, Key::None),
            m(0, false, Key::None),
            m(4, true, Key::None),
            m(4, true, Key::Hard),
            m(4, true, Key::Soft),
            m(4, true, Key::Open),
        ]
    }

    /// Its name in reports, e.g. "SH 0–1 (occluded) + soft key".
    pub fn name(&self) -> String {
        let soft = match self.soft {
            0 => return "exposure and white balance only (the lighting kept)".into(),
            1 => "sky".to_string(),
            4 => "SH 0–1".to_string(),
            _ => "SH 0–2".to_string(),
        };
        let occ = if self.occlusion { "occluded" } else { "open" };
        let key = match self.key {
            Key::None => "",
            Key::Hard => " + hard key",
            Key::Soft => " + soft key",
            Key::Open => " + unshadowed key",
        };
        format!("{soft} ({occ}){key}")
    }
}

/// The angular radius of [`Key::Soft`]'s disc light. Authored: a 60 cm softbox at 1.5 m, or a
/// key a third of the way between the sun (0.27°) and an overcast sky; the held-out misfit, not
/// this figure, decides whether penumbrae help.
pub const SOFT_KEY_DEG: f32 = 12.0;

/// Rays per vertex across [`Key::Soft`]'s disc. Authored: a penumbra resolved in eighths, enough
/// for a term the held-out misfit only compares; the candidate costs 8 rays per scored vertex
/// and photo (about 0.1 s of a bake of the built-in face).
pub const SOFT_KEY_RAYS: usize = 8;

/// The per-vertex terms a model's coefficients multiply, for every photo.
pub struct Basis<'a> {
    /// The SH transfer per vertex (shadowed or open, as the model says).
    pub transfer: &'a [[f32; SH9]],
    /// SH coefficients used (0: the constant).
    pub soft: usize,
    /// Per photo: the key's term per vertex; `None` without a key.
    pub keys: Option<Vec<&'a [f32]>>,
}

impl Basis<'_> {
    /// Coefficients per photo and channel.
    pub fn len(&self) -> usize {
        self.soft.max(1) + usize::from(self.keys.is_some())
    }

    /// Never empty.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The terms of vertex v in photo k (zero beyond [`Basis::len`]).
    pub fn at(&self, v: usize, k: usize) -> [f32; PARAMS] {
        let mut f = [0.0; PARAMS];
        if self.soft == 0 {
            f[0] = 1.0;
        } else {
            f[..self.soft].copy_from_slice(&self.transfer[v][..self.soft]);
        }
        if let Some(keys) = &self.keys {
            f[self.soft.max(1)] = keys[k][v];
        }
        f
    }

    /// Photo k's shading at vertex v under coefficients `coef` (one channel's).
    pub fn shade(&self, v: usize, k: usize, coef: &[f32; PARAMS]) -> f32 {
        self.at(v, k).iter().zip(coef).map(|(a, b)| a * b).sum()
    }
}

/// The open (unshadowed) SH transfer of every vertex.
pub fn open_transfers(normals: &[Vec3]) -> Vec<[f32; SH9]> {
    normals.par_iter().map(|n| open_transfer(*n)).collect()
}

/// Directions across a disc light of angular radius `deg` about unit `l`: a Fibonacci spiral
/// over the cap, even in solid angle.
pub fn disc_directions(l: Vec3, deg: f32, n: usize) -> Vec<Vec3> {
    let (a, b) = l.any_orthonormal_pair();
    let cos_max = deg.to_radians().cos();
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (1.0 - cos_max) * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f32;
            (l * z + a * (r * phi.cos()) + b * (r * phi.sin())).normalize()
        })
        .collect()
}

/// A key's term at one vertex with unit normal `n`: max(⟨n, l⟩, 0) for [`Key::Open`]; times
/// the visibility of l for [`Key::Hard`]; the mean of max(⟨n, d⟩, 0) × visibility over the
/// disc's directions for [`Key::Soft`] (`open(d)`: nothing in the way toward d).
pub fn key_at(key: Key, n: Vec3, l: Vec3, disc: &[Vec3], open: &dyn Fn(Vec3) -> bool) -> f32 {
    match key {
        Key::None => 0.0,
        Key::Open => n.dot(l).max(0.0),
        Key::Hard => {
            let c = n.dot(l);
            if c > 0.0 && open(l) {
                c
            } else {
                0.0
            }
        }
        Key::Soft => {
            let sum: f32 = disc
                .iter()
                .map(|d| {
                    let c = n.dot(*d);
                    if c > 0.0 && open(*d) {
                        c
                    } else {
                        0.0
                    }
                })
                .sum();
            sum / disc.len().max(1) as f32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_basis_places_the_key_after_the_soft_light() {
        let t = [[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]];
        let key = [0.5f32];
        let b = Basis {
            transfer: &t,
            soft: 4,
            keys: Some(vec![&key[..]]),
        };
        assert_eq!(b.len(), 5);
        assert_eq!(&b.at(0, 0)[..6], &[1.0, 2.0, 3.0, 4.0, 0.5, 0.0]);
        let c = Basis {
            transfer: &t,
            soft: 0,
            keys: None,
        };
        assert_eq!(c.len(), 1);
        assert_eq!(c.at(0, 0)[0], 1.0);
        assert_eq!(c.at(0, 0)[1..], [0.0; PARAMS - 1]);
    }

    #[test]
    fn disc_directions_lie_within_the_disc_and_centre_on_it() {
        let l = Vec3::new(0.3, 0.4, 0.866).normalize();
        let d = disc_directions(l, SOFT_KEY_DEG, 64);
        let cos_max = SOFT_KEY_DEG.to_radians().cos();
        assert!(d.iter().all(|x| x.dot(l) >= cos_max - 1e-5));
        let mean: Vec3 = d.iter().copied().sum::<Vec3>() / 64.0;
        assert!(mean.normalize().dot(l) > 0.9999, "{mean}");
    }

    #[test]
    fn a_soft_key_half_blocked_gives_about_half_the_light() {
        // A wall blocking every direction with x < 0: half the disc about +z is in shadow.
        let l = Vec3::Z;
        let disc = disc_directions(l, SOFT_KEY_DEG, 64);
        let open = |d: Vec3| d.x >= 0.0;
        let soft = key_at(Key::Soft, Vec3::Z, l, &disc, &open);
        let full = key_at(Key::Soft, Vec3::Z, l, &disc, &|_| true);
        assert!((soft / full - 0.5).abs() < 0.05, "{soft} / {full}");
        // The hard key sees its centre only (open here), the open key ignores the wall.
        assert!(key_at(Key::Hard, Vec3::Z, l, &disc, &|d: Vec3| d.x > 0.01) == 0.0);
        assert_eq!(key_at(Key::Open, Vec3::Z, l, &disc, &|_| false), 1.0);
    }
}
