//! A photograph as linear RGB (the sRGB transfer undone, IEC 61966-2-1) with bilinear sampling,
//! and its calibrated camera: the input of the resampling (Tarini et al. 2002 §3.2).

use crate::camera::Camera;
use crate::error::{PhotoError, Result};
use derma_core::color::{srgb_decode, srgb_encode};
use derma_core::image_io::read_rgb;
use glam::DVec2;
use std::path::Path;

/// A linear-RGB image, interleaved, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Linear RGB, `data[y * width + x]`.
    pub data: Vec<[f32; 3]>,
}

impl RgbImage {
    /// An image of one colour.
    pub fn filled(width: usize, height: usize, c: [f32; 3]) -> Self {
        Self {
            width,
            height,
            data: vec![c; width * height],
        }
    }

    /// Reads an image file; PNG/JPEG are sRGB-decoded to linear, EXR is taken as linear.
    pub fn read(path: &Path) -> Result<Self> {
        let img = read_rgb(path)?;
        let linear = !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let (w, h) = (img.channels[0].width(), img.channels[0].height());
        let [r, g, b] = [0, 1, 2].map(|c| img.channels[c].data());
        let f = |v: f32| if linear { srgb_decode(v) } else { v };
        Ok(Self {
            width: w,
            height: h,
            data: (0..w * h).map(|i| [f(r[i]), f(g[i]), f(b[i])]).collect(),
        })
    }

    /// Writes as 8-bit sRGB PNG (or linear EXR by extension), atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        let maps: Vec<derma_core::Map> = (0..3)
            .map(|c| {
                derma_core::Map::from_vec(
                    self.width,
                    self.height,
                    self.data.iter().map(|p| p[c]).collect(),
                )
            })
            .collect::<std::result::Result<_, _>>()?;
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
        {
            derma_core::image_io::write_exr(
                path,
                &[("R", &maps[0]), ("G", &maps[1]), ("B", &maps[2])],
                derma_core::image_io::ExrPrecision::F16,
            )?;
        } else {
            derma_core::image_io::write_png8_srgb(path, &[&maps[0], &maps[1], &maps[2]])?;
        }
        Ok(())
    }

    /// Bilinear sample at a pixel position (origin at the top-left corner; clamped at edges).
    pub fn sample(&self, p: DVec2) -> [f32; 3] {
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

    /// sRGB-encoded 8-bit quantisation of the image (what a camera's JPEG/PNG stores), decoded
    /// back to linear.
    pub fn quantised_8bit(&self) -> Self {
        let q = |v: f32| srgb_decode((srgb_encode(v.clamp(0.0, 1.0)) * 255.0).round() / 255.0);
        Self {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(|p| p.map(q)).collect(),
        }
    }
}

/// A photograph with its camera.
#[derive(Clone, Debug)]
pub struct Photo {
    /// Name (file name) for reports.
    pub name: String,
    /// The image, linear RGB.
    pub image: RgbImage,
    /// The calibrated camera.
    pub camera: Camera,
}

impl Photo {
    /// Checks that the image and camera agree in size.
    pub fn check(&self) -> Result<()> {
        if (self.image.width, self.image.height)
            != (self.camera.width as usize, self.camera.height as usize)
        {
            return Err(PhotoError::Camera {
                photo: self.name.clone(),
                detail: format!(
                    "the image is {}×{} but the camera was calibrated for {}×{}",
                    self.image.width, self.image.height, self.camera.width, self.camera.height
                ),
            });
        }
        Ok(())
    }
}
