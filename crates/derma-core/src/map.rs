//! Planar f32 maps: one channel per `Map`, row-major with row 0 at the top of the image
//! (image convention). The texture-space v coordinate increases upward (OpenGL), so v = 1 − (y+½)/h.

use crate::error::Result;

/// A single-channel, row-major `f32` image.
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

impl Map {
    /// A `width` × `height` map filled with `value`.
    pub fn filled(width: usize, height: usize, value: f32) -> Self {
        Self {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Wraps existing row-major data; fails when the length does not match the size.
    pub fn from_vec(width: usize, height: usize, data: Vec<f32>) -> Result<Self> {
        if data.len() != width * height {
            return Err(crate::Invalid::new(
                format!("the data of a {width}x{height} map"),
                format!("{} values", width * height),
                data.len(),
            )
            .into());
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// A map of `f(i)` for every texel index i (row-major): sized by construction.
    pub fn from_fn(width: usize, height: usize, f: impl FnMut(usize) -> f32) -> Self {
        Self {
            width,
            height,
            data: (0..width * height).map(f).collect(),
        }
    }

    /// As [`Map::from_fn`], the texels computed in parallel (each on its own, so the same bits
    /// at any thread count).
    pub fn from_par_fn(
        width: usize,
        height: usize,
        f: impl Fn(usize) -> f32 + Sync + Send,
    ) -> Self {
        use rayon::prelude::*;
        Self {
            width,
            height,
            data: (0..width * height).into_par_iter().map(f).collect(),
        }
    }

    /// A map whose rows `fill(y, row)` writes, rows in parallel.
    pub fn from_par_rows(
        width: usize,
        height: usize,
        fill: impl Fn(usize, &mut [f32]) + Sync + Send,
    ) -> Self {
        use rayon::prelude::*;
        let mut m = Self::filled(width, height, 0.0);
        if width > 0 {
            m.data
                .par_chunks_mut(width)
                .enumerate()
                .for_each(|(y, row)| fill(y, row));
        }
        m
    }

    /// `C` maps of `width` × `height` from interleaved texels: plane c holds `texel(i)[c]`.
    pub fn planes<const C: usize>(
        width: usize,
        height: usize,
        texel: impl Fn(usize) -> [f32; C],
    ) -> [Map; C] {
        let mut out: [Vec<f32>; C] = std::array::from_fn(|_| Vec::with_capacity(width * height));
        for i in 0..width * height {
            let t = texel(i);
            for c in 0..C {
                out[c].push(t[c]);
            }
        }
        out.map(|data| Self {
            width,
            height,
            data,
        })
    }

    /// Each texel through `f`.
    pub fn map(&self, f: impl Fn(f32) -> f32) -> Map {
        Self {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(|&v| f(v)).collect(),
        }
    }

    /// Texel by texel `f(self, other)` of two maps of one size. A map of another size is a bug
    /// of the caller, and panics.
    pub fn zip_map(&self, other: &Map, f: impl Fn(f32, f32) -> f32) -> Map {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "zip_map of maps of different sizes"
        );
        Self {
            width: self.width,
            height: self.height,
            data: self
                .data
                .iter()
                .zip(&other.data)
                .map(|(&a, &b)| f(a, b))
                .collect(),
        }
    }

    /// The `w` × `h` texels from (x0, y0), rows past the bottom edge repeating the last row and
    /// columns past the right edge the last column.
    pub fn crop(&self, x0: usize, y0: usize, w: usize, h: usize) -> Map {
        let (mx, my) = (self.width.saturating_sub(1), self.height.saturating_sub(1));
        Self::from_fn(w, h, |i| {
            self.get((x0 + i % w.max(1)).min(mx), (y0 + i / w.max(1)).min(my))
        })
    }

    /// Width in texels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in texels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// The texels, row-major from the top row.
    pub fn data(&self) -> &[f32] {
        &self.data
    }
    /// The texels, writable.
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }
    /// The texels, by value.
    pub fn into_vec(self) -> Vec<f32> {
        self.data
    }

    #[inline]
    /// The texel at column `x`, row `y`.
    pub fn get(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }
    #[inline]
    /// Sets the texel at column `x`, row `y`.
    pub fn set(&mut self, x: usize, y: usize, v: f32) {
        self.data[y * self.width + x] = v;
    }

    /// Bilinear sample at texture coordinates (u, v) ∈ [0, 1]², v up (OpenGL). With `wrap` the
    /// map is treated as periodic, otherwise coordinates are clamped to the edge texels.
    pub fn sample_uv(&self, u: f32, v: f32, wrap: bool) -> f32 {
        let fx = u * self.width as f32 - 0.5;
        let fy = (1.0 - v) * self.height as f32 - 0.5;
        self.sample_texel(fx, fy, wrap)
    }

    /// Bilinear sample at continuous texel coordinates (texel centres at integers).
    #[inline]
    pub fn sample_texel(&self, fx: f32, fy: f32, wrap: bool) -> f32 {
        self.at_taps(&Taps::texel(self.width, self.height, fx, fy, wrap))
    }

    /// The bilinear sample of `taps` (made for this map's size: maps of one size share them).
    #[inline]
    fn at_taps(&self, t: &Taps) -> f32 {
        t.blend(t.idx.map(|i| self.data[i]))
    }

    /// [`Map::sample_uv`] at the coordinates of `taps`, reusing their texels and weights when
    /// the map has the size they were made for (the same value either way).
    #[inline]
    pub fn sample(&self, taps: &Taps) -> f32 {
        if (self.width, self.height) == (taps.width, taps.height) {
            self.at_taps(taps)
        } else {
            self.sample_uv(taps.u, taps.v, taps.wrap)
        }
    }

    /// Resamples to a new size by bilinear filtering (area-averaging first when shrinking by more
    /// than 2×, so thin painted strokes are not lost).
    pub fn resized(&self, width: usize, height: usize) -> Map {
        if width == self.width && height == self.height {
            return self.clone();
        }
        let mut src = self.clone();
        while src.width >= 2 * width.max(1) * 2 && src.height >= 2 * height.max(1) * 2 {
            src = src.halved();
        }
        let sx = src.width as f32 / width as f32;
        let sy = src.height as f32 / height as f32;
        let mut out = Map::filled(width, height, 0.0);
        for y in 0..height {
            for x in 0..width {
                let fx = (x as f32 + 0.5) * sx - 0.5;
                let fy = (y as f32 + 0.5) * sy - 0.5;
                out.set(x, y, src.sample_texel(fx, fy, false));
            }
        }
        out
    }

    fn halved(&self) -> Map {
        let [m] = box_reduced(self.width, self.height, 2, |i| [self.data[i]]);
        m
    }

    /// Mean, minimum and maximum over the texels where `mask` (if given) is true.
    pub fn stats(&self, mask: Option<&[bool]>) -> MapStats {
        MapStats::of(
            self.data
                .iter()
                .enumerate()
                .filter(|(i, _)| mask.is_none_or(|m| m[*i]))
                .map(|(_, &v)| v),
        )
    }
}

impl MapStats {
    /// Mean (summed in f64, in order), minimum and maximum of `values`.
    pub fn of(values: impl IntoIterator<Item = f32>) -> MapStats {
        let mut sum = 0.0f64;
        let mut n = 0usize;
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for v in values {
            sum += v as f64;
            n += 1;
            lo = lo.min(v);
            hi = hi.max(v);
        }
        MapStats {
            mean: if n > 0 { sum / n as f64 } else { 0.0 },
            min: lo,
            max: hi,
            count: n,
        }
    }
}

/// `C` maps of (`width` / k) × (`height` / k) texels, each texel the mean of a k × k block of
/// `f(texel index)` over a row-major `width` × `height` grid (a partial last block row or column
/// is dropped), rows in parallel: thumbnails and decoded planes of any store of texels without
/// a full-size copy. k = 1 gives the values themselves.
pub fn box_reduced<const C: usize>(
    width: usize,
    height: usize,
    k: usize,
    f: impl Fn(usize) -> [f32; C] + Sync,
) -> [Map; C] {
    use rayon::prelude::*;
    let k = k.max(1);
    let (w, h) = (width / k, height / k);
    let mut out: [Vec<f32>; C] = std::array::from_fn(|_| vec![0.0; w * h]);
    if w * h == 0 {
        return std::array::from_fn(|_| Map::filled(w, h, 0.0));
    }
    let mut rows: Vec<[&mut [f32]; C]> = Vec::with_capacity(h);
    let mut its = out.each_mut().map(|v| v.chunks_mut(w));
    for _ in 0..h {
        rows.push(its.each_mut().map(|i| i.next().expect("rows")));
    }
    let norm = 1.0 / (k * k) as f32;
    rows.into_par_iter().enumerate().for_each(|(y, r)| {
        for x in 0..w {
            let mut acc = [0.0f32; C];
            for yy in y * k..(y + 1) * k {
                for xx in x * k..(x + 1) * k {
                    let v = f(yy * width + xx);
                    for c in 0..C {
                        acc[c] += v[c];
                    }
                }
            }
            for c in 0..C {
                r[c][x] = acc[c] * norm;
            }
        }
    });
    out.map(|data| Map {
        width: w,
        height: h,
        data,
    })
}

/// The four texels and the weights of one bilinear sample on maps of one size: several maps
/// sampled at the same point (the fields a texel reads) share the index arithmetic.
#[derive(Clone, Copy, Debug)]
pub struct Taps {
    idx: [usize; 4],
    tx: f32,
    ty: f32,
    width: usize,
    height: usize,
    u: f32,
    v: f32,
    wrap: bool,
}

impl Taps {
    /// The four texels (top left, top right, bottom left, bottom right) on row-major maps of
    /// the size the taps were made for.
    #[inline]
    pub fn texels(&self) -> [usize; 4] {
        self.idx
    }

    /// The bilinear blend of the four texels' values (in [`Taps::texels`] order): what any
    /// store of texels (encoded, interleaved) gives for the sample.
    #[inline]
    pub fn blend(&self, v: [f32; 4]) -> f32 {
        let top = v[0] + (v[1] - v[0]) * self.tx;
        let bot = v[2] + (v[3] - v[2]) * self.tx;
        top + (bot - top) * self.ty
    }

    /// The taps of texture coordinates (`u`, `v`) (v up) on `width` × `height` maps.
    #[inline]
    pub fn uv(width: usize, height: usize, u: f32, v: f32, wrap: bool) -> Taps {
        let fx = u * width as f32 - 0.5;
        let fy = (1.0 - v) * height as f32 - 0.5;
        Taps {
            u,
            v,
            ..Taps::texel(width, height, fx, fy, wrap)
        }
    }

    /// The taps of continuous texel coordinates (texel centres at integers).
    #[inline]
    fn texel(width: usize, height: usize, fx: f32, fy: f32, wrap: bool) -> Taps {
        // ⌊·⌋ by truncation and correction: avoids a libm call per sample on baseline x86-64.
        let floor = |f: f32| {
            let t = f as i64 as f32;
            if f < t {
                t - 1.0
            } else {
                t
            }
        };
        let (x0, y0) = (floor(fx), floor(fy));
        let (w, h) = (width as i64, height as i64);
        let idx = |x: i64, y: i64| -> usize {
            let (x, y) = if wrap {
                (x.rem_euclid(w), y.rem_euclid(h))
            } else {
                (x.clamp(0, w - 1), y.clamp(0, h - 1))
            };
            (y * w + x) as usize
        };
        let (xi, yi) = (x0 as i64, y0 as i64);
        Taps {
            idx: [
                idx(xi, yi),
                idx(xi + 1, yi),
                idx(xi, yi + 1),
                idx(xi + 1, yi + 1),
            ],
            tx: fx - x0,
            ty: fy - y0,
            width,
            height,
            // Texel coordinates back to (u, v), for maps of other sizes.
            u: (fx + 0.5) / width as f32,
            v: 1.0 - (fy + 0.5) / height as f32,
            wrap,
        }
    }
}

/// Summary statistics of a map.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct MapStats {
    /// Mean of the texels counted.
    pub mean: f64,
    /// Smallest texel counted.
    pub min: f32,
    /// Largest texel counted.
    pub max: f32,
    /// Number of texels counted.
    pub count: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_reduced_takes_block_means_and_drops_partial_blocks() {
        // A 5 × 4 grid of texel indices, two channels (i and −i), reduced by 2: 2 × 2 blocks.
        let [a, b] = box_reduced(5, 4, 2, |i| [i as f32, -(i as f32)]);
        assert_eq!((a.width(), a.height()), (2, 2));
        // Block (0, 0) holds texels 0, 1, 5, 6; block (1, 1) holds 12, 13, 17, 18.
        assert_eq!(a.data(), &[3.0, 5.0, 13.0, 15.0]);
        assert_eq!(b.data(), &[-3.0, -5.0, -13.0, -15.0]);
        let [same] = box_reduced(3, 2, 1, |i| [i as f32 * 0.5]);
        assert_eq!(same.data(), &[0.0, 0.5, 1.0, 1.5, 2.0, 2.5]);
        // A factor beyond a side leaves no whole block: an empty map, not a panic.
        let [none] = box_reduced(3, 8, 4, |i| [i as f32]);
        assert_eq!((none.width(), none.height()), (0, 2));
    }

    #[test]
    fn bilinear_reproduces_texel_centres_and_midpoints() {
        let m = Map::from_vec(2, 1, vec![0.0, 1.0]).unwrap();
        assert_eq!(m.sample_uv(0.25, 0.5, false), 0.0);
        assert_eq!(m.sample_uv(0.75, 0.5, false), 1.0);
        assert!((m.sample_uv(0.5, 0.5, false) - 0.5).abs() < 1e-6);
        // wrapping: halfway between the last and the first texel
        assert!((m.sample_uv(0.0, 0.5, true) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn resize_preserves_constant_and_mean() {
        let m = Map::filled(64, 32, 0.3);
        let r = m.resized(7, 5);
        assert!(r.data().iter().all(|&v| (v - 0.3).abs() < 1e-6));
        let mut g = Map::filled(64, 64, 0.0);
        for y in 0..64 {
            for x in 0..64 {
                g.set(x, y, x as f32 / 63.0);
            }
        }
        let r = g.resized(8, 8);
        assert!((r.stats(None).mean - 0.5).abs() < 0.02);
    }

    #[test]
    fn from_vec_rejects_wrong_length() {
        assert!(Map::from_vec(3, 3, vec![0.0; 8]).is_err());
    }
}
