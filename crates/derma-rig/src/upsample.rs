//! Bilinear upsampling of the low-resolution basis maps, the way a GPU samples a texture with
//! clamp-to-edge addressing and texel centres at half-integers (Jimenez et al. 2010 §4.2, §6).
//!
//! Rows are produced one at a time from precomputed column taps, so evaluation streams through
//! the full-resolution maps with two source rows in cache.

use derma_core::Map;
use rayon::prelude::*;

/// Source taps of one output coordinate: the two neighbours and the weight of the second.
#[derive(Clone, Copy, Debug)]
pub struct Tap {
    /// First source index.
    pub i0: u32,
    /// Second source index.
    pub i1: u32,
    /// Weight of the second.
    pub t: f32,
}

/// Taps for resampling `src` texels onto `dst` texels along one axis.
pub fn taps(src: usize, dst: usize) -> Vec<Tap> {
    let s = src as f64 / dst as f64;
    (0..dst)
        .map(|x| {
            let f = ((x as f64 + 0.5) * s - 0.5).clamp(0.0, (src - 1) as f64);
            let i0 = (f.floor() as usize).min(src - 1);
            let i1 = (i0 + 1).min(src - 1);
            Tap {
                i0: i0 as u32,
                i1: i1 as u32,
                t: (f - i0 as f64) as f32,
            }
        })
        .collect()
}

/// Taps that extrapolate linearly from the two outermost source texels beyond their centres
/// (instead of holding the edge value): for smooth fields such as local statistics.
pub fn taps_extrapolating(src: usize, dst: usize) -> Vec<Tap> {
    if src < 2 {
        return taps(src, dst);
    }
    let s = src as f64 / dst as f64;
    (0..dst)
        .map(|x| {
            let f = (x as f64 + 0.5) * s - 0.5;
            let i0 = (f.floor().max(0.0) as usize).min(src - 2);
            Tap {
                i0: i0 as u32,
                i1: i0 as u32 + 1,
                t: (f - i0 as f64) as f32,
            }
        })
        .collect()
}

/// A bilinear upsampler from a `src_w × src_h` grid to `dst_w × dst_h`.
#[derive(Clone, Debug)]
pub struct Upsampler {
    /// Source size (w, h).
    pub src: (usize, usize),
    /// Output size (w, h).
    pub dst: (usize, usize),
    /// Taps per output column.
    pub cols: Vec<Tap>,
    /// Taps per output row.
    pub rows: Vec<Tap>,
}

impl Upsampler {
    /// An upsampler from `src` to `dst` that holds edge values.
    pub fn new(src: (usize, usize), dst: (usize, usize)) -> Self {
        Self {
            src,
            dst,
            cols: taps(src.0, dst.0),
            rows: taps(src.1, dst.1),
        }
    }

    /// As [`Upsampler::new`], but extrapolating linearly at the borders.
    pub fn new_extrapolating(src: (usize, usize), dst: (usize, usize)) -> Self {
        Self {
            src,
            dst,
            cols: taps_extrapolating(src.0, dst.0),
            rows: taps_extrapolating(src.1, dst.1),
        }
    }

    /// Horizontal pass only: every source row resampled to the output width (`src.1 × dst.0`).
    /// With it, each output row is a contiguous lerp of two wide rows ([`Self::row_of_wide`]),
    /// which vectorises, instead of a gather per texel.
    pub fn widen(&self, map: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0f32; self.src.1 * self.dst.0];
        self.widen_into(map, &mut out);
        out
    }

    /// [`Self::widen`] into a caller's buffer (reused across frames: no page faults).
    pub fn widen_into(&self, map: &[f32], out: &mut [f32]) {
        let sw = self.src.0;
        let dw = self.dst.0;
        out.par_chunks_mut(dw).enumerate().for_each(|(j, row)| {
            let src = &map[j * sw..(j + 1) * sw];
            for (o, c) in row.iter_mut().zip(&self.cols) {
                let (p, q) = (src[c.i0 as usize], src[c.i1 as usize]);
                *o = p + (q - p) * c.t;
            }
        });
    }

    /// Output row `y` from a [`Self::widen`]ed map.
    #[inline]
    pub fn row_of_wide(&self, wide: &[f32], y: usize, out: &mut [f32]) {
        let dw = self.dst.0;
        let r = self.rows[y];
        let (a, b) = (
            &wide[r.i0 as usize * dw..][..dw],
            &wide[r.i1 as usize * dw..][..dw],
        );
        for ((o, &p), &q) in out.iter_mut().zip(a).zip(b) {
            *o = p + (q - p) * r.t;
        }
    }

    /// The whole upsampled map.
    pub fn apply(&self, map: &Map) -> Map {
        debug_assert_eq!((map.width(), map.height()), self.src);
        let (w, h) = self.dst;
        let wide = self.widen(map.data());
        Map::from_par_rows(w, h, |y, row| self.row_of_wide(&wide, y, row))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_core_bilinear_sampler_and_reproduces_linear_ramps() {
        let src = Map::from_vec(4, 3, (0..12).map(|i| (i * i % 7) as f32).collect()).unwrap();
        let up = Upsampler::new((4, 3), (16, 9)).apply(&src);
        for y in 0..9 {
            for x in 0..16 {
                let fx = (x as f32 + 0.5) * 4.0 / 16.0 - 0.5;
                let fy = (y as f32 + 0.5) * 3.0 / 9.0 - 0.5;
                let want = src.sample_texel(fx, fy, false);
                assert!((up.get(x, y) - want).abs() < 1e-5, "({x},{y})");
            }
        }
        // A linear ramp stays linear inside (bilinear interpolation is exact for it).
        let ramp = Map::from_vec(8, 1, (0..8).map(|i| i as f32).collect()).unwrap();
        let up = Upsampler::new((8, 1), (64, 1)).apply(&ramp);
        for x in 8..56 {
            let want = (x as f32 + 0.5) / 8.0 - 0.5;
            assert!((up.get(x, 0) - want).abs() < 1e-5);
        }
    }
}
