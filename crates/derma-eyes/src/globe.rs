//! The eyeball as a non-spherical globe (thesis §2.2, §3.8): a scleral sphere with the cornea's
//! steeper cap bulging in front, an iris plane behind the cornea with a pupil, meshed with the
//! head's eye UVs (so a `derma photo iris` texture maps onto it), and the radial distance map
//! D(α) of its outer surface that globe sliding samples (eq. 3.12).

use derma_core::bvh::Bvh;
use derma_core::mesh::TriMesh;
use derma_head::eye::{polar_mesh, Eye, IRIS_UV_RADIUS};
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Anterior corneal radius of curvature (mm): Le Grand's full theoretical eye, 7.8 mm
/// (Le Grand & El Hage 1980, "Physiological Optics", table 4.1).
pub const CORNEA_RADIUS: f32 = 7.8;
/// Limbus radius (mm): half the 11.7 mm horizontal visible iris diameter (Rüfer et al. 2005,
/// Cornea 24:259), where the corneal cap meets the sclera.
pub const LIMBUS_RADIUS: f32 = 5.85;
/// Depth of the iris plane behind the corneal apex (mm): corneal thickness 0.55 plus anterior
/// chamber 3.05 in Le Grand's eye, 3.6 mm.
pub const IRIS_DEPTH: f32 = 3.6;
/// Pupil radius (mm): a 4 mm pupil in indoor light, as the head's default eye texture.
pub const PUPIL_RADIUS: f32 = 2.0;

/// A globe in its own frame: centre at the origin, optical axis +Z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Globe {
    /// Scleral radius (mm).
    pub radius: f32,
    /// Distance from the globe centre to the corneal sphere's centre along +Z.
    pub cornea_offset: f32,
}

impl Globe {
    /// The globe of a head eye: its sphere is the sclera; the cornea cap meets it at the limbus.
    pub fn of(eye: &Eye) -> Globe {
        let z_limbus = (eye.radius * eye.radius - LIMBUS_RADIUS * LIMBUS_RADIUS).sqrt();
        let sag =
            CORNEA_RADIUS - (CORNEA_RADIUS * CORNEA_RADIUS - LIMBUS_RADIUS * LIMBUS_RADIUS).sqrt();
        let apex = z_limbus + sag;
        Globe {
            radius: eye.radius,
            cornea_offset: apex - CORNEA_RADIUS,
        }
    }

    /// z of the corneal apex.
    pub fn apex(&self) -> f32 {
        self.cornea_offset + CORNEA_RADIUS
    }

    /// Angle (rad) of the limbus from the optical axis.
    pub fn limbus_angle(&self) -> f32 {
        (LIMBUS_RADIUS / self.radius).asin()
    }

    /// Exact radial distance of the outer surface along unit direction `d`: the sclera, or the
    /// corneal sphere where it lies outside it.
    pub fn radial(&self, d: Vec3) -> f32 {
        // Ray from the origin along d against the sphere |x − c ẑ| = R_c.
        let c = self.cornea_offset;
        let b = d.z * c;
        let disc = b * b - (c * c - CORNEA_RADIUS * CORNEA_RADIUS);
        if disc < 0.0 {
            return self.radius;
        }
        (b + disc.sqrt()).max(self.radius)
    }

    /// The outer shell (sclera and cornea) with the head's eye UVs; `with_cornea: false` leaves
    /// the corneal cap open (for renderers without transparency, which then show the iris disc).
    pub fn shell(&self, with_cornea: bool) -> TriMesh {
        const RINGS: usize = 64;
        const SEGMENTS: usize = 64;
        let lim = self.limbus_angle();
        // Rings: the corneal cap gets a third of them, so the bulge is resolved.
        let cap = RINGS / 3;
        let theta_of = |r: usize| {
            if r <= cap {
                lim * r as f32 / cap as f32
            } else {
                lim + (PI - lim) * (r - cap) as f32 / (RINGS - cap) as f32
            }
        };
        let thetas: Vec<f32> = (0..=RINGS).map(theta_of).collect();
        let c = Vec3::new(0.0, 0.0, self.cornea_offset);
        polar_mesh(&thetas, SEGMENTS, if with_cornea { 0 } else { cap }, |d| {
            let rad = self.radial(d);
            let n = if rad > self.radius + 1e-5 {
                (d * rad - c).normalize()
            } else {
                d
            };
            (d * rad, n)
        })
    }

    /// The iris disc in the iris plane, from the pupil to the limbus, facing +Z, with UVs
    /// scaled into the iris ring of the eye texture; and the pupil as a black disc behind it.
    pub fn iris(&self) -> TriMesh {
        const RINGS: usize = 12;
        const SEGMENTS: usize = 64;
        let z = self.apex() - IRIS_DEPTH;
        // The iris's outer edge meets the globe wall: the scleral sphere's radius at that depth.
        let outer = (self.radius * self.radius - z * z)
            .sqrt()
            .min(LIMBUS_RADIUS);
        let mut m = TriMesh::default();
        for r in 0..=RINGS {
            let rho = r as f32 / RINGS as f32 * outer;
            for s in 0..=SEGMENTS {
                let phi = TAU * s as f32 / SEGMENTS as f32;
                m.positions
                    .push(Vec3::new(rho * phi.cos(), rho * phi.sin(), z));
                m.normals.push(Vec3::Z);
                let uvr = IRIS_UV_RADIUS * rho / outer;
                m.uvs
                    .push(Vec2::splat(0.5) + uvr * Vec2::new(phi.cos(), phi.sin()));
            }
        }
        let row = SEGMENTS as u32 + 1;
        for r in 0..RINGS as u32 {
            for s in 0..SEGMENTS as u32 {
                let (a, b, c, d) = (
                    r * row + s,
                    r * row + s + 1,
                    (r + 1) * row + s,
                    (r + 1) * row + s + 1,
                );
                // Counter-clockwise seen from +Z, the side the iris faces.
                m.triangles.push([a, c, b]);
                m.triangles.push([b, c, d]);
            }
        }
        m
    }
}

