//! Surfaces: the map from a texel to a point on the skin (thesis §3.3 and §4.8.7, UVtoManifold).
//! A flat patch (optionally a modulo space that tiles) or a mesh rasterised in UV space.

use derma_core::mesh::TriMesh;
use derma_core::raster::{dilation_sources, UvRaster};
use glam::{Vec2, Vec3};

/// Local frame of the surface at a texel.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Unit normal.
    pub n: Vec3,
    /// Unit tangent (MikkTSpace on meshes, +x on patches).
    pub t: Vec3,
    /// Unit bitangent, sign included (B = sign · N × T, the glTF convention).
    pub b: Vec3,
    /// ∂P/∂u and ∂P/∂v in mm per unit of texture coordinate.
    pub dpdu: Vec3,
    /// See `dpdu`.
    pub dpdv: Vec3,
}

impl Frame {
    /// Surface area covered by one texel of a `w`×`h` texture, mm².
    pub fn texel_area(&self, w: usize, h: usize) -> f32 {
        texel_area(self.dpdu, self.dpdv, w, h)
    }
}

/// Surface area covered by one texel of a `w`×`h` texture with UV Jacobian (∂P/∂u, ∂P/∂v), mm².
#[inline]
pub fn texel_area(dpdu: Vec3, dpdv: Vec3, w: usize, h: usize) -> f32 {
    dpdu.cross(dpdv).length() / (w * h) as f32
}

/// What a surface is made of.
pub enum Geometry {
    /// A flat rectangle.
    Patch {
        /// Its width and height, mm.
        size_mm: [f32; 2],
        /// Whether it wraps around (a modulo space, thesis §3.3).
        tileable: bool,
    },
    /// A mesh rasterised in UV space.
    Mesh(Box<MeshSurface>),
}

/// A mesh in millimetres with its UV raster and per-corner MikkTSpace tangents.
pub struct MeshSurface {
    /// The mesh, in mm.
    pub mesh: TriMesh,
    /// Its UV rasterisation at the output size.
    pub raster: UvRaster,
    /// Per triangle corner (3 per triangle): tangent xyz and bitangent sign.
    pub tangents: Vec<[f32; 4]>,
    /// Per triangle: ∂P/∂u, ∂P/∂v.
    pub jacobians: Vec<[Vec3; 2]>,
}

/// A texture-sized sampling of a surface.
pub struct Surface {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// Patch or mesh.
    pub geometry: Geometry,
}

impl Surface {
    /// A flat `size_mm` patch at `width × height` texels, tiling when `tileable`.
    pub fn patch(width: usize, height: usize, size_mm: [f32; 2], tileable: bool) -> Surface {
        Surface {
            width,
            height,
            geometry: Geometry::Patch { size_mm, tileable },
        }
    }

    /// Rasterises `mesh` (already in mm) at `width`×`height`.
    pub fn mesh(mesh: &TriMesh, tangents: &[[f32; 4]], width: usize, height: usize) -> Surface {
        let raster = UvRaster::new(mesh, width, height);
        let jacobians = mesh
            .triangles
            .iter()
            .map(|t| {
                let [p0, p1, p2] = t.map(|i| mesh.positions[i as usize]);
                let [t0, t1, t2] = t.map(|i| mesh.uvs[i as usize]);
                let (e1, e2) = (p1 - p0, p2 - p0);
                let (d1, d2) = (t1 - t0, t2 - t0);
                let det = d1.x * d2.y - d2.x * d1.y;
                if det.abs() < 1e-20 {
                    return [Vec3::ZERO, Vec3::ZERO];
                }
                let r = 1.0 / det;
                [(e1 * d2.y - e2 * d1.y) * r, (e2 * d1.x - e1 * d2.x) * r]
            })
            .collect();
        Surface {
            width,
            height,
            geometry: Geometry::Mesh(Box::new(MeshSurface {
                mesh: mesh.clone(),
                raster,
                tangents: tangents.to_vec(),
                jacobians,
            })),
        }
    }

    #[inline]
    /// Number of texels.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    #[inline]
    /// True without texels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Texture coordinate (v up) of texel `i`'s centre.
    #[inline]
    pub fn uv(&self, i: usize) -> Vec2 {
        let (x, y) = (i % self.width, i / self.width);
        Vec2::new(
            (x as f32 + 0.5) / self.width as f32,
            1.0 - (y as f32 + 0.5) / self.height as f32,
        )
    }

    /// The texel containing texture coordinate `uv` (clamped, or wrapped on a tileable patch).
    pub fn texel_at(&self, uv: Vec2) -> usize {
        let wrap = self.period().is_some();
        let fx = uv.x * self.width as f32;
        let fy = (1.0 - uv.y) * self.height as f32;
        let (x, y) = if wrap {
            (
                fx.floor().rem_euclid(self.width as f32) as usize,
                fy.floor().rem_euclid(self.height as f32) as usize,
            )
        } else {
            (
                (fx.max(0.0) as usize).min(self.width - 1),
                (fy.max(0.0) as usize).min(self.height - 1),
            )
        };
        y * self.width + x
    }

    #[inline]
    /// Whether texel `i` lies on the surface (always on a patch).
    pub fn covered(&self, i: usize) -> bool {
        match &self.geometry {
            Geometry::Patch { .. } => true,
            Geometry::Mesh(m) => m.raster.covered(i),
        }
    }

