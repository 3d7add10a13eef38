//! Bio maps → the renderer's texture set (thesis §4.8.8, mmd(FEATURE(…))): base colour through an
//! [`Appearance`], roughness and specular from documented skin values modulated by lips and hair,
//! height and normal maps; dilation into the UV gutter; and the map files of [`crate::outputs`].

use crate::config::MaterialConfig;
use crate::outputs;
use crate::paint::{BioMaps, BIO_CHANNELS};
use crate::surface::Surface;
use derma_core::image_io::{self, ExrPrecision};
use derma_core::Map;
use derma_optics::bio::names;
use derma_shading::Appearance;
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::slice::ChunksMut;

/// Normal-incidence reflectance of hair keratin, n ≈ 1.55 (Stamm, Garcia & Fuchs 1977, "The optical
/// properties of human hair"): ((1.55 − 1)/(1.55 + 1))² = 0.0465.
pub const HAIR_F0: f32 = 0.0465;
pub use derma_core::preview::SPECULAR_SCALE;

/// The render maps, linear values.
pub struct RenderMaps {
    /// Diffuse albedo, linear sRGB.
    pub base_color: [Map; 3],
    /// glTF perceptual roughness.
    pub roughness: Map,
    /// F0 / 0.08.
    pub specular: Map,
    /// Tangent-space normal in [−1, 1].
    pub normal: [Map; 3],
    /// Displacement from the mean skin surface, mm.
    pub height_mm: Map,
    /// Subsurface maps, when the appearance provides them (the match table does).
    pub subsurface: Option<SubsurfaceMaps>,
}

/// Per-texel subsurface parameters (linear sRGB channels).
pub struct SubsurfaceMaps {
    /// Burley's surface albedo A (subsurface colour), linear.
    pub color: [Map; 3],
    /// Scatter distance (mean free path ℓ) in mm.
    pub radius_mm: [Map; 3],
}

/// sss_radius.png stores ℓ / SSS_RADIUS_RANGE_MM (16-bit): 0–8 mm, the radial profile's range.
pub const SSS_RADIUS_RANGE_MM: f32 = 8.0;

/// One row of three colour channels.
type RgbRow<'a> = [&'a mut [f32]; 3];
/// Three planar colour channels.
type RgbPlanes = [Vec<f32>; 3];

/// One row of every output channel of [`convert`], by name.
struct RowOut<'a> {
    base_color: [&'a mut [f32]; 3],
    roughness: &'a mut [f32],
    specular: &'a mut [f32],
    /// Subsurface colour and scatter distance, with a subsurface-aware appearance.
    subsurface: Option<(RgbRow<'a>, RgbRow<'a>)>,
}

/// Planar output channels of [`convert`].
struct Channels {
    base_color: [Vec<f32>; 3],
    roughness: Vec<f32>,
    specular: Vec<f32>,
    subsurface: Option<(RgbPlanes, RgbPlanes)>,
}

impl Channels {
    fn new(n: usize, subsurface: bool) -> Self {
        let three = || std::array::from_fn(|_| vec![0.0f32; n]);
        Self {
            base_color: three(),
            roughness: vec![0.0; n],
            specular: vec![0.0; n],
            subsurface: subsurface.then(|| (three(), three())),
        }
    }

    /// The channels cut into rows of `w` texels, each row holding its slice of every channel.
    fn rows(&mut self, w: usize) -> Vec<RowOut<'_>> {
        fn split3(c: &mut [Vec<f32>; 3], w: usize) -> [ChunksMut<'_, f32>; 3] {
            c.each_mut().map(|v| v.chunks_mut(w))
        }
        fn next3<'a>(it: &mut [ChunksMut<'a, f32>; 3]) -> [&'a mut [f32]; 3] {
            it.each_mut().map(|i| i.next().expect("rows"))
        }
        let mut base = split3(&mut self.base_color, w);
        let rough = self.roughness.chunks_mut(w);
        let mut spec = self.specular.chunks_mut(w);
        let mut sss = self
            .subsurface
            .as_mut()
            .map(|(c, r)| (split3(c, w), split3(r, w)));
        let mut rows = Vec::new();
        for roughness in rough {
            rows.push(RowOut {
                base_color: next3(&mut base),
                roughness,
                specular: spec.next().expect("rows"),
                subsurface: sss.as_mut().map(|(c, r)| (next3(c), next3(r))),
            });
        }
        rows
    }
}

/// Depth (mm) below the mean of its 3×3 neighbourhood at which a texel counts as fully inside a
/// cavity (furrows of the micro-relief, pores, wrinkles).
pub const CAVITY_DEPTH_MM: f32 = 0.02;

/// Cavity of every texel: how far it lies below the mean of its 3×3 neighbourhood, over
/// [`CAVITY_DEPTH_MM`], in [0, 1].
pub fn cavity(height_mm: &Map) -> Vec<f32> {
    let (w, h) = (height_mm.width(), height_mm.height());
    let d = height_mm.data();
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut sum = 0.0f32;
            for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    sum += d[yy * w + xx];
                }
            }
            let n = ((y + 1).min(h - 1) - y.saturating_sub(1) + 1)
                * ((x + 1).min(w - 1) - x.saturating_sub(1) + 1);
            ((sum / n as f32 - d[i]) / CAVITY_DEPTH_MM).clamp(0.0, 1.0)
        })
        .collect()
}

