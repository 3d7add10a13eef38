//! Where expression wrinkles deepen and which face units deepen them: soft region masks placed
//! from the landmarks and a weight table from the 52 face units (ARKit names) to the regions.
//!
//! The scheme is Jimenez et al. 2011 ("Practical and realistic facial wrinkles animation", ACM
//! TOG 30(1)): a wrinkle map blended per region by masks, each region weighted by the
//! expression; the eye-region thesis (§3.9) blends wrinkle bump maps by expression weights the
//! same way. The regions follow the wrinkle families `derma skin` paints on a head (forehead
//! lines, glabellar lines, crow's feet, under-eye lines, nasolabial folds), one per side, with
//! the same landmarks; they are wider than the families' start regions because a wrinkle walks
//! up to its length from where it starts. Each region's drivers are the face units of the
//! muscle that folds it (Facial Action Coding System, Ekman & Friesen 1978: frontalis AU1/AU2,
//! corrugator and procerus AU4/AU9, orbicularis oculi AU6/AU7, zygomaticus major AU12, levator
//! labii AU9/AU10); the gains are AUTHORED, not measured.
//!
//! At run time a texel's furrow activation is m = clamp(Σ_r w_r · mask_r, 0, 1) with
//! w_r = clamp(Σ_u gain_{r,u} · unit_u, 0, 1) ([`weights`], [`activation`]).

use crate::regions::{smoothstep, Regions};
use glam::{Vec2, Vec3};

/// One region of expression wrinkles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WrinkleRegion {
    /// Its name (a mask channel's name in `wrinkle_masks.exr`).
    pub name: &'static str,
    /// Face units that deepen it, with their gains.
    pub drivers: &'static [(&'static str, f32)],
}

const fn region(name: &'static str, drivers: &'static [(&'static str, f32)]) -> WrinkleRegion {
    WrinkleRegion { name, drivers }
}

/// Every region, in a fixed order (mask channels, the GLB's and the web export's packing:
/// three regions per RGB image in this order). "left" is the subject's left (+X), as in the
/// face units' names.
pub const REGIONS: [WrinkleRegion; 10] = [
    // Frontalis: the inner brow raiser (AU1) folds the middle of the forehead, the outer brow
    // raiser (AU2) its own side.
    region(
        "forehead_left",
        &[("browInnerUp", 0.7), ("browOuterUpLeft", 0.6)],
    ),
    region(
        "forehead_right",
        &[("browInnerUp", 0.7), ("browOuterUpRight", 0.6)],
    ),
    // Corrugator and procerus: the brow lowerer (AU4) and, more weakly, the nose wrinkler (AU9).
    region(
        "glabella_left",
        &[("browDownLeft", 1.0), ("noseSneerLeft", 0.4)],
    ),
    region(
        "glabella_right",
        &[("browDownRight", 1.0), ("noseSneerRight", 0.4)],
    ),
    // Orbicularis oculi, orbital part: the cheek raiser (AU6, ARKit's cheekSquint) makes the
    // crow's feet, the lid tightener (AU7) and a broad smile add to them.
    region(
        "crows_feet_left",
        &[
            ("cheekSquintLeft", 1.0),
            ("eyeSquintLeft", 0.6),
            ("mouthSmileLeft", 0.4),
        ],
    ),
    region(
        "crows_feet_right",
        &[
            ("cheekSquintRight", 1.0),
            ("eyeSquintRight", 0.6),
            ("mouthSmileRight", 0.4),
        ],
    ),
    // Orbicularis oculi, palpebral part: the lid tightener (AU7), with the cheek raiser pushing
    // the lower lid up.
    region(
        "under_eye_left",
        &[("eyeSquintLeft", 1.0), ("cheekSquintLeft", 0.5)],
    ),
    region(
        "under_eye_right",
        &[("eyeSquintRight", 1.0), ("cheekSquintRight", 0.5)],
    ),
    // Zygomaticus major (AU12) pulls the fold deeper; levator labii (AU9, AU10) lifts it.
    region(
        "nasolabial_left",
        &[
            ("mouthSmileLeft", 0.8),
            ("noseSneerLeft", 0.5),
            ("mouthUpperUpLeft", 0.5),
            ("cheekSquintLeft", 0.3),
        ],
    ),
    region(
        "nasolabial_right",
        &[
            ("mouthSmileRight", 0.8),
            ("noseSneerRight", 0.5),
            ("mouthUpperUpRight", 0.5),
            ("cheekSquintRight", 0.3),
        ],
    ),
];

/// The blend, as the GLB and web exports state it.
pub const FORMULA: &str = "w_r = clamp(sum_u gain_(r,u) * unit_u, 0, 1); m = clamp(sum_r w_r * mask_r, 0, 1); normal = normalize(lerp(2*normal_rest - 1, 2*normal_wrinkled - 1, m)); height = height_rest + m * height_mm_furrow";

/// Number of regions.
pub const COUNT: usize = REGIONS.len();

/// Region weights w_r = clamp(Σ_u gain_{r,u} · unit_u, 0, 1) from face-unit weights (units
/// not named in the table drive nothing).
pub fn weights<'a>(units: impl IntoIterator<Item = (&'a str, f32)> + Clone) -> [f32; COUNT] {
    REGIONS.map(|r| {
        let s: f32 = units
            .clone()
            .into_iter()
            .map(|(n, w)| {
                r.drivers
                    .iter()
                    .filter(|(d, _)| *d == n)
                    .map(|(_, g)| g * w)
                    .sum::<f32>()
            })
            .sum();
        s.clamp(0.0, 1.0)
    })
}

