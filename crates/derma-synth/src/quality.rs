//! Quality of a synthesised texture without neural networks: a patch-statistics distance to the
//! exemplar, the share of the output that is a large verbatim copy, and the seam energy along
//! the synthesis grid. Definitions and references: docs/synth.md.
//!
//! - **Patch sliced Wasserstein distance** (Rabin, Peyré, Delon & Bernot 2011, "Wasserstein
//!   barycenter and its application to texture mixing", §2; as a texture measure, Heitz et al.
//!   2021): the k×k×C patches of each texture as a point cloud; random unit directions; the 1-D
//!   Wasserstein-2 distance of the projections by sorting; the root mean over directions.
//! - **Verbatim-copy ratio**: the fraction of output texels covered by a B×B window that occurs
//!   exactly (at 16-bit precision) somewhere in the exemplar.
//! - **Seam energy**: the mean squared difference across the synthesis grid's lines divided by
//!   the mean squared difference across all other texel boundaries, minus one: 0 when the grid
//!   is invisible, positive when patches show.
//! - **Multi-scale**: the patch SWD again on 2 × 2 and 4 × 4 box-averaged copies of both
//!   textures (7 × 7 patches then span 14 and 28 texels: structure a 7 × 7 patch cannot see,
//!   such as bands and repeated features), the contrast ratio (standard deviation of the output
//!   over the exemplar's) and the grain ratio (the same for what a 3 × 3 box blur removes: the
//!   finest detail, which averaging overlapping windows loses first).

use crate::error::{invalid, Result};
use crate::texture::Texture;
use derma_core::map::box_reduced;
use derma_core::rng::Philox;
use derma_core::Map;
use rayon::prelude::*;
use std::collections::HashMap;

/// The quality figures of a synthesis against its exemplar (`derma synth --metrics`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Metrics {
    /// [`patch_swd`] with default settings (lower is closer to the exemplar).
    pub patch_swd: f64,
    /// [`patch_swd`] of both textures at half resolution ([`downsample`] by 2).
    pub patch_swd_half: f64,
    /// [`patch_swd`] of both textures at quarter resolution ([`downsample`] by 4).
    pub patch_swd_quarter: f64,
    /// [`contrast_ratio`]: 1 when the output varies as much as the exemplar.
    pub contrast_ratio: f64,
    /// [`grain_ratio`]: 1 when the output keeps the exemplar's finest detail.
    pub grain_ratio: f64,
    /// [`verbatim_copy_ratio`] for 32 × 32 blocks.
    pub verbatim_copy_ratio: f64,
    /// [`seam_energy`] along the patch pass's grid (step N/2).
    pub seam_energy: f64,
}

impl Metrics {
    /// Measures `output` against `exemplar`, synthesised with patches of side `patch`.
    /// The coarser SWDs are NaN where the exemplar is too small for 7 × 7 patches at that scale.
    pub fn measure(output: &Texture, exemplar: &Texture, patch: usize) -> Result<Self> {
        let o = SwdOptions::default();
        let coarse = |f: usize| -> Result<f64> {
            let (a, b) = (downsample(output, f), downsample(exemplar, f));
            if a.width < o.patch || a.height < o.patch || b.width < o.patch || b.height < o.patch {
                return Ok(f64::NAN);
            }
            patch_swd(&a, &b, &o)
        };
        Ok(Self {
            patch_swd: patch_swd(output, exemplar, &o)?,
            patch_swd_half: coarse(2)?,
            patch_swd_quarter: coarse(4)?,
            contrast_ratio: contrast_ratio(output, exemplar)?,
            grain_ratio: grain_ratio(output, exemplar)?,
            verbatim_copy_ratio: verbatim_copy_ratio(output, exemplar, 32)?,
            seam_energy: seam_energy(output, patch / 2)?,
        })
    }
}

