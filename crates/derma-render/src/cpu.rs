//! The renderer without a GPU: a textured mesh (and props such as eyes and teeth) rasterised by
//! [`crate::raster`] and shaded under a key and a fill light — Lambert diffuse plus a GGX
//! specular lobe (Walter et al. 2007), no subsurface scattering or shadows. What previews use
//! (`derma skin`'s preview.png, the rig's frames, the eyes' frames) where the GPU path's passes
//! are not needed.

use crate::brdf::{ggx_d, schlick};
use crate::raster::{rasterise, Object, Projection};
use derma_core::mesh::TriMesh;
use derma_core::Map;
use glam::{Mat3, Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

use crate::material::SPECULAR_SCALE;

/// A uniform material for surfaces without maps of their own: flat normals, one perceptual
/// roughness and one specular level (F0 / [`SPECULAR_SCALE`]), as 1×1 maps.
pub struct FlatMaterial {
    normal: [Map; 3],
    roughness: Map,
    specular: Map,
}

impl FlatMaterial {
    /// Roughness and specular level of the material.
    pub fn new(roughness: f32, specular: f32) -> Self {
        let one = |v: f32| Map::filled(1, 1, v);
        Self {
            normal: [one(0.0), one(0.0), one(1.0)],
            roughness: one(roughness),
            specular: one(specular),
        }
    }

    /// The material with `base_color` (any size; not repeated).
    pub fn textures<'a>(&'a self, base_color: &'a [Map; 3]) -> Textures<'a> {
        Textures {
            base_color,
            normal: &self.normal,
            roughness: &self.roughness,
            specular: &self.specular,
            specular_scale: SPECULAR_SCALE,
            wrap: false,
            uv_scale: Vec2::ONE,
        }
    }
}

/// A uniform linear colour as 1×1 maps.
pub fn uniform_color(rgb: [f32; 3]) -> [Map; 3] {
    rgb.map(|v| Map::filled(1, 1, v))
}

/// Textures the renderer samples (glTF metallic-roughness conventions, dielectric).
pub struct Textures<'a> {
    /// Diffuse albedo, linear sRGB.
    pub base_color: &'a [Map; 3],
    /// Tangent-space normal in [−1, 1].
    pub normal: &'a [Map; 3],
    /// Perceptual roughness.
    pub roughness: &'a Map,
    /// Specular map: F0 = specular × `specular_scale`.
    pub specular: &'a Map,
    /// F0 of a specular value of 1.
    pub specular_scale: f32,
    /// Repeat the texture (tileable patches).
    pub wrap: bool,
    /// UV scale applied before sampling (tiling a patch over the preview sphere).
    pub uv_scale: Vec2,
}

/// What the renderer reads of a surface's material at a texture coordinate.
#[derive(Clone, Copy, Debug)]
pub struct MaterialSample {
    /// Diffuse albedo, linear RGB.
    pub albedo: Vec3,
    /// Tangent-space normal (normalised by the renderer).
    pub normal: Vec3,
    /// Perceptual roughness.
    pub roughness: f32,
    /// Normal-incidence reflectance F0.
    pub f0: f32,
}

/// A surface material the renderer samples: planar maps ([`Textures`]) or any other store of
/// texels (a texture set's encoded maps, sampled without decoded copies).
pub trait Material: Sync {
    /// The material at texture coordinate `uv` (already scaled by [`Material::uv_scale`]).
    fn sample(&self, uv: Vec2) -> MaterialSample;
    /// UV scale applied before sampling (tiling a patch over the preview sphere).
    fn uv_scale(&self) -> Vec2 {
        Vec2::ONE
    }
}

