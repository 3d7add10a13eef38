//! Placing features (thesis §4.8.8, the first loop of TexGen): for each feature kind, draw its
//! count from the density field and the surface area, then its centre and parameters from the
//! counter-based RNG keyed by (seed, kind, index), and build the kind's spatial index.

use crate::config::SkinConfig;
use crate::features::bezier::CubicBezier;
use crate::features::cyst::Cyst;
use crate::features::follicle::Follicle;
use crate::features::freckle::Freckle;
use crate::features::mole::Mole;
use crate::features::pore::Pore;
use crate::features::wrinkle::Wrinkle;
use crate::features::Feature;
use crate::field::FieldSet;
use crate::index::Grid;
use crate::scatter::{Sampler, SurfacePoint};
use crate::surface::Surface;
use crate::Result;
use derma_core::rng::Philox;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::Serialize;

/// RNG streams, one per feature kind (stable numbers: changing one changes a kind's features).
pub mod stream {
    pub const CYST: u32 = 1;
    pub const MOLE: u32 = 2;
    pub const FRECKLE: u32 = 3;
    pub const WRINKLE: u32 = 4;
    pub const PORE: u32 = 5;
    pub const FOLLICLE: u32 = 6;
    pub const EYEBROW: u32 = 7;
    pub const NOISE: u32 = 100;
}

/// The features of one kind, with ghost copies (tileable patches) and their index.
pub struct Kind<T> {
    pub items: Vec<T>,
    /// Number of real features; items past it are ghost copies across a tileable patch's edges.
    pub originals: usize,
    pub grid: Grid,
}

impl<T: Feature> Kind<T> {
    pub fn new(mut items: Vec<T>, period: Option<[f32; 2]>, cell_mm: f32) -> Self {
        let originals = items.len();
        if let Some([px, py]) = period {
            let mut ghosts = Vec::new();
            for f in &items {
                let (lo, hi) = f.bounds();
                for dy in -1..=1i32 {
                    for dx in -1..=1i32 {
                        if dx == 0 && dy == 0 {
                            continue;
                        }
                        let d = Vec3::new(dx as f32 * px, dy as f32 * py, 0.0);
                        let (l, h) = (lo + d, hi + d);
                        if h.x >= 0.0 && l.x <= px && h.y >= 0.0 && l.y <= py {
                            ghosts.push(f.translated(d));
                        }
                    }
                }
            }
            items.extend(ghosts);
        }
        let grid = Grid::build(cell_mm, items.iter().map(|f| f.bounds()));
        Self {
            items,
            originals,
            grid,
        }
    }

    /// Cells twice the largest reach of the kind's features (so most features touch few cells),
    /// capped at `max_cell_mm`.
    fn with_auto_cell(items: Vec<T>, period: Option<[f32; 2]>, max_cell_mm: f32) -> Self {
        let reach = items
            .iter()
            .map(|f| {
                let (lo, hi) = f.bounds();
                (hi - lo).max_element() * 0.5
            })
            .fold(0.0f32, f32::max);
        Self::new(items, period, (2.0 * reach).clamp(0.05, max_cell_mm))
    }

    pub fn originals(&self) -> &[T] {
        &self.items[..self.originals]
    }
}

/// Every scattered feature.
pub struct FeatureSet {
    pub cysts: Kind<Cyst>,
    pub moles: Kind<Mole>,
    pub freckles: Kind<Freckle>,
    pub wrinkles: Kind<Wrinkle>,
    pub pores: Kind<Pore>,
    pub follicles: Kind<Follicle>,
    pub eyebrows: Kind<Follicle>,
}

/// Counts per kind, for reports.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FeatureCounts {
    pub cyst: usize,
    pub mole: usize,
    pub freckle: usize,
    pub wrinkle: usize,
    pub pore: usize,
    pub follicle: usize,
    pub eyebrow: usize,
}

impl FeatureSet {
    pub fn counts(&self) -> FeatureCounts {
        FeatureCounts {
            cyst: self.cysts.originals,
            mole: self.moles.originals,
            freckle: self.freckles.originals,
            wrinkle: self.wrinkles.originals,
            pore: self.pores.originals,
            follicle: self.follicles.originals,
            eyebrow: self.eyebrows.originals,
        }
    }

    pub fn total(&self) -> usize {
        let c = self.counts();
        c.cyst + c.mole + c.freckle + c.wrinkle + c.pore + c.follicle + c.eyebrow
    }