    /// Point on the surface (mm) of a covered texel.
    #[inline]
    pub fn position(&self, i: usize) -> Vec3 {
        match &self.geometry {
            Geometry::Patch { size_mm, .. } => {
                let uv = self.uv(i);
                Vec3::new(uv.x * size_mm[0], uv.y * size_mm[1], 0.0)
            }
            Geometry::Mesh(m) => m.raster.position(&m.mesh, i),
        }
    }

    /// Interpolated unit normal of a covered texel.
    #[inline]
    pub fn normal(&self, i: usize) -> Vec3 {
        match &self.geometry {
            Geometry::Patch { .. } => Vec3::Z,
            Geometry::Mesh(m) => {
                let [w1, w2] = m.raster.bary[i];
                let idx = m.mesh.triangles[m.raster.triangle[i] as usize];
                let nn = |k: usize| m.mesh.normals[idx[k] as usize];
                (nn(0) * (1.0 - w1 - w2) + nn(1) * w1 + nn(2) * w2).normalize_or(Vec3::Z)
            }
        }
    }

    /// Unit normal and ∂P/∂u, ∂P/∂v (mm per unit of texture coordinate) of a covered texel: the
    /// parts of [`Surface::frame`] that need no tangent.
    #[inline]
    pub fn normal_jacobian(&self, i: usize) -> (Vec3, [Vec3; 2]) {
        match &self.geometry {
            Geometry::Patch { size_mm, .. } => (
                Vec3::Z,
                [
                    Vec3::new(size_mm[0], 0.0, 0.0),
                    Vec3::new(0.0, size_mm[1], 0.0),
                ],
            ),
            Geometry::Mesh(m) => (self.normal(i), m.jacobians[m.raster.triangle[i] as usize]),
        }
    }

    /// Surface frame of a covered texel.
    pub fn frame(&self, i: usize) -> Frame {
        match &self.geometry {
            Geometry::Patch { size_mm, .. } => Frame {
                n: Vec3::Z,
                t: Vec3::X,
                b: Vec3::Y,
                dpdu: Vec3::new(size_mm[0], 0.0, 0.0),
                dpdv: Vec3::new(0.0, size_mm[1], 0.0),
            },
            Geometry::Mesh(m) => {
                let tri = m.raster.triangle[i] as usize;
                let [w1, w2] = m.raster.bary[i];
                let w0 = 1.0 - w1 - w2;
                let n = self.normal(i);
                let tc = |k: usize| Vec3::from_slice(&m.tangents[3 * tri + k][..3]);
                let sign = m.tangents[3 * tri][3];
                let t_raw = tc(0) * w0 + tc(1) * w1 + tc(2) * w2;
                // Gram–Schmidt against the interpolated normal (as a shader does per pixel).
                let t = (t_raw - n * n.dot(t_raw)).normalize_or(n.any_orthonormal_vector());
                let b = n.cross(t) * sign;
                let [dpdu, dpdv] = m.jacobians[tri];
                Frame {
                    n,
                    t,
                    b,
                    dpdu,
                    dpdv,
                }
            }
        }
    }

    /// Period of a tileable patch in mm.
    pub fn period(&self) -> Option<[f32; 2]> {
        match &self.geometry {
            Geometry::Patch {
                size_mm,
                tileable: true,
            } => Some(*size_mm),
            _ => None,
        }
    }

    /// Total painted surface area in mm².
    pub fn area_mm2(&self) -> f64 {
        match &self.geometry {
            Geometry::Patch { size_mm, .. } => (size_mm[0] * size_mm[1]) as f64,
            Geometry::Mesh(m) => m.mesh.area(),
        }
    }

    /// For meshes, the dilation sources that fill texels outside every triangle.
    pub fn dilation(&self) -> Option<Vec<u32>> {
        match &self.geometry {
            Geometry::Patch { .. } => None,
            Geometry::Mesh(m) => {
                let covered: Vec<bool> = (0..self.len()).map(|i| m.raster.covered(i)).collect();
                dilation_sources(&covered, self.width, self.height)
            }
        }
    }

    /// Mesh surface data, if any.
    pub fn mesh_surface(&self) -> Option<&MeshSurface> {
        match &self.geometry {
            Geometry::Mesh(m) => Some(m),
            _ => None,
        }
    }
}

pub use derma_core::mesh::mikktspace_tangents;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patch_maps_texels_to_mm() {
        let s = Surface::patch(4, 2, [40.0, 20.0], false);
        assert_eq!(s.position(0), Vec3::new(5.0, 15.0, 0.0));
        assert!((s.frame(0).texel_area(4, 2) - 100.0).abs() < 1e-4);
        assert_eq!(s.texel_at(Vec2::new(0.99, 0.01)), 7);
    }

    #[test]
    fn mesh_frame_matches_uv_directions() {
        // A 10 mm square with u along +x and v along +y.
        let mut m = TriMesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::new(10.0, 0.0, 0.0),
                Vec3::new(10.0, 10.0, 0.0),
                Vec3::new(0.0, 10.0, 0.0),
            ],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            normals: vec![],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        m.compute_normals();
        let tan = mikktspace_tangents(&m);
        let s = Surface::mesh(&m, &tan, 8, 8);
        let f = s.frame(9);
        assert!(
            (f.t - Vec3::X).length() < 1e-4
                && (f.b - Vec3::Y).length() < 1e-4
                && (f.n - Vec3::Z).length() < 1e-4
        );
        assert!((f.dpdu - Vec3::new(10.0, 0.0, 0.0)).length() < 1e-4);
        assert!((f.texel_area(8, 8) - 100.0 / 64.0).abs() < 1e-4);
    }
}
