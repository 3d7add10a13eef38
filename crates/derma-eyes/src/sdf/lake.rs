//! The lacrimal lake (thesis §4.5): the tear meniscus along the lid margins as a depth that falls
//! linearly with the distance field, normals from its screen-space derivatives, and the two
//! effects Alexander et al. 2013 name — darkening by absorption along the path through the fluid
//! and a specular highlight — composited onto a rendered eye.

use super::scene::Scene;
use super::{material, Field};
use glam::Vec3;

/// Meniscus height at the lid margin (mm): ≈ 0.25 mm, inside the 0.2–0.5 mm range of lower tear
/// meniscus heights reviewed by Johnson & Murphy 2004 (Prog Retin Eye Res 23:449).
pub const MENISCUS_MM: f32 = 0.25;
/// Effective attenuation (1/mm) of the light's double pass through the fluid (authored for
/// appearance: the thesis gives no value; 1.5 /mm darkens the full meniscus by ~30 %).
pub const ATTENUATION: f32 = 1.5;
/// Water's normal-incidence reflectance, n = 1.333: ((n − 1)/(n + 1))² ≈ 0.020.
pub const F0: f32 = 0.020;
/// GGX roughness of the fluid surface (authored: a liquid film, near mirror-like).
pub const ROUGHNESS: f32 = 0.06;

/// Lake depth (mm) at distance `lambda` from the skin for a lake of width `range` (§4.5: first
/// order in the distance).
pub fn depth(lambda: f32, range: f32) -> f32 {
    if lambda.is_finite() && lambda < range {
        MENISCUS_MM * (1.0 - lambda / range)
    } else {
        0.0
    }
}

/// The lake over a scene: per pixel its depth and normal (view space).
pub fn lake(scene: &Scene, f: &Field, range: f32) -> (Vec<f32>, Vec<Vec3>) {
    let g = &scene.g;
    let (w, h) = (g.width, g.height);
    let d: Vec<f32> = f.distance.iter().map(|&l| depth(l, range)).collect();
    let mut n = scene.normal.clone();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            if g.mask[i] != material::EYE || d[i] <= 0.0 {
                continue;
            }
            // ∂depth/∂x and ∂y in mm per mm of Ψ (central differences; skin neighbours count as
            // the full meniscus height).
            let at = |j: usize| {
                if g.mask[j] == material::SKIN {
                    MENISCUS_MM
                } else {
                    d[j]
                }
            };
            let mm_per_px = 1.0 / g.px_per_mm(i);
            let dx = (at(i + 1) - at(i - 1)) / (2.0 * mm_per_px);
            let dy = -(at(i + w) - at(i - w)) / (2.0 * mm_per_px);
            // The fluid surface rises towards the skin: tilt the globe normal by the slope.
            n[i] = (scene.normal[i] + Vec3::new(dx, dy, 0.0)).normalize();
        }
    }
    (d, n)
}

/// Shades the scene (linear RGB) under one directional light `l` (view space, towards the
/// light) with an ambient term, with or without the lake.
pub fn shade(scene: &Scene, lake: Option<(&[f32], &[Vec3])>, l: Vec3, radiance: f32) -> Vec<Vec3> {
    let g = &scene.g;
    let l = l.normalize();
    let v = Vec3::Z;
    let hv = (l + v).normalize();
    (0..g.width * g.height)
        .map(|i| {
            if g.mask[i] == material::NONE {
                return Vec3::splat(0.02);
            }
            let n = scene.normal[i];
            let mut c = scene.albedo[i] * (0.15 + radiance * n.dot(l).max(0.0));
            if g.mask[i] == material::EYE {
                // The bare tear film: a faint highlight everywhere on the globe.
                c += Vec3::splat(ggx_spec(n, l, v, hv, 0.1) * radiance);
            }
            if let Some((d, ln)) = lake {
                if d[i] > 0.0 {
                    c *= (-ATTENUATION * 2.0 * d[i]).exp();
                    c += Vec3::splat(ggx_spec(ln[i], l, v, hv, ROUGHNESS) * radiance);
                }
            }
            c
        })
        .collect()
}

/// GGX specular (Walter et al. 2007) with Schlick Fresnel and Smith's uncorrelated masking.
fn ggx_spec(n: Vec3, l: Vec3, v: Vec3, h: Vec3, rough: f32) -> f32 {
    let a2 = (rough * rough).powi(2);
    let nh = n.dot(h).max(0.0);
    let nl = n.dot(l).max(1e-4);
    let nv = n.dot(v).max(1e-4);
    let d = a2 / (std::f32::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let g1 = |x: f32| 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
    let f = F0 + (1.0 - F0) * (1.0 - v.dot(h).max(0.0)).powi(5);
    d * g1(nl) * g1(nv) * f / (4.0 * nv) // × n·l / (n·l) cancels
}
