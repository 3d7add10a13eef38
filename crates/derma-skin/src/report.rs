//! What a `derma skin` run says about itself: manifest.json (every file with its colour space
//! and meaning, for engines and pipelines) and report.json (version, seed, inputs with their
//! hashes, counts, statistics, notes and stage timings), numbers as the user wrote them.

use crate::config::{SkinConfig, SurfaceKind};
use crate::feature_set::FeatureCounts;
use crate::outputs;
use crate::paint::BioMaps;
use crate::surface::Surface;
use crate::texture_set::{HeightRange, RenderMaps};
use derma_core::map::MapStats;
use derma_core::mesh::MeshScale;
use derma_core::progress::Log;
use derma_core::report::{pretty_json, sha256_file};
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
    /// The kind of surface painted.
    pub surface: SurfaceKind,
}

/// What report.json describes.
pub struct Run<'a> {
    /// The configuration used.
    pub config: &'a SkinConfig,
    /// The files read.
    pub inputs: &'a InputFiles,
    /// How a user mesh became millimetres (its unit, or the fitted scale).
    pub mesh_scale: Option<MeshScale>,
    /// Worker threads.
    pub threads: usize,
    /// Name of the appearance that made the colours.
    pub appearance: &'a str,
    /// The surface (its chart coverage masks the statistics).
    pub surface: &'a Surface,
    /// The painted bio maps.
    pub bio: &'a BioMaps,
    /// The render maps (the base colour's statistics).
    pub render: &'a RenderMaps,
    /// Features per kind.
    pub counts: FeatureCounts,
    /// Range of height.png.
    pub height_range: HeightRange,
    /// Timings and notes of the whole run.
    pub log: &'a Log,
}

/// manifest.json of a `size`² set listing `files` (the maps, features.json, preview.png and
/// report.json).
pub fn manifest(size: u32, files: &[&str]) -> Vec<u8> {
    let maps: Vec<&outputs::OutputFile> = files.iter().filter_map(|f| outputs::output(f)).collect();
    let manifest = json!({
        "generator": format!("derma {}", env!("CARGO_PKG_VERSION")),
        "size": [size, size],
        "conventions": {
            "uv": "OpenGL: v up; row 0 of every image is v = 1",
            "normal": "tangent space, OpenGL +Y (green up); MikkTSpace tangents on meshes",
            "lengths": "mm"
        },
        "maps": maps,
    });
    pretty_json(&manifest).expect("the manifest serializes")
}

/// report.json of a run.
pub fn report(set: &Run) -> Vec<u8> {
    let covered = |i: usize| set.surface.covered(i);
    let stat = |f: fn(&crate::features::BioSample) -> f32| {
        MapStats::of(
            set.bio
                .texels
                .iter()
                .enumerate()
                .filter(|(i, _)| covered(*i))
                .map(|(_, s)| f(s)),
        )
    };
    let bc = |k: usize| {
        MapStats::of(
            set.render
                .base_color
                .iter()
                .enumerate()
                .filter(|(i, _)| covered(*i))
                .map(|(_, c)| derma_core::color::srgb8_decode(c[k])),
        )
    };
    let file = |p: &Option<std::path::PathBuf>| {
        p.as_ref()
            .map(|p| json!({"path": p.display().to_string(), "sha256": sha256_file(p)}))
    };
    let mut mesh = file(&set.inputs.mesh);
    if let (Some(m), Some(scale)) = (mesh.as_mut(), set.mesh_scale) {
        m["unit"] = json!(scale.unit.map_or("fit", |u| u.name()));
        m["mm_per_unit"] = json!(derma_core::report::as_written(scale.mm_per_unit as f64));
    }
    let surface = match set.inputs.surface {
        SurfaceKind::Template => "template",
        SurfaceKind::Patch => "patch",
        SurfaceKind::Mesh => "mesh",
    };
    let report = json!({
        "derma_version": env!("CARGO_PKG_VERSION"),
        "command": "skin",
        "seed": set.config.seed,
        "size": set.config.size,
        "threads": set.threads,
        "appearance": set.appearance,
        "inputs": {
            "config": file(&set.inputs.config),
            "mesh": mesh,
            "fields": set.inputs.fields.as_ref().map(|p| p.display().to_string()),
            "surface": surface,
        },
        "config": set.config,
        "surface_area_cm2": set.surface.area_mm2() / 100.0,
        "counts": set.counts,
        "height_range": set.height_range,
        "statistics": {
            names::MELANIN: stat(|s| s.tissue.melanin),
            names::PHEOMELANIN: stat(|s| s.tissue.pheomelanin),
            names::BLOOD: stat(|s| s.tissue.blood),
            names::OXYGENATION: stat(|s| s.tissue.oxygenation),
            names::EPIDERMIS_UM: stat(|s| s.tissue.epidermis_um),
            "height_mm": stat(|s| s.height_mm),
            "base_color_linear": [bc(0), bc(1), bc(2)],
        },
        "notes": set.log.notes,
        "timings_s": set.log.timings,
    });
    pretty_json(&report).expect("the report serializes")
}
