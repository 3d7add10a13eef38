//! Local statistics of a hemoglobin map: mean and standard deviation in a disk of radius r around
//! each texel (Jimenez et al. 2010 §4.1, eq. 1, with f(u) = [‖u‖ ≤ r] / πr²).
//!
//! The disk is the digital disk (texels whose centres lie within r), summed from row spans over
//! row prefix sums of the moment maps Σm, Σm(H−c), Σm(H−c)², where m is an optional mask weight
//! and c the map's mean (subtracted against cancellation). The disk is clipped at the map border
//! and by the mask: the statistics are those of the texels that exist. At texel resolution this
//! costs O(r) per texel ([`local_stats_exact`]); [`local_stats`] and [`stats_on_grid`] keep the
//! cost bounded independent of r by summing the moments over blocks first and running the disk
//! on the coarsest power-of-two level where it still spans [`MIN_RHO`]–2·[`MIN_RHO`] blocks, then
//! interpolating the first and second moments bilinearly (error measured in docs/rig.md).

use crate::error::{invalid, Result, RigError};
use crate::upsample::Upsampler;
use derma_core::Map;
use rayon::prelude::*;

/// The disk is evaluated on the coarsest level where its radius is still at least this many
/// blocks (so at most 2·MIN_RHO + 1 spans per cell). Authored: 8 keeps the digital disk's area
/// within ~1 % of πρ² and the measured error of μ and σ small (docs/rig.md).
pub const MIN_RHO: f64 = 8.0;

/// Sums of the weight m, m·(H − c) and m·(H − c)² over the texels of each cell of a grid.
#[derive(Clone, Debug)]
pub struct Moments {
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// Texels per cell along x and y.
    pub block: (usize, usize),
    /// The offset c.
    pub offset: f64,
    /// Σ m per cell.
    pub m0: Vec<f64>,
    /// Σ m·(H − c) per cell.
    pub m1: Vec<f64>,
    /// Σ m·(H − c)² per cell.
    pub m2: Vec<f64>,
}

/// Local mean and standard deviation maps.
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    /// Local mean μ.
    pub mean: Map,
    /// Local standard deviation σ.
    pub sigma: Map,
}

fn check_mask(map: &Map, mask: Option<&Map>) -> Result<()> {
    if let Some(m) = mask {
        if (m.width(), m.height()) != (map.width(), map.height()) {
            return Err(RigError::Size {
                what: "mask".into(),
                got_w: m.width(),
                got_h: m.height(),
                want_w: map.width(),
                want_h: map.height(),
            });
        }
    }
    Ok(())
}