impl Material for Textures<'_> {
    fn sample(&self, uv: Vec2) -> MaterialSample {
        let taps = derma_core::map::Taps::uv(
            self.base_color[0].width(),
            self.base_color[0].height(),
            uv.x,
            uv.y,
            self.wrap,
        );
        let s = |m: &Map| m.sample(&taps);
        MaterialSample {
            albedo: Vec3::new(
                s(&self.base_color[0]),
                s(&self.base_color[1]),
                s(&self.base_color[2]),
            ),
            normal: Vec3::new(s(&self.normal[0]), s(&self.normal[1]), s(&self.normal[2])),
            roughness: s(self.roughness),
            f0: s(self.specular) * self.specular_scale,
        }
    }
    fn uv_scale(&self) -> Vec2 {
        self.uv_scale
    }
}

/// A part drawn beside the textured surface with its own simple material (eyes, teeth, lashes):
/// albedo as a function of its UV, one roughness and one F0.
pub struct Prop<'a> {
    /// Its mesh (same space as the surface), with normals and UVs.
    pub mesh: &'a TriMesh,
    /// Linear albedo at a texture coordinate.
    pub albedo: &'a (dyn Fn(Vec2) -> Vec3 + Sync),
    /// GGX roughness (perceptual).
    pub roughness: f32,
    /// Normal-incidence Fresnel reflectance.
    pub f0: f32,
    /// Coverage in [0, 1] at a texture coordinate, for cards such as eyelashes: a pixel is drawn
    /// where the coverage exceeds an ordered-dither threshold (no blending). `None`: opaque.
    pub coverage: Option<&'a (dyn Fn(Vec2) -> f32 + Sync)>,
}

/// The parts of `head` as props with their looks ([`derma_head::Look`]).
pub fn head_props(head: &derma_head::Head) -> Vec<Prop<'_>> {
    head.parts
        .iter()
        .map(|p| {
            let look = derma_head::Look::of(&p.name);
            Prop {
                mesh: &p.mesh,
                albedo: look.albedo,
                roughness: look.roughness,
                f0: look.f0,
                coverage: look.coverage,
            }
        })
        .collect()
}

/// Gives every card of `props` (the parts with a coverage: the lashes) the albedo `albedo`.
pub fn recolour_cards<'a>(props: &mut [Prop<'a>], albedo: &'a (dyn Fn(Vec2) -> Vec3 + Sync)) {
    for p in props.iter_mut().filter(|p| p.coverage.is_some()) {
        p.albedo = albedo;
    }
}

/// Renders `mesh` (with per-corner tangents) seen from direction `view_yaw` (radians about +Y,
/// 0 = from +Z) into a `size`×`size` linear RGB image with a dark background.
pub fn render(
    mesh: &TriMesh,
    tangents: &[[f32; 4]],
    tex: &dyn Material,
    view_yaw: f32,
    size: usize,
) -> [Map; 3] {
    render_with(mesh, tangents, tex, &[], view_yaw, size)
}

/// [`render`] with props (drawn with their own materials, depth-tested against the surface);
/// the view is framed on the surface alone.
pub fn render_with(
    mesh: &TriMesh,
    tangents: &[[f32; 4]],
    tex: &dyn Material,
    props: &[Prop],
    view_yaw: f32,
    size: usize,
) -> [Map; 3] {
    render_lit(mesh, tangents, tex, props, view_yaw, size, &STUDIO)
}

/// A directional light in view space: unit direction towards the light and radiance.
pub type Light = (Vec3, Vec3);

/// The default lighting: a warm key from the upper left and a cool fill from the right
/// (radiance units), with a faint ambient term.
pub const STUDIO: [Light; 2] = [
    (
        Vec3::new(-0.5495, 0.5495, 0.6294),
        Vec3::new(3.0, 2.85, 2.6),
    ),
    (Vec3::new(0.7960, 0.0995, 0.5970), Vec3::new(0.55, 0.6, 0.7)),
];

