//! The CPU renderer's frame, shaded in two passes as the GPU's: meshes rasterised by
//! [`crate::raster`] into a G-buffer (per pixel what was drawn, its view depth and the surface
//! there); then the steps that read the whole buffer — the lacrimal lake from a distance buffer
//! (EyeMove thesis §4.5, [`crate::lake`]) and the key light's shadow from an occluder — and the
//! one CPU shading ([`crate::shade`]), tone-mapped as composite.wgsl does.

use crate::camera::{Camera, View};
use crate::lake;
use crate::lighting::Lighting;
use crate::material::{MATERIAL_EYE, MATERIAL_OTHER};
use crate::raster::{rasterise, rasterise_above, Hit, Object, Projection};
use crate::rendered::Rendered;
use crate::shade::{Env, Lobe, Surface};
use derma_core::bvh::Bvh;
use derma_core::mesh::TriMesh;
use glam::{Mat3, Vec2, Vec3, Vec4};
use rayon::prelude::*;

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

/// A surface material the renderer samples: planar maps, a texture set's encoded maps (sampled
/// without decoded copies), or a solid texture over the surface's points.
pub trait Material: Sync {
    /// The material at texture coordinate `uv` (already scaled by [`Material::uv_scale`]) and
    /// surface point `p` (world; for materials that vary over space, not over their UVs).
    fn sample(&self, uv: Vec2, p: Vec3) -> MaterialSample;
    /// UV scale applied before sampling (tiling a patch over the preview sphere).
    fn uv_scale(&self) -> Vec2 {
        Vec2::ONE
    }
}

/// One mesh the CPU renderer draws.
pub struct Drawn<'a> {
    /// The mesh, with normals and UVs.
    pub mesh: &'a TriMesh,
    /// Per triangle corner (`3 t + k`), the MikkTSpace tangent and bitangent sign: the material's
    /// normals are tangent-space normals. `None`: the material's normals are ignored.
    pub tangents: Option<&'a [[f32; 4]]>,
    /// Its material.
    pub material: &'a dyn Material,
    /// Coverage over its UVs (cards, a part's voids): the part is blended over what lies
    /// behind it by this alpha — its nearest covered fragment per pixel, composited far to near
    /// with the other blended parts' ([`GBuffer::layers`]); `None`: opaque.
    pub coverage: Option<&'a (dyn Fn(Vec2) -> f32 + Sync)>,
    /// What its pixels show ([`crate::material::MATERIAL_SKIN`], [`MATERIAL_EYE`] or
    /// [`MATERIAL_OTHER`]); an eye is lit as a matte globe under a clear film and never shows
    /// its back faces.
    pub kind: u8,
}

/// Where the viewer of a CPU image stands.
#[derive(Clone, Copy, Debug)]
pub enum Viewer {
    /// A pinhole at this point (world).
    At(Vec3),
    /// Infinitely far along this unit direction (orthographic).
    Along(Vec3),
}

/// How a CPU image is taken: the projection, the viewer, the camera's axes in world (lights are
/// given in camera space) and the size.
pub struct Shot {
    /// World → pixels.
    pub projection: Projection,
    /// Where the viewer stands.
    pub viewer: Viewer,
    /// Camera → world rotation (x right, y up, z towards the viewer).
    pub to_world: Mat3,
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
}

impl Shot {
    /// The renderer's perspective camera ([`Camera::frame`]) for `view` of the sphere (`centre`,
    /// `radius`), as the GPU renderer takes it.
    pub fn framed(centre: Vec3, radius: f32, view: &View, width: usize, height: usize) -> Shot {
        let cam = Camera::frame(centre, radius, view, width as u32, height as u32);
        let [right, up, back] = cam.basis;
        Shot::pinhole(
            cam.eye,
            Mat3::from_cols(right, up, back),
            cam.focal_px,
            width,
            height,
        )
    }