/// Roughness and specular occlusion in cavities: inside a furrow the walls hide part of the
/// specular lobe (specular occlusion, as Jimenez et al. 2016, "Practical realtime strategies for
/// accurate indirect occlusion", apply it to cavities), so specular falls by up to 60 %, and the
/// furrow's floor scatters more (roughness + 0.15 at most; authored).
pub fn occlude_cavities(height_mm: &Map, roughness: &mut [f32], specular: &mut [f32]) {
    let c = cavity(height_mm);
    roughness
        .par_iter_mut()
        .zip(specular.par_iter_mut())
        .zip(c.par_iter())
        .for_each(|((r, s), &c)| {
            *r = (*r + 0.15 * c).min(1.0);
            *s *= 1.0 - 0.6 * c;
        });
}

/// Converts painted bio maps (already dilated on meshes, see [`BioMaps::dilate`]) to render maps;
/// `dilation` fills the normal map's texels outside the UV charts.
pub fn convert(
    bio: &BioMaps,
    surface: &Surface,
    appearance: &dyn Appearance,
    material: &MaterialConfig,
    dilation: Option<&[u32]>,
) -> RenderMaps {
    let (w, h) = (bio.width, bio.height);
    let has_sss = appearance.subsurface(&bio.texels[0].tissue).is_some();
    let mut channels = Channels::new(w * h, has_sss);
    // Rows are handed out in parallel, each with its slice of every channel.
    channels
        .rows(w)
        .into_par_iter()
        .enumerate()
        .for_each(|(y, mut row)| {
            for x in 0..w {
                let t = &bio.texels[y * w + x];
                let (a, sub) = appearance.shade(&t.tissue);
                let ea = t.extra[3].clamp(0.0, 1.0);
                for k in 0..3 {
                    row.base_color[k][x] = a[k] + (t.extra[k] - a[k]) * ea;
                }
                let base_r = material.roughness_skin
                    + (material.roughness_lips - material.roughness_skin) * t.lips;
                row.roughness[x] = base_r + (material.roughness_hair - base_r) * ea;
                row.specular[x] =
                    (material.specular_f0 + (HAIR_F0 - material.specular_f0) * ea) / SPECULAR_SCALE;
                if let (Some(sub), Some((color, radius))) = (sub, row.subsurface.as_mut()) {
                    for k in 0..3 {
                        color[k][x] = sub.color[k];
                        radius[k][x] = sub.radius_mm[k];
                    }
                }
            }
        });
    let map = |v: Vec<f32>| Map::from_vec(w, h, v).expect("size");
    let Channels {
        base_color,
        roughness,
        specular,
        subsurface,
    } = channels;
    let height_mm = bio.channel(|s| s.height_mm);
    let (mut roughness, mut specular) = (roughness, specular);
    occlude_cavities(&height_mm, &mut roughness, &mut specular);
    // Normals use only texels on the surface (one-sided differences at chart borders), then are
    // dilated themselves; every other map derives from already dilated bio samples.
    let mut normal = crate::normal_map::normals_from_height(surface, &height_mm);
    if let Some(src) = dilation {
        normal
            .par_iter_mut()
            .for_each(|m| derma_core::raster::apply_dilation(m.data_mut(), src));
    }
    RenderMaps {
        base_color: base_color.map(map),
        roughness: map(roughness),
        specular: map(specular),
        normal,
        height_mm,
        subsurface: subsurface.map(|(c, r)| SubsurfaceMaps {
            color: c.map(map),
            radius_mm: r.map(map),
        }),
    }
}

/// Range of the height map, for decoding height.png.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct HeightRange {
    /// Height of texel value 0, mm.
    pub min_mm: f32,
    /// Height of texel value 1, mm.
    pub max_mm: f32,
}

