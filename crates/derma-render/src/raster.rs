//! The one software rasteriser: triangles of several meshes z-buffered into a per-pixel record
//! of what is nearest (object, triangle, barycentric weights, view depth), under an orthographic
//! framing or a pinhole camera (perspective-correct weights) — what the CPU renderer shades.

use derma_core::mesh::TriMesh;
use glam::{Mat3, Vec2, Vec3};

/// How points reach the image.
#[derive(Clone, Copy, Debug)]
pub enum Projection {
    /// Orthographic: a point p lands at `origin` + (p' − `centre`)·`scale` (y flipped: up on
    /// screen), with p' = `rotation` p; nearer is larger p'.z.
    Orthographic {
        /// Rotation applied before projecting.
        rotation: Mat3,
        /// The point drawn at `origin` (after rotation).
        centre: Vec3,
        /// Pixels per unit of length.
        scale: f32,
        /// Where `centre` lands (px).
        origin: Vec2,
    },
    /// A pinhole camera (the computer-vision convention): q = `rotation` (p − `position`) has
    /// +z forward and +y down, the pixel is `principal` + `focal` (q.x, q.y) / q.z.
    Pinhole {
        /// World → camera rotation.
        rotation: Mat3,
        /// Centre of projection (world).
        position: Vec3,
        /// Focal length (px).
        focal: f32,
        /// Principal point (px).
        principal: Vec2,
    },
}

impl Projection {
    /// Pixel coordinates and view depth (larger is farther) of a point.
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        match *self {
            Projection::Orthographic {
                rotation,
                centre,
                scale,
                origin,
            } => {
                let q = rotation * p;
                (
                    Vec2::new(
                        (q.x - centre.x) * scale + origin.x,
                        (centre.y - q.y) * scale + origin.y,
                    ),
                    -q.z,
                )
            }
            Projection::Pinhole {
                rotation,
                position,
                focal,
                principal,
            } => {
                let q = rotation * (p - position);
                (principal + focal * Vec2::new(q.x, q.y) / q.z, q.z)
            }
        }
    }
}

/// A mesh to rasterise, with an optional coverage over its UVs (cards such as eyelashes, a
/// texture's voids): a pixel is drawn where the coverage exceeds a threshold — ½ ([`rasterise`])
/// or the caller's ([`rasterise_above`]).
pub struct Object<'a> {
    /// The mesh (positions; UVs where `coverage` is given).
    pub mesh: &'a TriMesh,
    /// Coverage in [0, 1] at a texture coordinate; `None`: opaque.
    pub coverage: Option<&'a (dyn Fn(Vec2) -> f32 + Sync)>,
}

/// What a pixel shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the object.
    pub object: u32,
    /// Index of the triangle in its mesh.
    pub triangle: u32,
    /// Barycentric weights of the triangle's corners at the pixel centre (perspective-correct).
    pub weights: [f32; 3],
    /// View depth (units of length; orthographic: −z after rotation).
    pub depth: f32,
}

impl Hit {
    /// `values` (one per vertex of the object's mesh) interpolated at the pixel.
    pub fn interpolate<T>(&self, mesh: &TriMesh, values: &[T]) -> T
    where
        T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
    {
        let t = mesh.triangles[self.triangle as usize];
        let [w0, w1, w2] = self.weights;
        values[t[0] as usize] * w0 + values[t[1] as usize] * w1 + values[t[2] as usize] * w2
    }
}

/// Nearest depth a pinhole camera draws (units of length): triangles with a corner closer are
/// dropped (no clipping).
pub const NEAR: f32 = 1.0;

/// Rasterises `objects` into a `width`×`height` image (row 0 at the top): per pixel the nearest
/// surface, `None` where nothing is drawn. Pixel (x, y) samples at (x + ½, y + ½); of two
/// surfaces at the same depth the first drawn stays. An object with a coverage draws where it
/// exceeds ½ (an alpha test; blended cards go through [`rasterise_above`]).
pub fn rasterise(
    objects: &[Object],
    projection: &Projection,
    width: usize,
    height: usize,
) -> Vec<Option<Hit>> {
    rasterise_above(objects, projection, width, height, &|_, _| 0.5)
}