/// `t` averaged over `f × f` blocks (a box filter and decimation; a partial last row or column
/// of blocks is dropped): derma-core's [`box_reduced`] channel by channel.
pub fn downsample(t: &Texture, f: usize) -> Texture {
    let c = t.channels;
    if c == 0 {
        return Texture {
            width: t.width / f.max(1),
            height: t.height / f.max(1),
            channels: 0,
            data: Vec::new(),
        };
    }
    let maps: Vec<Map> = (0..c)
        .map(|k| {
            let [m] = box_reduced(t.width, t.height, f, |i| [t.data[i * c + k]]);
            m
        })
        .collect();
    let (w, h) = (maps[0].width(), maps[0].height());
    Texture {
        width: w,
        height: h,
        channels: c,
        data: (0..w * h * c).map(|j| maps[j % c].data()[j / c]).collect(),
    }
}

/// Standard deviation of each channel of `t`.
fn channel_std(t: &Texture) -> Vec<f64> {
    let c = t.channels;
    let n = (t.width * t.height) as f64;
    (0..c)
        .map(|k| {
            let vals = t.data.iter().skip(k).step_by(c).map(|&v| v as f64);
            let mean = vals.clone().sum::<f64>() / n;
            (vals.map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
        })
        .collect()
}

/// Mean over channels of the ratio of standard deviations, `a`'s over `b`'s (channels where
/// `b` is constant are skipped; 1 when none is left).
fn std_ratio(a: &Texture, b: &Texture) -> Result<f64> {
    if a.channels != b.channels {
        return Err(invalid(
            "textures",
            format!("{} and {} channels", a.channels, b.channels),
        ));
    }
    let ratios: Vec<f64> = channel_std(a)
        .iter()
        .zip(channel_std(b))
        .filter(|(_, sb)| *sb > 0.0)
        .map(|(sa, sb)| sa / sb)
        .collect();
    Ok(if ratios.is_empty() {
        1.0
    } else {
        ratios.iter().sum::<f64>() / ratios.len() as f64
    })
}

/// Contrast ratio: the output's standard deviation over the exemplar's (mean over channels):
/// below 1 when synthesis washes the texture out.
pub fn contrast_ratio(output: &Texture, exemplar: &Texture) -> Result<f64> {
    std_ratio(output, exemplar)
}

/// `t` minus its 3 × 3 box blur (edges clamped): the finest octave of detail.
fn fine_detail(t: &Texture) -> Texture {
    let (w, h, c) = (t.width, t.height, t.channels);
    let mut data = vec![0f32; w * h * c];
    for y in 0..h {
        for x in 0..w {
            for k in 0..c {
                let mut s = 0.0;
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let xx = (x as i64 + dx).clamp(0, w as i64 - 1) as usize;
                        let yy = (y as i64 + dy).clamp(0, h as i64 - 1) as usize;
                        s += t.texel(xx, yy)[k];
                    }
                }
                data[(y * w + x) * c + k] = t.texel(x, y)[k] - s / 9.0;
            }
        }
    }
    Texture {
        width: w,
        height: h,
        channels: c,
        data,
    }
}

/// Grain ratio: the [`contrast_ratio`] of the finest detail (each texture minus its 3 × 3 box
/// blur): below 1 when synthesis blurs the grain.
pub fn grain_ratio(output: &Texture, exemplar: &Texture) -> Result<f64> {
    std_ratio(&fine_detail(output), &fine_detail(exemplar))
}

/// Settings of [`patch_swd`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwdOptions {
    /// Patch side k (7 by default, as the issue asks).
    pub patch: usize,
    /// Random projection directions.
    pub directions: usize,
    /// Patches sampled per texture (all positions when there are fewer).
    pub samples: usize,
    /// Seed of the directions and samples.
    pub seed: u64,
}

impl Default for SwdOptions {
    fn default() -> Self {
        Self {
            patch: 7,
            directions: 64,
            samples: 4096,
            seed: 1,
        }
    }
}

/// Top-left corners of the patches sampled from `t`: every position when there are at most
/// `n`, otherwise `n` drawn uniformly (Philox, so the same texture gives the same positions).
fn patch_positions(t: &Texture, k: usize, n: usize, seed: u64) -> Vec<(usize, usize)> {
    let (nx, ny) = (t.width + 1 - k, t.height + 1 - k);
    if nx * ny <= n {
        return (0..ny).flat_map(|y| (0..nx).map(move |x| (x, y))).collect();
    }
    let rng = Philox::new(seed, 0x5344);
    (0..n as u64)
        .map(|i| {
            let u = rng.uniform4(i, 0);
            (
                ((u[0] * nx as f32) as usize).min(nx - 1),
                ((u[1] * ny as f32) as usize).min(ny - 1),
            )
        })
        .collect()
}

