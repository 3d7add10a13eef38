//! Bio maps → the renderer's texture set (thesis §4.8.8, mmd(FEATURE(…))): base colour through an
//! [`Appearance`], roughness and specular from documented skin values modulated by lips and hair,
//! height and normal maps; dilation into the UV gutter; and the map files of [`crate::outputs`].

use crate::config::MaterialConfig;
use crate::features::BioSample;
use crate::outputs;
use crate::paint::{BioMaps, BIO_CHANNELS};
use crate::surface::Surface;
use derma_core::color::srgb8_decode;
use derma_core::exr_writer::{write_exr_rows, ExrChannel, ExrCompression};
use derma_core::image_io::{quantize16, quantize8, srgb8, write_png_rows, ExrPrecision, PngDepth};
use derma_core::map::{box_reduced, Taps};
use derma_core::Map;
use derma_optics::bio::names;
use derma_render::frame::{Material, MaterialSample};
use derma_shading::{Appearance, BioTexel};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// Normal-incidence reflectance of hair keratin, n ≈ 1.55 (Stamm, Garcia & Fuchs 1977, "The optical
/// properties of human hair"): ((1.55 − 1)/(1.55 + 1))² = 0.0465.
pub const HAIR_F0: f32 = 0.0465;
pub use derma_render::material::SPECULAR_SCALE;

/// The render maps as their files store them: what is in memory is what the files hold
/// (8-bit sRGB colours, 16-bit normals and scatter distances, 8-bit roughness and specular),
/// 20 bytes per texel where f32 planes took 60 (issue 15: 4096² in ≤ 1.6 GB). The height is the
/// bio samples' own ([`BioMaps`]); `decode_*` give linear f32 maps.
pub struct RenderMaps {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// base_color.png: diffuse albedo, 8-bit sRGB.
    pub base_color: Vec<[u8; 3]>,
    /// roughness.png: glTF perceptual roughness, 8-bit.
    pub roughness: Vec<u8>,
    /// specular.png: F0 / 0.08, 8-bit.
    pub specular: Vec<u8>,
    /// normal.png: tangent-space normal as n·½ + ½, 16-bit.
    pub normal: Vec<[u16; 3]>,
    /// wrinkle_normal.png where it differs from normal.png: the normal of the surface with
    /// every expression furrow at full activation, as (texel, n·½ + ½), by texel (sparse: only
    /// texels within a texel of a wrinkle).
    pub wrinkle_normal: Vec<(u32, [u16; 3])>,
    /// Subsurface maps, when the appearance provides them (the match table does).
    pub subsurface: Option<SubsurfaceMaps>,
    /// The hair's colour (linear RGB) for the built-in head's lash cards, when on it.
    pub lash_color: Option<[f32; 3]>,
}

/// Per-texel subsurface parameters (linear sRGB channels), as their files store them.
pub struct SubsurfaceMaps {
    /// sss_color.png: Burley's surface albedo A (subsurface colour), 8-bit sRGB.
    pub color: Vec<[u8; 3]>,
    /// sss_radius.png: scatter distance (mean free path ℓ) / [`SSS_RADIUS_RANGE_MM`], 16-bit.
    pub radius: Vec<[u16; 3]>,
}

pub use derma_render::material::SSS_RADIUS_RANGE_MM;

impl RenderMaps {
    /// Maps of `width` × `height` texels, zero until [`convert`] fills them.
    fn zeroed(width: usize, height: usize, subsurface: bool) -> Self {
        let n = width * height;
        Self {
            width,
            height,
            base_color: vec![[0; 3]; n],
            roughness: vec![0; n],
            specular: vec![0; n],
            normal: vec![[0; 3]; n],
            wrinkle_normal: Vec::new(),
            subsurface: subsurface.then(|| SubsurfaceMaps {
                color: vec![[0; 3]; n],
                radius: vec![[0; 3]; n],
            }),
            lash_color: None,
        }
    }

    /// Planar f32 maps of `C` channels, each texel from `f` (texel index → values).
    fn planes<const C: usize>(&self, f: impl Fn(usize) -> [f32; C] + Sync) -> [Map; C] {
        box_reduced(self.width, self.height, 1, f)
    }