/// [`render_with`] under the given lights (view space; the view looks down −Z).
pub fn render_lit(
    mesh: &TriMesh,
    tangents: &[[f32; 4]],
    tex: &dyn Material,
    props: &[Prop],
    view_yaw: f32,
    size: usize,
    lights: &[Light],
) -> [Map; 3] {
    let rot = Mat3::from_rotation_y(-view_yaw);
    let (lo, hi) = mesh.positions.iter().map(|&p| rot * p).fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(a, b), p| (a.min(p), b.max(p)),
    );
    let projection = Projection::Orthographic {
        rotation: rot,
        centre: 0.5 * (lo + hi),
        scale: 0.92 * size as f32 / (hi - lo).x.max((hi - lo).y),
        origin: Vec2::splat(0.5 * size as f32),
    };
    // Object 0 is the surface, k + 1 prop k.
    let objects: Vec<Object> = std::iter::once(Object {
        mesh,
        coverage: None,
    })
    .chain(props.iter().map(|p| Object {
        mesh: p.mesh,
        coverage: p.coverage,
    }))
    .collect();
    let hits = rasterise(&objects, &projection, size, size);
    let ambient = Vec3::new(0.08, 0.085, 0.1);
    let view = Vec3::Z;
    let pixels: Vec<Vec3> = hits
        .par_iter()
        .map(|hit| {
            let Some(hit) = hit else {
                return Vec3::splat(0.02);
            };
            let (obj, ti, [w0, w1, w2]) = (hit.object, hit.triangle, hit.weights);
            if obj > 0 {
                let p = &props[obj as usize - 1];
                let t = p.mesh.triangles[ti as usize];
                let at = |v: &[Vec3]| {
                    v[t[0] as usize] * w0 + v[t[1] as usize] * w1 + v[t[2] as usize] * w2
                };
                let uv = p.mesh.uvs[t[0] as usize] * w0
                    + p.mesh.uvs[t[1] as usize] * w1
                    + p.mesh.uvs[t[2] as usize] * w2;
                let n = (rot * at(&p.mesh.normals)).normalize_or(Vec3::Z);
                let alpha = (p.roughness * p.roughness).max(0.02);
                return shade(n, (p.albedo)(uv), alpha, p.f0, lights, ambient, view);
            }
            let t = mesh.triangles[ti as usize];
            let uv = (mesh.uvs[t[0] as usize] * w0
                + mesh.uvs[t[1] as usize] * w1
                + mesh.uvs[t[2] as usize] * w2)
                * tex.uv_scale();
            let n = (rot
                * (mesh.normals[t[0] as usize] * w0
                    + mesh.normals[t[1] as usize] * w1
                    + mesh.normals[t[2] as usize] * w2))
                .normalize_or(Vec3::Z);
            let tc = |k: usize| Vec3::from_slice(&tangents[3 * ti as usize + k][..3]);
            let tan = rot * (tc(0) * w0 + tc(1) * w1 + tc(2) * w2);
            let tan = (tan - n * n.dot(tan)).normalize_or(n.any_orthonormal_vector());
            let bit = n.cross(tan) * tangents[3 * ti as usize][3];
            let m = tex.sample(uv);
            let nt = m.normal;
            let nn = (tan * nt.x + bit * nt.y + n * nt.z).normalize_or(n);
            let alpha = m.roughness.powi(2).max(0.02);
            shade(nn, m.albedo, alpha, m.f0, lights, ambient, view)
        })
        .collect();
    Map::planes(size, size, |i| pixels[i].to_array())
}

/// Lambert diffuse plus a GGX lobe (Smith–Schlick visibility) under `lights` and an ambient term.
fn shade(
    nn: Vec3,
    albedo: Vec3,
    alpha: f32,
    f0: f32,
    lights: &[(Vec3, Vec3)],
    ambient: Vec3,
    view: Vec3,
) -> Vec3 {
    let mut c = albedo * ambient;
    for &(l, e) in lights {
        let nl = nn.dot(l);
        if nl <= 0.0 {
            continue;
        }
        let h = (l + view).normalize();
        let nh = nn.dot(h).max(0.0);
        let nv = nn.dot(view).max(1e-3);
        let d = ggx_d(nh, alpha);
        let f = schlick(f0, view.dot(h).max(0.0));
        let k = alpha * 0.5;
        let g = (nl / (nl * (1.0 - k) + k)) * (nv / (nv * (1.0 - k) + k));
        let spec = d * f * g / (4.0 * nl * nv);
        c += e * nl * (albedo * (1.0 - f) / PI + Vec3::splat(spec));
    }
    c
}

