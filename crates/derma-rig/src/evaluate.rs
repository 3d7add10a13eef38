//! Rig evaluation (Jimenez et al. 2010 eq. 6 and §6): H = g · (Σ w_i bias_i + H_0 · Σ w_i scale_i)
//! with bias_0 = μ_n and scale_0 = 1, then colour from the skin-colour LUT indexed by
//! (∛C_m, ∛C_hd) (eq. 7).
//!
//! The weighted sums are formed at basis resolution and upsampled once per frame, which is
//! the same arithmetic as a shader that samples every basis texture bilinearly and sums (the
//! interpolation is linear). [`FramePlan`] is the real-time path: 8-bit sRGB RGBA out, the LUT
//! resampled once to 256 × 256 at output precision and the melanin index precomputed, since
//! melanin is static (§1).

use crate::basis::Rig;
use crate::error::{invalid, Result};
use crate::upsample::Upsampler;
use derma_core::color::srgb_encode;
use derma_core::Map;
use derma_shading::skin_color_lut::SkinColorLut;
use rayon::prelude::*;

/// Σ w_i bias_i and Σ w_i scale_i at basis resolution, both multiplied by the global scale `g`.
/// `w` holds w_0 (neutral) first.
pub fn combine(rig: &Rig, w: &[f32], g: f32) -> Result<(Map, Map)> {
    if w.len() != rig.targets.len() + 1 {
        return Err(invalid(
            "weights",
            format!(
                "{} weights for a rig with {} targets plus the neutral",
                w.len(),
                rig.targets.len()
            ),
        ));
    }
    let n = rig.neutral_mean.data().len();
    let mut bias: Vec<f32> = rig.neutral_mean.data().iter().map(|&m| w[0] * m).collect();
    let mut scale = vec![w[0]; n];
    for (t, &wi) in rig.targets.iter().zip(&w[1..]) {
        if wi == 0.0 {
            continue;
        }
        for ((b, s), (&tb, &ts)) in bias
            .iter_mut()
            .zip(scale.iter_mut())
            .zip(t.bias.data().iter().zip(t.scale.data()))
        {
            *b += wi * tb;
            *s += wi * ts;
        }
    }
    let (bw, bh) = rig.basis_size();
    Ok((
        Map::from_vec(bw, bh, bias.iter().map(|b| g * b).collect())?,
        Map::from_vec(bw, bh, scale.iter().map(|s| g * s).collect())?,
    ))
}

/// The hemoglobin map (dermal blood volume fraction) of weights `w` under global scale `g`,
/// clamped to [0, 1].
pub fn hemoglobin(rig: &Rig, w: &[f32], g: f32) -> Result<Map> {
    let (bias, scale) = combine(rig, w, g)?;
    let (fw, fh) = rig.size();
    let up = Upsampler::new(rig.basis_size(), (fw, fh));
    let mut out = vec![0.0f32; fw * fh];
    out.par_chunks_mut(fw).enumerate().for_each_init(
        || (vec![0.0f32; bias.width()], vec![0.0f32; fw]),
        |(scratch, srow), (y, row)| {
            up.row(bias.data(), y, scratch, row);
            up.row(scale.data(), y, scratch, srow);
            let h0 = &rig.h0.data()[y * fw..(y + 1) * fw];
            for ((o, &s), &d) in row.iter_mut().zip(srow.iter()).zip(h0) {
                *o = (*o + d * s).clamp(0.0, 1.0);
            }
        },
    );
    Ok(Map::from_vec(fw, fh, out)?)
}

/// Linear sRGB colour of hemoglobin `h` and melanin `melanin` through the LUT (bilinear, as a
/// GPU samples it).
pub fn color(h: &Map, melanin: &Map, lut: &SkinColorLut) -> Result<[Map; 3]> {
    if (h.width(), h.height()) != (melanin.width(), melanin.height()) {
        return Err(invalid(
            "melanin map",
            format!(
                "{}×{}; expected the hemoglobin map's {}×{}",
                melanin.width(),
                melanin.height(),
                h.width(),
                h.height()
            ),
        ));
    }
    let rgb: Vec<[f32; 3]> = h
        .data()
        .par_iter()
        .zip(melanin.data())
        .map(|(&hb, &m)| lut.lookup(m as f64, hb as f64).map(|c| c as f32))
        .collect();
    let (w, hh) = (h.width(), h.height());
    Ok([0, 1, 2].map(|k| Map::from_vec(w, hh, rgb.iter().map(|p| p[k]).collect()).expect("size")))
}

