//! Interleaved images: `C` values per pixel, row-major with row 0 at the top, the companion of
//! the planar [`Map`] (one per channel); conversions between the two, sampling and crops.

use crate::color::{srgb_decode, srgb_encode};
use crate::error::Result;
use crate::image_io::{read_rgb, write_exr, write_png8_srgb, ExrPrecision};
use crate::Map;
use glam::DVec2;
use std::path::Path;

/// An image of `C`-channel pixels, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<const C: usize> {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Pixels, `data[y * width + x]`.
    pub data: Vec<[f32; C]>,
}

/// Three channels: linear RGB unless said otherwise.
pub type Rgb = Image<3>;

/// One channel, as an interleaved image (a pyramid's masks).
pub type Grey = Image<1>;

/// `n` zero pixels, written rather than calloc'ed: pages first touched by a read map the shared
/// zero page, and the write after it costs a copy-on-write fault with a TLB shootdown on every
/// core (measured in the photo bake: a third of its time).
pub fn zeroed<const C: usize>(n: usize) -> Vec<[f32; C]> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, [0.0; C]);
    v
}

impl<const C: usize> Image<C> {
    /// An image of zeros.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: zeroed(width * height),
        }
    }

    /// An image of one colour.
    pub fn filled(width: usize, height: usize, c: [f32; C]) -> Self {
        Self {
            width,
            height,
            data: vec![c; width * height],
        }
    }

    /// The image of `f(i)` for every pixel index i (row-major): sized by construction.
    pub fn from_fn(width: usize, height: usize, f: impl FnMut(usize) -> [f32; C]) -> Self {
        Self {
            width,
            height,
            data: (0..width * height).map(f).collect(),
        }
    }

    /// The interleaved image of `C` planar maps of one size (a map of another size is a bug of
    /// the caller, and panics).
    pub fn from_planes(planes: [&Map; C]) -> Self {
        let (w, h) = (planes[0].width(), planes[0].height());
        assert!(
            planes.iter().all(|m| (m.width(), m.height()) == (w, h)),
            "planes of different sizes"
        );
        Self::from_fn(w, h, |i| std::array::from_fn(|c| planes[c].data()[i]))
    }

    /// One planar map per channel.
    pub fn to_planes(&self) -> [Map; C] {
        Map::planes(self.width, self.height, |i| self.data[i])
    }

    /// Bilinear sample at a pixel position (origin at the top-left corner of the image, pixel
    /// centres at half-integers; clamped at the edges).
    pub fn sample(&self, p: DVec2) -> [f32; C] {
        let x = (p.x - 0.5).clamp(0.0, (self.width - 1) as f64);
        let y = (p.y - 0.5).clamp(0.0, (self.height - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let at = |x: usize, y: usize| self.data[y * self.width + x];
        let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
        std::array::from_fn(|k| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        })
    }

    /// The `w` × `h` pixels from (x0, y0), clamped at the right and bottom edges.
    pub fn crop(&self, x0: usize, y0: usize, w: usize, h: usize) -> Self {
        let (mx, my) = (self.width.saturating_sub(1), self.height.saturating_sub(1));
        Self::from_fn(w, h, |i| {
            let (x, y) = ((x0 + i % w.max(1)).min(mx), (y0 + i / w.max(1)).min(my));
            self.data[y * self.width + x]
        })
    }
}

impl Rgb {
    /// Reads an image file as linear RGB: PNG and JPEG are sRGB-decoded (IEC 61966-2-1), EXR is
    /// taken as linear.
    pub fn read_linear(path: &Path) -> Result<Self> {
        let img = read_rgb(path)?;
        let linear = !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let (w, h) = (img.channels[0].width(), img.channels[0].height());
        let [r, g, b] = [0, 1, 2].map(|c| img.channels[c].data());
        // 8-bit codes (code / 255 exactly) through the table, the same values as decoding.
        let f = |v: f32| {
            if !linear {
                return v;
            }
            let code = (v * 255.0).round().clamp(0.0, 255.0) as u8;
            if code as f32 / 255.0 == v {
                crate::color::srgb8_decode(code)
            } else {
                srgb_decode(v)
            }
        };
        Ok(Self::from_fn(w, h, |i| [f(r[i]), f(g[i]), f(b[i])]))
    }

    /// Writes linear RGB as 8-bit sRGB PNG (or half-float EXR by extension), atomically.
    pub fn write_linear(&self, path: &Path) -> Result<()> {
        let [r, g, b] = self.to_planes();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
        {
            write_exr(path, &[("R", &r), ("G", &g), ("B", &b)], ExrPrecision::F16)
        } else {
            write_png8_srgb(path, &[&r, &g, &b])
        }
    }

    /// sRGB-encoded 8-bit quantisation of the image (what a camera's JPEG or PNG stores),
    /// decoded back to linear.
    pub fn quantised_srgb8(&self) -> Self {
        let q = |v: f32| srgb_decode((srgb_encode(v.clamp(0.0, 1.0)) * 255.0).round() / 255.0);
        Self {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(|p| p.map(q)).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_round_trip_and_samples_interpolate() {
        let img = Rgb::from_fn(4, 3, |i| [i as f32, 2.0 * i as f32, -(i as f32)]);
        let planes = img.to_planes();
        assert_eq!(planes[1].get(3, 2), 22.0);
        assert_eq!(Rgb::from_planes([&planes[0], &planes[1], &planes[2]]), img);
        // Halfway between pixel centres (0, 0) and (1, 0): the mean.
        assert_eq!(img.sample(DVec2::new(1.0, 0.5)), [0.5, 1.0, -0.5]);
        let c = img.crop(2, 1, 3, 3);
        assert_eq!(c.data[0], img.data[6]);
        assert_eq!(
            c.data[2], img.data[7],
            "columns past the edge repeat the last"
        );
        assert_eq!(
            c.data[8], img.data[11],
            "rows past the edge repeat the last"
        );
    }
}
