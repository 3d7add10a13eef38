//! Bio maps → the renderer's texture set (thesis §4.8.8, mmd(FEATURE(…))): base colour through an
//! [`Appearance`], roughness and specular from documented skin values modulated by lips and hair,
//! height and normal maps; dilation into the UV gutter; and the files of DESIGN.md §3.

use crate::config::MaterialConfig;
use crate::paint::{BioMaps, BIO_CHANNELS};
use crate::surface::Surface;
use derma_core::image_io::{self, ExrPrecision};
use derma_core::Map;
use derma_shading::Appearance;
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// Normal-incidence reflectance of hair keratin, n ≈ 1.55 (Stamm, Garcia & Fuchs 1977, "The optical
/// properties of human hair"): ((1.55 − 1)/(1.55 + 1))² = 0.0465.
pub const HAIR_F0: f32 = 0.0465;
/// Specular maps store F0 / 0.08 (the Unreal/Substance "specular" convention: 0.5 ↔ F0 = 4 %).
pub const SPECULAR_SCALE: f32 = 0.08;

/// The render maps, linear values.
pub struct RenderMaps {
    /// Diffuse albedo, linear sRGB.
    pub base_color: [Map; 3],
    pub roughness: Map,
    /// F0 / 0.08.
    pub specular: Map,
    /// Tangent-space normal in [−1, 1].
    pub normal: [Map; 3],
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
    let n = w * h;
    let has_sss = appearance.subsurface(&bio.texels[0].texel()).is_some();
    // One planar buffer per output channel: base colour (3), roughness, specular, and with a
    // subsurface-aware appearance its colour (3) and scatter distance (3). Rows are handed out
    // in parallel, each row getting its slice of every channel.
    let n_ch = if has_sss { 11 } else { 5 };
    let mut chans: Vec<Vec<f32>> = (0..n_ch).map(|_| vec![0.0f32; n]).collect();
    let mut rows: Vec<Vec<&mut [f32]>> = (0..h).map(|_| Vec::with_capacity(n_ch)).collect();
    for c in chans.iter_mut() {
        for (row, chunk) in rows.iter_mut().zip(c.chunks_mut(w)) {
            row.push(chunk);
        }
    }
    rows.into_par_iter().enumerate().for_each(|(y, mut ch)| {
        for x in 0..w {
            let t = &bio.texels[y * w + x];
            let (a, sub) = appearance.shade(&t.texel());
            let ea = t.extra[3].clamp(0.0, 1.0);
            for k in 0..3 {
                ch[k][x] = a[k] + (t.extra[k] - a[k]) * ea;
            }
            let base_r = material.roughness_skin
                + (material.roughness_lips - material.roughness_skin) * t.lips;
            ch[3][x] = base_r + (material.roughness_hair - base_r) * ea;
            ch[4][x] =
                (material.specular_f0 + (HAIR_F0 - material.specular_f0) * ea) / SPECULAR_SCALE;
            if let Some(sub) = sub {
                for k in 0..3 {
                    ch[5 + k][x] = sub.color[k];
                    ch[8 + k][x] = sub.radius_mm[k];
                }
            }
        }
    });
    let mut maps = chans
        .into_iter()
        .map(|v| Map::from_vec(w, h, v).expect("size"));
    let mut next = || maps.next().expect("channel");
    let base_color = [next(), next(), next()];
    let roughness = next();
    let specular = next();
    let subsurface = has_sss.then(|| SubsurfaceMaps {
        color: [next(), next(), next()],
        radius_mm: [next(), next(), next()],
    });
    let height_mm = bio.channel(|s| s.height_mm);
    // Normals use only texels on the surface (one-sided differences at chart borders), then are
    // dilated themselves; every other map derives from already dilated bio samples.
    let mut normal = crate::normal_map::normals_from_height(surface, &height_mm);
    if let Some(src) = dilation {
        normal
            .par_iter_mut()
            .for_each(|m| derma_core::raster::apply_dilation(m.data_mut(), src));
    }
    RenderMaps {
        base_color,
        roughness,
        specular,
        normal,
        height_mm,
        subsurface,
    }
}

/// One output file as listed in manifest.json.
#[derive(Clone, Debug, Serialize)]
pub struct OutputEntry {
    pub file: String,
    pub colour_space: String,
    pub meaning: String,
}

/// Range of the height map, for decoding height.png.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct HeightRange {
    pub min_mm: f32,
    pub max_mm: f32,
}

