//! The lacrimal lake (EyeMove thesis §4.5) as each renderer draws it over the built-in head: on
//! the globes only, within the lake's reach Λ of the skin, darkening every globe pixel at the
//! lid margin — the CPU renderer's lake step and, on a GPU, lake.wgsl.

use derma_render::material::{MATERIAL_EYE, MATERIAL_SKIN};
use derma_render::{CpuRenderer, Draw, Rendered, Scene, Setup, SkinMaps, View};

/// The built-in head under a flat skin (the lake reads geometry and materials only), without
/// its lash cards: the lake seen through a blended lash changes a pixel that shows the lash.
fn head() -> Scene {
    let maps = SkinMaps::uniform([0.6, 0.4, 0.3], 0.5, 0.35);
    let mut scene = Scene::head(derma_head::Head::builtin(), maps, &[], None, (0.0, 0.0));
    scene
        .parts
        .retain(|p| !matches!(p.material, derma_render::scene::Material::Card { .. }));
    scene
}

#[test]
fn the_cpu_renderers_lake_lines_the_lid_margins_and_touches_nothing_else() {
    let scene = head();
    lines_the_lid_margins(&scene, &CpuRenderer::new(&scene));
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_renderers_lake_lines_the_lid_margins_and_touches_nothing_else() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    let scene = head();
    lines_the_lid_margins(
        &scene,
        &derma_render::Renderer::new(&scene).expect("renderer"),
    );
}

/// The lake drawn by `r` (a renderer of `scene`, the built-in head) lines the lid margins and
/// touches nothing else.
fn lines_the_lid_margins(scene: &Scene, r: &dyn Draw) {
    let n = 512;
    let view = View {
        zoom: 0.35,
        ..Default::default()
    };
    let shot = |lake: bool| {
        r.set_lake(lake);
        r.draw(&view, &Setup::Studio.lighting(), n as u32, n as u32)
            .unwrap()
    };
    let (dry, wet) = (shot(false), shot(true));
    assert_eq!(dry.material, wet.material);
    let m = &wet.material;
    let eye_px = m.iter().filter(|&&x| x == MATERIAL_EYE).count();
    assert!(eye_px > 2000, "{eye_px} eye pixels in the close-up");
    let changed: Vec<usize> = (0..n * n)
        .filter(|&i| dry.display[4 * i..4 * i + 3] != wet.display[4 * i..4 * i + 3])
        .collect();
    // Only the globes change.
    assert!(changed.iter().all(|&i| m[i] == MATERIAL_EYE));
    // Within the lake's reach Λ of the skin, in pixels at the globes' front (the nearest point,
    // so the most pixels per mm), measured here by brute force.
    let head = derma_head::Head::builtin();
    let cam =
        derma_render::camera::Camera::frame(scene.centre, scene.radius, &view, n as u32, n as u32);
    let near = head
        .eyes
        .iter()
        .map(|e| (e.centre + glam::Vec3::Z * e.radius - cam.eye).dot(cam.forward))
        .fold(f32::MAX, f32::min);
    let reach_px = derma_render::lake::RANGE_MM * cam.focal_px / near;
    let skin_px: Vec<(i64, i64)> = (0..n * n)
        .filter(|&i| m[i] == MATERIAL_SKIN)
        .map(|i| ((i % n) as i64, (i / n) as i64))
        .collect();
    let to_skin = |i: usize| {
        let (x, y) = ((i % n) as i64, (i / n) as i64);
        skin_px
            .iter()
            .map(|&(sx, sy)| (((sx - x).pow(2) + (sy - y).pow(2)) as f32).sqrt())
            .fold(f32::MAX, f32::min)
    };
    let far = changed.iter().map(|&i| to_skin(i)).fold(0.0f32, f32::max);
    assert!(
        far <= reach_px + 1.0,
        "the lake reaches {far} px; Λ is {reach_px} px"
    );
    // Every globe pixel next to the skin is under the meniscus, and it darkens them
    // (absorption along the double pass, derma-render's lake).
    let margin: Vec<usize> = (n + 1..n * n - n - 1)
        .filter(|&i| {
            m[i] == MATERIAL_EYE
                && [i - 1, i + 1, i - n, i + n]
                    .iter()
                    .any(|&j| m[j] == MATERIAL_SKIN)
        })
        .collect();
    let lum = |img: &Rendered, i: usize| {
        let p = img.linear[i];
        0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
    };
    let wet_margin = margin
        .iter()
        .filter(|&&i| changed.binary_search(&i).is_ok())
        .count();
    assert!(
        wet_margin as f64 >= 0.95 * margin.len() as f64,
        "{wet_margin} of {} margin pixels under the lake",
        margin.len()
    );
    let darker = margin
        .iter()
        .filter(|&&i| lum(&wet, i) < lum(&dry, i))
        .count();
    assert!(
        darker as f64 > 0.8 * margin.len() as f64,
        "{darker} of {} margin pixels darker",
        margin.len()
    );
    println!(
        "{}: {eye_px} eye px, {} under the lake, reach {far:.1} of {reach_px:.1} px, {darker}/{} margin px darker",
        r.name(),
        changed.len(),
        margin.len()
    );
}