    /// A pinhole at `eye` with the camera → world rotation `to_world` (x right, y up, z towards
    /// the viewer), focal length `focal` (px) and the principal point at the image centre.
    pub fn pinhole(eye: Vec3, to_world: Mat3, focal: f32, width: usize, height: usize) -> Shot {
        // World → camera in the computer-vision convention (x right, y down, z forward).
        let cv = Mat3::from_cols(to_world.x_axis, -to_world.y_axis, -to_world.z_axis);
        Shot {
            projection: Projection::Pinhole {
                rotation: cv.transpose(),
                position: eye,
                focal,
                principal: Vec2::new(0.5 * width as f32, 0.5 * height as f32),
            },
            viewer: Viewer::At(eye),
            to_world,
            width,
            height,
        }
    }

    /// An orthographic `size`² view of `mesh` from yaw `view_yaw` (radians about +Y, 0 = from
    /// +Z), framed on the mesh's extent at 92 % of the image.
    pub fn orthographic(mesh: &TriMesh, view_yaw: f32, size: usize) -> Shot {
        let rot = Mat3::from_rotation_y(-view_yaw);
        let (lo, hi) = mesh.positions.iter().map(|&p| rot * p).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(a, b), p| (a.min(p), b.max(p)),
        );
        Shot {
            projection: Projection::Orthographic {
                rotation: rot,
                centre: 0.5 * (lo + hi),
                scale: 0.92 * size as f32 / (hi - lo).x.max((hi - lo).y),
                origin: Vec2::splat(0.5 * size as f32),
            },
            viewer: Viewer::Along(rot.transpose() * Vec3::Z),
            to_world: rot.transpose(),
            width: size,
            height: size,
        }
    }

    /// Pixels per unit of length at view depth `depth`.
    fn px_per_unit(&self, depth: f32) -> f32 {
        match self.projection {
            Projection::Pinhole { focal, .. } => focal / depth.max(1e-3),
            Projection::Orthographic { scale, .. } => scale,
        }
    }
}

/// One pixel of the G-buffer: what was drawn there.
#[derive(Clone, Copy, Debug)]
pub struct Pixel {
    /// What it shows ([`Drawn::kind`]).
    pub kind: u8,
    /// View depth (units of length, larger is farther).
    pub depth: f32,
    /// The point (world).
    pub p: Vec3,
    /// The surface to shade.
    pub surface: Surface,
}

/// A fragment of a blended part (a card) in front of the opaque surface at its pixel.
#[derive(Clone, Copy, Debug)]
pub struct Fragment {
    /// Its pixel (row-major index).
    pub pixel: usize,
    /// Its coverage: the share of the pixel it covers.
    pub alpha: f32,
    /// What it shows there.
    pub px: Pixel,
}

/// The frame's G-buffer: per pixel what was drawn (`None`: the background).
pub struct GBuffer {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// The pixels, top row first.
    pub pixels: Vec<Option<Pixel>>,
    /// Camera → world rotation (the image's right, up and back in world).
    pub to_world: Mat3,
    /// Pixels per unit of length at each pixel's depth (pinhole: f / z).
    pub px_per_unit: Vec<f32>,
    /// The blended parts' fragments in front of the opaque surface: one per part and pixel
    /// (its nearest with any coverage), sorted by pixel and, within one, far to near.
    pub layers: Vec<Fragment>,
}

/// The key light's shadow: an occluder over the drawn meshes and the offset (units of length)
/// of the shadow rays' origins along the geometric normal.
#[derive(Clone, Copy)]
pub struct Shadow<'a> {
    /// The meshes that cast shadows.
    pub occluder: &'a Bvh,
    /// Ray offset (units of length).
    pub offset: f32,
}

/// What a frame adds between its G-buffer and its shading (all off by default).
#[derive(Clone, Copy, Default)]
pub struct Steps<'a> {
    /// The lacrimal lake over the globes, from [`GBuffer::lake`].
    pub lake: Option<&'a lake::Lake>,
    /// The key light's cast shadow.
    pub shadow: Option<Shadow<'a>>,
}

