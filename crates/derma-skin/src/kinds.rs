//! The table of feature kinds (thesis §4.8.5, §5.3): one entry per kind, in painting order —
//! its name in reports and features.json, its random stream, and how it is scattered. Placing,
//! painting, counts, features.json and summaries all follow the table, so a new kind is a
//! module in `features/`, a config section and one entry here.
//!
//! Painting order (thesis §4.8.5): the baseline and the lips first (`paint.rs`), then features
//! that add melanin or height, then wrinkles and pores that carve the surface, and follicles
//! last because they reduce the blood the others have set and cover everything with hair colour;
//! the strands grown from them (brows, stubble) lie on top of all.

use crate::config::FollicleConfig;
use crate::features::cyst::Cyst;
use crate::features::follicle::{Follicle, FollicleParams};
use crate::features::freckle::Freckle;
use crate::features::mole::Mole;
use crate::features::pore::{Pore, PoreParams};
use crate::features::strand::{Strand, StrandParams};
use crate::features::wrinkle::Wrinkle;
use crate::placement::{walk_strand, walk_wrinkle, PlacedKind, Placing, Scattered, Spec};
use crate::{Result, SkinError};
use derma_core::rng::Philox;

/// One kind of feature.
pub struct KindEntry {
    /// Its key in report counts and features.json ("cyst").
    pub name: &'static str,
    /// Plural noun for summaries ("cysts").
    pub label: &'static str,
    /// Philox stream of its draws (stable: changing it changes the kind's features).
    pub stream: u32,
    /// Scatters the kind and indexes it.
    pub place: fn(&Placing) -> Result<Box<dyn PlacedKind>>,
}

impl std::fmt::Debug for KindEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name)
    }
}

impl PartialEq for KindEntry {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// Every kind, in painting order.
pub const KINDS: [KindEntry; 9] = [
    KindEntry {
        name: "cyst",
        label: "cysts",
        stream: 1,
        place: place_cysts,
    },
    KindEntry {
        name: "mole",
        label: "moles",
        stream: 2,
        place: place_moles,
    },
    KindEntry {
        name: "freckle",
        label: "freckles",
        stream: 3,
        place: place_freckles,
    },
    KindEntry {
        name: "wrinkle",
        label: "wrinkles",
        stream: 4,
        place: place_wrinkles,
    },
    KindEntry {
        name: "pore",
        label: "pores",
        stream: 5,
        place: place_pores,
    },
    KindEntry {
        name: "follicle",
        label: "follicles",
        stream: 6,
        place: place_follicles,
    },
    KindEntry {
        name: "eyebrow",
        label: "eyebrow follicles",
        stream: 7,
        place: place_eyebrows,
    },
    KindEntry {
        name: "brow_hair",
        label: "eyebrow strands",
        stream: 8,
        place: place_brow_hairs,
    },
    KindEntry {
        name: "stubble",
        label: "stubble hairs",
        stream: 9,
        place: place_stubble,
    },
];

/// The entry of kind `name`.
pub fn entry(name: &str) -> Option<&'static KindEntry> {
    KINDS.iter().find(|e| e.name == name)
}

fn stream(name: &str) -> u32 {
    entry(name).expect("a kind of the table").stream
}

fn place_cysts(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let c = &ctx.cfg.cyst;
    let spec = Spec::new(&c.field, c.density_per_cm2, c.enabled, stream("cyst"));
    let items = ctx.scatter(spec, |r, k, p| {
        Some(Cyst::new(
            p.position,
            c,
            r.normal2(k, 1)[0],
            r.uniform4(k, 2)[0],
            ctx.pitch(&p),
        ))
    })?;
    Ok(Box::new(Scattered::with_auto_cell(
        items,
        ctx.period(),
        8.0,
        (),
    )))
}

fn place_moles(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let m = &ctx.cfg.mole;
    let spec = Spec::new(&m.field, m.density_per_cm2, m.enabled, stream("mole"));
    let items = ctx.scatter(spec, |r, k, p| {
        let (z, u, v) = (r.normal2(k, 1)[0], r.uniform4(k, 2), r.uniform4(k, 3));
        let px = ctx.pitch(&p);
        Some(Mole::new(p.position, p.frame.t, p.frame.b, m, z, u, v, px))
    })?;
    Ok(Box::new(Scattered::with_auto_cell(
        items,
        ctx.period(),
        8.0,
        (),
    )))
}

