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
    let (bw, bh) = rig.basis_size();
    let (mut bias, mut scale) = (vec![0.0f32; bw * bh], vec![0.0f32; bw * bh]);
    combine_into(rig, w, g, &mut bias, &mut scale)?;
    Ok((Map::from_vec(bw, bh, bias)?, Map::from_vec(bw, bh, scale)?))
}

/// [`combine`] into the caller's buffers (basis size each).
pub fn combine_into(
    rig: &Rig,
    w: &[f32],
    g: f32,
    bias: &mut [f32],
    scale: &mut [f32],
) -> Result<()> {
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
    let bw = rig.basis_size().0;
    for (b, &m) in bias.iter_mut().zip(rig.neutral_mean.data()) {
        *b = w[0] * m;
    }
    scale.fill(w[0]);
    let active: Vec<_> = rig
        .targets
        .iter()
        .zip(&w[1..])
        .filter(|(_, &wi)| wi != 0.0)
        .collect();
    // Row-parallel; each texel sums the targets in a fixed order (deterministic).
    bias.par_chunks_mut(bw)
        .zip(scale.par_chunks_mut(bw))
        .enumerate()
        .for_each(|(y, (brow, srow))| {
            for (t, &wi) in &active {
                let (tb, ts) = (
                    &t.bias.data()[y * bw..][..bw],
                    &t.scale.data()[y * bw..][..bw],
                );
                for ((b, s), (&pb, &ps)) in
                    brow.iter_mut().zip(srow.iter_mut()).zip(tb.iter().zip(ts))
                {
                    *b += wi * pb;
                    *s += wi * ps;
                }
            }
            for (b, s) in brow.iter_mut().zip(srow.iter_mut()) {
                *b *= g;
                *s *= g;
            }
        });
    Ok(())
}

/// The hemoglobin map (dermal blood volume fraction) of weights `w` under global scale `g`,
/// clamped to [0, 1].
pub fn hemoglobin(rig: &Rig, w: &[f32], g: f32) -> Result<Map> {
    let (bias, scale) = combine(rig, w, g)?;
    let (fw, fh) = rig.size();
    let up = Upsampler::new(rig.basis_size(), (fw, fh));
    let (wb, ws) = (up.widen(bias.data()), up.widen(scale.data()));
    let mut out = vec![0.0f32; fw * fh];
    out.par_chunks_mut(fw).enumerate().for_each_init(
        || vec![0.0f32; fw],
        |srow, (y, row)| {
            up.row_of_wide(&wb, y, row);
            up.row_of_wide(&ws, y, srow);
            let h0 = &rig.h0.data()[y * fw..(y + 1) * fw];
            for ((o, &s), &d) in row.iter_mut().zip(srow.iter()).zip(h0) {
                *o = (*o + d * s).clamp(0.0, 1.0);
            }
        },
    );
    Ok(Map::from_vec(fw, fh, out)?)
}

/// The weights of the neutral pose: w_0 = 1, every target 0.
pub fn neutral_weights(rig: &Rig) -> Vec<f32> {
    let mut w = vec![0.0; rig.targets.len() + 1];
    w[0] = 1.0;
    w
}

/// Linear sRGB colour of a frame whose hemoglobin is `h`: with the rig's skin (a rig built from
/// a texture set) the set's base colour re-shaded with H ([`crate::skin_response`]), else the
/// LUT's colour of (`melanin`, H).
pub fn frame_color(rig: &Rig, h: &Map, melanin: &Map, lut: &SkinColorLut) -> Result<[Map; 3]> {
    match &rig.skin {
        Some(s) => s.color(h, &hemoglobin(rig, &neutral_weights(rig), 1.0)?),
        None => color(h, melanin, lut),
    }
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
    Ok(Map::planes(w, hh, |i| rgb[i]))
}

/// Levels of the resampled LUT per axis (8-bit output precision).
pub const FRAME_LUT_LEVELS: usize = 256;

/// Rows of the frame LUT over t = H / C_hd,max ∈ [0, 1], linear in t (the cube root of eq. 7 is
/// folded into the rows): at a typical C_hd of 0.012 (t ≈ 0.04) one row moves ∛t by 0.37 of an
/// 8-bit level; 2048 × 256 RGBA8 entries = 2 MiB, cache-resident, one table read per texel.
pub const CBRT_STEPS: usize = 1 << 11;

/// Precomputed state for real-time frames of one rig and melanin map.
pub struct FramePlan {
    up: Upsampler,
    /// Melanin index u = round(∛(C_m / C_m,max) · 255) per texel.
    u_index: Vec<u8>,
    /// RGBA8 (sRGB) of the LUT at u = i/255 and t = H / C_hd,max = j / (CBRT_STEPS − 1):
    /// `lut8[j * 256 + i]` (the cube root of eq. 7 folded into the rows).
    lut8: Vec<u32>,
    inv_blood_max: f32,
    /// Per-frame buffers, kept so frames after the first allocate (and page-fault) nothing.
    scratch: Scratch,
}

