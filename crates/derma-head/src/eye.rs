//! The eye globes: spheres at the centres and radii of head.json, meshed with their own UVs —
//! an azimuthal equidistant map around the optical axis (+Z), so the iris and pupil sit at the
//! centre of the texture and the sclera around them, as iris textures are usually authored.

use derma_core::mesh::TriMesh;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Rings from the front pole to the back pole, and segments around the axis.
const RINGS: usize = 48;
const SEGMENTS: usize = 64;

/// One eye: centre and radius (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eye {
    /// Centre of the globe (mm, head coordinates).
    pub centre: Vec3,
    /// Radius of the globe (mm). The neutral gaze, the optical axis of the UVs, is +Z.
    pub radius: f32,
}

/// UV of a point on the unit sphere at angle `theta` from the optical axis and azimuth `phi`.
pub fn uv_of(theta: f32, phi: f32) -> Vec2 {
    Vec2::splat(0.5) + 0.5 * (theta / PI) * Vec2::new(phi.cos(), phi.sin())
}

impl Eye {
    /// The globe as a triangle mesh with normals and its own UVs.
    pub fn mesh(&self) -> TriMesh {
        let thetas: Vec<f32> = (0..=RINGS).map(|r| PI * r as f32 / RINGS as f32).collect();
        polar_mesh(&thetas, SEGMENTS, 0, |d| (self.centre + self.radius * d, d))
    }
}

/// A closed globe-like mesh with the eye UVs ([`uv_of`]): rings at polar angles `thetas` from
/// the optical axis (+Z; the first 0, the last π), `segments` around; `surface` gives the
/// position and normal for each unit direction. Rings before `first` get no triangles (an open
/// cap). Triangles are counter-clockwise seen from outside.
pub fn polar_mesh(
    thetas: &[f32],
    segments: usize,
    first: usize,
    surface: impl Fn(Vec3) -> (Vec3, Vec3),
) -> TriMesh {
    let mut m = TriMesh::default();
    for &theta in thetas {
        for s in 0..=segments {
            let phi = TAU * s as f32 / segments as f32;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let (p, n) = surface(d);
            m.positions.push(p);
            m.normals.push(n);
            m.uvs.push(uv_of(theta, phi));
        }
    }
    let rings = thetas.len() as u32 - 1;
    let row = segments as u32 + 1;
    for r in first as u32..rings {
        for s in 0..segments as u32 {
            let (a, b, c, d) = (
                r * row + s,
                r * row + s + 1,
                (r + 1) * row + s,
                (r + 1) * row + s + 1,
            );
            if r > 0 {
                m.triangles.push([a, c, b]);
            }
            if r + 1 < rings {
                m.triangles.push([b, c, d]);
            }
        }
    }
    m
}

/// Iris radius in UV: the visible iris is ~11.7 mm across (horizontal visible iris diameter,
/// Rüfer et al. 2005, Cornea 24:259), asin(5.85 / 12) ≈ 29° from the axis on a 12 mm globe, and
/// [`uv_of`] maps θ to a UV radius of 0.5 θ / π.
pub const IRIS_UV_RADIUS: f32 = 0.5 * 29.0 / 180.0;
/// Pupil radius (UV): a 4 mm pupil in indoor light, asin(2 / 12) ≈ 9.6°.
pub const PUPIL_UV_RADIUS: f32 = 0.5 * 9.6 / 180.0;

/// The default eye albedo (linear) at a UV of the globe: a dark pupil, a brown iris with radial
/// striations and a darker limbal ring, and an off-white sclera.
pub fn default_albedo(uv: Vec2) -> Vec3 {
    let d = uv - Vec2::splat(0.5);
    let r = d.length();
    if r < PUPIL_UV_RADIUS {
        return Vec3::splat(0.01);
    }
    if r < IRIS_UV_RADIUS {
        let t = (r - PUPIL_UV_RADIUS) / (IRIS_UV_RADIUS - PUPIL_UV_RADIUS);
        let stria = 0.85 + 0.15 * (d.y.atan2(d.x) * 37.0).sin();
        let limbus = 1.0 - 0.6 * ((t - 0.85) / 0.15).clamp(0.0, 1.0);
        return Vec3::new(0.16, 0.075, 0.03) * stria * limbus * (0.8 + 0.4 * t);
    }
    Vec3::new(0.72, 0.68, 0.63)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globe_is_a_closed_sphere_facing_out_with_the_iris_at_the_uv_centre() {
        let e = Eye {
            centre: Vec3::new(30.0, 0.0, 60.0),
            radius: 12.0,
        };
        let m = e.mesh();
        let area = m.area();
        let want = 4.0 * PI as f64 * 144.0;
        assert!((area - want).abs() < 0.01 * want, "{area} vs {want}");
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0 - e.centre) > 0.0, "inward triangle");
        }
        // The front pole maps to the UV centre.
        assert_eq!(m.uvs[0], Vec2::splat(0.5));
        assert!((m.positions[0] - Vec3::new(30.0, 0.0, 72.0)).length() < 1e-4);
    }
}
