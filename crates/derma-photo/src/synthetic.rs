//! Ground truth for the photo pipeline, built from derma's own head: a face disc to unwrap,
//! and photos of a known texture rendered from known cameras under varied light, exposure,
//! white balance and vignetting, with landmarks perturbed like a person's clicks.

use crate::error::Result;
use crate::topology::fill_holes;
use derma_core::mesh::TriMesh;
use derma_head::regions::index;
use derma_head::Head;
use derma_render::brdf::specular;
use glam::Vec3;

/// The built-in head's skin without the mouth cavity and eye sockets, the openings closed as a
/// scanner closes them: a disc bounded at the neck, as Tarini et al. 2002 §3.1 assume.
pub fn head_disc(head: &Head) -> Result<TriMesh> {
    let skin = &head.skin;
    let (mi, es) = (
        index("mouth_interior").expect("region"),
        index("eye_sockets").expect("region"),
    );
    let keep: Vec<[u32; 3]> = skin
        .triangles
        .iter()
        .copied()
        .filter(|t| {
            let c = t.map(|i| skin.positions[i as usize]);
            let uv = t.map(|i| skin.uvs[i as usize]);
            let w = head
                .regions
                .weights((c[0] + c[1] + c[2]) / 3.0, (uv[0] + uv[1] + uv[2]) / 3.0);
            w[mi] < 0.5 && w[es] < 0.5
        })
        .collect();
    let cut = TriMesh {
        positions: skin.positions.clone(),
        normals: skin.normals.clone(),
        uvs: Vec::new(),
        triangles: keep,
    };
    Ok(fill_holes(&cut)?.0)
}

/// The front of [`head_disc`]: the face from brow to chin and ear to ear (canonical face
/// coordinates of [`derma_head::Regions::face_coords`]: |x| < 85, −105 < y < 85, frontness > 0.3),
/// its largest connected piece, holes closed — the kind of face mask a scan or a face tracker
/// gives.
pub fn face_disc(head: &Head) -> Result<TriMesh> {
    let disc = head_disc(head)?;
    let keep: Vec<[u32; 3]> = disc
        .triangles
        .iter()
        .copied()
        .filter(|t| {
            let c = t.map(|i| disc.positions[i as usize]);
            let (x, y, front) = head.regions.face_coords((c[0] + c[1] + c[2]) / 3.0);
            x.abs() < 85.0 && y > -105.0 && y < 85.0 && front > 0.3
        })
        .collect();
    let cut = TriMesh {
        positions: disc.positions.clone(),
        normals: disc.normals.clone(),
        uvs: Vec::new(),
        triangles: keep,
    };
    Ok(fill_holes(&largest_component(&cut))?.0)
}

/// The largest edge-connected piece of a mesh (other triangles dropped).
pub fn largest_component(mesh: &TriMesh) -> TriMesh {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for t in &mesh.triangles {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut count = std::collections::HashMap::new();
    for t in &mesh.triangles {
        *count.entry(find(&mut parent, t[0])).or_insert(0usize) += 1;
    }
    let best = count
        .iter()
        .max_by_key(|(k, c)| (**c, std::cmp::Reverse(**k)))
        .map(|(k, _)| *k);
    let mut out = mesh.clone();
    out.triangles
        .retain(|t| Some(find(&mut parent, t[0])) == best);
    out
}

/// Known chromophores on the surface, as solid fields of the 3D position (mm) so that they can
/// be compared in any UV layout: melanin C_m and dermal blood C_hd with smooth regional
/// variation (a redder lower face, darker sides) and freckles of 1–2 mm on a jittered 4 mm grid.
pub fn chromophores_at(p: Vec3, seed: u64) -> (f32, f32) {
    let wave = |k: Vec3, phase: f32| (p.dot(k) + phase).sin();
    let m = 0.06
        + 0.012 * wave(Vec3::new(0.031, 0.017, 0.009), 0.3)
        + 0.008 * wave(Vec3::new(-0.013, 0.041, 0.02), 1.1)
        + 0.004 * wave(Vec3::new(0.19, -0.11, 0.07), 2.0);
    let h = 0.045
        + 0.015 * wave(Vec3::new(0.012, -0.035, 0.01), 0.7)
        + 0.006 * wave(Vec3::new(0.05, 0.06, -0.03), 0.2)
        + 0.003 * wave(Vec3::new(-0.23, 0.17, 0.11), 1.4);
    // Freckles: one candidate per 4 mm cell, a third of them present.
    let rng = derma_core::rng::Philox::new(seed, 7);
    let cell = (p / 4.0).floor();
    let mut spot = 0.0f32;
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let c = cell + Vec3::new(dx as f32, dy as f32, dz as f32);
                let key = ((c.x as i64 + 512) as u64)
                    | (((c.y as i64 + 512) as u64) << 11)
                    | (((c.z as i64 + 512) as u64) << 22);
                let u = rng.uniform4(key, 0);
                if u[3] > 0.33 {
                    continue;
                }
                let centre = (c + Vec3::new(u[0], u[1], u[2])) * 4.0;
                let r = 0.5 + 0.5 * rng.uniform4(key, 1)[0];
                let d = (p - centre).length() / r;
                spot = spot.max((-d * d).exp());
            }
        }
    }
    ((m + 0.08 * spot).clamp(0.0, 0.5), h.clamp(0.0, 0.32))
}