/// Cube root for x ≥ 0 to about 1e-4 relative: the exponent divided by three in the bit
/// pattern, then two Newton steps. Branch-free, so the frame loop vectorises.
#[inline(always)]
pub fn fast_cbrt(x: f32) -> f32 {
    let x = x.max(1e-12);
    let mut y = f32::from_bits(x.to_bits() / 3 + 709_921_077);
    y = (2.0 * y + x / (y * y)) * (1.0 / 3.0);
    (2.0 * y + x / (y * y)) * (1.0 / 3.0)
}

/// Levels of the resampled LUT per axis (8-bit output precision).
pub const FRAME_LUT_LEVELS: usize = 256;

/// Precomputed state for real-time frames of one rig and melanin map.
pub struct FramePlan {
    up: Upsampler,
    /// Melanin index u = round(∛(C_m / C_m,max) · 255) per texel.
    u_index: Vec<u8>,
    /// RGBA8 (sRGB) of the LUT at (u, v) = (i/255, j/255): `lut8[j * 256 + i]`.
    lut8: Vec<u32>,
    inv_blood_max: f32,
}

impl FramePlan {
    pub fn new(rig: &Rig, melanin: &Map, lut: &SkinColorLut) -> Result<Self> {
        let (w, h) = rig.size();
        if (melanin.width(), melanin.height()) != (w, h) {
            return Err(invalid(
                "melanin map",
                format!(
                    "{}×{}; expected the rig's {w}×{h}",
                    melanin.width(),
                    melanin.height()
                ),
            ));
        }
        let n = FRAME_LUT_LEVELS;
        let (mmax, bmax) = (lut.options.melanin_max, lut.options.blood_max);
        let u_index = melanin
            .data()
            .par_iter()
            .map(|&m| {
                let u = (m.max(0.0) as f64 / mmax).cbrt().min(1.0);
                (u * (n - 1) as f64 + 0.5) as u8
            })
            .collect();
        let lut8 = (0..n * n)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let u = i as f64 / (n - 1) as f64;
                let v = j as f64 / (n - 1) as f64;
                let c = lut.lookup(u * u * u * mmax, v * v * v * bmax);
                let q = |x: f64| (srgb_encode(x as f32).clamp(0.0, 1.0) * 255.0 + 0.5) as u32;
                q(c[0]) | (q(c[1]) << 8) | (q(c[2]) << 16) | (255 << 24)
            })
            .collect();
        Ok(Self {
            up: Upsampler::new(rig.basis_size(), (w, h)),
            u_index,
            lut8,
            inv_blood_max: (1.0 / bmax) as f32,
        })
    }

    /// Renders one frame into `out` (RGBA8 little-endian per texel, sRGB, row-major from the top).
    pub fn render(&self, rig: &Rig, w: &[f32], g: f32, out: &mut [u32]) -> Result<()> {
        let (fw, fh) = rig.size();
        if out.len() != fw * fh {
            return Err(invalid(
                "frame buffer",
                format!("{} texels; expected {}", out.len(), fw * fh),
            ));
        }
        let (bias, scale) = combine(rig, w, g)?;
        let k = self.inv_blood_max;
        let top = (FRAME_LUT_LEVELS - 1) as f32;
        out.par_chunks_mut(fw).enumerate().for_each_init(
            || {
                (
                    vec![0.0f32; bias.width()],
                    vec![0.0f32; fw],
                    vec![0.0f32; fw],
                    vec![0u32; fw],
                )
            },
            |(scratch, brow, srow, vrow), (y, row)| {
                self.up.row(bias.data(), y, scratch, brow);
                self.up.row(scale.data(), y, scratch, srow);
                let h0 = &rig.h0.data()[y * fw..(y + 1) * fw];
                // Vectorisable part: H, the cube root and the v index.
                for (((v, &b), &s), &d) in vrow.iter_mut().zip(brow.iter()).zip(srow.iter()).zip(h0)
                {
                    let t = ((b + d * s) * k).clamp(0.0, 1.0);
                    *v = (fast_cbrt(t) * top + 0.5) as u32;
                }
                let u = &self.u_index[y * fw..(y + 1) * fw];
                for ((o, &v), &u) in row.iter_mut().zip(vrow.iter()).zip(u) {
                    *o = self.lut8[((v.min(255) as usize) << 8) | u as usize];
                }
            },
        );
        Ok(())
    }
}

/// Unpacks an RGBA8 frame into three maps of encoded [0, 1] values (for writing a PNG).
pub fn unpack_rgba8(frame: &[u32], w: usize, h: usize) -> [Map; 3] {
    [0, 8, 16].map(|s| {
        Map::from_vec(
            w,
            h,
            frame
                .iter()
                .map(|p| ((p >> s) & 255) as f32 / 255.0)
                .collect(),
        )
        .expect("size")
    })
}
