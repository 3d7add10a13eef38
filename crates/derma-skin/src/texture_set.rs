//! Bio maps → the renderer's texture set (thesis §4.8.8, mmd(FEATURE(…))): base colour through an
//! [`Appearance`], roughness and specular from documented skin values modulated by lips and hair,
//! height and normal maps; dilation into the UV gutter; and the map files of [`crate::outputs`].

use crate::config::MaterialConfig;
use crate::features::BioSample;
use crate::outputs;
use crate::paint::{BioMaps, BIO_CHANNELS};
use crate::surface::Surface;
use derma_core::color::srgb8_decode;
use derma_core::exr_writer::{write_exr_rows, ExrChannel, ExrCompression, ExrRowSink};
use derma_core::image_io::{
    quantize16, quantize8, srgb8, write_png_rows, ExrPrecision, PngDepth, PngRowSink,
};
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
    /// Rows of `band` (a band of the same width) copied in at row `first_row`: every map
    /// this one has but the wrinkle normals.
    pub(crate) fn copy_rows(&mut self, band: &RenderMaps, first_row: usize) {
        let at = first_row * self.width..(first_row + band.height) * self.width;
        self.base_color[at.clone()].copy_from_slice(&band.base_color);
        self.roughness[at.clone()].copy_from_slice(&band.roughness);
        self.specular[at.clone()].copy_from_slice(&band.specular);
        self.normal[at.clone()].copy_from_slice(&band.normal);
        if let (Some(all), Some(b)) = (self.subsurface.as_mut(), band.subsurface.as_ref()) {
            all.color[at.clone()].copy_from_slice(&b.color);
            all.radius[at].copy_from_slice(&b.radius);
        }
    }

    /// Maps of `width` × `height` texels, zero until [`convert`] fills them.
    pub(crate) fn zeroed(width: usize, height: usize, subsurface: bool) -> Self {
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

/// Bio samples by texel index: the whole maps, or a band of rows with the rows around it
/// (the streamed main job's, `crate::stream`).
pub trait Samples: Sync {
    /// The sample of texel `j`.
    fn at(&self, j: usize) -> &BioSample;
}

impl Samples for BioMaps {
    #[inline]
    fn at(&self, j: usize) -> &BioSample {
        &self.texels[j]
    }
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
    let mut maps = convert_rows(bio, 0..bio.height, surface, appearance, material);
    if let Some(src) = dilation {
        derma_core::raster::apply_dilation(&mut maps.normal, src);
        maps.wrinkle_normal = dilate_sparse(&maps.wrinkle_normal, src);
    }
    maps
}

/// The render maps of `rows` (a band; texel 0 of the result is the first row's first), read
/// from `bio` (which must hold those rows and the rows next to them), with no dilation: texels
/// outside the UV charts get the up normal. The wrinkle normals' texels are the image's.
pub fn convert_rows<S: Samples>(
    bio: &S,
    rows: std::ops::Range<usize>,
    surface: &Surface,
    appearance: &dyn Appearance,
    material: &MaterialConfig,
) -> RenderMaps {
    let w = surface.width;
    let has_sss = appearance
        .subsurface(&bio.at(rows.start * w).tissue)
        .is_some();
    let mut maps = RenderMaps::zeroed(w, rows.len(), has_sss);
    let mut strips = strips(&mut maps, rows.start);
    let ctx = Converter {
        bio,
        surface,
        appearance,
        material,
        skin: skin_surface(material, appearance),
    };
    strips.par_iter_mut().for_each(|st| ctx.strip(st));
    maps.wrinkle_normal = strips
        .into_iter()
        .flat_map(|st| st.wrinkle_normal)
        .collect();
    maps
}

/// `maps` cut into strips of [`CONVERT_ROWS`] rows, the first at image row `first_row`.
fn strips(maps: &mut RenderMaps, first_row: usize) -> Vec<Strip<'_>> {
    let n = maps.width * CONVERT_ROWS;
    let mut strips = Vec::with_capacity(maps.height.div_ceil(CONVERT_ROWS));
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
            first_row: first_row + k * CONVERT_ROWS,
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
    strips
}

/// What converting a strip reads.
struct Converter<'a, S> {
    bio: &'a S,
    surface: &'a Surface,
    appearance: &'a dyn Appearance,
    material: &'a MaterialConfig,
    skin: SkinSurface,
}

