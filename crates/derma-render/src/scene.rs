//! What is drawn: the skin (a mesh with a derma texture set) and, for the built-in head, its
//! parts with their own materials — eyes with a refracting cornea, lash cards, teeth, tongue —
//! as GPU-ready vertex lists (one vertex per triangle corner, MikkTSpace tangents).

use crate::material::{default_eye_texture, AlbedoTexture, SkinMaps};
use derma_core::mesh::{mikktspace_tangents, TriMesh};
use derma_core::Map;
use glam::{Quat, Vec3};

/// One vertex as the shaders read it.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Position (mm).
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Texture coordinate (v up).
    pub uv: [f32; 2],
    /// MikkTSpace tangent and bitangent sign.
    pub tangent: [f32; 4],
}

/// How a part is shaded.
#[derive(Clone)]
pub enum Material {
    /// The skin texture set.
    Skin(Box<SkinMaps>),
    /// An eye globe: its albedo on the globe's UVs, the globe (centre, radius, mm) and its
    /// optical axis; the cornea's tear film has the given roughness and F0.
    Eye {
        /// Linear RGB on the eye UVs.
        albedo: Box<[Map; 3]>,
        /// Centre (mm).
        centre: Vec3,
        /// Globe radius (mm).
        radius: f32,
        /// Unit optical axis (gaze).
        axis: Vec3,
        /// Tear film roughness.
        roughness: f32,
        /// Tear film F0.
        f0: f32,
        /// The pupil's UV radius as drawn (the texture's own: `derma_head::eye::PUPIL_UV_RADIUS`;
        /// another dilates or constricts it through texture coordinates, `eye::dilated_uv`).
        pupil: f32,
    },
    /// A part with its own albedo texture on its UVs (teeth from `derma photo teeth`).
    Textured {
        /// Linear RGB on the part's UVs.
        albedo: Box<[Map; 3]>,
        /// Coverage on the part's UVs (the texture's alpha: the voids between teeth), tested
        /// at ½; `None`: opaque.
        coverage: Option<Box<Map>>,
        /// Perceptual roughness.
        roughness: f32,
        /// F0.
        f0: f32,
    },
    /// A uniform material.
    Flat {
        /// Linear albedo.
        albedo: Vec3,
        /// Perceptual roughness.
        roughness: f32,
        /// F0.
        f0: f32,
    },
    /// A card (eyelashes, brows): uniform albedo, blended over what lies behind by its coverage.
    Card {
        /// Linear albedo.
        albedo: Vec3,
        /// Coverage on the card's UVs.
        coverage: Box<Map>,
        /// Perceptual roughness.
        roughness: f32,
        /// F0.
        f0: f32,
    },
}

/// A named mesh and its material.
pub struct Part {
    /// Name (as in the head: skin, eye_left, teeth_upper, …).
    pub name: String,
    /// Vertices, three per triangle.
    pub vertices: Vec<Vertex>,
    /// Its material.
    pub material: Material,
}

/// Everything a frame draws; the camera frames the first part (the skin).
pub struct Scene {
    /// The skin first, then the props.
    pub parts: Vec<Part>,
    /// Centre of the skin's bounding sphere (mm).
    pub centre: Vec3,
    /// Its radius (mm).
    pub radius: f32,
}

/// Corner vertices of `m` with per-corner `tangents` (or +X when `None`).
pub fn corner_vertices(m: &TriMesh, tangents: Option<&[[f32; 4]]>) -> Vec<Vertex> {
    let mut out = Vec::with_capacity(m.triangles.len() * 3);
    for (f, tri) in m.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let v = v as usize;
            out.push(Vertex {
                position: m.positions[v].to_array(),
                normal: m.normals.get(v).copied().unwrap_or(Vec3::Z).to_array(),
                uv: m.uvs.get(v).map(|t| t.to_array()).unwrap_or([0.0, 0.0]),
                tangent: tangents
                    .map(|t| t[3 * f + k])
                    .unwrap_or([1.0, 0.0, 0.0, 1.0]),
            });
        }
    }
    out
}

/// The sphere the camera frames a mesh by: centred on its bounding box, through its farthest
/// vertex.
pub fn bounding_sphere(mesh: &TriMesh) -> (Vec3, f32) {
    let (lo, hi) = mesh.bounds();
    let centre = 0.5 * (lo + hi);
    let radius = mesh
        .positions
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0f32, f32::max);
    (centre, radius)
}

/// Rotation of an eye from the neutral gaze (+Z) by yaw (about +Y, positive to the subject's
/// left) and pitch (up), degrees.
pub fn gaze_rotation(yaw_deg: f32, pitch_deg: f32) -> Quat {
    Quat::from_rotation_y(yaw_deg.to_radians()) * Quat::from_rotation_x(-pitch_deg.to_radians())
}

impl Scene {
    /// A user mesh (mm, with UVs and normals) with a texture set.
    pub fn mesh(mesh: &TriMesh, skin: SkinMaps) -> Scene {
        let t = mikktspace_tangents(mesh);
        let (centre, radius) = bounding_sphere(mesh);
        Scene {
            parts: vec![Part {
                name: "skin".into(),
                vertices: corner_vertices(mesh, Some(&t)),
                material: Material::Skin(Box::new(skin)),
            }],
            centre,
            radius,
        }
    }