/// Moments of `map` summed over `bx × by` blocks (which must divide the map's size). Mask values
/// are clamped to [0, 1] and used as weights.
pub fn block_moments(map: &Map, mask: Option<&Map>, bx: usize, by: usize) -> Result<Moments> {
    check_mask(map, mask)?;
    let (w, h) = (map.width(), map.height());
    if bx == 0 || by == 0 || w % bx != 0 || h % by != 0 {
        return Err(invalid(
            "statistics block",
            format!("{bx}×{by} texels does not divide the {w}×{h} map"),
        ));
    }
    let weight = |i: usize| mask.map_or(1.0, |m| m.data()[i].clamp(0.0, 1.0) as f64);
    let (s, n) = (0..h)
        .into_par_iter()
        .map(|y| {
            let (mut s, mut n) = (0.0f64, 0.0f64);
            for x in 0..w {
                let i = y * w + x;
                let m = weight(i);
                s += m * map.data()[i] as f64;
                n += m;
            }
            (s, n)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let offset = if n > 0.0 { s / n } else { 0.0 };
    let (gw, gh) = (w / bx, h / by);
    let mut m0 = vec![0.0f64; gw * gh];
    let mut m1 = vec![0.0f64; gw * gh];
    let mut m2 = vec![0.0f64; gw * gh];
    m0.par_chunks_mut(gw)
        .zip(m1.par_chunks_mut(gw))
        .zip(m2.par_chunks_mut(gw))
        .enumerate()
        .for_each(|(j, ((r0, r1), r2))| {
            for y in j * by..(j + 1) * by {
                let row = &map.data()[y * w..(y + 1) * w];
                match mask {
                    None => {
                        for (i, cell) in row.chunks_exact(bx).enumerate() {
                            // f32 differences, f64 sums: the block sums stay exact enough and
                            // the loop vectorises.
                            let (mut a, mut b) = (0.0f64, 0.0f64);
                            for &v in cell {
                                let d = (v as f64) - offset;
                                a += d;
                                b += d * d;
                            }
                            r0[i] += bx as f64;
                            r1[i] += a;
                            r2[i] += b;
                        }
                    }
                    Some(mk) => {
                        let mrow = &mk.data()[y * w..(y + 1) * w];
                        for (i, (cell, mc)) in
                            row.chunks_exact(bx).zip(mrow.chunks_exact(bx)).enumerate()
                        {
                            for (&v, &m) in cell.iter().zip(mc) {
                                let m = m.clamp(0.0, 1.0) as f64;
                                let d = (v as f64) - offset;
                                r0[i] += m;
                                r1[i] += m * d;
                                r2[i] += m * d * d;
                            }
                        }
                    }
                }
            }
        });
    Ok(Moments {
        width: gw,
        height: gh,
        block: (bx, by),
        offset,
        m0,
        m1,
        m2,
    })
}

impl Moments {
    /// Sums 2 × 2 cells (both sizes must be even).
    fn coarsened(&self) -> Moments {
        let (w, h) = (self.width / 2, self.height / 2);
        let sum = |v: &[f64]| {
            let mut out = vec![0.0f64; w * h];
            out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let i = 2 * y * self.width + 2 * x;
                    *o = v[i] + v[i + 1] + v[i + self.width] + v[i + self.width + 1];
                }
            });
            out
        };
        Moments {
            width: w,
            height: h,
            block: (2 * self.block.0, 2 * self.block.1),
            offset: self.offset,
            m0: sum(&self.m0),
            m1: sum(&self.m1),
            m2: sum(&self.m2),
        }
    }

    /// Sums over the digital disk of radius `r` texels around each cell (cells whose centres lie
    /// within r of the cell's centre), clipped at the grid border.
    pub fn disk_sums(&self, r: f64) -> Moments {
        let (w, h) = (self.width, self.height);
        let (rx, ry) = (r / self.block.0 as f64, r / self.block.1 as f64);
        let reach = ry.floor() as isize;
        // Half-width of the disk's span in row offset dy: cells with (dx/rx)² + (dy/ry)² ≤ 1.
        let spans: Vec<(isize, isize)> = (-reach..=reach)
            .map(|dy| {
                let t = 1.0 - (dy as f64 / ry).powi(2);
                (dy, (rx * t.max(0.0).sqrt() + 1e-9).floor() as isize)
            })
            .collect();
        let prefix = |v: &[f64]| {
            let mut p = vec![0.0f64; h * (w + 1)];
            p.par_chunks_mut(w + 1).enumerate().for_each(|(y, row)| {
                let mut acc = 0.0;
                for x in 0..w {
                    acc += v[y * w + x];
                    row[x + 1] = acc;
                }
            });
            p
        };
        let (p0, p1, p2) = (prefix(&self.m0), prefix(&self.m1), prefix(&self.m2));
        let mut out = [
            vec![0.0f64; w * h],
            vec![0.0f64; w * h],
            vec![0.0f64; w * h],
        ];
        let [o0, o1, o2] = &mut out;
        o0.par_chunks_mut(w)
            .zip(o1.par_chunks_mut(w))
            .zip(o2.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, ((r0, r1), r2))| {
                for &(dy, hw) in &spans {
                    let yy = y as isize + dy;
                    if yy < 0 || yy >= h as isize {
                        continue;
                    }
                    let base = yy as usize * (w + 1);
                    let (q0, q1, q2) = (
                        &p0[base..base + w + 1],
                        &p1[base..base + w + 1],
                        &p2[base..base + w + 1],
                    );
                    for x in 0..w {
                        let a = (x as isize - hw).max(0) as usize;
                        let b = ((x as isize + hw) as usize).min(w - 1) + 1;
                        r0[x] += q0[b] - q0[a];
                        r1[x] += q1[b] - q1[a];
                        r2[x] += q2[b] - q2[a];
                    }
                }
            });
        let [m0, m1, m2] = out;
        Moments {
            m0,
            m1,
            m2,
            ..*self
        }
    }

    /// Mean and second central moment (about the mean, as E[(H−c)²] − (E[H−c])² is formed
    /// later) of each cell: (c + Σm·d / Σm, Σm·d / Σm, Σm·d² / Σm), with d = H − c. Cells without
    /// any weight get the map mean and zero spread.
    fn normalised(&self) -> Centred {
        let n = self.width * self.height;
        let mut e1 = vec![0.0f64; n];
        let mut e2 = vec![0.0f64; n];
        for i in 0..n {
            if self.m0[i] > 1e-9 {
                e1[i] = self.m1[i] / self.m0[i];
                e2[i] = self.m2[i] / self.m0[i];
            }
        }
        Centred {
            width: self.width,
            height: self.height,
            offset: self.offset,
            e1,
            e2,
        }
    }
}

