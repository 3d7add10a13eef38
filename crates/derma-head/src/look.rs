//! How the head's parts look: the authored materials of the eyes, teeth, tongue and lashes
//! (albedo over each part's UVs, roughness, F0, lash coverage) that every renderer and exporter
//! draws them with — data, not drawing (derma-render draws them).

use crate::{eye, lashes};
use glam::{Vec2, Vec3};

/// A part's material: linear albedo over its UVs, perceptual GGX roughness, normal-incidence
/// Fresnel reflectance, and for cards (eyelashes) a coverage in [0, 1] over its UVs.
#[derive(Clone, Copy)]
pub struct Look {
    /// Linear albedo at a texture coordinate.
    pub albedo: &'static (dyn Fn(Vec2) -> Vec3 + Sync),
    /// Perceptual roughness.
    pub roughness: f32,
    /// F0.
    pub f0: f32,
    /// Coverage at a texture coordinate (`None`: opaque).
    pub coverage: Option<&'static (dyn Fn(Vec2) -> f32 + Sync)>,
}

impl Look {
    /// The material of the part called `name`: the eyes with [`eye::default_albedo`] under a
    /// glossy tear film, ivory teeth, a pink tongue and near-black hair (lashes, brow cards: the
    /// roughness and F0 of hair; their colour comes from a texture set) thinning to their tips
    /// ([`lashes::coverage`]: single tapering lashes).
    pub fn of(name: &str) -> Look {
        // Linear albedos: enamel ivory, tongue mucosa pink, lashes near black (authored).
        static TEETH: fn(Vec2) -> Vec3 = |_| Vec3::new(0.62, 0.56, 0.45);
        static TONGUE: fn(Vec2) -> Vec3 = |_| Vec3::new(0.42, 0.12, 0.11);
        static LASHES: fn(Vec2) -> Vec3 = |_| Vec3::new(0.02, 0.015, 0.012);
        static EYE: fn(Vec2) -> Vec3 = eye::default_albedo;
        static LASH_COVERAGE: fn(Vec2) -> f32 = lashes::coverage;
        type Albedo = &'static (dyn Fn(Vec2) -> Vec3 + Sync);
        let (albedo, roughness, f0): (Albedo, f32, f32) = if name.starts_with("eye_") {
            // The cornea's tear film: glossy; F0 of n ≈ 1.376 (cornea) ≈ 0.025.
            (&EYE, 0.08, 0.025)
        } else if name.starts_with("teeth") {
            (&TEETH, 0.3, 0.04)
        } else if name == "tongue" {
            (&TONGUE, 0.35, 0.03)
        } else {
            (&LASHES, 0.6, 0.04)
        };
        let coverage: Option<&'static (dyn Fn(Vec2) -> f32 + Sync)> =
            name.starts_with("eyelashes").then_some(&LASH_COVERAGE);
        Look {
            albedo,
            roughness,
            f0,
            coverage,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_part_has_a_look_and_only_lashes_are_cards() {
        let head = crate::Head::builtin();
        for p in &head.parts {
            let l = Look::of(&p.name);
            assert_eq!(
                l.coverage.is_some(),
                p.name.starts_with("eyelashes"),
                "{}",
                p.name
            );
            assert!((0.0..=1.0).contains(&l.roughness) && (0.0..0.1).contains(&l.f0));
            let a = (l.albedo)(Vec2::splat(0.5));
            assert!(
                a.min_element() >= 0.0 && a.max_element() <= 1.0,
                "{}: {a}",
                p.name
            );
        }
    }
}