    /// Base colour, linear sRGB.
    pub fn decode_base_color(&self) -> [Map; 3] {
        self.planes(|i| self.base_color[i].map(srgb8_decode))
    }

    /// Tangent-space normal in [−1, 1] (as decoded from normal.png).
    pub fn decode_normal(&self) -> [Map; 3] {
        self.planes(|i| self.normal[i].map(unit16))
    }

    /// Perceptual roughness.
    pub fn decode_roughness(&self) -> Map {
        let [m] = self.planes(|i| [self.roughness[i] as f32 / 255.0]);
        m
    }

    /// Specular level (F0 / 0.08).
    pub fn decode_specular(&self) -> Map {
        let [m] = self.planes(|i| [self.specular[i] as f32 / 255.0]);
        m
    }

    /// Subsurface colour (linear) and scatter distance (mm), when the set has them.
    pub fn decode_subsurface(&self) -> Option<([Map; 3], [Map; 3])> {
        self.subsurface.as_ref().map(|s| {
            (
                self.planes(|i| s.color[i].map(srgb8_decode)),
                self.planes(|i| s.radius[i].map(|c| c as f32 / 65535.0 * SSS_RADIUS_RANGE_MM)),
            )
        })
    }

    /// The maps as derma-render draws them (the normal encoded n·½ + ½ as normal.png stores it);
    /// `wrap` repeats them (tileable patches).
    pub fn skin_maps(&self, wrap: bool) -> derma_render::SkinMaps {
        let enc = |mut m: Map| {
            m.data_mut().iter_mut().for_each(|v| *v = 0.5 * *v + 0.5);
            m
        };
        derma_render::SkinMaps {
            base_color: self.decode_base_color(),
            normal: self.decode_normal().map(enc),
            roughness: self.decode_roughness(),
            specular: self.decode_specular(),
            subsurface: self.decode_subsurface(),
            lash_color: self.lash_color,
            // The in-memory previews draw the brows painted only (no cards).
            hair: None,
            wrap,
        }
    }

    /// Base colour (linear), normal and roughness box-filtered by the whole factor `k` (each
    /// texel the mean of a k × k block): thumbnails without full-size copies.
    pub fn reduced(&self, k: usize) -> ([Map; 3], [Map; 3], Map) {
        let [r, g, b, nx, ny, nz, ro] = box_reduced(self.width, self.height, k, |i| {
            let (c, n) = (self.base_color[i], self.normal[i]);
            [
                srgb8_decode(c[0]),
                srgb8_decode(c[1]),
                srgb8_decode(c[2]),
                unit16(n[0]),
                unit16(n[1]),
                unit16(n[2]),
                self.roughness[i] as f32 / 255.0,
            ]
        });
        ([r, g, b], [nx, ny, nz], ro)
    }

    /// The maps as a material of derma-render's CPU previews, sampled from their encodings (bilinear,
    /// the same values as sampling [`Self::decode_base_color`] and the others, without the
    /// decoded copies); `wrap` repeats them, `uv_scale` tiles them.
    pub fn material(&self, wrap: bool, uv_scale: glam::Vec2) -> EncodedMaterial<'_> {
        EncodedMaterial {
            maps: self,
            wrap,
            uv_scale,
        }
    }
}

/// [`RenderMaps`] as a [`Material`] of derma-render's CPU previews.
pub struct EncodedMaterial<'a> {
    maps: &'a RenderMaps,
    wrap: bool,
    uv_scale: glam::Vec2,
}

/// A 16-bit code of n·½ + ½ back to n ∈ [−1, 1].
#[inline]
fn unit16(c: u16) -> f32 {
    c as f32 / 65535.0 * 2.0 - 1.0
}