    /// Every placed feature with its parameters (features.json).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "units": "positions and lengths in mm on the surface",
            "cyst": self.cysts.originals(),
            "mole": self.moles.originals(),
            "freckle": self.freckles.originals(),
            "wrinkle": self.wrinkles.originals(),
            "pore": self.pores.originals(),
            "follicle": self.follicles.originals().iter().map(|f| f.center).collect::<Vec<_>>(),
            "eyebrow": self.eyebrows.originals().iter().map(|f| f.center).collect::<Vec<_>>(),
        })
    }
}

/// Output texel pitch (mm) at a scatter point.
fn pitch(frame: &crate::surface::Frame, size: usize) -> f32 {
    frame.texel_area(size, size).sqrt()
}

/// What to scatter for one kind: its density field (raised to `power`), peak density per cm²,
/// whether it is enabled, and its RNG stream.
struct Spec<'a> {
    field: &'a str,
    power: f32,
    density: f32,
    enabled: bool,
    stream: u32,
}

impl<'a> Spec<'a> {
    fn new(field: &'a str, density: f32, enabled: bool, stream: u32) -> Self {
        Self {
            field,
            power: 1.0,
            density,
            enabled,
            stream,
        }
    }
}

/// Scatters kinds over one surface.
struct Scatter<'a> {
    surface: &'a Surface,
    fields: &'a FieldSet,
    seed: u64,
}

impl Scatter<'_> {
    /// Scatters one kind in parallel; the i-th feature depends only on (seed, stream, i).
    fn kind<T: Send>(
        &self,
        spec: Spec,
        make: impl Fn(&Philox, u64, SurfacePoint) -> Option<T> + Sync,
    ) -> Result<Vec<T>> {
        if !spec.enabled || spec.density <= 0.0 {
            return Ok(Vec::new());
        }
        let s = self.surface;
        let map = self.fields.scalar(spec.field)?;
        let wrap = s.period().is_some();
        let weights: Vec<f32> = (0..s.len())
            .map(|i| {
                let uv = s.uv(i);
                let v = map.sample_uv(uv.x, uv.y, wrap).clamp(0.0, 1.0);
                if spec.power == 1.0 {
                    v
                } else {
                    v.powf(spec.power)
                }
            })
            .collect();
        let sampler = Sampler::new(s, |i| weights[i]);
        let n = sampler.count(spec.density);
        let rng = Philox::new(self.seed, spec.stream);
        Ok((0..n as u64)
            .into_par_iter()
            .filter_map(|k| sampler.sample(&rng, k).and_then(|p| make(&rng, k, p)))
            .collect())
    }
}

