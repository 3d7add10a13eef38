//! Multiresolution splines (Burt & Adelson 1983, "A multiresolution spline with application to
//! image mosaics"): each image's Laplacian pyramid weighted by its mask's Gaussian pyramid, so
//! low frequencies blend over wide zones and fine detail switches sharply (Tarini et al. §3.2).

use rayon::prelude::*;

/// The generating kernel of Burt & Adelson (a = 0.4): [0.05, 0.25, 0.4, 0.25, 0.05].
const KERNEL: [f32; 5] = [0.05, 0.25, 0.4, 0.25, 0.05];

/// A planar single-channel image.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Values, row-major.
    pub data: Vec<f32>,
}

impl Plane {
    /// A plane from its values.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Self {
        assert_eq!(data.len(), width * height);
        Self {
            width,
            height,
            data,
        }
    }
}

/// REDUCE: blur with the 5-tap kernel and keep every second sample (borders clamped).
pub fn reduce(p: &Plane) -> Plane {
    let (w, h) = (p.width, p.height);
    let (w2, h2) = (w.div_ceil(2), h.div_ceil(2));
    // Horizontal pass on every row, decimated in x.
    let mut tmp = vec![0.0f32; w2 * h];
    tmp.par_chunks_mut(w2).enumerate().for_each(|(y, row)| {
        let src = &p.data[y * w..(y + 1) * w];
        for (x2, out) in row.iter_mut().enumerate() {
            let x = 2 * x2 as isize;
            let mut s = 0.0;
            for (k, kv) in KERNEL.iter().enumerate() {
                let xi = (x + k as isize - 2).clamp(0, w as isize - 1) as usize;
                s += kv * src[xi];
            }
            *out = s;
        }
    });
    let mut out = vec![0.0f32; w2 * h2];
    out.par_chunks_mut(w2).enumerate().for_each(|(y2, row)| {
        let y = 2 * y2 as isize;
        for (k, kv) in KERNEL.iter().enumerate() {
            let yi = (y + k as isize - 2).clamp(0, h as isize - 1) as usize;
            let src = &tmp[yi * w2..(yi + 1) * w2];
            for (o, s) in row.iter_mut().zip(src) {
                *o += kv * s;
            }
        }
    });
    Plane::new(w2, h2, out)
}

/// EXPAND: upsample `p` to `width` × `height` by interpolating with the kernel (×4 gain on the
/// inserted zeros, separably ×2 per axis).
pub fn expand(p: &Plane, width: usize, height: usize) -> Plane {
    let (w, h) = (p.width, p.height);
    // Horizontal: out[x] = 2 Σ_k K[k] in[(x − k + 2)/2] over integer positions.
    let mut tmp = vec![0.0f32; width * h];
    tmp.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let src = &p.data[y * w..(y + 1) * w];
        for (x, out) in row.iter_mut().enumerate() {
            let mut s = 0.0;
            for (k, kv) in KERNEL.iter().enumerate() {
                let t = x as isize - k as isize + 2;
                if t % 2 == 0 {
                    let xi = (t / 2).clamp(0, w as isize - 1) as usize;
                    s += kv * src[xi];
                }
            }
            *out = 2.0 * s;
        }
    });
    let mut out = vec![0.0f32; width * height];
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (k, kv) in KERNEL.iter().enumerate() {
            let t = y as isize - k as isize + 2;
            if t % 2 != 0 {
                continue;
            }
            let yi = (t / 2).clamp(0, h as isize - 1) as usize;
            let src = &tmp[yi * width..(yi + 1) * width];
            for (o, s) in row.iter_mut().zip(src) {
                *o += 2.0 * kv * s;
            }
        }
    });
    Plane::new(width, height, out)
}