/// Writes the texture-set maps into `dir` (each atomically; files in parallel).
pub fn write_maps(
    dir: &Path,
    bio: &BioMaps,
    maps: &RenderMaps,
) -> crate::Result<(Vec<OutputEntry>, HeightRange)> {
    let hs = maps.height_mm.stats(None);
    let range = HeightRange {
        min_mm: hs.min,
        max_mm: hs.max,
    };
    let span = (hs.max - hs.min).max(1e-9);
    let bio_channel = |f: fn(&crate::features::BioSample) -> f32| bio.channel(f);
    type Job<'a> = Box<dyn FnOnce() -> crate::Result<()> + Send + 'a>;
    let mut list: Vec<(&str, &str, &str, Job)> = Vec::new();
    list.push((
        "base_color.png",
        "sRGB",
        "diffuse albedo (glTF baseColor / Unreal Base Color), 8-bit sRGB",
        Box::new(|| {
            let c = &maps.base_color;
            Ok(image_io::write_png8_srgb(
                &dir.join("base_color.png"),
                &[&c[0], &c[1], &c[2]],
            )?)
        }),
    ));
    list.push((
        "normal.png",
        "linear (non-colour)",
        "tangent-space normal, OpenGL +Y (green up), MikkTSpace frame on meshes; 16-bit, n·½+½",
        Box::new(|| {
            let enc = maps.normal.clone().map(|mut m| {
                m.data_mut().iter_mut().for_each(|v| *v = 0.5 * *v + 0.5);
                m
            });
            Ok(image_io::write_png16(
                &dir.join("normal.png"),
                &[&enc[0], &enc[1], &enc[2]],
            )?)
        }),
    ));
    list.push((
        "height.exr",
        "linear",
        "displacement in mm from the mean skin surface (float32)",
        Box::new(|| {
            Ok(image_io::write_exr(
                &dir.join("height.exr"),
                &[("height_mm", &maps.height_mm)],
                ExrPrecision::F32,
            )?)
        }),
    ));
    list.push((
        "height.png",
        "linear (non-colour)",
        "displacement, 16-bit, 0 ↔ height_range.min_mm and 1 ↔ max_mm (report.json)",
        Box::new(move || {
            let mut m = maps.height_mm.clone();
            m.data_mut()
                .iter_mut()
                .for_each(|v| *v = (*v - hs.min) / span);
            Ok(image_io::write_png16(&dir.join("height.png"), &[&m])?)
        }),
    ));
    list.push((
        "roughness.png",
        "linear (non-colour)",
        "glTF perceptual roughness (Unreal Roughness), 8-bit",
        Box::new(|| {
            Ok(image_io::write_png8(
                &dir.join("roughness.png"),
                &[&maps.roughness],
            )?)
        }),
    ));
    list.push((
        "specular.png",
        "linear (non-colour)",
        "specular level F0/0.08 (Unreal/Substance Specular: 0.5 ↔ F0 = 4 %), 8-bit",
        Box::new(|| {
            Ok(image_io::write_png8(
                &dir.join("specular.png"),
                &[&maps.specular],
            )?)
        }),
    ));
    list.push((
        "melanin.exr",
        "linear",
        "melanosome volume fraction of the epidermis (melanin) and pheomelanin share",
        Box::new(|| {
            let (m, p) = (bio_channel(|s| s.melanin), bio_channel(|s| s.pheomelanin));
            Ok(image_io::write_exr(
                &dir.join("melanin.exr"),
                &[("melanin", &m), ("pheomelanin", &p)],
                ExrPrecision::F32,
            )?)
        }),
    ));
    list.push((
        "hemoglobin.exr",
        "linear",
        "whole-blood volume fraction of the dermis (blood) and its oxygenation",
        Box::new(|| {
            let (b, o) = (bio_channel(|s| s.blood), bio_channel(|s| s.oxygenation));
            Ok(image_io::write_exr(
                &dir.join("hemoglobin.exr"),
                &[("blood", &b), ("oxygenation", &o)],
                ExrPrecision::F32,
            )?)
        }),
    ));
    list.push(("bio.exr", "linear", "every bio parameter as a channel (half float): melanin, pheomelanin, blood, oxygenation, stratum_corneum_um, epidermis_um, height_mm, extra.RGBA, lips", Box::new(|| {
        let chans: Vec<(&str, Map)> = BIO_CHANNELS.iter().map(|(n, f)| (*n, bio_channel(*f))).collect();
        let refs: Vec<(&str, &Map)> = chans.iter().map(|(n, m)| (*n, m)).collect();
        Ok(image_io::write_exr(&dir.join("bio.exr"), &refs, ExrPrecision::F16)?)
    })));
    if let Some(sub) = &maps.subsurface {
        list.push((
            "sss_color.png",
            "sRGB",
            "subsurface colour: Burley 2015 surface albedo A of the fitted diffusion profile (Unreal Subsurface Color, Blender Subsurface Color), 8-bit sRGB",
            Box::new(|| {
                let c = &sub.color;
                Ok(image_io::write_png8_srgb(
                    &dir.join("sss_color.png"),
                    &[&c[0], &c[1], &c[2]],
                )?)
            }),
        ));
        list.push((
            "sss_radius.png",
            "linear (non-colour)",
            "subsurface scatter distance per channel (Christensen & Burley 2015 mean free path, Blender Subsurface Radius), 16-bit, 0 ↔ 0 mm and 1 ↔ 8 mm",
            Box::new(|| {
                let r = sub.radius_mm.clone().map(|mut m| {
                    m.data_mut()
                        .iter_mut()
                        .for_each(|v| *v = (*v / SSS_RADIUS_RANGE_MM).clamp(0.0, 1.0));
                    m
                });
                Ok(image_io::write_png16(
                    &dir.join("sss_radius.png"),
                    &[&r[0], &r[1], &r[2]],
                )?)
            }),
        ));
    }
    let entries = list
        .iter()
        .map(|(f, c, m, _)| OutputEntry {
            file: (*f).into(),
            colour_space: (*c).into(),
            meaning: (*m).into(),
        })
        .collect();
    list.into_par_iter()
        .map(|(_, _, _, j)| j())
        .collect::<crate::Result<Vec<()>>>()?;
    Ok((entries, range))
}