fn place_freckles(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let f = &ctx.cfg.freckle;
    let spec = Spec {
        power: f.power,
        ..Spec::new(&f.field, f.density_per_cm2, f.enabled, stream("freckle"))
    };
    let items = ctx.scatter(spec, |r, k, p| {
        let (z, u, v) = (r.normal2(k, 1)[0], r.uniform4(k, 2), r.uniform4(k, 3));
        let px = ctx.pitch(&p);
        Some(Freckle::new(
            p.position, p.frame.t, p.frame.b, f, z, u, v, px,
        ))
    })?;
    Ok(Box::new(Scattered::with_auto_cell(
        items,
        ctx.period(),
        8.0,
        (),
    )))
}

fn place_wrinkles(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let w = &ctx.cfg.wrinkle;
    if w.enabled && w.density_per_cm2 > 0.0 && !ctx.fields.vectors.contains_key(&w.vector_field) {
        return Err(SkinError::Field {
            name: w.vector_field.clone(),
            detail: "wrinkles need this vector field (RGB: R,G direction, B length)".into(),
        });
    }
    let spec = Spec::new(&w.field, w.density_per_cm2, w.enabled, stream("wrinkle"));
    let items = ctx.scatter(spec, |r, k, p| {
        let u = r.uniform4(k, 1);
        let px = ctx.pitch(&p);
        let curve = walk_wrinkle(ctx.surface, ctx.fields, &w.vector_field, w.max_length_mm, p)?;
        let width = w.width_mm.min + (w.width_mm.max - w.width_mm.min) * u[0];
        let depth = w.depth_mm.min + (w.depth_mm.max - w.depth_mm.min) * u[1];
        Some(Wrinkle::new(curve, width, depth, px))
    })?;
    Ok(Box::new(Scattered::new(items, ctx.period(), 4.0, ())))
}

fn place_pores(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let pc = &ctx.cfg.pore;
    let spec = Spec::new(&pc.field, pc.density_per_cm2, pc.enabled, stream("pore"));
    let items = ctx.scatter(spec, |r, k, p| {
        Some(Pore::new(p.position, pc, r.normal2(k, 1)[0], ctx.pitch(&p)))
    })?;
    let params = PoreParams {
        depth_mm: pc.depth_mm,
        melanin_add: pc.melanin_add,
    };
    Ok(Box::new(Scattered::with_auto_cell(
        items,
        ctx.period(),
        4.0,
        params,
    )))
}

/// Follicles of scalp or eyebrow hair: features.json lists their centres only (170 000 of them).
fn place_hair(ctx: &Placing, fc: &FollicleConfig, name: &str) -> Result<Box<dyn PlacedKind>> {
    let spec = Spec::new(&fc.field, fc.density_per_cm2, fc.enabled, stream(name));
    let items = ctx.scatter(spec, |_, _, p| {
        Some(Follicle::new(p.position, fc, ctx.pitch(&p)))
    })?;
    let params = FollicleParams {
        hair_color: ctx.cfg.hair.melanin(&ctx.cfg.person).color(),
        height_mm: fc.height_mm,
        blood_reduction: fc.blood_reduction,
        gland_radius_mm: fc.gland_radius_mm,
    };
    Ok(Box::new(
        Scattered::with_auto_cell(items, ctx.period(), 4.0, params).listed_as(|items| {
            serde_json::to_value(items.iter().map(|f| f.center).collect::<Vec<_>>())
                .unwrap_or_default()
        }),
    ))
}

fn place_follicles(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    place_hair(ctx, &ctx.cfg.follicle, "follicle")
}

fn place_eyebrows(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    place_hair(ctx, &ctx.cfg.eyebrow, "eyebrow")
}

