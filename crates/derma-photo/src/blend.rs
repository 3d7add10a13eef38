//! Multiresolution splines (Burt & Adelson 1983, "A multiresolution spline with application to
//! image mosaics"): each image's Laplacian pyramid weighted by its mask's Gaussian pyramid, so
//! low frequencies blend over wide zones and fine detail switches sharply (Tarini et al. §3.2).

use rayon::prelude::*;

/// The generating kernel of Burt & Adelson (a = 0.4): [0.05, 0.25, 0.4, 0.25, 0.05].
const KERNEL: [f32; 5] = [0.05, 0.25, 0.4, 0.25, 0.05];

/// An image of `C`-channel pixels, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<const C: usize> {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Pixels, row-major.
    pub data: Vec<[f32; C]>,
}

/// A single-channel image.
pub type Plane = Image<1>;

impl Plane {
    /// A plane from its values.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Self {
        assert_eq!(data.len(), width * height);
        Self {
            width,
            height,
            data: data.into_iter().map(|v| [v]).collect(),
        }
    }

    /// The values.
    pub fn values(&self) -> Vec<f32> {
        self.data.iter().map(|v| v[0]).collect()
    }
}

impl<const C: usize> Image<C> {
    fn zeros(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: zeroed(width * height),
        }
    }
}

/// `n` zero pixels, written rather than calloc'ed: pages first touched by a read map the shared
/// zero page, and the write after it costs a copy-on-write fault with a TLB shootdown on every
/// core (measured: a third of the bake's time).
pub(crate) fn zeroed<const C: usize>(n: usize) -> Vec<[f32; C]> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, [0.0; C]);
    v
}

#[inline]
fn madd<const C: usize>(acc: &mut [f32; C], k: f32, v: &[f32; C]) {
    for c in 0..C {
        acc[c] += k * v[c];
    }
}

/// REDUCE: blur with the 5-tap kernel and keep every second sample (borders clamped).
pub fn reduce<const C: usize>(p: &Image<C>) -> Image<C> {
    let mut out = Image::zeros(p.width.div_ceil(2), p.height.div_ceil(2));
    reduce_into(p, &mut out, &mut Vec::new());
    out
}

/// [`reduce`] into `out` (of the halved size), with `tmp` as scratch (grown as needed).
fn reduce_into<const C: usize>(p: &Image<C>, out: &mut Image<C>, tmp: &mut Vec<[f32; C]>) {
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
            for (k, kv) in KERNEL.iter().enumerate() {
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
                    for (k, kv) in KERNEL.iter().enumerate() {
                        madd(&mut acc, *kv, &src[x + k - 2]);
                    }
                } else {
                    for (k, kv) in KERNEL.iter().enumerate() {
                        madd(&mut acc, *kv, at(x as isize + k as isize - 2));
                    }
                }
                *o = acc;
            }
        });
}

