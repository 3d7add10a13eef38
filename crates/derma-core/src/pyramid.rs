//! Gaussian pyramids after Burt & Adelson 1983 ("The Laplacian pyramid as a compact image code";
//! "A multiresolution spline with application to image mosaics"): REDUCE and EXPAND with the
//! 5-tap generating kernel, borders clamped, levels of ⌈w/2⌉ × ⌈h/2⌉. The one pyramid of derma.

use crate::image::{zeroed, Image};
use rayon::prelude::*;

/// The generating kernel of Burt & Adelson with a = 0.4: [1/4 − a/2, 1/4, a, 1/4, 1/4 − a/2].
pub const BURT_ADELSON: [f32; 5] = [0.05, 0.25, 0.4, 0.25, 0.05];

/// The same kernel with a = 3/8: the binomial [1 4 6 4 1]/16 (Itti et al. 1998's dyadic
/// Gaussian pyramid).
pub const BINOMIAL: [f32; 5] = [0.0625, 0.25, 0.375, 0.25, 0.0625];

/// acc += k · v, channel by channel.
#[inline]
pub fn madd<const C: usize>(acc: &mut [f32; C], k: f32, v: &[f32; C]) {
    for c in 0..C {
        acc[c] += k * v[c];
    }
}

/// REDUCE: blur with `kernel` and keep every second sample (borders clamped).
pub fn reduce<const C: usize>(p: &Image<C>, kernel: &[f32; 5]) -> Image<C> {
    let mut out = Image::zeros(p.width.div_ceil(2), p.height.div_ceil(2));
    reduce_into(p, &mut out, kernel, &mut Vec::new());
    out
}

/// [`reduce`] into `out` (of the halved size), with `tmp` as scratch (grown as needed).
pub fn reduce_into<const C: usize>(
    p: &Image<C>,
    out: &mut Image<C>,
    kernel: &[f32; 5],
    tmp: &mut Vec<[f32; C]>,
) {
    let (w, h) = (p.width, p.height);
    let (w2, h2) = (w.div_ceil(2), h.div_ceil(2));
    assert_eq!((out.width, out.height), (w2, h2));
    if tmp.len() < w * h2 {
        *tmp = zeroed(w * h2);
    }
    // Vertical pass on every second row, then horizontal on every second column.
    tmp[..w * h2]
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y2, row)| {
            let y = 2 * y2 as isize;
            row.fill([0.0; C]);
            for (k, kv) in kernel.iter().enumerate() {
                let yi = (y + k as isize - 2).clamp(0, h as isize - 1) as usize;
                let src = &p.data[yi * w..(yi + 1) * w];
                // Flat f32 rows: the compiler vectorises this across channels and pixels.
                for (o, s) in row.as_flattened_mut().iter_mut().zip(src.as_flattened()) {
                    *o += kv * s;
                }
            }
        });
    let tmp = &tmp[..w * h2];
    out.data
        .par_chunks_mut(w2)
        .enumerate()
        .for_each(|(y2, row)| {
            let src = &tmp[y2 * w..(y2 + 1) * w];
            let at = |x: isize| &src[x.clamp(0, w as isize - 1) as usize];
            for (x2, o) in row.iter_mut().enumerate() {
                let x = 2 * x2;
                let mut acc = [0.0f32; C];
                if x >= 2 && x + 2 < w {
                    // Interior: no clamping.
                    for (k, kv) in kernel.iter().enumerate() {
                        madd(&mut acc, *kv, &src[x + k - 2]);
                    }
                } else {
                    for (k, kv) in kernel.iter().enumerate() {
                        madd(&mut acc, *kv, at(x as isize + k as isize - 2));
                    }
                }
                *o = acc;
            }
        });
}

