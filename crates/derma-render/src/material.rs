//! The materials the renderer draws: a derma texture set (from `derma skin`'s output directory
//! or straight from memory) as linear maps, and the built-in parts' materials (eyes with their
//! iris texture, lash cards, teeth, tongue).

use crate::error::{RenderError, Result};
use derma_core::image_io::read_rgb;
use derma_core::Map;
use derma_skin::outputs;
use derma_skin::texture_set::{RenderMaps, SSS_RADIUS_RANGE_MM};
use std::path::Path;

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
        return Err(RenderError::Input {
            path: path.to_path_buf(),
            detail: format!(
                "is {}×{}; base_color.png is {w}×{h} (every map of a set must be the same size)",
                m.width(),
                m.height()
            ),
        });
    }
    Ok(())
}

impl SkinMaps {
    /// Reads a texture set written by `derma skin` (base_color, normal, roughness, specular and,
    /// when present, sss_color and sss_radius).
    pub fn from_dir(dir: &Path) -> Result<SkinMaps> {
        let need = |f: &str| {
            let p = dir.join(f);
            if p.is_file() {
                Ok(p)
            } else {
                Err(RenderError::Input {
                    path: p,
                    detail: "missing; expected a texture set from `derma skin --out DIR`".into(),
                })
            }
        };
        let bp = need(outputs::BASE_COLOR)?;
        let base_color = decode_srgb(three(&bp)?);
        let (w, h) = (base_color[0].width(), base_color[0].height());
        let np = need(outputs::NORMAL)?;
        let normal = three(&np)?;
        check_size(&np, &normal[0], w, h)?;
        let rp = need(outputs::ROUGHNESS)?;
        let roughness = three(&rp)?[0].clone();
        check_size(&rp, &roughness, w, h)?;
        let sp = need(outputs::SPECULAR)?;
        let specular = three(&sp)?[0].clone();
        check_size(&sp, &specular, w, h)?;
        let (cp, rdp) = (dir.join(outputs::SSS_COLOR), dir.join(outputs::SSS_RADIUS));
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
        Ok(SkinMaps {
            base_color,
            normal,
            roughness,
            specular,
            subsurface,
            wrap: false,
        })
    }

    /// The maps of a texture set in memory (`derma skin`'s preview).
    pub fn from_render_maps(r: &RenderMaps, wrap: bool) -> SkinMaps {
        let enc = |mut m: Map| {
            m.data_mut().iter_mut().for_each(|v| *v = 0.5 * *v + 0.5);
            m
        };
        SkinMaps {
            base_color: r.decode_base_color(),
            normal: r.decode_normal().map(enc),
            roughness: r.decode_roughness(),
            specular: r.decode_specular(),
            subsurface: r.decode_subsurface(),
            wrap,
        }
    }

    /// (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.base_color[0].width(), self.base_color[0].height())
    }
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

/// The lash cards' coverage ([`derma_head::eye::lash_coverage`]) as an `n`×`n` map.
pub fn lash_coverage_map(n: usize) -> Map {
    let mut m = Map::filled(n, n, 0.0);
    for y in 0..n {
        for x in 0..n {
            let uv = glam::Vec2::new(
                (x as f32 + 0.5) / n as f32,
                1.0 - (y as f32 + 0.5) / n as f32,
            );
            m.set(x, y, derma_head::eye::lash_coverage(uv));
        }
    }
    m
}