/// Rasterises `drawn` as `shot` sees them: the opaque parts (the first in front where they
/// overlap) into the pixels, the blended ones into [`GBuffer::layers`].
pub fn gbuffer(drawn: &[Drawn], shot: &Shot) -> GBuffer {
    let opaque: Vec<&Drawn> = drawn.iter().filter(|d| d.coverage.is_none()).collect();
    let objects: Vec<Object> = opaque
        .iter()
        .map(|d| Object {
            mesh: d.mesh,
            coverage: None,
        })
        .collect();
    let hits = rasterise(&objects, &shot.projection, shot.width, shot.height);
    let pixels: Vec<Option<Pixel>> = hits
        .par_iter()
        .map(|hit| {
            let hit = hit.as_ref()?;
            Some(pixel_at(hit, opaque[hit.object as usize], shot.viewer))
        })
        .collect();
    let layers = layers(drawn, shot, &pixels);
    let px_per_unit = pixels
        .iter()
        .map(|p| shot.px_per_unit(p.map_or(1.0, |p| p.depth)))
        .collect();
    GBuffer {
        width: shot.width,
        height: shot.height,
        pixels,
        to_world: shot.to_world,
        px_per_unit,
        layers,
    }
}

/// The fragments of `drawn`'s blended parts in front of `pixels` (the opaque surface), each
/// part's nearest with any coverage per pixel, sorted by pixel and far to near.
fn layers(drawn: &[Drawn], shot: &Shot, pixels: &[Option<Pixel>]) -> Vec<Fragment> {
    let mut out = Vec::new();
    for d in drawn.iter().filter(|d| d.coverage.is_some()) {
        let object = [Object {
            mesh: d.mesh,
            coverage: d.coverage,
        }];
        let hits = rasterise_above(
            &object,
            &shot.projection,
            shot.width,
            shot.height,
            &|_, _| 0.0,
        );
        let cover = d.coverage.expect("a blended part");
        out.par_extend(hits.par_iter().enumerate().filter_map(|(i, hit)| {
            let hit = hit.as_ref()?;
            if pixels[i].is_some_and(|p| p.depth <= hit.depth) {
                return None;
            }
            let uv = hit.interpolate(d.mesh, &d.mesh.uvs);
            Some(Fragment {
                pixel: i,
                alpha: cover(uv).clamp(0.0, 1.0),
                px: pixel_at(hit, d, shot.viewer),
            })
        }));
    }
    out.sort_by(|a, b| {
        a.pixel
            .cmp(&b.pixel)
            .then(b.px.depth.total_cmp(&a.px.depth))
    });
    out
}

/// Draws `drawn` as `shot` sees them under `lighting`: [`gbuffer`] shaded without steps.
pub fn draw(drawn: &[Drawn], shot: &Shot, lighting: &Lighting) -> Rendered {
    gbuffer(drawn, shot).shade(lighting, Steps::default())
}

impl GBuffer {
    /// What each pixel shows ([`MATERIAL_OTHER`] on the background).
    pub fn kinds(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .map(|p| p.map_or(MATERIAL_OTHER, |p| p.kind))
            .collect()
    }

    /// The lake over the globes from the distance buffer `distance` (per pixel λ to the nearest
    /// skin, units of length; infinite off the globes) for a lake of reach `range`: its depth,
    /// and the globe's normal tilted by its slope.
    pub fn lake(&self, distance: &[f32], range: f32) -> lake::Lake {
        self.lake_over(&self.kinds(), distance, range)
    }

