//! A generator of plausible tracked sequences (issue: "so the pipeline runs and is tested end to
//! end"): the rig driven over time by the blink and gaze drivers, a subject's resting aperture
//! drawn from Read et al. 2006's primary-gaze distribution (9.7 ± 1.2 mm), and tracking noise
//! on every 2D point and gaze angle, written in the tracked-data format.

use crate::blink::{self, Activity};
use crate::gaze::verge;
use crate::idle;
use crate::lids::CONTROL_POINTS;
use crate::rigdata::{Pose, Rig, UNITS};
use crate::tracked::{Tracked, FORMAT};
use derma_core::rng::Philox;
use glam::{Vec2, Vec3};

/// Tracking noise: σ of 2D points (mm; a tenth of a pixel at 0.5 mm per pixel, typical of
/// sub-pixel video tracking, authored) and of gaze angles (°; 0.5° is the usual accuracy of
/// video eye trackers, e.g. Holmqvist et al. 2011, "Eye Tracking", ch. 2).
pub const POINT_NOISE_MM: f32 = 0.05;
/// See [`POINT_NOISE_MM`].
pub const GAZE_NOISE_DEG: f32 = 0.5;

/// Read et al. 2006 (Invest Ophthalmol Vis Sci 47:1234): palpebral opening in primary gaze.
pub const READ_PRIMARY_MM: (f32, f32) = (9.7, 1.2);

/// A tracked sequence of `seconds` at `fps` from the rig (seeded).
pub fn sequence(rig: &Rig, centres: [Vec3; 2], seconds: f32, fps: f32, seed: u64) -> Tracked {
    use rayon::prelude::*;
    let rng = Philox::new(seed, 0x7EAC);
    let rest_mm = (READ_PRIMARY_MM.0 + READ_PRIMARY_MM.1 * rng.normal2(0, 0)[0]).clamp(7.5, 12.0);
    let rest = rig.rest_blink_for(rest_mm);
    let fix = idle::schedule(seconds, seed);
    let blinks = blink::schedule(seconds, Activity::Conversation, seed);
    let mid = 0.5 * (centres[0] + centres[1]);
    let n = (seconds * fps).round().max(10.0) as usize;
    let path = crate::animate::Scanpath::new(fix);
    // A blink of ≥ 45° closes fully (the table 3.1 mean, 34.6°, closes ~¾).
    let full = 45.0;
    let mut frames: Vec<crate::tracked::Frame> = (0..n)
        .into_par_iter()
        .map(|i| {
            let t = i as f32 / fps;
            let cyc = path.at(t);
            let gaze = verge(centres, mid + 600.0 * cyc.direction());
            let closure = blinks
                .iter()
                .map(|bl| bl.closure(t, full))
                .fold(0.0f32, f32::max);
            let w = rest + (1.0 - rest) * closure;
            let pose = Pose {
                gaze,
                blink: [w; 2],
                ..Pose::default()
            };
            let mut f = rig.frame(&pose);
            f.baseline = closure == 0.0;
            // Tracking noise (per frame and point, seeded).
            let noisy = |p: &mut Vec2, j: u64| {
                let z = rng.normal2(((i as u64) << 20) | j, 1);
                *p += POINT_NOISE_MM * Vec2::new(z[0], z[1]);
            };
            for (j, p) in f.lids.iter_mut().chain(f.vertices.iter_mut()).enumerate() {
                noisy(p, j as u64);
            }
            for (e, g) in f.gaze.iter_mut().enumerate() {
                let z = rng.normal2(((i as u64) << 20) | 0xF_FFF0 | e as u64, 2);
                g.h += GAZE_NOISE_DEG * z[0];
                g.v += GAZE_NOISE_DEG * z[1];
            }
            f
        })
        .collect();
    // One fully closed and one wide frame, as a capture session asks the subject for (§3.4).
    for (blink, wide) in [(1.0, 0.0), (0.0, 1.0)] {
        let mut f = rig.frame(&Pose {
            blink: [blink; 2],
            wide: [wide; 2],
            ..Pose::default()
        });
        f.baseline = false;
        frames.push(f);
    }
    Tracked {
        format: FORMAT.into(),
        fps,
        units: UNITS.iter().map(|s| s.to_string()).collect(),
        lid_points: CONTROL_POINTS,
        frames,
    }
}
