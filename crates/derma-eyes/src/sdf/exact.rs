//! The exact Euclidean distance transform in linear time (Felzenszwalb & Huttenlocher 2012,
//! "Distance Transforms of Sampled Functions", Theory of Computing 8:415): the squared distance
//! as the lower envelope of parabolas, one dimension at a time, rows and columns in parallel.

use super::{material, Field, GBuffer};
use rayon::prelude::*;

/// One-dimensional squared-distance transform of `f` (f = 0 at sites, ∞ elsewhere) into `d`,
/// with the scratch `v` (parabola vertices) and `z` (envelope boundaries).
fn dt1(f: &[f32], d: &mut [f32], v: &mut [usize], z: &mut [f32]) {
    let n = f.len();
    let mut k = 0usize;
    // Skip leading infinite samples: the envelope starts at the first finite one.
    let Some(first) = f.iter().position(|x| x.is_finite()) else {
        d.iter_mut().for_each(|x| *x = f32::INFINITY);
        return;
    };
    v[0] = first;
    z[0] = f32::NEG_INFINITY;
    z[1] = f32::INFINITY;
    for q in first + 1..n {
        if !f[q].is_finite() {
            continue;
        }
        loop {
            let p = v[k];
            let s =
                ((f[q] + (q * q) as f32) - (f[p] + (p * p) as f32)) / (2.0 * (q as f32 - p as f32));
            if s <= z[k] && k > 0 {
                k -= 1;
            } else {
                if s <= z[k] {
                    // k == 0 and the new parabola dominates everywhere.
                    v[0] = q;
                    z[1] = f32::INFINITY;
                } else {
                    k += 1;
                    v[k] = q;
                    z[k] = s;
                    z[k + 1] = f32::INFINITY;
                }
                break;
            }
        }
    }
    let mut k = 0usize;
    for q in 0..n {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let p = v[k];
        let dq = q as f32 - p as f32;
        d[q] = dq * dq + f[p];
    }
}

/// Columns per block of the column pass: a block's column data (h × 16 floats) stays in cache
/// while its rows are read and written 64 bytes at a time.
const BLOCK: usize = 16;

/// Squared pixel distance to the nearest site (`sites[i]` true) for every pixel: rows first by
/// two linear scans (the 1D distance to binary sites), then columns by the parabola envelope
/// over the rows' squared distances, in blocks of [`BLOCK`] columns.
pub fn squared_edt(sites: &[bool], w: usize, h: usize) -> Vec<f32> {
    let mut g = vec![0.0f32; w * h];
    g.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let s = &sites[y * w..(y + 1) * w];
        let mut last: Option<usize> = None;
        for x in 0..w {
            if s[x] {
                last = Some(x);
            }
            row[x] = last.map_or(f32::INFINITY, |l| ((x - l) * (x - l)) as f32);
        }
        let mut next: Option<usize> = None;
        for x in (0..w).rev() {
            if s[x] {
                next = Some(x);
            }
            if let Some(n) = next {
                row[x] = row[x].min(((n - x) * (n - x)) as f32);
            }
        }
    });
    let mut out = vec![0.0f32; w * h];
    let blocks: Vec<usize> = (0..w.div_ceil(BLOCK)).collect();
    let cols: Vec<Vec<f32>> = blocks
        .par_iter()
        .map_init(
            || {
                (
                    vec![0.0f32; h],
                    vec![0.0f32; h],
                    vec![0usize; h],
                    vec![0.0f32; h + 1],
                )
            },
            |(f, d, v, z), &b| {
                let x0 = b * BLOCK;
                let bw = BLOCK.min(w - x0);
                let mut local = vec![0.0f32; h * bw];
                for c in 0..bw {
                    for y in 0..h {
                        f[y] = g[y * w + x0 + c];
                    }
                    dt1(f, d, v, z);
                    for y in 0..h {
                        local[y * bw + c] = d[y];
                    }
                }
                local
            },
        )
        .collect();
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (b, local) in cols.iter().enumerate() {
            let x0 = b * BLOCK;
            let bw = BLOCK.min(w - x0);
            row[x0..x0 + bw].copy_from_slice(&local[y * bw..(y + 1) * bw]);
        }
    });
    out
}

/// The exact field: λ = (pixel distance to the nearest skin) × z / f on every globe pixel.
pub fn field(g: &GBuffer) -> Field {
    let sites: Vec<bool> = g.mask.iter().map(|&m| m == material::SKIN).collect();
    let d2 = squared_edt(&sites, g.width, g.height);
    let distance = d2
        .par_iter()
        .enumerate()
        .map(|(i, &d)| {
            if g.mask[i] == material::EYE {
                d.sqrt() / g.px_per_mm(i)
            } else {
                f32::INFINITY
            }
        })
        .collect();
    // Per texel: the mask once, the column pass's result once, the depth once.
    Field {
        distance,
        accesses: vec![3; g.width * g.height],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_brute_force_on_random_sites() {
        let (w, h) = (37, 23);
        let sites: Vec<bool> = (0..w * h)
            .map(|i| super::super::hash01(i as u32, 7, 3) < 0.03)
            .collect();
        let d = squared_edt(&sites, w, h);
        for y in 0..h {
            for x in 0..w {
                let mut best = f32::INFINITY;
                for j in 0..w * h {
                    if sites[j] {
                        let (dx, dy) = ((j % w) as f32 - x as f32, (j / w) as f32 - y as f32);
                        best = best.min(dx * dx + dy * dy);
                    }
                }
                assert_eq!(d[y * w + x], best, "({x}, {y})");
            }
        }
    }
}
