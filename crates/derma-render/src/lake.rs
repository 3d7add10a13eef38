//! The lacrimal lake (EyeMove thesis §4.5): the tear meniscus along the lid margins as a depth
//! that falls linearly with the distance λ to the skin, normals from its screen-space slope, and
//! the two effects Alexander et al. 2013 name — darkening by absorption along the path through
//! the fluid and a specular highlight. Its one home: the GPU pass (lake.wgsl) reads these
//! constants, and the CPU compositing below draws it over a G-buffer.

use crate::lighting::Lighting;
use crate::material::{MATERIAL_EYE, MATERIAL_OTHER, MATERIAL_SKIN};
use crate::shade::{Env, Surface};
use glam::Vec3;

/// The lake's range Λ (mm): the meniscus and its fade reach about a millimetre from the lid
/// margin.
pub const RANGE_MM: f32 = 1.0;
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

/// A G-buffer the CPU compositing reads: per pixel the material ([`MATERIAL_SKIN`],
/// [`MATERIAL_EYE`]; anything else, [`MATERIAL_OTHER`], is shaded as the background — the eyes'
/// close-up draws only skin and globes), view-space normal and linear albedo, and the pixels per
/// millimetre at the pixel's depth.
pub struct Surfaces<'a> {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// Material per pixel.
    pub material: &'a [u8],
    /// View-space normal per pixel.
    pub normal: &'a [Vec3],
    /// Linear albedo per pixel.
    pub albedo: &'a [Vec3],
    /// Pixels per millimetre at pixel i (f / z).
    pub px_per_mm: &'a (dyn Fn(usize) -> f32 + Sync),
}

/// The lake over `s` from the distances λ (mm, per pixel; infinite off the globes): per pixel
/// its depth and normal (view space).
pub fn lake(s: &Surfaces, distance: &[f32], range: f32) -> (Vec<f32>, Vec<Vec3>) {
    let (w, h) = (s.width, s.height);
    let d: Vec<f32> = distance.iter().map(|&l| depth(l, range)).collect();
    let mut n = s.normal.to_vec();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            if s.material[i] != MATERIAL_EYE || d[i] <= 0.0 {
                continue;
            }
            // ∂depth/∂x and ∂y in mm per mm of Ψ (central differences; skin neighbours count as
            // the full meniscus height).
            let at = |j: usize| {
                if s.material[j] == MATERIAL_SKIN {
                    MENISCUS_MM
                } else {
                    d[j]
                }
            };
            let mm_per_px = 1.0 / (s.px_per_mm)(i);
            let dx = (at(i + 1) - at(i - 1)) / (2.0 * mm_per_px);
            let dy = -(at(i + w) - at(i - w)) / (2.0 * mm_per_px);
            // The fluid surface rises towards the skin: tilt the globe normal by the slope.
            n[i] = (s.normal[i] + Vec3::new(dx, dy, 0.0)).normalize();
        }
    }
    (d, n)
}

/// Roughness and F0 of the skin around the globes in the G-buffer's shading: a skin-like lobe
/// (F0 = 0.35 × 0.08 = 2.8 %, as the previews' flat skin).
const SKIN_LOBE: (f32, f32) = (0.5, 0.028);
/// Roughness of the bare tear film over the globe (authored: a thin, slightly uneven film).
const FILM_ROUGHNESS: f32 = 0.1;

/// Shades `s` (linear RGB, view space) under `lighting` by the one CPU shading
/// ([`crate::shade`]), with or without the lake (`lake`: per pixel its depth and normal, from
/// [`lake`]): absorption along the path through the fluid and its specular reflection.
pub fn shade(s: &Surfaces, lake: Option<(&[f32], &[Vec3])>, lighting: &Lighting) -> Vec<Vec3> {
    let env = Env::new(lighting, |d| d);
    let v = Vec3::Z;
    (0..s.width * s.height)
        .map(|i| {
            let eye = match s.material[i] {
                MATERIAL_OTHER => return Vec3::splat(0.02),
                m => m == MATERIAL_EYE,
            };
            let (roughness, f0) = if eye { (FILM_ROUGHNESS, F0) } else { SKIN_LOBE };
            let n = s.normal[i];
            let surface = Surface {
                n,
                ng: n,
                v,
                albedo: s.albedo[i],
                roughness,
                f0,
                matte_under_film: eye,
            };
            let mut c = env.shade(&surface);
            if let Some((d, ln)) = lake {
                if d[i] > 0.0 {
                    c *= (-ATTENUATION * 2.0 * d[i]).exp();
                    c += env.light(ln[i], ln[i], v, ROUGHNESS, F0).1;
                }
            }
            c
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_meniscus_falls_linearly_to_nothing_at_the_range() {
        assert_eq!(depth(0.0, RANGE_MM), MENISCUS_MM);
        assert!((depth(0.5 * RANGE_MM, RANGE_MM) - 0.5 * MENISCUS_MM).abs() < 1e-7);
        assert_eq!(depth(RANGE_MM, RANGE_MM), 0.0);
        assert_eq!(depth(f32::INFINITY, RANGE_MM), 0.0);
    }

    #[test]
    fn the_lake_darkens_the_globe_only_where_it_lies() {
        // A 5×3 strip: skin, then four eye pixels at λ = 0.2, 0.6, 2 mm and off the lake.
        let material = [
            MATERIAL_SKIN,
            MATERIAL_EYE,
            MATERIAL_EYE,
            MATERIAL_EYE,
            MATERIAL_EYE,
        ];
        let material: Vec<u8> = material.repeat(3);
        let normal = vec![Vec3::Z; 15];
        let albedo = vec![Vec3::splat(0.8); 15];
        let px = |_: usize| 10.0;
        let s = Surfaces {
            width: 5,
            height: 3,
            material: &material,
            normal: &normal,
            albedo: &albedo,
            px_per_mm: &px,
        };
        let lambda = [f32::INFINITY, 0.2, 0.6, 2.0, f32::INFINITY].repeat(3);
        let (d, n) = lake(&s, &lambda, RANGE_MM);
        assert!(d[6] > d[7] && d[7] > 0.0 && d[8] == 0.0, "{d:?}");
        // The fluid's slope tilts the normal in x, not in y, and keeps it a unit vector.
        assert!(n[6].x.abs() > 0.1 && n[6].y == 0.0, "{}", n[6]);
        assert!((n[6].length() - 1.0).abs() < 1e-6);
        let l = crate::cpu::single_light(Vec3::Z, Vec3::splat(3.0));
        let (dry, wet) = (shade(&s, None, &l), shade(&s, Some((&d, &n)), &l));
        assert_eq!(dry[0], wet[0]);
        assert_eq!(dry[8], wet[8]);
        // Head-on, the tilted fluid sends its highlight away: only the absorption remains.
        assert!(wet[6].x < dry[6].x, "{} vs {}", wet[6], dry[6]);
    }
}
