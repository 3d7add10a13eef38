//! One scene API on any device: [`Draw`] renders a [`Scene`] from a [`View`] under a
//! [`Lighting`] — on a GPU the full renderer ([`Renderer`]), without one [`CpuRenderer`]: the
//! scene's parts through the CPU frame ([`crate::frame`]): the same camera, lights, microfacet
//! terms, environment, key shadow (ray-cast, hard, where the GPU filters a shadow map), lacrimal
//! lake and tone mapping as the shaders, without subsurface scattering or corneal refraction (and
//! triangles with a corner within 1 mm of the camera are dropped, not clipped).

use crate::camera::View;
use crate::cpu::Plain;
use crate::error::Result;
use crate::frame::{gbuffer, Drawn, Shadow, Shot, Steps};
use crate::lighting::Lighting;
use crate::material::{MATERIAL_EYE, MATERIAL_OTHER, MATERIAL_SKIN};
use crate::rendered::Rendered;
#[cfg(feature = "gpu")]
use crate::renderer::Renderer;
use crate::scene::{Material, Scene};
use derma_core::bvh::Bvh;
use derma_core::gpu::Device;
use derma_core::mesh::TriMesh;
use derma_core::Map;
use glam::{Vec2, Vec3};

/// Something that renders its scene.
pub trait Draw {
    /// Renders `view` under `lighting` at `w`×`h` pixels.
    fn draw(&self, view: &View, lighting: &Lighting, w: u32, h: u32) -> Result<Rendered>;
    /// What draws: the GPU adapter, or the CPU renderer.
    fn name(&self) -> String;
    /// Draws the lacrimal lake or not (on by default).
    fn set_lake(&self, on: bool);
}

#[cfg(feature = "gpu")]
impl Draw for Renderer {
    fn draw(&self, view: &View, lighting: &Lighting, w: u32, h: u32) -> Result<Rendered> {
        self.render(view, lighting, w, h)
    }
    fn name(&self) -> String {
        self.adapter.clone()
    }
    fn set_lake(&self, on: bool) {
        Renderer::set_lake(self, on)
    }
}

/// The renderer for `scene` on `device`: the GPU renderer where `device` resolves to a GPU (only
/// in a build with the `gpu` feature), the CPU renderer otherwise.
pub fn renderer<'a>(scene: &'a Scene, device: Device) -> Result<Box<dyn Draw + 'a>> {
    Ok(match device.resolve()? {
        #[cfg(feature = "gpu")]
        Device::Gpu => Box::new(Renderer::new(scene)?),
        _ => Box::new(CpuRenderer::new(scene)),
    })
}

/// [`CpuRenderer::name`]'s answer.
pub const CPU_NAME: &str =
    "CPU (derma-render's CPU renderer: no subsurface scattering or corneal refraction)";

/// A scene drawn on the CPU through [`crate::raster`].
pub struct CpuRenderer<'a> {
    scene: &'a Scene,
    /// Each part's corner vertices as an indexed mesh (three vertices per triangle).
    meshes: Vec<TriMesh>,
    /// Per part, per vertex (= per corner): the tangent and its bitangent sign.
    tangents: Vec<Vec<[f32; 4]>>,
    /// Draw the lacrimal lake.
    lake: std::sync::atomic::AtomicBool,
    /// The parts that cast the key light's shadow (all but the cards, as on the GPU).
    occluder: Bvh,
}

