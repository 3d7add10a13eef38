//! The main job end to end: surface → fields → features → bio maps → texture set → files, with
//! per-stage timings. Orchestration only; the physics lives in the modules it calls.

use crate::config::{SkinConfig, SurfaceKind};
use crate::field::FieldSet;
use crate::paint::BioMaps;
use crate::placement::FeatureSet;
use crate::surface::Surface;
use crate::texture_set::{OutputEntry, RenderMaps};
use crate::{Result, SkinError};
use derma_core::mesh::{LengthUnit, TriMesh};
use derma_core::Map;
use derma_shading::Appearance;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Every file `derma skin` writes into its output directory.
pub const OUTPUT_FILES: [&str; 15] = [
    "base_color.png",
    "sss_color.png",
    "sss_radius.png",
    "normal.png",
    "height.exr",
    "height.png",
    "roughness.png",
    "specular.png",
    "melanin.exr",
    "hemoglobin.exr",
    "bio.exr",
    "features.json",
    "preview.png",
    "manifest.json",
    "report.json",
];

/// Which bio → render conversion the texture set uses.
#[derive(Clone, Default)]
pub enum AppearanceChoice {
    /// The built-in Monte Carlo match table (derma's default).
    #[default]
    Default,
    /// The analytic spectral Kubelka–Munk model.
    Analytic,
    /// A match table read by the caller.
    Table(std::sync::Arc<derma_shading::TableAppearance>),
}

impl std::fmt::Debug for AppearanceChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            AppearanceChoice::Default => "Default",
            AppearanceChoice::Analytic => "Analytic",
            AppearanceChoice::Table(_) => "Table",
        })
    }
}

/// Files given on the command line (they override the config's `surface.mesh`).
#[derive(Clone, Debug, Default)]
pub struct Inputs {
    pub appearance: AppearanceChoice,
    pub mesh: Option<PathBuf>,
    pub fields_dir: Option<PathBuf>,
    /// Directory relative to which paths in the config are resolved.
    pub config_dir: Option<PathBuf>,
}

/// Progress reporting (the CLI shows bars; libraries never print).
pub trait Progress: Sync {
    fn stage(&self, _name: &str, _total: u64) {}
    fn advance_to(&self, _done: u64) {}
    fn note(&self, _message: &str) {}
}

/// Progress that ignores everything.
pub struct NoProgress;
impl Progress for NoProgress {}

/// Everything the main job produced, in memory.
pub struct Generated {
    pub surface: Surface,
    pub fields: FieldSet,
    pub features: FeatureSet,
    pub bio: BioMaps,
    pub render: RenderMaps,
    pub dilation: Option<Vec<u32>>,
    pub notes: Vec<String>,
    pub timings: Vec<(String, f64)>,
    pub surface_area_mm2: f64,
    pub mesh_unit: Option<LengthUnit>,
    /// Mesh and tangents used for the preview (template, user mesh, or none for patches).
    pub preview_mesh: Option<(TriMesh, Vec<[f32; 4]>)>,
    pub appearance: &'static str,
}

/// Bytes of memory per output texel at the pipeline's peak: measured peak resident memory of
/// `derma skin` on the built-in head was 0.92 GB at 2048² and 3.18 GB at 4096², i.e. 184 bytes
/// per added texel (bio samples 48, render maps 36, surface raster 24, file encoding buffers);
/// rounded up for a margin.
pub const BYTES_PER_TEXEL: f64 = 200.0;

fn available_memory_bytes() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Fails early when a `size`² texture set would not fit in memory.
pub fn check_memory(size: usize) -> Result<()> {
    let need = BYTES_PER_TEXEL * (size * size) as f64;
    if let Some(have) = available_memory_bytes() {
        if need > 0.9 * have {
            return Err(SkinError::TooLarge {
                width: size,
                height: size,
                need_gib: need / 1073741824.0,
                have_gib: have / 1073741824.0,
            });
        }
    }
    Ok(())
}

fn resolve(inputs: &Inputs, p: &str) -> PathBuf {
    let p = Path::new(p);
    match (&inputs.config_dir, p.is_absolute()) {
        (Some(d), false) => d.join(p),
        _ => p.to_path_buf(),
    }
}

