//! Drivers to frames (thesis §3.9, "realistic input synthesis"): gaze from idle-gaze statistics,
//! salient image points or a gaze tracker, moved on the saccade main sequence and verged on a
//! target at a distance; spontaneous blinks scale the baseline aperture (eq. 3.11's closing
//! factor c), which follows vertical gaze — the lid saccades that accompany eye saccades.

use crate::blink::{self, Activity, Blink};
use crate::gaze::{verge, Fick, Gaze};
use crate::idle::{self, Fixation};
use crate::model::EyeModel;
use crate::saccade::Profile;
use crate::{EyesError, Result};
use glam::Vec3;
use serde::Serialize;
use std::path::Path;

/// What drives the animation.
#[derive(Clone, Debug)]
pub struct Drive {
    /// Length (s).
    pub seconds: f32,
    /// Frames per second.
    pub fps: f32,
    /// Activity (blink rate).
    pub activity: Activity,
    /// Seed of the stochastic drivers.
    pub seed: u64,
    /// Distance (mm) of what the eyes look at, for vergence.
    pub distance: f32,
    /// Fixations to follow (time, gaze); idle gaze when `None`.
    pub fixations: Option<Vec<Fixation>>,
    /// Blinks; spontaneous ones from `activity` when `None`.
    pub blinks: Option<Vec<Blink>>,
}

impl Default for Drive {
    fn default() -> Self {
        Drive {
            seconds: 4.0,
            fps: 30.0,
            activity: Activity::Rest,
            seed: 1,
            distance: 1000.0,
            fixations: None,
            blinks: None,
        }
    }
}

/// One frame of the drivers.
#[derive(Clone, Debug, Serialize)]
pub struct Sample {
    /// Time (s).
    pub t: f32,
    /// The normalised gaze vector.
    pub gaze: Gaze,
    /// Lid closure from blinks, 0 open … 1 closed.
    pub closure: f32,
    /// Cyclopean gaze before vergence.
    pub cyclopean: Fick,
}

/// Fixations joined by saccades on the main sequence: the cyclopean gaze at any time.
pub struct Scanpath {
    fixations: Vec<Fixation>,
    /// Gaze each saccade starts from.
    from: Vec<Fick>,
    profiles: Vec<Profile>,
}

impl Scanpath {
    /// The path through `fixations` (sorted by start; the first starts from primary position).
    pub fn new(fixations: Vec<Fixation>) -> Scanpath {
        let mut from = vec![Fick::PRIMARY; fixations.len()];
        for k in 1..fixations.len() {
            from[k] = fixations[k - 1].gaze;
        }
        let profiles = fixations
            .iter()
            .zip(&from)
            .map(|(f, p)| Profile::new(p.amplitude_to(f.gaze)))
            .collect();
        Scanpath {
            fixations,
            from,
            profiles,
        }
    }

    /// The cyclopean gaze at time `t` (s): the saccade into the current fixation along its
    /// velocity profile, then the fixation.
    pub fn at(&self, t: f32) -> Fick {
        if self.fixations.is_empty() {
            return Fick::PRIMARY;
        }
        let k = self
            .fixations
            .partition_point(|f| f.start <= t)
            .saturating_sub(1);
        let s = self.profiles[k].progress(t - self.fixations[k].start);
        let (a, b) = (self.from[k], self.fixations[k].gaze);
        Fick {
            h: a.h + (b.h - a.h) * s,
            v: a.v + (b.v - a.v) * s,
            t: 0.0,
        }
    }
}

/// Upper-lid rotation (°) from the model's open baseline to closed, about the globe centre at
/// `radius`: a blink of this amplitude closes the eye fully.
pub fn full_blink_amplitude(m: &EyeModel, centre_y: f32, radius: f32) -> f32 {
    let open = m.denormalise_lids(0, m.baseline_aperture(0, 0.0, 0.0, 1.0));
    let up = m.plane[0] + open[0] - centre_y;
    let closed = m.plane[0] - centre_y;
    let a = |y: f32| (y / radius).clamp(-1.0, 1.0).asin().to_degrees();
    (a(up) - a(closed)).max(1.0)
}

/// The idle eyes as the web viewer plays them: `seconds` at `fps`, each frame the cyclopean
/// gaze (h, v in °, Fick, as [`Scanpath::at`]: Lee et al.'s idle fixations joined by saccades on
/// the main sequence) and the lids' closure in [0, 1] (table 3.1's blinks at `activity`, a
/// blink of `full_amplitude` ° closing the eye).
pub fn idle_track(
    seconds: f32,
    fps: f32,
    activity: Activity,
    seed: u64,
    full_amplitude: f32,
) -> Vec<[f32; 3]> {
    let path = Scanpath::new(idle::schedule(seconds, seed));
    let blinks = blink::schedule(seconds, activity, seed);
    let n = (seconds * fps).round().max(1.0) as usize;
    let mut next = 0;
    (0..n)
        .map(|i| {
            let t = i as f32 / fps;
            // Blinks are in order and never overlap: only those that may be under way count.
            while next < blinks.len()
                && blinks[next].start + blinks[next].down + blinks[next].up < t
            {
                next += 1;
            }
            let closure = blinks[next..]
                .iter()
                .take_while(|b| b.start <= t)
                .map(|b| b.closure(t, full_amplitude))
                .fold(0.0f32, f32::max);
            let g = path.at(t);
            [g.h, g.v, closure]
        })
        .collect()
}

