//! A look at a frame (Jimenez et al. 2010 fig. 2): the face template rendered with the frame's
//! colour as base colour, beside the same head shaded by its hemoglobin map as grey (dark =
//! more blood). Needs maps on the template's UV layout (those `derma skin` paints).

use crate::error::Result;
use derma_core::Map;

/// Top of the preview's hemoglobin scale (volume fraction): grey = 1 − H / PREVIEW_BLOOD_TOP,
/// dark = more blood, clipped (lips and moles saturate so the face's variation shows).
pub const PREVIEW_BLOOD_TOP: f32 = 0.03;

/// The template head rendered with `rgb` as base colour, and again with the hemoglobin map as
/// display grey (dark = more blood), side by side (linear RGB).
pub fn preview(rgb: &[Map; 3], h: &Map) -> Result<[Map; 3]> {
    use derma_skin::preview::render;
    use derma_skin::texture_set::RenderMaps;
    const PANEL: usize = 512;
    let mesh = derma_skin::builtin_head::head_mesh();
    let tangents = derma_skin::surface::mikktspace_tangents(&mesh);
    let (w, hh) = (h.width(), h.height());
    let flat = |v: f32| Map::filled(w, hh, v);
    let maps = |base: [Map; 3]| RenderMaps {
        base_color: base,
        // Skin-like specular (F0 2.8 %, Kelemen/Jimenez) and roughness, flat normals.
        roughness: flat(0.45),
        specular: flat(0.35),
        normal: [flat(0.0), flat(0.0), flat(1.0)],
        height_mm: flat(0.0),
        subsurface: None,
    };
    let shade = |m: &RenderMaps| {
        render(
            &mesh,
            &tangents,
            &derma_skin::preview::Textures {
                maps: m,
                wrap: false,
                uv_scale: glam::Vec2::ONE,
            },
            0.0,
            PANEL,
        )
    };
    let color = shade(&maps(rgb.clone()));
    let grey = Map::from_vec(
        w,
        hh,
        h.data()
            .iter()
            .map(|v| derma_core::color::srgb_decode((1.0 - v / PREVIEW_BLOOD_TOP).clamp(0.0, 1.0)))
            .collect(),
    )?;
    let blood = shade(&maps([grey.clone(), grey.clone(), grey]));
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