/// EXPAND `p` to `into`'s size by interpolating with the kernel (×4 gain on the inserted zeros,
/// ×2 per axis) and add `sign` × the result to `into`.
pub fn expand_into<const C: usize>(
    p: &Image<C>,
    into: &mut Image<C>,
    sign: f32,
    kernel: &[f32; 5],
    tmp: &mut Vec<[f32; C]>,
) {
    let (w, h) = (p.width, p.height);
    let width = into.width;
    if tmp.len() < width * h {
        *tmp = zeroed(width * h);
    }
    // Horizontal: out[x] = 2 Σ_k K[k] in[(x − k + 2)/2] over integer positions: even x take
    // K0, K2, K4 at x/2 + 1, x/2, x/2 − 1; odd x take K1, K3 at (x + 1)/2, (x − 1)/2.
    tmp[..width * h]
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(y, row)| {
            let src = &p.data[y * w..(y + 1) * w];
            let at = |i: isize| &src[i.clamp(0, w as isize - 1) as usize];
            for (x, out) in row.iter_mut().enumerate() {
                let mut acc = [0.0f32; C];
                let half = (x / 2) as isize;
                if x % 2 == 0 {
                    madd(&mut acc, 2.0 * kernel[2], at(half));
                    madd(&mut acc, 2.0 * kernel[0], at(half + 1));
                    madd(&mut acc, 2.0 * kernel[4], at(half - 1));
                } else {
                    madd(&mut acc, 2.0 * kernel[1], at(half + 1));
                    madd(&mut acc, 2.0 * kernel[3], at(half));
                }
                *out = acc;
            }
        });
    let tmp = &tmp[..width * h];
    into.data
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(y, row)| {
            for (k, kv) in kernel.iter().enumerate() {
                let t = y as isize - k as isize + 2;
                if t % 2 != 0 {
                    continue;
                }
                let yi = (t / 2).clamp(0, h as isize - 1) as usize;
                let src = &tmp[yi * width..(yi + 1) * width];
                let k = sign * 2.0 * kv;
                for (o, s) in row.as_flattened_mut().iter_mut().zip(src.as_flattened()) {
                    *o += k * s;
                }
            }
        });
}

/// EXPAND: upsample `p` to `width` × `height` by interpolating with the kernel.
pub fn expand<const C: usize>(
    p: &Image<C>,
    width: usize,
    height: usize,
    kernel: &[f32; 5],
) -> Image<C> {
    let mut out = Image::zeros(width, height);
    expand_into(p, &mut out, 1.0, kernel, &mut Vec::new());
    out
}

/// The Gaussian pyramid of `p` with `levels` levels (level 0 is `p`).
pub fn gaussian_pyramid<const C: usize>(
    p: Image<C>,
    levels: usize,
    kernel: &[f32; 5],
) -> Vec<Image<C>> {
    let mut out = vec![p];
    for l in 1..levels {
        let next = reduce(&out[l - 1], kernel);
        out.push(next);
    }
    out
}

/// Pyramid levels for an image: down to about 8 texels on the short side.
pub fn default_levels(width: usize, height: usize) -> usize {
    let mut n = 1;
    let mut s = width.min(height);
    while s > 16 {
        s = s.div_ceil(2);
        n += 1;
    }
    n
}

/// Zero images of a pyramid's level sizes.
pub fn zero_pyramid<const C: usize>(width: usize, height: usize, levels: usize) -> Vec<Image<C>> {
    let mut out = Vec::with_capacity(levels);
    let (mut w, mut h) = (width, height);
    for _ in 0..levels {
        out.push(Image::zeros(w, h));
        w = w.div_ceil(2);
        h = h.div_ceil(2);
    }
    out
}

/// Fills levels 1… of `g` by REDUCE from level 0.
pub fn build_gaussian<const C: usize>(
    g: &mut [Image<C>],
    kernel: &[f32; 5],
    tmp: &mut Vec<[f32; C]>,
) {
    for l in 1..g.len() {
        let (lo, hi) = g.split_at_mut(l);
        reduce_into(&lo[l - 1], &mut hi[0], kernel, tmp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernels_sum_to_one_as_burt_and_adelson_require() {
        // Normalised (Σ = 1), symmetric, equal contribution (odd and even taps each sum to ½).
        for k in [BURT_ADELSON, BINOMIAL] {
            assert!((k.iter().sum::<f32>() - 1.0).abs() < 1e-7);
            assert_eq!(k[0], k[4]);
            assert!((k[0] + k[2] + k[4] - 0.5).abs() < 1e-7 && (k[1] + k[3] - 0.5).abs() < 1e-7);
        }
    }

    #[test]
    fn the_kernel_keeps_a_constant() {
        let c = Image::<1>::filled(20, 14, [0.3]);
        for kernel in [&BURT_ADELSON, &BINOMIAL] {
            let r = reduce(&c, kernel);
            assert!(r.data.iter().all(|v| (v[0] - 0.3).abs() < 1e-6));
            let e = expand(&r, 20, 14, kernel);
            assert!(
                e.data.iter().all(|v| (v[0] - 0.3).abs() < 1e-6),
                "{:?}",
                &e.data[..5]
            );
        }
    }

    #[test]
    fn levels_halve_rounding_up() {
        let p = gaussian_pyramid(Image::<2>::zeros(37, 20), 4, &BURT_ADELSON);
        let sizes: Vec<(usize, usize)> = p.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(37, 20), (19, 10), (10, 5), (5, 3)]);
        assert_eq!(default_levels(37, 20), 2);
    }
}
