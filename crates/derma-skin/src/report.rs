//! What a `derma skin` run says about itself: report.json (version, seed, inputs with their
//! hashes, counts, statistics, notes and stage timings), numbers as the user wrote them.

use crate::config::{SkinConfig, SurfaceKind};
use crate::feature_set::FeatureCounts;
use crate::paint::BioMaps;
use crate::surface::Surface;
use crate::texture_set::{HeightRange, RenderMaps};
use derma_core::head_mesh::MeshFrame;
use derma_core::map::MapStats;
use derma_core::progress::Log;
use derma_core::report::sha256_file;
use derma_optics::bio::names;
use serde_json::json;
use std::path::PathBuf;

/// The files a run read.
#[derive(Clone, Debug)]
pub struct InputFiles {
    /// The TOML config, when one was read.
    pub config: Option<PathBuf>,
    /// The mesh, when one was used.
    pub mesh: Option<PathBuf>,
    /// The fields directory, when given.
    pub fields: Option<PathBuf>,
    /// The fitted head directory, when given.
    pub head: Option<PathBuf>,
    /// The kind of surface painted.
    pub surface: SurfaceKind,
}

/// What report.json describes.
pub struct Run<'a> {
    /// The configuration used.
    pub config: &'a SkinConfig,
    /// The files read.
    pub inputs: &'a InputFiles,
    /// How a user mesh became derma's frame (its unit or scale, axes and part).
    pub mesh_scale: Option<MeshFrame>,
    /// Worker threads.
    pub threads: usize,
    /// Name of the appearance that made the colours.
    pub appearance: &'a str,
    /// The skin's roughness and F0 and their source.
    pub skin_surface: crate::texture_set::SkinSurface,
    /// The surface painted.
    pub surface: &'a Surface,
    /// The statistics over the covered texels.
    pub statistics: &'a Statistics,
    /// Where each field came from (built-in, uniform, a file, an expression).
    pub field_origins: &'a std::collections::BTreeMap<String, String>,
    /// Features per kind.
    pub counts: FeatureCounts,
    /// Range of height.png.
    pub height_range: HeightRange,
    /// Timings and notes of the whole run.
    pub log: &'a Log,
    /// The set beside a photographed albedo, when one was given.
    pub albedo_comparison: Option<&'a crate::albedo_compare::AlbedoComparison>,
}

/// Texels per block of [`Statistics`]: the blocks' sums are added in order, so the statistics
/// do not depend on the thread count, nor on the bands the texels come in.
const STATS_BLOCK: usize = 1 << 16;

/// Values per texel in report.json's statistics: melanin, pheomelanin, blood, oxygenation,
/// epidermis, height, and the base colour's three linear channels.
const STATS: usize = 9;

/// One block's sum, count, least and greatest value of one statistic.
type Acc = (f64, usize, f32, f32);
const EMPTY: Acc = (0.0, 0, f32::INFINITY, f32::NEG_INFINITY);

/// report.json's statistics over the covered texels, accumulated as texels come: whole
/// ([`Statistics::of_set`]) or band by band (the streamed main job), with the same bits.
pub struct Statistics {
    blocks: Vec<[Acc; STATS]>,
}

impl Statistics {
    /// No texel yet, of a surface of `texels` texels.
    pub fn new(texels: usize) -> Self {
        Self {
            blocks: vec![[EMPTY; STATS]; texels.div_ceil(STATS_BLOCK)],
        }
    }

    /// The statistics of a whole set.
    pub fn of_set(surface: &Surface, bio: &BioMaps, render: &RenderMaps) -> Self {
        let mut s = Self::new(surface.len());
        s.add(surface, 0..surface.len(), |i| {
            values(&bio.texels[i], render.base_color[i])
        });
        s
    }

