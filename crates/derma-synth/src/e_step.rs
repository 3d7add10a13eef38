//! The E-step of an optimisation pass (Shen et al. §3.3, after Kwatra et al. 2005 §3): each
//! texel becomes the weighted mean of the best matches of the windows covering it, on the CPU.

use crate::canvas::{Canvas, NO_SOURCE};
use crate::exemplar::ExemplarSet;
use rayon::prelude::*;

/// What the E-step blends: the windows (origins along each axis, row-major), where each
/// window's best match lies (exemplar, x, y) and its weight.
pub(crate) struct Blend {
    pub w: usize,
    pub xs: Vec<usize>,
    pub ys: Vec<usize>,
    pub placed: Vec<(usize, usize, usize)>,
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
/// thread count; `e_step.wgsl` reproduces them bit for bit).
pub(crate) fn e_step(canvas: &mut Canvas, set: &ExemplarSet, b: &Blend) {
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
            for x in 0..width {
                acc.iter_mut().for_each(|a| *a = 0.0);
                let mut wsum = 0f64;
                let mut best = (f32::NEG_INFINITY, 0u8, NO_SOURCE);
                for &(jy, oy) in &cover_y[y] {
                    for &(ix, ox) in &cover_x[x] {
                        let k = jy as usize * nwx + ix as usize;
                        let (ex, mx, my) = b.placed[k];
                        let e = &set.exemplars[ex];
                        let s = (my + oy as usize) * e.width() + mx + ox as usize;
                        let wk = b.weights[k];
                        for (a, &v) in acc.iter_mut().zip(&e.texture.data[s * c..(s + 1) * c]) {
                            *a += wk as f64 * v as f64;
                        }
                        wsum += wk as f64;
                        if wk > best.0 {
                            best = (wk, ex as u8, s as u32);
                        }
                    }
                }
                for k in 0..c {
                    row[x * c + k] = (acc[k] / wsum) as f32;
                }
                src_row[x] = (best.1, best.2);
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
