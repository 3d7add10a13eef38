//! The E-step of an optimisation pass (Shen et al. §3.3, after Kwatra et al. 2005 §3), on the CPU:
//! the covering windows' low bands blended, the best-matching one's high band (see [`crate::optimize`]).

use crate::canvas::{Canvas, NO_SOURCE};
use crate::exemplar::ExemplarSet;
use rayon::prelude::*;

/// What the E-step works from: the windows (origins along each axis, row-major), where each
/// window's best match lies (exemplar, x, y), its cost (the integer distance to it) and its
/// weight in the low band's mean.
pub(crate) struct Windows {
    pub w: usize,
    pub xs: Vec<usize>,
    pub ys: Vec<usize>,
    pub placed: Vec<(usize, usize, usize)>,
    pub costs: Vec<u32>,
    pub weights: Vec<f32>,
}

/// Which windows of side `w` at `origins` cover each of the `len` positions of an axis, with
/// the offset into the window, in the order of the windows.
pub(crate) fn cover(len: usize, origins: &[usize], w: usize, tile: bool) -> Vec<Vec<(u32, u32)>> {
    let mut v = vec![Vec::new(); len];
    for (k, &o) in origins.iter().enumerate() {
        for d in 0..w {
            let p = if tile { (o + d) % len } else { o + d };
            v[p].push((k as u32, d as u32));
        }
    }
    v
}

