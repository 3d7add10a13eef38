//! Painting the bio maps (thesis §4.8.8, the second loop of TexGen): for every texel, the baseline
//! skin and the lips, then each feature kind present at its surface point in the table's order
//! ([`crate::kinds::KINDS`]). Texels are independent, so rows are painted in parallel and the
//! result does not depend on the number of threads.

use crate::config::SkinConfig;
use crate::feature_set::FeatureSet;
use crate::features::lips::{apply_lips, LipParams};
use crate::features::relief::{self, ReliefParams};
use crate::features::relief_lanes::{heights, ReliefTexel};
use crate::features::{BioSample, PaintPoint};
use crate::index::GridCursor;
use crate::noise::{stream_seed, BandNoise, CHANNELS, NOISE_STREAM, RELIEF_STREAM};
use crate::surface::Surface;
use derma_core::map::Taps;
use derma_core::progress::{Progress, Unit};
use derma_core::Map;
use derma_optics::bio::names;
use derma_shading::BioTexel;
use rayon::prelude::*;

/// Painted bio parameters of every texel (array of structs: painting touches all of a texel's
/// parameters at once).
pub struct BioMaps {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// One sample per texel, row-major.
    pub texels: Vec<BioSample>,
}

/// A named bio channel and how to read it from a sample.
pub type BioChannel = (&'static str, fn(&BioSample) -> f32);

/// Names of the bio channels as written to bio.exr, with their accessor.
pub const BIO_CHANNELS: [BioChannel; 12] = [
    (names::MELANIN, |s| s.tissue.melanin),
    (names::PHEOMELANIN, |s| s.tissue.pheomelanin),
    (names::BLOOD, |s| s.tissue.blood),
    (names::OXYGENATION, |s| s.tissue.oxygenation),
    (names::STRATUM_CORNEUM_UM, |s| s.tissue.stratum_corneum_um),
    (names::EPIDERMIS_UM, |s| s.tissue.epidermis_um),
    ("height_mm", |s| s.height_mm),
    ("extra.R", |s| s.extra[0]),
    ("extra.G", |s| s.extra[1]),
    ("extra.B", |s| s.extra[2]),
    ("extra.A", |s| s.extra[3]),
    ("lips", |s| s.lips),
];

impl BioSample {
    /// The sample's values in [`BIO_CHANNELS`] order.
    #[inline]
    pub fn channels(&self) -> [f32; 12] {
        let t = &self.tissue;
        [
            t.melanin,
            t.pheomelanin,
            t.blood,
            t.oxygenation,
            t.stratum_corneum_um,
            t.epidermis_um,
            self.height_mm,
            self.extra[0],
            self.extra[1],
            self.extra[2],
            self.extra[3],
            self.lips,
        ]
    }
}

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

    /// Channels box-filtered by the whole factor `k` (each texel the mean of a k × k block),
    /// without making the full-size maps, in one pass over the samples.
    pub fn channels_reduced<const C: usize>(
        &self,
        k: usize,
        f: impl Fn(&BioSample) -> [f32; C] + Sync,
    ) -> [Map; C] {
        derma_core::map::box_reduced(self.width, self.height, k, |i| f(&self.texels[i]))
    }

    /// One channel as a planar map.
    pub fn channel(&self, f: fn(&BioSample) -> f32) -> Map {
        Map::from_par_fn(self.width, self.height, |i| f(&self.texels[i]))
    }
}

/// Rows painted per parallel task.
const ROWS_PER_TASK: usize = 8;

/// Measured chromophore maps that replace the baseline's (`baseline.melanin_map`,
/// `baseline.blood_map`): volume fractions in the surface's UV layout.
#[derive(Clone, Debug, Default)]
pub struct BaselineMaps {
    /// Melanosome volume fraction C_m.
    pub melanin: Option<Map>,
    /// Dermal blood volume fraction C_hd.
    pub blood: Option<Map>,
    /// Where a map is given, the tissue's other parameters (pheomelanin share, oxygenation,
    /// the layers' thicknesses), without noise or regional change: the ones the maps' colours
    /// were inverted at ([`crate::config::BaselineConfig::mean_tissue`]). The photo's colour,
    /// regional differences included, is in the maps.
    pub tissue: Option<BioTexel>,
}

/// Paints every covered texel of `surface`; uncovered texels keep the default sample and are
/// filled by dilation later. One stage, advancing by rows.
pub fn paint(
    cfg: &SkinConfig,
    surface: &Surface,
    fields: &crate::field::FieldSet,
    features: &FeatureSet,
    progress: &dyn Progress,
) -> crate::Result<BioMaps> {
    paint_with(
        cfg,
        surface,
        fields,
        features,
        &BaselineMaps::default(),
        progress,
    )
}