    /// The lake over the pixels whose kinds are `kinds` ([`GBuffer::kinds`]).
    fn lake_over(&self, kinds: &[u8], distance: &[f32], range: f32) -> lake::Lake {
        let depth: Vec<f32> = distance.iter().map(|&l| lake::depth(l, range)).collect();
        let slope = lake::slopes(kinds, self.width, &depth, &self.px_per_unit);
        let (right, up) = (self.to_world.x_axis, self.to_world.y_axis);
        let normal = self
            .pixels
            .iter()
            .zip(&slope)
            .map(|(p, s)| match p {
                // A height field's normal leans down its slope, away from the lid.
                Some(p) => (p.surface.n - s.x * right - s.y * up).normalize(),
                None => Vec3::Z,
            })
            .collect();
        lake::Lake { depth, normal }
    }

    /// The lake found by the renderer's own distance search (lake.wgsl's: exact within the
    /// reach, at most [`lake::MAX_SEARCH_PX`] pixels a side).
    pub fn searched_lake(&self) -> lake::Lake {
        let kinds = self.kinds();
        let distance = lake::distance(&kinds, self.width, &self.px_per_unit, lake::RANGE_MM);
        self.lake_over(&kinds, &distance, lake::RANGE_MM)
    }

    /// Shades the frame under `lighting` with `steps`.
    pub fn shade(&self, lighting: &Lighting, steps: Steps) -> Rendered {
        let env = Env::new(lighting, |d| (self.to_world * d).normalize());
        let key = env.lights[0].0;
        let surface = |px: &Pixel| {
            let mut s = px.surface;
            if let Some(sh) = steps.shadow {
                s.key_seen *= lit(sh, px.p, s.ng, key);
            }
            s
        };
        let mut shaded: Vec<Option<(Vec3, u8)>> = self
            .pixels
            .par_iter()
            .enumerate()
            .map(|(i, px)| {
                let px = px.as_ref()?;
                let s = surface(px);
                let mut c = env.shade(&s);
                if let Some(l) = steps.lake.filter(|l| l.depth[i] > 0.0) {
                    let film = Lobe {
                        n: l.normal[i],
                        rough: lake::ROUGHNESS,
                        f0: lake::F0,
                        ..s.lobe()
                    };
                    c = lake::over(c, l.depth[i], env.light(film, s.key_seen).1);
                }
                Some((c, px.kind))
            })
            .collect();
        // The blended parts over it, far to near (the background as black light); a pixel
        // shows what covers at least half of it.
        let over: Vec<(&Fragment, Vec3)> = self
            .layers
            .par_iter()
            .map(|f| (f, env.shade(&surface(&f.px))))
            .collect();
        for (f, c) in over {
            let (under, kind) = shaded[f.pixel].unwrap_or((Vec3::ZERO, MATERIAL_OTHER));
            let kind = if f.alpha >= 0.5 { f.px.kind } else { kind };
            shaded[f.pixel] = Some((under.lerp(c, f.alpha), kind));
        }
        compose(&shaded, self.width, self.height, lighting.exposure)
    }
}

/// 1 where the key light towards `l` reaches `p` (geometric normal `ng`), else 0.
fn lit(sh: Shadow, p: Vec3, ng: Vec3, l: Vec3) -> f32 {
    if ng.dot(l) <= 0.0 || sh.occluder.occluded(p + ng * sh.offset, l, 0.0, f32::MAX) {
        0.0
    } else {
        1.0
    }
}