/// The Gaussian pyramid of `p` with `levels` levels (level 0 is `p`).
pub fn gaussian_pyramid(p: &Plane, levels: usize) -> Vec<Plane> {
    let mut out = vec![p.clone()];
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

/// Gaussian pyramids of `masks`, normalised to sum 1 per pixel at every level; where no mask
/// covers a pixel at some level the last mask (the complement) takes it.
fn mask_pyramids(masks: &[Plane], levels: usize) -> Vec<Vec<Plane>> {
    let mut pyr: Vec<Vec<Plane>> = masks.iter().map(|m| gaussian_pyramid(m, levels)).collect();
    let last = pyr.len() - 1;
    for l in 0..levels {
        let n = pyr[0][l].data.len();
        let sums: Vec<f32> = (0..n)
            .into_par_iter()
            .map(|i| pyr.iter().map(|p| p[l].data[i]).sum::<f32>())
            .collect();
        for (k, p) in pyr.iter_mut().enumerate() {
            p[l].data.par_iter_mut().zip(&sums).for_each(|(v, s)| {
                *v = if *s > 1e-12 {
                    *v / s
                } else {
                    (k == last) as u8 as f32
                };
            });
        }
    }
    pyr
}

/// Adds image `img`'s Laplacian pyramid weighted by its mask pyramid `mp` into `acc`.
fn accumulate(img: &Plane, mp: &[Plane], acc: &mut [Plane]) {
    let levels = acc.len();
    let g = gaussian_pyramid(img, levels);
    for l in 0..levels {
        // Laplacian level: G_l − EXPAND(G_{l+1}); the top level is G_top itself.
        let e = (l + 1 < levels).then(|| expand(&g[l + 1], g[l].width, g[l].height));
        let gl = &g[l].data;
        acc[l].data.par_iter_mut().enumerate().for_each(|(i, a)| {
            let lap = gl[i] - e.as_ref().map_or(0.0, |e| e.data[i]);
            *a += lap * mp[l].data[i];
        });
    }
}

fn collapse(mut acc: Vec<Plane>) -> Plane {
    let mut out = acc.pop().expect("a level");
    while let Some(level) = acc.pop() {
        let mut e = expand(&out, level.width, level.height);
        e.data
            .par_iter_mut()
            .zip(&level.data)
            .for_each(|(a, b)| *a += b);
        out = e;
    }
    out
}

fn zero_pyramid(like: &[Plane]) -> Vec<Plane> {
    like.iter()
        .map(|p| Plane::new(p.width, p.height, vec![0.0; p.data.len()]))
        .collect()
}

/// Blends `images` by `masks` (same size, ≥ 0; normalised per pixel and level here, the last
/// mask taking pixels none covers) with a multiresolution spline of `levels` levels.
pub fn multiband(images: &[&Plane], masks: &[Plane], levels: usize) -> Plane {
    assert_eq!(images.len(), masks.len());
    let mp = mask_pyramids(masks, levels);
    let mut acc = zero_pyramid(&mp[0]);
    for (img, m) in images.iter().zip(&mp) {
        accumulate(img, m, &mut acc);
    }
    collapse(acc)
}

/// [`multiband`] for RGB images made one at a time by `image(k)` (interleaved, the masks'
/// size), so that only one image and its pyramid are in memory at once.
pub fn multiband_rgb(
    masks: &[Plane],
    levels: usize,
    image: impl Fn(usize) -> Vec<[f32; 3]>,
) -> [Plane; 3] {
    let (w, h) = (masks[0].width, masks[0].height);
    let mp = mask_pyramids(masks, levels);
    let mut acc: [Vec<Plane>; 3] = std::array::from_fn(|_| zero_pyramid(&mp[0]));
    for (k, m) in mp.iter().enumerate() {
        let img = image(k);
        for (c, a) in acc.iter_mut().enumerate() {
            let plane = Plane::new(w, h, img.iter().map(|p| p[c]).collect());
            accumulate(&plane, m, a);
        }
    }
    acc.map(collapse)
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
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(err < 1e-5, "{err}");
    }

    #[test]
    fn the_kernel_keeps_a_constant() {
        let c = Plane::new(20, 14, vec![0.3; 280]);
        let r = reduce(&c);
        assert!(r.data.iter().all(|v| (v - 0.3).abs() < 1e-6));
        let e = expand(&r, 20, 14);
        assert!(
            e.data.iter().all(|v| (v - 0.3).abs() < 1e-6),
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
            .map(|i| if i % w < w / 2 { a.data[i] } else { b.data[i] })
            .collect();
        let out = multiband(&[&a, &b], &[left, right], default_levels(w, h));
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
            jump(&out.data) < 0.5 * jump(&hard),
            "{} vs {}",
            jump(&out.data),
            jump(&hard)
        );
        // Far from the seam the detail is that of the chosen image.
        for y in 0..h {
            for x in [2, 8, w - 9, w - 3] {
                let want = if x < w / 2 {
                    a.data[y * w + x]
                } else {
                    b.data[y * w + x]
                };
                let got = out.data[y * w + x];
                assert!((got - want).abs() < 0.06, "({x}, {y}) {got} vs {want}");
            }
        }
    }
}