impl Material for EncodedMaterial<'_> {
    fn sample(&self, uv: glam::Vec2, _p: glam::Vec3) -> MaterialSample {
        let r = self.maps;
        let taps = Taps::uv(r.width, r.height, uv.x, uv.y, self.wrap);
        let t = taps.texels();
        let colour = |c: usize| taps.blend(t.map(|i| srgb8_decode(r.base_color[i][c])));
        let normal = |c: usize| taps.blend(t.map(|i| unit16(r.normal[i][c])));
        let byte = |m: &[u8]| taps.blend(t.map(|i| m[i] as f32 / 255.0));
        MaterialSample {
            albedo: glam::Vec3::new(colour(0), colour(1), colour(2)),
            normal: glam::Vec3::new(normal(0), normal(1), normal(2)),
            roughness: byte(&r.roughness),
            f0: byte(&r.specular) * SPECULAR_SCALE,
        }
    }
    fn uv_scale(&self) -> glam::Vec2 {
        self.uv_scale
    }
}

/// Depth (mm) below the mean of its 3×3 neighbourhood at which a texel counts as fully inside a
/// cavity (furrows of the micro-relief, pores, wrinkles).
pub const CAVITY_DEPTH_MM: f32 = 0.02;

/// Cavity of texel (`x`, `y`) of a `w` × `h` height map (`height(j)`, mm): how far it lies
/// below the mean of its 3×3 neighbourhood, over [`CAVITY_DEPTH_MM`], in [0, 1].
#[inline]
pub fn cavity_at(height: impl Fn(usize) -> f32, w: usize, h: usize, x: usize, y: usize) -> f32 {
    let (y0, y1) = (y.saturating_sub(1), (y + 1).min(h - 1));
    let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
    let mut sum = 0.0f32;
    for yy in y0..=y1 {
        for xx in x0..=x1 {
            sum += height(yy * w + xx);
        }
    }
    let n = (y1 - y0 + 1) * (x1 - x0 + 1);
    ((sum / n as f32 - height(y * w + x)) / CAVITY_DEPTH_MM).clamp(0.0, 1.0)
}

/// Cavity of every texel of `height_mm` ([`cavity_at`]).
pub fn cavity(height_mm: &Map) -> Vec<f32> {
    let (w, h) = (height_mm.width(), height_mm.height());
    let d = height_mm.data();
    (0..w * h)
        .into_par_iter()
        .map(|i| cavity_at(|j| d[j], w, h, i % w, i / w))
        .collect()
}

/// The skin's roughness and F0 before lips, hair and cavities, and where they came from.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SkinSurface {
    /// glTF perceptual roughness.
    pub roughness: f32,
    /// Normal-incidence reflectance.
    pub f0: f32,
    /// True: the appearance's fit of the Monte Carlo surface; false: the authored values.
    pub fitted: bool,
}

/// The appearance's fit of the Monte Carlo surface where it has one and
/// `material.fitted_surface` asks for it (the match table's, derma_shading::surface_fit), else
/// the authored `roughness_skin` and `specular_f0`.
pub fn skin_surface(material: &MaterialConfig, appearance: &dyn Appearance) -> SkinSurface {
    match appearance.specular().filter(|_| material.fitted_surface) {
        Some(s) => SkinSurface {
            roughness: s.roughness,
            f0: s.f0,
            fitted: true,
        },
        None => SkinSurface {
            roughness: material.roughness_skin,
            f0: material.specular_f0,
            fitted: false,
        },
    }
}

/// Roughness and specular occlusion in a cavity `c`: inside a furrow the walls hide part of
/// the specular lobe (specular occlusion, as Jimenez et al. 2016, "Practical realtime
/// strategies for accurate indirect occlusion", apply it to cavities), so specular falls by up
/// to 60 %, and the furrow's floor scatters more (roughness + 0.15 at most; authored).
#[inline]
pub fn occlude(roughness: f32, specular: f32, c: f32) -> (f32, f32) {
    ((roughness + 0.15 * c).min(1.0), specular * (1.0 - 0.6 * c))
}

/// [`occlude`] over whole maps, each texel by its cavity in `height_mm`.
pub fn occlude_cavities(height_mm: &Map, roughness: &mut [f32], specular: &mut [f32]) {
    let c = cavity(height_mm);
    roughness
        .par_iter_mut()
        .zip(specular.par_iter_mut())
        .zip(c.par_iter())
        .for_each(|((r, s), &c)| (*r, *s) = occlude(*r, *s, c));
}

