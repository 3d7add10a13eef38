//! Band-limited value noise at physical scales for the baseline skin (thesis §5.3.1 adds "a bit
//! of noise to each parameter every pixel"; we use smooth lattice noise instead).
//!
//! Why not white per-texel noise: biological variation (melanin density, perfusion, epidermal
//! thickness) is spatially correlated over millimetres to centimetres, and white noise per texel
//! would make the skin depend on the output resolution — at 4096² it is fine grain, after
//! mip-mapping it averages away. Lattice noise whose wavelengths are set in millimetres makes a
//! patch and a face, at any resolution, show the same skin. Value noise with a C¹ smoothstep
//! interpolant (Perlin 1985; see Lagae et al. 2010, "A survey of procedural noise functions",
//! §3.1) concentrates its energy near the lattice frequency: three octaves give the band.

use crate::index::fast_floor;
use glam::Vec3;

/// Eight channels of noise in [0, 1] from one set of lattice look-ups.
pub const CHANNELS: usize = 8;

/// Philox stream of the baseline noise's seed (stable; the feature kinds use 1–7).
pub const NOISE_STREAM: u32 = 100;

/// Philox stream of the micro-relief's site jitter seed (features/relief.rs).
pub const RELIEF_STREAM: u32 = 101;

/// The seed of a noise from the skin's seed and its Philox stream (first lane of counter 0).
pub fn stream_seed(seed: u64, stream: u32) -> u32 {
    derma_core::rng::Philox::new(seed, stream).u32x4(0)[0]
}

/// One octave: lattice spacing and optional periods (in cells) for a tileable patch.
#[derive(Clone, Copy, Debug)]
struct Octave {
    inv_cell: f32,
    inv_cell_y: f32,
    weight: f32,
    period: [i32; 2],
    salt: u64,
}

/// Lattice values of the cells last used, one slot per octave (per thread).
#[derive(Default, Clone)]
pub struct NoiseCache {
    octaves: [CacheSlot; 3],
}

#[derive(Default, Clone, Copy)]
struct CacheSlot {
    key: Option<(i32, i32, i32)>,
    values: [[f32; CHANNELS]; 8],
}

/// Three-octave band-limited noise keyed by a seed.
#[derive(Clone, Debug)]
pub struct BandNoise {
    octaves: Vec<Octave>,
    seed: u64,
}

/// Octave weights ½, ⅓, ⅙ (coarsest first): most variation at the largest scale, like skin.
const WEIGHTS: [f32; 3] = [0.5, 1.0 / 3.0, 1.0 / 6.0];