/// What `hit` shows of `d` seen by `viewer`.
fn pixel_at(hit: &Hit, d: &Drawn, viewer: Viewer) -> Pixel {
    let mesh = d.mesh;
    let p = hit.interpolate(mesh, &mesh.positions);
    let uv = hit.interpolate(mesh, &mesh.uvs) * d.material.uv_scale();
    let (v, towards) = match viewer {
        Viewer::At(eye) => ((eye - p).normalize(), eye),
        Viewer::Along(dir) => (dir, p + dir),
    };
    let mut ng = hit.interpolate(mesh, &mesh.normals).normalize_or(Vec3::Z);
    // Back faces show their inside as forward.wgsl does: facing from the triangle's winding
    // (counter-clockwise in front), not the interpolated normal; the eyes' shader never flips.
    let [a, b, c] = mesh.triangles[hit.triangle as usize].map(|i| mesh.positions[i as usize]);
    if (b - a).cross(c - a).dot(towards - a) < 0.0 && d.kind != MATERIAL_EYE {
        ng = -ng;
    }
    let m = d.material.sample(uv, p);
    let n = match d.tangents {
        Some(t) => normal_mapped(hit, t, ng, m.normal),
        None => ng,
    };
    Pixel {
        kind: d.kind,
        depth: hit.depth,
        p,
        surface: Surface {
            n,
            ng,
            v,
            albedo: m.albedo,
            roughness: m.roughness,
            f0: m.f0,
            matte_under_film: d.kind == MATERIAL_EYE,
            key_seen: 1.0,
        },
    }
}

/// The tangent-space normal `m` (in [−1, 1]) of a hit turned into world space by the per-corner
/// `tangents` about the geometric normal `ng`.
fn normal_mapped(hit: &Hit, tangents: &[[f32; 4]], ng: Vec3, m: Vec3) -> Vec3 {
    let c = |k: usize| Vec4::from(tangents[3 * hit.triangle as usize + k]);
    let [w0, w1, w2] = hit.weights;
    let t = c(0) * w0 + c(1) * w1 + c(2) * w2;
    let t0 = t.truncate() - ng * ng.dot(t.truncate());
    if t0.length_squared() < 1e-12 {
        return ng;
    }
    let t0 = t0.normalize();
    let b = ng.cross(t0) * t.w.signum();
    (t0 * m.x + b * m.y + ng * m.z).normalize_or(ng)
}

/// Narkowicz 2015, "ACES filmic tone mapping curve".
fn aces(x: f32) -> f32 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

