//! The renderer's materials and previews without a GPU: planar maps, a texture set's maps and
//! plain props as [`Material`]s, and the previews (`derma skin`'s preview.png, the rig's and the
//! eyes' frames, patches on a sphere or a tile) drawn through the CPU frame ([`crate::frame`]).

use crate::camera::View;
use crate::frame::{draw, Drawn, Material, MaterialSample, Shot};
use crate::lighting::{Light, Lighting};
use crate::material::{MATERIAL_EYE, MATERIAL_OTHER, MATERIAL_SKIN, SPECULAR_SCALE};
use crate::SkinMaps;
use derma_core::mesh::TriMesh;
use derma_core::Map;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

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

impl Material for Textures<'_> {
    fn sample(&self, uv: Vec2, _p: Vec3) -> MaterialSample {
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
    /// Coverage in [0, 1] at a texture coordinate, for cards such as eyelashes: the card is
    /// blended over what lies behind it by this alpha ([`crate::frame`]). `None`: opaque.
    pub coverage: Option<&'a (dyn Fn(Vec2) -> f32 + Sync)>,
    /// What its pixels show: [`MATERIAL_EYE`] (lit as a matte globe under a clear film, as the
    /// renderer lights an eye) or [`MATERIAL_OTHER`].
    pub kind: u8,
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
                kind: if p.name.starts_with("eye_") {
                    MATERIAL_EYE
                } else {
                    MATERIAL_OTHER
                },
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

/// A uniform-looking part: albedo as a function of its UV, one roughness and one F0, flat
/// normals (props, and the scene's eyes, cards and flat parts).
pub struct Plain<'a> {
    /// Linear albedo at a texture coordinate.
    pub albedo: &'a (dyn Fn(Vec2) -> Vec3 + Sync),
    /// Perceptual roughness.
    pub roughness: f32,
    /// Normal-incidence reflectance.
    pub f0: f32,
}

impl Material for Plain<'_> {
    fn sample(&self, uv: Vec2, _p: Vec3) -> MaterialSample {
        MaterialSample {
            albedo: (self.albedo)(uv),
            normal: Vec3::Z,
            roughness: self.roughness,
            f0: self.f0,
        }
    }
}

impl Material for SkinMaps {
    fn sample(&self, uv: Vec2, _p: Vec3) -> MaterialSample {
        let at = |m: &Map| m.sample_uv(uv.x, uv.y, self.wrap);
        let rgb = |m: &[Map; 3]| Vec3::new(at(&m[0]), at(&m[1]), at(&m[2]));
        MaterialSample {
            albedo: rgb(&self.base_color),
            // Stored n·½ + ½, as normal.png.
            normal: rgb(&self.normal) * 2.0 - 1.0,
            roughness: at(&self.roughness),
            f0: at(&self.specular) * SPECULAR_SCALE,
        }
    }
}

/// The surface `mesh` (per-corner `tangents`, material `tex`) and `props` as drawn objects.
fn with_props<'a>(
    mesh: &'a TriMesh,
    tangents: &'a [[f32; 4]],
    tex: &'a dyn Material,
    props: &'a [Prop],
    plains: &'a [Plain],
) -> Vec<Drawn<'a>> {
    let skin = Drawn {
        mesh,
        tangents: Some(tangents),
        material: tex,
        coverage: None,
        kind: MATERIAL_SKIN,
    };
    std::iter::once(skin)
        .chain(props.iter().zip(plains).map(|(p, plain)| Drawn {
            mesh: p.mesh,
            tangents: None,
            material: plain as &dyn Material,
            coverage: p.coverage,
            kind: p.kind,
        }))
        .collect()
}

/// Renders `mesh` (with per-corner tangents) seen from yaw `view_yaw` (radians about +Y, 0 =
/// from +Z) through the renderer's camera ([`Shot::framed`]) under the studio lighting
/// ([`crate::Setup::Studio`], as the GPU renderer's previews) into a `size`×`size` preview
/// (tone-mapped, linear RGB).
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
    let (centre, radius) = crate::scene::bounding_sphere(mesh);
    let view = View {
        yaw_deg: view_yaw.to_degrees(),
        ..View::default()
    };
    let shot = Shot::framed(centre, radius, &view, size, size);
    let plains = plains(props);
    let drawn = with_props(mesh, tangents, tex, props, &plains);
    draw(&drawn, &shot, &crate::Setup::Studio.lighting()).display_linear_maps()
}

/// Props' materials.
fn plains<'a>(props: &'a [Prop<'a>]) -> Vec<Plain<'a>> {
    props
        .iter()
        .map(|p| Plain {
            albedo: p.albedo,
            roughness: p.roughness,
            f0: p.f0,
        })
        .collect()
}

/// An orthographic preview ([`Shot::orthographic`], yaw `view_yaw` in radians) of `mesh` and
/// `props` under `lighting` (tone-mapped, linear RGB): for flat patches under a grazing light
/// and crops at a known scale (the eye region's band).
pub fn render_lit(
    mesh: &TriMesh,
    tangents: &[[f32; 4]],
    tex: &dyn Material,
    props: &[Prop],
    view_yaw: f32,
    size: usize,
    lighting: &Lighting,
) -> [Map; 3] {
    let shot = Shot::orthographic(mesh, view_yaw, size);
    let plains = plains(props);
    let drawn = with_props(mesh, tangents, tex, props, &plains);
    draw(&drawn, &shot, lighting).display_linear_maps()
}

/// One light towards `dir` (camera space; normalised here) of irradiance `irradiance`, with the
/// other two dark and no environment: a single-light [`Lighting`] (a grazing light over a patch).
pub fn single_light(dir: Vec3, irradiance: Vec3) -> Lighting {
    let dark = Light {
        dir: Vec3::Y,
        irradiance: Vec3::ZERO,
    };
    Lighting {
        lights: [
            Light {
                dir: dir.normalize(),
                irradiance,
            },
            dark,
            dark,
        ],
        sky: Vec3::ZERO,
        ground: Vec3::ZERO,
        exposure: 1.0,
    }
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
            kind: MATERIAL_OTHER,
        };
        render_with(&m, &t, &tex, &[prop], 0.0, 64)
    }

    /// The green channel (the white tile's, which the red card has none of) over the card's
    /// footprint, linear.
    fn green(img: &[Map; 3]) -> Vec<f32> {
        (26..38)
            .flat_map(|y| (26..38).map(move |x| (x, y)))
            .map(|(x, y)| derma_core::color::srgb_decode(img[1].get(x, y)))
            .collect()
    }

    #[test]
    fn props_draw_in_front_and_coverage_blends_them() {
        let (card, none) = (green(&scene(None)), green(&scene(Some(&|_| 0.0))));
        assert!(card.iter().all(|&g| g < 0.01), "{card:?}");
        assert!(none.iter().all(|&g| g > 0.1), "{none:?}");
        // Half coverage: every pixel a half-and-half mix, the same everywhere — no dither
        // pattern (the 4×4 ordered dither drew half of the pixels whole: two values, 0 and the
        // tile's). Mixed in linear light, then tone-mapped: between the two, at neither.
        let half = green(&scene(Some(&|_| 0.5)));
        let (lo, hi) = half
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &g| (a.min(g), b.max(g)));
        assert!(hi - lo < 0.01 * hi, "a pattern: {lo} to {hi}");
        assert!(lo > 0.02 && hi < 0.9 * none[0], "{lo} {hi} vs {}", none[0]);
    }
}