/// D(α) tabulated over directions, built by casting rays from the centre against a globe mesh
/// (any star-shaped shell). Directions are charted octahedrally (Praun & Hoppe 2003) rather than
/// by the thesis' polar angles: the same map, sampled without trigonometry per vertex.
#[derive(Clone, Debug)]
pub struct RadialMap {
    /// Texels per side.
    pub size: usize,
    /// Radial distance per texel (mm).
    pub radius: Vec<f32>,
}

/// Octahedral coordinates in [0, 1]² of a unit direction.
#[inline]
pub fn octahedral(d: Vec3) -> Vec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let p = Vec2::new(d.x, d.y) / l1;
    let p = if d.z < 0.0 {
        Vec2::new(
            (1.0 - p.y.abs()) * p.x.signum(),
            (1.0 - p.x.abs()) * p.y.signum(),
        )
    } else {
        p
    };
    p * 0.5 + Vec2::splat(0.5)
}

/// The unit direction of octahedral coordinates.
pub fn from_octahedral(t: Vec2) -> Vec3 {
    let p = t * 2.0 - Vec2::ONE;
    let z = 1.0 - p.x.abs() - p.y.abs();
    let (x, y) = if z < 0.0 {
        (
            (1.0 - p.y.abs()) * p.x.signum(),
            (1.0 - p.x.abs()) * p.y.signum(),
        )
    } else {
        (p.x, p.y)
    };
    Vec3::new(x, y, z).normalize()
}

impl RadialMap {
    /// Casts a ray from the origin through every texel centre against `shell`.
    pub fn from_mesh(shell: &TriMesh, size: usize) -> RadialMap {
        let bvh = Bvh::new(&shell.positions, &shell.triangles);
        let far = shell.extent() * 4.0;
        let radius = (0..size * size)
            .map(|i| {
                let t = Vec2::new((i % size) as f32 + 0.5, (i / size) as f32 + 0.5) / size as f32;
                let d = from_octahedral(t);
                bvh.nearest(Vec3::ZERO, d, 0.0, far).map_or(0.0, |h| h.t)
            })
            .collect();
        RadialMap { size, radius }
    }

    /// D along unit direction `d` (bilinear).
    #[inline]
    pub fn sample(&self, d: Vec3) -> f32 {
        let t = octahedral(d) * self.size as f32 - Vec2::splat(0.5);
        let n = self.size as f32 - 1.0;
        let fx = t.x.clamp(0.0, n - 1e-3);
        let fy = t.y.clamp(0.0, n - 1e-3);
        let (x0, y0) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let i = y0 * self.size + x0;
        let r = &self.radius;
        let top = r[i] + (r[i + 1] - r[i]) * tx;
        let bot = r[i + self.size] + (r[i + self.size + 1] - r[i + self.size]) * tx;
        top + (bot - top) * ty
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_globe_part_and_head_part_is_wound_outward() {
        // The GLB's parts: glTF's front faces are counter-clockwise; a part wound against its
        // normals shows as a dark disc in Cycles and vanishes under back-face culling (the
        // iris was: 1 472 of its 1 536 triangles, the other 64 degenerate at the pupil).
        let g = Globe::of(&Eye {
            centre: Vec3::ZERO,
            radius: 12.0,
        });
        for (name, m) in [
            ("shell with cornea", g.shell(true)),
            ("shell", g.shell(false)),
            ("iris", g.iris()),
        ] {
            assert_eq!(m.inward_triangles(), 0, "{name}");
        }
        let head = derma_head::Head::builtin();
        assert_eq!(head.skin.inward_triangles(), 0, "skin");
        for p in &head.parts {
            assert_eq!(p.mesh.inward_triangles(), 0, "{}", p.name);
        }
    }

    #[test]
    fn the_cornea_bulges_by_its_sagitta_and_meets_the_sclera_at_the_limbus() {
        let g = Globe::of(&Eye {
            centre: Vec3::ZERO,
            radius: 12.0,
        });
        // Limbus at √(12² − 5.85²) = 10.48 mm, sagitta 7.8 − √(7.8² − 5.85²) = 2.64 mm: the apex
        // 13.12 mm from the centre, 1.1 mm proud of the scleral sphere.
        assert!((g.apex() - 13.118).abs() < 0.01, "{}", g.apex());
        assert!((g.radial(Vec3::Z) - g.apex()).abs() < 1e-4);
        assert_eq!(g.radial(Vec3::X), 12.0);
        let l = g.limbus_angle();
        let at = g.radial(Vec3::new(l.sin(), 0.0, l.cos()));
        assert!((at - 12.0).abs() < 0.01, "{at}");
    }

    #[test]
    fn the_radial_map_of_the_shell_matches_the_exact_surface() {
        let g = Globe::of(&Eye {
            centre: Vec3::ZERO,
            radius: 11.765,
        });
        let map = RadialMap::from_mesh(&g.shell(true), 128);
        let mut worst = 0.0f32;
        for i in 0..500 {
            let t = Vec2::new((i as f32 * 0.618_034) % 1.0, (i as f32 * 0.414_213) % 1.0);
            let d = from_octahedral(t);
            worst = worst.max((map.sample(d) - g.radial(d)).abs());
            assert!((octahedral(d) - t).length() < 1e-4);
        }
        // Faceting of the 64-ring shell and bilinear lookup: well under the 0.1 mm skin scale.
        assert!(worst < 0.05, "{worst}");
    }
}
