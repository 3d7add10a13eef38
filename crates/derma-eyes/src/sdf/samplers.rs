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
    /// to `steps` samples. `refine`: derma's pruning, pixel-resolution stop and two levels of
    /// angular refinement around the best direction.
    Backtracking {
        /// Directions.
        n: u32,
        /// Bisection steps per direction at most.
        steps: u32,
        /// derma's refinements.
        refine: bool,
    },
}

impl Sampler {
    /// A short name for tables.
    pub fn name(&self) -> String {
        match *self {
            Sampler::Equiangular { n } => format!("equiangular {n}"),
            Sampler::Exponential { steps } => format!("exponential {steps}x{steps}"),
            Sampler::Backtracking { n, steps, refine } => {
                format!(
                    "backtracking {n}x{steps}{}",
                    if refine { " refined" } else { "" }
                )
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
    refine: bool,
    best: f32,
) -> f32 {
    let half_px = 0.5 / p.ppm;
    for _ in 0..steps {
        if refine && (hi - lo < half_px || lo >= best) {
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

fn backtracking(p: &mut Px, range: f32, n: u32, steps: u32, refine: bool, rot: f32) -> f32 {
    let mut best = f32::INFINITY;
    let mut best_angle = 0.0;
    for i in 0..n {
        let a = TAU * (i as f32 + rot) / n as f32;
        let dir = unit(a);
        if !p.skin_at(dir, range) {
            continue;
        }
        let d = bisect(p, dir, 0.0, range, steps, refine, best);
        if d < best {
            best = d;
            best_angle = a;
        }
    }
    if refine && best.is_finite() {
        // Two levels of angular refinement: ±¼ and ±⅛ of the direction spacing.
        let mut spacing = TAU / n as f32;
        for _ in 0..2 {
            spacing *= 0.5;
            let centre = best_angle;
            for s in [-0.5f32, 0.5] {
                let a = centre + s * spacing;
                let dir = unit(a);
                // The current best distance bounds the search: skin there or no improvement.
                if !p.skin_at(dir, best) {
                    continue;
                }
                let d = bisect(p, dir, 0.0, best, steps, refine, best);
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
            best = best.min(d);
        }
    }
    best
}

/// Exponential line search along `dir` (§4.4.2) on a metric: `probe(d)` fetches and returns the
/// metric at distance d. Steps grow by µ = 2 from h₀ (so `steps` growing steps reach Λ) until
/// the metric stops improving, then reverse with shrinking steps.
fn exp_search(range: f32, steps: u32, mut probe: impl FnMut(f32) -> f32) -> f32 {
    let mu = 2.0f32;
    let h0 = range * (mu - 1.0) / (mu.powi(steps as i32) - 1.0);
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
    let h0 = range * (mu - 1.0) / (mu.powi(steps as i32) - 1.0);
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
            let (distance, acc): (Vec<f32>, Vec<u64>) = (0..w * g.height)
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
                    (d, p.accesses as u64)
                })
                .unzip();
            Field {
                pixels: g.mask.iter().filter(|&&m| m == material::EYE).count() as u64,
                accesses: acc.iter().sum(),
                distance,
            }
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
    // Pass 1: along the rotated axis, both ways; metric = distance where the mask is skin.
    let pass1: Vec<(f32, u64)> = (0..w * g.height)
        .into_par_iter()
        .map(|i| {
            if g.mask[i] != material::EYE {
                return (f32::INFINITY, 0);
            }
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let a = TAU * hash01(x, y, ROTATION_SALT);
            let ppm = g.px_per_mm(i);
            let mut acc = 1u64;
            let mut best = f32::INFINITY;
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
                best = best.min(d);
            }
            (best, acc)
        })
        .collect();
    // Pass 2: perpendicular, on λᵢ = sqrt(|sᵢ − x|² + λ̃(sᵢ)²) (eq. 4.13).
    let (distance, acc2): (Vec<f32>, Vec<u64>) = (0..w * g.height)
        .into_par_iter()
        .map(|i| {
            if g.mask[i] != material::EYE {
                return (f32::INFINITY, 0);
            }
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let a = TAU * hash01(x, y, ROTATION_SALT) + std::f32::consts::FRAC_PI_2;
            let ppm = g.px_per_mm(i);
            let mut acc = 0u64;
            let mut best = pass1[i].0;
            for sgn in [1.0f32, -1.0] {
                let dir = (sgn * a.cos(), sgn * a.sin());
                let d = exp_search(range, steps, |t| {
                    acc += 2; // mask and λ̃
                    match idx(
                        x as f32 + 0.5 + dir.0 * t * ppm,
                        y as f32 + 0.5 + dir.1 * t * ppm,
                    ) {
                        Some(j) if g.mask[j] == material::SKIN => t,
                        Some(j) if g.mask[j] == material::EYE && pass1[j].0.is_finite() => {
                            (t * t + pass1[j].0 * pass1[j].0).sqrt()
                        }
                        _ => f32::INFINITY,
                    }
                });
                best = best.min(d);
            }
            (best, acc + pass1[i].1)
        })
        .unzip();
    Field {
        pixels: g.mask.iter().filter(|&&m| m == material::EYE).count() as u64,
        accesses: acc2.iter().sum(),
        distance,
    }
}
