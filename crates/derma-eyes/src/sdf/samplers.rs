//! The thesis' three screen-space samplers (§4.4), per pixel of the globes: equiangular sampling
//! on a circle with per-pixel rotation (§4.4.1), the two-pass exponential line search (§4.4.2)
//! and the backtracking (bisection) line search (§4.4.3) — the last with derma's refinements:
//! bisection stops at pixel resolution, directions that cannot beat the current best are pruned,
//! and the best direction is refined angularly.

use super::{hash01, material, Field, GBuffer};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f32::consts::TAU;

/// A sampler and its settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Sampler {
    /// §4.4.1: `n` directions, one sample each at a random distance in (0, Λ].
    Equiangular {
        /// Directions (= samples).
        n: u32,
    },
    /// §4.4.2: exponential line search with `steps` samples per direction, along a randomly
    /// rotated axis (pass 1), then perpendicular on the combined metric of eq. 4.13 (pass 2).
    Exponential {
        /// Samples per direction.
        steps: u32,
    },
    /// §4.4.3: `n` directions; a direction whose far end (distance Λ) is skin is bisected for up
    /// to `steps` samples. `refine` > 0: derma's pruning, pixel-resolution stop and that many
    /// levels of angular refinement around the best direction (0: the thesis' search).
    Backtracking {
        /// Directions.
        n: u32,
        /// Bisection steps per direction at most.
        steps: u32,
        /// Levels of angular refinement (0: none, and no pruning or early stop).
        refine: u32,
    },
}

impl Sampler {
    /// A short name for tables.
    pub fn name(&self) -> String {
        match *self {
            Sampler::Equiangular { n } => format!("equiangular {n}"),
            Sampler::Exponential { steps } => format!("exponential {steps}x{steps}"),
            Sampler::Backtracking { n, steps, refine } => {
                if refine > 0 {
                    format!("backtracking {n}x{steps}, {refine} refinements")
                } else {
                    format!("backtracking {n}x{steps}")
                }
            }
        }
    }
}

/// Salt of the per-pixel rotation (the same on every pass and device).
const ROTATION_SALT: u32 = 0x51;

/// One pixel's sample context.
struct Px<'a> {
    g: &'a GBuffer,
    x: f32,
    y: f32,
    ppm: f32,
    accesses: u32,
}

impl Px<'_> {
    /// Is the texel at distance `d` (mm, in Ψ) along `dir` skin? One mask fetch.
    fn skin_at(&mut self, dir: (f32, f32), d: f32) -> bool {
        self.accesses += 1;
        let sx = (self.x + dir.0 * d * self.ppm).floor() as i32;
        let sy = (self.y + dir.1 * d * self.ppm).floor() as i32;
        self.g.skin(sx, sy)
    }
}

impl Px<'_> {
    /// Distance (mm in Ψ) from the pixel's centre to the centre of the texel at distance `d`
    /// along `dir`: the skin point a search ends on is that texel, and the distance between
    /// texel centres is what the exact transform measures (no access: the texel is known).
    fn centre_distance(&self, dir: (f32, f32), d: f32) -> f32 {
        let sx = (self.x + dir.0 * d * self.ppm).floor() + 0.5;
        let sy = (self.y + dir.1 * d * self.ppm).floor() + 0.5;
        let (dx, dy) = (sx - self.x, sy - self.y);
        (dx * dx + dy * dy).sqrt() / self.ppm
    }
}

fn unit(a: f32) -> (f32, f32) {
    (a.cos(), a.sin())
}

