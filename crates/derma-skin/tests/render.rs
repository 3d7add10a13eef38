//! The renderer on a real (or software) GPU: a 1024² frame of the built-in head with a
//! generated texture set shows skin and eyes, repeats bit for bit, and its subsurface pass
//! softens the skin's fine relief while keeping its light (Jimenez et al. 2015 §3: the
//! separable kernel is normalised).

use derma_core::Map;
use derma_render::{Rendered, Renderer, Scene, Setup, SkinMaps, View};

fn skin(size: u32) -> SkinMaps {
    let mut g = derma_skin::SkinGenerator::new(derma_skin::SkinConfig::default());
    g.config_mut().size = size;
    let set = g.run().expect("skin");
    set.render.skin_maps(false)
}

/// The built-in head with a generated `size`² set, and its renderer; `None` (skip) without a GPU.
fn head(size: u32) -> Option<(Scene, Renderer)> {
    if derma_test_support::skip_without_gpu() {
        return None;
    }
    let scene = Scene::head(
        derma_head::Head::builtin(),
        skin(size),
        &[],
        None,
        (0.0, 0.0),
    );
    let r = Renderer::new(&scene).expect("renderer");
    Some((scene, r))
}

fn frame(r: &Renderer, n: u32) -> Rendered {
    r.render(&View::default(), &Setup::Studio.lighting(), n, n)
        .expect("render")
}

fn covered(img: &Rendered, i: usize) -> bool {
    img.linear[i].iter().any(|&v| v > 0.0)
}

/// Mean linear radiance per channel over the covered pixels.
fn mean(img: &Rendered, mask: &[bool]) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    let mut n = 0usize;
    for (p, &m) in img.linear.iter().zip(mask) {
        if m {
            for k in 0..3 {
                s[k] += p[k] as f64;
            }
            n += 1;
        }
    }
    s.map(|v| v / n.max(1) as f64)
}

