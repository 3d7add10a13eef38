//! The lacrimal lake (EyeMove thesis §4.5): the tear meniscus along the lid margins as a depth
//! that falls linearly with the distance λ to the skin, normals from its screen-space slope, and
//! the two effects Alexander et al. 2013 name — darkening by absorption along the path through
//! the fluid and a specular highlight. Its one home: the GPU pass (lake.wgsl) reads these
//! constants, and the CPU frame ([`crate::frame`]) runs the steps below over its G-buffer.

use crate::material::{MATERIAL_EYE, MATERIAL_SKIN};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

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

/// Most pixels the distance search reaches on each side (lake.wgsl's and [`distance`]'s): Λ =
/// 1 mm spans fewer at every framing `derma render` makes of a head (≈ 4 px at 1024², ≈ 20 px
/// in a 0.3-zoom close-up).
pub const MAX_SEARCH_PX: u32 = 48;

/// The lake over a frame: per pixel the meniscus depth (0 off the lake) and the fluid
/// surface's normal (world).
pub struct Lake {
    /// Depth per pixel (mm).
    pub depth: Vec<f32>,
    /// Unit normal of the fluid surface per pixel.
    pub normal: Vec<Vec3>,
}

/// The distance buffer lake.wgsl's first pass finds: per globe pixel of `material` (rows of
/// `width`) the distance λ (mm) to the nearest skin pixel, exact within `range` and
/// [`MAX_SEARCH_PX`] (square rings outwards, stopping once a ring lies beyond the best found);
/// infinite elsewhere. `px_per_mm`: pixels per mm at each pixel's depth.
pub fn distance(material: &[u8], width: usize, px_per_mm: &[f32], range: f32) -> Vec<f32> {
    if width == 0 {
        return Vec::new();
    }
    let height = material.len() / width;
    let skin = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && (x as usize) < width
            && (y as usize) < height
            && material[y as usize * width + x as usize] == MATERIAL_SKIN
    };
    (0..material.len())
        .into_par_iter()
        .map(|i| {
            if material[i] != MATERIAL_EYE {
                return f32::INFINITY;
            }
            let (x, y) = ((i % width) as i64, (i / width) as i64);
            let reach = ((range * px_per_mm[i]).ceil() as i64).min(MAX_SEARCH_PX as i64);
            let mut best = i64::MAX;
            for r in 1..=reach {
                if r * r >= best {
                    break;
                }
                for k in -r..=r {
                    let d2 = k * k + r * r;
                    if d2 < best
                        && (skin(x + k, y - r)
                            || skin(x + k, y + r)
                            || skin(x - r, y + k)
                            || skin(x + r, y + k))
                    {
                        best = d2;
                    }
                }
            }
            let lambda = (best as f32).sqrt() / px_per_mm[i];
            if best == i64::MAX || lambda >= range {
                f32::INFINITY
            } else {
                lambda
            }
        })
        .collect()
}

/// Per pixel the slope (∂depth/∂x right, ∂depth/∂y up; mm per mm in the plane Ψ) of the lake's
/// depth `depth` over the globe pixels of `material` (central differences; skin neighbours
/// stand at the full meniscus height, as lake.wgsl's `depth_at`); zero elsewhere and on the
/// image's edge.
pub fn slopes(material: &[u8], width: usize, depth: &[f32], px_per_mm: &[f32]) -> Vec<Vec2> {
    if width == 0 {
        return Vec::new();
    }
    let height = material.len() / width;
    let at = |j: usize| {
        if material[j] == MATERIAL_SKIN {
            MENISCUS_MM
        } else {
            depth[j]
        }
    };
    (0..material.len())
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let inside = x > 0 && y > 0 && x + 1 < width && y + 1 < height;
            if !inside || material[i] != MATERIAL_EYE || depth[i] <= 0.0 {
                return Vec2::ZERO;
            }
            let mm_per_px = 1.0 / px_per_mm[i];
            Vec2::new(
                (at(i + 1) - at(i - 1)) / (2.0 * mm_per_px),
                -(at(i + width) - at(i - width)) / (2.0 * mm_per_px),
            )
        })
        .collect()
}

/// A globe's radiance `c` under a lake of depth `depth` (mm) whose surface reflects `specular`:
/// absorbed along the light's double pass through the fluid, plus the fluid's highlight.
pub fn over(c: Vec3, depth: f32, specular: Vec3) -> Vec3 {
    c * (-ATTENUATION * 2.0 * depth).exp() + specular
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
    fn the_search_finds_the_nearest_skin_within_the_reach() {
        // 9×9 globe with one skin pixel at (2, 3), 10 px per mm, Λ = 0.45 mm = 4.5 px.
        let (w, mut m) = (9, vec![MATERIAL_EYE; 81]);
        m[3 * w + 2] = MATERIAL_SKIN;
        let d = distance(&m, w, &[10.0; 81], 0.45);
        for (i, &l) in d.iter().enumerate() {
            let (dx, dy) = ((i % w) as f32 - 2.0, (i / w) as f32 - 3.0);
            let truth = (dx * dx + dy * dy).sqrt() / 10.0;
            match m[i] {
                MATERIAL_SKIN => assert!(l.is_infinite()),
                _ if truth < 0.45 => assert!((l - truth).abs() < 1e-6, "{i}: {l} vs {truth}"),
                _ => assert!(l.is_infinite(), "{i}: {l} beyond the reach"),
            }
        }
    }

    #[test]
    fn the_slope_rises_towards_the_skin_and_the_fluid_darkens_the_globe() {
        // A 5×3 strip: skin, then eye pixels at λ = 0.2, 0.6, 2 mm and off the lake.
        let m: Vec<u8> = [
            MATERIAL_SKIN,
            MATERIAL_EYE,
            MATERIAL_EYE,
            MATERIAL_EYE,
            MATERIAL_EYE,
        ]
        .repeat(3);
        let lambda = [f32::INFINITY, 0.2, 0.6, 2.0, f32::INFINITY].repeat(3);
        let d: Vec<f32> = lambda.iter().map(|&l| depth(l, RANGE_MM)).collect();
        let s = slopes(&m, 5, &d, &[10.0; 15]);
        assert!(d[6] > d[7] && d[7] > 0.0 && d[8] == 0.0, "{d:?}");
        // Rising towards the skin on the left: a negative x slope, none in y; none on the
        // edge rows or off the lake.
        assert!(s[6].x < -0.1 && s[6].y == 0.0, "{}", s[6]);
        assert_eq!((s[1], s[8]), (Vec2::ZERO, Vec2::ZERO));
        // Absorption: e^(−2 · 1.5 /mm · 0.25 mm) of the globe, plus the highlight.
        let c = over(Vec3::ONE, MENISCUS_MM, Vec3::splat(0.1));
        assert!((c.x - ((-0.75f32).exp() + 0.1)).abs() < 1e-6, "{c}");
        assert_eq!(over(Vec3::ONE, 0.0, Vec3::ZERO), Vec3::ONE);
    }
}
