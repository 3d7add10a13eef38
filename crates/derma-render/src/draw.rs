//! One scene API on any device: [`Draw`] renders a [`Scene`] from a [`View`] under a
//! [`Lighting`] — on a GPU the full renderer ([`Renderer`]), without one [`CpuRenderer`]: the
//! same camera, lights, GGX with height-correlated Smith visibility (Heitz 2014), hemisphere
//! environment (Karis 2014's split-sum fit) and ACES tone mapping (Narkowicz 2015) as
//! lighting.wgsl and composite.wgsl, without subsurface scattering, shadows, the lacrimal lake
//! or corneal refraction (and triangles with a corner within 1 mm of the camera are dropped,
//! not clipped).

use crate::brdf::{ggx_d, schlick, smith_vis};
use crate::camera::{Camera, View};
use crate::error::Result;
use crate::lighting::Lighting;
use crate::material::{MATERIAL_EYE, MATERIAL_OTHER, MATERIAL_SKIN, SPECULAR_SCALE};
use crate::raster::{rasterise, Object, Projection};
use crate::rendered::Rendered;
#[cfg(feature = "gpu")]
use crate::renderer::Renderer;
use crate::scene::{Material, Scene};
use derma_core::gpu::Device;
use derma_core::mesh::TriMesh;
use derma_core::Map;
use glam::{Mat3, Vec2, Vec3, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Something that renders its scene.
pub trait Draw {
    /// Renders `view` under `lighting` at `w`×`h` pixels.
    fn draw(&self, view: &View, lighting: &Lighting, w: u32, h: u32) -> Result<Rendered>;
    /// What draws: the GPU adapter, or the CPU renderer.
    fn name(&self) -> String;
    /// Draws the lacrimal lake or not (the GPU renderer; the CPU renderer has none).
    fn set_lake(&self, _on: bool) {}
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
pub const CPU_NAME: &str = "CPU (derma-render's CPU renderer: no subsurface scattering, shadows, lacrimal lake or corneal refraction)";

/// A scene drawn on the CPU through [`crate::raster`].
pub struct CpuRenderer<'a> {
    scene: &'a Scene,
    /// Each part's corner vertices as an indexed mesh (three vertices per triangle).
    meshes: Vec<TriMesh>,
    /// Per part, per vertex: the tangent and its bitangent sign.
    tangents: Vec<Vec<Vec4>>,
}

impl<'a> CpuRenderer<'a> {
    /// The renderer of `scene`.
    pub fn new(scene: &'a Scene) -> CpuRenderer<'a> {
        let meshes = scene
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
            .map(|p| p.vertices.iter().map(|v| Vec4::from(v.tangent)).collect())
            .collect();
        CpuRenderer {
            scene,
            meshes,
            tangents,
        }
    }
}

/// The lights and environment of a frame in world space.
struct Env {
    lights: [(Vec3, Vec3); 3],
    sky: Vec3,
    ground: Vec3,
}

impl Env {
    /// Hemisphere environment: sky above, ground below, blended over ±0.3 of the up component.
    fn environment(&self, d: Vec3) -> Vec3 {
        let t = ((d.y + 0.3) / 0.6).clamp(0.0, 1.0);
        self.ground.lerp(self.sky, t * t * (3.0 - 2.0 * t))
    }

    /// Diffuse irradiance (× albedo) and specular radiance of a surface (lighting.wgsl's
    /// `light_surface` without the key light's shadow).
    fn light(&self, n: Vec3, ng: Vec3, v: Vec3, rough: f32, f0: f32) -> (Vec3, Vec3) {
        let a = (rough * rough).max(0.002);
        let nv = n.dot(v).max(1e-4);
        let (mut diffuse, mut specular) = (Vec3::ZERO, Vec3::ZERO);
        for &(l, e) in &self.lights {
            let nl = n.dot(l).max(0.0) * if ng.dot(l) >= 0.0 { 1.0 } else { 0.0 };
            if nl <= 0.0 {
                continue;
            }
            let h = (l + v).normalize();
            let spec =
                ggx_d(n.dot(h).max(0.0), a) * smith_vis(nl, nv, a) * schlick(f0, v.dot(h).max(0.0));
            diffuse += e * nl * (1.0 - schlick(f0, nl)) / PI;
            specular += e * nl * spec;
        }
        diffuse += self.environment(n) * (1.0 - f0);
        let r = 2.0 * n.dot(v) * n - v;
        let (scale, bias) = env_brdf(rough, nv);
        specular += self
            .environment(r)
            .lerp(0.5 * (self.sky + self.ground), rough)
            * (f0 * scale + bias);
        (diffuse, specular)
    }
}

/// Karis 2014 ("Physically based shading on mobile"): the split-sum environment BRDF's F0
/// scale and bias.
fn env_brdf(rough: f32, nv: f32) -> (f32, f32) {
    let c0 = Vec4::new(-1.0, -0.0275, -0.572, 0.022);
    let c1 = Vec4::new(1.0, 0.0425, 1.04, -0.04);
    let r = rough * c0 + c1;
    let a004 = (r.x * r.x).min((-9.28 * nv).exp2()) * r.x + r.y;
    (-1.04 * a004 + r.z, 1.04 * a004 + r.w)
}

/// Narkowicz 2015, "ACES filmic tone mapping curve".
fn aces(x: f32) -> f32 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

fn byte(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

impl Draw for CpuRenderer<'_> {
    fn draw(&self, view: &View, lighting: &Lighting, w: u32, h: u32) -> Result<Rendered> {
        let (wu, hu) = (w as usize, h as usize);
        let cam = Camera::frame(self.scene.centre, self.scene.radius, view, w, h);
        // World → camera in the computer-vision convention (x right, y down, z forward).
        let [right, up, back] = cam.basis;
        let projection = Projection::Pinhole {
            rotation: Mat3::from_cols(right, -up, -back).transpose(),
            position: cam.eye,
            focal: cam.focal_px,
            principal: Vec2::new(0.5 * w as f32, 0.5 * h as f32),
        };
        let env = Env {
            lights: lighting.lights.map(|l| (cam.to_world(l.dir), l.irradiance)),
            sky: lighting.sky,
            ground: lighting.ground,
        };
        // Cards are drawn where their coverage exceeds the rasteriser's ordered dither, as
        // forward.wgsl discards them.
        type Cover<'m> = Box<dyn Fn(Vec2) -> f32 + Sync + 'm>;
        let covers: Vec<Option<Cover>> = self
            .scene
            .parts
            .iter()
            .map(|p| match &p.material {
                Material::Card { coverage: m, .. } => {
                    Some(Box::new(move |uv: Vec2| m.sample_uv(uv.x, uv.y, false)) as Cover)
                }
                _ => None,
            })
            .collect();
        let objects: Vec<Object> = self
            .meshes
            .iter()
            .zip(&covers)
            .map(|(mesh, c)| Object {
                mesh,
                coverage: c.as_deref().map(|f| f as &(dyn Fn(Vec2) -> f32 + Sync)),
            })
            .collect();
        let hits = rasterise(&objects, &projection, wu, hu);
        let shaded: Vec<Option<(Vec3, u8)>> = hits
            .par_iter()
            .map(|hit| {
                let hit = hit.as_ref()?;
                let k = hit.object as usize;
                let (mesh, part) = (&self.meshes[k], &self.scene.parts[k]);
                let p = hit.interpolate(mesh, &mesh.positions);
                let uv = hit.interpolate(mesh, &mesh.uvs);
                let v = (cam.eye - p).normalize();
                let mut ng = hit.interpolate(mesh, &mesh.normals).normalize_or(Vec3::Z);
                // Back faces show their inside as forward.wgsl does: facing from the triangle's
                // winding (counter-clockwise in front), not the interpolated normal; the eyes'
                // shader never flips.
                let [a, b, c] =
                    mesh.triangles[hit.triangle as usize].map(|i| mesh.positions[i as usize]);
                let front = (b - a).cross(c - a).dot(cam.eye - a) >= 0.0;
                if !front && !matches!(part.material, Material::Eye { .. }) {
                    ng = -ng;
                }
                // A part's own albedo texture at the hit (eyes, textured parts).
                let rgb_at =
                    |m: &[Map; 3]| Vec3::from(m.each_ref().map(|c| c.sample_uv(uv.x, uv.y, false)));
                Some(match &part.material {
                    Material::Skin(s) => {
                        let at = |m: &Map| m.sample_uv(uv.x, uv.y, s.wrap);
                        let albedo = Vec3::new(
                            at(&s.base_color[0]),
                            at(&s.base_color[1]),
                            at(&s.base_color[2]),
                        );
                        let t = hit.interpolate(mesh, &self.tangents[k]);
                        let t0 = t.truncate() - ng * ng.dot(t.truncate());
                        let n = if t0.length_squared() < 1e-12 {
                            ng
                        } else {
                            let t0 = t0.normalize();
                            let b = ng.cross(t0) * t.w.signum();
                            let m = Vec3::new(at(&s.normal[0]), at(&s.normal[1]), at(&s.normal[2]))
                                * 2.0
                                - 1.0;
                            (t0 * m.x + b * m.y + ng * m.z).normalize_or(ng)
                        };
                        let (rough, f0) = (at(&s.roughness), at(&s.specular) * SPECULAR_SCALE);
                        let (d, sp) = env.light(n, ng, v, rough, f0);
                        (d * albedo + sp, MATERIAL_SKIN)
                    }
                    Material::Eye {
                        albedo,
                        roughness,
                        f0,
                        ..
                    } => {
                        let a = rgb_at(albedo);
                        let (d, _) = env.light(ng, ng, v, 1.0, 0.0);
                        let (_, sp) = env.light(ng, ng, v, *roughness, *f0);
                        (d * a + sp, MATERIAL_EYE)
                    }
                    Material::Textured {
                        albedo,
                        roughness,
                        f0,
                    } => {
                        let (d, sp) = env.light(ng, ng, v, *roughness, *f0);
                        (d * rgb_at(albedo) + sp, MATERIAL_OTHER)
                    }
                    Material::Flat {
                        albedo,
                        roughness,
                        f0,
                    }
                    | Material::Card {
                        albedo,
                        roughness,
                        f0,
                        ..
                    } => {
                        let (d, sp) = env.light(ng, ng, v, *roughness, *f0);
                        (d * *albedo + sp, MATERIAL_OTHER)
                    }
                })
            })
            .collect();
        let mut display = Vec::with_capacity(4 * wu * hu);
        let mut linear = Vec::with_capacity(wu * hu);
        let mut material = Vec::with_capacity(wu * hu);
        for (i, s) in shaded.iter().enumerate() {
            match *s {
                None => {
                    // The background: composite.wgsl's soft vertical gradient.
                    let t = ((i / wu) as f32 + 0.5) / h as f32;
                    let bg = Vec3::new(0.06, 0.065, 0.075).lerp(Vec3::new(0.02, 0.02, 0.025), t);
                    display.extend([byte(bg.x), byte(bg.y), byte(bg.z), 255]);
                    linear.push([0.0; 3]);
                    material.push(MATERIAL_OTHER);
                }
                Some((rgb, m)) => {
                    let enc =
                        |x: f32| byte(derma_core::color::srgb_encode(aces(x * lighting.exposure)));
                    display.extend([enc(rgb.x), enc(rgb.y), enc(rgb.z), 255]);
                    linear.push(rgb.to_array());
                    material.push(m);
                }
            }
        }
        Ok(Rendered {
            width: wu,
            height: hu,
            display,
            linear,
            material,
        })
    }

    fn name(&self) -> String {
        CPU_NAME.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lighting::Setup;

    #[test]
    fn the_environment_brdf_and_tone_curve_match_their_sources() {
        // Karis 2014: a mirror seen head-on reflects all of F0 (scale ≈ 1, bias ≈ 0).
        let (s, b) = env_brdf(0.0, 1.0);
        assert!((s - 1.0).abs() < 0.03 && b.abs() < 0.03, "{s} {b}");
        // Narkowicz 2015: 0 → 0, monotone, saturating at 1.
        assert_eq!(aces(0.0), 0.0);
        assert!(aces(0.18) < aces(0.5) && aces(100.0) == 1.0);
    }

    #[test]
    fn a_user_mesh_draws_on_the_cpu_framed_lit_and_repeatable() {
        let (mesh, _) = crate::cpu::sphere(50.0, 48);
        let one = |v: f32| Map::filled(4, 4, v);
        let maps = crate::SkinMaps {
            base_color: [one(0.6), one(0.4), one(0.3)],
            normal: [one(0.5), one(0.5), one(1.0)],
            roughness: one(0.5),
            specular: one(0.35),
            subsurface: None,
            lash_color: None,
            hair: None,
            wrap: false,
        };
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