/// Rows of the render maps converted per parallel task.
const CONVERT_ROWS: usize = 8;

/// One task's rows of the subsurface colour and radius maps.
type SubsurfaceRows<'a> = (&'a mut [[u8; 3]], &'a mut [[u16; 3]]);

/// One task's rows of every render map.
struct Strip<'a> {
    first_row: usize,
    base_color: &'a mut [[u8; 3]],
    roughness: &'a mut [u8],
    specular: &'a mut [u8],
    normal: &'a mut [[u16; 3]],
    subsurface: Option<SubsurfaceRows<'a>>,
    /// The strip's wrinkle normals (texel, encoded), in texel order.
    wrinkle_normal: Vec<(u32, [u16; 3])>,
}

/// Converts painted bio maps (already dilated on meshes, see [`BioMaps::dilate`]) to render maps
/// in one pass per texel, straight to the files' encodings; `dilation` fills the normal map's
/// texels outside the UV charts.
pub fn convert(
    bio: &BioMaps,
    surface: &Surface,
    appearance: &dyn Appearance,
    material: &MaterialConfig,
    dilation: Option<&[u32]>,
) -> RenderMaps {
    let (w, h) = (bio.width, bio.height);
    let has_sss = appearance.subsurface(&bio.texels[0].tissue).is_some();
    let mut maps = RenderMaps::zeroed(w, h, has_sss);
    let height = |j: usize| bio.texels[j].height_mm;
    let n = w * CONVERT_ROWS;
    let mut strips = Vec::with_capacity(h.div_ceil(CONVERT_ROWS));
    {
        let mut sss = maps
            .subsurface
            .as_mut()
            .map(|s| (s.color.chunks_mut(n), s.radius.chunks_mut(n)));
        for (k, (((b, r), s), nm)) in maps
            .base_color
            .chunks_mut(n)
            .zip(maps.roughness.chunks_mut(n))
            .zip(maps.specular.chunks_mut(n))
            .zip(maps.normal.chunks_mut(n))
            .enumerate()
        {
            strips.push(Strip {
                first_row: k * CONVERT_ROWS,
                base_color: b,
                roughness: r,
                specular: s,
                normal: nm,
                subsurface: sss
                    .as_mut()
                    .map(|(c, r)| (c.next().expect("rows"), r.next().expect("rows"))),
                wrinkle_normal: Vec::new(),
            });
        }
    }
    let furrow = |j: usize| bio.texels[j].furrow_mm;
    let wrap = surface.period().is_some();
    let with_furrows = |j: usize| bio.texels[j].height_mm + bio.texels[j].furrow_mm;
    let SkinSurface {
        roughness: skin_r,
        f0: skin_f0,
        ..
    } = skin_surface(material, appearance);
    strips.par_iter_mut().for_each(|st| {
        let first = st.first_row * w;
        let len = st.roughness.len();
        // The appearance over the whole strip at once (the match table interpolates eight
        // texels per SIMD register).
        let tissue: Vec<BioTexel> = bio.texels[first..first + len]
            .iter()
            .map(|t| t.tissue)
            .collect();
        let mut shade = vec![([0.0f32; 3], None); len];
        appearance.shade_batch(&tissue, &mut shade);
        for k in 0..len {
            let i = first + k;
            let (x, y) = (i % w, i / w);
            let t = &bio.texels[i];
            let (a, sub) = shade[k];
            let ea = t.extra[3].clamp(0.0, 1.0);
            st.base_color[k] = std::array::from_fn(|c| srgb8(a[c] + (t.extra[c] - a[c]) * ea));
            let base_r = skin_r + (material.roughness_lips - skin_r) * t.lips;
            let r = base_r + (material.roughness_hair - base_r) * ea;
            let s = (skin_f0 + (HAIR_F0 - skin_f0) * ea) / SPECULAR_SCALE;
            let (r, s) = occlude(r, s, cavity_at(height, w, h, x, y));
            st.roughness[k] = quantize8(r);
            st.specular[k] = quantize8(s);
            // Normals use only texels on the surface (one-sided differences at chart borders);
            // texels off it are dilated below.
            let nrm = if surface.covered(i) {
                crate::normal_map::tangent_normal(surface, height, x, y)
            } else {
                [0.0, 0.0, 1.0]
            };
            st.normal[k] = nrm.map(|v| quantize16(0.5 * v + 0.5));
            if surface.covered(i) && near_furrow(furrow, (w, h), (x, y), wrap) {
                let n = crate::normal_map::tangent_normal(surface, with_furrows, x, y);
                st.wrinkle_normal
                    .push((i as u32, n.map(|v| quantize16(0.5 * v + 0.5))));
            }
            if let (Some(sub), Some((color, radius))) = (sub, st.subsurface.as_mut()) {
                // Hair lies on the skin and scatters no light beneath it: composited over the
                // subsurface colour as over the base colour, and the scatter distance shrinks by
                // its share of the texel (renderers diffuse with sss_color where they scatter).
                color[k] =
                    std::array::from_fn(|c| srgb8(sub.color[c] + (t.extra[c] - sub.color[c]) * ea));
                radius[k] = sub
                    .radius_mm
                    .map(|v| quantize16(v * (1.0 - ea) / SSS_RADIUS_RANGE_MM));
            }
        }
    });
    maps.wrinkle_normal = strips
        .into_iter()
        .flat_map(|st| st.wrinkle_normal)
        .collect();
    if let Some(src) = dilation {
        derma_core::raster::apply_dilation(&mut maps.normal, src);
        maps.wrinkle_normal = dilate_sparse(&maps.wrinkle_normal, src);
    }
    maps
}