/// Centred moments E[d] and E[d²] (d = H − offset) per cell.
struct Centred {
    width: usize,
    height: usize,
    offset: f64,
    e1: Vec<f64>,
    e2: Vec<f64>,
}

impl Centred {
    /// Bilinear interpolation of both moments onto a `w × h` grid, extrapolated linearly over
    /// the half cell at the border (where the clipped disk's statistics change fastest).
    fn upsampled(&self, w: usize, h: usize) -> Centred {
        let up = Upsampler::new_extrapolating((self.width, self.height), (w, h));
        let go = |v: &[f64]| {
            let m = Map::from_fn(self.width, self.height, |i| v[i] as f32);
            up.apply(&m).data().iter().map(|&x| x as f64).collect()
        };
        Centred {
            width: w,
            height: h,
            offset: self.offset,
            e1: go(&self.e1),
            e2: go(&self.e2),
        }
    }

    /// Mean and standard deviation.
    fn finish(&self) -> Stats {
        let (w, h) = (self.width, self.height);
        Stats {
            mean: Map::from_fn(w, h, |i| (self.offset + self.e1[i]) as f32),
            sigma: Map::from_fn(w, h, |i| {
                let (m, s) = (self.e1[i], self.e2[i]);
                (s - m * m).max(0.0).sqrt() as f32
            }),
        }
    }
}

fn check_radius(r: f64) -> Result<()> {
    if !(r.is_finite() && r >= 0.5) {
        return Err(invalid(
            "radius",
            format!("{r} texels; expected a finite radius of at least 0.5 texels"),
        ));
    }
    Ok(())
}

/// Exact statistics at every texel: the texel-resolution digital disk, O(r) per texel. The
/// reference for [`local_stats`] in tests and benchmarks.
pub fn local_stats_exact(map: &Map, mask: Option<&Map>, r: f64) -> Result<Stats> {
    check_radius(r)?;
    Ok(block_moments(map, mask, 1, 1)?
        .disk_sums(r)
        .normalised()
        .finish())
}

/// Centred moments E[d], E[d²] of the disk around each cell of a `gw × gh` grid of blocks, with
/// the disk evaluated on a coarser level when it spans more than 2·MIN_RHO blocks.
fn grid_moments(map: &Map, mask: Option<&Map>, r: f64, gw: usize, gh: usize) -> Result<Centred> {
    check_radius(r)?;
    let (w, h) = (map.width(), map.height());
    if gw == 0 || gh == 0 || w % gw != 0 || h % gh != 0 {
        return Err(invalid(
            "statistics grid",
            format!("{gw}×{gh} does not divide the {w}×{h} map evenly"),
        ));
    }
    let mut m = block_moments(map, mask, w / gw, h / gh)?;
    while r / (2 * m.block.0.max(m.block.1)) as f64 >= MIN_RHO
        && m.width % 2 == 0
        && m.height % 2 == 0
    {
        m = m.coarsened();
    }
    let c = m.disk_sums(r).normalised();
    if (c.width, c.height) == (gw, gh) {
        return Ok(c);
    }
    Ok(c.upsampled(gw, gh))
}

