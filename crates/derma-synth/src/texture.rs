//! A multi-channel texture with interleaved texels: what exemplar synthesis compares and copies
//! (albedo, height and normal of one texel side by side, so they stay registered).

use crate::error::{invalid, Result};
use derma_core::Map;

/// `width × height` texels of `channels` f32 values each, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// Values per texel.
    pub channels: usize,
    /// The values, texel-major.
    pub data: Vec<f32>,
}

impl Texture {
    /// A texture from interleaved values; fails when the length does not match the size.
    pub fn new(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Result<Self> {
        if width == 0 || height == 0 || channels == 0 || data.len() != width * height * channels {
            return Err(invalid(
                "texture",
                format!(
                    "{width}×{height}×{channels} needs {} values, got {}",
                    width * height * channels,
                    data.len()
                ),
            ));
        }
        Ok(Self {
            width,
            height,
            channels,
            data,
        })
    }

    /// Interleaves planar maps of equal size (one channel each).
    pub fn from_maps(maps: &[&Map]) -> Result<Self> {
        let first = maps
            .first()
            .ok_or_else(|| invalid("texture", "no channels given"))?;
        let (w, h) = (first.width(), first.height());
        if let Some(m) = maps.iter().find(|m| (m.width(), m.height()) != (w, h)) {
            return Err(invalid(
                "texture",
                format!(
                    "channel of {}×{} among channels of {w}×{h}",
                    m.width(),
                    m.height()
                ),
            ));
        }
        let c = maps.len();
        let mut data = vec![0.0f32; w * h * c];
        for (k, m) in maps.iter().enumerate() {
            for (i, &v) in m.data().iter().enumerate() {
                data[i * c + k] = v;
            }
        }
        Self::new(w, h, c, data)
    }

    /// Channel `k` as a planar map.
    pub fn channel(&self, k: usize) -> Map {
        Map::from_fn(self.width, self.height, |i| {
            self.data[i * self.channels + k]
        })
    }

    /// The texel at (x, y).
    #[inline]
    pub fn texel(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_interleave_and_come_back() {
        let a = Map::from_vec(2, 2, vec![1.0, 2.0, 3.0, 4.0]).unwrap();
        let b = Map::from_vec(2, 2, vec![5.0, 6.0, 7.0, 8.0]).unwrap();
        let t = Texture::from_maps(&[&a, &b]).unwrap();
        assert_eq!(t.texel(1, 0), &[2.0, 6.0]);
        assert_eq!(t.channel(1), b);
        assert!(Texture::from_maps(&[&a, &Map::filled(3, 2, 0.0)]).is_err());
        assert!(Texture::new(2, 2, 3, vec![0.0; 11])
            .unwrap_err()
            .to_string()
            .contains("12"));
    }
}