    /// Adds texels `texels` (each texel once, ranges in increasing order), `values(i)` giving
    /// texel i's; the blocks they fall in are summed in parallel.
    pub fn add(
        &mut self,
        surface: &Surface,
        texels: std::ops::Range<usize>,
        values: impl Fn(usize) -> [f32; STATS] + Sync,
    ) {
        use rayon::prelude::*;
        if texels.is_empty() {
            return;
        }
        let (b0, b1) = (texels.start / STATS_BLOCK, (texels.end - 1) / STATS_BLOCK);
        self.blocks[b0..=b1]
            .par_iter_mut()
            .enumerate()
            .for_each(|(k, acc)| {
                let b = b0 + k;
                let lo = texels.start.max(b * STATS_BLOCK);
                let hi = texels.end.min((b + 1) * STATS_BLOCK);
                for i in (lo..hi).filter(|&i| surface.covered(i)) {
                    for (a, v) in acc.iter_mut().zip(values(i)) {
                        *a = (a.0 + v as f64, a.1 + 1, a.2.min(v), a.3.max(v));
                    }
                }
            });
    }

    /// The statistics, the blocks added in order.
    pub fn finish(&self) -> [MapStats; STATS] {
        std::array::from_fn(|c| {
            let (sum, n, lo, hi) = self.blocks.iter().fold(EMPTY, |t, b| {
                let a = b[c];
                (t.0 + a.0, t.1 + a.1, t.2.min(a.2), t.3.max(a.3))
            });
            MapStats {
                mean: if n > 0 { sum / n as f64 } else { 0.0 },
                min: lo,
                max: hi,
                count: n,
            }
        })
    }
}

/// The statistics' values of one texel: its sample and its base colour's code.
pub fn values(s: &crate::features::BioSample, c: [u8; 3]) -> [f32; STATS] {
    let srgb = derma_core::color::srgb8_decode;
    let t = &s.tissue;
    [
        t.melanin,
        t.pheomelanin,
        t.blood,
        t.oxygenation,
        t.epidermis_um,
        s.height_mm,
        srgb(c[0]),
        srgb(c[1]),
        srgb(c[2]),
    ]
}

/// report.json of a run.
pub fn report(set: &Run) -> serde_json::Value {
    let [mel, pheo, blood, oxy, epi, height, r, g, b] = set.statistics.finish();
    let file = |p: &Option<std::path::PathBuf>| {
        p.as_ref()
            .map(|p| json!({"path": p.display().to_string(), "sha256": sha256_file(p)}))
    };
    let mut mesh = file(&set.inputs.mesh);
    if let (Some(m), Some(scale)) = (mesh.as_mut(), set.mesh_scale.as_ref()) {
        m["unit"] = json!(scale.unit.map_or("fit", |u| u.name()));
        m["mm_per_unit"] = json!(derma_core::report::as_written(scale.mm_per_unit as f64));
        m["axes"] = json!(scale.axes_in_words());
        if let Some(p) = &scale.part {
            m["part"] = json!(p);
        }
    }
    let surface = match set.inputs.surface {
        SurfaceKind::Template => "template",
        SurfaceKind::Patch => "patch",
        SurfaceKind::Mesh => "mesh",
    };
    let mut report = json!({
        "derma_version": env!("CARGO_PKG_VERSION"),
        "command": "skin",
        "seed": set.config.seed,
        "size": set.config.size,
        "threads": set.threads,
        "appearance": set.appearance,
        "skin_surface": set.skin_surface,
        "inputs": {
            "config": file(&set.inputs.config),
            "mesh": mesh,
            "fields": set.inputs.fields.as_ref().map(|p| p.display().to_string()),
            "field_origins": set.field_origins,
            "head": set.inputs.head.as_ref().map(|p| json!({"path": p.display().to_string(), "sha256": sha256_file(&p.join("head.json"))})),
            "surface": surface,
        },
        "config": set.config,
        "surface_area_cm2": set.surface.area_mm2() / 100.0,
        "counts": set.counts,
        "height_range": set.height_range,
        "statistics": {
            names::MELANIN: mel,
            names::PHEOMELANIN: pheo,
            names::BLOOD: blood,
            names::OXYGENATION: oxy,
            names::EPIDERMIS_UM: epi,
            "height_mm": height,
            "base_color_linear": [r, g, b],
        },
        "notes": set.log.notes,
        "timings_s": set.log.timings,
    });
    if let Some(c) = set.albedo_comparison {
        report["albedo_comparison"] = json!(c);
    }
    report
}
