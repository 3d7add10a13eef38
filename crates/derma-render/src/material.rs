//! The materials the renderer draws: a derma texture set (from `derma skin`'s output directory,
//! or built by derma-skin's `RenderMaps::skin_maps` in memory) as linear maps, the file names
//! and encodings it reads, and the built-in parts' materials (eyes with their iris texture, lash
//! cards, teeth, tongue).

use crate::error::{RenderError, Result};
use derma_core::image_io::read_rgb;
use derma_core::Map;
use std::path::Path;

/// The files of a render texture set as the renderer reads them (the Substance/Unreal names;
/// derma-skin writes them under these names, docs/render.md lists their encodings).
pub mod files {
    /// `base_color.png`: diffuse albedo, 8-bit sRGB.
    pub const BASE_COLOR: &str = "base_color.png";
    /// `normal.png`: tangent-space normal as n·½ + ½.
    pub const NORMAL: &str = "normal.png";
    /// `roughness.png`: perceptual roughness.
    pub const ROUGHNESS: &str = "roughness.png";
    /// `specular.png`: F0 / [`super::SPECULAR_SCALE`].
    pub const SPECULAR: &str = "specular.png";
    /// `sss_color.png`: Burley's surface albedo, 8-bit sRGB.
    pub const SSS_COLOR: &str = "sss_color.png";
    /// `sss_radius.png`: mean free path / [`super::SSS_RADIUS_RANGE_MM`], 16-bit.
    pub const SSS_RADIUS: &str = "sss_radius.png";
    /// `lashes.png`: the lash cards' colour (sRGB) and coverage (alpha), 8-bit RGBA.
    pub const LASHES: &str = "lashes.png";
    /// `hair_coverage.png`: the hair's coverage, 8-bit.
    pub const HAIR_COVERAGE: &str = "hair_coverage.png";
    /// `wrinkle_normal.png`: the normal with every expression furrow at full activation.
    pub const WRINKLE_NORMAL: &str = "wrinkle_normal.png";
    /// `wrinkle_masks.exr`: the regions of expression wrinkles, a channel each.
    pub const WRINKLE_MASKS: &str = "wrinkle_masks.exr";
}

/// [`crate::Rendered::material`] of the skin mesh.
pub const MATERIAL_SKIN: u8 = 1;
/// [`crate::Rendered::material`] of an eye globe.
pub const MATERIAL_EYE: u8 = 2;
/// [`crate::Rendered::material`] of anything else: lashes, teeth, tongue, the background.
pub const MATERIAL_OTHER: u8 = 0;

/// Specular maps store F0 / 0.08 (the Unreal/Substance "specular" convention: 0.5 ↔ F0 = 4 %).
pub const SPECULAR_SCALE: f32 = 0.08;

/// Largest side of the hair coverage the brow cards are drawn with (box-reduced from the set's).
pub const HAIR_CARD_SIZE: usize = 2048;

/// The hair coverage of `path`, box-reduced by a whole factor to at most [`HAIR_CARD_SIZE`].
pub fn read_hair_coverage(path: &Path) -> Result<Map> {
    let m = derma_core::image_io::read_grey(path)?
        .channels
        .swap_remove(0);
    let (w, h) = (m.width(), m.height());
    let k = w.max(h).div_ceil(HAIR_CARD_SIZE).max(1);
    if k == 1 {
        return Ok(m);
    }
    let [r] = derma_core::map::box_reduced(w, h, k, |i| [m.data()[i]]);
    Ok(r)
}

/// sss_radius.png stores ℓ / SSS_RADIUS_RANGE_MM (16-bit): 0–8 mm, the radial profile's range.
pub const SSS_RADIUS_RANGE_MM: f32 = 8.0;

/// A skin texture set as linear maps (all the same size).
#[derive(Clone)]
pub struct SkinMaps {
    /// Diffuse albedo, linear RGB.
    pub base_color: [Map; 3],
    /// Tangent-space normal encoded n·½ + ½ (as normal.png stores it).
    pub normal: [Map; 3],
    /// Perceptual roughness.
    pub roughness: Map,
    /// Specular level (F0 / 0.08).
    pub specular: Map,
    /// Burley's surface albedo (linear RGB) and mean free path (mm) per channel, when the set
    /// has them; without them the skin is lit without subsurface scattering.
    pub subsurface: Option<([Map; 3], [Map; 3])>,
    /// The hair's colour (linear RGB) for the lash cards (lashes.png in a set on the built-in
    /// head); `None`: the cards' authored look ([`derma_head::Look`]).
    pub lash_color: Option<[f32; 3]>,
    /// The hair's coverage (hair_coverage.png, at most [`HAIR_CARD_SIZE`]²), when the set has
    /// it: on the built-in head the brows stand on it as cards ([`derma_head::brows`]).
    pub hair: Option<Map>,
    /// Repeat the maps (tileable patches).
    pub wrap: bool,
}

fn decode_srgb(mut maps: [Map; 3]) -> [Map; 3] {
    for m in &mut maps {
        m.data_mut()
            .iter_mut()
            .for_each(|v| *v = derma_core::color::srgb_decode(*v));
    }
    maps
}

fn three(path: &Path) -> Result<[Map; 3]> {
    let img = read_rgb(path)?;
    let mut it = img.channels.into_iter();
    Ok([
        it.next().expect("rgb"),
        it.next().expect("rgb"),
        it.next().expect("rgb"),
    ])
}