#[derive(Default)]
struct Scratch {
    bias: Vec<f32>,
    scale: Vec<f32>,
    wide_bias: Vec<f32>,
    wide_scale: Vec<f32>,
}

/// One frame on `device` (resolved: `Auto` picks a hardware GPU when there is one): the
/// hemoglobin map, and with `melanin` its colour through `lut` (the CPU's exact path, or
/// `rig.wgsl` on the GPU). `w` holds w_0 first; `g` is the global scale.
pub fn evaluate_frame(
    rig: &Rig,
    lut: &SkinColorLut,
    w: &[f32],
    g: f32,
    melanin: Option<&Map>,
    device: derma_core::gpu::Device,
) -> Result<(Map, Option<[Map; 3]>)> {
    match device.resolve()? {
        #[cfg(feature = "gpu")]
        derma_core::gpu::Device::Gpu => {
            // Without melanin only the hemoglobin is wanted; colour with C_m = 0 is discarded.
            let zero;
            let m = match melanin {
                Some(m) => m,
                None => {
                    zero = Map::filled(rig.size().0, rig.size().1, 0.0);
                    &zero
                }
            };
            let (h, rgb) = crate::gpu_eval::GpuRig::new(rig, m, lut)?.render(w, g)?;
            Ok((h, melanin.is_some().then_some(rgb)))
        }
        _ => {
            let h = hemoglobin(rig, w, g)?;
            let rgb = melanin.map(|m| frame_color(rig, &h, m, lut)).transpose()?;
            Ok((h, rgb))
        }
    }
}

impl FramePlan {
    /// Prepares frames of `rig` coloured with `melanin` through `lut`.
    pub fn new(rig: &Rig, melanin: &Map, lut: &SkinColorLut) -> Result<Self> {
        let (w, h) = rig.size();
        rig.check_melanin(melanin)?;
        if rig.skin.is_some() {
            return Err(invalid(
                "rig",
                "built from a texture set: its frames keep the set's skin, which the LUT's real-time path does not serve; evaluate them with evaluate_frame",
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
        let lut8 = (0..CBRT_STEPS * n)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let u = i as f64 / (n - 1) as f64;
                let t = j as f64 / (CBRT_STEPS - 1) as f64;
                let c = lut.lookup(u * u * u * mmax, t * bmax);
                let q = |x: f64| (srgb_encode(x as f32).clamp(0.0, 1.0) * 255.0 + 0.5) as u32;
                q(c[0]) | (q(c[1]) << 8) | (q(c[2]) << 16) | (255 << 24)
            })
            .collect();
        Ok(Self {
            up: Upsampler::new(rig.basis_size(), (w, h)),
            u_index,
            lut8,
            inv_blood_max: (1.0 / bmax) as f32,
            scratch: Scratch::default(),
        })
    }

    /// Renders one frame into `out` (RGBA8 little-endian per texel, sRGB, row-major from the top).
    pub fn render(&mut self, rig: &Rig, w: &[f32], g: f32, out: &mut [u32]) -> Result<()> {
        let (fw, fh) = rig.size();
        if out.len() != fw * fh {
            return Err(invalid(
                "frame buffer",
                format!("{} texels; expected {}", out.len(), fw * fh),
            ));
        }
        if self.up.src != rig.basis_size() || self.up.dst != (fw, fh) {
            return Err(invalid("rig", "not the rig this frame plan was made for"));
        }
        let (bw, bh) = rig.basis_size();
        let sc = &mut self.scratch;
        sc.bias.resize(bw * bh, 0.0);
        sc.scale.resize(bw * bh, 0.0);
        sc.wide_bias.resize(bh * fw, 0.0);
        sc.wide_scale.resize(bh * fw, 0.0);
        combine_into(rig, w, g, &mut sc.bias, &mut sc.scale)?;
        self.up.widen_into(&sc.bias, &mut sc.wide_bias);
        self.up.widen_into(&sc.scale, &mut sc.wide_scale);
        let (wb, ws) = (&sc.wide_bias, &sc.wide_scale);
        let k = self.inv_blood_max * (CBRT_STEPS - 1) as f32;
        let top = (CBRT_STEPS - 1) as f32;
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        out.par_chunks_mut(fw).enumerate().for_each_init(
            || vec![0u32; fw],
            |vrow, (y, row)| {
                let h0 = &rig.h0.data()[y * fw..(y + 1) * fw];
                // Vectorised part: the basis rows interpolated vertically (the horizontal pass
                // is in `widen`), H, and its step in the cube-root table, rounded by the 2²³
                // trick (adding 2²³ leaves round(x) in the low mantissa bits; NaN → 0 by max).
                let r = self.up.rows[y];
                let (b0, b1) = (
                    &wb[r.i0 as usize * fw..][..fw],
                    &wb[r.i1 as usize * fw..][..fw],
                );
                let (s0, s1) = (
                    &ws[r.i0 as usize * fw..][..fw],
                    &ws[r.i1 as usize * fw..][..fw],
                );
                let u = &self.u_index[y * fw..(y + 1) * fw];
                let lut: &[u32; CBRT_STEPS * FRAME_LUT_LEVELS] =
                    self.lut8[..].try_into().expect("table size");
                let rows = RowInputs {
                    b0,
                    b1,
                    s0,
                    s1,
                    t: r.t,
                    h0,
                    u,
                    k,
                    top,
                };
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    // SAFETY: AVX2 was detected at run time just above.
                    unsafe { frame_row_avx2(&rows, lut, vrow, row) };
                    return;
                }
                frame_row(&rows, lut, vrow, row);
            },
        );
        Ok(())
    }
}

