//! Statistics of a texture set by region: mean CIELAB (D65) and ITA° of the base colour
//! and the standard deviation of its coarse (block-averaged) variation — the figures the
//! regional biology is checked against (Chardon et al. 1991 for ITA°). They measure the skin's
//! own colour, as a colorimeter on shaven skin does: hair (follicle stalks, brow hairs, stubble)
//! is unmixed from the base colour, and texels that are almost all hair are left out.

use crate::regional::ita_deg;
use crate::TextureSet;
use derma_core::color::{linear_srgb_to_xyz, srgb8_decode, xyz_to_lab};

/// Mean colour of one region.
#[derive(Clone, Debug, PartialEq)]
pub struct RegionColor {
    /// Region (a field of the set: a derma-head region name).
    pub region: String,
    /// Mean CIELAB (D65) of the texels' base colour (L*, a*, b* averaged in Lab).
    pub lab: [f64; 3],
    /// ITA° of the mean.
    pub ita_deg: f64,
    /// Texels averaged.
    pub texels: usize,
}

/// Hair coverage above which a texel's skin is not measured (its unmixed colour would amplify
/// the base colour's 8-bit steps more than twentyfold).
const MOSTLY_HAIR: f32 = 0.95;

/// Lab of the skin of every texel: the base colour with the hair composited over it (coverage
/// α, colour h: base = skin + (h − skin)·α) unmixed, skin = (base − α·h) / (1 − α).
fn lab_map(set: &TextureSet) -> Vec<[f64; 3]> {
    set.render
        .base_color
        .iter()
        .zip(&set.bio.texels)
        .map(|(c, t)| {
            let a = t.extra[3].clamp(0.0, MOSTLY_HAIR) as f64;
            let skin: [f64; 3] = std::array::from_fn(|k| {
                ((srgb8_decode(c[k]) as f64 - a * t.extra[k] as f64) / (1.0 - a)).max(0.0)
            });
            xyz_to_lab(linear_srgb_to_xyz(skin))
        })
        .collect()
}

/// Texels where the field `region` exceeds 0.7, the surface is covered and the skin is not
/// almost all hair.
fn in_region(set: &TextureSet, region: &str) -> crate::Result<Vec<bool>> {
    let f = set.fields.scalar(region)?;
    let s = &set.surface;
    Ok((0..s.len())
        .map(|i| {
            let uv = s.uv(i);
            s.covered(i)
                && f.sample_uv(uv.x, uv.y, false) > 0.7
                && set.bio.texels[i].extra[3] < MOSTLY_HAIR
        })
        .collect())
}

/// Mean colour of each named region.
pub fn region_colors(set: &TextureSet, regions: &[&str]) -> crate::Result<Vec<RegionColor>> {
    let lab = lab_map(set);
    regions
        .iter()
        .map(|name| {
            let mask = in_region(set, name)?;
            let (mut sum, mut n) = ([0.0f64; 3], 0usize);
            for (l, _) in lab.iter().zip(&mask).filter(|(_, m)| **m) {
                for k in 0..3 {
                    sum[k] += l[k];
                }
                n += 1;
            }
            let mean = sum.map(|v| v / n.max(1) as f64);
            Ok(RegionColor {
                region: (*name).into(),
                lab: mean,
                ita_deg: ita_deg(mean),
                texels: n,
            })
        })
        .collect()
}

/// Standard deviation of L*, a*, b* over `region` after averaging the texels in blocks of about
/// `block_mm` (blocks wholly inside the region only): the coarse colour variation.
pub fn coarse_std(set: &TextureSet, region: &str, block_mm: f32) -> crate::Result<[f64; 3]> {
    let lab = lab_map(set);
    let mask = in_region(set, region)?;
    let s = &set.surface;
    let (w, h) = (s.width, s.height);
    // Texel size from the mean of the covered texels' areas.
    let (mut area, mut n) = (0.0f64, 0usize);
    for i in (0..s.len()).filter(|&i| mask[i]) {
        area += s.frame(i).texel_area(w, h) as f64;
        n += 1;
    }
    let texel_mm = (area / n.max(1) as f64).sqrt();
    let b = ((block_mm as f64 / texel_mm).round() as usize).max(1);
    let mut means: Vec<[f64; 3]> = Vec::new();
    for by in 0..h / b {
        for bx in 0..w / b {
            let idx: Vec<usize> = (0..b * b)
                .map(|k| (by * b + k / b) * w + bx * b + k % b)
                .collect();
            if idx.iter().all(|&i| mask[i]) {
                let mut m = [0.0f64; 3];
                for &i in &idx {
                    for c in 0..3 {
                        m[c] += lab[i][c] / idx.len() as f64;
                    }
                }
                means.push(m);
            }
        }
    }
    let k = means.len().max(1) as f64;
    let mean: [f64; 3] = [0, 1, 2].map(|c| means.iter().map(|m| m[c]).sum::<f64>() / k);
    Ok([0, 1, 2].map(|c| (means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / k).sqrt()))
}

/// Tilt statistics of the normal map over a region (degrees from the unperturbed normal).
#[derive(Clone, Debug, PartialEq)]
pub struct TiltStats {
    /// Median tilt (°).
    pub median_deg: f64,
    /// 90th percentile (°).
    pub p90_deg: f64,
    /// Share of texels tilted more than 2°.
    pub over_2deg: f64,
    /// Share of texels tilted more than 5°.
    pub over_5deg: f64,
}

/// Tilt of the tangent-space normal map from +Z over the texels of `region` (mask > 0.7).
pub fn normal_tilt(set: &TextureSet, region: &str) -> crate::Result<TiltStats> {
    let mask = in_region(set, region)?;
    let z = &set.render.normal;
    let mut t: Vec<f64> = (0..z.len())
        .filter(|&i| mask[i])
        .map(|i| {
            let nz = z[i][2] as f64 / 65535.0 * 2.0 - 1.0;
            nz.clamp(-1.0, 1.0).acos().to_degrees()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    let n = t.len().max(1) as f64;
    let q = |p: f64| {
        t.get(((t.len() as f64 - 1.0) * p).round() as usize)
            .copied()
            .unwrap_or(0.0)
    };
    Ok(TiltStats {
        median_deg: q(0.5),
        p90_deg: q(0.9),
        over_2deg: t.iter().filter(|&&d| d > 2.0).count() as f64 / n,
        over_5deg: t.iter().filter(|&&d| d > 5.0).count() as f64 / n,
    })
}
