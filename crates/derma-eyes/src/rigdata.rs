//! Training data without a capture rig (issue: "an artist-made rig no one here wrote"): the
//! built-in head's face units eyeLook*, eyeBlink*, eyeSquint* and eyeWide* pose the lids and the
//! skin around them; sampled gaze/blink combinations are projected through the modelling camera
//! into the tracked-data format the thesis' capture produces (§3.4).

use crate::gaze::Fick;
use crate::lids::{opening, project, resample, CONTROL_POINTS};
use crate::region::EyeRegion;
use crate::tracked::{Frame, Tracked, FORMAT};
use derma_core::rng::Philox;
use derma_head::Head;
use glam::{Vec2, Vec3};

/// Gaze angle (°) at which an eyeLook unit reaches weight 1, in every direction. Authored:
/// ARKit's units carry no angle; 45° lies inside the human oculomotor range of about ±55°
/// (Guitton & Volle 1987, J Neurophysiol 58:427). The lids' response to gaze is then the
/// artist's, and the anatomical check against Read et al. 2006 tests it.
pub const FULL_LOOK: f32 = 45.0;

/// Action units of the rig-trained model (g₁₁, g₁₂): squint raises the cheeks and lower lids
/// beyond what the aperture says.
pub const UNITS: [&str; 2] = ["eyeSquintLeft", "eyeSquintRight"];

/// A pose of the rig's eye units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// Gaze per eye.
    pub gaze: [Fick; 2],
    /// eyeBlink weight per eye.
    pub blink: [f32; 2],
    /// eyeWide weight per eye.
    pub wide: [f32; 2],
    /// eyeSquint weight per eye.
    pub squint: [f32; 2],
}

/// The rig: the head's eye region and its unit offsets on the model vertices.
pub struct Rig {
    /// The region.
    pub region: EyeRegion,
    units: Vec<(String, Vec<(u32, Vec3)>)>,
    /// The skin's triangles that touch the region, their corners as model vertices or, outside
    /// the region, fixed rest positions (for the posed region's normals).
    triangles: Vec<[Corner; 3]>,
}

/// A triangle corner of the rig's region: a model vertex, or a skin vertex that never moves.
#[derive(Clone, Copy, Debug)]
enum Corner {
    Model(u32),
    Fixed(Vec3),
}

impl Rig {
    /// The rig of a head (its eye region, [`EyeRegion::of_head`]).
    pub fn new(head: &Head) -> crate::Result<Rig> {
        Ok(Self::with_region(head, EyeRegion::of_head(head)?))
    }

    /// The rig of a head over a given region of it.
    pub fn with_region(head: &Head, region: EyeRegion) -> Rig {
        let units = crate::region::REGION_UNITS
            .iter()
            .map(|&name| {
                let t = head
                    .face_units()
                    .iter()
                    .find(|t| t.name == name)
                    .expect("checked by the region");
                let mut offs: Vec<(u32, Vec3)> = t
                    .skin
                    .iter()
                    .filter_map(|&(i, d)| {
                        let m = region.skin_to_model[i as usize];
                        (m != u32::MAX).then_some((m, d))
                    })
                    .collect();
                offs.sort_by_key(|o| o.0);
                offs.dedup_by_key(|o| o.0);
                (name.to_string(), offs)
            })
            .collect();
        let triangles = head
            .skin
            .triangles
            .iter()
            .filter(|t| {
                t.iter()
                    .any(|&s| region.skin_to_model[s as usize] != u32::MAX)
            })
            .map(|t| {
                t.map(|s| match region.skin_to_model[s as usize] {
                    u32::MAX => Corner::Fixed(head.skin.positions[s as usize]),
                    m => Corner::Model(m),
                })
            })
            .collect();
        Rig {
            region,
            units,
            triangles,
        }
    }