/// [`paint`] with measured baseline maps (a photographed face's chromophores): where given,
/// they replace the baseline's melanin or blood and its regional gain; features paint on top.
pub fn paint_with(
    cfg: &SkinConfig,
    surface: &Surface,
    fields: &crate::field::FieldSet,
    features: &FeatureSet,
    measured: &BaselineMaps,
    progress: &dyn Progress,
) -> crate::Result<BioMaps> {
    progress.stage("paint", surface.height as u64, Unit::Rows);
    let painter = Painter::new(cfg, surface, fields, features, measured)?;
    Ok(BioMaps {
        width: surface.width,
        height: surface.height,
        texels: painter.rows(0..surface.height, progress),
    })
}

/// What painting a row reads, shared by every task ([`Painter::new`]); [`paint_with`] paints
/// every row, the streamed main job a band of rows or a few texels at a time.
pub struct Painter<'a> {
    surface: &'a Surface,
    noise: BandNoise,
    mottling: Option<crate::mottling::Mottling>,
    lips: Option<(&'a Map, LipParams)>,
    regional: Option<Vec<&'a Map>>,
    measured: &'a BaselineMaps,
    relief: Option<(ReliefParams, &'a Map, Option<&'a [Map; 3]>)>,
    /// Per baseline channel: minimum and amplitude of its noise.
    chans: [(f32, f32); 7],
    wrap: bool,
    field_size: (usize, usize),
    /// The feature kinds present, in the table's order.
    kinds: Vec<&'a dyn crate::placement::PlacedKind>,
}

impl<'a> Painter<'a> {
    /// What painting reads, from the options, the surface, the fields, the features and the
    /// measured maps.
    pub fn new(
        cfg: &SkinConfig,
        surface: &'a Surface,
        fields: &'a crate::field::FieldSet,
        features: &'a FeatureSet,
        measured: &'a BaselineMaps,
    ) -> crate::Result<Self> {
        let b = &cfg.baseline;
        let noise = BandNoise::new(
            stream_seed(cfg.seed, NOISE_STREAM) as u64,
            b.noise_wavelengths_mm,
            surface.period(),
        );
        let mottling = cfg.mottling.enabled.then(|| {
            crate::mottling::Mottling::new(
                stream_seed(cfg.seed, crate::mottling::MOTTLING_STREAM) as u64,
                cfg.mottling.wavelengths_mm,
                cfg.mottling.blood,
                cfg.mottling.melanin,
                surface.period(),
            )
        });
        let lips_map = if cfg.lips.enabled {
            Some(fields.scalar(&cfg.lips.field)?)
        } else {
            None
        };
        let lip_params = LipParams {
            blood: cfg.lips.blood,
            pheomelanin: cfg.lips.pheomelanin,
            epidermis_um: cfg.lips.epidermis_um,
        };
        // Regional biology (regional.rs): gains on blood, melanin and epidermis and a shift of
        // oxygenation, where the fields carry them (the built-in head) and they are enabled.
        let regional: Option<Vec<&Map>> = if cfg.regional.enabled {
            crate::regional::CHANNELS
                .iter()
                .map(|c| fields.scalars.get(*c))
                .collect()
        } else {
            None
        };
        // Micro-relief (features/relief.rs): its depth field and, if given, the tension lines.
        let relief = if cfg.relief.enabled {
            let r = &cfg.relief;
            Some((
                ReliefParams::from_config(
                    r,
                    stream_seed(cfg.seed, RELIEF_STREAM),
                    surface.period(),
                ),
                fields.scalar(&r.field)?,
                fields.vectors.get(&r.vector_field),
            ))
        } else {
            None
        };
        let kinds: Vec<_> = features.kinds().map(|(_, k)| k).collect();
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
        // The size most fields share (the built-in head's are all FIELD_RESOLUTION²).
        let field_size = regional
            .as_ref()
            .and_then(|r| r.first().copied())
            .or(lips_map)
            .map_or((1, 1), |m| (m.width(), m.height()));
        Ok(Painter {
            surface,
            noise,
            mottling,
            lips: lips_map.map(|m| (m, lip_params)),
            regional,
            measured,
            relief,
            chans,
            wrap: surface.period().is_some(),
            field_size,
            kinds,
        })
    }

