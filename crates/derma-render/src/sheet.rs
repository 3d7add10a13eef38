//! Layouts of renders for people to judge: `derma skin`'s preview views on the GPU, contact
//! sheets (views under each lighting setup beside the raw maps) and turntables.

use crate::camera::View;
use crate::error::Result;
use crate::lighting::Setup;
use crate::material::SkinMaps;
use crate::renderer::Renderer;
use crate::scene::Scene;
use derma_core::gpu::Device;
use derma_core::preview::{compose, normalised};
use derma_core::Map;
use derma_skin::config::SurfaceKind;
use derma_skin::TextureSet;

/// The front and three-quarter views of `derma skin`'s preview, rendered on the GPU when
/// `device` resolves to one and the set is on a mesh; with the adapter's name. `None`: the
/// software preview is the one to use (no GPU, `--device cpu`, or a flat patch).
pub fn skin_views(set: &TextureSet, device: Device) -> Result<Option<(Vec<[Map; 3]>, String)>> {
    if device.resolve().ok() != Some(Device::Gpu) {
        return Ok(None);
    }
    let Some((mesh, _)) = set.preview_mesh.as_ref() else {
        return Ok(None);
    };
    let maps = SkinMaps::from_render_maps(&set.render, false);
    let scene = if set.inputs.surface == SurfaceKind::Template {
        Scene::head(derma_head::Head::builtin(), maps, &[], None, (0.0, 0.0))
    } else {
        Scene::mesh(mesh, maps)
    };
    let r = Renderer::new(&scene)?;
    let panel = derma_skin::preview::PANEL as u32;
    let mut views = Vec::new();
    for yaw in [0.0, 45.0] {
        let v = View {
            yaw_deg: yaw,
            ..Default::default()
        };
        views.push(linear(
            r.render(&v, &Setup::Studio.lighting(), panel, panel)?
                .display_maps(),
        ));
    }
    Ok(Some((views, r.adapter.clone())))
}

/// Display values decoded back to linear (derma-core's [`compose`] encodes its renders).
fn linear(mut m: [Map; 3]) -> [Map; 3] {
    for c in &mut m {
        c.data_mut()
            .iter_mut()
            .for_each(|v| *v = derma_core::color::srgb_decode(*v));
    }
    m
}

/// Thumbnails of the raw maps (sRGB-encoded where colour, normalised where data): base
/// colour, normal, roughness, specular, and with subsurface maps sss colour and radius.
pub fn map_thumbnails(s: &SkinMaps, size: usize) -> Vec<[Map; 3]> {
    let small = |m: &Map| m.resized(size, size);
    let enc = |c: &[Map; 3]| {
        c.clone().map(|m| {
            let mut m = small(&m);
            m.data_mut()
                .iter_mut()
                .for_each(|v| *v = derma_core::color::srgb_encode(*v));
            m
        })
    };
    let grey = |m: &Map| {
        let m = small(m);
        [m.clone(), m.clone(), m]
    };
    let mut out = vec![
        enc(&s.base_color),
        s.normal.clone().map(|m| small(&m)),
        grey(&s.roughness),
        grey(&s.specular),
    ];
    if let Some((c, r)) = &s.subsurface {
        out.push(enc(c));
        out.push(normalised(&small(&r[0])));
    }
    out
}

/// A contact sheet: for each setup a row of views (front, three-quarter, profile) at `panel`²,
/// the first row followed by the raw maps as thumbnails (3 × 2 at half the panel).
pub fn contact_sheet(
    r: &Renderer,
    skin: &SkinMaps,
    setups: &[Setup],
    panel: u32,
) -> Result<[Map; 3]> {
    let thumbs = map_thumbnails(skin, panel as usize / 2);
    let mut rows = Vec::new();
    for (i, s) in setups.iter().enumerate() {
        let mut views = Vec::new();
        for yaw in [0.0, 35.0, 90.0] {
            let v = View {
                yaw_deg: yaw,
                ..Default::default()
            };
            views.push(linear(
                r.render(&v, &s.lighting(), panel, panel)?.display_maps(),
            ));
        }
        let sheet: &[[Map; 3]] = if i == 0 { &thumbs } else { &[] };
        rows.push(compose(&views, sheet, panel as usize));
    }
    Ok(stack(&rows))
}

/// Rows stacked top to bottom, left-aligned on a black background.
fn stack(rows: &[[Map; 3]]) -> [Map; 3] {
    let w = rows.iter().map(|r| r[0].width()).max().unwrap_or(0);
    let h: usize = rows.iter().map(|r| r[0].height()).sum();
    let mut out = [
        Map::filled(w, h, 0.0),
        Map::filled(w, h, 0.0),
        Map::filled(w, h, 0.0),
    ];
    let mut y0 = 0;
    for r in rows {
        for k in 0..3 {
            for y in 0..r[k].height() {
                for x in 0..r[k].width() {
                    out[k].set(x, y0 + y, r[k].get(x, y));
                }
            }
        }
        y0 += r[0].height();
    }
    out
}

/// `frames` views in a full turn (yaw 0 → 360°) under `setup`, as 8-bit sRGB RGB frames.
pub fn turntable(
    r: &Renderer,
    setup: Setup,
    frames: usize,
    w: u32,
    h: u32,
) -> Result<Vec<Vec<u8>>> {
    (0..frames)
        .map(|i| {
            let v = View {
                yaw_deg: 360.0 * i as f32 / frames as f32,
                ..Default::default()
            };
            let img = r.render(&v, &setup.lighting(), w, h)?;
            Ok(img
                .display
                .chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect())
        })
        .collect()
}
