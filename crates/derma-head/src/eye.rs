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

/// Pupil diameters a `--pupil` may ask for (mm): about 2 in bright light to 8 dark-adapted in
/// young adults (Watson & Yellott 2012, "A unified formula for light-adapted pupil size", J Vis
/// 12(10):12), with room either side.
pub const PUPIL_RANGE_MM: (f32, f32) = (1.5, 9.0);

/// The UV radius of a pupil `diameter_mm` across on a globe of `radius_mm`: its edge at
/// asin(d/2 / r) from the optical axis, which [`uv_of`] maps to 0.5 θ/π.
pub fn pupil_uv_radius(diameter_mm: f32, radius_mm: f32) -> f32 {
    0.5 * (0.5 * diameter_mm / radius_mm).clamp(0.0, 1.0).asin() / PI
}

/// Where the texture is read for a point at UV radius `r` from the iris centre when the pupil
/// is drawn at UV radius `pupil` (the texture's own is [`PUPIL_UV_RADIUS`]): pupil dilation
/// through texture coordinates (Tarini et al., the iris model's §4.1) — the pupil scaled to its
/// new edge and the iris annulus stretched between that edge and the limbus, which stays.
pub fn dilated_radius(r: f32, pupil: f32) -> f32 {
    if r >= IRIS_UV_RADIUS {
        r
    } else if r < pupil {
        r / pupil * PUPIL_UV_RADIUS
    } else {
        PUPIL_UV_RADIUS
            + (r - pupil) / (IRIS_UV_RADIUS - pupil) * (IRIS_UV_RADIUS - PUPIL_UV_RADIUS)
    }
}

/// The inverse of [`dilated_radius`]: the UV radius at which the texture's radius `r_tex` is
/// drawn (what a morph of the globe's vertices needs: each vertex keeps its UV and moves).
pub fn undilated_radius(r_tex: f32, pupil: f32) -> f32 {
    if r_tex >= IRIS_UV_RADIUS {
        r_tex
    } else if r_tex < PUPIL_UV_RADIUS {
        r_tex / PUPIL_UV_RADIUS * pupil
    } else {
        pupil
            + (r_tex - PUPIL_UV_RADIUS) / (IRIS_UV_RADIUS - PUPIL_UV_RADIUS)
                * (IRIS_UV_RADIUS - pupil)
    }
}

/// The texture coordinate to sample at the globe's `uv` for a pupil of UV radius `pupil`
/// ([`dilated_radius`] along the ray from the iris centre).
pub fn dilated_uv(uv: Vec2, pupil: f32) -> Vec2 {
    let d = uv - Vec2::splat(0.5);
    let r = d.length();
    if r == 0.0 {
        return uv;
    }
    Vec2::splat(0.5) + d * (dilated_radius(r, pupil) / r)
}

/// Pupil diameters of the globes' morph targets (mm): dilated in the dark and constricted in
/// bright light (Watson & Yellott 2012's range for young adults), against the texture's 4 mm.
pub const PUPIL_MORPHS_MM: [(&str, f32); 2] = [("pupilDilate", 8.0), ("pupilConstrict", 2.0)];

/// The vertex offsets that draw a globe's pupil `diameter_mm` across with its texture's
/// coordinates unchanged: each vertex inside the iris slides along the sphere about `centre` to
/// the [`undilated_radius`] of its own UV radius (a glTF morph target; a texture transform
/// cannot bend the radial map). The optical axis is the direction of the vertex at the UV
/// centre; vertices outside the iris stay. Exact at the vertices, linear between them.
pub fn pupil_offsets(mesh: &TriMesh, centre: Vec3, diameter_mm: f32) -> Vec<(u32, Vec3)> {
    let pole = mesh
        .uvs
        .iter()
        .position(|uv| (*uv - Vec2::splat(0.5)).length() < 1e-6);
    let Some(pole) = pole else {
        return Vec::new();
    };
    let axis = (mesh.positions[pole] - centre).normalize_or(Vec3::Z);
    let radius = (mesh.positions[pole] - centre).length();
    let pupil = pupil_uv_radius(diameter_mm, radius);
    let mut out = Vec::new();
    for (i, (p, uv)) in mesh.positions.iter().zip(&mesh.uvs).enumerate() {
        let r = (*uv - Vec2::splat(0.5)).length();
        if r <= 0.0 || r >= IRIS_UV_RADIUS {
            continue;
        }
        let d = *p - centre;
        let turn = axis.cross(d).normalize_or_zero();
        // θ = 2π r (uv_of's map), so the UV radius change is an angle change of 2π Δr.
        let dtheta = TAU * (undilated_radius(r, pupil) - r);
        let moved = glam::Quat::from_axis_angle(turn, dtheta) * d;
        if turn != Vec3::ZERO {
            out.push((i as u32, moved - d));
        }
    }
    out
}

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
    fn the_pupil_morph_puts_the_textures_pupil_edge_at_the_new_diameter() {
        let e = Eye {
            centre: Vec3::new(30.0, 0.0, 60.0),
            radius: 12.0,
        };
        let m = e.mesh();
        let offs = pupil_offsets(&m, e.centre, 8.0);
        assert!(!offs.is_empty());
        for (i, o) in &offs {
            let (p, uv) = (m.positions[*i as usize], m.uvs[*i as usize]);
            let q = p + *o;
            // Still on the globe, and at the angle from the axis where its texel is drawn.
            assert!(((q - e.centre).length() - 12.0).abs() < 1e-3);
            let theta = ((q - e.centre).normalize().dot(Vec3::Z))
                .clamp(-1.0, 1.0)
                .acos();
            let want = TAU
                * undilated_radius((uv - Vec2::splat(0.5)).length(), pupil_uv_radius(8.0, 12.0));
            assert!((theta - want).abs() < 1e-3, "{theta} vs {want}");
        }
        // The texture's pupil edge is drawn 4 mm from the axis (8 mm across).
        let r_new = undilated_radius(PUPIL_UV_RADIUS, pupil_uv_radius(8.0, 12.0));
        assert!((12.0 * (TAU * r_new).sin() - 4.0).abs() < 1e-3);
    }

    #[test]
    fn dilation_keeps_the_limbus_moves_the_pupil_edge_and_inverts() {
        let pupil = pupil_uv_radius(7.0, 12.0);
        // A 7 mm pupil on a 12 mm globe: 17.0° from the axis.
        assert!(
            (pupil - 0.5 * 17.0f32.to_radians() / PI).abs() < 2e-4,
            "{pupil}"
        );
        // The texture's own 4 mm pupil is the identity.
        let own = pupil_uv_radius(4.0, 12.0);
        assert!((own - PUPIL_UV_RADIUS).abs() < 2e-4);
        let limbus = Vec2::new(0.5 + IRIS_UV_RADIUS, 0.5);
        assert!((dilated_uv(limbus, pupil) - limbus).length() < 1e-6);
        let edge = Vec2::new(0.5, 0.5 + pupil);
        assert!((dilated_uv(edge, pupil).y - (0.5 + PUPIL_UV_RADIUS)).abs() < 1e-6);
        for k in 0..=100 {
            let r = IRIS_UV_RADIUS * 1.2 * k as f32 / 100.0;
            let back = undilated_radius(dilated_radius(r, pupil), pupil);
            assert!((back - r).abs() < 1e-6, "{r} → {back}");
            // Monotone: the iris is stretched, never folded.
            assert!(dilated_radius(r + 1e-4, pupil) > dilated_radius(r, pupil));
        }
    }

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
