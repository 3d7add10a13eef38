//! What a `derma skin` run says about itself: manifest.json (every file with its colour space
//! and meaning, for engines and pipelines) and report.json (version, seed, inputs with their
//! hashes, counts, statistics, notes and stage timings), numbers as the user wrote them.

use crate::config::SurfaceKind;
use crate::generate::TextureSet;
use crate::outputs;
use crate::texture_set::HeightRange;
use derma_core::progress::Log;
use derma_core::report::{pretty_json, sha256_file};
use derma_optics::bio::names;
use serde_json::json;

/// manifest.json listing `files` (the maps, features.json, preview.png and report.json).
pub fn manifest(set: &TextureSet, files: &[&str]) -> Vec<u8> {
    let maps: Vec<&outputs::OutputFile> = files.iter().filter_map(|f| outputs::output(f)).collect();
    let manifest = json!({
        "generator": format!("derma {}", env!("CARGO_PKG_VERSION")),
        "size": [set.config.size, set.config.size],
        "conventions": {
            "uv": "OpenGL: v up; row 0 of every image is v = 1",
            "normal": "tangent space, OpenGL +Y (green up); MikkTSpace tangents on meshes",
            "lengths": "mm"
        },
        "maps": maps,
    });
    pretty_json(&manifest).expect("the manifest serializes")
}

/// report.json of `set` with the whole run's `log`.
pub fn report(set: &TextureSet, height_range: &HeightRange, log: &Log) -> Vec<u8> {
    let mask: Option<Vec<bool>> = set
        .surface
        .mesh_surface()
        .map(|m| (0..set.surface.len()).map(|i| m.raster.covered(i)).collect());
    let stat = |f: fn(&crate::features::BioSample) -> f32| {
        set.bio.channel(f).stats(mask.as_deref())
    };
    let bc = &set.render.base_color;
    let file = |p: &Option<std::path::PathBuf>| {
        p.as_ref()
            .map(|p| json!({"path": p.display().to_string(), "sha256": sha256_file(p)}))
    };
    let mut mesh = file(&set.inputs.mesh);
    if let (Some(m), Some(unit)) = (mesh.as_mut(), set.mesh_unit) {
        m["unit"] = json!(unit);
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
        "threads": set.threads(),
        "appearance": set.appearance,
        "inputs": {
            "config": file(&set.inputs.config),
            "mesh": mesh,
            "fields": set.inputs.fields.as_ref().map(|p| p.display().to_string()),
            "surface": surface,
        },
        "config": set.config,
        "surface_area_cm2": set.surface_area_mm2 / 100.0,
        "counts": set.features.counts(),
        "height_range": height_range,
        "statistics": {
            names::MELANIN: stat(|s| s.tissue.melanin),
            names::PHEOMELANIN: stat(|s| s.tissue.pheomelanin),
            names::BLOOD: stat(|s| s.tissue.blood),
            names::OXYGENATION: stat(|s| s.tissue.oxygenation),
            names::EPIDERMIS_UM: stat(|s| s.tissue.epidermis_um),
            "height_mm": stat(|s| s.height_mm),
            "base_color_linear": [bc[0].stats(mask.as_deref()), bc[1].stats(mask.as_deref()), bc[2].stats(mask.as_deref())],
        },
        "notes": log.notes,
        "timings_s": log.timings,
    });
    pretty_json(&report).expect("the report serializes")
}