#[inline]
fn mix64(mut z: u64) -> u64 {
    // SplitMix64 finaliser (Steele, Lea & Flood 2014).
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl BandNoise {
    /// `wavelengths_mm` coarse to fine; `period_mm` makes the noise tile with that period (the
    /// lattice spacing is adjusted so a whole number of cells fits).
    pub fn new(seed: u64, wavelengths_mm: [f32; 3], period_mm: Option<[f32; 2]>) -> Self {
        let octaves = wavelengths_mm
            .iter()
            .zip(WEIGHTS)
            .enumerate()
            .map(|(k, (&wl, weight))| {
                let wl = wl.max(1e-3);
                let (inv_cell, period) = match period_mm {
                    Some([px, py]) => {
                        // Same spacing on both axes would break the wrap unless it divides both.
                        let nx = (px / wl).round().max(1.0);
                        let ny = (py / wl).round().max(1.0);
                        (nx / px, [nx as i32, ny as i32])
                    }
                    None => (1.0 / wl, [0, 0]),
                };
                // On a non-square tileable patch y gets its own spacing so whole cells fit.
                let inv_cell_y = match period_mm {
                    Some([_, py]) => period[1] as f32 / py,
                    None => inv_cell,
                };
                Octave {
                    inv_cell,
                    inv_cell_y,
                    weight,
                    period,
                    salt: (k as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15),
                }
            })
            .collect();
        Self { octaves, seed }
    }

    #[inline]
    fn corner(&self, o: &Octave, mut x: i32, mut y: i32, z: i32) -> u64 {
        if o.period[0] > 0 {
            x = x.rem_euclid(o.period[0]);
            y = y.rem_euclid(o.period[1]);
        }
        // 21 bits per axis (±1 M cells ≥ ±1.5 km at the finest octave): no two cells share a key.
        let key = (x as u64 & 0x1f_ffff)
            | ((y as u64 & 0x1f_ffff) << 21)
            | ((z as u64 & 0x1f_ffff) << 42);
        mix64(key ^ self.seed.wrapping_mul(0xd6e8_feb8_6659_fd93) ^ o.salt)
    }

    /// Noise at `p` (mm); each channel in [0, 1] with mean ½.
    pub fn eval(&self, p: Vec3) -> [f32; CHANNELS] {
        self.eval_cached(p, &mut NoiseCache::default())
    }

    /// As [`BandNoise::eval`], reusing the lattice values of the previous call's cells: texels
    /// are visited in scanline order and cells are millimetres wide, so most calls hit.
    #[inline]
    pub fn eval_cached(&self, p: Vec3, cache: &mut NoiseCache) -> [f32; CHANNELS] {
        self.eval_inline(p, cache)
    }

    /// [`BandNoise::eval_cached`] at each point of `ps` (a row of texels), compiled for AVX2
    /// where the CPU has it: the eight channels of a corner are blended in one register. The
    /// same operations in the same order, so the same values.
    pub fn eval_many(&self, ps: &[Vec3], out: &mut [[f32; CHANNELS]], cache: &mut NoiseCache) {
        assert_eq!(ps.len(), out.len(), "one value per point");
        #[cfg(target_arch = "x86_64")]
        if derma_core::numerics::lanes::Avx2::detect().is_some() {
            // SAFETY: the CPU has AVX2 and FMA (detected just now).
            unsafe { self.eval_many_avx2(ps, out, cache) };
            return;
        }
        for (o, &p) in out.iter_mut().zip(ps) {
            *o = self.eval_inline(p, cache);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn eval_many_avx2(
        &self,
        ps: &[Vec3],
        out: &mut [[f32; CHANNELS]],
        cache: &mut NoiseCache,
    ) {
        for (o, &p) in out.iter_mut().zip(ps) {
            *o = self.eval_inline(p, cache);
        }
    }

    #[inline(always)]
    fn eval_inline(&self, p: Vec3, cache: &mut NoiseCache) -> [f32; CHANNELS] {
        let mut out = [0.0f32; CHANNELS];
        for (k, o) in self.octaves.iter().enumerate() {
            let q = Vec3::new(p.x * o.inv_cell, p.y * o.inv_cell_y, p.z * o.inv_cell);
            let (cx, cy, cz) = (
                fast_floor(q.x) as i32,
                fast_floor(q.y) as i32,
                fast_floor(q.z) as i32,
            );
            let slot = &mut cache.octaves[k];
            if slot.key != Some((cx, cy, cz)) {
                slot.key = Some((cx, cy, cz));
                for corner in 0..8 {
                    let (dx, dy, dz) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
                    let h = self.corner(o, cx + dx as i32, cy + dy as i32, cz + dz as i32);
                    for ch in 0..CHANNELS {
                        slot.values[corner][ch] =
                            ((h >> (8 * ch)) & 0xff) as f32 * (o.weight / 255.0);
                    }
                }
            }
            let f = q - Vec3::new(cx as f32, cy as f32, cz as f32);
            let s = f * f * (Vec3::splat(3.0) - 2.0 * f);
            let (sx, sy, sz) = (s.x, s.y, s.z);
            let w = [
                (1.0 - sx) * (1.0 - sy) * (1.0 - sz),
                sx * (1.0 - sy) * (1.0 - sz),
                (1.0 - sx) * sy * (1.0 - sz),
                sx * sy * (1.0 - sz),
                (1.0 - sx) * (1.0 - sy) * sz,
                sx * (1.0 - sy) * sz,
                (1.0 - sx) * sy * sz,
                sx * sy * sz,
            ];
            for corner in 0..8 {
                for ch in 0..CHANNELS {
                    out[ch] += w[corner] * slot.values[corner][ch];
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_smooth_bounded_and_tiles() {
        let n = BandNoise::new(3, [8.0, 2.0, 0.5], Some([20.0, 10.0]));
        for i in 0..200 {
            let p = Vec3::new(i as f32 * 0.173, i as f32 * 0.091, 0.0);
            let a = n.eval(p);
            assert!(a.iter().all(|v| (0.0..=1.0).contains(v)));
            // periodic in x by 20 mm and in y by 10 mm
            let b = n.eval(p + Vec3::new(20.0, 10.0, 0.0));
            for k in 0..CHANNELS {
                assert!((a[k] - b[k]).abs() < 1e-4, "not periodic at {p}");
            }
            // continuous: a 1 µm step changes little
            let c = n.eval(p + Vec3::new(0.001, 0.0, 0.0));
            assert!((a[0] - c[0]).abs() < 0.02);
        }
    }

    #[test]
    fn a_row_at_once_gives_each_point_s_bits() {
        // eval_many (AVX2 where the CPU has it) against eval, point by point, on a patch that
        // tiles and in open space, with steps within and across cells.
        for period in [None, Some([20.0, 10.0])] {
            let n = BandNoise::new(4, [8.0, 2.0, 0.5], period);
            let ps: Vec<Vec3> = (0..3000)
                .map(|i| Vec3::new(i as f32 * 0.0731 - 40.0, (i % 37) as f32 * 0.61, 0.2))
                .collect();
            let mut out = vec![[0.0; CHANNELS]; ps.len()];
            n.eval_many(&ps, &mut out, &mut NoiseCache::default());
            for (p, o) in ps.iter().zip(&out) {
                assert_eq!(o.map(f32::to_bits), n.eval(*p).map(f32::to_bits), "at {p}");
            }
        }
    }

    #[test]
    fn lattice_cells_get_distinct_values() {
        // Packing the cell key must not let two cells (negative coordinates included) collide:
        // collisions repeat lattice values and show as streaks.
        let n = BandNoise::new(1, [8.0, 2.0, 0.5], None);
        let o = n.octaves[0];
        let mut seen = std::collections::HashSet::new();
        for x in -40..40 {
            for y in -40..40 {
                for z in -2..2 {
                    assert!(
                        seen.insert(n.corner(&o, x, y, z)),
                        "cells collide at ({x}, {y}, {z})"
                    );
                }
            }
        }
    }

    #[test]
    fn variation_lives_at_the_stated_scales() {
        // Correlation between points 0.05 mm apart is high; 50 mm apart it is near zero.
        let n = BandNoise::new(9, [8.0, 2.0, 0.5], None);
        let (mut near, mut far, mut var) = (0.0f64, 0.0f64, 0.0f64);
        let m = 0.5f64;
        for i in 0..4000 {
            let p = Vec3::new((i % 97) as f32 * 3.7, (i / 97) as f32 * 4.1, 0.3);
            let a = n.eval(p)[1] as f64 - m;
            let b = n.eval(p + Vec3::new(0.05, 0.0, 0.0))[1] as f64 - m;
            let c = n.eval(p + Vec3::new(50.0, 0.0, 0.0))[1] as f64 - m;
            near += a * b;
            far += a * c;
            var += a * a;
        }
        assert!(near / var > 0.9, "near {}", near / var);
        assert!((far / var).abs() < 0.15, "far {}", far / var);
    }
}
