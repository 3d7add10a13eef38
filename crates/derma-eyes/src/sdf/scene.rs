//! The G-buffer of a close-up of the built-in head's eyes (material mask, view depth, normals
//! and albedo): a perspective z-buffer rasteriser over the skin (lids and sockets as skin) and
//! the globes, the input the distance fields and the lake compositing need.

use super::{material, GBuffer};
use derma_core::mesh::TriMesh;
use glam::{Vec2, Vec3};

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

    /// Pixel coordinates and view depth of a head-space point.
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        let v = p - self.position;
        let z = -v.z;
        (
            Vec2::new(
                self.width as f32 * 0.5 + self.focal * v.x / z,
                self.height as f32 * 0.5 - self.focal * v.y / z,
            ),
            z,
        )
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

/// Rasterises the layers (perspective-correct interpolation, nearest surface wins).
pub fn render(cam: &Camera, layers: &[Layer]) -> Scene {
    let (w, h) = (cam.width, cam.height);
    let mut depth = vec![f32::INFINITY; w * h];
    let mut mask = vec![material::NONE; w * h];
    let mut normal = vec![Vec3::Z; w * h];
    let mut albedo = vec![Vec3::ZERO; w * h];
    for l in layers {
        let m = l.mesh;
        let proj: Vec<(Vec2, f32)> = m.positions.iter().map(|&p| cam.project(p)).collect();
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| proj[i as usize]);
            if a.1 <= 1.0 || b.1 <= 1.0 || c.1 <= 1.0 {
                continue;
            }
            let area = (b.0 - a.0).perp_dot(c.0 - a.0);
            if area.abs() < 1e-9 {
                continue;
            }
            let lo = a.0.min(b.0).min(c.0).floor().max(Vec2::ZERO);
            let hi =
                a.0.max(b.0)
                    .max(c.0)
                    .ceil()
                    .min(Vec2::new(w as f32 - 1.0, h as f32 - 1.0));
            if lo.x > hi.x || lo.y > hi.y {
                continue;
            }
            for y in lo.y as usize..=hi.y as usize {
                for x in lo.x as usize..=hi.x as usize {
                    let s = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let w0 = (c.0 - b.0).perp_dot(s - b.0) / area;
                    let w1 = (a.0 - c.0).perp_dot(s - c.0) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    // Perspective-correct weights.
                    let q = [w0 / a.1, w1 / b.1, w2 / c.1];
                    let qs = q[0] + q[1] + q[2];
                    let z = 1.0 / qs;
                    let i = y * w + x;
                    if z < depth[i] {
                        depth[i] = z;
                        mask[i] = l.material;
                        let bw = q.map(|v| v * z);
                        let n = t
                            .iter()
                            .zip(bw)
                            .map(|(&k, wk)| m.normals[k as usize] * wk)
                            .sum::<Vec3>();
                        normal[i] = n.normalize_or(Vec3::Z);
                        let uv: Vec2 = t
                            .iter()
                            .zip(bw)
                            .map(|(&k, wk)| m.uvs[k as usize] * wk)
                            .sum();
                        albedo[i] = (l.albedo)(uv);
                    }
                }
            }
        }
    }
    for d in depth.iter_mut() {
        if !d.is_finite() {
            *d = 0.0;
        }
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
