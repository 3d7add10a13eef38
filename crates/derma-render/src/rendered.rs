//! One rendered frame, what every renderer returns (`Renderer` on a GPU,
//! [`crate::CpuRenderer`] without one): display and linear pixels and each pixel's material.

use derma_core::Map;

/// One rendered frame.
pub struct Rendered {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Tone-mapped sRGB, RGBA 8-bit, top row first.
    pub display: Vec<u8>,
    /// Scene-referred linear RGB radiance (0 on the background).
    pub linear: Vec<[f32; 3]>,
    /// What each pixel shows: [`crate::material::MATERIAL_SKIN`],
    /// [`crate::material::MATERIAL_EYE`] or [`crate::material::MATERIAL_OTHER`].
    pub material: Vec<u8>,
}

impl Rendered {
    /// The display image as three maps with values in [0, 1] (sRGB-encoded).
    pub fn display_maps(&self) -> [Map; 3] {
        let ch = |k: usize| {
            Map::from_fn(self.width, self.height, |i| {
                self.display[4 * i + k] as f32 / 255.0
            })
        };
        [ch(0), ch(1), ch(2)]
    }

    /// The display image decoded to linear light (the tone-mapped frame as linear maps), for
    /// sheets composed in linear light and encoded once.
    pub fn display_linear_maps(&self) -> [Map; 3] {
        let ch = |k: usize| {
            Map::from_fn(self.width, self.height, |i| {
                derma_core::color::srgb_decode(self.display[4 * i + k] as f32 / 255.0)
            })
        };
        [ch(0), ch(1), ch(2)]
    }

    /// The linear radiance as three maps.
    pub fn linear_maps(&self) -> [Map; 3] {
        let ch = |k: usize| Map::from_fn(self.width, self.height, |i| self.linear[i][k]);
        [ch(0), ch(1), ch(2)]
    }
}
