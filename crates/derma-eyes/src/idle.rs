//! Idle gaze (Lee, Badler & Badler 2002, "Eyes Alive"): saccade magnitudes with P(A) ∝ e^(−A/6.9),
//! directions from a histogram over eight sectors, and alternating mutual (towards the viewer)
//! and away gaze with their own fixation intervals; targets from a saliency map or a gaze
//! tracker instead when given.

use crate::gaze::Fick;
use derma_core::rng::Philox;

/// Mean saccade magnitude (°) of the exponential P(A) ∝ e^(−A/6.9) (Lee et al. 2002, eq. 1 fit).
pub const MAGNITUDE_SCALE: f32 = 6.9;
/// Largest idle saccade (°; authored): larger shifts come with head movement, which this model
/// leaves out.
pub const MAX_MAGNITUDE: f32 = 27.0;

/// Relative frequency of saccade directions in eight 45° sectors, counter-clockwise from "right"
/// (towards −X for the viewer-facing head … +X is the head's left). Authored after the shape Lee
/// et al. 2002 report — horizontal and vertical directions dominate, obliques are rarer — not
/// their exact percentages.
pub const DIRECTIONS: [f32; 8] = [0.18, 0.07, 0.15, 0.07, 0.18, 0.07, 0.21, 0.07];

/// Mean fixation (inter-saccade) interval (s) in mutual and away gaze. Authored: Lee et al. fit
/// polynomials to the interval distributions of talking and listening; derma uses exponential
/// intervals with these means.
pub const MUTUAL_S: f32 = 1.6;
/// See [`MUTUAL_S`].
pub const AWAY_S: f32 = 0.8;

/// A fixation: from `start` the eyes look at `gaze` (after a saccade from the previous one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fixation {
    /// Start time of the saccade into it (s).
    pub start: f32,
    /// Target gaze (both eyes before vergence), relative to looking at the viewer.
    pub gaze: Fick,
    /// True in mutual gaze (looking at the viewer).
    pub mutual: bool,
}

/// Inverse CDF of the truncated exponential magnitude distribution.
pub fn magnitude(u: f32) -> f32 {
    let cap = 1.0 - (-MAX_MAGNITUDE / MAGNITUDE_SCALE).exp();
    -MAGNITUDE_SCALE * (1.0 - u * cap).ln()
}

/// The idle-gaze sequence over `seconds`.
pub fn schedule(seconds: f32, seed: u64) -> Vec<Fixation> {
    let rng = Philox::new(seed, 0x1D1E);
    let total: f32 = DIRECTIONS.iter().sum();
    let mut out = vec![Fixation {
        start: 0.0,
        gaze: Fick::PRIMARY,
        mutual: true,
    }];
    let mut t = 0.0f32;
    let mut mutual = true;
    let mut away = Fick::PRIMARY;
    for i in 0u64.. {
        let u = rng.uniform4(i, 0);
        let mean = if mutual { MUTUAL_S } else { AWAY_S };
        t += -mean * (1.0 - u[0]).ln();
        if t >= seconds {
            break;
        }
        // Mutual gaze is left for an away excursion (and back) now and then.
        let leave = u[1] < 0.35;
        let (gaze, m) = if mutual && !leave {
            // Small corrective saccades about the viewer.
            (jitter(&rng, i, 0.25), true)
        } else if mutual || u[1] < 0.5 {
            let a = magnitude(u[2]);
            let mut acc = 0.0;
            let mut sector = 7;
            for (k, w) in DIRECTIONS.iter().enumerate() {
                acc += w / total;
                if u[3] < acc {
                    sector = k;
                    break;
                }
            }
            let dir = (sector as f32 * 45.0 + 45.0 * rng.uniform4(i, 1)[0] - 22.5).to_radians();
            away = Fick {
                h: (away.h + a * dir.cos()).clamp(-MAX_MAGNITUDE, MAX_MAGNITUDE),
                v: (away.v + a * dir.sin()).clamp(-MAX_MAGNITUDE, MAX_MAGNITUDE),
                t: 0.0,
            };
            if mutual {
                away = Fick {
                    h: a * dir.cos(),
                    v: a * dir.sin(),
                    t: 0.0,
                };
            }
            (away, false)
        } else {
            (Fick::PRIMARY, true)
        };
        mutual = m;
        out.push(Fixation {
            start: t,
            gaze,
            mutual: m,
        });
    }
    out
}

fn jitter(rng: &Philox, i: u64, deg: f32) -> Fick {
    let n = rng.normal2(i, 9);
    Fick {
        h: deg * n[0],
        v: deg * n[1],
        t: 0.0,
    }
}
