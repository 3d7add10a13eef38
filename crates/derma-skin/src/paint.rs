//! Painting the bio maps (thesis §4.8.8, the second loop of TexGen): for every texel, the baseline
//! skin, then each feature kind present at its surface point in priority order
//! ([`crate::features::PRIORITY`]). Texels are independent, so rows are painted in parallel and
//! the result does not depend on the number of threads.

use crate::config::SkinConfig;
use crate::features::follicle::FollicleParams;
use crate::features::lips::{apply_lips, LipParams};
use crate::features::pore::PoreParams;
use crate::features::{BioSample, Feature, PaintPoint};
use crate::index::GridCursor;
use crate::noise::BandNoise;
use crate::placement::{stream, FeatureSet, Kind};
use crate::surface::Surface;
use derma_core::Map;
use rayon::prelude::*;

/// Painted bio parameters of every texel (array of structs: painting touches all of a texel's
/// parameters at once).
pub struct BioMaps {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<BioSample>,
}

/// Names of the bio channels as written to bio.exr, with their accessor.
pub const BIO_CHANNELS: [(&str, fn(&BioSample) -> f32); 12] = [
    ("melanin", |s| s.melanin),
    ("pheomelanin", |s| s.pheomelanin),
    ("blood", |s| s.blood),
    ("oxygenation", |s| s.oxygenation),
    ("stratum_corneum_um", |s| s.stratum_corneum_um),
    ("epidermis_um", |s| s.epidermis_um),
    ("height_mm", |s| s.height_mm),
    ("extra.R", |s| s.extra[0]),
    ("extra.G", |s| s.extra[1]),
    ("extra.B", |s| s.extra[2]),
    ("extra.A", |s| s.extra[3]),
    ("lips", |s| s.lips),
];

impl BioMaps {
    /// Fills texels outside the UV charts from their dilation sources (whole samples at once,
    /// so every map derived from them is dilated consistently).
    pub fn dilate(&mut self, sources: &[u32]) {
        for i in 0..self.texels.len() {
            let s = sources[i] as usize;
            if s != i {
                self.texels[i] = self.texels[s];
            }
        }
    }

    /// One channel as a planar map.
    pub fn channel(&self, f: fn(&BioSample) -> f32) -> Map {
        Map::from_vec(
            self.width,
            self.height,
            self.texels.par_iter().map(f).collect(),
        )
        .expect("size matches")
    }
}

/// Rows painted per parallel task.
const ROWS_PER_TASK: usize = 8;