/// Whether texel (`x`, `y`) or one of the four neighbours the normal reads (across the edges
/// when `wrap`, as [`crate::normal_map::tangent_normal`] does) has an expression furrow: only
/// there can the wrinkle normal differ from the rest normal.
fn near_furrow(
    furrow: impl Fn(usize) -> f32,
    (w, h): (usize, usize),
    (x, y): (usize, usize),
    wrap: bool,
) -> bool {
    let at = |dx: i64, dy: i64| {
        crate::normal_map::texel_at((w, h), x as i64 + dx, y as i64 + dy, wrap)
            .is_some_and(|j| furrow(j) != 0.0)
    };
    at(0, 0) || at(-1, 0) || at(1, 0) || at(0, -1) || at(0, 1)
}

/// A sparse per-texel list (sorted by texel) with the gutter's texels added from their dilation
/// sources `src`, as [`derma_core::raster::apply_dilation`] fills a full map.
fn dilate_sparse<T: Copy>(list: &[(u32, T)], src: &[u32]) -> Vec<(u32, T)> {
    let find = |t: u32| {
        list.binary_search_by_key(&t, |e| e.0)
            .ok()
            .map(|k| list[k].1)
    };
    let mut out: Vec<(u32, T)> = (0..src.len() as u32)
        .filter(|&i| src[i as usize] != i)
        .filter_map(|i| find(src[i as usize]).map(|v| (i, v)))
        .collect();
    out.extend_from_slice(list);
    out.sort_unstable_by_key(|e| e.0);
    out
}

/// Range of the height map, for decoding height.png.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct HeightRange {
    /// Height of texel value 0, mm.
    pub min_mm: f32,
    /// Height of texel value 1, mm.
    pub max_mm: f32,
}