/// Loads a mesh, detects its unit and reports overlaps.
fn load_mesh(path: &Path, unit: &str, notes: &mut Vec<String>) -> Result<(TriMesh, LengthUnit)> {
    let mut mesh = TriMesh::load(path)?;
    let extent = mesh.extent();
    let unit = match unit {
        "auto" => {
            let u = LengthUnit::guess_from_extent(extent);
            notes.push(format!(
                "mesh '{}': largest extent {extent:.3} units, read as {} (a head is 150–250 mm; set surface.unit to override)",
                path.display(),
                match u {
                    LengthUnit::Mm => "millimetres",
                    LengthUnit::Cm => "centimetres",
                    LengthUnit::M => "metres",
                }
            ));
            u
        }
        "mm" => LengthUnit::Mm,
        "cm" => LengthUnit::Cm,
        "m" => LengthUnit::M,
        other => {
            return Err(SkinError::Config {
                file: "surface.unit".into(),
                detail: format!("'{other}': expected auto, mm, cm or m"),
            })
        }
    };
    mesh.to_millimetres(unit);
    Ok((mesh, unit))
}

/// Runs the main job in memory.
pub fn generate(cfg: &SkinConfig, inputs: &Inputs, progress: &dyn Progress) -> Result<Generated> {
    cfg.validate("config")?;
    let size = cfg.size as usize;
    check_memory(size)?;
    let mut timings = Vec::new();
    let mut notes = Vec::new();
    let mut t0 = Instant::now();
    let mut lap = |name: &str, timings: &mut Vec<(String, f64)>| {
        timings.push((name.to_string(), t0.elapsed().as_secs_f64()));
        t0 = Instant::now();
    };

    // Surface.
    progress.stage("surface", 1);
    let mesh_path = inputs.mesh.clone().or_else(|| {
        (cfg.surface.kind == SurfaceKind::Mesh && !cfg.surface.mesh.is_empty())
            .then(|| resolve(inputs, &cfg.surface.mesh))
    });
    let kind = if mesh_path.is_some() {
        SurfaceKind::Mesh
    } else {
        cfg.surface.kind
    };
    if kind == SurfaceKind::Mesh && mesh_path.is_none() {
        return Err(SkinError::Config {
            file: "surface.kind".into(),
            detail: "\"mesh\" needs surface.mesh or --mesh".into(),
        });
    }
    let mut mesh_unit = None;
    let mut fields = FieldSet::default();
    let (mesh, template) = match kind {
        SurfaceKind::Template => (Some(crate::template::head_mesh()), true),
        SurfaceKind::Mesh => {
            let p = mesh_path.expect("checked");
            let (m, u) = load_mesh(&p, &cfg.surface.unit, &mut notes)?;
            mesh_unit = Some(u);
            (Some(m), false)
        }
        SurfaceKind::Patch => (None, false),
    };
    let (surface, scatter_surface, preview_mesh) = match &mesh {
        Some(m) => {
            let tangents = crate::surface::mikktspace_tangents(m);
            let s = Surface::mesh(m, &tangents, size, size);
            let sr = cfg.scatter_resolution as usize;
            let ss = Surface::mesh(m, &tangents, sr, sr);
            if let Some(ms) = s.mesh_surface() {
                if ms.raster.overlapping_triangles > 0 {
                    notes.push(format!(
                        "warning: {} triangles overlap others in UV space; overlapping texels take the triangle nearest its interior, so the other surface goes unpainted",
                        ms.raster.overlapping_triangles
                    ));
                }
                if ms.raster.triangles_outside_unit_square > 0 {
                    notes.push(format!("warning: {} triangles have UVs outside [0, 1]; only the part inside is painted", ms.raster.triangles_outside_unit_square));
                }
                if ms.raster.coverage() == 0.0 {
                    return Err(SkinError::Mesh {
                        path: "mesh".into(),
                        detail: "no triangle covers any texel (degenerate UVs?)".into(),
                    });
                }
            }
            (s, ss, Some((m.clone(), tangents)))
        }
        None => {
            let [w, h] = cfg.surface.patch_size_mm;
            let sr = cfg.scatter_resolution as usize;
            (
                Surface::patch(size, size, [w, h], cfg.surface.tileable),
                Surface::patch(sr, sr, [w, h], cfg.surface.tileable),
                None,
            )
        }
    };
    let dilation = surface.dilation();
    lap("surface", &mut timings);

    // Fields: template defaults, or uniform ones; then a fields directory; then config entries.
    progress.stage("fields", 1);
    if template {
        fields = crate::template::default_fields(mesh.as_ref().expect("template mesh"));
    } else {
        uniform_fields(&mut fields);
        if inputs.fields_dir.is_none() && cfg.fields.is_empty() {
            notes.push(
                "no --fields given: uniform fields are used (moles, freckles, cysts and pores everywhere; no lips, hair or wrinkles); paint fields to place them".into(),
            );
        }
    }
    if let Some(dir) = &inputs.fields_dir {
        fields.load_dir(dir)?;
    }
    for (name, value) in &cfg.fields {
        let v = value.trim();
        let lower = v.to_ascii_lowercase();
        if lower.ends_with(".png") || lower.ends_with(".exr") {
            fields.load_file(name, &resolve(inputs, v))?;
        } else {
            fields.define(name, v)?;
        }
    }
    notes.append(&mut fields.notes);
    lap("fields", &mut timings);

    progress.stage("scatter", 1);
    let features = crate::placement::place(cfg, &fields, &scatter_surface, size)?;
    drop(scatter_surface);
    lap("scatter+index", &mut timings);

    progress.stage("paint", size as u64);
    let mut bio = crate::paint::paint(cfg, &surface, &fields, &features, &|rows| {
        progress.advance_to(rows as u64)
    })?;
    lap("paint", &mut timings);
    if cfg.detail.enabled() {
        progress.stage("detail", 1);
        let path = |p: &str| (!p.trim().is_empty()).then(|| resolve(inputs, p.trim()));
        let (h, a) = (path(&cfg.detail.height), path(&cfg.detail.albedo));
        let tile = crate::detail::build(&cfg.detail, h.as_deref(), a.as_deref(), cfg.seed)?;
        tile.apply(&cfg.detail, &mut bio.texels, bio.width);
        lap("detail", &mut timings);
    }
    if let Some(src) = &dilation {
        bio.dilate(src);
    }

    progress.stage("convert", 1);
    let analytic;
    let builtin;
    let appearance: &dyn Appearance = match &inputs.appearance {
        AppearanceChoice::Analytic => {
            analytic = derma_shading::SpectralKubelkaMunk::default();
            &analytic
        }
        AppearanceChoice::Default => {
            builtin = derma_shading::TableAppearance::builtin();
            &builtin
        }
        AppearanceChoice::Table(t) => t.as_ref(),
    };
    let render = crate::texture_set::convert(
        &bio,
        &surface,
        appearance,
        &cfg.material,
        dilation.as_deref(),
    );
    lap("convert", &mut timings);

    Ok(Generated {
        surface_area_mm2: surface.area_mm2(),
        surface,
        fields,
        features,
        bio,
        render,
        dilation,
        notes,
        timings,
        mesh_unit,
        preview_mesh,
        appearance: appearance.name(),
    })
}