/// The true albedo (linear RGB) of [`chromophores_at`] through the skin-colour LUT.
pub fn truth_albedo(
    lut: &derma_shading::skin_color_lut::SkinColorLut,
    seed: u64,
) -> impl Fn(Vec3) -> [f32; 3] + Sync + '_ {
    move |p| {
        let (m, h) = chromophores_at(p, seed);
        lut.lookup(m as f64, h as f64).map(|v| v as f32)
    }
}

/// `photos` with the recovered cameras of `resections` (same order).
pub fn with_cameras(
    photos: &[crate::photo::Photo],
    resections: &[crate::resection::Resection],
) -> Vec<crate::photo::Photo> {
    photos
        .iter()
        .zip(resections)
        .map(|(p, r)| crate::photo::Photo {
            camera: r.camera,
            ..p.clone()
        })
        .collect()
}

/// One synthetic photo's set-up: camera direction, light, exposure, white balance, vignetting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Azimuth of the camera around the head (degrees, 0 = in front, + = the head's left).
    pub azimuth_deg: f32,
    /// Elevation (degrees).
    pub elevation_deg: f32,
    /// Direction toward the key light (world).
    pub light: Vec3,
    /// Irradiance of the key light on a surface facing it (casts hard shadows).
    pub key: f32,
    /// Irradiance of the uniform ambient sky on an open surface (occluded by the mesh).
    pub ambient: f32,
    /// Normal-incidence reflectance of the white surface lobe (GGX, roughness
    /// [`SPECULAR_ROUGHNESS`]); 0 for none.
    pub specular_f0: f32,
    /// Exposure factor.
    pub exposure: f32,
    /// White-balance factors per channel.
    pub white_balance: [f32; 3],
    /// Vignetting: brightness falls as 1 − v r² (r = 1 at the image corner).
    pub vignetting: f32,
}

/// Five views as a photographer would take them without a light tent (front, ±35°, ±70°): each
/// its own directional key light with hard shadows (key 0.65–1.0), a weaker ambient sky
/// (0.25–0.45) occluded by the face, a specular sheen (F0 0.035–0.05, an oily forehead and nose;
/// skin's F0 is ≈ 0.028 for n ≈ 1.4, Weyrich et al. 2006), exposure ×0.7–1.3, white balance and
/// vignetting.
pub fn default_views() -> Vec<View> {
    let v = |az: f32, el: f32, light: [f32; 3], key: f32, ambient: f32, f0: f32| View {
        azimuth_deg: az,
        elevation_deg: el,
        light: Vec3::from(light),
        key,
        ambient,
        specular_f0: f0,
        exposure: 1.0,
        white_balance: [1.0; 3],
        vignetting: 0.2,
    };
    vec![
        View {
            ..v(0.0, 5.0, [0.3, 0.4, 1.0], 0.8, 0.35, 0.04)
        },
        View {
            exposure: 1.3,
            white_balance: [1.08, 1.0, 0.9],
            vignetting: 0.3,
            ..v(35.0, 0.0, [0.8, 0.3, 0.6], 0.7, 0.3, 0.05)
        },
        View {
            exposure: 0.7,
            white_balance: [0.93, 1.0, 1.1],
            vignetting: 0.25,
            ..v(-35.0, 0.0, [-0.6, 0.5, 0.7], 1.0, 0.25, 0.035)
        },
        View {
            exposure: 1.15,
            white_balance: [1.0, 0.97, 0.95],
            vignetting: 0.3,
            ..v(70.0, -5.0, [1.0, 0.2, 0.2], 0.65, 0.45, 0.04)
        },
        View {
            exposure: 0.85,
            white_balance: [0.97, 1.0, 1.05],
            ..v(-70.0, 10.0, [-1.0, 0.1, 0.3], 0.9, 0.3, 0.045)
        },
    ]
}

