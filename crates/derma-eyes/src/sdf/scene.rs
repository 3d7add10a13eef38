//! The G-buffer of a close-up of the built-in head's eyes (material mask, view depth and the
//! surfaces), drawn by derma-render's CPU frame through a pinhole over the skin (lids and
//! sockets as skin) and the globes: the input the distance fields and the lake step need.

use super::{material, GBuffer};
use derma_core::mesh::TriMesh;
use derma_render::cpu::Plain;
use derma_render::frame::{gbuffer, Drawn, Shot};
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

    /// The camera as derma-render's shot: a pinhole looking down −Z, its axes head space's.
    pub fn shot(&self) -> Shot {
        Shot::pinhole(
            self.position,
            Mat3::IDENTITY,
            self.focal,
            self.width,
            self.height,
        )
    }

    /// Pixel coordinates and view depth of a head-space point.
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        self.shot().projection.project(p)
    }
}

/// A rendered close-up: derma-render's G-buffer, and the mask and depth the fields read.
pub struct Scene {
    /// Mask, depth, focal length.
    pub g: GBuffer,
    /// The renderer's G-buffer, which the lake is composited over and shaded from.
    pub frame: derma_render::frame::GBuffer,
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

/// Roughness and F0 of the skin around the globes: a skin-like lobe (F0 = 0.35 × 0.08 = 2.8 %,
/// as derma-render's flat skin).
const SKIN_LOBE: (f32, f32) = (0.5, 0.028);
/// Roughness of the bare tear film over the globe (authored: a thin, slightly uneven film) and
/// its F0 (water's, derma-render's lake).
const FILM_LOBE: (f32, f32) = (0.1, derma_render::lake::F0);

/// Draws the layers into derma-render's G-buffer (its rasteriser: perspective-correct
/// interpolation, nearest surface wins).
pub fn render(cam: &Camera, layers: &[Layer]) -> Scene {
    let plains: Vec<Plain> = layers
        .iter()
        .map(|l| {
            let (roughness, f0) = if l.material == material::EYE {
                FILM_LOBE
            } else {
                SKIN_LOBE
            };
            Plain {
                albedo: l.albedo,
                roughness,
                f0,
            }
        })
        .collect();
    let drawn: Vec<Drawn> = layers
        .iter()
        .zip(&plains)
        .map(|(l, plain)| Drawn {
            mesh: l.mesh,
            tangents: None,
            material: plain,
            coverage: None,
            kind: l.material,
        })
        .collect();
    let frame = gbuffer(&drawn, &cam.shot());
    let g = GBuffer {
        width: cam.width,
        height: cam.height,
        mask: frame.kinds(),
        depth: frame
            .pixels
            .iter()
            .map(|p| p.map_or(0.0, |p| p.depth))
            .collect(),
        focal: cam.focal,
    };
    Scene { g, frame }
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