    /// Rows `rows` painted (uncovered texels keep the default sample, for the dilation to
    /// fill), advancing `progress` by rows; rows are painted in parallel tasks.
    pub fn rows(&self, rows: std::ops::Range<usize>, progress: &dyn Progress) -> Vec<BioSample> {
        let w = self.surface.width;
        let start = rows.start * w;
        // Filled in parallel: the first touch of these pages (about 1 GB at 4096² for the
        // whole map) is spread over the threads instead of one.
        let mut texels = Vec::with_capacity(rows.len() * w);
        texels.par_extend(rayon::iter::repeat_n(BioSample::default(), rows.len() * w));
        texels
            .par_chunks_mut(w * ROWS_PER_TASK)
            .enumerate()
            .for_each(|(task, rows)| {
                let (mut cursors, mut scratch) = self.task_state();
                for (r, row) in rows.chunks_mut(w).enumerate() {
                    let first = start + (task * ROWS_PER_TASK + r) * w;
                    self.row(first, row, None, &mut cursors, &mut scratch);
                }
                progress.advance((rows.len() / w) as u64);
            });
        texels
    }

    /// The samples of `texels` (sorted and distinct), each painted as in its whole row:
    /// a texel's sample does not depend on the others of its row.
    pub fn texels(&self, texels: &[u32]) -> Vec<BioSample> {
        let w = self.surface.width;
        // The texels grouped by row.
        let mut groups: Vec<&[u32]> = Vec::new();
        let mut rest = texels;
        while let Some(&t) = rest.first() {
            let y = t as usize / w;
            let n = rest.partition_point(|&u| u as usize / w == y);
            groups.push(&rest[..n]);
            rest = &rest[n..];
        }
        let painted: Vec<Vec<BioSample>> = groups
            .par_chunks(ROWS_PER_TASK)
            .flat_map_iter(|task| {
                let (mut cursors, mut scratch) = self.task_state();
                let mut row = vec![BioSample::default(); w];
                task.iter()
                    .map(|g| {
                        let first = g[0] as usize / w * w;
                        let cols: Vec<usize> = g.iter().map(|&t| t as usize - first).collect();
                        row.fill(BioSample::default());
                        self.row(first, &mut row, Some(&cols), &mut cursors, &mut scratch);
                        cols.iter().map(|&x| row[x]).collect()
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        painted.into_iter().flatten().collect()
    }

    /// A task's grid cursors (one per feature kind) and scratch buffers.
    fn task_state(&self) -> (Vec<GridCursor<'_>>, Scratch) {
        let cursors = self
            .kinds
            .iter()
            .map(|k| GridCursor::new(k.grid()))
            .collect();
        (cursors, Scratch::default())
    }
}

/// A task's caches and a row's buffers, reused from row to row.
#[derive(Default)]
struct Scratch {
    noise_cache: crate::noise::NoiseCache,
    mottling_cache: crate::noise::NoiseCache,
    relief_cache: relief::ReliefCache,
    covered: Vec<usize>,
    points: Vec<glam::Vec3>,
    base_noise: Vec<[f32; CHANNELS]>,
    mottling_noise: Vec<[f32; CHANNELS]>,
    /// Per covered texel: its column, point and lip mask.
    row_points: Vec<(usize, PaintPoint, f32)>,
    relief_in: Vec<ReliefTexel>,
    relief_at: Vec<usize>,
    relief_out: Vec<f32>,
}

impl Painter<'_> {
    /// Paints `row`, whose first texel is `first`, in three passes, so the micro-relief runs
    /// across the row's texels in SIMD lanes (relief_lanes.rs): the baseline and the inputs of
    /// the relief; the relief; the lips and the features. Each texel sees the same operations
    /// in the same order as when painted alone.
    fn row(
        &self,
        first: usize,
        row: &mut [BioSample],
        cols: Option<&[usize]>,
        cursors: &mut [GridCursor],
        sc: &mut Scratch,
    ) {
        self.baseline(first, row, cols, sc);
        if let Some((prm, _, _)) = &self.relief {
            sc.relief_out.resize(sc.relief_in.len(), 0.0);
            heights(prm, &sc.relief_in, &mut sc.relief_out, &mut sc.relief_cache);
            for (&x, h) in sc.relief_at.iter().zip(&sc.relief_out) {
                row[x].height_mm += h;
            }
        }
        for (x, q, lip) in &sc.row_points {
            let s = &mut row[*x];
            if let Some((_, params)) = &self.lips {
                apply_lips(params, lip.clamp(0.0, 1.0), s);
            }
            for (kind, cursor) in self.kinds.iter().zip(cursors.iter_mut()) {
                let ids = cursor.query(q.p);
                if !ids.is_empty() {
                    kind.paint(ids, q, s);
                }
            }
            s.tissue.melanin = s.tissue.melanin.clamp(0.0, 1.0);
            s.tissue.pheomelanin = s.tissue.pheomelanin.clamp(0.0, 1.0);
            s.tissue.blood = s.tissue.blood.clamp(0.0, 1.0);
        }
    }

    /// The first pass: each covered texel's baseline, regional gains, mottling and measured
    /// maps, and what the later passes need (its point and lip mask, the relief's inputs).
    fn baseline(
        &self,
        first: usize,
        row: &mut [BioSample],
        cols: Option<&[usize]>,
        sc: &mut Scratch,
    ) {
        let surface = self.surface;
        sc.row_points.clear();
        sc.relief_in.clear();
        sc.relief_at.clear();
        // The covered texels' points, and the noises there for the whole row at once.
        sc.covered.clear();
        match cols {
            Some(cols) => sc
                .covered
                .extend(cols.iter().copied().filter(|&x| surface.covered(first + x))),
            None => sc
                .covered
                .extend((0..row.len()).filter(|&x| surface.covered(first + x))),
        }
        sc.points.clear();
        sc.points
            .extend(sc.covered.iter().map(|&x| surface.position(first + x)));
        sc.base_noise.resize(sc.points.len(), [0.0; CHANNELS]);
        self.noise
            .eval_many(&sc.points, &mut sc.base_noise, &mut sc.noise_cache);
        if let Some(m) = &self.mottling {
            sc.mottling_noise.resize(sc.points.len(), [0.0; CHANNELS]);
            m.noise()
                .eval_many(&sc.points, &mut sc.mottling_noise, &mut sc.mottling_cache);
        }
        let chans = &self.chans;
        for (k, &x) in sc.covered.iter().enumerate() {
            let s = &mut row[x];
            let i = first + x;
            let p = sc.points[k];
            let n = sc.base_noise[k];
            let v = |c: usize| chans[c].0 + chans[c].1 * n[c];
            *s = BioSample {
                tissue: BioTexel {
                    melanin: v(0),
                    pheomelanin: v(1),
                    blood: v(2),
                    oxygenation: v(3),
                    stratum_corneum_um: v(4),
                    epidermis_um: v(5),
                },
                height_mm: v(6),
                extra: [0.0; 4],
                lips: 0.0,
                furrow_mm: 0.0,
            };
            // Every field this texel reads, sampled through one set of bilinear taps (the
            // fields share a size; others are sampled on their own).
            let uv = surface.uv(i);
            let taps = Taps::uv(self.field_size.0, self.field_size.1, uv.x, uv.y, self.wrap);
            if let Some(r) = &self.regional {
                let at = |k: usize| r[k].sample(&taps);
                s.tissue.blood *= at(0);
                s.tissue.melanin *= at(1);
                s.tissue.oxygenation = (s.tissue.oxygenation + at(2)).clamp(0.0, 1.0);
                s.tissue.epidermis_um *= at(3);
            }
            if let Some(m) = &self.mottling {
                let [b, mel] = m.factors_of(&sc.mottling_noise[k]);
                s.tissue.blood *= b;
                s.tissue.melanin *= mel;
            }
            if let Some(t) = &self.measured.tissue {
                s.tissue = BioTexel {
                    melanin: s.tissue.melanin,
                    blood: s.tissue.blood,
                    ..*t
                };
            }
            if let Some(m) = &self.measured.melanin {
                s.tissue.melanin = m.sample(&taps);
            }
            if let Some(m) = &self.measured.blood {
                s.tissue.blood = m.sample(&taps);
            }
            let (n, [dpdu, dpdv]) = surface.normal_jacobian(i);
            if let Some((_, depth, tension)) = &self.relief {
                let scale = depth.sample(&taps).max(0.0);
                if scale > 0.0 {
                    let t = tension
                        .map(|maps| crate::field::decode_vector_at(maps, &taps))
                        .map_or(glam::Vec3::ZERO, |v| {
                            let d = dpdu * v.dir.x + dpdv * v.dir.y;
                            (d - n * n.dot(d)).normalize_or_zero()
                        });
                    let texel_mm =
                        crate::surface::texel_area(dpdu, dpdv, surface.width, surface.height)
                            .sqrt();
                    sc.relief_in.push(ReliefTexel {
                        p,
                        n,
                        tension: t,
                        scale,
                        texel_mm,
                    });
                    sc.relief_at.push(x);
                }
            }
            let lip = self.lips.as_ref().map_or(0.0, |(m, _)| m.sample(&taps));
            sc.row_points.push((x, PaintPoint { p, n }, lip));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_follow_the_bio_channel_table() {
        let s = BioSample {
            tissue: BioTexel {
                melanin: 0.1,
                pheomelanin: 0.2,
                blood: 0.3,
                oxygenation: 0.4,
                stratum_corneum_um: 15.0,
                epidermis_um: 60.0,
            },
            height_mm: -0.02,
            extra: [0.5, 0.6, 0.7, 0.8],
            lips: 0.9,
            furrow_mm: -0.05,
        };
        let by_table: Vec<f32> = BIO_CHANNELS.iter().map(|(_, f)| f(&s)).collect();
        assert_eq!(s.channels().to_vec(), by_table);
    }
}