/// Uniform defaults for surfaces without painted fields.
fn uniform_fields(f: &mut FieldSet) {
    let one = |v: f32| Map::filled(4, 4, v);
    for name in ["moles", "freckles", "cysts", "pores", "face"] {
        f.scalars.insert(name.into(), one(1.0));
    }
    for name in ["lips", "scalp", "eyebrows", "wrinkles", "eyes"] {
        f.scalars.insert(name.into(), one(0.0));
    }
    f.vectors
        .insert("wrinkle_vectors".into(), [one(0.5), one(0.5), one(0.0)]);
}

/// Writes the texture set, features.json and preview.png into `dir`; returns the manifest entries.
pub fn write_outputs(
    dir: &Path,
    g: &Generated,
    timings: &mut Vec<(String, f64)>,
) -> Result<(Vec<OutputEntry>, crate::texture_set::HeightRange)> {
    let t = Instant::now();
    let (mut entries, range) = crate::texture_set::write_maps(dir, &g.bio, &g.render)?;
    let features = serde_json::to_vec(&g.features.to_json()).map_err(|e| SkinError::Field {
        name: "features.json".into(),
        detail: e.to_string(),
    })?;
    derma_core::atomic::write_bytes(&dir.join("features.json"), &features)?;
    entries.push(OutputEntry {
        file: "features.json".into(),
        colour_space: "-".into(),
        meaning: "every placed feature with its parameters (mm)".into(),
    });
    timings.push(("encode/write".into(), t.elapsed().as_secs_f64()));

    let t = Instant::now();
    let preview = preview_image(g);
    derma_core::image_io::write_png8(
        &dir.join("preview.png"),
        &[&preview[0], &preview[1], &preview[2]],
    )?;
    entries.push(OutputEntry {
        file: "preview.png".into(),
        colour_space: "sRGB".into(),
        meaning: "shaded preview and a contact sheet of the maps".into(),
    });
    timings.push(("preview".into(), t.elapsed().as_secs_f64()));
    Ok((entries, range))
}