/// The range of the painted heights (every texel, the gutter's dilated ones included).
pub fn height_range(bio: &BioMaps) -> HeightRange {
    let (lo, hi) = bio
        .texels
        .par_iter()
        .fold(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |(lo, hi), t| (lo.min(t.height_mm), hi.max(t.height_mm)),
        )
        .reduce(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    HeightRange {
        min_mm: lo,
        max_mm: hi,
    }
}

/// Writes an EXR of `C` channels of the bio samples, each line in one pass over its samples.
fn exr<const C: usize>(
    path: &Path,
    bio: &BioMaps,
    names: [&str; C],
    precision: ExrPrecision,
    compression: ExrCompression,
    values: impl Fn(&BioSample) -> [f32; C] + Sync,
) -> crate::Result<()> {
    let w = bio.width;
    let list = names.map(|name| ExrChannel { name, precision });
    Ok(write_exr_rows(
        path,
        w,
        bio.height,
        &list,
        compression,
        |y, rows| {
            for (x, s) in bio.texels[y * w..(y + 1) * w].iter().enumerate() {
                let v = values(s);
                for c in 0..C {
                    rows[c][x] = v[c];
                }
            }
        },
    )?)
}

/// bio.exr: every bio channel ([`BIO_CHANNELS`]) as half floats, with `compression` (the main
/// job uses [`BIO_COMPRESSION`]; the `exr_compression` bench compares the others).
pub fn write_bio_exr(path: &Path, bio: &BioMaps, compression: ExrCompression) -> crate::Result<()> {
    let names = BIO_CHANNELS.map(|(n, _)| n);
    exr(
        path,
        bio,
        names,
        ExrPrecision::F16,
        compression,
        BioSample::channels,
    )
}

/// Largest side of wrinkle_masks.exr: the masks vary over millimetres, not texels.
pub const WRINKLE_MASK_MAX_SIZE: usize = 1024;

/// Writes `path`, the masks of the expression-wrinkle regions (one channel per
/// [`derma_head::wrinkle_regions::REGIONS`] entry, by name) sampled from `fields` at a set of
/// `width` × `height` texels, at most [`WRINKLE_MASK_MAX_SIZE`] a side. Returns false (and
/// writes nothing) where the fields carry no masks: a surface without landmarks.
pub fn write_wrinkle_masks(
    path: &Path,
    fields: &crate::field::FieldSet,
    width: usize,
    height: usize,
    wrap: bool,
) -> crate::Result<bool> {
    use derma_head::wrinkle_regions::{COUNT, REGIONS};
    let masks: Option<Vec<&Map>> = REGIONS
        .iter()
        .map(|r| {
            fields
                .scalars
                .get(&crate::builtin_head::wrinkle_mask_field(r.name))
        })
        .collect();
    let Some(masks) = masks else {
        return Ok(false);
    };
    let (w, h) = (
        width.min(WRINKLE_MASK_MAX_SIZE),
        height.min(WRINKLE_MASK_MAX_SIZE),
    );
    let names = REGIONS.map(|r| r.name);
    let list: [ExrChannel; COUNT] = std::array::from_fn(|k| ExrChannel {
        name: names[k],
        precision: ExrPrecision::F16,
    });
    write_exr_rows(path, w, h, &list, ExrCompression::Zip, |y, rows| {
        for x in 0..w {
            let (u, v) = (
                (x as f32 + 0.5) / w as f32,
                1.0 - (y as f32 + 0.5) / h as f32,
            );
            for (c, m) in masks.iter().enumerate() {
                rows[c][x] = m.sample(&Taps::uv(m.width(), m.height(), u, v, wrap));
            }
        }
    })?;
    Ok(true)
}

/// Side of lashes.png.
pub const LASH_MAP_SIZE: usize = 512;

/// Writes `path`, the built-in lash cards' texture: `hair` (linear RGB) as sRGB and the lashes'
/// coverage ([`derma_head::lashes::coverage_map`]) as alpha.
pub fn write_lashes(path: &Path, hair: [f32; 3]) -> crate::Result<()> {
    let n = LASH_MAP_SIZE;
    let coverage = derma_head::lashes::coverage_map(n);
    let rgb = hair.map(srgb8);
    Ok(write_png_rows(path, n, n, 4, PngDepth::Eight, |y, out| {
        for (x, px) in out.chunks_exact_mut(4).enumerate() {
            px[..3].copy_from_slice(&rgb);
            px[3] = quantize8(coverage.get(x, y));
        }
    })?)
}

/// Writes the maps of the texture set into `dir` (each atomically; files in parallel, each
/// streamed from the bio samples or the render maps by rows, with no whole-image copy): every
/// file of [`crate::outputs::OUTPUTS`] but features.json, preview.png, manifest.json and
/// report.json, the subsurface maps only when `maps` has them. Returns the files written and
/// the height range of height.png.
pub fn write_maps(
    dir: &Path,
    bio: &BioMaps,
    maps: &RenderMaps,
) -> crate::Result<(Vec<&'static str>, HeightRange)> {
    let range = height_range(bio);
    let writer = MapWriter {
        dir,
        bio,
        range,
        span: (range.max_mm - range.min_mm).max(1e-9),
    };
    let list = map_jobs(&writer, maps);
    let written: Vec<&'static str> = list.iter().map(|(name, _)| *name).collect();
    list.into_par_iter()
        .map(|(_, j)| j())
        .collect::<crate::Result<Vec<()>>>()?;
    // The files written, in manifest order.
    let files = outputs::OUTPUTS
        .iter()
        .map(|o| o.file)
        .filter(|f| written.contains(f))
        .collect();
    Ok((files, range))
}

/// Writing one map file, to run beside the others.
type MapJob<'a> = Box<dyn FnOnce() -> crate::Result<()> + Send + 'a>;

/// The job of every map [`write_maps`] writes (the subsurface maps' where `maps` has them),
/// largest first, so the last jobs to start are short.
fn map_jobs<'a>(wr: &'a MapWriter<'a>, maps: &'a RenderMaps) -> Vec<(&'static str, MapJob<'a>)> {
    let bio = wr.bio;
    let (f32, none) = (ExrPrecision::F32, ExrCompression::None);
    let mut list: Vec<(&'static str, MapJob)> = vec![
        (
            outputs::BIO,
            Box::new(move || write_bio_exr(&wr.path(outputs::BIO), bio, BIO_COMPRESSION)),
        ),
        (
            outputs::MELANIN,
            Box::new(move || {
                let names = [names::MELANIN, names::PHEOMELANIN];
                exr(&wr.path(outputs::MELANIN), bio, names, f32, none, |s| {
                    [s.tissue.melanin, s.tissue.pheomelanin]
                })
            }),
        ),
        (
            outputs::HEMOGLOBIN,
            Box::new(move || {
                let names = [names::HEMOGLOBIN, names::OXYGENATION];
                exr(&wr.path(outputs::HEMOGLOBIN), bio, names, f32, none, |s| {
                    [s.tissue.blood, s.tissue.oxygenation]
                })
            }),
        ),
        (
            outputs::NORMAL,
            Box::new(move || wr.rgb16(outputs::NORMAL, &maps.normal)),
        ),
        (
            outputs::WRINKLE_NORMAL,
            Box::new(move || wr.wrinkle_normal(maps)),
        ),
        (
            outputs::HEIGHT_EXR,
            Box::new(move || {
                exr(
                    &wr.path(outputs::HEIGHT_EXR),
                    bio,
                    ["height_mm", "height_mm_furrow"],
                    f32,
                    none,
                    |s| [s.height_mm, s.furrow_mm],
                )
            }),
        ),
        (outputs::HEIGHT_PNG, Box::new(move || wr.height_png())),
        (
            outputs::BASE_COLOR,
            Box::new(move || wr.rgb8(outputs::BASE_COLOR, &maps.base_color)),
        ),
        (
            outputs::ROUGHNESS,
            Box::new(move || wr.grey8(outputs::ROUGHNESS, &maps.roughness)),
        ),
        (
            outputs::SPECULAR,
            Box::new(move || wr.grey8(outputs::SPECULAR, &maps.specular)),
        ),
        (outputs::HAIR_COVERAGE, Box::new(move || wr.hair_coverage())),
    ];
    if let Some(sub) = &maps.subsurface {
        list.insert(
            4,
            (
                outputs::SSS_RADIUS,
                Box::new(move || wr.rgb16(outputs::SSS_RADIUS, &sub.radius)),
            ),
        );
        list.push((
            outputs::SSS_COLOR,
            Box::new(move || wr.rgb8(outputs::SSS_COLOR, &sub.color)),
        ));
    }
    list
}