/// A UV sphere of `radius` mm with per-corner tangents (for previewing patches).
pub fn sphere(radius: f32, seg: usize) -> (TriMesh, Vec<[f32; 4]>) {
    let mut m = TriMesh::default();
    for j in 0..=seg {
        let v = j as f32 / seg as f32;
        let phi = v * PI;
        for i in 0..=2 * seg {
            let u = i as f32 / (2 * seg) as f32;
            let th = u * 2.0 * PI;
            let d = Vec3::new(phi.sin() * th.sin(), phi.cos(), phi.sin() * th.cos());
            m.positions.push(d * radius);
            m.normals.push(d);
            m.uvs.push(Vec2::new(u, 1.0 - v));
        }
    }
    let row = 2 * seg as u32 + 1;
    for j in 0..seg as u32 {
        for i in 0..2 * seg as u32 {
            let (a, b, c, d) = (
                j * row + i,
                j * row + i + 1,
                (j + 1) * row + i,
                (j + 1) * row + i + 1,
            );
            m.triangles.push([a, c, b]);
            m.triangles.push([b, c, d]);
        }
    }
    let tangents = derma_core::mesh::mikktspace_tangents(&m);
    (m, tangents)
}

/// A flat square of `size` mm facing +Z with UVs over [0, 1]².
pub fn tile(size: f32) -> (TriMesh, Vec<[f32; 4]>) {
    let s = 0.5 * size;
    let m = TriMesh {
        positions: vec![
            Vec3::new(-s, -s, 0.0),
            Vec3::new(s, -s, 0.0),
            Vec3::new(s, s, 0.0),
            Vec3::new(-s, s, 0.0),
        ],
        normals: vec![Vec3::Z; 4],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let t = derma_core::mesh::mikktspace_tangents(&m);
    (m, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A white tile seen head-on with a red prop card in front of it.
    fn scene(coverage: Option<&(dyn Fn(Vec2) -> f32 + Sync)>) -> [Map; 3] {
        let (m, t) = tile(10.0);
        let (base, material) = (uniform_color([0.8; 3]), FlatMaterial::new(0.5, 0.0));
        let tex = material.textures(&base);
        let mut card = tile(4.0).0;
        card.positions.iter_mut().for_each(|p| p.z = 1.0);
        let red = |_: Vec2| Vec3::new(0.8, 0.0, 0.0);
        let prop = Prop {
            mesh: &card,
            albedo: &red,
            roughness: 0.5,
            f0: 0.0,
            coverage,
        };
        render_with(&m, &t, &tex, &[prop], 0.0, 64)
    }

    /// Share of the pixels in the card's footprint that show the card (red, no green).
    fn card_share(img: &[Map; 3]) -> f32 {
        let (mut red, mut n) = (0, 0);
        for y in 26..38 {
            for x in 26..38 {
                n += 1;
                if img[1].get(x, y) < 0.01 && img[0].get(x, y) > 0.05 {
                    red += 1;
                }
            }
        }
        red as f32 / n as f32
    }

    #[test]
    fn props_draw_in_front_and_coverage_thins_them() {
        assert_eq!(card_share(&scene(None)), 1.0);
        assert_eq!(card_share(&scene(Some(&|_| 0.0))), 0.0);
        // Half coverage draws half of the pixels, evenly (the 4×4 ordered dither).
        let half = card_share(&scene(Some(&|_| 0.5)));
        assert!((half - 0.5).abs() < 0.05, "{half}");
    }
}
