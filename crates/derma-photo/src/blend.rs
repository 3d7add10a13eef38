//! Multiresolution splines (Burt & Adelson 1983, "A multiresolution spline with application to
//! image mosaics"): each image's Laplacian pyramid weighted by its mask's Gaussian pyramid, so
//! low frequencies blend over wide zones and fine detail switches sharply (Tarini et al. §3.2).
//! The pyramid itself is derma-core's ([`derma_core::pyramid`], a = 0.4).

use derma_core::image::Image;
use derma_core::pyramid::{build_gaussian, expand_into, madd, zero_pyramid, BURT_ADELSON};
use rayon::prelude::*;

pub use derma_core::pyramid::default_levels;

/// A single-channel image (a mask).
pub type Plane = derma_core::image::Grey;

/// Adds the Laplacian pyramid of the image in `g[0]` (its Gaussian levels built in `g`, then
/// turned into Laplacian levels in place) weighted by its mask pyramid `mp` into `acc`.
fn accumulate<const C: usize>(
    g: &mut [Image<C>],
    mp: &[Plane],
    acc: &mut [Image<C>],
    tmp: &mut Vec<[f32; C]>,
) {
    let levels = acc.len();
    build_gaussian(g, &BURT_ADELSON, tmp);
    for l in 0..levels {
        // Laplacian level in place: G_l − EXPAND(G_{l+1}) (G_{l+1} still Gaussian); the top
        // level is G_top itself.
        let (lo, hi) = g.split_at_mut(l + 1);
        if let Some(next) = hi.first() {
            expand_into(next, &mut lo[l], -1.0, &BURT_ADELSON, tmp);
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
        expand_into(&out, &mut level, 1.0, &BURT_ADELSON, tmp);
        out = level;
    }
    out
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
        build_gaussian(&mut mp, &BURT_ADELSON, &mut mtmp);
        image(k, &mut g[0]);
        accumulate(&mut g, &mp, &mut acc, &mut tmp);
    }
    collapse(acc, &mut tmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Plane {
        Plane::from_fn(w, h, |i| [f(i % w, i / w)])
    }

    fn values(p: &Plane) -> Vec<f32> {
        p.data.iter().map(|v| v[0]).collect()
    }

    #[test]
    fn one_image_with_a_full_mask_comes_back_exactly() {
        let img = ramp(37, 29, |x, y| ((x * 7 + y * 13) % 17) as f32 / 17.0);
        let mask = Plane::filled(37, 29, [1.0]);
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
        let out = values(&multiband(&[&a, &b], &[left, right], default_levels(w, h)));
        let (a, b) = (values(&a), values(&b));
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