/// The frames of a drive for `model` with globe centres `centres` (head space) and radius.
pub fn timeline(model: &EyeModel, centres: [Vec3; 2], radius: f32, d: &Drive) -> Vec<Sample> {
    let fix = d
        .fixations
        .clone()
        .unwrap_or_else(|| idle::schedule(d.seconds, d.seed));
    let blinks = d
        .blinks
        .clone()
        .unwrap_or_else(|| blink::schedule(d.seconds, d.activity, d.seed));
    let full = full_blink_amplitude(model, centres[0].y, radius);
    let mid = 0.5 * (centres[0] + centres[1]);
    let path = Scanpath::new(fix);
    let n = (d.seconds * d.fps).round().max(1.0) as usize;
    (0..n)
        .map(|i| {
            let t = i as f32 / d.fps;
            let cyc = path.at(t);
            let target = mid + d.distance * cyc.direction();
            let eyes = verge(centres, target);
            let closure = blinks
                .iter()
                .map(|bl| bl.closure(t, full))
                .fold(0.0f32, f32::max);
            let lids =
                [0, 1].map(|e| model.baseline_aperture(e, eyes[e].h, eyes[e].v, 1.0 - closure));
            Sample {
                t,
                gaze: Gaze {
                    eyes,
                    lids,
                    units: vec![0.0; model.units.len()],
                },
                closure,
                cyclopean: cyc,
            }
        })
        .collect()
}

/// Fixations from a gaze-tracker CSV with a header naming `time` (s), `h` and `v` (°, Fick,
/// positive towards the head's left and up); consecutive rows more than 1° apart start a new
/// fixation.
pub fn read_tracker(path: &Path) -> Result<Vec<Fixation>> {
    let bad = |detail: String| EyesError::Tracked {
        path: path.to_path_buf(),
        detail,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let head: Vec<String> = lines
        .next()
        .ok_or_else(|| bad("empty file".into()))?
        .split(',')
        .map(|s| s.trim().to_ascii_lowercase())
        .collect();
    let col = |n: &str| {
        head.iter()
            .position(|h| h == n)
            .ok_or_else(|| bad(format!("no column '{n}' (expected time, h, v)")))
    };
    let (ct, ch, cv) = (col("time")?, col("h")?, col("v")?);
    let mut out: Vec<Fixation> = Vec::new();
    for (r, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let num = |c: usize, name: &str| -> Result<f32> {
            cells
                .get(c)
                .and_then(|s| s.parse::<f32>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("row {}: '{name}' is not a number", r + 2)))
        };
        let (t, h, v) = (num(ct, "time")?, num(ch, "h")?, num(cv, "v")?);
        if h.abs() > 60.0 || v.abs() > 60.0 {
            return Err(bad(format!("row {}: gaze ({h}°, {v}°) beyond ±60°", r + 2)));
        }
        if let Some(last) = out.last() {
            if t < last.start {
                return Err(bad(format!("row {}: time {t} s goes backwards", r + 2)));
            }
        }
        let g = Fick { h, v, t: 0.0 };
        if out.last().is_none_or(|l| l.gaze.amplitude_to(g) > 1.0) {
            out.push(Fixation {
                start: t,
                gaze: g,
                mutual: false,
            });
        }
    }
    if out.is_empty() {
        return Err(bad("no rows".into()));
    }
    Ok(out)
}

/// Fixations on the `n` most salient points of an image the character looks at, spanning
/// `fov` degrees horizontally in front of it; one every ~0.8 s (exponential intervals).
pub fn salient_fixations(
    rgb: &[derma_core::Map; 3],
    n: usize,
    fov: f32,
    seconds: f32,
    seed: u64,
) -> Vec<Fixation> {
    let s = crate::saliency::saliency(rgb);
    let pts = crate::saliency::targets(&s, n, 0.08);
    let aspect = rgb[0].height() as f32 / rgb[0].width() as f32;
    let rng = derma_core::rng::Philox::new(seed, 0x5A11);
    let mut out = vec![];
    let mut t = 0.0f32;
    let mut k = 0usize;
    while t < seconds && !pts.is_empty() {
        let p = pts[k % pts.len()];
        // The image faces the character: its right (x → 1) is the character's right (−X).
        out.push(Fixation {
            start: t,
            gaze: Fick {
                h: -(p.x - 0.5) * fov,
                v: -(p.y - 0.5) * fov * aspect,
                t: 0.0,
            },
            mutual: false,
        });
        t += -idle::AWAY_S * (1.0 - rng.uniform4(k as u64, 0)[0]).ln() + 0.15;
        k += 1;
    }
    out
}

#[cfg(test)]
mod idle_track_tests {
    use super::*;

    #[test]
    fn the_idle_track_blinks_at_the_tables_rate_over_200_blinks() {
        // 900 s at rest (17 blinks a minute, Bentivoglio et al. 1997).
        let track = idle_track(900.0, 60.0, Activity::Rest, 3, 40.0);
        let onsets: Vec<f32> = track
            .windows(2)
            .enumerate()
            .filter(|(_, w)| w[0][2] < 0.3 && w[1][2] >= 0.3)
            .map(|(i, _)| i as f32 / 60.0)
            .collect();
        assert!(onsets.len() >= 200, "{} blinks", onsets.len());
        let mean = (onsets[onsets.len() - 1] - onsets[0]) / (onsets.len() - 1) as f32;
        let table = 60.0 / 17.0;
        println!(
            "{} blinks, mean interval {mean:.2} s (table {table:.2} s)",
            onsets.len()
        );
        assert!(
            (mean / table - 1.0).abs() <= 0.15,
            "mean interval {mean} s against {table}"
        );
        // Gaze moves (saccades) and stays within the idle model's reach.
        assert!(track
            .iter()
            .all(|f| f[0].abs() <= 30.0 && f[1].abs() <= 30.0));
        assert!(
            track
                .windows(2)
                .filter(|w| (w[1][0] - w[0][0]).abs() > 0.5)
                .count()
                > 100
        );
    }
}