/// GGX roughness of the synthetic photos' surface lobe: a skin-like sheen (Weyrich et al. 2006
/// fit Torrance–Sparrow roughness 0.3–0.45 on faces).
pub const SPECULAR_ROUGHNESS: f32 = 0.35;

/// Ray offset of the synthetic renders' shadow and sky rays (mm).
const RAY_OFFSET_MM: f32 = 0.05;

/// A mesh ready to be photographed: its ray-casting hierarchy and each vertex's sky visibility
/// (the ambient occlusion, 16² cosine-weighted rays), computed once for all views.
pub struct Stage<'a> {
    mesh: &'a TriMesh,
    bvh: derma_core::bvh::Bvh,
    sky: Vec<f32>,
}

impl<'a> Stage<'a> {
    /// Prepares `mesh` (with normals).
    pub fn new(mesh: &'a TriMesh) -> Self {
        use derma_core::sh::stratified_direction;
        use rayon::prelude::*;
        let bvh = derma_core::bvh::Bvh::new(&mesh.positions, &mesh.triangles);
        let rng = derma_core::rng::Philox::new(0x5ce7e, 3);
        let side = 16;
        let sky = mesh
            .positions
            .par_iter()
            .zip(&mesh.normals)
            .enumerate()
            .map(|(v, (p, n))| {
                let n = n.normalize_or(Vec3::Z);
                let o = *p + n * RAY_OFFSET_MM;
                let open = (0..side * side)
                    .filter(|&k| {
                        let d = stratified_direction(n, &rng, v as u64, k, side);
                        !bvh.occluded(o, d, 0.0, f32::MAX)
                    })
                    .count();
                open as f32 / (side * side) as f32
            })
            .collect();
        Self { mesh, bvh, sky }
    }
}

/// A camera for `view` framing the head's face from `distance_mm`.
pub fn camera_for(
    head: &Head,
    view: &View,
    width: u32,
    height: u32,
    distance_mm: f32,
) -> crate::Camera {
    let target = 0.5 * (head.landmarks.get("nose_tip") + head.landmarks.get("menton"));
    let target = Vec3::new(0.0, target.y + 15.0, target.z - 40.0);
    let (a, e) = (
        view.azimuth_deg.to_radians(),
        view.elevation_deg.to_radians(),
    );
    let eye = target + distance_mm * Vec3::new(a.sin() * e.cos(), e.sin(), a.cos() * e.cos());
    // 50 mm on a full-frame sensor: f = 50/36 of the width.
    crate::Camera::look_at(
        width,
        height,
        eye,
        target,
        Vec3::Y,
        width as f64 * 50.0 / 36.0,
    )
}