/// A texel's furrow activation m = clamp(Σ_r w_r · mask_r, 0, 1).
#[inline]
pub fn activation(masks: &[f32; COUNT], weights: &[f32; COUNT]) -> f32 {
    masks
        .iter()
        .zip(weights)
        .map(|(m, w)| m * w)
        .sum::<f32>()
        .clamp(0.0, 1.0)
}

/// Distance from `p` to segment `ab`.
fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (p - (a + t * ab)).length()
}

/// The region masks at point `p` (mm) of a head with regions `r`, in [`REGIONS`] order; each in
/// [0, 1], and where they overlap scaled so they sum to at most 1.
pub fn masks(r: &Regions, p: Vec3) -> [f32; COUNT] {
    let front = smoothstep(0.2, 0.5, r.azimuth_cos(p));
    if front <= 0.0 {
        return [0.0; COUNT];
    }
    let this = r.side(p.x);
    let s = if p.x >= 0.0 { 1.0 } else { -1.0 };
    let (eye, co, mc) = (this.eye, this.canthus_outer, this.mouth_corner);
    // The share of the subject's left, blended over the midline (forehead and glabella cross it).
    let left = smoothstep(-8.0, 8.0, p.x);
    // Forehead: above the brows, past the hairline landmark (the top lines reach it) and across
    // to the temples.
    let hairline = r.hairline().y;
    let forehead = smoothstep(eye.y + 18.0, eye.y + 26.0, p.y)
        * smoothstep(hairline + 20.0, hairline + 10.0, p.y)
        * smoothstep(70.0, 55.0, p.x.abs());
    // Glabella: between the brows, from the nasion up into the lower forehead.
    let glabella = smoothstep(14.0, 9.0, p.x.abs())
        * smoothstep(eye.y + 3.0, eye.y + 9.0, p.y)
        * smoothstep(eye.y + 40.0, eye.y + 32.0, p.y);
    // Crow's feet: lateral of the outer canthus.
    let dc = Vec2::new(p.x - co.x, p.y - co.y);
    let crows = smoothstep(28.0, 20.0, dc.length()) * smoothstep(-3.0, 3.0, dc.x * s);
    // Under the eye: across the lower lid and the top of the cheek.
    let under = smoothstep(eye.y - 22.0, eye.y - 17.0, p.y)
        * smoothstep(eye.y - 4.0, eye.y - 8.0, p.y)
        * smoothstep(22.0, 15.0, (p.x - eye.x).abs());
    // Nasolabial fold: the segment the fold is painted along, lengthened 8 mm at both ends.
    let sn = r.subnasale();
    let a = Vec2::new(s * 20.0, sn.y + 6.0);
    let b = Vec2::new(mc.x + s * 8.0, mc.y - 10.0);
    let along = (b - a).normalize();
    let d = segment_distance(Vec2::new(p.x, p.y), a - 8.0 * along, b + 8.0 * along);
    let naso = smoothstep(11.0, 7.0, d);
    let (l, rt) = if s > 0.0 { (1.0, 0.0) } else { (0.0, 1.0) };
    let mut m = [
        forehead * left,
        forehead * (1.0 - left),
        glabella * left,
        glabella * (1.0 - left),
        crows * l,
        crows * rt,
        under * l,
        under * rt,
        naso * l,
        naso * rt,
    ];
    let sum: f32 = m.iter().sum();
    let k = front / sum.max(1.0);
    m.iter_mut().for_each(|v| *v *= k);
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Head;

    #[test]
    fn every_driver_is_one_of_the_heads_face_units() {
        let head = Head::builtin();
        for r in &REGIONS {
            for (u, g) in r.drivers {
                assert!(
                    head.face_units().iter().any(|t| t.name == *u),
                    "{}: {u}",
                    r.name
                );
                assert!(*g > 0.0 && *g <= 1.0);
            }
        }
    }

    #[test]
    fn weights_sum_the_drivers_and_clamp() {
        let w = weights([("browInnerUp", 1.0)]);
        assert_eq!(w[0], 0.7);
        assert_eq!(w[1], 0.7);
        assert!(w[2..].iter().all(|v| *v == 0.0));
        let w = weights([("browInnerUp", 1.0), ("browOuterUpLeft", 1.0)]);
        assert_eq!(w[0], 1.0, "0.7 + 0.6 clamps at 1");
        assert_eq!(w[1], 0.7);
        // A smile drives its side's crow's feet and nasolabial fold only.
        let w = weights([("mouthSmileLeft", 1.0)]);
        assert_eq!((w[4], w[5], w[8], w[9]), (0.4, 0.0, 0.8, 0.0));
        assert_eq!(weights([("jawOpen", 1.0)]), [0.0; COUNT]);
    }

    #[test]
    fn masks_sit_where_the_families_are_and_sum_to_one_at_most() {
        let head = Head::builtin();
        let r = &head.regions;
        let at = |i: usize| {
            // The skin vertex with the largest mask i, and its value.
            head.skin
                .positions
                .iter()
                .map(|p| (*p, masks(r, *p)))
                .max_by(|a, b| a.1[i].total_cmp(&b.1[i]))
                .unwrap()
        };
        let eye_l = r.side(1.0).eye;
        for (i, reg) in REGIONS.iter().enumerate() {
            let (p, m) = at(i);
            assert!(m[i] > 0.9, "{}: peak {}", reg.name, m[i]);
            // Left regions on the subject's left (+X), right ones on the right.
            if reg.name.ends_with("_left") && !reg.name.starts_with("forehead") {
                assert!(p.x > 0.0, "{} at {p}", reg.name);
            }
            if reg.name.ends_with("_right") && !reg.name.starts_with("forehead") {
                assert!(p.x < 0.0, "{} at {p}", reg.name);
            }
            match reg.name.split('_').next().unwrap() {
                "forehead" => assert!(p.y > eye_l.y + 20.0, "{p}"),
                "under" => assert!(p.y < eye_l.y - 3.0, "{p}"),
                "nasolabial" => assert!(p.y < eye_l.y - 25.0, "{p}"),
                _ => {}
            }
        }
        for p in &head.skin.positions {
            let m = masks(r, *p);
            assert!(m.iter().all(|v| (0.0..=1.0).contains(v)));
            assert!(m.iter().sum::<f32>() <= 1.0 + 1e-5);
        }
        // The back of the head and the neck take none.
        let back = Vec3::new(0.0, eye_l.y, r.landmarks().get("ear_left").z - 60.0);
        assert_eq!(masks(r, back), [0.0; COUNT]);
    }

    #[test]
    fn activation_is_the_masked_sum_clamped() {
        let mut m = [0.0; COUNT];
        m[0] = 0.5;
        m[2] = 0.5;
        let w = weights([("browInnerUp", 1.0), ("browDownLeft", 1.0)]);
        assert!((activation(&m, &w) - (0.5 * 0.7 + 0.5)).abs() < 1e-6);
        assert_eq!(activation(&[1.0; COUNT], &[1.0; COUNT]), 1.0);
    }
}
