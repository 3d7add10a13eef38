//! A painted set beside a photographed albedo of the same mesh (its UV layout), region by region:
//! mean CIELAB (D65), ΔE*ab between the means and the a* spread — S0 §6.2's side-by-side, in numbers.
//!
//! Both sides are measured as a camera sees them (hair included: a scan's albedo holds its
//! stubble), on the texels the mesh covers where the region's field exceeds 0.7. The a* spread is
//! the standard deviation of a* over the region after a [`SPREAD_BLUR_MM`] box blur, so it counts
//! blotches and erythema rather than pores, hairs or a photograph's noise.

use crate::regional::ita_deg;
use crate::{Result, TextureSet};
use derma_core::color::{linear_srgb_to_xyz, srgb8_decode, srgb_decode, xyz_to_lab};
use derma_core::image_io::LoadedImage;
use serde::Serialize;

/// The regions compared, as the issue of S0 §6.2's figure lists them plus lids, ears and chin.
pub const REGIONS: [&str; 10] = [
    "forehead",
    "periorbital",
    "eyelids",
    "nose",
    "cheeks",
    "ears",
    "lips",
    "beard",
    "chin",
    "neck",
];

/// Side of the box blur before the a* spread (mm): about the size of the smallest erythema
/// blotch, above pores (≤ 0.25 mm) and single hairs.
pub const SPREAD_BLUR_MM: f64 = 2.0;

/// Field value above which a texel belongs to a region (as [`crate::color_stats`]).
const IN_REGION: f32 = 0.7;

/// One side's colour over a region.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RegionLab {
    /// Mean L*, a*, b* (averaged in Lab).
    pub lab: [f64; 3],
    /// Standard deviation of a* after the [`SPREAD_BLUR_MM`] blur.
    pub a_spread: f64,
}

/// The two sides over one region.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegionPair {
    /// Region (derma-head's name).
    pub region: String,
    /// Texels measured.
    pub texels: usize,
    /// The photographed albedo.
    pub photo: RegionLab,
    /// The painted set's base colour.
    pub derma: RegionLab,
    /// CIE 1976 ΔE*ab between the means.
    pub delta_e: f64,
}

/// The whole comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlbedoComparison {
    /// The photographed albedo's file.
    pub albedo: String,
    /// ITA° of the photo's mean cheek colour (Chardon et al. 1991): the preset to paint at.
    pub photo_cheek_ita_deg: f64,
    /// Per region, in [`REGIONS`]' order (regions the mesh does not show are left out).
    pub regions: Vec<RegionPair>,
    /// Median ΔE*ab over the regions.
    pub median_delta_e: f64,
}