/// Statistics of the disk of radius `r` (texels of `map`) at the centres of a `gw × gh` grid of
/// blocks (which must divide the map): what the rig's basis stores (§6: 256² by default).
pub fn stats_on_grid(map: &Map, mask: Option<&Map>, r: f64, gw: usize, gh: usize) -> Result<Stats> {
    Ok(grid_moments(map, mask, r, gw, gh)?.finish())
}

/// Statistics at every texel in time bounded independently of r: blocks of the largest power of
/// two ≤ r / MIN_RHO that divides the map (1, i.e. exact, for r < 2·MIN_RHO), the disk on
/// block sums, and the moments interpolated bilinearly back to texels.
pub fn local_stats(map: &Map, mask: Option<&Map>, r: f64) -> Result<Stats> {
    check_radius(r)?;
    let (w, h) = (map.width(), map.height());
    let mut b = 1usize;
    while r / (2 * b) as f64 >= MIN_RHO && w % (2 * b) == 0 && h % (2 * b) == 0 {
        b *= 2;
    }
    let c = grid_moments(map, mask, r, w / b, h / b)?;
    if b == 1 {
        return Ok(c.finish());
    }
    Ok(c.upsampled(w, h).finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reproducible test map: smooth variation plus texel noise from an integer hash.
    pub(crate) fn test_map(w: usize, h: usize, seed: u32) -> Map {
        let hash = |i: u32| {
            let mut x = i.wrapping_mul(0x9E37_79B9) ^ seed.wrapping_mul(0x85EB_CA6B);
            x ^= x >> 15;
            x = x.wrapping_mul(0x2C1B_3C6D);
            x ^= x >> 12;
            (x & 0xFFFF) as f32 / 65535.0
        };
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                0.05 + 0.02 * (x * 0.05).sin() * (y * 0.03).cos() + 0.01 * hash(i as u32)
            })
            .collect();
        Map::from_vec(w, h, data).unwrap()
    }

    /// Brute force: every texel within r, by distance.
    fn brute(map: &Map, r: f64, x: usize, y: usize) -> (f64, f64) {
        let (mut s, mut s2, mut n) = (0.0, 0.0, 0.0);
        for yy in 0..map.height() {
            for xx in 0..map.width() {
                let d2 = (xx as f64 - x as f64).powi(2) + (yy as f64 - y as f64).powi(2);
                if d2 <= r * r {
                    let v = map.get(xx, yy) as f64;
                    s += v;
                    s2 += v * v;
                    n += 1.0;
                }
            }
        }
        let m = s / n;
        (m, (s2 / n - m * m).max(0.0).sqrt())
    }

    #[test]
    fn exact_matches_brute_force_disk_with_border_clipping() {
        let map = test_map(37, 29, 1);
        for r in [0.5, 1.0, 2.5, 7.0, 40.0] {
            let s = local_stats_exact(&map, None, r).unwrap();
            for (x, y) in [(0, 0), (5, 7), (36, 28), (18, 14), (36, 0)] {
                let (m, sd) = brute(&map, r, x, y);
                assert!(
                    (s.mean.get(x, y) as f64 - m).abs() < 1e-6,
                    "r {r} ({x},{y})"
                );
                assert!(
                    (s.sigma.get(x, y) as f64 - sd).abs() < 1e-6,
                    "r {r} ({x},{y})"
                );
            }
        }
    }

    #[test]
    fn mask_leaves_texels_out() {
        let map = test_map(20, 20, 2);
        let mut mask = Map::filled(20, 20, 1.0);
        let mut changed = map.clone();
        for y in 0..20 {
            for x in 10..20 {
                mask.set(x, y, 0.0);
                changed.set(x, y, 5.0);
            }
        }
        let a = local_stats_exact(&map, Some(&mask), 6.0).unwrap();
        let b = local_stats_exact(&changed, Some(&mask), 6.0).unwrap();
        for y in 0..20 {
            for x in 0..10 {
                assert!((a.mean.get(x, y) - b.mean.get(x, y)).abs() < 1e-6);
                assert!((a.sigma.get(x, y) - b.sigma.get(x, y)).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn pyramid_is_exact_below_its_threshold_and_close_above_it() {
        let map = test_map(256, 128, 3);
        let r = 2.0 * MIN_RHO - 1.0;
        assert_eq!(
            local_stats(&map, None, r).unwrap(),
            local_stats_exact(&map, None, r).unwrap()
        );
        for r in [24.0, 40.0, 70.0] {
            let a = local_stats(&map, None, r).unwrap();
            let e = local_stats_exact(&map, None, r).unwrap();
            // Errors relative to the map's local spread (≈ 0.014 here).
            let sd = e.sigma.stats(None).mean;
            let max_dm = a
                .mean
                .data()
                .iter()
                .zip(e.mean.data())
                .map(|(p, q)| (p - q).abs())
                .fold(0.0f32, f32::max);
            let max_ds = a
                .sigma
                .data()
                .iter()
                .zip(e.sigma.data())
                .map(|(p, q)| (p - q).abs())
                .fold(0.0f32, f32::max);
            // Block quantisation of the disk's rim (measured: docs/rig.md).
            let inner = (8..120)
                .flat_map(|y| (8..248).map(move |x| (x, y)))
                .map(|(x, y)| (a.mean.get(x, y) - e.mean.get(x, y)).abs())
                .fold(0.0f32, f32::max);
            println!(
                "r {r}: max |Δμ| inside {:.4} σ, anywhere {:.4} σ; max |Δσ| {:.4} σ",
                inner as f64 / sd,
                max_dm as f64 / sd,
                max_ds as f64 / sd
            );
            assert!(
                (inner as f64) < 0.03 * sd,
                "r {r}: inner mean error {inner} vs σ {sd}"
            );
            assert!(
                (max_dm as f64) < 0.08 * sd,
                "r {r}: mean error {max_dm} vs σ {sd}"
            );
            assert!(
                (max_ds as f64) < 0.08 * sd,
                "r {r}: σ error {max_ds} vs σ {sd}"
            );
        }
    }

    #[test]
    fn a_radius_covering_the_map_gives_global_statistics() {
        let map = test_map(64, 32, 4);
        let n = (64 * 32) as f64;
        let mean = map.data().iter().map(|&v| v as f64).sum::<f64>() / n;
        let sd = (map
            .data()
            .iter()
            .map(|&v| (v as f64 - mean).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        for s in [
            local_stats(&map, None, 200.0).unwrap(),
            local_stats_exact(&map, None, 200.0).unwrap(),
        ] {
            for &v in s.mean.data() {
                assert!((v as f64 - mean).abs() < 1e-6);
            }
            for &v in s.sigma.data() {
                assert!((v as f64 - sd).abs() < 1e-6);
            }
        }
        let g = stats_on_grid(&map, None, 200.0, 8, 4).unwrap();
        assert!((g.sigma.get(3, 2) as f64 - sd).abs() < 1e-6);
    }

    #[test]
    fn bad_inputs_are_named() {
        let map = test_map(10, 10, 5);
        let e = local_stats(&map, None, f64::NAN).unwrap_err().to_string();
        assert!(e.contains("radius"), "{e}");
        let e = stats_on_grid(&map, None, 4.0, 3, 3)
            .unwrap_err()
            .to_string();
        assert!(e.contains("3×3") && e.contains("10×10"), "{e}");
        let e = local_stats(&map, Some(&Map::filled(5, 5, 1.0)), 4.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("mask"), "{e}");
    }
}