    /// Area-weighted normals of the model vertices at posed positions `x` (the rest normal where
    /// a vertex has no triangle).
    pub fn normals(&self, x: &[Vec3]) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; x.len()];
        let at = |c: &Corner| match c {
            Corner::Model(m) => x[*m as usize],
            Corner::Fixed(p) => *p,
        };
        for t in &self.triangles {
            let [a, b, c] = t.map(|k| at(&k));
            let f = (b - a).cross(c - a);
            for k in t {
                if let Corner::Model(m) = k {
                    n[*m as usize] += f;
                }
            }
        }
        n.iter()
            .zip(&self.region.rest_normals)
            .map(|(v, r)| v.try_normalize().unwrap_or(*r))
            .collect()
    }

    /// Face-unit weights of a pose.
    pub fn weights(&self, p: &Pose) -> Vec<(&'static str, f32)> {
        let mut w = Vec::new();
        for e in 0..2 {
            let g = p.gaze[e];
            let h = (g.h / FULL_LOOK).clamp(-1.0, 1.0);
            let v_down = (-g.v / FULL_LOOK).clamp(0.0, 1.0);
            let v_up = (g.v / FULL_LOOK).clamp(0.0, 1.0);
            // h > 0 looks towards +X: outwards for the left eye, inwards for the right.
            let (out, inn) = if e == 0 {
                (h.max(0.0), (-h).max(0.0))
            } else {
                ((-h).max(0.0), h.max(0.0))
            };
            // REGION_UNITS per side: LookUp, LookDown, LookIn, LookOut, Blink, Squint, Wide.
            let u = &crate::region::REGION_UNITS[7 * e..7 * e + 7];
            w.extend([
                (u[3], out),
                (u[2], inn),
                (u[1], v_down),
                (u[0], v_up),
                (u[4], p.blink[e]),
                (u[6], p.wide[e]),
                (u[5], p.squint[e]),
            ]);
        }
        w
    }

    /// Model-vertex positions with face-unit weights applied.
    pub fn positions(&self, weights: &[(&str, f32)]) -> Vec<Vec3> {
        let mut p = self.region.rest.clone();
        for (name, w) in weights {
            if *w == 0.0 {
                continue;
            }
            if let Some((_, offs)) = self.units.iter().find(|u| u.0 == *name) {
                for &(i, d) in offs {
                    p[i as usize] += *w * d;
                }
            }
        }
        p
    }

    /// One lid's control points in the modelling camera (eye 0/1, lid 0 upper / 1 lower).
    pub fn lid(&self, positions: &[Vec3], eye: usize, lid: usize) -> Vec<Vec2> {
        let chain: Vec<Vec2> = self.region.margins[eye][lid]
            .iter()
            .map(|&i| project(positions[i as usize]))
            .collect();
        resample(&chain, CONTROL_POINTS)
    }

    /// The tracked frame of a pose.
    pub fn frame(&self, p: &Pose) -> Frame {
        let x = self.positions(&self.weights(p));
        self.frame_of(p, &x)
    }

    /// The tracked frame of posed model positions `x`.
    pub fn frame_of(&self, p: &Pose, x: &[Vec3]) -> Frame {
        let mut lids = Vec::with_capacity(4 * CONTROL_POINTS);
        for e in 0..2 {
            for l in 0..2 {
                lids.extend(self.lid(x, e, l));
            }
        }
        Frame {
            gaze: p.gaze,
            lids,
            units: p.squint.to_vec(),
            vertices: x[..self.region.tracked]
                .iter()
                .map(|&v| project(v))
                .collect(),
            baseline: p.blink == [0.0; 2] && p.wide == [0.0; 2] && p.squint == [0.0; 2],
        }
    }

    /// Palpebral opening (mm) of eye `e` in a pose.
    pub fn opening(&self, p: &Pose, e: usize) -> f32 {
        let x = self.positions(&self.weights(p));
        opening(&self.lid(&x, e, 0), &self.lid(&x, e, 1))
    }

    /// `n` sampled poses (seeded): gaze over ±30° horizontally and −35…+25° vertically with a
    /// little vergence, a third of them with partial blinks, some wide or squinting, plus a fully
    /// closed and a fully wide frame so aperture normalisation sees both ends.
    pub fn sample_poses(&self, n: usize, seed: u64) -> Vec<Pose> {
        let rng = Philox::new(seed, 0x5EED_E7E5);
        let mut poses = vec![
            Pose {
                blink: [1.0; 2],
                ..Pose::default()
            },
            Pose {
                wide: [1.0; 2],
                ..Pose::default()
            },
        ];
        for i in 0..n.saturating_sub(2) as u64 {
            let a = rng.uniform4(i, 0);
            let b = rng.uniform4(i, 1);
            let h = -30.0 + 60.0 * a[0];
            let v = -35.0 + 60.0 * a[1];
            let verg = 3.0 * a[2];
            let gaze = [
                Fick {
                    h: h - verg,
                    v,
                    t: 0.0,
                },
                Fick {
                    h: h + verg,
                    v,
                    t: 0.0,
                },
            ];
            let blink = if b[0] < 0.33 { b[1] } else { 0.0 };
            let (wide, squint) = if blink > 0.0 {
                (0.0, 0.0)
            } else if b[2] < 0.15 {
                (b[3], 0.0)
            } else if b[2] > 0.8 {
                (0.0, b[3])
            } else {
                (0.0, 0.0)
            };
            poses.push(Pose {
                gaze,
                blink: [blink; 2],
                wide: [wide; 2],
                squint: [squint; 2],
            });
        }
        poses
    }

    /// Tracked data of sampled poses (unordered samples: fps 0).
    pub fn samples(&self, n: usize, seed: u64) -> Tracked {
        use rayon::prelude::*;
        let poses = self.sample_poses(n, seed);
        Tracked {
            format: FORMAT.into(),
            fps: 0.0,
            units: UNITS.iter().map(|s| s.to_string()).collect(),
            lid_points: CONTROL_POINTS,
            frames: poses.par_iter().map(|p| self.frame(p)).collect(),
        }
    }

    /// The eyeBlink weight at which the opening in primary gaze is `mm` (a subject's resting
    /// lid position), by bisection; 0 when the rig's neutral is already narrower.
    pub fn rest_blink_for(&self, mm: f32) -> f32 {
        let at = |b: f32| {
            self.opening(
                &Pose {
                    blink: [b; 2],
                    ..Pose::default()
                },
                0,
            )
        };
        if at(0.0) <= mm {
            return 0.0;
        }
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for _ in 0..30 {
            let m = 0.5 * (lo + hi);
            if at(m) > mm {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    }
}
