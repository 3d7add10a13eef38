//! A painted set beside a photographed albedo of the same mesh (its UV layout), region by region:
//! mean CIELAB (D65), ΔE*ab between the means and the a* spread — S0 §6.2's side-by-side, in numbers.
//!
//! Both sides are measured as a camera sees them (hair included: a scan's albedo holds its
//! stubble), on the texels the mesh covers where the region's field exceeds 0.7 and the photo
//! shows skin ([`photo_shows_skin`]: not dense hair, clothing or an atlas's empty space). The a* spread is
//! the standard deviation of a* over the region after a [`SPREAD_BLUR_MM`] box blur, so it counts
//! blotches and erythema rather than pores, hairs or a photograph's noise.

use crate::field::FieldSet;
use crate::regional::ita_deg;
use crate::surface::Surface;
use crate::Result;
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

/// Share of a region's texels the photo must show as skin for the region to count in the
/// median (a scan whose beard or shirt covers a region says nothing of its skin there).
pub const MIN_SKIN_SHARE: f64 = 0.5;

/// Whether a photographed colour can be skin: inside the gamut of measured human skin in
/// CIELAB — L* 25–85, a* 0–30, b* 0–35 (Chardon et al. 1991's ITA° range, −70° to 70°, and the
/// facial measurements of Xiao et al. 2017 and Wee et al. 2009 all fall inside; authored
/// bounds) — so dense dark hair, a yellow shirt or an atlas's black space is left out.
pub fn photo_shows_skin(lab: [f64; 3]) -> bool {
    (25.0..=85.0).contains(&lab[0])
        && (0.0..=30.0).contains(&lab[1])
        && (0.0..=35.0).contains(&lab[2])
}

/// L* below which a photo texel is an atlas's empty space; texels next to it are left out (a
/// seam's bilinear samples mix it in).
const EMPTY_L: f64 = 5.0;

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
    /// Texels measured (the photo shows skin there).
    pub texels: usize,
    /// Share of the region's covered texels where the photo shows skin.
    pub skin_share: f64,
    /// The photographed albedo.
    pub photo: RegionLab,
    /// The painted set's base colour.
    pub derma: RegionLab,
    /// CIE 1976 ΔE*ab between the means.
    pub delta_e: f64,
    /// The photo at the exposure that gives its cheeks and forehead derma's mean luminance
    /// ([`AlbedoComparison::exposure_gain`]): its mean Lab and ΔE*ab from derma's.
    pub photo_matched: [f64; 3],
    /// ΔE*ab between derma's mean and [`RegionPair::photo_matched`].
    pub delta_e_matched: f64,
}

/// What is compared of a painted set: its surface (texel → UV, coverage, texel size), its
/// fields (the regions) and its base colour (sRGB codes per texel).
#[derive(Clone, Copy)]
pub struct Painted<'a> {
    /// Texel → point on the mesh.
    pub surface: &'a Surface,
    /// The region fields.
    pub fields: &'a FieldSet,
    /// base_color.png's codes.
    pub base_color: &'a [[u8; 3]],
}

/// The whole comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlbedoComparison {
    /// The photographed albedo's file.
    pub albedo: String,
    /// ITA° of the photo's mean cheek colour (Chardon et al. 1991): the preset to paint at.
    pub photo_cheek_ita_deg: f64,
    /// ITA° of the photo's mean over cheeks and forehead, what `person.ita_deg` calibrates:
    /// the scan's own tone.
    pub photo_ita_deg: f64,
    /// Factor on the photo's linear RGB that gives its cheeks and forehead derma's mean
    /// luminance: 1 for an albedo at derma's exposure; a camera texture's unknown exposure.
    pub exposure_gain: f64,
    /// Per region, in [`REGIONS`]' order (regions the mesh does not show are left out).
    pub regions: Vec<RegionPair>,
    /// Median ΔE*ab over the regions whose skin share reaches [`MIN_SKIN_SHARE`].
    pub median_delta_e: f64,
    /// The same median at the matched exposure.
    pub median_delta_e_matched: f64,
}