/// [`rasterise`] with an object's coverage tested against `threshold(x, y)` instead of ½: `&|_, _| 0.0` keeps the nearest fragment with any coverage (a blended card's layer).
pub fn rasterise_above(
    objects: &[Object],
    projection: &Projection,
    width: usize,
    height: usize,
    threshold: &dyn Fn(usize, usize) -> f32,
) -> Vec<Option<Hit>> {
    let perspective = matches!(projection, Projection::Pinhole { .. });
    let mut out: Vec<Option<Hit>> = vec![None; width * height];
    if out.is_empty() {
        return out;
    }
    let mut depth = vec![f32::INFINITY; width * height];
    for (obj, o) in objects.iter().enumerate() {
        let m = o.mesh;
        let scr: Vec<(Vec2, f32)> = m.positions.iter().map(|&p| projection.project(p)).collect();
        for (ti, t) in m.triangles.iter().enumerate() {
            let [(a, za), (b, zb), (c, zc)] = t.map(|i| scr[i as usize]);
            if perspective && (za <= NEAR || zb <= NEAR || zc <= NEAR) {
                continue;
            }
            let area = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
            if area.abs() < 1e-12 {
                continue;
            }
            let x0 = a.x.min(b.x).min(c.x).floor().max(0.0) as usize;
            let x1 = (a.x.max(b.x).max(c.x).ceil() as usize).min(width - 1);
            let y0 = a.y.min(b.y).min(c.y).floor().max(0.0) as usize;
            let y1 = (a.y.max(b.y).max(c.y).ceil() as usize).min(height - 1);
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let w1 = ((px - a.x) * (c.y - a.y) - (c.x - a.x) * (py - a.y)) / area;
                    let w2 = ((b.x - a.x) * (py - a.y) - (px - a.x) * (b.y - a.y)) / area;
                    let w0 = 1.0 - w1 - w2;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    let (weights, z) = if perspective {
                        let q = [w0 / za, w1 / zb, w2 / zc];
                        let z = 1.0 / (q[0] + q[1] + q[2]);
                        (q.map(|v| v * z), z)
                    } else {
                        ([w0, w1, w2], za * w0 + zb * w1 + zc * w2)
                    };
                    let k = y * width + x;
                    if let Some(cov) = o.coverage {
                        let uv = m.uvs[t[0] as usize] * weights[0]
                            + m.uvs[t[1] as usize] * weights[1]
                            + m.uvs[t[2] as usize] * weights[2];
                        if cov(uv) <= threshold(x, y) {
                            continue;
                        }
                    }
                    if z < depth[k] {
                        depth[k] = z;
                        out[k] = Some(Hit {
                            object: obj as u32,
                            triangle: ti as u32,
                            weights,
                            depth: z,
                        });
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32, half: f32) -> TriMesh {
        TriMesh {
            positions: vec![
                Vec3::new(-half, -half, z),
                Vec3::new(half, -half, z),
                Vec3::new(half, half, z),
                Vec3::new(-half, half, z),
            ],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn the_nearer_surface_wins_in_both_projections() {
        let (back, front) = (quad(-10.0, 12.0), quad(-5.0, 2.0));
        let objects = [
            Object {
                mesh: &back,
                coverage: None,
            },
            Object {
                mesh: &front,
                coverage: None,
            },
        ];
        let ortho = Projection::Orthographic {
            rotation: Mat3::IDENTITY,
            centre: Vec3::ZERO,
            scale: 1.0,
            origin: Vec2::splat(16.0),
        };
        // Looking down −Z from the origin: camera y down, z forward = diag(1, −1, −1).
        let pinhole = Projection::Pinhole {
            rotation: Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0)),
            position: Vec3::ZERO,
            focal: 16.0,
            principal: Vec2::splat(16.0),
        };
        for p in [ortho, pinhole] {
            let img = rasterise(&objects, &p, 32, 32);
            let centre = img[16 * 32 + 16].expect("drawn");
            assert_eq!(centre.object, 1, "{p:?}");
            let w = centre.weights;
            assert!((w[0] + w[1] + w[2] - 1.0).abs() < 1e-5);
            // Off the small quad, inside the large one.
            assert_eq!(img[16 * 32 + 6].map(|h| h.object), Some(0), "{p:?}");
        }
    }

    #[test]
    fn perspective_weights_recover_the_surface_point() {
        // A slanted triangle: the interpolated position must reproject onto the pixel centre.
        let m = TriMesh {
            positions: vec![
                Vec3::new(-30.0, -20.0, -40.0),
                Vec3::new(30.0, -20.0, -120.0),
                Vec3::new(0.0, 30.0, -60.0),
            ],
            normals: vec![Vec3::Z; 3],
            uvs: vec![Vec2::ZERO; 3],
            triangles: vec![[0, 1, 2]],
        };
        let p = Projection::Pinhole {
            rotation: Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0)),
            position: Vec3::ZERO,
            focal: 50.0,
            principal: Vec2::splat(50.0),
        };
        let img = rasterise(
            &[Object {
                mesh: &m,
                coverage: None,
            }],
            &p,
            100,
            100,
        );
        let mut n = 0;
        for (k, h) in img.iter().enumerate() {
            let Some(h) = h else { continue };
            let q = h.interpolate(&m, &m.positions);
            let (px, z) = p.project(q);
            let want = Vec2::new((k % 100) as f32 + 0.5, (k / 100) as f32 + 0.5);
            assert!(px.distance(want) < 1e-2, "{px} vs {want}");
            assert!((z - h.depth).abs() < 1e-3 * z);
            n += 1;
        }
        assert!(n > 500, "{n}");
    }

    #[test]
    fn an_empty_image_has_no_pixels() {
        let m = quad(-10.0, 1.0);
        let o = [Object {
            mesh: &m,
            coverage: None,
        }];
        let p = Projection::Orthographic {
            rotation: Mat3::IDENTITY,
            centre: Vec3::ZERO,
            scale: 1.0,
            origin: Vec2::ZERO,
        };
        assert!(rasterise(&o, &p, 0, 8).is_empty());
        assert!(rasterise(&o, &p, 8, 0).is_empty());
    }

    #[test]
    fn coverage_is_tested_at_a_half() {
        let m = quad(0.0, 16.0);
        let half = |uv: Vec2| uv.x;
        let img = rasterise(
            &[Object {
                mesh: &m,
                coverage: Some(&half),
            }],
            &Projection::Orthographic {
                rotation: Mat3::IDENTITY,
                centre: Vec3::ZERO,
                scale: 1.0,
                origin: Vec2::splat(8.0),
            },
            16,
            16,
        );
        // u runs 0.25 → 0.75 across the frame: the right half is drawn, whole, and no more.
        let drawn = img.iter().filter(|h| h.is_some()).count();
        assert_eq!(drawn, 128);
        assert!(img
            .iter()
            .enumerate()
            .all(|(i, h)| h.is_some() == (i % 16 >= 8)));
    }
}