/// One output row's inputs.
struct RowInputs<'a> {
    b0: &'a [f32],
    b1: &'a [f32],
    s0: &'a [f32],
    s1: &'a [f32],
    t: f32,
    h0: &'a [f32],
    u: &'a [u8],
    k: f32,
    top: f32,
}

/// One row of a frame. The same arithmetic whatever the instruction set (no fused multiply-add
/// is enabled), so frames are bit-identical on every x86-64.
#[inline(always)]
fn frame_row_body(
    r: &RowInputs,
    lut: &[u32; CBRT_STEPS * FRAME_LUT_LEVELS],
    vrow: &mut [u32],
    row: &mut [u32],
) {
    // Vectorised part: the basis rows interpolated vertically (the horizontal pass is in
    // `widen`), H, and its step in the cube-root table, rounded by the 2²³ trick (adding 2²³
    // leaves round(x) in the low mantissa bits; NaN → 0 by max).
    let (t, k, top) = (r.t, r.k, r.top);
    let rows = r.b0.iter().zip(r.b1).zip(r.s0.iter().zip(r.s1));
    for ((v, &d), ((&p0, &p1), (&q0, &q1))) in vrow.iter_mut().zip(r.h0).zip(rows) {
        let b = p0 + (p1 - p0) * t;
        let s = q0 + (q1 - q0) * t;
        let h = ((b + d * s) * k).max(0.0).min(top);
        *v = (h + 8_388_608.0).to_bits() & (CBRT_STEPS as u32 - 1);
    }
    // One table read per texel (fixed-size table, masked index: no bounds check).
    for ((o, &v), &u) in row.iter_mut().zip(vrow.iter()).zip(r.u) {
        *o = lut[((v as usize) << 8 | u as usize) & (CBRT_STEPS * FRAME_LUT_LEVELS - 1)];
    }
}

fn frame_row(
    r: &RowInputs,
    lut: &[u32; CBRT_STEPS * FRAME_LUT_LEVELS],
    vrow: &mut [u32],
    row: &mut [u32],
) {
    frame_row_body(r, lut, vrow, row)
}

/// [`frame_row`] compiled for AVX2 (8 lanes, hardware gathers for the table).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn frame_row_avx2(
    r: &RowInputs,
    lut: &[u32; CBRT_STEPS * FRAME_LUT_LEVELS],
    vrow: &mut [u32],
    row: &mut [u32],
) {
    frame_row_body(r, lut, vrow, row)
}

/// Unpacks an RGBA8 frame into three maps of encoded [0, 1] values (for writing a PNG).
pub fn unpack_rgba8(frame: &[u32], w: usize, h: usize) -> [Map; 3] {
    [0, 8, 16].map(|s| Map::from_fn(w, h, |i| ((frame[i] >> s) & 255) as f32 / 255.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_row_kernel_is_bit_identical_to_the_generic_one() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("skipped: no AVX2 on this machine");
            return;
        }
        let n = 1000;
        let f = |i: usize, a: f32| 0.01 + 0.005 * ((i as f32 * a).sin());
        let (b0, b1): (Vec<f32>, Vec<f32>) = (0..n).map(|i| (f(i, 0.1), f(i, 0.13))).unzip();
        let (s0, s1): (Vec<f32>, Vec<f32>) =
            (0..n).map(|i| (1.0 + f(i, 0.2), 0.9 + f(i, 0.3))).unzip();
        let h0: Vec<f32> = (0..n).map(|i| f(i, 0.7) - 0.01).collect();
        let u: Vec<u8> = (0..n).map(|i| (i * 7 % 256) as u8).collect();
        let lut: Vec<u32> = (0..CBRT_STEPS * FRAME_LUT_LEVELS)
            .map(|i| (i as u32).wrapping_mul(2654435761))
            .collect();
        let lut: &[u32; CBRT_STEPS * FRAME_LUT_LEVELS] = lut[..].try_into().unwrap();
        let r = RowInputs {
            b0: &b0,
            b1: &b1,
            s0: &s0,
            s1: &s1,
            t: 0.37,
            h0: &h0,
            u: &u,
            k: 2047.0 / 0.32,
            top: 2047.0,
        };
        let (mut va, mut vb, mut a, mut b) =
            (vec![0u32; n], vec![0u32; n], vec![0u32; n], vec![0u32; n]);
        frame_row(&r, lut, &mut va, &mut a);
        unsafe { frame_row_avx2(&r, lut, &mut vb, &mut b) };
        assert_eq!(a, b);
        assert!(va.iter().any(|&v| v > 0));
    }
}