impl<'a> CpuRenderer<'a> {
    /// The renderer of `scene`.
    pub fn new(scene: &'a Scene) -> CpuRenderer<'a> {
        let meshes: Vec<TriMesh> = scene
            .parts
            .iter()
            .map(|p| TriMesh {
                positions: p.vertices.iter().map(|v| Vec3::from(v.position)).collect(),
                normals: p.vertices.iter().map(|v| Vec3::from(v.normal)).collect(),
                uvs: p.vertices.iter().map(|v| Vec2::from(v.uv)).collect(),
                triangles: (0..p.vertices.len() as u32 / 3)
                    .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
                    .collect(),
            })
            .collect();
        let tangents = scene
            .parts
            .iter()
            .map(|p| p.vertices.iter().map(|v| v.tangent).collect())
            .collect();
        let occluder = occluder(scene, &meshes);
        CpuRenderer {
            scene,
            meshes,
            tangents,
            lake: true.into(),
            occluder,
        }
    }
}

/// The parts of `scene` (as `meshes`) that cast the key's shadow: all but the cards.
fn occluder(scene: &Scene, meshes: &[TriMesh]) -> Bvh {
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for (part, mesh) in scene.parts.iter().zip(meshes) {
        if matches!(part.material, Material::Card { .. }) {
            continue;
        }
        let base = positions.len() as u32;
        positions.extend_from_slice(&mesh.positions);
        triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    Bvh::new(&positions, &triangles)
}

/// A part's albedo at a texture coordinate.
type Albedo<'m> = Box<dyn Fn(Vec2) -> Vec3 + Sync + 'm>;
/// A card's coverage at a texture coordinate.
type Cover<'m> = Box<dyn Fn(Vec2) -> f32 + Sync + 'm>;

/// How the CPU renderer reads a scene material: its albedo (none for the skin, which samples
/// its maps), roughness, F0, coverage and pixel kind.
fn looks(m: &Material) -> (Option<Albedo<'_>>, f32, f32, Option<Cover<'_>>, u8) {
    match m {
        Material::Skin(_) => (None, 0.0, 0.0, None, MATERIAL_SKIN),
        Material::Eye {
            albedo,
            roughness,
            f0,
            pupil,
            ..
        } => {
            let (tex, pupil) = (textured(albedo), *pupil);
            let dilated: Albedo = Box::new(move |uv| tex(derma_head::eye::dilated_uv(uv, pupil)));
            (Some(dilated), *roughness, *f0, None, MATERIAL_EYE)
        }
        Material::Textured {
            albedo,
            coverage,
            roughness,
            f0,
        } => (
            Some(textured(albedo)),
            *roughness,
            *f0,
            coverage.as_deref().map(voids),
            MATERIAL_OTHER,
        ),
        Material::Flat {
            albedo,
            roughness,
            f0,
        } => {
            let a = *albedo;
            (
                Some(Box::new(move |_| a)),
                *roughness,
                *f0,
                None,
                MATERIAL_OTHER,
            )
        }
        Material::Card {
            albedo,
            coverage,
            roughness,
            f0,
        } => {
            let a = *albedo;
            let cover: Cover = Box::new(move |uv: Vec2| coverage.sample_uv(uv.x, uv.y, false));
            (
                Some(Box::new(move |_| a)),
                *roughness,
                *f0,
                Some(cover),
                MATERIAL_OTHER,
            )
        }
    }
}

/// A textured part's coverage: its texture's alpha tested at ½ (forward.wgsl's test), so the
/// voids are cut out, not dithered.
fn voids(alpha: &Map) -> Cover<'_> {
    Box::new(move |uv: Vec2| {
        if alpha.sample_uv(uv.x, uv.y, false) < 0.5 {
            0.0
        } else {
            1.0
        }
    })
}

/// An albedo texture on a part's UVs (not repeated).
fn textured(albedo: &[Map; 3]) -> Albedo<'_> {
    Box::new(move |uv: Vec2| Vec3::from(albedo.each_ref().map(|c| c.sample_uv(uv.x, uv.y, false))))
}