fn byte(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The frame from per-pixel radiance and material (`None`: the background), as composite.wgsl
/// composes it: exposure, ACES and sRGB over a soft vertical gradient.
fn compose(shaded: &[Option<(Vec3, u8)>], w: usize, h: usize, exposure: f32) -> Rendered {
    let mut display = Vec::with_capacity(4 * w * h);
    let mut linear = Vec::with_capacity(w * h);
    let mut material = Vec::with_capacity(w * h);
    for (i, s) in shaded.iter().enumerate() {
        match *s {
            None => {
                let t = ((i / w) as f32 + 0.5) / h as f32;
                let bg = Vec3::new(0.06, 0.065, 0.075).lerp(Vec3::new(0.02, 0.02, 0.025), t);
                display.extend([byte(bg.x), byte(bg.y), byte(bg.z), 255]);
                linear.push([0.0; 3]);
                material.push(MATERIAL_OTHER);
            }
            Some((rgb, m)) => {
                let enc = |x: f32| byte(derma_core::color::srgb_encode(aces(x * exposure)));
                display.extend([enc(rgb.x), enc(rgb.y), enc(rgb.z), 255]);
                linear.push(rgb.to_array());
                material.push(m);
            }
        }
    }
    Rendered {
        width: w,
        height: h,
        display,
        linear,
        material,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::{single_light, tile, Plain};
    use crate::material::MATERIAL_SKIN;

    /// A 10 mm white tile seen head-on (orthographic, 32²), shaded by a key light from the
    /// viewer's side, with `occluder` casting the key's shadow when given.
    fn tile_under(occluder: Option<&Bvh>) -> Rendered {
        let (m, _) = tile(10.0);
        let white = |_: Vec2| Vec3::splat(0.8);
        let plain = Plain {
            albedo: &white,
            roughness: 0.5,
            f0: 0.0,
        };
        let drawn = [Drawn {
            mesh: &m,
            tangents: None,
            material: &plain,
            coverage: None,
            kind: MATERIAL_SKIN,
        }];
        let shot = Shot::orthographic(&m, 0.0, 32);
        let steps = Steps {
            shadow: occluder.map(|occluder| Shadow {
                occluder,
                offset: 0.01,
            }),
            ..Steps::default()
        };
        gbuffer(&drawn, &shot).shade(&single_light(Vec3::Z, Vec3::ONE), steps)
    }

    #[test]
    fn the_key_light_casts_the_occluders_shadow_and_nothing_else() {
        // A 4 mm card 2 mm above the tile's centre, between it and the key (not drawn).
        let (mut card, _) = tile(4.0);
        card.positions.iter_mut().for_each(|p| p.z = 2.0);
        let bvh = Bvh::new(&card.positions, &card.triangles);
        let (open, shaded) = (tile_under(None), tile_under(Some(&bvh)));
        let px = |r: &Rendered, x: usize, y: usize| r.linear[y * 32 + x][0];
        // The centre is dark (no environment in this lighting), a corner keeps its light.
        assert!(px(&open, 16, 16) > 0.1);
        assert_eq!(px(&shaded, 16, 16), 0.0);
        assert_eq!(px(&shaded, 3, 3), px(&open, 3, 3));
        // An occluder with nothing in it changes nothing.
        let none = Bvh::new(&[], &[]);
        assert_eq!(tile_under(Some(&none)).linear, open.linear);
    }

    /// A hand-made G-buffer: a 5×3 strip, skin in the first column and globe after it, facing
    /// the viewer, 10 px per mm.
    fn strip() -> GBuffer {
        let surface = Surface {
            n: Vec3::Z,
            ng: Vec3::Z,
            v: Vec3::Z,
            albedo: Vec3::splat(0.8),
            roughness: 0.1,
            f0: lake::F0,
            matte_under_film: true,
            key_seen: 1.0,
        };
        let pixels = (0..15)
            .map(|i| {
                Some(Pixel {
                    kind: if i % 5 == 0 {
                        MATERIAL_SKIN
                    } else {
                        MATERIAL_EYE
                    },
                    depth: 100.0,
                    p: Vec3::ZERO,
                    surface,
                })
            })
            .collect();
        GBuffer {
            width: 5,
            height: 3,
            pixels,
            to_world: Mat3::IDENTITY,
            px_per_unit: vec![10.0; 15],
            layers: Vec::new(),
        }
    }

    #[test]
    fn the_lake_step_leans_the_film_away_from_the_lid_and_leaves_the_skin() {
        let g = strip();
        let lake = g.lake(
            &[f32::INFINITY, 0.1, 0.3, 2.0, 2.0].repeat(3),
            lake::RANGE_MM,
        );
        // The film rises towards the skin on the left, so its normal leans right (+x), away
        // from the lid (a height field's normal is (−∂x, −∂y, 1)).
        assert!(
            lake.normal[6].x > 0.1 && lake.normal[6].y.abs() < 1e-6,
            "{}",
            lake.normal[6]
        );
        assert!((lake.normal[6].length() - 1.0).abs() < 1e-6);
        let l = single_light(Vec3::new(0.3, 0.2, 1.0), Vec3::splat(3.0));
        let dry = g.shade(&l, Steps::default());
        let wet = g.shade(
            &l,
            Steps {
                lake: Some(&lake),
                ..Steps::default()
            },
        );
        // The skin and the globe beyond the lake are untouched; under it the globe changes.
        assert_eq!(
            (dry.linear[5], dry.linear[8]),
            (wet.linear[5], wet.linear[8])
        );
        assert_ne!(dry.linear[6], wet.linear[6]);
        // The renderer's own search finds the same lake where λ is exact on the pixel grid.
        let searched = g.searched_lake();
        assert!((searched.depth[6] - lake::depth(0.1, lake::RANGE_MM)).abs() < 1e-6);
    }
}