/// Renders a photo of the staged mesh (with `albedo` per surface point) through
/// derma-render's rasteriser (one sample per pixel centre, the camera's pinhole): a Lambertian
/// surface under the view's ambient sky (times the vertex's sky visibility) and key light (with
/// a hard shadow ray), plus a white GGX sheen from the key (derma-render's microfacet lobe,
/// [`derma_render::brdf::specular`]), times exposure, white balance and vignetting, then stored as 8-bit sRGB as a
/// camera would.
pub fn render(
    stage: &Stage,
    cam: &crate::Camera,
    view: &View,
    albedo: &(dyn Fn(Vec3) -> [f32; 3] + Sync),
) -> crate::photo::RgbImage {
    use rayon::prelude::*;
    let mesh = stage.mesh;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let hits = cam.rasterise(mesh);
    let light = view.light.normalize();
    let eye = cam.centre().as_vec3();
    let alpha = SPECULAR_ROUGHNESS * SPECULAR_ROUGHNESS;
    let half_diag = ((w * w + h * h) as f32).sqrt() / 2.0;
    let data: Vec<[f32; 3]> = hits
        .par_iter()
        .enumerate()
        .map(|(i, hit)| {
            let (x, y) = (i % w, i / w);
            let r = ((x as f32 + 0.5 - w as f32 / 2.0).powi(2)
                + (y as f32 + 0.5 - h as f32 / 2.0).powi(2))
            .sqrt()
                / half_diag;
            let vig = 1.0 - view.vignetting * r * r;
            let c = match hit {
                Some(hit) => {
                    let n = hit.interpolate(mesh, &mesh.normals).normalize_or(Vec3::Z);
                    let p = hit.interpolate(mesh, &mesh.positions);
                    let sky = hit.interpolate(mesh, &stage.sky);
                    let n_l = n.dot(light);
                    let lit = n_l > 0.0
                        && !stage
                            .bvh
                            .occluded(p + n * RAY_OFFSET_MM, light, 0.0, f32::MAX);
                    let key = if lit { view.key * n_l } else { 0.0 };
                    let v = (eye - p).normalize();
                    let sheen = if lit && view.specular_f0 > 0.0 {
                        view.key * n_l * specular(n, light, v, alpha, view.specular_f0)
                    } else {
                        0.0
                    };
                    let diffuse = view.ambient * sky + key;
                    albedo(p).map(|a| a * diffuse + sheen)
                }
                // A grey backdrop.
                None => [0.18, 0.19, 0.2],
            };
            std::array::from_fn(|k| c[k] * view.exposure * view.white_balance[k] * vig)
        })
        .collect();
    crate::photo::RgbImage {
        width: w,
        height: h,
        data,
    }
    .quantised_srgb8()
}

/// Feature points a person would click: the head's named landmarks (without the eye centres,
/// which lie inside the head) and skin features at a grid of canonical face coordinates
/// (x ∈ {−60, −30, 0, 30, 60}, y ∈ {−80, −40, 0, 40, 70}), snapped to the nearest vertex of
/// `mesh` and labelled by it.
pub fn feature_points(head: &Head, mesh: &TriMesh) -> Vec<(String, Vec3)> {
    let mut out: Vec<(String, Vec3)> = derma_head::landmarks::NAMES
        .iter()
        .filter(|n| !n.starts_with("eye_centre"))
        .map(|n| (n.to_string(), head.landmarks.get(n)))
        .collect();
    for y in [-80.0f32, -40.0, 0.0, 40.0, 70.0] {
        for x in [-60.0f32, -30.0, 0.0, 30.0, 60.0] {
            let best = mesh
                .positions
                .iter()
                .enumerate()
                .filter(|(_, p)| head.regions.face_coords(**p).2 > 0.5)
                .min_by(|(_, a), (_, b)| {
                    let d = |p: Vec3| {
                        let (fx, fy, _) = head.regions.face_coords(p);
                        (fx - x).powi(2) + (fy - y).powi(2)
                    };
                    d(**a)
                        .total_cmp(&d(**b))
                        .then(a.z.total_cmp(&b.z).reverse())
                });
            if let Some((i, p)) = best {
                out.push((format!("v{i}"), *p));
            }
        }
    }
    out
}

/// The `features` seen by `cam` (not hidden by the mesh, inside the image) with Gaussian pixel
/// noise of `noise_px`, as a person would click them.
pub fn clicked_points(
    features: &[(String, Vec3)],
    bvh: &derma_core::bvh::Bvh,
    cam: &crate::Camera,
    name: &str,
    noise_px: f64,
    seed: u64,
) -> crate::resection::PhotoPoints {
    let rng = derma_core::rng::Philox::new(seed, 11);
    let centre = cam.centre().as_vec3();
    let points = features
        .iter()
        .enumerate()
        .filter_map(|(i, (label, p))| {
            let p = *p;
            let to = centre - p;
            let dist = to.length();
            let dir = to / dist;
            if bvh.occluded(p + dir * 0.5, dir, 0.0, dist) {
                return None;
            }
            let px = cam.project(p.as_dvec3())?;
            if !cam.in_image(px) {
                return None;
            }
            let g = rng.normal2(i as u64, 0);
            Some(crate::resection::Correspondence {
                label: label.clone(),
                pixel: px + noise_px * glam::DVec2::new(g[0] as f64, g[1] as f64),
                world: p.as_dvec3(),
            })
        })
        .collect();
    crate::resection::PhotoPoints {
        name: name.to_string(),
        width: cam.width,
        height: cam.height,
        focal_px: None,
        points,
    }
}