/// Shaded views plus the contact sheet (base colour, normal, height, roughness, melanin, blood).
pub fn preview_image(g: &Generated) -> [Map; 3] {
    use crate::preview::{compose, normalised, render, sphere, tile, Textures};
    const PANEL: usize = 512;
    let r = &g.render;
    let renders = match &g.preview_mesh {
        Some((m, t)) => {
            let tex = Textures {
                maps: r,
                wrap: false,
                uv_scale: glam::Vec2::ONE,
            };
            vec![
                render(m, t, &tex, 0.0, PANEL),
                render(m, t, &tex, 0.6, PANEL),
            ]
        }
        None => {
            let (sx, sy) = match &g.surface.geometry {
                crate::surface::Geometry::Patch { size_mm, .. } => (size_mm[0], size_mm[1]),
                _ => (1.0, 1.0),
            };
            // A sphere of radius 1.2 patch widths, the patch repeated at its physical size.
            let radius = 1.2 * sx;
            let (sm, st) = sphere(radius, 96);
            let scale = glam::Vec2::new(
                2.0 * std::f32::consts::PI * radius / sx,
                std::f32::consts::PI * radius / sy,
            );
            let (tm, tt) = tile(sx);
            vec![
                render(
                    &sm,
                    &st,
                    &Textures {
                        maps: r,
                        wrap: true,
                        uv_scale: scale,
                    },
                    0.0,
                    PANEL,
                ),
                render(
                    &tm,
                    &tt,
                    &Textures {
                        maps: r,
                        wrap: true,
                        uv_scale: glam::Vec2::ONE,
                    },
                    0.0,
                    PANEL,
                ),
            ]
        }
    };
    // Thumbnails are downsampled first (area-averaged), then encoded or normalised.
    let t = PANEL / 2;
    let small = |m: &Map| m.resized(t, t);
    let enc = |m: &Map| {
        let mut m = small(m);
        m.data_mut()
            .iter_mut()
            .for_each(|v| *v = derma_core::color::srgb_encode(*v));
        m
    };
    let half = |m: &Map| {
        let mut m = small(m);
        m.data_mut().iter_mut().for_each(|v| *v = 0.5 * *v + 0.5);
        m
    };
    let rough = small(&r.roughness);
    let sheet = vec![
        [
            enc(&r.base_color[0]),
            enc(&r.base_color[1]),
            enc(&r.base_color[2]),
        ],
        [half(&r.normal[0]), half(&r.normal[1]), half(&r.normal[2])],
        normalised(&small(&r.height_mm)),
        [rough.clone(), rough.clone(), rough],
        normalised(&small(&g.bio.channel(|s| s.melanin))),
        normalised(&small(&g.bio.channel(|s| s.blood))),
    ];
    compose(&renders, &sheet, PANEL)
}