/// CIE 1976 colour difference.
pub fn delta_e76(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Lab of a linear sRGB colour.
fn lab_of(rgb: [f32; 3]) -> [f64; 3] {
    xyz_to_lab(linear_srgb_to_xyz(rgb.map(f64::from)))
}

/// Relative luminance of a linear sRGB colour (ITU-R BT.709 weights).
fn luminance(rgb: [f32; 3]) -> f64 {
    0.2126 * rgb[0] as f64 + 0.7152 * rgb[1] as f64 + 0.0722 * rgb[2] as f64
}

/// One texel's two colours, linear sRGB (single precision: the comparison keeps one per texel).
#[derive(Clone, Copy)]
struct Texel {
    photo: [f32; 3],
    derma: [f32; 3],
}

/// Median of `v` (NaN when empty).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Per covered texel of the set, the Lab of the photo at the texel's UV and of the set's base
/// colour (`None` off the mesh, where the photo shows no skin, and next to an atlas's empty
/// space).
fn lab_maps(set: Painted, photo: &LoadedImage) -> Vec<Option<Texel>> {
    let s = &set.surface;
    let (w, h) = (s.width, s.height);
    let ch = &photo.channels;
    let photo_rgb: Vec<[f32; 3]> = (0..s.len())
        .map(|i| {
            let uv = s.uv(i);
            [0, 1, 2].map(|k| srgb_decode(ch[k].sample_uv(uv.x, uv.y, false).clamp(0.0, 1.0)))
        })
        .collect();
    let photo_l: Vec<f32> = photo_rgb.iter().map(|&c| lab_of(c)[0] as f32).collect();
    let near_empty = |i: usize| {
        let (x, y) = ((i % w) as isize, (i / w) as isize);
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (xx, yy) = (x + dx, y + dy);
                (0..w as isize).contains(&xx)
                    && (0..h as isize).contains(&yy)
                    && (photo_l[yy as usize * w + xx as usize] as f64) < EMPTY_L
            })
        })
    };
    (0..s.len())
        .map(|i| {
            if !s.covered(i) || !photo_shows_skin(lab_of(photo_rgb[i])) || near_empty(i) {
                return None;
            }
            let c = set.base_color[i].map(srgb8_decode);
            Some(Texel {
                photo: photo_rgb[i],
                derma: c,
            })
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

/// Mean Lab of `labs` and the spread (standard deviation) of `blurred_a`, one per texel.
fn region_lab(labs: &[[f64; 3]], blurred_a: &[f64]) -> RegionLab {
    let n = labs.len().max(1) as f64;
    let lab = [0, 1, 2].map(|k| labs.iter().map(|l| l[k]).sum::<f64>() / n);
    let m = blurred_a.iter().sum::<f64>() / n;
    let a_spread = (blurred_a.iter().map(|a| (a - m).powi(2)).sum::<f64>() / n).sqrt();
    RegionLab { lab, a_spread }
}

/// Mean texel side (mm) over the texels of `mask`.
fn texel_mm(set: Painted, mask: &[bool]) -> f64 {
    let s = &set.surface;
    let (mut area, mut n) = (0.0f64, 0usize);
    for i in (0..s.len()).filter(|&i| mask[i]) {
        area += s.frame(i).texel_area(s.width, s.height) as f64;
        n += 1;
    }
    (area / n.max(1) as f64).sqrt()
}

/// The texels of each region of [`REGIONS`] on the mesh, and of those where the photo shows skin.
fn region_texels(
    set: Painted,
    texels: &[Option<Texel>],
) -> Result<Vec<(&'static str, usize, Vec<usize>)>> {
    let s = &set.surface;
    let mut out = Vec::new();
    for name in REGIONS {
        let f = set.fields.scalar(name)?;
        let on_mesh: Vec<usize> = (0..s.len())
            .filter(|&i| {
                let uv = s.uv(i);
                s.covered(i) && f.sample_uv(uv.x, uv.y, false) > IN_REGION
            })
            .collect();
        let skin: Vec<usize> = on_mesh
            .iter()
            .copied()
            .filter(|&i| texels[i].is_some())
            .collect();
        if !skin.is_empty() {
            out.push((name, on_mesh.len(), skin));
        }
    }
    Ok(out)
}

/// The exposure gain on the photo that gives the texels `idx` derma's mean luminance.
fn exposure_gain(texels: &[Option<Texel>], idx: &[usize]) -> f64 {
    let (mut p, mut d) = (0.0, 0.0);
    for t in idx.iter().filter_map(|&i| texels[i]) {
        p += luminance(t.photo);
        d += luminance(t.derma);
    }
    if p > 0.0 {
        d / p
    } else {
        1.0
    }
}

/// Compares `set` with `photo`, an albedo of the same mesh in the same UV layout (`name` is its
/// file, for the report). Regions of [`REGIONS`] that cover no texel are left out.
pub fn compare(set: Painted, photo: &LoadedImage, name: &str) -> Result<AlbedoComparison> {
    let s = &set.surface;
    let (w, h) = (s.width, s.height);
    let texels = lab_maps(set, photo);
    let regions = region_texels(set, &texels)?;
    let tone: Vec<usize> = regions
        .iter()
        .filter(|r| r.0 == "cheeks" || r.0 == "forehead")
        .flat_map(|r| r.2.iter().copied())
        .collect();
    let gain = exposure_gain(&texels, &tone);
    // Per texel: the photo's Lab as given and at the matched exposure, and derma's.
    let lab32 = |c: [f32; 3]| lab_of(c).map(|v| v as f32);
    let labs: Vec<Option<[[f32; 3]; 3]>> = texels
        .iter()
        .map(|t| {
            t.map(|t| {
                [
                    lab32(t.photo),
                    lab32(t.photo.map(|c| c * gain as f32)),
                    lab32(t.derma),
                ]
            })
        })
        .collect();
    drop(texels);
    let all: Vec<bool> = labs.iter().map(Option::is_some).collect();
    let side = ((SPREAD_BLUR_MM / texel_mm(set, &all)).round() as usize).max(1) | 1;
    let blurred: Vec<Vec<Option<f64>>> = [0, 2]
        .iter()
        .map(|&k| {
            let a: Vec<Option<f64>> = labs.iter().map(|l| l.map(|l| l[k][1] as f64)).collect();
            masked_box_blur(&a, w, h, side)
        })
        .collect();
    let side_of = |idx: &[usize], k: usize, b: usize| {
        let l: Vec<[f64; 3]> = idx
            .iter()
            .map(|&i| labs[i].expect("a skin texel")[k].map(f64::from))
            .collect();
        let a: Vec<f64> = idx.iter().map(|&i| blurred[b][i].unwrap_or(0.0)).collect();
        region_lab(&l, &a)
    };
    let pairs: Vec<RegionPair> = regions
        .iter()
        .map(|(name, on_mesh, idx)| {
            let (photo, derma) = (side_of(idx, 0, 0), side_of(idx, 2, 1));
            let matched = side_of(idx, 1, 0).lab;
            RegionPair {
                region: (*name).into(),
                texels: idx.len(),
                skin_share: idx.len() as f64 / *on_mesh as f64,
                delta_e: delta_e76(photo.lab, derma.lab),
                photo_matched: matched,
                delta_e_matched: delta_e76(matched, derma.lab),
                photo,
                derma,
            }
        })
        .collect();
    let counted = |f: fn(&RegionPair) -> f64| {
        median(
            pairs
                .iter()
                .filter(|r| r.skin_share >= MIN_SKIN_SHARE)
                .map(f)
                .collect(),
        )
    };
    let mean_lab = |idx: &[usize]| {
        let n = idx.len().max(1) as f64;
        [0, 1, 2].map(|c| {
            idx.iter()
                .map(|&i| labs[i].expect("a skin texel")[0][c] as f64)
                .sum::<f64>()
                / n
        })
    };
    let cheeks: Vec<usize> = regions
        .iter()
        .filter(|r| r.0 == "cheeks")
        .flat_map(|r| r.2.iter().copied())
        .collect();
    Ok(AlbedoComparison {
        albedo: name.into(),
        photo_cheek_ita_deg: if cheeks.is_empty() {
            f64::NAN
        } else {
            ita_deg(mean_lab(&cheeks))
        },
        photo_ita_deg: if tone.is_empty() {
            f64::NAN
        } else {
            ita_deg(mean_lab(&tone))
        },
        exposure_gain: gain,
        median_delta_e: counted(|r| r.delta_e),
        median_delta_e_matched: counted(|r| r.delta_e_matched),
        regions: pairs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
