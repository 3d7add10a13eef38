//! Jump flooding (Rong & Tan 2006, "Jump flooding in GPU with applications to Voronoi diagram and
//! distance transform"): every pixel keeps the nearest skin pixel seen so far and looks at its
//! eight neighbours at offsets k = N/2, N/4, …, 1, then once more at 1 ("JFA+1", which removes
//! most of its rare errors). log₂ N passes, each a gather the GPU runs in parallel.

use super::{material, Field, GBuffer};
use rayon::prelude::*;

const NONE: u32 = u32::MAX;

/// Nearest-seed indices after jump flooding.
pub fn flood(g: &GBuffer) -> Vec<u32> {
    let (w, h) = (g.width, g.height);
    let mut cur: Vec<u32> = (0..w * h)
        .map(|i| {
            if g.mask[i] == material::SKIN {
                i as u32
            } else {
                NONE
            }
        })
        .collect();
    let mut next = cur.clone();
    let mut steps = Vec::new();
    let mut k = w.max(h).next_power_of_two() / 2;
    while k >= 1 {
        steps.push(k);
        k /= 2;
    }
    steps.push(1);
    for &k in &steps {
        let k = k as i32;
        next.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                let mut best = cur[y * w + x];
                let mut bd = dist2(best, x, y, w);
                for dy in [-k, 0, k] {
                    for dx in [-k, 0, k] {
                        let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                        if nx < 0 || ny < 0 || nx >= w as i32 || ny >= h as i32 {
                            continue;
                        }
                        let s = cur[ny as usize * w + nx as usize];
                        let d = dist2(s, x, y, w);
                        if d < bd {
                            bd = d;
                            best = s;
                        }
                    }
                }
                *out = best;
            }
        });
        std::mem::swap(&mut cur, &mut next);
    }
    cur
}

#[inline]
fn dist2(s: u32, x: usize, y: usize, w: usize) -> u64 {
    if s == NONE {
        return u64::MAX;
    }
    let (sx, sy) = ((s as usize % w) as i64, (s as usize / w) as i64);
    let (dx, dy) = (sx - x as i64, sy - y as i64);
    (dx * dx + dy * dy) as u64
}

/// The jump-flooding field on the globe pixels.
pub fn field(g: &GBuffer) -> Field {
    let seeds = flood(g);
    let w = g.width;
    let passes = g.width.max(g.height).next_power_of_two().trailing_zeros() + 1;
    let distance = (0..w * g.height)
        .into_par_iter()
        .map(|i| {
            if g.mask[i] != material::EYE || seeds[i] == NONE {
                return f32::INFINITY;
            }
            (dist2(seeds[i], i % w, i / w, w) as f32).sqrt() / g.px_per_mm(i)
        })
        .collect();
    // Per texel: nine seed fetches per pass, the mask and the depth.
    Field {
        distance,
        accesses: vec![9 * passes + 2; g.width * g.height],
    }
}