/// Sorted projections of the sampled patches of `t` on `dir` (length k²C).
fn projections(t: &Texture, pos: &[(usize, usize)], k: usize, dir: &[f32]) -> Vec<f32> {
    let c = t.channels;
    let mut p: Vec<f32> = pos
        .iter()
        .map(|&(x0, y0)| {
            let mut s = 0.0f32;
            for dy in 0..k {
                let row = &t.data[((y0 + dy) * t.width + x0) * c..][..k * c];
                let d = &dir[dy * k * c..][..k * c];
                s += row.iter().zip(d).map(|(a, b)| a * b).sum::<f32>();
            }
            s
        })
        .collect();
    p.sort_by(f32::total_cmp);
    p
}

/// Quantile `q` ∈ [0, 1] of sorted values, linearly interpolated.
fn quantile(sorted: &[f32], q: f64) -> f64 {
    let f = q * (sorted.len() - 1) as f64;
    let i = (f.floor() as usize).min(sorted.len() - 1);
    let j = (i + 1).min(sorted.len() - 1);
    let t = f - i as f64;
    sorted[i] as f64 * (1.0 - t) + sorted[j] as f64 * t
}

/// Patch sliced Wasserstein distance between `a` and `b` (same channel count), in the textures'
/// value units: 0 for identical textures.
pub fn patch_swd(a: &Texture, b: &Texture, o: &SwdOptions) -> Result<f64> {
    let k = o.patch;
    if a.channels != b.channels {
        return Err(invalid(
            "textures",
            format!("{} and {} channels", a.channels, b.channels),
        ));
    }
    for (name, t) in [("first", a), ("second", b)] {
        if k == 0 || t.width < k || t.height < k {
            return Err(invalid(
                "patch size",
                format!(
                    "{k}×{k} patches do not fit the {name} texture ({}×{})",
                    t.width, t.height
                ),
            ));
        }
    }
    if o.directions == 0 || o.samples < 2 {
        return Err(invalid(
            "SWD options",
            "need at least one direction and two samples",
        ));
    }
    let dim = k * k * a.channels;
    let pa = patch_positions(a, k, o.samples, o.seed);
    let pb = patch_positions(b, k, o.samples, o.seed);
    let rng = Philox::new(o.seed, 0x5357);
    let sum: f64 = (0..o.directions)
        .into_par_iter()
        .map(|d| {
            let mut dir: Vec<f32> = (0..dim.div_ceil(2))
                .flat_map(|i| rng.normal2(i as u64, d as u32))
                .take(dim)
                .collect();
            let norm = dir.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-12);
            dir.iter_mut().for_each(|v| *v /= norm);
            let (sa, sb) = (projections(a, &pa, k, &dir), projections(b, &pb, k, &dir));
            let m = sa.len().min(sb.len());
            (0..m)
                .map(|i| {
                    let q = if m == 1 {
                        0.5
                    } else {
                        i as f64 / (m - 1) as f64
                    };
                    (quantile(&sa, q) - quantile(&sb, q)).powi(2)
                })
                .sum::<f64>()
                / m as f64
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum();
    Ok((sum / o.directions as f64).sqrt())
}

/// A texel's values at 16-bit precision, folded into one word.
fn texel_key(v: &[f32]) -> u64 {
    v.iter().fold(0x9E37_79B9_7F4A_7C15u64, |h, &x| {
        let q = (x.clamp(-1e6, 1e6) * 65535.0).round() as i64 as u64;
        (h ^ q).wrapping_mul(0x0100_0000_01B3)
    })
}

/// Hashes of every `b × b` window (top-left corner (x, y) at `y * (w − b + 1) + x`): rolling
/// polynomial hashes along rows, then down columns.
fn window_hashes(t: &Texture, b: usize) -> Vec<u64> {
    const P: u64 = 0x0000_0100_0000_01B3;
    const Q: u64 = 0x9E37_79B9_7F4A_7C15 | 1;
    let (w, h) = (t.width, t.height);
    let (nx, ny) = (w + 1 - b, h + 1 - b);
    let pb = (0..b).fold(1u64, |a, _| a.wrapping_mul(P));
    let qb = (0..b).fold(1u64, |a, _| a.wrapping_mul(Q));
    let rows: Vec<Vec<u64>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let keys: Vec<u64> = (0..w).map(|x| texel_key(t.texel(x, y))).collect();
            let mut out = Vec::with_capacity(nx);
            let mut hsh = 0u64;
            for x in 0..w {
                hsh = hsh.wrapping_mul(P).wrapping_add(keys[x]);
                if x >= b {
                    hsh = hsh.wrapping_sub(keys[x - b].wrapping_mul(pb));
                }
                if x + 1 >= b {
                    out.push(hsh);
                }
            }
            out
        })
        .collect();
    let mut out = vec![0u64; nx * ny];
    out.par_chunks_mut(ny).enumerate().for_each(|(x, col)| {
        let mut hsh = 0u64;
        for y in 0..h {
            hsh = hsh.wrapping_mul(Q).wrapping_add(rows[y][x]);
            if y >= b {
                hsh = hsh.wrapping_sub(rows[y - b][x].wrapping_mul(qb));
            }
            if y + 1 >= b {
                col[y + 1 - b] = hsh;
            }
        }
    });
    // `out` is column-major here; transpose to row-major.
    let mut rm = vec![0u64; nx * ny];
    for x in 0..nx {
        for y in 0..ny {
            rm[y * nx + x] = out[x * ny + y];
        }
    }
    rm
}

