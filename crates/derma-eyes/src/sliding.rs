//! Globe sliding (thesis §3.8–3.9, Algorithm 1): skin that the motion model puts inside a globe
//! is pushed out radially to the globe's surface plus a skin thickness t, in the globe's current
//! orientation, so lids ride over the corneal bulge; extrapolated vertices at the lid margins and
//! canthi keep their rest offset δ₀ from the globe (eq. 3.14); normals follow (eqs. 3.17–3.19).

use crate::globe::RadialMap;
use glam::{Quat, Vec3};

/// Default cap (mm) on the skin thickness over the globe: a vertex never comes closer to the
/// globe than min(its rest gap, this). Upper-lid skin with orbicularis and tarsus is about 1 mm
/// thick near the margin (authored; the thesis leaves t to the user).
pub const THICKNESS: f32 = 1.0;

/// Inner-surface vertices within this distance (mm) of a globe at rest get the δ₀ treatment: the
/// lid margins and canthi, not the deep socket (authored).
const DELTA0_REACH: f32 = 4.0;

/// How one vertex slides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// Follows the region's surface; pushed out only when inside the globe (δ̂ > 1).
    Surface {
        /// Skin thickness t over the globe.
        t: f32,
    },
    /// An extrapolated vertex kept at its rest radial offset δ₀ from the globe.
    Offset {
        /// δ₀ (mm), measured from D + t.
        delta0: f32,
        /// Skin thickness t.
        t: f32,
        /// Globe sliding normal τ̂₀ at rest (globe frame).
        tau0: Vec3,
    },
}

/// The globes and each vertex's mode.
#[derive(Clone, Debug)]
pub struct Slider {
    /// Globe centres (head space).
    pub centres: [Vec3; 2],
    /// D(α) per globe (globe frame).
    pub maps: [RadialMap; 2],
    /// Eye of each vertex.
    pub eye: Vec<u8>,
    /// Mode of each vertex.
    pub modes: Vec<Mode>,
    /// Vertices that can reach a globe (rest gap under [`REACH_MM`]); the others are skipped.
    pub near: Vec<u32>,
    /// Largest radial distance of each globe's surface (mm).
    pub reach: [f32; 2],
}

/// A vertex further than this (mm) from its globe at rest never meets it: the region's skin
/// slides by a few millimetres at most (a blink moves the upper lid ~10 mm, but along the globe).
pub const REACH_MM: f32 = 8.0;

impl Slider {
    /// Modes from rest positions: `offset` vertices (the thesis' extrapolated lid margins and
    /// canthi: here the lids' inner surfaces) near a globe keep δ₀ = |r₀| − D(α₀) − t; every
    /// vertex's t is min(rest gap, `thickness`).
    pub fn new(
        centres: [Vec3; 2],
        maps: [RadialMap; 2],
        rest: &[Vec3],
        eye: &[u8],
        offset: &[bool],
        thickness: f32,
    ) -> Slider {
        let modes = rest
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let e = eye[i] as usize;
                let r = p - centres[e];
                let len = r.length().max(1e-6);
                let d = r / len;
                let gap = len - maps[e].sample(d);
                let t = gap.clamp(0.0, thickness);
                if offset[i] && gap < DELTA0_REACH {
                    Mode::Offset {
                        delta0: gap - t,
                        t,
                        tau0: d,
                    }
                } else {
                    Mode::Surface { t }
                }
            })
            .collect();
        let near = rest
            .iter()
            .enumerate()
            .filter(|(i, p)| {
                let e = eye[*i] as usize;
                (**p - centres[e]).length()
                    < maps[e].sample((**p - centres[e]).normalize_or(Vec3::Z)) + REACH_MM
            })
            .map(|(i, _)| i as u32)
            .collect();
        let reach = [0, 1].map(|e| maps[e].radius.iter().copied().fold(0.0f32, f32::max));
        Slider {
            centres,
            maps,
            eye: eye.to_vec(),
            modes,
            near,
            reach,
        }
    }

    /// Algorithm 1 on every vertex, globes rotated by `rot` (from primary position).
    pub fn apply(&self, rot: [Quat; 2], pos: &mut [Vec3], nrm: &mut [Vec3], rest_normals: &[Vec3]) {
        let inv = rot.map(|q| q.inverse());
        for &i in &self.near {
            let i = i as usize;
            let e = self.eye[i] as usize;
            let c = self.centres[e];
            // Position in the globe's frame.
            let r = inv[e] * (pos[i] - c);
            let len = r.length().max(1e-6);
            let dir = r / len;
            match self.modes[i] {
                Mode::Surface { t } => {
                    // Beyond the globe's furthest point plus t nothing can push the vertex.
                    if len >= self.reach[e] + t {
                        continue;
                    }
                    let delta = self.maps[e].sample(dir) + t;
                    if delta > len {
                        pos[i] = c + rot[e] * (dir * delta);
                        // Eq. 3.17–3.18: the globe sliding normal (sphere approximation).
                        nrm[i] = (pos[i] - c).normalize();
                    }
                }
                Mode::Offset { delta0, t, tau0 } => {
                    let delta = self.maps[e].sample(dir) + t + delta0;
                    pos[i] = c + rot[e] * (dir * delta);
                    // Eq. 3.19: turn the rest normal as the sliding normal turns from τ̂₀ to τ̂
                    // (to first order: exact at rest, no rotation to build).
                    let tau = rot[e] * dir;
                    let n = rest_normals[i] + tau - tau0;
                    nrm[i] = n * n.length_recip();
                }
            }
        }
    }
}
