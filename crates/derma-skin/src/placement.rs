//! Placing features (thesis §4.8.8, the first loop of TexGen): for a kind, draw its count from
//! the density field and the surface area, then its centres and parameters from the
//! counter-based RNG keyed by (seed, kind, index), and build the kind's spatial index
//! ([`Scattered`]); wrinkles walk the vector field. `kinds.rs` applies this to every kind.

use crate::config::SkinConfig;
use crate::features::bezier::CubicBezier;
use crate::features::{BioSample, Feature, PaintPoint};
use crate::field::FieldSet;
use crate::index::Grid;
use crate::scatter::{Sampler, SurfacePoint};
use crate::surface::Surface;
use crate::Result;
use derma_core::rng::Philox;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// The features of one kind, with ghost copies (tileable patches), their index and the
/// parameters every feature of the kind shares.
pub struct Scattered<T: Feature> {
    /// The features, then their ghost copies.
    pub items: Vec<T>,
    /// Number of real features; items past it are ghost copies across a tileable patch's edges.
    pub originals: usize,
    /// The spatial index over every item's bounds.
    pub grid: Grid,
    /// Parameters shared by the kind.
    pub params: T::Params,
    json: fn(&[T]) -> serde_json::Value,
}

impl<T: Feature + 'static> Scattered<T> {
    /// Indexes `items` in cells of `cell_mm`, adding ghost copies when `period` (a tileable
    /// patch's size) is given.
    pub fn new(
        mut items: Vec<T>,
        period: Option<[f32; 2]>,
        cell_mm: f32,
        params: T::Params,
    ) -> Self {
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
            params,
            json: |items| serde_json::to_value(items).unwrap_or_default(),
        }
    }

    /// As [`Scattered::new`] with cells twice the largest reach of the kind's features (so
    /// most features touch few cells), capped at `max_cell_mm`.
    pub fn with_auto_cell(
        items: Vec<T>,
        period: Option<[f32; 2]>,
        max_cell_mm: f32,
        params: T::Params,
    ) -> Self {
        let reach = items
            .iter()
            .map(|f| {
                let (lo, hi) = f.bounds();
                (hi - lo).max_element() * 0.5
            })
            .fold(0.0f32, f32::max);
        Self::new(
            items,
            period,
            (2.0 * reach).clamp(0.05, max_cell_mm),
            params,
        )
    }

    /// features.json lists the kind through `json` instead of every parameter.
    pub fn listed_as(mut self, json: fn(&[T]) -> serde_json::Value) -> Self {
        self.json = json;
        self
    }

    /// The real features (no ghosts).
    pub fn originals(&self) -> &[T] {
        &self.items[..self.originals]
    }
}

/// A placed kind as painting and reporting see it, whatever its feature type.
pub trait PlacedKind: Send + Sync {
    /// Number of real features.
    fn count(&self) -> usize;
    /// The spatial index.
    fn grid(&self) -> &Grid;
    /// Applies the features `ids` (from the grid) at `q`, in order.
    fn paint(&self, ids: &[u32], q: &PaintPoint, s: &mut BioSample);
    /// The real features for features.json.
    fn to_json(&self) -> serde_json::Value;
    /// The concrete [`Scattered`], for callers that know the type.
    fn as_any(&self) -> &dyn std::any::Any;
}

impl<T: Feature + 'static> PlacedKind for Scattered<T>
where
    T::Params: Send + Sync,
{
    fn count(&self) -> usize {
        self.originals
    }
    fn grid(&self) -> &Grid {
        &self.grid
    }
    #[inline]
    fn paint(&self, ids: &[u32], q: &PaintPoint, s: &mut BioSample) {
        for &id in ids {
            self.items[id as usize].apply(&self.params, q, s);
        }
    }
    fn to_json(&self) -> serde_json::Value {
        (self.json)(self.originals())
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// Output texel pitch (mm) at a scatter point.
pub(crate) fn pitch(frame: &crate::surface::Frame, size: usize) -> f32 {
    frame.texel_area(size, size).sqrt()
}

/// What to scatter for one kind: its density field (raised to `power`), peak density per cm²,
/// whether it is enabled, and its RNG stream.
pub(crate) struct Spec<'a> {
    pub field: &'a str,
    pub power: f32,
    pub density: f32,
    pub enabled: bool,
    pub stream: u32,
}

impl<'a> Spec<'a> {
    pub fn new(field: &'a str, density: f32, enabled: bool, stream: u32) -> Self {
        Self {
            field,
            power: 1.0,
            density,
            enabled,
            stream,
        }
    }
}

/// What placing a kind needs: the config, the fields, the surface at scatter resolution and
/// the output size (for anti-aliasing sub-texel features).
pub struct Placing<'a> {
    /// The run's configuration.
    pub cfg: &'a SkinConfig,
    /// The probability and vector fields.
    pub fields: &'a FieldSet,
    /// The surface at scatter resolution.
    pub surface: &'a Surface,
    /// Output resolution (texels per side).
    pub size: usize,
    /// Points already scattered, by spec: the strand kinds grow from the follicle kinds'
    /// points, drawn once.
    pub(crate) scattered: Scattering,
}