/// Photos of `mesh` (with `albedo` per surface point) from [`default_views`]' cameras at
/// 550 mm, named `photoN.png`, and the [`feature_points`] each one shows, clicked with
/// `noise_px` of noise (seeded per photo from `seed`).
pub fn photo_set(
    head: &Head,
    mesh: &TriMesh,
    albedo: &(dyn Fn(Vec3) -> [f32; 3] + Sync),
    (width, height): (u32, u32),
    noise_px: f64,
    seed: u64,
) -> (Vec<crate::photo::Photo>, Vec<crate::resection::PhotoPoints>) {
    let stage = Stage::new(mesh);
    let feats = feature_points(head, mesh);
    default_views()
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let cam = camera_for(head, v, width, height, 550.0);
            let name = format!("photo{i}.png");
            let points = clicked_points(
                &feats,
                &stage.bvh,
                &cam,
                &name,
                noise_px,
                seed * 1000 + i as u64,
            );
            let image = render(&stage, &cam, v, albedo);
            (
                crate::photo::Photo {
                    name,
                    image,
                    camera: cam,
                },
                points,
            )
        })
        .unzip()
}

/// How close a baked texture comes to the truth.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TextureScores {
    /// PSNR (dB, peak 1) over texels coloured from photos, after the one per-channel scale
    /// that best matches the truth (exposure and shading level are not recoverable).
    pub psnr_db: f64,
    /// That per-channel scale (recovered / true).
    pub channel_scale: [f64; 3],
    /// The colour cast: the mean over channels of |scale / mean scale − 1| (0 when the texture
    /// is the truth times one number).
    pub cast: f64,
    /// Mean squared gradient of the error (recovered − scaled truth) across seams: between
    /// neighbouring texels whose best photo differs.
    pub seam_gradient_energy: f64,
    /// Seam texel pairs measured.
    pub seam_pairs: usize,
}

/// Scores `baked` (on `mesh`'s UVs) against `truth` per surface point.
pub fn evaluate(
    mesh: &TriMesh,
    baked: &crate::bake::Baked,
    truth: &(dyn Fn(Vec3) -> [f32; 3] + Sync),
) -> TextureScores {
    let size = baked.texture.width;
    let raster = derma_core::raster::UvRaster::new(mesh, size, size);
    let n_photos = baked.report.photos.len();
    let seen = |i: usize| (baked.source[i] as usize) < n_photos && raster.covered(i);
    let t: Vec<[f32; 3]> = (0..size * size)
        .map(|i| {
            if raster.covered(i) {
                truth(raster.position(mesh, i))
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let r = &baked.texture.data;
    // Per-channel scale: s = Σ r t / Σ t².
    let mut scale = [0.0f64; 3];
    for c in 0..3 {
        let (mut rt, mut tt) = (0.0f64, 0.0f64);
        for i in (0..size * size).filter(|&i| seen(i)) {
            rt += r[i][c] as f64 * t[i][c] as f64;
            tt += (t[i][c] as f64).powi(2);
        }
        scale[c] = rt / tt.max(1e-30);
    }
    let err = |i: usize| -> [f64; 3] {
        std::array::from_fn(|c| r[i][c] as f64 - scale[c] * t[i][c] as f64)
    };
    let (mut se, mut k) = (0.0, 0usize);
    for i in (0..size * size).filter(|&i| seen(i)) {
        se += err(i).iter().map(|e| e * e).sum::<f64>();
        k += 3;
    }
    let mse = se / k.max(1) as f64;
    let (mut seam, mut pairs) = (0.0, 0usize);
    for y in 0..size {
        for x in 0..size {
            let i = y * size + x;
            if !seen(i) {
                continue;
            }
            for j in [i + 1, i + size] {
                if (j == i + 1 && x + 1 >= size)
                    || j >= size * size
                    || !seen(j)
                    || baked.source[j] == baked.source[i]
                {
                    continue;
                }
                let (a, b) = (err(i), err(j));
                seam += (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>();
                pairs += 1;
            }
        }
    }
    let mean_scale = scale.iter().sum::<f64>() / 3.0;
    TextureScores {
        psnr_db: -10.0 * mse.max(1e-30).log10(),
        channel_scale: scale,
        cast: scale
            .iter()
            .map(|s| (s / mean_scale - 1.0).abs())
            .sum::<f64>()
            / 3.0,
        seam_gradient_energy: seam / pairs.max(1) as f64,
        seam_pairs: pairs,
    }
}