/// A flat square of side `2·s` mm facing the camera (+Z), UVs over [0, 1]².
fn quad(s: f32) -> derma_core::mesh::TriMesh {
    derma_core::mesh::TriMesh {
        positions: vec![
            glam::Vec3::new(-s, -s, 0.0),
            glam::Vec3::new(s, -s, 0.0),
            glam::Vec3::new(s, s, 0.0),
            glam::Vec3::new(-s, s, 0.0),
        ],
        normals: vec![glam::Vec3::Z; 4],
        uvs: vec![
            glam::Vec2::new(0.0, 0.0),
            glam::Vec2::new(1.0, 0.0),
            glam::Vec2::new(1.0, 1.0),
            glam::Vec2::new(0.0, 1.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

#[test]
fn a_1024_frame_of_the_head_shows_skin_and_eyes_and_repeats_bit_for_bit() {
    let Some((scene, r)) = head(256) else {
        return;
    };
    let a = frame(&r, 1024);
    assert_eq!((a.width, a.height), (1024, 1024));
    assert_eq!(a.display.len(), 4 * 1024 * 1024);
    let mask: Vec<bool> = (0..a.linear.len()).map(|i| covered(&a, i)).collect();
    let frac = mask.iter().filter(|&&m| m).count() as f64 / mask.len() as f64;
    // The framing fits the head's bounding sphere into the frame: a face fills a good part of
    // it but not all.
    assert!(
        (0.2..0.85).contains(&frac),
        "head covers {frac:.3} of the frame"
    );
    // Lit skin: red above green above blue (melanin and hemoglobin absorb blue most).
    let m = mean(&a, &mask);
    assert!(m[0] > m[1] && m[1] > m[2] && m[2] > 0.0, "mean skin {m:?}");
    // The eyes: the centre column between the brows and the mouth holds the face; the two
    // eye positions, projected, show the iris darker than the skin beside it.
    let head = derma_head::Head::builtin();
    let cam = derma_render::camera::Camera::frame(
        scene.centre,
        scene.radius,
        &View::default(),
        1024,
        1024,
    );
    // World (mm) → pixel, as the rasteriser maps clip space (y down from the top).
    let project = |p: glam::Vec3| {
        let c = cam.view_proj * p.extend(1.0);
        let (x, y) = (c.x / c.w, c.y / c.w);
        (
            ((0.5 * x + 0.5) * 1024.0) as usize,
            ((0.5 - 0.5 * y) * 1024.0) as usize,
        )
    };
    let lum = |x: usize, y: usize| {
        let p = a.linear[y * 1024 + x];
        0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
    };
    for eye in &head.eyes {
        let front = eye.centre + glam::Vec3::Z * eye.radius;
        let (x, y) = project(front);
        assert!(mask[y * 1024 + x], "the eye at ({x}, {y}) is drawn");
        // The cheek below the eye, by 1.6 eye radii, is brighter than the pupil.
        let below = eye.centre + glam::Vec3::new(0.0, -1.6 * eye.radius, eye.radius);
        let (bx, by) = project(below);
        assert!(
            lum(x, y) < 0.5 * lum(bx, by),
            "pupil {} vs cheek {}",
            lum(x, y),
            lum(bx, by)
        );
    }
    // Determinism: the same scene and view give the same bytes.
    let b = frame(&r, 1024);
    assert!(a.display == b.display, "two renders of one frame differ");
    // And another view gives another image.
    let c = r
        .render(
            &View {
                yaw_deg: 35.0,
                ..Default::default()
            },
            &Setup::Studio.lighting(),
            1024,
            1024,
        )
        .unwrap();
    assert!(a.display != c.display);
}

#[test]
fn subsurface_scattering_blurs_relief_by_each_channels_mean_free_path_and_keeps_the_light() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    // A 40 mm square of skin-coloured material with vertical ridges in its normal map, 1.25 mm
    // apart (16 texels of 512), lit by the studio's oblique key: the ridges show as stripes.
    // With Burley mean free paths of 1.0, 0.4 and 0.2 mm (red, green, blue; red light goes
    // deepest in skin, Jensen et al. 2001 Table 2) the red stripes fade most.
    let n = 512;
    let flat = |v: f32| Map::filled(n, n, v);
    let ridge = |i: usize| 0.35 * (std::f32::consts::TAU * (i % n) as f32 / 16.0).sin();
    let nx: Vec<f32> = (0..n * n).map(ridge).collect();
    let nz: Vec<f32> = nx.iter().map(|x| (1.0 - x * x).sqrt()).collect();
    let enc = |v: &[f32]| Map::from_vec(n, n, v.iter().map(|x| 0.5 * x + 0.5).collect()).unwrap();
    let maps = SkinMaps {
        base_color: [flat(0.6), flat(0.35), flat(0.25)],
        normal: [enc(&nx), flat(0.5), enc(&nz)],
        roughness: flat(0.6),
        specular: flat(0.0),
        subsurface: Some((
            [flat(0.6), flat(0.35), flat(0.25)],
            [flat(1.0), flat(0.4), flat(0.2)],
        )),
        lash_color: None,
        hair: None,
        wrap: false,
    };
    let mut without = maps.clone();
    without.subsurface = None;
    let mesh = quad(20.0);
    let render = |m: SkinMaps| frame(&Renderer::new(&Scene::mesh(&mesh, m)).unwrap(), 512);
    let (a, b) = (render(maps), render(without));
    // The middle half of the frame (well inside the square, away from its rim).
    let (mut sum_a, mut sum_b, mut det_a, mut det_b) =
        ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
    for y in 128..384 {
        for x in 128..384 {
            let i = y * 512 + x;
            for k in 0..3 {
                let d = |img: &Rendered| {
                    let l = &img.linear;
                    (l[i][k] as f64 - 0.5 * (l[i - 3][k] as f64 + l[i + 3][k] as f64)).abs()
                };
                sum_a[k] += a.linear[i][k] as f64;
                sum_b[k] += b.linear[i][k] as f64;
                det_a[k] += d(&a);
                det_b[k] += d(&b);
            }
        }
    }
    let keep: Vec<f64> = (0..3).map(|k| sum_a[k] / sum_b[k]).collect();
    let fade: Vec<f64> = (0..3).map(|k| det_a[k] / det_b[k]).collect();
    // The kernel integrates to one: the light is moved, not made or lost.
    assert!(
        keep.iter().all(|r| (r - 1.0).abs() < 0.03),
        "light kept {keep:?}"
    );
    // The stripes fade, red most, blue least.
    assert!(
        fade[0] < 0.6,
        "red relief kept {:.3} of its contrast",
        fade[0]
    );
    assert!(
        fade[0] < fade[1] && fade[1] < fade[2],
        "fade per channel {fade:?}"
    );
}

#[test]
fn the_sets_colour_is_applied_once_after_the_scattering() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    // A 40 mm square lit evenly (flat, a directional key: one irradiance everywhere), its colour
    // stepping at the middle column from a to b, with wide scattering (mean free paths 1.0, 0.4,
    // 0.2 mm: 10 px and more for red at this framing). Post-scatter texturing (Jimenez et al.
    // 2010 §6) scatters colourless light and multiplies the colour once: the rendered diffuse
    // over the colour is the scattered irradiance, the same on both sides of the step right up
    // to it. Colour scattered too (√albedo before and after) would pull each side towards the
    // other near the step (the √ split measured 8.5 % off in red here).
    let n = 512;
    let (a, b) = ([0.6f32, 0.35, 0.25], [0.3f32, 0.3, 0.3]);
    let split = |k: usize| Map::from_fn(n, n, |i| if i % n < n / 2 { a[k] } else { b[k] });
    let flat = |v: f32| Map::filled(n, n, v);
    let maps = SkinMaps {
        base_color: [split(0), split(1), split(2)],
        normal: [flat(0.5), flat(0.5), flat(1.0)],
        roughness: flat(0.6),
        // F0 = 0: no specular light at all (f90 = 0), the frame is diffuse alone.
        specular: flat(0.0),
        subsurface: Some((
            [flat(0.5), flat(0.5), flat(0.5)],
            [flat(1.0), flat(0.4), flat(0.2)],
        )),
        lash_color: None,
        hair: None,
        wrap: false,
    };
    let mesh = quad(20.0);
    let img = frame(&Renderer::new(&Scene::mesh(&mesh, maps)).unwrap(), n as u32);
    // Along the middle rows, 3 to 24 px from the step (the texel the step falls in, and the
    // rasteriser's pixel centres, left out): rendered / colour, per channel.
    let mut worst = [0.0f32; 3];
    for y in (n / 2 - 8..n / 2 + 8).step_by(4) {
        let ratio = |x: usize, k: usize| {
            let c = if x < n / 2 { a[k] } else { b[k] };
            img.linear[y * n + x][k] / c
        };
        for k in 0..3 {
            let far = 0.5 * (ratio(n / 2 - 40, k) + ratio(n / 2 + 40, k));
            for d in 3..24 {
                for x in [n / 2 - 1 - d, n / 2 + d] {
                    worst[k] = worst[k].max((ratio(x, k) / far - 1.0).abs());
                }
            }
        }
    }
    assert!(
        worst.iter().all(|&w| w < 0.02),
        "irradiance off by {worst:?} near the step"
    );
}

#[test]
fn a_user_mesh_renders_with_its_own_uvs() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    // A flat quad facing the camera with a set whose base colour is a left/right split: the
    // render shows the split where the UVs put it.
    let n = 64;
    let split = |l: f32, r: f32| {
        Map::from_vec(
            n,
            n,
            (0..n * n)
                .map(|i| if i % n < n / 2 { l } else { r })
                .collect(),
        )
        .unwrap()
    };
    let flat = |v: f32| Map::filled(n, n, v);
    let maps = SkinMaps {
        base_color: [split(0.6, 0.05), split(0.1, 0.05), split(0.1, 0.6)],
        normal: [flat(0.5), flat(0.5), flat(1.0)],
        roughness: flat(0.5),
        specular: flat(0.5),
        subsurface: None,
        lash_color: None,
        hair: None,
        wrap: false,
    };
    let mesh = quad(100.0);
    let r = Renderer::new(&Scene::mesh(&mesh, maps)).unwrap();
    let img = frame(&r, 256);
    let px = |x: usize, y: usize| img.linear[y * 256 + x];
    let (left, right) = (px(90, 128), px(166, 128));
    assert!(left[0] > 3.0 * left[2], "left half red: {left:?}");
    assert!(right[2] > 3.0 * right[0], "right half blue: {right:?}");
}

#[test]
fn no_pixel_is_ever_not_a_number() {
    // A 512² set seen from 35° once rendered a dot product of unit vectors just past 1 into
    // Schlick's pow(1 − cos, 5): NaN on lavapipe, spread by the blur into a 20-pixel black
    // square on the scalp. The same set and view must give finite radiance everywhere.
    let Some((_, r)) = head(512) else {
        return;
    };
    let view = View {
        yaw_deg: 35.0,
        ..Default::default()
    };
    let img = r
        .render(&view, &Setup::Studio.lighting(), 512, 512)
        .unwrap();
    let bad = img
        .linear
        .iter()
        .filter(|p| p.iter().any(|v| !v.is_finite()))
        .count();
    assert_eq!(bad, 0, "{bad} pixels are not finite");
}