fn same_window(
    a: &Texture,
    ax: usize,
    ay: usize,
    b: &Texture,
    bx: usize,
    by: usize,
    s: usize,
) -> bool {
    (0..s).all(|dy| {
        (0..s)
            .all(|dx| texel_key(a.texel(ax + dx, ay + dy)) == texel_key(b.texel(bx + dx, by + dy)))
    })
}

/// Fraction of `output`'s texels covered by a `block × block` window that occurs verbatim (at
/// 16-bit precision, all channels) in `exemplar`: 1 for a copy of the exemplar, ≈ 0 for an
/// output that shares no large piece with it.
pub fn verbatim_copy_ratio(output: &Texture, exemplar: &Texture, block: usize) -> Result<f64> {
    if output.channels != exemplar.channels {
        return Err(invalid(
            "textures",
            format!("{} and {} channels", output.channels, exemplar.channels),
        ));
    }
    if block == 0
        || [output.width, output.height, exemplar.width, exemplar.height]
            .iter()
            .any(|&s| s < block)
    {
        return Err(invalid(
            "copy block",
            format!("{block} does not fit both textures"),
        ));
    }
    let ex = window_hashes(exemplar, block);
    let enx = exemplar.width + 1 - block;
    let mut index: HashMap<u64, Vec<u32>> = HashMap::new();
    for (i, &h) in ex.iter().enumerate() {
        index.entry(h).or_default().push(i as u32);
    }
    let out = window_hashes(output, block);
    let onx = output.width + 1 - block;
    let hits: Vec<bool> = out
        .par_iter()
        .enumerate()
        .map(|(i, h)| {
            let (x, y) = (i % onx, i / onx);
            index.get(h).is_some_and(|c| {
                c.iter().any(|&j| {
                    let (ex_x, ex_y) = (j as usize % enx, j as usize / enx);
                    same_window(output, x, y, exemplar, ex_x, ex_y, block)
                })
            })
        })
        .collect();
    // Mark covered texels with a 2-D difference array.
    let (w, h) = (output.width, output.height);
    let mut diff = vec![0i32; (w + 1) * (h + 1)];
    for (i, _) in hits.iter().enumerate().filter(|(_, &hit)| hit) {
        let (x, y) = (i % onx, i / onx);
        diff[y * (w + 1) + x] += 1;
        diff[y * (w + 1) + x + block] -= 1;
        diff[(y + block) * (w + 1) + x] -= 1;
        diff[(y + block) * (w + 1) + x + block] += 1;
    }
    let mut covered = 0usize;
    let mut above = vec![0i32; w + 1];
    for y in 0..h {
        let mut run = 0i32;
        for x in 0..w {
            run += diff[y * (w + 1) + x];
            above[x] += run;
            if above[x] > 0 {
                covered += 1;
            }
        }
    }
    Ok(covered as f64 / (w * h) as f64)
}