/// CIE 1976 colour difference.
pub fn delta_e76(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Lab of an sRGB-encoded colour in [0, 1].
fn lab_of_encoded(rgb: [f32; 3]) -> [f64; 3] {
    xyz_to_lab(linear_srgb_to_xyz(
        rgb.map(|v| srgb_decode(v.clamp(0.0, 1.0)) as f64),
    ))
}

/// Per covered texel of the set, the Lab of the photo at the texel's UV and of the set's base
/// colour (`None` off the mesh).
fn lab_maps(set: &TextureSet, photo: &LoadedImage) -> Vec<Option<([f64; 3], [f64; 3])>> {
    let s = &set.surface;
    let ch = &photo.channels;
    (0..s.len())
        .map(|i| {
            if !s.covered(i) {
                return None;
            }
            let uv = s.uv(i);
            let p = [0, 1, 2].map(|k| ch[k].sample_uv(uv.x, uv.y, false));
            let c = set.render.base_color[i];
            let d = xyz_to_lab(linear_srgb_to_xyz(c.map(|v| srgb8_decode(v) as f64)));
            Some((lab_of_encoded(p), d))
        })
        .collect()
}

/// Box blur of `values` over a `side`-texel square, averaging only the texels where `values`
/// is `Some` (summed-area tables); `None` stays `None`.
pub fn masked_box_blur(
    values: &[Option<f64>],
    w: usize,
    h: usize,
    side: usize,
) -> Vec<Option<f64>> {
    let (mut sum, mut cnt) = (
        vec![0.0f64; (w + 1) * (h + 1)],
        vec![0u32; (w + 1) * (h + 1)],
    );
    for y in 0..h {
        for x in 0..w {
            let (v, n) = values[y * w + x].map_or((0.0, 0), |v| (v, 1));
            let (i, up, left, diag) = (
                (y + 1) * (w + 1) + x + 1,
                y * (w + 1) + x + 1,
                (y + 1) * (w + 1) + x,
                y * (w + 1) + x,
            );
            sum[i] = v + sum[up] + sum[left] - sum[diag];
            cnt[i] = n + cnt[up] + cnt[left] - cnt[diag];
        }
    }
    let r = side / 2;
    (0..w * h)
        .map(|i| {
            values[i]?;
            let (x, y) = (i % w, i / w);
            let (x0, y0, x1, y1) = (
                x.saturating_sub(r),
                y.saturating_sub(r),
                (x + r + 1).min(w),
                (y + r + 1).min(h),
            );
            let at = |x: usize, y: usize| y * (w + 1) + x;
            let s = sum[at(x1, y1)] - sum[at(x0, y1)] - sum[at(x1, y0)] + sum[at(x0, y0)];
            let n = cnt[at(x1, y1)] + cnt[at(x0, y0)] - cnt[at(x0, y1)] - cnt[at(x1, y0)];
            Some(s / n as f64)
        })
        .collect()
}

/// Mean Lab and blurred-a* spread of `side` (0 photo, 1 derma) over the texels of `mask`.
fn region_lab(labs: &[[f64; 3]], blurred_a: &[f64]) -> RegionLab {
    let n = labs.len().max(1) as f64;
    let lab = [0, 1, 2].map(|k| labs.iter().map(|l| l[k]).sum::<f64>() / n);
    let m = blurred_a.iter().sum::<f64>() / n;
    let a_spread = (blurred_a.iter().map(|a| (a - m).powi(2)).sum::<f64>() / n).sqrt();
    RegionLab { lab, a_spread }
}

/// Mean texel side (mm) over the texels of `mask`.
fn texel_mm(set: &TextureSet, mask: &[bool]) -> f64 {
    let s = &set.surface;
    let (mut area, mut n) = (0.0f64, 0usize);
    for i in (0..s.len()).filter(|&i| mask[i]) {
        area += s.frame(i).texel_area(s.width, s.height) as f64;
        n += 1;
    }
    (area / n.max(1) as f64).sqrt()
}

/// Compares `set` with `photo`, an albedo of the same mesh in the same UV layout (`name` is its
/// file, for the report). Regions of [`REGIONS`] that cover no texel are left out.
pub fn compare(set: &TextureSet, photo: &LoadedImage, name: &str) -> Result<AlbedoComparison> {
    let s = &set.surface;
    let (w, h) = (s.width, s.height);
    let labs = lab_maps(set, photo);
    let a_of = |side: usize| -> Vec<Option<f64>> {
        labs.iter()
            .map(|l| l.map(|(p, d)| [p, d][side][1]))
            .collect()
    };
    let all: Vec<bool> = labs.iter().map(Option::is_some).collect();
    let side = ((SPREAD_BLUR_MM / texel_mm(set, &all)).round() as usize).max(1) | 1;
    let blurred = [
        masked_box_blur(&a_of(0), w, h, side),
        masked_box_blur(&a_of(1), w, h, side),
    ];
    let mut regions = Vec::new();
    let mut cheek_ita = f64::NAN;
    for name in REGIONS {
        let f = set.fields.scalar(name)?;
        let idx: Vec<usize> = (0..s.len())
            .filter(|&i| {
                labs[i].is_some() && {
                    let uv = s.uv(i);
                    f.sample_uv(uv.x, uv.y, false) > IN_REGION
                }
            })
            .collect();
        if idx.is_empty() {
            continue;
        }
        let sides: [RegionLab; 2] = [0, 1].map(|k| {
            let l: Vec<[f64; 3]> = idx
                .iter()
                .map(|&i| {
                    let (p, d) = labs[i].unwrap();
                    [p, d][k]
                })
                .collect();
            let a: Vec<f64> = idx.iter().map(|&i| blurred[k][i].unwrap_or(0.0)).collect();
            region_lab(&l, &a)
        });
        if name == "cheeks" {
            cheek_ita = ita_deg(sides[0].lab);
        }
        regions.push(RegionPair {
            region: name.into(),
            texels: idx.len(),
            delta_e: delta_e76(sides[0].lab, sides[1].lab),
            photo: sides[0],
            derma: sides[1],
        });
    }
    let mut de: Vec<f64> = regions.iter().map(|r| r.delta_e).collect();
    de.sort_by(f64::total_cmp);
    let median_delta_e = match de.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => de[n / 2],
        n => 0.5 * (de[n / 2 - 1] + de[n / 2]),
    };
    Ok(AlbedoComparison {
        albedo: name.into(),
        photo_cheek_ita_deg: cheek_ita,
        regions,
        median_delta_e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{SkinConfig, SkinGenerator};
    use derma_core::map::Map;

    #[test]
    fn the_masked_blur_averages_only_the_texels_it_has() {
        let (w, h) = (13usize, 9usize);
        let values: Vec<Option<f64>> = (0..w * h)
            .map(|i| (i % 7 != 3).then(|| ((i * 37) % 11) as f64))
            .collect();
        let got = masked_box_blur(&values, w, h, 5);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let mut s = (0.0, 0);
                for yy in y.saturating_sub(2)..(y + 3).min(h) {
                    for xx in x.saturating_sub(2)..(x + 3).min(w) {
                        if let Some(v) = values[yy * w + xx] {
                            s = (s.0 + v, s.1 + 1);
                        }
                    }
                }
                match (values[i], got[i]) {
                    (None, g) => assert_eq!(g, None),
                    (Some(_), Some(g)) => assert!((g - s.0 / s.1 as f64).abs() < 1e-9, "{x},{y}"),
                    (Some(_), None) => panic!("lost {x},{y}"),
                }
            }
        }
    }

    /// The built-in head's base colour as a "photograph" of itself, optionally with its red
    /// raised by `red` (as an 8-bit sRGB image read back).
    fn photo_of(set: &TextureSet, red: f32) -> LoadedImage {
        let s = &set.surface;
        let ch = |k: usize| {
            Map::from_fn(s.width, s.height, |i| {
                let v = set.render.base_color[i][k] as f32 / 255.0;
                if k == 0 {
                    (v + red).min(1.0)
                } else {
                    v
                }
            })
        };
        LoadedImage {
            channels: vec![ch(0), ch(1), ch(2)],
            is_color: true,
            alpha: None,
        }
    }

    #[test]
    fn a_set_beside_itself_differs_by_nothing_and_a_redder_photo_by_its_redness() {
        let cfg = SkinConfig {
            size: 128,
            ..SkinConfig::default()
        };
        let set = SkinGenerator::new(cfg).threads(2).run().unwrap();
        let same = compare(&set, &photo_of(&set, 0.0), "self").unwrap();
        assert_eq!(same.regions.len(), REGIONS.len());
        for r in &same.regions {
            assert!(r.delta_e < 1e-6, "{}: {}", r.region, r.delta_e);
            assert!((r.photo.a_spread - r.derma.a_spread).abs() < 1e-9);
            assert!(r.texels > 0);
        }
        assert!(same.photo_cheek_ita_deg > 30.0 && same.photo_cheek_ita_deg < 60.0);
        let red = compare(&set, &photo_of(&set, 0.05), "redder").unwrap();
        for r in &red.regions {
            // More red: a* up, ΔE the size of that shift.
            let da = r.photo.lab[1] - r.derma.lab[1];
            assert!(
                da > 2.0 && r.delta_e >= da,
                "{}: Δa* {da}, ΔE {}",
                r.region,
                r.delta_e
            );
        }
        assert!(red.median_delta_e > 2.0);
    }
}
