//! A look at a frame (Jimenez et al. 2010 fig. 2): the built-in head rendered with the frame's
//! colour as base colour, beside the same head shaded by its hemoglobin map as grey (dark =
//! more blood). Needs maps on the built-in head's UV layout (those `derma skin` paints).

use crate::error::Result;
use derma_core::Map;

/// Top of the preview's hemoglobin scale (volume fraction): grey = 1 − H / PREVIEW_BLOOD_TOP,
/// dark = more blood, clipped: 0.1, the lips' blood and the top of the built-in match table, so
/// the face's regional variation (1–8 %) shows.
pub const PREVIEW_BLOOD_TOP: f32 = 0.1;

/// The built-in head rendered with `rgb` as base colour, and again with the hemoglobin map as
/// display grey (dark = more blood), side by side (linear RGB).
pub fn preview(rgb: &[Map; 3], h: &Map) -> Result<[Map; 3]> {
    use derma_render::cpu::{head_props, render_with, FlatMaterial};
    const PANEL: usize = 512;
    let head = derma_head::Head::builtin();
    let mesh = &head.skin;
    let tangents = derma_core::mesh::mikktspace_tangents(mesh);
    let props = head_props(head);
    let (w, hh) = (h.width(), h.height());
    // Skin-like specular (F0 = 0.35 × 0.08 = 2.8 %, Kelemen/Jimenez) and roughness, flat normals.
    let material = FlatMaterial::new(0.45, 0.35);
    let shade = |base: &[Map; 3]| {
        render_with(
            mesh,
            &tangents,
            &material.textures(base),
            &props,
            0.0,
            PANEL,
        )
    };
    let color = shade(rgb);
    let grey = Map::from_vec(
        w,
        hh,
        h.data()
            .iter()
            .map(|v| derma_core::color::srgb_decode((1.0 - v / PREVIEW_BLOOD_TOP).clamp(0.0, 1.0)))
            .collect(),
    )?;
    let blood = shade(&[grey.clone(), grey.clone(), grey]);
    Ok([0, 1, 2].map(|k| {
        let mut out = Map::filled(2 * PANEL, PANEL, 0.0);
        for y in 0..PANEL {
            for x in 0..PANEL {
                out.set(x, y, color[k].get(x, y));
                out.set(PANEL + x, y, blood[k].get(x, y));
            }
        }
        out
    }))
}

/// Writes [`preview`] as an 8-bit sRGB PNG.
pub fn write_preview(path: &std::path::Path, rgb: &[Map; 3], h: &Map) -> Result<()> {
    let img = preview(rgb, h)?;
    derma_core::image_io::write_png8_srgb(path, &[&img[0], &img[1], &img[2]])?;
    Ok(())
}
