//! The G-buffer of a close-up of the built-in head's eyes (material mask, view depth, normals
//! and albedo), drawn by derma-render's rasteriser through a pinhole over the skin (lids and
//! sockets as skin) and the globes: the input the distance fields and the lake compositing need.

use super::{material, GBuffer};
use derma_core::mesh::TriMesh;
use derma_render::lake::Surfaces;
use derma_render::raster::{rasterise, Object, Projection};
use glam::{Mat3, Vec2, Vec3};

/// A pinhole camera looking down −Z (view space), at `position` in head space.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye point (head space, mm).
    pub position: Vec3,
    /// Focal length (px).
    pub focal: f32,
    /// Image size.
    pub width: usize,
    /// Image height.
    pub height: usize,
}

impl Camera {
    /// A frontal close-up of both eyes of `head` at `width` × `height`: 260 mm in front of the
    /// globes, framing 110 mm across.
    pub fn close_up(head: &derma_head::Head, width: usize, height: usize) -> Camera {
        let c = 0.5 * (head.eyes[0].centre + head.eyes[1].centre);
        let dist = 260.0;
        Camera {
            position: c + Vec3::new(0.0, 0.0, dist),
            focal: width as f32 * dist / 110.0,
            width,
            height,
        }
    }

    /// The camera as derma-render's pinhole (looking down −Z: camera y down, z forward).
    pub fn projection(&self) -> Projection {
        Projection::Pinhole {
            rotation: Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0)),
            position: self.position,
            focal: self.focal,
            principal: Vec2::new(self.width as f32 * 0.5, self.height as f32 * 0.5),
        }
    }

    /// Pixel coordinates and view depth of a head-space point.
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        self.projection().project(p)
    }
}

/// A rendered close-up: the G-buffer plus view-space normals and linear albedo.
pub struct Scene {
    /// Mask, depth, focal length.
    pub g: GBuffer,
    /// View-space normal per pixel.
    pub normal: Vec<Vec3>,
    /// Linear albedo per pixel.
    pub albedo: Vec<Vec3>,
}

/// A mesh to draw: its material and albedo function of UV.
pub struct Layer<'a> {
    /// Mesh in head space.
    pub mesh: &'a TriMesh,
    /// Material id.
    pub material: u8,
    /// Albedo at a UV.
    pub albedo: &'a (dyn Fn(Vec2) -> Vec3 + Sync),
}

/// Rasterises the layers with derma-render's rasteriser (perspective-correct interpolation,
/// nearest surface wins).
pub fn render(cam: &Camera, layers: &[Layer]) -> Scene {
    let (w, h) = (cam.width, cam.height);
    let objects: Vec<Object> = layers
        .iter()
        .map(|l| Object {
            mesh: l.mesh,
            coverage: None,
        })
        .collect();
    let hits = rasterise(&objects, &cam.projection(), w, h);
    let mut depth = vec![0.0; w * h];
    let mut mask = vec![material::NONE; w * h];
    let mut normal = vec![Vec3::Z; w * h];
    let mut albedo = vec![Vec3::ZERO; w * h];
    for (i, hit) in hits.iter().enumerate() {
        let Some(hit) = hit else { continue };
        let l = &layers[hit.object as usize];
        depth[i] = hit.depth;
        mask[i] = l.material;
        normal[i] = hit
            .interpolate(l.mesh, &l.mesh.normals)
            .normalize_or(Vec3::Z);
        albedo[i] = (l.albedo)(hit.interpolate(l.mesh, &l.mesh.uvs));
    }
    Scene {
        g: GBuffer {
            width: w,
            height: h,
            mask,
            depth,
            focal: cam.focal,
        },
        normal,
        albedo,
    }
}

impl Scene {
    /// The scene as derma-render's lake compositing reads it.
    pub fn surfaces<'a>(&'a self, px_per_mm: &'a (dyn Fn(usize) -> f32 + Sync)) -> Surfaces<'a> {
        Surfaces {
            width: self.g.width,
            height: self.g.height,
            material: &self.g.mask,
            normal: &self.normal,
            albedo: &self.albedo,
            px_per_mm,
        }
    }
}

/// The built-in head's eye close-up at rest: skin (skin albedo), globes with the default eye
/// texture (open cornea, iris disc behind it).
pub fn head_close_up(head: &derma_head::Head, width: usize, height: usize) -> Scene {
    let cam = Camera::close_up(head, width, height);
    let globes: Vec<TriMesh> = head
        .eyes
        .iter()
        .flat_map(|e| {
            let g = crate::globe::Globe::of(e);
            let mut shell = g.shell(false);
            let mut iris = g.iris();
            for m in [&mut shell, &mut iris] {
                for p in m.positions.iter_mut() {
                    *p += e.centre;
                }
            }
            [shell, iris]
        })
        .collect();
    static SKIN: fn(Vec2) -> Vec3 = |_| Vec3::new(0.56, 0.36, 0.28);
    static EYE: fn(Vec2) -> Vec3 = derma_head::eye::default_albedo;
    let mut layers = vec![Layer {
        mesh: &head.skin,
        material: material::SKIN,
        albedo: &SKIN,
    }];
    for g in &globes {
        layers.push(Layer {
            mesh: g,
            material: material::EYE,
            albedo: &EYE,
        });
    }
    render(&cam, &layers)
}