/// Points scattered for a spec (field, power, density, stream), each with its draw index.
pub(crate) type Scattering = std::sync::Mutex<
    std::collections::HashMap<(String, u32, u32, u32), std::sync::Arc<Vec<(u64, SurfacePoint)>>>,
>;

impl Placing<'_> {
    /// Output texel pitch (mm) at a scatter point.
    pub(crate) fn pitch(&self, p: &SurfacePoint) -> f32 {
        pitch(&p.frame, self.size)
    }

    /// The patch period when the surface tiles.
    pub(crate) fn period(&self) -> Option<[f32; 2]> {
        self.surface.period()
    }

    /// Scatters one kind in parallel; the i-th feature depends only on (seed, stream, i).
    pub(crate) fn scatter<T: Send>(
        &self,
        spec: Spec,
        make: impl Fn(&Philox, u64, SurfacePoint) -> Option<T> + Sync,
    ) -> Result<Vec<T>> {
        if !spec.enabled || spec.density <= 0.0 {
            return Ok(Vec::new());
        }
        let rng = Philox::new(self.cfg.seed, spec.stream);
        let points = self.points(&spec)?;
        Ok(points
            .par_iter()
            .filter_map(|&(k, p)| make(&rng, k, p))
            .collect())
    }

    /// The points of `spec` with their draw indices: drawn with probability ∝ field × area, or
    /// taken from an earlier kind with the same spec.
    fn points(&self, spec: &Spec) -> Result<std::sync::Arc<Vec<(u64, SurfacePoint)>>> {
        let key = (
            spec.field.to_string(),
            spec.power.to_bits(),
            spec.density.to_bits(),
            spec.stream,
        );
        if let Some(p) = self
            .scattered
            .lock()
            .ok()
            .and_then(|m| m.get(&key).cloned())
        {
            return Ok(p);
        }
        let s = self.surface;
        let map = self.fields.scalar(spec.field)?;
        let wrap = s.period().is_some();
        let weights: Vec<f32> = (0..s.len())
            .into_par_iter()
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
        let rng = Philox::new(self.cfg.seed, spec.stream);
        let points = std::sync::Arc::new(
            (0..n as u64)
                .into_par_iter()
                .filter_map(|k| sampler.sample(&rng, k).map(|p| (k, p)))
                .collect::<Vec<_>>(),
        );
        if let Ok(mut m) = self.scattered.lock() {
            m.insert(key, points.clone());
        }
        Ok(points)
    }
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
    walk_curve(
        s,
        &|uv| fields.vector(name, uv.x, uv.y, wrap).ok(),
        v0.length * max_length_mm,
        start,
        true,
    )
}

/// A hair strand's centre line from its follicle at `start`: `length_mm` times the vector
/// field's length at the root, walked along the vector field `name`, or `length_mm` along +v of
/// the UV layout where the fields have no such vector field.
pub fn walk_strand(
    s: &Surface,
    fields: &FieldSet,
    name: &str,
    length_mm: f32,
    start: SurfacePoint,
) -> Option<CubicBezier> {
    let wrap = s.period().is_some();
    let up = crate::field::UvVector {
        dir: Vec2::Y,
        length: 1.0,
    };
    let dir = |uv: Vec2| match fields.vectors.contains_key(name) {
        true => fields.vector(name, uv.x, uv.y, wrap).ok(),
        false => Some(up),
    };
    let at_root = dir(start.uv)?.length;
    walk_curve(s, &dir, length_mm * at_root, start, false)
}

/// Three steps of `length`/3 along the directions of `field` from `start` (stopping where it
/// has none), as the four control points of a cubic Bézier on the surface. With `snap`, each
/// point on a mesh is the position of the scatter texel reached (a wrinkle, centimetres long);
/// without, the steps are taken in the tangent plane (a hair a millimetre long, shorter than a
/// few scatter texels, whose centres would bend and stretch it).
fn walk_curve(
    s: &Surface,
    field: &dyn Fn(Vec2) -> Option<crate::field::UvVector>,
    length: f32,
    start: SurfacePoint,
    snap: bool,
) -> Option<CubicBezier> {
    let wrap = s.period().is_some();
    if length <= 0.0 {
        return None;
    }
    let step = length / 3.0;
    let mut pts = vec![start.position];
    let mut uv = start.uv;
    let mut pos = start.position;
    for _ in 0..3 {
        let v = field(uv)?;
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
            pos = if !snap || matches!(s.geometry, crate::surface::Geometry::Patch { .. }) {
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