/// Writes the PNG maps of one texture set into a directory, by rows.
struct MapWriter<'a> {
    dir: &'a Path,
    bio: &'a BioMaps,
    /// The heights' range and its span (height.png's scale).
    range: HeightRange,
    span: f32,
}

impl MapWriter<'_> {
    /// The path of `name` in the directory.
    fn path(&self, name: &str) -> std::path::PathBuf {
        self.dir.join(name)
    }

    /// An 8-bit RGB PNG of `px`.
    fn rgb8(&self, file: &'static str, px: &[[u8; 3]]) -> crate::Result<()> {
        let (w, h) = (self.bio.width, self.bio.height);
        Ok(write_png_rows(
            &self.path(file),
            w,
            h,
            3,
            PngDepth::Eight,
            |y, out| {
                out.copy_from_slice(px[y * w..(y + 1) * w].as_flattened());
            },
        )?)
    }

    /// A 16-bit RGB PNG of `px`.
    fn rgb16(&self, file: &'static str, px: &[[u16; 3]]) -> crate::Result<()> {
        let (w, h) = (self.bio.width, self.bio.height);
        Ok(write_png_rows(
            &self.path(file),
            w,
            h,
            3,
            PngDepth::Sixteen,
            |y, out| {
                for (o, v) in out
                    .chunks_exact_mut(2)
                    .zip(px[y * w..(y + 1) * w].as_flattened())
                {
                    o.copy_from_slice(&v.to_be_bytes());
                }
            },
        )?)
    }

    /// An 8-bit grey PNG of `px`.
    fn grey8(&self, file: &'static str, px: &[u8]) -> crate::Result<()> {
        let (w, h) = (self.bio.width, self.bio.height);
        Ok(write_png_rows(
            &self.path(file),
            w,
            h,
            1,
            PngDepth::Eight,
            |y, out| {
                out.copy_from_slice(&px[y * w..(y + 1) * w]);
            },
        )?)
    }

    /// wrinkle_normal.png: normal.png with the sparse wrinkle normals laid over it.
    fn wrinkle_normal(&self, maps: &RenderMaps) -> crate::Result<()> {
        let (w, h) = (self.bio.width, self.bio.height);
        Ok(write_png_rows(
            &self.path(outputs::WRINKLE_NORMAL),
            w,
            h,
            3,
            PngDepth::Sixteen,
            |y, out| {
                let (a, b) = (y * w, (y + 1) * w);
                let wn = &maps.wrinkle_normal;
                let first = wn.partition_point(|e| (e.0 as usize) < a);
                let last = wn.partition_point(|e| (e.0 as usize) < b);
                let mut row = maps.normal[a..b].to_vec();
                for (i, n) in &wn[first..last] {
                    row[*i as usize - a] = *n;
                }
                for (o, v) in out.chunks_exact_mut(2).zip(row.as_flattened()) {
                    o.copy_from_slice(&v.to_be_bytes());
                }
            },
        )?)
    }

    /// height.png: the heights over their range, 16-bit.
    fn height_png(&self) -> crate::Result<()> {
        let (w, h) = (self.bio.width, self.bio.height);
        let (range, span) = (self.range, self.span);
        Ok(write_png_rows(
            &self.path(outputs::HEIGHT_PNG),
            w,
            h,
            1,
            PngDepth::Sixteen,
            |y, out| {
                for (o, s) in out
                    .chunks_exact_mut(2)
                    .zip(&self.bio.texels[y * w..(y + 1) * w])
                {
                    let v = quantize16((s.height_mm - range.min_mm) / span);
                    o.copy_from_slice(&v.to_be_bytes());
                }
            },
        )?)
    }

    /// hair_coverage.png: the hair's coverage, 8-bit.
    fn hair_coverage(&self) -> crate::Result<()> {
        let (w, h) = (self.bio.width, self.bio.height);
        Ok(write_png_rows(
            &self.path(outputs::HAIR_COVERAGE),
            w,
            h,
            1,
            PngDepth::Eight,
            |y, out| {
                for (o, s) in out.iter_mut().zip(&self.bio.texels[y * w..(y + 1) * w]) {
                    *o = quantize8(s.extra[3]);
                }
            },
        )?)
    }
}

/// bio.exr's compression: RLE (see BENCHMARKS.md, "EXR compression", for the alternatives'
/// sizes and times).
pub const BIO_COMPRESSION: ExrCompression = ExrCompression::Rle;

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