/// Hair strands grown from the follicles of kind `follicles` (the same scatter, so every strand
/// starts at one of its follicles): each follicle grows one with probability `share` at its
/// surface point, of a length drawn by `length` from a uniform number.
fn place_strands(
    ctx: &Placing,
    follicles: (&FollicleConfig, &str),
    name: &str,
    share: &(dyn Fn(&crate::scatter::SurfacePoint) -> f32 + Sync),
    length: &(dyn Fn(f32) -> f32 + Sync),
    radius: f32,
    tapered: bool,
) -> Result<Box<dyn PlacedKind>> {
    let h = &ctx.cfg.hair;
    let (fc, kind) = follicles;
    let on = h.strands && fc.enabled && radius > 0.0;
    let spec = Spec::new(&fc.field, fc.density_per_cm2, on, stream(kind));
    let draws = Philox::new(ctx.cfg.seed, stream(name));
    let items = ctx.scatter(spec, |_, k, p| {
        let u = draws.uniform4(k, 0);
        if u[0] >= share(&p) {
            return None;
        }
        let curve = walk_strand(ctx.surface, ctx.fields, &h.vector_field, length(u[1]), p)?;
        Some(Strand::new(curve, radius, tapered, ctx.pitch(&p)))
    })?;
    let params = StrandParams {
        color: h.melanin(&ctx.cfg.person).color(),
    };
    Ok(Box::new(
        Scattered::with_auto_cell(items, ctx.period(), 4.0, params).listed_as(|items| {
            serde_json::to_value(items.iter().map(|s| s.curve.p).collect::<Vec<_>>())
                .unwrap_or_default()
        }),
    ))
}

/// A hair from every eyebrow follicle, along the brows' flow.
fn place_brow_hairs(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let r = ctx.cfg.hair.brow_length_mm;
    place_strands(
        ctx,
        (&ctx.cfg.eyebrow, "eyebrow"),
        "brow_hair",
        &|_| 1.0,
        &|u| r.min + (r.max - r.min) * u,
        ctx.cfg.hair.brow_radius_mm,
        true,
    )
}

/// Stubble on a man's beard follicles: the follicle field is scalp + BEARD_TO_SCALP · beard, so
/// a follicle is a beard one with probability BEARD_TO_SCALP · beard / field there.
fn place_stubble(ctx: &Placing) -> Result<Box<dyn PlacedKind>> {
    let h = &ctx.cfg.hair;
    let male = ctx.cfg.person.sex == crate::regional::Sex::Male;
    let (Some(beard), Ok(field)) = (
        ctx.fields.scalars.get(&h.beard_field),
        ctx.fields.scalar(&ctx.cfg.follicle.field),
    ) else {
        return Ok(Box::new(Scattered::<Strand>::new(
            Vec::new(),
            ctx.period(),
            4.0,
            StrandParams { color: [0.0; 3] },
        )));
    };
    let wrap = ctx.period().is_some();
    let share = |p: &crate::scatter::SurfacePoint| {
        let b = crate::builtin_head::BEARD_TO_SCALP * beard.sample_uv(p.uv.x, p.uv.y, wrap);
        b / field.sample_uv(p.uv.x, p.uv.y, wrap).max(1e-6)
    };
    let length = h.stubble_length_mm;
    place_strands(
        ctx,
        (&ctx.cfg.follicle, "follicle"),
        "stubble",
        &share,
        &|_| length,
        if male && length > 0.0 {
            h.stubble_radius_mm
        } else {
            0.0
        },
        false,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_streams_are_unique_and_stable() {
        let names: std::collections::HashSet<&str> = KINDS.iter().map(|k| k.name).collect();
        assert_eq!(names.len(), KINDS.len());
        // The streams are part of what a seed means: changing one changes the textures.
        let streams: Vec<u32> = KINDS.iter().map(|k| k.stream).collect();
        assert_eq!(streams, [1, 2, 3, 4, 5, 6, 7, 8, 9]);
        assert!(streams.iter().all(|&s| s != crate::noise::NOISE_STREAM));
        assert!(streams.iter().all(|&s| s != crate::noise::RELIEF_STREAM));
        assert!(streams
            .iter()
            .all(|&s| s != crate::mottling::MOTTLING_STREAM));
        assert_ne!(crate::mottling::MOTTLING_STREAM, crate::noise::NOISE_STREAM);
        assert_ne!(
            crate::mottling::MOTTLING_STREAM,
            crate::noise::RELIEF_STREAM
        );
    }
}