impl Draw for CpuRenderer<'_> {
    fn draw(&self, view: &View, lighting: &Lighting, w: u32, h: u32) -> Result<Rendered> {
        let shot = Shot::framed(
            self.scene.centre,
            self.scene.radius,
            view,
            w as usize,
            h as usize,
        );
        let looks: Vec<_> = self
            .scene
            .parts
            .iter()
            .map(|p| looks(&p.material))
            .collect();
        let plains: Vec<Option<Plain>> = looks
            .iter()
            .map(|(albedo, roughness, f0, _, _)| {
                albedo.as_deref().map(|albedo| Plain {
                    albedo,
                    roughness: *roughness,
                    f0: *f0,
                })
            })
            .collect();
        let drawn: Vec<Drawn> = self
            .scene
            .parts
            .iter()
            .enumerate()
            .map(|(k, part)| {
                let (material, tangents): (&dyn crate::frame::Material, _) =
                    match (&part.material, &plains[k]) {
                        (Material::Skin(maps), _) => (maps.as_ref(), Some(&self.tangents[k][..])),
                        (_, Some(plain)) => (plain, None),
                        (_, None) => unreachable!("every part but the skin has an albedo"),
                    };
                Drawn {
                    mesh: &self.meshes[k],
                    tangents,
                    material,
                    coverage: looks[k]
                        .3
                        .as_deref()
                        .map(|f| f as &(dyn Fn(Vec2) -> f32 + Sync)),
                    kind: looks[k].4,
                }
            })
            .collect();
        let g = gbuffer(&drawn, &shot);
        let lake = self
            .lake
            .load(std::sync::atomic::Ordering::Relaxed)
            .then(|| g.searched_lake());
        // Shadow rays leave the surface 0.02 % of the scene's radius out (0.03 mm on a head).
        let shadow = Shadow {
            occluder: &self.occluder,
            offset: 2e-4 * self.scene.radius,
        };
        Ok(g.shade(
            lighting,
            Steps {
                lake: lake.as_ref(),
                shadow: Some(shadow),
            },
        ))
    }

    fn name(&self) -> String {
        CPU_NAME.into()
    }

    fn set_lake(&self, on: bool) {
        self.lake.store(on, std::sync::atomic::Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lighting::Setup;

    #[test]
    fn a_user_mesh_draws_on_the_cpu_framed_lit_and_repeatable() {
        let (mesh, _) = crate::cpu::sphere(50.0, 48);
        let maps = crate::SkinMaps::uniform([0.6, 0.4, 0.3], 0.5, 0.35);
        let scene = Scene::mesh(&mesh, maps);
        let r = CpuRenderer::new(&scene);
        let l = Setup::Studio.lighting();
        let a = r.draw(&View::default(), &l, 128, 96).unwrap();
        assert_eq!(
            (a.width, a.height, a.display.len()),
            (128, 96, 4 * 128 * 96)
        );
        // The sphere fills the middle of the frame, not the corners.
        assert_eq!(a.material[48 * 128 + 64], MATERIAL_SKIN);
        assert_eq!(a.material[0], MATERIAL_OTHER);
        let covered = a.material.iter().filter(|&&m| m == MATERIAL_SKIN).count();
        let frac = covered as f64 / (128.0 * 96.0);
        assert!((0.3..0.7).contains(&frac), "{frac}");
        // Lit from the key's side (upper left, camera space) more than the other.
        let lum = |x: usize, y: usize| {
            let p = a.linear[y * 128 + x];
            p[0] + p[1] + p[2]
        };
        assert!(
            lum(50, 36) > lum(78, 60),
            "{} vs {}",
            lum(50, 36),
            lum(78, 60)
        );
        // Red above green above blue for a skin-coloured albedo.
        let c = a.linear[48 * 128 + 64];
        assert!(c[0] > c[1] && c[1] > c[2], "{c:?}");
        let b = r.draw(&View::default(), &l, 128, 96).unwrap();
        assert!(a.display == b.display && a.linear == b.linear);
    }
}

/// A square `2 half` across at depth `z`, facing +Z, with UVs over it (the tests' scenes).
#[cfg(test)]
fn square(half: f32, z: f32) -> TriMesh {
    TriMesh {
        positions: [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(x, y)| Vec3::new(half * x, half * y, z))
            .to_vec(),
        normals: vec![Vec3::Z; 4],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// The tests' scene: a 40 mm skin square of colour `skin` and, 5 mm in front of it, a 20 mm
/// square part `name` drawn with `material`.
#[cfg(test)]
fn part_before_skin(skin: [f32; 3], name: &str, material: Material) -> Scene {
    let mut scene = Scene::mesh(
        &square(20.0, 0.0),
        crate::SkinMaps::uniform(skin, 0.5, 0.35),
    );
    scene.parts.push(crate::scene::Part {
        name: name.into(),
        vertices: crate::scene::corner_vertices(&square(10.0, 5.0), None),
        material,
    });
    scene
}

#[cfg(test)]
mod voids {
    use super::*;
    use crate::lighting::Setup;

    /// A 40 mm skin square and, 5 mm in front of it, a 20 mm textured square whose texture's
    /// alpha is 0 on its left half (a void, as between teeth).
    fn scene() -> Scene {
        let alpha = Map::from_fn(8, 8, |i| if i % 8 < 4 { 0.0 } else { 1.0 });
        part_before_skin(
            [0.6, 0.4, 0.3],
            "teeth_upper",
            Material::Textured {
                albedo: Box::new([0.9, 0.9, 0.85].map(|v| Map::filled(8, 8, v))),
                coverage: Some(Box::new(alpha)),
                roughness: 0.4,
                f0: 0.04,
            },
        )
    }

    /// What `r` shows in the textured square's left and right halves (a 128² frame, head-on).
    fn halves(r: &dyn Draw) -> (Vec<u8>, Vec<u8>) {
        let img = r
            .draw(&View::default(), &Setup::Studio.lighting(), 128, 128)
            .unwrap();
        // The front square spans about the middle third of the frame: sample well inside it.
        let at = |xs: std::ops::Range<usize>| {
            (56..72)
                .flat_map(|y| xs.clone().map(move |x| y * 128 + x))
                .map(|i| img.material[i])
                .collect()
        };
        (at(50..60), at(68..78))
    }

    fn the_voids_show_what_is_behind(r: &dyn Draw) {
        let (left, right) = halves(r);
        assert!(
            left.iter().all(|&m| m == MATERIAL_SKIN),
            "{}: {left:?}",
            r.name()
        );
        assert!(
            right.iter().all(|&m| m == MATERIAL_OTHER),
            "{}: {right:?}",
            r.name()
        );
    }

    #[test]
    fn a_textured_parts_voids_show_the_skin_behind_on_the_cpu() {
        let scene = scene();
        the_voids_show_what_is_behind(&CpuRenderer::new(&scene));
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn a_textured_parts_voids_show_the_skin_behind_on_the_gpu() {
        if derma_test_support::skip_without_gpu() {
            return;
        }
        let scene = scene();
        the_voids_show_what_is_behind(&Renderer::new(&scene).unwrap());
    }
}

#[cfg(test)]
mod cards {
    use super::*;
    use crate::lighting::Setup;

    /// A 40 mm grey skin square and, 5 mm in front of it, a 20 mm dark card whose coverage
    /// rises from 0 at its left edge to 1 at its right (a lash's edge, drawn large).
    fn scene() -> Scene {
        let ramp = Map::from_fn(64, 4, |i| (i % 64) as f32 / 63.0);
        part_before_skin(
            [0.6, 0.6, 0.6],
            "lashes",
            Material::Card {
                albedo: Vec3::splat(0.02),
                coverage: Box::new(ramp),
                roughness: 0.5,
                f0: 0.04,
            },
        )
    }

    /// The green channel's display codes along the card's middle rows, left to right, and the
    /// skin's beside it (a 128² frame, head-on).
    fn ramp(r: &dyn Draw) -> (Vec<Vec<u8>>, u8) {
        let img = r
            .draw(&View::default(), &Setup::Studio.lighting(), 128, 128)
            .unwrap();
        let g = |x: usize, y: usize| img.display[4 * (y * 128 + x) + 1];
        // The card spans about the middle third of the frame; rows and columns well inside it.
        let rows = (58..70)
            .map(|y| (48..80).map(|x| g(x, y)).collect())
            .collect();
        (rows, g(34, 64))
    }

    /// The alpha edge's pixels: every row falls smoothly from the skin to the card (no pixel
    /// brighter than its left neighbour by more than a code), the rows agree (no pattern from
    /// row to row), and the histogram is spread over many levels between the two ends — where
    /// the 4×4 ordered dither put nearly every pixel at the card's or the skin's value.
    fn the_alpha_edge_is_blended(r: &dyn Draw) {
        let (rows, skin) = ramp(r);
        for row in &rows {
            for w in row.windows(2) {
                assert!(w[1] <= w[0] + 1, "{}: not monotone {row:?}", r.name());
            }
            assert!(
                row.iter().zip(&rows[0]).all(|(a, b)| a.abs_diff(*b) <= 2),
                "{}: rows differ {row:?} vs {:?}",
                r.name(),
                rows[0]
            );
        }
        let codes: Vec<u8> = rows.concat();
        let (lo, hi) = (*codes.iter().min().unwrap(), *codes.iter().max().unwrap());
        let mut levels: Vec<u8> = codes.clone();
        levels.sort();
        levels.dedup();
        assert!(
            levels.len() >= 16,
            "{}: {} levels {levels:?}",
            r.name(),
            levels.len()
        );
        let ends = codes
            .iter()
            .filter(|&&c| c <= lo + 2 || c >= hi - 2)
            .count();
        assert!(
            ends * 4 < codes.len(),
            "{}: {ends} of {} pixels at the ends",
            r.name(),
            codes.len()
        );
        assert!(
            hi <= skin && lo < skin / 2,
            "{}: {lo}..{hi} against the skin's {skin}",
            r.name()
        );
    }

    #[test]
    fn a_cards_alpha_edge_is_blended_on_the_cpu() {
        the_alpha_edge_is_blended(&CpuRenderer::new(&scene()));
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn a_cards_alpha_edge_is_blended_on_the_gpu() {
        if derma_test_support::skip_without_gpu() {
            return;
        }
        the_alpha_edge_is_blended(&Renderer::new(&scene()).unwrap());
    }
}

#[cfg(test)]
mod pupil {
    use super::*;
    use crate::lighting::Setup;
    use crate::scene::{corner_vertices, Part};

    /// An eye texture of black pupil, light iris and grey sclera (the pupil the texture's own
    /// 4 mm), so the pupil's edge is unmistakable under any light.
    fn contrast_eye(n: usize) -> [Map; 3] {
        use derma_head::eye::{IRIS_UV_RADIUS, PUPIL_UV_RADIUS};
        let m = Map::from_fn(n, n, |i| {
            let uv = Vec2::new((i % n) as f32 + 0.5, (i / n) as f32 + 0.5) / n as f32;
            let r = (uv - Vec2::splat(0.5)).length();
            if r < PUPIL_UV_RADIUS {
                0.0
            } else if r < IRIS_UV_RADIUS {
                0.8
            } else {
                0.4
            }
        });
        [m.clone(), m.clone(), m]
    }

    /// A 12 mm globe looking at the camera in front of a skin square, its pupil `mm` across.
    fn scene(mm: f32) -> Scene {
        let mut scene = Scene::mesh(
            &square(30.0, -20.0),
            crate::SkinMaps::uniform([0.6, 0.4, 0.3], 0.5, 0.35),
        );
        let eye = derma_head::eye::Eye {
            centre: Vec3::ZERO,
            radius: 12.0,
        };
        scene.parts.push(Part {
            name: "eye_left".into(),
            vertices: corner_vertices(&eye.mesh(), None),
            material: Material::Eye {
                albedo: Box::new(contrast_eye(256)),
                centre: Vec3::ZERO,
                radius: 12.0,
                axis: Vec3::Z,
                roughness: 0.1,
                f0: 0.02,
                pupil: derma_head::eye::PUPIL_UV_RADIUS,
            },
        });
        scene.set_pupil(mm);
        scene
    }

    /// Pixels of the pupil (nearly black) in a head-on frame of the globe.
    fn pupil_pixels(r: &dyn Draw) -> usize {
        let img = r
            .draw(
                &View {
                    zoom: 0.5,
                    ..View::default()
                },
                &Setup::Studio.lighting(),
                128,
                128,
            )
            .unwrap();
        // Within 20 px of the frame's centre (about 5.5 mm: inside the iris, whose edge is
        // 5.8 mm out), away from the globe's shadowed rim.
        let near = |i: usize| {
            (((i % 128) as f32 - 63.5).powi(2) + ((i / 128) as f32 - 63.5).powi(2)) < 400.0
        };
        img.display
            .chunks_exact(4)
            .zip(&img.material)
            .enumerate()
            .filter(|(i, (p, m))| near(*i) && **m == MATERIAL_EYE && p[0].max(p[1]).max(p[2]) < 40)
            .count()
    }

    /// The pupil dilates and constricts through the texture's coordinates: its drawn area
    /// scales as the diameter squared (8 mm against 2 mm: 16×; the cornea magnifies both alike,
    /// the pixel grid and the specular highlight blur the count).
    fn the_pupils_area_follows_its_diameter(make: &dyn Fn(&Scene) -> Box<dyn Draw + '_>) {
        let (small, large) = (scene(2.0), scene(8.0));
        let (a, b) = (pupil_pixels(&*make(&small)), pupil_pixels(&*make(&large)));
        let ratio = b as f32 / a.max(1) as f32;
        println!("pupil 2 mm: {a} px, 8 mm: {b} px, ×{ratio:.1}");
        assert!(
            a > 10 && (11.0..=21.0).contains(&ratio),
            "2 mm: {a} px, 8 mm: {b} px, ×{ratio}"
        );
    }

    #[test]
    fn the_pupil_dilates_on_the_cpu() {
        the_pupils_area_follows_its_diameter(&|s| Box::new(CpuRenderer::new(s)));
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn the_pupil_dilates_on_the_gpu() {
        if derma_test_support::skip_without_gpu() {
            return;
        }
        the_pupils_area_follows_its_diameter(&|s| Box::new(Renderer::new(s).unwrap()));
    }
}