impl<S: Samples> Converter<'_, S> {
    /// Converts one strip of texels.
    fn strip(&self, st: &mut Strip) {
        let (bio, surface, material) = (self.bio, self.surface, self.material);
        let (w, h) = (surface.width, surface.height);
        let first = st.first_row * w;
        let len = st.roughness.len();
        // The appearance over the whole strip at once (the match table interpolates eight
        // texels per SIMD register).
        let tissue: Vec<BioTexel> = (first..first + len).map(|i| bio.at(i).tissue).collect();
        let mut shade = vec![([0.0f32; 3], None); len];
        self.appearance.shade_batch(&tissue, &mut shade);
        let height = |j: usize| bio.at(j).height_mm;
        let (skin_r, skin_f0) = (self.skin.roughness, self.skin.f0);
        for k in 0..len {
            let i = first + k;
            let (x, y) = (i % w, i / w);
            let t = bio.at(i);
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
            // texels off it are dilated later.
            st.normal[k] = if surface.covered(i) {
                normal_code(surface, bio, i)
            } else {
                [0.0f32, 0.0, 1.0].map(|v| quantize16(0.5 * v + 0.5))
            };
            if let Some(n) = wrinkle_code(surface, bio, i) {
                st.wrinkle_normal.push((i as u32, n));
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
    }
}

/// normal.png's code at covered texel `i`, from the heights of `bio` around it.
pub fn normal_code<S: Samples + ?Sized>(surface: &Surface, bio: &S, i: usize) -> [u16; 3] {
    let w = surface.width;
    let n = crate::normal_map::tangent_normal(surface, |j| bio.at(j).height_mm, i % w, i / w);
    n.map(|v| quantize16(0.5 * v + 0.5))
}

/// wrinkle_normal.png's code at texel `i` where it differs from normal.png's: on the surface
/// within a texel of an expression furrow ([`near_furrow`]); `None` elsewhere.
pub fn wrinkle_code<S: Samples + ?Sized>(surface: &Surface, bio: &S, i: usize) -> Option<[u16; 3]> {
    let (w, h) = (surface.width, surface.height);
    let wrap = surface.period().is_some();
    let furrow = |j: usize| bio.at(j).furrow_mm;
    if !surface.covered(i) || !near_furrow(furrow, (w, h), (i % w, i / w), wrap) {
        return None;
    }
    let with_furrows = |j: usize| bio.at(j).height_mm + bio.at(j).furrow_mm;
    let n = crate::normal_map::tangent_normal(surface, with_furrows, i % w, i / w);
    Some(n.map(|v| quantize16(0.5 * v + 0.5)))
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

/// The range of heights (mm) of every texel.
pub fn range_of(heights: &[f32]) -> HeightRange {
    range_by(heights, |&v| v)
}

/// The range of the painted heights (every texel, the gutter's dilated ones included).
pub fn height_range(bio: &BioMaps) -> HeightRange {
    range_by(&bio.texels, |t| t.height_mm)
}

/// The least and greatest `height(item)` of `items`.
fn range_by<T: Sync>(items: &[T], height: impl Fn(&T) -> f32 + Sync) -> HeightRange {
    let (lo, hi) = items
        .par_iter()
        .fold(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |(lo, hi), t| (lo.min(height(t)), hi.max(height(t))),
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

/// bio.exr: every bio channel ([`BIO_CHANNELS`]) as half floats, with `compression` (the main
/// job uses [`BIO_COMPRESSION`]; the `exr_compression` bench compares the others).
pub fn write_bio_exr(path: &Path, bio: &BioMaps, compression: ExrCompression) -> crate::Result<()> {
    let w = bio.width;
    let list = BIO_CHANNELS.map(|(name, _)| ExrChannel {
        name,
        precision: ExrPrecision::F16,
    });
    Ok(write_exr_rows(
        path,
        w,
        bio.height,
        &list,
        compression,
        |y, rows| {
            for (x, s) in bio.texels[y * w..(y + 1) * w].iter().enumerate() {
                for (row, v) in rows.iter_mut().zip(s.channels()) {
                    row[x] = v;
                }
            }
        },
    )?)
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

/// Writes the maps of the texture set into `dir` (each atomically; every file streamed from the
/// bio samples or the render maps by rows, with no whole-image copy): every file of
/// [`crate::outputs::OUTPUTS`] but features.json, preview.png, manifest.json and report.json,
/// the subsurface maps only when `maps` has them. Returns the files written and the height
/// range of height.png. The streamed main job pushes the same files band by band.
pub fn write_maps(
    dir: &Path,
    bio: &BioMaps,
    maps: &RenderMaps,
) -> crate::Result<(Vec<&'static str>, HeightRange)> {
    let range = height_range(bio);
    let mut sinks = MapSinks::create(dir, bio.width, bio.height, maps.subsurface.is_some())?;
    sinks.push(bio, maps, 0)?;
    let mut files = sinks.finish()?;
    write_height_png(dir, (bio.width, bio.height), range, |i| {
        bio.texels[i].height_mm
    })?;
    files.push(outputs::HEIGHT_PNG);
    Ok((in_manifest_order(&files), range))
}

/// The files written, in manifest order.
pub fn in_manifest_order(written: &[&'static str]) -> Vec<&'static str> {
    outputs::OUTPUTS
        .iter()
        .map(|o| o.file)
        .filter(|f| written.contains(f))
        .collect()
}

/// height.png of a `size` map: the heights (`height(i)`, mm) over `range`, 16-bit.
pub fn write_height_png(
    dir: &Path,
    (w, h): (usize, usize),
    range: HeightRange,
    height: impl Fn(usize) -> f32 + Sync,
) -> crate::Result<()> {
    let span = (range.max_mm - range.min_mm).max(1e-9);
    Ok(write_png_rows(
        &dir.join(outputs::HEIGHT_PNG),
        w,
        h,
        1,
        PngDepth::Sixteen,
        |y, out| {
            for (x, o) in out.chunks_exact_mut(2).enumerate() {
                let v = quantize16((height(y * w + x) - range.min_mm) / span);
                o.copy_from_slice(&v.to_be_bytes());
            }
        },
    )?)
}

/// A map file being written: a PNG or an EXR.
enum Sink {
    Png(Box<PngRowSink>),
    Exr(Box<ExrRowSink>),
}

/// Every map file but height.png (which needs the heights' range first), written from rows
/// pushed band by band ([`MapSinks::push`]), the files side by side.
pub struct MapSinks {
    sinks: Vec<(&'static str, Sink)>,
    width: usize,
}

/// The rows of one band: the bio samples (by texel, [`Samples`]) and the band's render maps,
/// whose texel 0 is the first row's first.
struct BandRows<'a, S: ?Sized> {
    bio: &'a S,
    maps: &'a RenderMaps,
    first_row: usize,
    width: usize,
}

impl MapSinks {
    /// Starts every map file of a `width` × `height` set in `dir`, the subsurface maps' with
    /// `subsurface`, largest first (the last to finish a band are short).
    pub fn create(
        dir: &Path,
        width: usize,
        height: usize,
        subsurface: bool,
    ) -> crate::Result<Self> {
        let (f16, f32) = (ExrPrecision::F16, ExrPrecision::F32);
        let exr = |file: &'static str, names: &[&str], precision, compression| {
            let list: Vec<ExrChannel> = names
                .iter()
                .map(|&name| ExrChannel { name, precision })
                .collect();
            let s = ExrRowSink::create(&dir.join(file), width, height, &list, compression);
            Ok::<_, crate::SkinError>((file, Sink::Exr(Box::new(s?))))
        };
        let png = |file: &'static str, channels, depth| {
            let s = PngRowSink::create(&dir.join(file), width, height, channels, depth)?;
            Ok::<_, crate::SkinError>((file, Sink::Png(Box::new(s))))
        };
        let none = ExrCompression::None;
        let bio_names = BIO_CHANNELS.map(|(n, _)| n);
        let mut sinks = vec![
            exr(outputs::BIO, &bio_names, f16, BIO_COMPRESSION)?,
            exr(
                outputs::MELANIN,
                &[names::MELANIN, names::PHEOMELANIN],
                f32,
                none,
            )?,
            exr(
                outputs::HEMOGLOBIN,
                &[names::HEMOGLOBIN, names::OXYGENATION],
                f32,
                none,
            )?,
            png(outputs::NORMAL, 3, PngDepth::Sixteen)?,
            png(outputs::WRINKLE_NORMAL, 3, PngDepth::Sixteen)?,
            exr(
                outputs::HEIGHT_EXR,
                &["height_mm", "height_mm_furrow"],
                f32,
                none,
            )?,
            png(outputs::BASE_COLOR, 3, PngDepth::Eight)?,
            png(outputs::ROUGHNESS, 1, PngDepth::Eight)?,
            png(outputs::SPECULAR, 1, PngDepth::Eight)?,
            png(outputs::HAIR_COVERAGE, 1, PngDepth::Eight)?,
        ];
        if subsurface {
            sinks.insert(4, png(outputs::SSS_RADIUS, 3, PngDepth::Sixteen)?);
            sinks.push(png(outputs::SSS_COLOR, 3, PngDepth::Eight)?);
        }
        Ok(Self { sinks, width })
    }

    /// Appends the rows of `maps` (a band starting at image row `first_row`) to every file,
    /// the bio samples read from `bio`; the files in parallel.
    pub fn push<S: Samples>(
        &mut self,
        bio: &S,
        maps: &RenderMaps,
        first_row: usize,
    ) -> crate::Result<()> {
        let band = BandRows {
            bio,
            maps,
            first_row,
            width: self.width,
        };
        self.sinks
            .par_iter_mut()
            .map(|(file, sink)| band.push(file, sink))
            .collect::<crate::Result<Vec<()>>>()?;
        Ok(())
    }

    /// Ends every file; returns their names.
    pub fn finish(self) -> crate::Result<Vec<&'static str>> {
        let mut files = Vec::with_capacity(self.sinks.len());
        for (file, sink) in self.sinks {
            match sink {
                Sink::Png(s) => s.finish()?,
                Sink::Exr(s) => s.finish()?,
            }
            files.push(file);
        }
        Ok(files)
    }
}

impl<S: Samples + ?Sized> BandRows<'_, S> {
    /// The bio samples of image row `y`'s texels.
    fn samples(&self, y: usize) -> impl Iterator<Item = &BioSample> {
        (y * self.width..(y + 1) * self.width).map(|i| self.bio.at(i))
    }

    /// Image row `y`'s texels in the band's render maps.
    fn span(&self, y: usize) -> std::ops::Range<usize> {
        let a = (y - self.first_row) * self.width;
        a..a + self.width
    }

    /// Pushes the band's rows of `file` to `sink`.
    fn push(&self, file: &str, sink: &mut Sink) -> crate::Result<()> {
        let n = self.maps.height;
        match sink {
            Sink::Exr(s) => Ok(s.push(n, |y, rows| self.exr_row(file, y, rows))?),
            Sink::Png(s) => Ok(s.push(n, |y, out| self.png_row(file, y, out))?),
        }
    }

    /// Line `y` of an EXR map, every channel.
    fn exr_row(&self, file: &str, y: usize, rows: &mut [&mut [f32]]) {
        match file {
            outputs::BIO => self.line(y, rows, BioSample::channels),
            outputs::MELANIN => self.line(y, rows, |s| [s.tissue.melanin, s.tissue.pheomelanin]),
            outputs::HEMOGLOBIN => self.line(y, rows, |s| [s.tissue.blood, s.tissue.oxygenation]),
            _ => self.line(y, rows, |s| [s.height_mm, s.furrow_mm]),
        }
    }

    /// Line `y` of `C` channels, each texel's from `values`.
    fn line<const C: usize>(
        &self,
        y: usize,
        rows: &mut [&mut [f32]],
        values: impl Fn(&BioSample) -> [f32; C],
    ) {
        for (x, s) in self.samples(y).enumerate() {
            let v = values(s);
            for c in 0..C {
                rows[c][x] = v[c];
            }
        }
    }

    /// Row `y` of a PNG map, as the file stores it.
    fn png_row(&self, file: &str, y: usize, out: &mut [u8]) {
        let (m, span) = (self.maps, self.span(y));
        let sixteen = |out: &mut [u8], px: &[[u16; 3]]| {
            for (o, v) in out.chunks_exact_mut(2).zip(px.as_flattened()) {
                o.copy_from_slice(&v.to_be_bytes());
            }
        };
        match file {
            outputs::NORMAL => sixteen(out, &m.normal[span]),
            outputs::WRINKLE_NORMAL => sixteen(out, &self.wrinkle_row(y)),
            outputs::SSS_RADIUS => sixteen(out, &m.subsurface.as_ref().expect("sss").radius[span]),
            outputs::BASE_COLOR => out.copy_from_slice(m.base_color[span].as_flattened()),
            outputs::SSS_COLOR => {
                out.copy_from_slice(m.subsurface.as_ref().expect("sss").color[span].as_flattened())
            }
            outputs::ROUGHNESS => out.copy_from_slice(&m.roughness[span]),
            outputs::SPECULAR => out.copy_from_slice(&m.specular[span]),
            _ => {
                for (o, s) in out.iter_mut().zip(self.samples(y)) {
                    *o = quantize8(s.extra[3]);
                }
            }
        }
    }

    /// wrinkle_normal.png's row `y`: normal.png's with the sparse wrinkle normals laid over it.
    fn wrinkle_row(&self, y: usize) -> Vec<[u16; 3]> {
        let (a, b) = (y * self.width, (y + 1) * self.width);
        let wn = &self.maps.wrinkle_normal;
        let first = wn.partition_point(|e| (e.0 as usize) < a);
        let last = wn.partition_point(|e| (e.0 as usize) < b);
        let mut row = self.maps.normal[self.span(y)].to_vec();
        for (i, n) in &wn[first..last] {
            row[*i as usize - a] = *n;
        }
        row
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