/// Paints every covered texel of `surface`; uncovered texels keep the default sample and are
/// filled by dilation later.
pub fn paint(
    cfg: &SkinConfig,
    surface: &Surface,
    fields: &crate::field::FieldSet,
    features: &FeatureSet,
    progress: &(dyn Fn(usize) + Sync),
) -> crate::Result<BioMaps> {
    let b = &cfg.baseline;
    let noise = BandNoise::new(
        derma_core::rng::Philox::new(cfg.seed, stream::NOISE).u32x4(0)[0] as u64,
        b.noise_wavelengths_mm,
        surface.period(),
    );
    let lips_map = if cfg.lips.enabled {
        Some(fields.scalar(&cfg.lips.field)?)
    } else {
        None
    };
    let lip = LipParams {
        blood: cfg.lips.blood,
        pheomelanin: cfg.lips.pheomelanin,
        epidermis_um: cfg.lips.epidermis_um,
    };
    let pore = PoreParams {
        depth_mm: cfg.pore.depth_mm,
        melanin_add: cfg.pore.melanin_add,
    };
    let hair = |f: &crate::config::FollicleConfig| FollicleParams {
        hair_color: f.hair_color,
        height_mm: f.height_mm,
        blood_reduction: f.blood_reduction,
        gland_radius_mm: f.gland_radius_mm,
    };
    let (scalp, brow) = (hair(&cfg.follicle), hair(&cfg.eyebrow));
    let phi = b.phi;
    let amp = |r: crate::config::Range| (r.min, phi * (r.max - r.min));
    let chans = [
        amp(b.melanin),
        amp(b.pheomelanin),
        amp(b.blood),
        amp(b.oxygenation),
        amp(b.stratum_corneum_um),
        amp(b.epidermis_um),
        amp(b.height_mm),
    ];
    let wrap = surface.period().is_some();
    let w = surface.width;
    let mut texels = vec![BioSample::default(); surface.len()];
    let done = std::sync::atomic::AtomicUsize::new(0);
    texels
        .par_chunks_mut(w * ROWS_PER_TASK)
        .enumerate()
        .for_each(|(task, rows)| {
            let mut cur = Cursors::new(features);
            let mut noise_cache = crate::noise::NoiseCache::default();
            for (k, s) in rows.iter_mut().enumerate() {
                let i = task * w * ROWS_PER_TASK + k;
                if !surface.covered(i) {
                    continue;
                }
                let p = surface.position(i);
                let n = noise.eval_cached(p, &mut noise_cache);
                let v = |c: usize| chans[c].0 + chans[c].1 * n[c];
                *s = BioSample {
                    melanin: v(0),
                    pheomelanin: v(1),
                    blood: v(2),
                    oxygenation: v(3),
                    stratum_corneum_um: v(4),
                    epidermis_um: v(5),
                    height_mm: v(6),
                    extra: [0.0; 4],
                    lips: 0.0,
                };
                if let Some(m) = lips_map {
                    let uv = surface.uv(i);
                    apply_lips(&lip, m.sample_uv(uv.x, uv.y, wrap).clamp(0.0, 1.0), s);
                }
                let q = PaintPoint {
                    p,
                    n: surface.normal(i),
                };
                apply_kind(&features.cysts, &mut cur.cyst, &(), &q, s);
                apply_kind(&features.moles, &mut cur.mole, &(), &q, s);
                apply_kind(&features.freckles, &mut cur.freckle, &(), &q, s);
                apply_kind(&features.wrinkles, &mut cur.wrinkle, &(), &q, s);
                apply_kind(&features.pores, &mut cur.pore, &pore, &q, s);
                apply_kind(&features.follicles, &mut cur.follicle, &scalp, &q, s);
                apply_kind(&features.eyebrows, &mut cur.eyebrow, &brow, &q, s);
                s.melanin = s.melanin.clamp(0.0, 1.0);
                s.pheomelanin = s.pheomelanin.clamp(0.0, 1.0);
                s.blood = s.blood.clamp(0.0, 1.0);
            }
            let d = done.fetch_add(rows.len() / w, std::sync::atomic::Ordering::Relaxed);
            progress(d + rows.len() / w);
        });
    Ok(BioMaps {
        width: surface.width,
        height: surface.height,
        texels,
    })
}

#[inline]
fn apply_kind<T: Feature>(
    kind: &Kind<T>,
    cursor: &mut GridCursor<'_>,
    prm: &T::Params,
    q: &PaintPoint,
    s: &mut BioSample,
) {
    for &id in cursor.query(q.p) {
        kind.items[id as usize].apply(prm, q, s);
    }
}

struct Cursors<'a> {
    cyst: GridCursor<'a>,
    mole: GridCursor<'a>,
    freckle: GridCursor<'a>,
    wrinkle: GridCursor<'a>,
    pore: GridCursor<'a>,
    follicle: GridCursor<'a>,
    eyebrow: GridCursor<'a>,
}

impl<'a> Cursors<'a> {
    fn new(f: &'a FeatureSet) -> Self {
        Self {
            cyst: GridCursor::new(&f.cysts.grid),
            mole: GridCursor::new(&f.moles.grid),
            freckle: GridCursor::new(&f.freckles.grid),
            wrinkle: GridCursor::new(&f.wrinkles.grid),
            pore: GridCursor::new(&f.pores.grid),
            follicle: GridCursor::new(&f.follicles.grid),
            eyebrow: GridCursor::new(&f.eyebrows.grid),
        }
    }
}