/// Places every feature kind of `cfg` on `scatter_surface` (the surface at scatter resolution);
/// `size` is the output resolution, used for anti-aliasing sub-texel features.
pub fn place(
    cfg: &SkinConfig,
    fields: &FieldSet,
    scatter_surface: &Surface,
    size: usize,
) -> Result<FeatureSet> {
    let s = scatter_surface;
    let sc = Scatter {
        surface: s,
        fields,
        seed: cfg.seed,
    };
    let period = s.period();
    let px = |p: &SurfacePoint| pitch(&p.frame, size);

    let c = &cfg.cyst;
    let cysts = sc.kind(
        Spec::new(&c.field, c.density_per_cm2, c.enabled, stream::CYST),
        |r, k, p| {
            Some(Cyst::new(
                p.position,
                c,
                r.normal2(k, 1)[0],
                r.uniform4(k, 2)[0],
                px(&p),
            ))
        },
    )?;
    let m = &cfg.mole;
    let moles = sc.kind(
        Spec::new(&m.field, m.density_per_cm2, m.enabled, stream::MOLE),
        |r, k, p| {
            let (z, u, v) = (r.normal2(k, 1)[0], r.uniform4(k, 2), r.uniform4(k, 3));
            Some(Mole::new(
                p.position,
                p.frame.t,
                p.frame.b,
                m,
                z,
                u,
                v,
                px(&p),
            ))
        },
    )?;
    let f = &cfg.freckle;
    let freckle_spec = Spec {
        power: f.power,
        ..Spec::new(&f.field, f.density_per_cm2, f.enabled, stream::FRECKLE)
    };
    let freckles = sc.kind(freckle_spec, |r, k, p| {
        let (z, u, v) = (r.normal2(k, 1)[0], r.uniform4(k, 2), r.uniform4(k, 3));
        Some(Freckle::new(
            p.position,
            p.frame.t,
            p.frame.b,
            f,
            z,
            u,
            v,
            px(&p),
        ))
    })?;
    let pc = &cfg.pore;
    let pores = sc.kind(
        Spec::new(&pc.field, pc.density_per_cm2, pc.enabled, stream::PORE),
        |r, k, p| Some(Pore::new(p.position, pc, r.normal2(k, 1)[0], px(&p))),
    )?;
    let hair = |fc: &crate::config::FollicleConfig, stream| {
        sc.kind(
            Spec::new(&fc.field, fc.density_per_cm2, fc.enabled, stream),
            |_, _, p| Some(Follicle::new(p.position, fc, px(&p))),
        )
    };
    let follicles = hair(&cfg.follicle, stream::FOLLICLE)?;
    let eyebrows = hair(&cfg.eyebrow, stream::EYEBROW)?;

    let w = &cfg.wrinkle;
    if w.enabled && w.density_per_cm2 > 0.0 && !fields.vectors.contains_key(&w.vector_field) {
        return Err(crate::SkinError::Field {
            name: w.vector_field.clone(),
            detail: "wrinkles need this vector field (RGB: R,G direction, B length)".into(),
        });
    }
    let wrinkles = sc.kind(
        Spec::new(&w.field, w.density_per_cm2, w.enabled, stream::WRINKLE),
        |r, k, p| {
            let u = r.uniform4(k, 1);
            let curve = walk_wrinkle(s, fields, &w.vector_field, w.max_length_mm, p)?;
            let width = w.width_mm.min + (w.width_mm.max - w.width_mm.min) * u[0];
            let depth = w.depth_mm.min + (w.depth_mm.max - w.depth_mm.min) * u[1];
            Some(Wrinkle::new(curve, width, depth, px(&p)))
        },
    )?;

    Ok(FeatureSet {
        cysts: Kind::with_auto_cell(cysts, period, 8.0),
        moles: Kind::with_auto_cell(moles, period, 8.0),
        freckles: Kind::with_auto_cell(freckles, period, 8.0),
        wrinkles: Kind::new(wrinkles, period, 4.0),
        pores: Kind::with_auto_cell(pores, period, 4.0),
        follicles: Kind::with_auto_cell(follicles, period, 4.0),
        eyebrows: Kind::with_auto_cell(eyebrows, period, 4.0),
    })
}

/// Builds a wrinkle's cubic Bézier by walking the vector field (thesis §5.3.7): the length l is
/// B·max_length at the start; three steps of l/3 along the field give the four control points.
pub fn walk_wrinkle(
    s: &Surface,
    fields: &FieldSet,
    name: &str,
    max_length_mm: f32,
    start: SurfacePoint,
) -> Option<CubicBezier> {
    let wrap = s.period().is_some();
    let v0 = fields.vector(name, start.uv.x, start.uv.y, wrap).ok()?;
    let length = v0.length * max_length_mm;
    if length <= 0.0 {
        return None;
    }
    let step = length / 3.0;
    let mut pts = vec![start.position];
    let mut uv = start.uv;
    let mut pos = start.position;
    for _ in 0..3 {
        let v = fields.vector(name, uv.x, uv.y, wrap).ok()?;
        if v.length <= 0.0 {
            break;
        }
        let i = s.texel_at(uv);
        let fr = s.frame(i);
        let dir3 = fr.dpdu * v.dir.x + fr.dpdv * v.dir.y;
        let mm_per_uv = dir3.length();
        if mm_per_uv <= 1e-6 {
            break;
        }
        uv += v.dir * (step / mm_per_uv);
        let inside = (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y);
        if !wrap && !inside {
            break;
        }
        if wrap {
            // On a patch the walk continues past the edge; positions stay unwrapped.
            pos += dir3 * (step / mm_per_uv);
            uv = Vec2::new(uv.x.rem_euclid(1.0), uv.y.rem_euclid(1.0));
        } else {
            let j = s.texel_at(uv);
            if !s.covered(j) {
                break;
            }
            pos = if matches!(s.geometry, crate::surface::Geometry::Patch { .. }) {
                pos + dir3 * (step / mm_per_uv)
            } else {
                s.position(j)
            };
        }
        pts.push(pos);
    }
    let last = *pts.last()?;
    if pts.len() < 2 || last.distance(pts[0]) < 1e-3 {
        return None;
    }
    // Fewer than four points (the walk left the chart): a straight cubic through the ends.
    while pts.len() < 4 {
        let n = pts.len();
        let a = pts[0];
        let b = pts[n - 1];
        pts = (0..=n).map(|k| a.lerp(b, k as f32 / n as f32)).collect();
    }
    Some(CubicBezier {
        p: [pts[0], pts[1], pts[2], pts[3]],
    })
}
