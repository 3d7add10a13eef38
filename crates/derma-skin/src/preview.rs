//! The texture set's preview: its maps shaded on its surface (derma-render: its GPU renderer
//! when there is one, its CPU renderer [`derma_render::cpu`] otherwise) in front and three-quarter views, next to a contact sheet of the
//! maps.

use crate::paint::BioMaps;
use crate::surface::Surface;
use crate::texture_set::RenderMaps;
use derma_core::mesh::TriMesh;
use derma_core::Map;
use derma_render::cpu::{render, render_with, sphere, tile, Prop};
use derma_render::sheet::{compose, normalised};

/// Side of a preview panel (pixels): shaded views are this size, thumbnails half.
pub const PANEL: usize = 512;

/// The front and three-quarter views of `derma skin`'s preview of `render_maps` on `mesh` (the
/// head with its parts when `template` is given), rendered on the GPU when `device` resolves to
/// one and the set is on a mesh; with the adapter's name. `None`: the CPU preview is the one to
/// use (no GPU, `--device cpu`, or a flat patch).
pub fn gpu_views(
    render_maps: &RenderMaps,
    mesh: Option<&(TriMesh, Vec<[f32; 4]>)>,
    template: Option<&derma_head::Head>,
    device: derma_core::gpu::Device,
) -> crate::Result<Option<(Vec<[Map; 3]>, String)>> {
    if device.resolve().ok() != Some(derma_core::gpu::Device::Gpu) {
        return Ok(None);
    }
    let Some((mesh, _)) = mesh else {
        return Ok(None);
    };
    let maps = render_maps.skin_maps(false);
    let scene = if let Some(head) = template {
        derma_render::Scene::head(head, maps, &[], None, (0.0, 0.0))
    } else {
        derma_render::Scene::mesh(mesh, maps)
    };
    let r = derma_render::renderer(&scene, derma_core::gpu::Device::Gpu)?;
    let panel = PANEL as u32;
    let mut views = Vec::new();
    for yaw in [0.0, 45.0] {
        let v = derma_render::View {
            yaw_deg: yaw,
            ..Default::default()
        };
        views.push(
            r.draw(&v, &derma_render::Setup::Studio.lighting(), panel, panel)?
                .display_linear_maps(),
        );
    }
    Ok(Some((views, r.name())))
}

/// The whole factor the contact sheet's thumbnails are box-reduced by first, for maps of
/// `width` × `height` texels: to about twice the thumbnails' size.
pub fn reduction(width: usize, height: usize) -> usize {
    (width.max(height) / PANEL).max(1)
}

/// The bio channels the contact sheet shows (height, melanin, blood) of a sample.
pub fn sheet_channels(s: &crate::features::BioSample) -> [f32; 3] {
    [s.height_mm, s.tissue.melanin, s.tissue.blood]
}

/// The contact sheet's bio channels of `bio`, box-reduced by [`reduction`].
pub fn reduced_bio(bio: &BioMaps) -> [Map; 3] {
    bio.channels_reduced(reduction(bio.width, bio.height), sheet_channels)
}

/// Shaded views of `render_maps` on its mesh (or a sphere and a tile for patches) plus the contact
/// sheet (base colour, normal, height, roughness, melanin, blood; the bio channels given
/// [`reduced_bio`]): preview.png. `shaded`: views
/// already rendered (by the GPU renderer, linear radiance after tone mapping, [`PANEL`]²); `None`
/// draws them with derma-render's CPU previews.
pub fn contact_sheet(
    render_maps: &RenderMaps,
    reduced: &[Map; 3],
    surface: &Surface,
    mesh: Option<&(TriMesh, Vec<[f32; 4]>)>,
    props: &[Prop],
    shaded: Option<Vec<[Map; 3]>>,
) -> [Map; 3] {
    let r = render_maps;
    let renders = match (shaded, mesh) {
        (Some(v), _) => v,
        (None, mesh) => match mesh {
            Some((m, t)) => {
                let tex = r.material(false, glam::Vec2::ONE);
                // Front and three-quarter (45°) views.
                vec![
                    render_with(m, t, &tex, props, 0.0, PANEL),
                    render_with(m, t, &tex, props, std::f32::consts::FRAC_PI_4, PANEL),
                ]
            }
            None => {
                let (sx, sy) = match &surface.geometry {
                    crate::surface::Geometry::Patch { size_mm, .. } => (size_mm[0], size_mm[1]),
                    _ => (1.0, 1.0),
                };
                // A sphere of radius 1.2 patch widths, the patch repeated at its physical size.
                let radius = 1.2 * sx;
                let (sm, st) = sphere(radius, 96);
                let scale = glam::Vec2::new(
                    2.0 * std::f32::consts::PI * radius / sx,
                    std::f32::consts::PI * radius / sy,
                );
                let (tm, tt) = tile(sx);
                vec![
                    render(&sm, &st, &r.material(true, scale), 0.0, PANEL),
                    render(&tm, &tt, &r.material(true, glam::Vec2::ONE), 0.0, PANEL),
                ]
            }
        },
    };
    // Thumbnails are downsampled first (area-averaged), then encoded or normalised.
    let t = PANEL / 2;
    let small = |m: &Map| m.resized(t, t);
    let enc = |m: &Map| {
        let mut m = small(m);
        m.data_mut()
            .iter_mut()
            .for_each(|v| *v = derma_core::color::srgb_encode(*v));
        m
    };
    let half = |m: &Map| {
        let mut m = small(m);
        m.data_mut().iter_mut().for_each(|v| *v = 0.5 * *v + 0.5);
        m
    };
    // Thumbnails from maps reduced to about twice their size first (no full-size copies).
    let (base, normal, rough) = r.reduced(reduction(r.width, r.height));
    let rough = small(&rough);
    let [height, melanin, blood] = reduced.each_ref().map(small);
    let sheet = vec![
        base.each_ref().map(enc),
        normal.each_ref().map(half),
        normalised(&height),
        [rough.clone(), rough.clone(), rough],
        normalised(&melanin),
        normalised(&blood),
    ];
    compose(&renders, &sheet, PANEL)
}