/// Writes the maps of the texture set into `dir` (each atomically; files in parallel): every
/// file of [`crate::outputs::OUTPUTS`] but features.json, preview.png, manifest.json and
/// report.json, the subsurface maps only when `maps` has them. Returns the files written and the
/// height range of height.png.
pub fn write_maps(
    dir: &Path,
    bio: &BioMaps,
    maps: &RenderMaps,
) -> crate::Result<(Vec<&'static str>, HeightRange)> {
    let hs = maps.height_mm.stats(None);
    let range = HeightRange {
        min_mm: hs.min,
        max_mm: hs.max,
    };
    let span = (hs.max - hs.min).max(1e-9);
    let bio_channel = |f: fn(&crate::features::BioSample) -> f32| bio.channel(f);
    let path = |name: &str| dir.join(name);
    type Job<'a> = Box<dyn FnOnce() -> crate::Result<()> + Send + 'a>;
    let mut list: Vec<(&'static str, Job)> = vec![
        (
            outputs::BASE_COLOR,
            Box::new(|| {
                let c = &maps.base_color;
                Ok(image_io::write_png8_srgb(
                    &path(outputs::BASE_COLOR),
                    &[&c[0], &c[1], &c[2]],
                )?)
            }),
        ),
        (
            outputs::NORMAL,
            Box::new(|| {
                let enc = maps.normal.clone().map(|mut m| {
                    m.data_mut().iter_mut().for_each(|v| *v = 0.5 * *v + 0.5);
                    m
                });
                Ok(image_io::write_png16(
                    &path(outputs::NORMAL),
                    &[&enc[0], &enc[1], &enc[2]],
                )?)
            }),
        ),
        (
            outputs::HEIGHT_EXR,
            Box::new(|| {
                Ok(image_io::write_exr(
                    &path(outputs::HEIGHT_EXR),
                    &[("height_mm", &maps.height_mm)],
                    ExrPrecision::F32,
                )?)
            }),
        ),
        (
            outputs::HEIGHT_PNG,
            Box::new(move || {
                let mut m = maps.height_mm.clone();
                m.data_mut()
                    .iter_mut()
                    .for_each(|v| *v = (*v - hs.min) / span);
                Ok(image_io::write_png16(&path(outputs::HEIGHT_PNG), &[&m])?)
            }),
        ),
        (
            outputs::ROUGHNESS,
            Box::new(|| {
                Ok(image_io::write_png8(
                    &path(outputs::ROUGHNESS),
                    &[&maps.roughness],
                )?)
            }),
        ),
        (
            outputs::SPECULAR,
            Box::new(|| {
                Ok(image_io::write_png8(
                    &path(outputs::SPECULAR),
                    &[&maps.specular],
                )?)
            }),
        ),
        (
            outputs::MELANIN,
            Box::new(|| {
                let m = bio_channel(|s| s.tissue.melanin);
                let p = bio_channel(|s| s.tissue.pheomelanin);
                Ok(image_io::write_exr(
                    &path(outputs::MELANIN),
                    &[(names::MELANIN, &m), (names::PHEOMELANIN, &p)],
                    ExrPrecision::F32,
                )?)
            }),
        ),
        (
            outputs::HEMOGLOBIN,
            Box::new(|| {
                let b = bio_channel(|s| s.tissue.blood);
                let o = bio_channel(|s| s.tissue.oxygenation);
                Ok(image_io::write_exr(
                    &path(outputs::HEMOGLOBIN),
                    &[(names::HEMOGLOBIN, &b), (names::OXYGENATION, &o)],
                    ExrPrecision::F32,
                )?)
            }),
        ),
        (
            outputs::BIO,
            Box::new(|| {
                let chans: Vec<(&str, Map)> = BIO_CHANNELS
                    .iter()
                    .map(|(n, f)| (*n, bio_channel(*f)))
                    .collect();
                let refs: Vec<(&str, &Map)> = chans.iter().map(|(n, m)| (*n, m)).collect();
                Ok(image_io::write_exr(
                    &path(outputs::BIO),
                    &refs,
                    ExrPrecision::F16,
                )?)
            }),
        ),
    ];
    if let Some(sub) = &maps.subsurface {
        list.push((
            outputs::SSS_COLOR,
            Box::new(|| {
                let c = &sub.color;
                Ok(image_io::write_png8_srgb(
                    &path(outputs::SSS_COLOR),
                    &[&c[0], &c[1], &c[2]],
                )?)
            }),
        ));
        list.push((
            outputs::SSS_RADIUS,
            Box::new(|| {
                let r = sub.radius_mm.clone().map(|mut m| {
                    m.data_mut()
                        .iter_mut()
                        .for_each(|v| *v = (*v / SSS_RADIUS_RANGE_MM).clamp(0.0, 1.0));
                    m
                });
                Ok(image_io::write_png16(
                    &path(outputs::SSS_RADIUS),
                    &[&r[0], &r[1], &r[2]],
                )?)
            }),
        ));
    }
    let files = list.iter().map(|(f, _)| *f).collect();
    list.into_par_iter()
        .map(|(_, j)| j())
        .collect::<crate::Result<Vec<()>>>()?;
    Ok((files, range))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn furrows_are_rougher_and_less_specular_flat_skin_is_unchanged() {
        // A flat 9×9 map with a one-texel groove 0.03 mm deep down column 4.
        let (w, h) = (9, 9);
        let height = Map::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| if i % w == 4 { -0.03 } else { 0.0 })
                .collect(),
        )
        .unwrap();
        let (mut r, mut s) = (vec![0.5; w * h], vec![0.35; w * h]);
        occlude_cavities(&height, &mut r, &mut s);
        let groove = 4 * w + 4;
        // The groove lies 0.03 − 0.03/3 = 0.02 mm below its neighbourhood's mean: full cavity.
        assert!((r[groove] - 0.65).abs() < 1e-6 && (s[groove] - 0.35 * 0.4).abs() < 1e-6);
        // Far from it nothing changes; beside it (above the mean) nothing either.
        assert_eq!((r[4 * w], s[4 * w]), (0.5, 0.35));
        assert_eq!((r[4 * w + 3], s[4 * w + 3]), (0.5, 0.35));
    }
}
