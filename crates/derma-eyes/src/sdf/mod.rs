//! Screen-space distance fields (thesis ch. 4): for every pixel of the globes, the distance λ to
//! the nearest skin, from a material mask and a depth buffer — the thesis' three samplers
//! ([`samplers`]), two exact baselines it did not compare against ([`exact`]: Felzenszwalb &
//! Huttenlocher's linear-time transform; [`jfa`]: jump flooding), which drive the lacrimal lake
//! (derma-render's `lake`). [`scene`] renders the mask and depth of the built-in head's eye region.
//!
//! Distances are measured in the plane Ψ through the pixel parallel to the image plane (eq. 4.6):
//! a screen offset of d pixels at view depth z is d z / f millimetres, the same for every
//! method, so the exact transform is the reference for all of them.

pub mod exact;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod jfa;
pub mod samplers;
pub mod scene;
pub mod table;

/// Material ids of the mask (the thesis' M(u), one 8-bit channel): derma-render's.
pub mod material {
    /// Nothing drawn.
    pub const NONE: u8 = derma_render::material::MATERIAL_OTHER;
    /// Skin.
    pub const SKIN: u8 = derma_render::material::MATERIAL_SKIN;
    /// An eye globe.
    pub const EYE: u8 = derma_render::material::MATERIAL_EYE;
}

/// The G-buffer the fields are computed from.
#[derive(Clone, Debug)]
pub struct GBuffer {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// Material per pixel.
    pub mask: Vec<u8>,
    /// View depth z (mm, positive in front of the camera) per pixel; 0 where nothing is drawn.
    pub depth: Vec<f32>,
    /// Focal length (px).
    pub focal: f32,
}

impl GBuffer {
    /// Pixels per millimetre in Ψ at pixel `i` (f / z).
    #[inline]
    pub fn px_per_mm(&self, i: usize) -> f32 {
        self.focal / self.depth[i].max(1e-3)
    }

    /// True where the mask is skin.
    #[inline]
    pub fn skin(&self, x: i32, y: i32) -> bool {
        x >= 0
            && y >= 0
            && (x as usize) < self.width
            && (y as usize) < self.height
            && self.mask[y as usize * self.width + x as usize] == material::SKIN
    }
}

/// A distance field over the globe pixels: λ (mm; `f32::INFINITY` beyond the search range or
/// off the globes) and the texture accesses spent per pixel.
#[derive(Clone, Debug)]
pub struct Field {
    /// λ per pixel.
    pub distance: Vec<f32>,
    /// Mask, depth and intermediate-texture fetches per pixel.
    pub accesses: Vec<u32>,
}

impl Field {
    /// Mean accesses per texel over the pixels where `relevant` holds (the thesis counts the
    /// "area of relevancy": globe texels within the lake's range of the skin).
    pub fn accesses_per_texel(&self, relevant: &[bool]) -> f64 {
        let (mut s, mut n) = (0u64, 0u64);
        for (a, r) in self.accesses.iter().zip(relevant) {
            if *r {
                s += *a as u64;
                n += 1;
            }
        }
        s as f64 / n.max(1) as f64
    }
}

/// A per-pixel pseudo-random number in [0, 1) (a 32-bit integer hash of the pixel and a salt,
/// Jarzynski & Olano 2020's PCG-style hash), identical on CPU and GPU.
#[inline]
pub fn hash01(x: u32, y: u32, salt: u32) -> f32 {
    let mut v = x
        .wrapping_mul(1_664_525)
        .wrapping_add(y.wrapping_mul(22_695_477))
        .wrapping_add(salt.wrapping_mul(2_654_435_761));
    v = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let w = ((v >> ((v >> 28).wrapping_add(4))) ^ v).wrapping_mul(277_803_737);
    ((w >> 22) ^ w) as f32 * (1.0 / 4_294_967_296.0)
}

/// Error of `f` against the exact field `truth` over pixels where the truth is within `range`
/// (mm): mean |λ − λ*| as a percentage of the range (the thesis' "visual error" normalisation).
pub fn error_percent(f: &[f32], truth: &[f32], range: f32) -> f64 {
    let mut sum = 0.0f64;
    let mut n = 0u64;
    for (a, b) in f.iter().zip(truth) {
        if b.is_finite() && *b < range {
            let a = if a.is_finite() { a.min(range) } else { range };
            sum += (a - b).abs() as f64;
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        100.0 * sum / n as f64 / range as f64
    }
}