fn check_size(path: &Path, m: &Map, w: usize, h: usize) -> Result<()> {
    if (m.width(), m.height()) != (w, h) {
        return Err(RenderError::from(derma_core::CoreError::Format {
            path: path.to_path_buf(),
            message: format!(
                "is {}×{}; base_color.png is {w}×{h} (every map of a set must be the same size)",
                m.width(),
                m.height()
            ),
        }));
    }
    Ok(())
}

impl SkinMaps {
    /// A uniform skin: one linear albedo `rgb`, flat normals, one perceptual `roughness` and
    /// one specular level (F0 / 0.08), as 1×1 maps (a plain material for a mesh, a test scene).
    pub fn uniform(rgb: [f32; 3], roughness: f32, specular: f32) -> SkinMaps {
        let one = |v: f32| Map::filled(1, 1, v);
        SkinMaps {
            base_color: rgb.map(one),
            normal: [one(0.5), one(0.5), one(1.0)],
            roughness: one(roughness),
            specular: one(specular),
            subsurface: None,
            lash_color: None,
            hair: None,
            wrap: false,
        }
    }

    /// Reads a texture set written by `derma skin` (base_color, normal, roughness, specular and,
    /// when present, sss_color and sss_radius).
    pub fn from_dir(dir: &Path) -> Result<SkinMaps> {
        let need = |f: &str| {
            let p = dir.join(f);
            if p.is_file() {
                Ok(p)
            } else {
                Err(RenderError::from(derma_core::CoreError::Format {
                    path: p,
                    message: "missing; expected a texture set as derma skin writes it".into(),
                }))
            }
        };
        let bp = need(files::BASE_COLOR)?;
        let base_color = decode_srgb(three(&bp)?);
        let (w, h) = (base_color[0].width(), base_color[0].height());
        let np = need(files::NORMAL)?;
        let normal = three(&np)?;
        check_size(&np, &normal[0], w, h)?;
        let rp = need(files::ROUGHNESS)?;
        let roughness = three(&rp)?[0].clone();
        check_size(&rp, &roughness, w, h)?;
        let sp = need(files::SPECULAR)?;
        let specular = three(&sp)?[0].clone();
        check_size(&sp, &specular, w, h)?;
        let (cp, rdp) = (dir.join(files::SSS_COLOR), dir.join(files::SSS_RADIUS));
        let subsurface = if cp.is_file() && rdp.is_file() {
            let c = decode_srgb(three(&cp)?);
            check_size(&cp, &c[0], w, h)?;
            let mut r = three(&rdp)?;
            check_size(&rdp, &r[0], w, h)?;
            for m in &mut r {
                m.data_mut()
                    .iter_mut()
                    .for_each(|v| *v *= SSS_RADIUS_RANGE_MM);
            }
            Some((c, r))
        } else {
            None
        };
        let lp = dir.join(files::LASHES);
        let lash_color = if lp.is_file() {
            let c = three(&lp)?;
            Some(std::array::from_fn(|k| {
                derma_core::color::srgb_decode(c[k].get(0, 0))
            }))
        } else {
            None
        };
        let hp = dir.join(files::HAIR_COVERAGE);
        let hair = if hp.is_file() {
            Some(read_hair_coverage(&hp)?)
        } else {
            None
        };
        Ok(SkinMaps {
            base_color,
            normal,
            roughness,
            specular,
            subsurface,
            lash_color,
            hair,
            wrap: false,
        })
    }

    /// (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.base_color[0].width(), self.base_color[0].height())
    }
}

/// An albedo texture as linear RGB maps and, where the file has one, its alpha: EXR as stored,
/// other formats (PNG, JPEG) sRGB-decoded — how `derma photo iris` and `derma photo teeth` textures
/// are read for the parts.
pub fn read_albedo(path: &std::path::Path) -> crate::Result<AlbedoTexture> {
    let img = derma_core::image_io::read_rgb(path)?;
    let alpha = img.alpha;
    let exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let mut rgb: [Map; 3] = img.channels.try_into().map_err(|c: Vec<Map>| {
        crate::RenderError::Invalid(derma_core::Invalid::new(
            format!("albedo texture '{}'", path.display()),
            "an RGB image",
            format!("{} channels", c.len()),
        ))
    })?;
    if !exr {
        for m in rgb.iter_mut() {
            m.data_mut()
                .iter_mut()
                .for_each(|v| *v = derma_core::color::srgb_decode(*v));
        }
    }
    Ok(AlbedoTexture { rgb, alpha })
}

/// A part's albedo texture as [`read_albedo`] reads it.
#[derive(Clone)]
pub struct AlbedoTexture {
    /// Linear RGB.
    pub rgb: [Map; 3],
    /// The file's alpha (coverage: 0 where the part is a void, as `derma photo teeth` writes
    /// between the teeth), where it has one.
    pub alpha: Option<Map>,
}

/// Linear RGB maps of size `n`×`n` on the eye globe's UVs (derma-head's azimuthal map): the
/// built-in eye ([`derma_head::eye::default_albedo`]) or a `derma photo iris` texture.
pub fn default_eye_texture(n: usize) -> [Map; 3] {
    let mut out = [
        Map::filled(n, n, 0.0),
        Map::filled(n, n, 0.0),
        Map::filled(n, n, 0.0),
    ];
    for y in 0..n {
        for x in 0..n {
            // Row 0 is the top: v = 1 − (y + ½)/n.
            let uv = glam::Vec2::new(
                (x as f32 + 0.5) / n as f32,
                1.0 - (y as f32 + 0.5) / n as f32,
            );
            let c = derma_head::eye::default_albedo(uv);
            for k in 0..3 {
                out[k].set(x, y, c[k]);
            }
        }
    }
    out
}