/// The E-step on the CPU, texel by texel in a fixed order of windows (the same sums on any
/// thread count; `e_step.wgsl` reproduces them bit for bit): each texel becomes the weighted
/// mean of its covering windows' low bands plus the high band of the one with the least cost,
/// the first in order among equals, whose exemplar texel becomes its source. `bands` holds
/// (low, high) per exemplar ([`crate::bands`]).
pub(crate) fn e_step(
    canvas: &mut Canvas,
    set: &ExemplarSet,
    b: &Windows,
    bands: &[(Vec<f32>, Vec<f32>)],
) {
    let c = canvas.channels;
    let cover_x = cover(canvas.width, &b.xs, b.w, canvas.tile);
    let cover_y = cover(canvas.height, &b.ys, b.w, canvas.tile);
    let nwx = b.xs.len();
    let width = canvas.width;
    // One output row: its values and, per texel, (source exemplar, source texel).
    type Sources = Vec<(u8, u32)>;
    type Row = (Vec<f32>, Sources);
    let (values, srcs): (Vec<Vec<f32>>, Vec<Sources>) = (0..canvas.height)
        .into_par_iter()
        .map(|y| {
            let mut row = vec![0f32; width * c];
            let mut src_row = vec![(0u8, NO_SOURCE); width];
            let mut acc = vec![0f64; c];
            // The windows covering a texel, in order: (window, exemplar, its texel there).
            let mut covering: Vec<(usize, usize, usize)> = Vec::new();
            for x in 0..width {
                covering.clear();
                for &(jy, oy) in &cover_y[y] {
                    for &(ix, ox) in &cover_x[x] {
                        let k = jy as usize * nwx + ix as usize;
                        let (ex, mx, my) = b.placed[k];
                        let s = (my + oy as usize) * set.exemplars[ex].width() + mx + ox as usize;
                        covering.push((k, ex, s));
                    }
                }
                // The chosen window: the least cost, the first in order among equals.
                let &(_, ex, s) = covering
                    .iter()
                    .min_by_key(|w| b.costs[w.0])
                    .expect("every texel is covered");
                let wsum: f64 = covering.iter().map(|w| b.weights[w.0] as f64).sum();
                let high = &bands[ex].1[s * c..(s + 1) * c];
                // Σ ω (L + H) / Σ ω, each product exact in f64 (e_step.wgsl sums the same terms
                // in the same order).
                acc.iter_mut().for_each(|a| *a = 0.0);
                for &(k, wex, ws) in &covering {
                    let wk = b.weights[k] as f64;
                    let low = &bands[wex].0[ws * c..(ws + 1) * c];
                    for ((a, &l), &h) in acc.iter_mut().zip(low).zip(high) {
                        *a += wk * l as f64;
                        *a += wk * h as f64;
                    }
                }
                for k in 0..c {
                    row[x * c + k] = (acc[k] / wsum) as f32;
                }
                src_row[x] = (ex as u8, s as u32);
            }
            (row, src_row)
        })
        .collect::<Vec<Row>>()
        .into_iter()
        .unzip();
    for (y, (row, src_row)) in values.into_iter().zip(srcs).enumerate() {
        canvas.values[y * width * c..(y + 1) * width * c].copy_from_slice(&row);
        for (x, (ex, s)) in src_row.into_iter().enumerate() {
            canvas.src_exemplar[y * width + x] = ex;
            canvas.src[y * width + x] = s;
        }
    }
    let q = &set.quantizer;
    canvas
        .codes
        .par_chunks_mut(c)
        .zip(canvas.values.par_chunks(c))
        .for_each(|(code, v)| {
            for k in 0..c {
                code[k] = q.quantize(k, v[k]);
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Texture;
    use derma_core::rng::Philox;

    #[test]
    fn low_bands_are_blended_and_the_least_cost_window_gives_the_grain_and_source() {
        // Two exemplars of different sizes, windows matched in either.
        let rng = Philox::new(5, 2);
        let c = 2;
        let sizes = [(12, 12), (15, 13)];
        let textures = sizes
            .iter()
            .enumerate()
            .map(|(e, &(ew, eh))| {
                let data = (0..ew * eh * c)
                    .map(|i| rng.uniform4(i as u64, e as u32)[0])
                    .collect();
                Texture::new(ew, eh, c, data).unwrap()
            })
            .collect();
        let set = ExemplarSet::new(textures, 4).unwrap();
        let (w, side) = (4, 10);
        let origins = [0, 2, 4, 6];
        let n = origins.len() * origins.len();
        let placed: Vec<(usize, usize, usize)> = (0..n)
            .map(|k| {
                let r = rng.u32x4(100 + k as u64);
                let ex = r[2] as usize % 2;
                let (ew, eh) = sizes[ex];
                (
                    ex,
                    r[0] as usize % (ew + 1 - w),
                    r[1] as usize % (eh + 1 - w),
                )
            })
            .collect();
        // Few distinct costs, so most texels meet ties.
        let costs: Vec<u32> = (0..n).map(|k| rng.u32x4(200 + k as u64)[2] % 3).collect();
        let weights: Vec<f32> = (0..n)
            .map(|k| 0.5 + rng.uniform4(300 + k as u64, 0)[0])
            .collect();
        let bands = crate::bands::bands(&set, w);
        let mut canvas = Canvas::new(side, side, c, false);
        let windows = Windows {
            w,
            xs: origins.to_vec(),
            ys: origins.to_vec(),
            placed: placed.clone(),
            costs: costs.clone(),
            weights: weights.clone(),
        };
        e_step(&mut canvas, &set, &windows, &bands);
        // The exemplar texel under (x, y) of window k.
        let texel = |k: usize, x: usize, y: usize| {
            let (ex, mx, my) = placed[k];
            (
                ex,
                (my + y - origins[k / 4]) * sizes[ex].0 + mx + x - origins[k % 4],
            )
        };
        let mut from = [0; 2];
        for y in 0..side {
            for x in 0..side {
                // Windows in row-major order; the least cost, the first among equals.
                let covering: Vec<usize> = (0..n)
                    .filter(|&k| {
                        let (ox, oy) = (origins[k % 4], origins[k / 4]);
                        (ox..ox + w).contains(&x) && (oy..oy + w).contains(&y)
                    })
                    .collect();
                let mut best: Option<(u32, usize)> = None;
                for &k in &covering {
                    if best.is_none_or(|b| costs[k] < b.0) {
                        best = Some((costs[k], k));
                    }
                }
                let (ex, s) = texel(best.expect("every texel is covered").1, x, y);
                let t = y * side + x;
                assert_eq!(canvas.src[t], s as u32, "texel ({x}, {y})");
                assert_eq!(canvas.src_exemplar[t] as usize, ex);
                from[ex] += 1;
                let high = &bands[ex].1;
                for ch in 0..c {
                    // The mean of the covering windows' low bands plus the chosen high band.
                    let (mut acc, mut low_sum, mut wsum) = (0f64, 0f64, 0f64);
                    for &k in &covering {
                        let (wex, ws) = texel(k, x, y);
                        let wk = weights[k] as f64;
                        acc += wk * bands[wex].0[ws * c + ch] as f64;
                        acc += wk * high[s * c + ch] as f64;
                        low_sum += wk * bands[wex].0[ws * c + ch] as f64;
                        wsum += wk;
                    }
                    let want = (acc / wsum) as f32;
                    assert_eq!(canvas.values[t * c + ch], want, "texel ({x}, {y})");
                    assert_eq!(canvas.codes[t * c + ch], set.quantizer.quantize(ch, want));
                    // Which is, to rounding, the low bands' mean plus the chosen high band.
                    let split = low_sum / wsum + high[s * c + ch] as f64;
                    assert!((want as f64 - split).abs() < 1e-6, "{want} vs {split}");
                }
            }
        }
        assert!(
            from[0] > 0 && from[1] > 0,
            "texels from each exemplar: {from:?}"
        );
    }
}