/// Seam energy of `t` for a synthesis grid of step `step` texels (lines at multiples of it):
/// mean squared difference across grid lines / mean squared difference across all other
/// neighbouring texels − 1.
pub fn seam_energy(t: &Texture, step: usize) -> Result<f64> {
    if step < 2 || step >= t.width.min(t.height) {
        return Err(invalid(
            "seam step",
            format!("{step}; expected 2 ≤ step < {}", t.width.min(t.height)),
        ));
    }
    let d2 = |a: &[f32], b: &[f32]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| ((p - q) as f64).powi(2))
            .sum::<f64>()
    };
    let (mut seam, mut ns, mut rest, mut nr) = (0.0, 0usize, 0.0, 0usize);
    for y in 0..t.height {
        for x in 1..t.width {
            let e = d2(t.texel(x, y), t.texel(x - 1, y));
            if x % step == 0 {
                seam += e;
                ns += 1;
            } else {
                rest += e;
                nr += 1;
            }
        }
    }
    for y in 1..t.height {
        for x in 0..t.width {
            let e = d2(t.texel(x, y), t.texel(x, y - 1));
            if y % step == 0 {
                seam += e;
                ns += 1;
            } else {
                rest += e;
                nr += 1;
            }
        }
    }
    let (seam, rest) = (seam / ns as f64, rest / nr as f64);
    if rest <= 0.0 {
        return Ok(if seam > 0.0 { f64::INFINITY } else { 0.0 });
    }
    Ok(seam / rest - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random texture with texture at two scales: hash noise box-blurred over 5×5 texels (the
    /// first channel, correlated like skin detail) and the raw noise (the second).
    fn noise(w: usize, h: usize, seed: u64) -> Texture {
        let rng = Philox::new(seed, 7);
        let raw: Vec<f32> = (0..w * h).map(|i| rng.uniform4(i as u64, 0)[0]).collect();
        let mut data = Vec::with_capacity(w * h * 2);
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for dy in 0..5 {
                    for dx in 0..5 {
                        s += raw[((y + dy) % h) * w + (x + dx) % w];
                    }
                }
                data.push(s / 25.0);
                data.push(0.2 * raw[y * w + x]);
            }
        }
        Texture::new(w, h, 2, data).unwrap()
    }

    /// `t` cut into step×step blocks, shuffled by a fixed permutation.
    fn shuffled_blocks(t: &Texture, step: usize) -> Texture {
        let (bx, by) = (t.width / step, t.height / step);
        let n = bx * by;
        let perm: Vec<usize> = (0..n).map(|i| (i * 7 + 3) % n).collect();
        let mut out = t.clone();
        for (dst, &src) in perm.iter().enumerate() {
            let (dx, dy, sx, sy) = (
                (dst % bx) * step,
                (dst / bx) * step,
                (src % bx) * step,
                (src / bx) * step,
            );
            for y in 0..step {
                for x in 0..step {
                    let s = ((sy + y) * t.width + sx + x) * t.channels;
                    let d = ((dy + y) * t.width + dx + x) * t.channels;
                    out.data[d..d + t.channels].copy_from_slice(&t.data[s..s + t.channels]);
                }
            }
        }
        out
    }

    #[test]
    fn contrast_and_grain_ratios_see_blur_and_gain() {
        let t = noise(64, 64, 5);
        assert!((contrast_ratio(&t, &t).unwrap() - 1.0).abs() < 1e-12);
        // Doubling the deviation about the mean doubles both ratios.
        let mean = t.data.iter().sum::<f32>() / t.data.len() as f32;
        let loud = Texture {
            data: t.data.iter().map(|v| mean + 2.0 * (v - mean)).collect(),
            ..t.clone()
        };
        assert!((contrast_ratio(&loud, &t).unwrap() - 2.0).abs() < 1e-5);
        assert!((grain_ratio(&loud, &t).unwrap() - 2.0).abs() < 1e-5);
        // A blur keeps the mean but loses the grain much more than the contrast.
        let rng = Philox::new(9, 7);
        let t = Texture::new(
            64,
            64,
            1,
            (0..64 * 64).map(|i| rng.uniform4(i, 0)[0]).collect(),
        )
        .unwrap();
        let blurred = downsample(&t, 2);
        let up = Texture {
            width: 64,
            height: 64,
            channels: 1,
            data: (0..64 * 64)
                .map(|i| blurred.data[(i / 64 / 2) * 32 + (i % 64) / 2])
                .collect(),
        };
        let (c, g) = (
            contrast_ratio(&up, &t).unwrap(),
            grain_ratio(&up, &t).unwrap(),
        );
        assert!(g < 0.7 && g < c, "contrast {c}, grain {g}");
    }

    #[test]
    fn downsample_averages_blocks() {
        let t = Texture {
            width: 4,
            height: 2,
            channels: 1,
            data: vec![0.0, 2.0, 4.0, 8.0, 2.0, 4.0, 0.0, 4.0],
        };
        let d = downsample(&t, 2);
        assert_eq!((d.width, d.height), (2, 1));
        assert_eq!(d.data, vec![2.0, 4.0]);
    }

    #[test]
    fn swd_is_zero_for_identical_textures_and_grows_with_difference() {
        let a = noise(64, 64, 1);
        let o = SwdOptions {
            samples: 1000,
            directions: 16,
            ..Default::default()
        };
        assert_eq!(patch_swd(&a, &a, &o).unwrap(), 0.0);
        // Another draw of the same process is close; a brighter, flatter texture is far.
        let b = noise(64, 64, 2);
        let flat = Texture::new(64, 64, 2, a.data.iter().map(|v| 0.5 * v + 0.4).collect()).unwrap();
        let (near, far) = (
            patch_swd(&a, &b, &o).unwrap(),
            patch_swd(&a, &flat, &o).unwrap(),
        );
        assert!(
            near > 0.0 && far > 3.0 * near,
            "same process {near}, different {far}"
        );
        // Symmetric.
        assert!((patch_swd(&b, &a, &o).unwrap() - near).abs() < 1e-9);
        assert!(patch_swd(&a, &noise(5, 5, 1), &o)
            .unwrap_err()
            .to_string()
            .contains("7×7"));
    }

    #[test]
    fn copy_ratio_sees_copies_and_only_copies() {
        let ex = noise(48, 48, 3);
        assert_eq!(verbatim_copy_ratio(&ex, &ex, 8).unwrap(), 1.0);
        // Block-shuffled exemplar: every 16×16 block is a copy.
        let sh = shuffled_blocks(&ex, 16);
        assert_eq!(verbatim_copy_ratio(&sh, &ex, 8).unwrap(), 1.0);
        // Blocks of 16 with copy windows of 24 cannot be covered except where neighbouring
        // blocks happen to stay neighbours.
        assert!(verbatim_copy_ratio(&sh, &ex, 24).unwrap() < 0.6);
        // An unrelated texture shares nothing.
        assert_eq!(verbatim_copy_ratio(&noise(48, 48, 4), &ex, 8).unwrap(), 0.0);
        // Half copied: the left half of the output is the exemplar's left half.
        let mut half = noise(48, 48, 5);
        for y in 0..48 {
            let i = y * 48 * 2;
            half.data[i..i + 48].copy_from_slice(&ex.data[i..i + 48]);
        }
        let r = verbatim_copy_ratio(&half, &ex, 8).unwrap();
        assert!((r - 0.5).abs() < 1e-9, "{r}");
    }

    #[test]
    fn seams_of_shuffled_blocks_score_worse() {
        let ex = noise(64, 64, 6);
        let base = seam_energy(&ex, 16).unwrap();
        let sh = seam_energy(&shuffled_blocks(&ex, 16), 16).unwrap();
        assert!(base.abs() < 0.3, "an unseamed texture: {base}");
        println!("seam energy: original {base}, shuffled blocks {sh}");
        assert!(sh > base + 0.5, "shuffled {sh} vs original {base}");
        // A linear ramp has the same difference everywhere: exactly 0.
        let ramp = Texture::new(
            32,
            32,
            1,
            (0..1024).map(|i| (i % 32 + i / 32) as f32).collect(),
        )
        .unwrap();
        assert_eq!(seam_energy(&ramp, 8).unwrap(), 0.0);
        assert!(seam_energy(&ex, 1).is_err());
    }
}