/// EXPAND `p` to `into`'s size by interpolating with the kernel (×4 gain on the inserted zeros,
/// ×2 per axis) and add `sign` × the result to `into`.
fn expand_into<const C: usize>(
    p: &Image<C>,
    into: &mut Image<C>,
    sign: f32,
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
                    madd(&mut acc, 2.0 * KERNEL[2], at(half));
                    madd(&mut acc, 2.0 * KERNEL[0], at(half + 1));
                    madd(&mut acc, 2.0 * KERNEL[4], at(half - 1));
                } else {
                    madd(&mut acc, 2.0 * KERNEL[1], at(half + 1));
                    madd(&mut acc, 2.0 * KERNEL[3], at(half));
                }
                *out = acc;
            }
        });
    let tmp = &tmp[..width * h];
    into.data
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(y, row)| {
            for (k, kv) in KERNEL.iter().enumerate() {
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
pub fn expand<const C: usize>(p: &Image<C>, width: usize, height: usize) -> Image<C> {
    let mut out = Image::zeros(width, height);
    expand_into(p, &mut out, 1.0, &mut Vec::new());
    out
}

/// The Gaussian pyramid of `p` with `levels` levels (level 0 is `p`).
pub fn gaussian_pyramid<const C: usize>(p: Image<C>, levels: usize) -> Vec<Image<C>> {
    let mut out = vec![p];
    for _ in 1..levels {
        let next = reduce(out.last().expect("a level"));
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

/// Adds the Laplacian pyramid of the image in `g[0]` (its Gaussian levels built in `g`, then
/// turned into Laplacian levels in place) weighted by its mask pyramid `mp` into `acc`.
fn accumulate<const C: usize>(
    g: &mut [Image<C>],
    mp: &[Plane],
    acc: &mut [Image<C>],
    tmp: &mut Vec<[f32; C]>,
) {
    let levels = acc.len();
    build_gaussian(g, tmp);
    for l in 0..levels {
        // Laplacian level in place: G_l − EXPAND(G_{l+1}) (G_{l+1} still Gaussian); the top
        // level is G_top itself.
        let (lo, hi) = g.split_at_mut(l + 1);
        if let Some(next) = hi.first() {
            expand_into(next, &mut lo[l], -1.0, tmp);
        }
        acc[l]
            .data
            .par_iter_mut()
            .zip(&lo[l].data)
            .zip(&mp[l].data)
            .for_each(|((a, v), m)| madd(a, m[0], v));
    }
}

fn collapse<const C: usize>(mut acc: Vec<Image<C>>, tmp: &mut Vec<[f32; C]>) -> Image<C> {
    let mut out = acc.pop().expect("a level");
    while let Some(mut level) = acc.pop() {
        expand_into(&out, &mut level, 1.0, tmp);
        out = level;
    }
    out
}

/// Zero images of a pyramid's level sizes.
fn zero_pyramid<const C: usize>(width: usize, height: usize, levels: usize) -> Vec<Image<C>> {
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
fn build_gaussian<const C: usize>(g: &mut [Image<C>], tmp: &mut Vec<[f32; C]>) {
    for l in 1..g.len() {
        let (lo, hi) = g.split_at_mut(l);
        reduce_into(&lo[l - 1], &mut hi[0], tmp);
    }
}

/// Blends `images` by `masks` (same size, ≥ 0; normalised per pixel and level here, the last
/// mask taking pixels none covers) with a multiresolution spline of `levels` levels.
pub fn multiband(images: &[&Plane], masks: &[Plane], levels: usize) -> Plane {
    assert_eq!(images.len(), masks.len());
    let (w, h) = (masks[0].width, masks[0].height);
    // Normalise at full resolution (the last mask takes pixels none covers); REDUCE is linear
    // and keeps constants, so the sum stays 1 at every level.
    let sums: Vec<f32> = (0..w * h)
        .map(|i| masks.iter().map(|m| m.data[i][0]).sum())
        .collect();
    let last = masks.len() - 1;
    multiband_with(
        w,
        h,
        masks.len(),
        levels,
        |k, out| {
            for (i, o) in out.data.iter_mut().enumerate() {
                o[0] = if sums[i] > 1e-12 {
                    masks[k].data[i][0] / sums[i]
                } else {
                    (k == last) as u8 as f32
                };
            }
        },
        |k, out| out.data.copy_from_slice(&images[k].data),
    )
}

/// The spline of `n` images of `width` × `height`, each image and its mask written one at a
/// time by `image(k, out)` and `mask(k, out)`; the masks must sum to 1 at every pixel (then
/// their Gaussian pyramids do at every level, REDUCE being linear). One image's and one mask's
/// pyramid are in memory at once, in buffers reused for the next (fresh pages cost more than
/// the filtering: the kernel zeroes every one).
pub fn multiband_with<const C: usize>(
    width: usize,
    height: usize,
    n: usize,
    levels: usize,
    mask: impl Fn(usize, &mut Plane),
    image: impl Fn(usize, &mut Image<C>),
) -> Image<C> {
    let mut acc: Vec<Image<C>> = zero_pyramid(width, height, levels);
    let mut g: Vec<Image<C>> = zero_pyramid(width, height, levels);
    let mut mp: Vec<Plane> = zero_pyramid(width, height, levels);
    let (mut tmp, mut mtmp) = (Vec::new(), Vec::new());
    for k in 0..n {
        mask(k, &mut mp[0]);
        build_gaussian(&mut mp, &mut mtmp);
        image(k, &mut g[0]);
        accumulate(&mut g, &mp, &mut acc, &mut tmp);
    }
    collapse(acc, &mut tmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Plane {
        Plane::new(w, h, (0..w * h).map(|i| f(i % w, i / w)).collect())
    }

    #[test]
    fn one_image_with_a_full_mask_comes_back_exactly() {
        let img = ramp(37, 29, |x, y| ((x * 7 + y * 13) % 17) as f32 / 17.0);
        let mask = Plane::new(37, 29, vec![1.0; 37 * 29]);
        let out = multiband(&[&img], &[mask], default_levels(37, 29));
        let err = out
            .data
            .iter()
            .zip(&img.data)
            .map(|(a, b)| (a[0] - b[0]).abs())
            .fold(0.0, f32::max);
        assert!(err < 1e-5, "{err}");
    }

    #[test]
    fn the_kernel_keeps_a_constant() {
        let c = Plane::new(20, 14, vec![0.3; 280]);
        let r = reduce(&c);
        assert!(r.values().iter().all(|v| (v - 0.3).abs() < 1e-6));
        let e = expand(&r, 20, 14);
        assert!(
            e.data.iter().all(|v| (v[0] - 0.3).abs() < 1e-6),
            "{:?}",
            &e.data[..5]
        );
    }

    #[test]
    fn a_step_between_two_exposures_is_smoothed_but_detail_stays_sharp() {
        // Left half from image A (gain 1), right half from B (gain 1.3) of the same detail.
        let (w, h) = (128, 64);
        let detail = |x: usize, y: usize| 0.4 + 0.1 * (((x / 2 + y / 2) % 2) as f32 - 0.5);
        let a = ramp(w, h, detail);
        let b = ramp(w, h, |x, y| 1.3 * detail(x, y));
        let left = ramp(w, h, |x, _| (x < w / 2) as u8 as f32);
        let right = ramp(w, h, |x, _| (x >= w / 2) as u8 as f32);
        let hard: Vec<f32> = (0..w * h)
            .map(|i| {
                if i % w < w / 2 {
                    a.data[i][0]
                } else {
                    b.data[i][0]
                }
            })
            .collect();
        let out = multiband(&[&a, &b], &[left, right], default_levels(w, h)).values();
        let (a, b) = (a.values(), b.values());
        // The largest jump of the local mean across the seam: row means over 4-pixel columns.
        let col_mean = |d: &[f32], x: usize| {
            (0..h)
                .map(|y| (0..4).map(|k| d[y * w + x + k]).sum::<f32>())
                .sum::<f32>()
                / (4 * h) as f32
        };
        let jump = |d: &[f32]| {
            (0..w - 8)
                .step_by(4)
                .map(|x| (col_mean(d, x + 4) - col_mean(d, x)).abs())
                .fold(0.0, f32::max)
        };
        assert!(
            jump(&out) < 0.5 * jump(&hard),
            "{} vs {}",
            jump(&out),
            jump(&hard)
        );
        // Far from the seam the detail is that of the chosen image.
        for y in 0..h {
            for x in [2, 8, w - 9, w - 3] {
                let want = if x < w / 2 {
                    a[y * w + x]
                } else {
                    b[y * w + x]
                };
                let got = out[y * w + x];
                assert!((got - want).abs() < 0.06, "({x}, {y}) {got} vs {want}");
            }
        }
    }
}