    /// The built-in head posed by face-unit `weights` (the skin only; the parts stay), with a
    /// texture set, the eyes' albedo (`None`: the built-in eye) and the gaze (yaw, pitch in
    /// degrees).
    pub fn head(
        head: &derma_head::Head,
        skin: SkinMaps,
        weights: &[(&str, f32)],
        eye_albedo: Option<[Map; 3]>,
        gaze: (f32, f32),
    ) -> Scene {
        let posed = if weights.is_empty() {
            head.skin.clone()
        } else {
            head.posed_skin(weights)
        };
        Scene::posed_head(head, posed, skin, eye_albedo, gaze)
    }

    /// As [`Scene::head`] with the head's skin already posed (`posed`: the head's skin mesh,
    /// its vertices moved; e.g. by face units and the eye-region model).
    pub fn posed_head(
        head: &derma_head::Head,
        posed: TriMesh,
        skin: SkinMaps,
        eye_albedo: Option<[Map; 3]>,
        gaze: (f32, f32),
    ) -> Scene {
        let lash_color = skin.lash_color.map(Vec3::from);
        let brow_cards = skin.hair.clone().zip(lash_color);
        let mut scene = Scene::mesh(&posed, skin);
        // The brows as cards over the skin, where the set carries its hair coverage.
        if let Some((coverage, albedo)) = brow_cards {
            let look = derma_head::Look::of("eyebrows");
            let cards = derma_head::brows::BrowCards::of(head, &posed);
            scene.parts.push(Part {
                name: "eyebrows".into(),
                vertices: corner_vertices(&cards.mesh, None),
                material: Material::Card {
                    albedo,
                    coverage: Box::new(coverage),
                    roughness: look.roughness,
                    f0: look.f0,
                },
            });
        }
        scene.with_parts(head, lash_color, eye_albedo, gaze)
    }

    /// Gives every flat part whose name starts with `prefix` (`teeth` for `teeth_upper` and
    /// `teeth_lower`) the albedo texture `albedo` on its UVs (its alpha the part's coverage),
    /// keeping its roughness and F0. Returns how many parts took it.
    pub fn texture_parts(&mut self, prefix: &str, albedo: &AlbedoTexture) -> usize {
        let mut n = 0;
        for p in self.parts.iter_mut().filter(|p| p.name.starts_with(prefix)) {
            if let Material::Flat { roughness, f0, .. } = p.material {
                p.material = Material::Textured {
                    albedo: Box::new(albedo.rgb.clone()),
                    coverage: albedo.alpha.clone().map(Box::new),
                    roughness,
                    f0,
                };
                n += 1;
            }
        }
        n
    }

    /// Draws every globe's pupil `diameter_mm` across (its texture's is 4 mm): dilated or
    /// constricted through the texture coordinates, the limbus kept. Returns how many globes
    /// took it.
    pub fn set_pupil(&mut self, diameter_mm: f32) -> usize {
        let mut n = 0;
        for p in &mut self.parts {
            if let Material::Eye { radius, pupil, .. } = &mut p.material {
                *pupil = derma_head::eye::pupil_uv_radius(diameter_mm, *radius);
                n += 1;
            }
        }
        n
    }

    /// The part named `name` drawn with `mesh` instead (a lash riding on a moved lid); false
    /// when the scene has no such part.
    pub fn replace_part_mesh(&mut self, name: &str, mesh: &TriMesh) -> bool {
        match self.parts.iter_mut().find(|p| p.name == name) {
            Some(p) => {
                p.vertices = corner_vertices(mesh, None);
                true
            }
            None => false,
        }
    }

    /// Adds `head`'s parts (the globes, textured with `eye_albedo` or the built-in eye and
    /// turned to `gaze`; the lashes in `lash_color` or their own; teeth and tongue) at rest:
    /// to the head's own skin, or to a user's mesh the head was fitted to.
    pub fn with_parts(
        mut self,
        head: &derma_head::Head,
        lash_color: Option<Vec3>,
        eye_albedo: Option<[Map; 3]>,
        gaze: (f32, f32),
    ) -> Scene {
        let eye_tex = eye_albedo.unwrap_or_else(|| default_eye_texture(512));
        let rot = gaze_rotation(gaze.0, gaze.1);
        for part in &head.parts {
            let prop = derma_head::Look::of(&part.name);
            let centre_uv = glam::Vec2::splat(0.5);
            let material = if let Some(side) = part.name.strip_prefix("eye_") {
                let eye = if side == "left" {
                    &head.eyes[0]
                } else {
                    &head.eyes[1]
                };
                Material::Eye {
                    albedo: Box::new(eye_tex.clone()),
                    centre: eye.centre,
                    radius: eye.radius,
                    axis: rot * Vec3::Z,
                    roughness: prop.roughness,
                    f0: prop.f0,
                    pupil: derma_head::eye::PUPIL_UV_RADIUS,
                }
            } else if prop.coverage.is_some() {
                Material::Card {
                    albedo: lash_color.unwrap_or((prop.albedo)(centre_uv)),
                    coverage: Box::new(derma_head::lashes::coverage_map(512)),
                    roughness: prop.roughness,
                    f0: prop.f0,
                }
            } else {
                Material::Flat {
                    albedo: (prop.albedo)(centre_uv),
                    roughness: prop.roughness,
                    f0: prop.f0,
                }
            };
            let mut mesh = part.mesh.clone();
            if let Material::Eye { centre, .. } = &material {
                for p in &mut mesh.positions {
                    *p = *centre + rot * (*p - *centre);
                }
                for n in &mut mesh.normals {
                    *n = rot * *n;
                }
            }
            self.parts.push(Part {
                name: part.name.clone(),
                vertices: corner_vertices(&mesh, None),
                material,
            });
        }
        self
    }
}