/// Backtracking along one direction between distances `lo` (not skin) and `hi` (skin):
/// bisection, at most `steps` samples, stopping below half a pixel when `refine`.
fn bisect(
    p: &mut Px,
    dir: (f32, f32),
    mut lo: f32,
    mut hi: f32,
    steps: u32,
    refine: u32,
    best: f32,
) -> f32 {
    let half_px = 0.5 / p.ppm;
    for _ in 0..steps {
        if refine > 0 && (hi - lo < half_px || lo >= best) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if p.skin_at(dir, mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

fn backtracking(p: &mut Px, range: f32, n: u32, steps: u32, refine: u32, rot: f32) -> f32 {
    let mut best = f32::INFINITY;
    let mut best_angle = 0.0;
    // With refinement, the far end reaches Λ / cos(π / n): a texel within Λ of a straight margin
    // then always has a direction within half the spacing of the perpendicular that hits it.
    let reach = if refine > 0 {
        range / (std::f32::consts::PI / n as f32).cos()
    } else {
        range
    };
    for i in 0..n {
        let a = TAU * (i as f32 + rot) / n as f32;
        let dir = unit(a);
        if !p.skin_at(dir, reach) {
            continue;
        }
        let d = bisect(p, dir, 0.0, reach, steps, refine, best);
        let d = p.centre_distance(dir, d);
        if d < best {
            best = d;
            best_angle = a;
        }
    }
    if refine > 0 && best.is_finite() {
        // Angular refinement: ±¼, ±⅛, … of the direction spacing around the best direction.
        let mut spacing = TAU / n as f32;
        for _ in 0..refine {
            spacing *= 0.5;
            let centre = best_angle;
            for s in [-0.5f32, 0.5] {
                let a = centre + s * spacing;
                let dir = unit(a);
                // The current best distance bounds the search: skin there or no improvement.
                if !p.skin_at(dir, best) {
                    continue;
                }
                // Below best · cos(spacing) a locally straight lid margin has no skin on this
                // direction (the best direction is within the spacing of the perpendicular):
                // bisect from there, after checking that it is indeed free.
                let floor = best * spacing.cos();
                let d = if p.skin_at(dir, floor) {
                    bisect(p, dir, 0.0, floor, steps, refine, best)
                } else {
                    bisect(p, dir, floor, best, steps, refine, best)
                };
                let d = p.centre_distance(dir, d);
                if d < best {
                    best = d;
                    best_angle = a;
                }
            }
        }
    }
    best
}

fn equiangular(p: &mut Px, range: f32, n: u32, rot: f32, px: (u32, u32)) -> f32 {
    let mut best = f32::INFINITY;
    for i in 0..n {
        let dir = unit(TAU * (i as f32 + rot) / n as f32);
        // Uniform distance in (0, Λ].
        let d = range * (1.0 - hash01(px.0, px.1, 0x100 + i));
        if p.skin_at(dir, d) {
            best = best.min(p.centre_distance(dir, d));
        }
    }
    best
}

/// Exponential line search along `dir` (§4.4.2) on a metric: `probe(d)` fetches and returns the
/// metric at distance d. Steps grow by µ = 2 from h₀ (half the steps reach Λ) until
/// the metric stops improving, then reverse with shrinking steps.
fn exp_search(range: f32, steps: u32, mut probe: impl FnMut(f32) -> f32) -> f32 {
    let mu = 2.0f32;
    let h0 = range * (mu - 1.0) / (mu.powi(steps.div_ceil(2) as i32) - 1.0);
    let mut best = f32::INFINITY;
    let mut pos = 0.0f32;
    let mut step = h0;
    let mut growing = true;
    let mut dir = 1.0f32;
    let mut last = f32::INFINITY;
    for _ in 0..steps {
        pos = (pos + dir * step).clamp(0.0, range);
        let m = probe(pos);
        if m < best {
            best = m;
        }
        if growing {
            if m.is_finite() && m > last {
                growing = false;
                dir = -dir;
                step /= mu;
            } else if m.is_finite() && m == 0.0 {
                growing = false;
                dir = -1.0;
                step /= mu;
            } else {
                step *= mu;
            }
        } else {
            step /= mu;
            if m > last || m == 0.0 {
                dir = -dir;
            }
        }
        last = m;
    }
    best
}

/// Pass 1 of §4.4.2 (eqs. 4.8–4.12): growing steps until a skin sample, then shrinking steps
/// that turn back whenever the sample's material changes; the nearest skin sample seen.
fn exp_boundary(range: f32, steps: u32, mut skin: impl FnMut(f32) -> bool) -> f32 {
    let mu = 2.0f32;
    // The growing steps reach Λ in half the budget, leaving the other half to refine.
    let h0 = range * (mu - 1.0) / (mu.powi(steps.div_ceil(2) as i32) - 1.0);
    let (mut pos, mut step, mut found, mut dir) = (0.0f32, h0, false, 1.0f32);
    let mut best = f32::INFINITY;
    for _ in 0..steps {
        if !found {
            pos += step;
            if pos > range * 1.0001 {
                break;
            }
            if skin(pos) {
                found = true;
                best = pos;
                dir = -1.0;
            } else {
                step *= mu;
                continue;
            }
        } else {
            pos += dir * step;
            if skin(pos) {
                best = best.min(pos);
                dir = -1.0;
            } else {
                dir = 1.0;
            }
        }
        step /= mu;
    }
    best
}

/// Computes a field with `s` on every globe pixel; `range` is Λ (mm).
pub fn field(g: &GBuffer, s: Sampler, range: f32) -> Field {
    let w = g.width;
    match s {
        Sampler::Exponential { steps } => exponential(g, steps, range),
        _ => {
            let (distance, accesses): (Vec<f32>, Vec<u32>) = (0..w * g.height)
                .into_par_iter()
                .map(|i| {
                    if g.mask[i] != material::EYE {
                        return (f32::INFINITY, 0);
                    }
                    let (x, y) = ((i % w) as u32, (i / w) as u32);
                    let rot = hash01(x, y, ROTATION_SALT);
                    let mut p = Px {
                        g,
                        x: x as f32 + 0.5,
                        y: y as f32 + 0.5,
                        ppm: g.px_per_mm(i),
                        accesses: 1, // the pixel's own depth
                    };
                    let d = match s {
                        Sampler::Equiangular { n } => equiangular(&mut p, range, n, rot, (x, y)),
                        Sampler::Backtracking { n, steps, refine } => {
                            backtracking(&mut p, range, n, steps, refine, rot)
                        }
                        Sampler::Exponential { .. } => unreachable!(),
                    };
                    (d, p.accesses)
                })
                .unzip();
            Field { distance, accesses }
        }
    }
}

fn exponential(g: &GBuffer, steps: u32, range: f32) -> Field {
    let w = g.width;
    let idx = |x: f32, y: f32| -> Option<usize> {
        let (sx, sy) = (x.floor() as i32, y.floor() as i32);
        (sx >= 0 && sy >= 0 && (sx as usize) < w && (sy as usize) < g.height)
            .then(|| sy as usize * w + sx as usize)
    };
    // Pass 1: along the pixel's rotated axis, both ways. derma stores the offset (px) to the
    // skin point found, not only its distance λ̃: with per-pixel rotations the axes of
    // neighbouring pixels differ, and eq. 4.13's right angle would not hold.
    let pass1: Vec<(f32, f32, u64)> = (0..w * g.height)
        .into_par_iter()
        .map(|i| {
            if g.mask[i] != material::EYE {
                return (f32::INFINITY, f32::INFINITY, 0);
            }
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let a = TAU * hash01(x, y, ROTATION_SALT);
            let ppm = g.px_per_mm(i);
            let mut acc = 1u64;
            let mut best = (f32::INFINITY, f32::INFINITY);
            let mut best_d = f32::INFINITY;
            for sgn in [1.0f32, -1.0] {
                let dir = (sgn * a.cos(), sgn * a.sin());
                let d = exp_boundary(range, steps, |d| {
                    acc += 1;
                    idx(
                        x as f32 + 0.5 + dir.0 * d * ppm,
                        y as f32 + 0.5 + dir.1 * d * ppm,
                    )
                    .is_some_and(|j| g.mask[j] == material::SKIN)
                });
                if d.is_finite() {
                    // Offset to the centre of the skin texel found.
                    let cx = (x as f32 + 0.5 + dir.0 * d * ppm).floor() + 0.5 - (x as f32 + 0.5);
                    let cy = (y as f32 + 0.5 + dir.1 * d * ppm).floor() + 0.5 - (y as f32 + 0.5);
                    let dc = (cx * cx + cy * cy).sqrt() / ppm;
                    if dc < best_d {
                        best_d = dc;
                        best = (cx, cy);
                    }
                }
            }
            (best.0, best.1, acc)
        })
        .collect();
    // Pass 2: perpendicular, minimising the distance to the skin points pass 1 found at the
    // samples (eq. 4.13 with the stored offsets).
    let (distance, accesses): (Vec<f32>, Vec<u32>) = (0..w * g.height)
        .into_par_iter()
        .map(|i| {
            if g.mask[i] != material::EYE {
                return (f32::INFINITY, 0);
            }
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let a = TAU * hash01(x, y, ROTATION_SALT) + std::f32::consts::FRAC_PI_2;
            let ppm = g.px_per_mm(i);
            let mut acc = 0u64;
            let own = pass1[i];
            let mut best = (own.0 * own.0 + own.1 * own.1).sqrt() / ppm;
            for sgn in [1.0f32, -1.0] {
                let dir = (sgn * a.cos(), sgn * a.sin());
                let d = exp_search(range, steps, |t| {
                    acc += 2; // mask and the stored offset
                    let (ox, oy) = (dir.0 * t * ppm, dir.1 * t * ppm);
                    let j = idx(x as f32 + 0.5 + ox, y as f32 + 0.5 + oy);
                    // Offsets between texel centres.
                    let (cx, cy) = (
                        (x as f32 + 0.5 + ox).floor() - x as f32,
                        (y as f32 + 0.5 + oy).floor() - y as f32,
                    );
                    match j {
                        Some(j) if g.mask[j] == material::SKIN => (cx * cx + cy * cy).sqrt() / ppm,
                        Some(j) if g.mask[j] == material::EYE && pass1[j].0.is_finite() => {
                            let (ex, ey) = (cx + pass1[j].0, cy + pass1[j].1);
                            (ex * ex + ey * ey).sqrt() / ppm
                        }
                        _ => f32::INFINITY,
                    }
                });
                best = best.min(d);
            }
            (best, (acc + pass1[i].2) as u32)
        })
        .unzip();
    Field { distance, accesses }
}
