//! `derma skin`: the main job.

use anyhow::{bail, Context, Result};
use clap::Args;
use derma_skin::config::{SkinConfig, SurfaceKind};
use derma_skin::generate::{generate, write_outputs, Inputs, Progress};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args)]
pub struct SkinArgs {
    /// Output directory (created if needed; existing texture files in it are replaced atomically).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Texture size in texels (square). Overrides `size` in the config.
    #[arg(long)]
    size: Option<u32>,
    /// Random seed. Overrides `seed` in the config.
    #[arg(long)]
    seed: Option<u64>,
    /// Mesh with UVs (OBJ, glTF, GLB) instead of the built-in head.
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// Directory of fields: NAME.png / NAME.exr (greyscale), NAME_vectors.png (RGB vector fields).
    #[arg(long)]
    fields: Option<PathBuf>,
    /// TOML configuration (see --print-config).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Worker threads (default: all cores). Outputs are identical for any value.
    #[arg(long)]
    threads: Option<usize>,
    /// A flat patch of this size in mm (WxH or W) instead of the head.
    #[arg(long, value_name = "WxH")]
    patch: Option<String>,
    /// With --patch: do not wrap (by default patches tile seamlessly).
    #[arg(long)]
    no_tile: bool,
    /// Print the full default configuration with units and sources, then exit.
    #[arg(long)]
    print_config: bool,
    /// Write the built-in head (head.obj, mm) and its default fields (PNG) into DIR, then exit:
    /// paint over the fields and run `derma skin --mesh DIR/head.obj --fields DIR`.
    #[arg(long, value_name = "DIR")]
    export_template: Option<PathBuf>,
    /// Bio → render conversion: `table` (the Monte Carlo match table, default; adds
    /// sss_color.png and sss_radius.png) or `analytic` (spectral Kubelka–Munk, colour only).
    #[arg(long, value_enum, default_value = "table")]
    appearance: AppearanceArg,
    /// A match table from `derma match fit` instead of the built-in one (implies table).
    #[arg(long, value_name = "FILE.dtab")]
    table: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AppearanceArg {
    Table,
    Analytic,
}

struct Bars {
    bar: Option<ProgressBar>,
    quiet: bool,
}

impl Progress for Bars {
    fn stage(&self, name: &str, total: u64) {
        if let Some(b) = &self.bar {
            b.set_length(total);
            b.set_position(0);
            b.set_message(name.to_string());
        }
    }
    fn advance_to(&self, done: u64) {
        if let Some(b) = &self.bar {
            b.set_position(done.max(b.position()));
        }
    }
    fn note(&self, message: &str) {
        if !self.quiet {
            eprintln!("{message}");
        }
    }
}

fn parse_patch(s: &str) -> Result<[f32; 2]> {
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    let num = |t: &str| {
        t.trim()
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite() && *v > 0.0)
    };
    match parts.as_slice() {
        [w] => num(w).map(|w| [w, w]),
        [w, h] => num(w).zip(num(h)).map(|(w, h)| [w, h]),
        _ => None,
    }
    .with_context(|| format!("--patch '{s}': expected a size in mm such as 40 or 40x30"))
}

fn sha256_file(p: &Path) -> Option<String> {
    let bytes = std::fs::read(p).ok()?;
    Some(format!("{:x}", Sha256::digest(&bytes)))
}

pub fn run(args: SkinArgs, quiet: bool) -> Result<()> {
    if args.print_config {
        print!("{}", SkinConfig::print_default());
        return Ok(());
    }
    if let Some(dir) = &args.export_template {
        let files = derma_skin::template::export(dir)
            .with_context(|| format!("cannot export the template to '{}'", dir.display()))?;
        if !quiet {
            eprintln!(
                "wrote {} files to {}: {}",
                files.len(),
                dir.display(),
                files.join(", ")
            );
        }
        return Ok(());
    }
    let start = Instant::now();
    let mut cfg = match &args.config {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read config '{}'", p.display()))?;
            SkinConfig::from_toml(&text, &p.display().to_string())?
        }
        None => SkinConfig::default(),
    };
    if let Some(s) = args.size {
        cfg.size = s;
    }
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    if let Some(p) = &args.patch {
        cfg.surface.kind = SurfaceKind::Patch;
        cfg.surface.patch_size_mm = parse_patch(p)?;
        cfg.surface.tileable = !args.no_tile;
    }
    if args.mesh.is_some() && args.patch.is_some() {
        bail!("--mesh and --patch exclude each other");
    }
    cfg.validate(
        &args
            .config
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| "command line".into()),
    )?;
    for (flag, p) in [("--mesh", &args.mesh), ("--fields", &args.fields)] {
        if let Some(p) = p {
            if !p.exists() {
                bail!("{flag} '{}' does not exist", p.display());
            }
        }
    }
    // Refuse to write into an input's directory entries: outputs have fixed names, inputs must
    // never be overwritten.
    derma_core::atomic::ensure_writable_dir(&args.out)
        .with_context(|| format!("output directory '{}' is not writable", args.out.display()))?;
    let out_canon = std::fs::canonicalize(&args.out)?;
    for input in [&args.mesh, &args.config].into_iter().flatten() {
        if let Ok(c) = std::fs::canonicalize(input) {
            if c.parent() == Some(out_canon.as_path())
                && derma_skin::generate::OUTPUT_FILES
                    .iter()
                    .any(|n| c.file_name().is_some_and(|f| f == *n))
            {
                bail!(
                    "input '{}' would be overwritten by an output; choose another --out",
                    input.display()
                );
            }
        }
    }
    if let Some(f) = &args.fields {
        if std::fs::canonicalize(f).ok().as_deref() == Some(out_canon.as_path()) {
            bail!("--fields and --out are the same directory '{}'; outputs could overwrite painted fields", f.display());
        }
    }
    derma_skin::generate::check_memory(cfg.size as usize)?;

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let bar = if quiet {
        None
    } else {
        let b = ProgressBar::new(1);
        b.set_style(
            ProgressStyle::with_template("{spinner} {msg:>8} [{bar:30}] {pos}/{len} {elapsed}")
                .expect("template")
                .progress_chars("=> "),
        );
        Some(b)
    };
    let progress = Bars { bar, quiet };
    let appearance = match (&args.table, args.appearance) {
        (Some(_), AppearanceArg::Analytic) => {
            bail!("--table and --appearance analytic contradict each other")
        }
        (Some(p), _) => derma_skin::generate::AppearanceChoice::Table(std::sync::Arc::new(
            derma_shading::TableAppearance::read(p)
                .with_context(|| format!("reading match table {}", p.display()))?,
        )),
        (None, AppearanceArg::Table) => derma_skin::generate::AppearanceChoice::Default,
        (None, AppearanceArg::Analytic) => derma_skin::generate::AppearanceChoice::Analytic,
    };
    let inputs = Inputs {
        appearance,
        mesh: args.mesh.clone(),
        fields_dir: args.fields.clone(),
        config_dir: args
            .config
            .as_ref()
            .and_then(|p| p.parent().map(Path::to_path_buf)),
    };
    let (generated, entries, range, mut timings) = pool.install(|| -> Result<_> {
        let g = generate(&cfg, &inputs, &progress)?;
        let mut timings = g.timings.clone();
        progress.stage("write", 1);
        let (entries, range) = write_outputs(&args.out, &g, &mut timings)?;
        Ok((g, entries, range, timings))
    })?;
    if let Some(b) = &progress.bar {
        b.finish_and_clear();
    }
    for n in &generated.notes {
        progress.note(n);
    }
    timings.push(("total".into(), start.elapsed().as_secs_f64()));

    // manifest.json and report.json
    let mut manifest: Vec<serde_json::Value> = entries
        .iter()
        .map(|e| serde_json::to_value(e).expect("serializable"))
        .collect();
    manifest.push(json!({"file": "report.json", "colour_space": "-", "meaning": "run report: version, seed, inputs with hashes, counts, statistics, timings"}));
    let manifest = json!({
        "generator": format!("derma {}", env!("CARGO_PKG_VERSION")),
        "size": [cfg.size, cfg.size],
        "conventions": {
            "uv": "OpenGL: v up; row 0 of every image is v = 1",
            "normal": "tangent space, OpenGL +Y (green up); MikkTSpace tangents on meshes",
            "lengths": "mm"
        },
        "maps": manifest,
    });
    derma_core::atomic::write_bytes(
        &args.out.join("manifest.json"),
        serde_json::to_string_pretty(&manifest)?.as_bytes(),
    )?;

    let mask: Option<Vec<bool>> = generated.surface.mesh_surface().map(|m| {
        (0..generated.surface.len())
            .map(|i| m.raster.covered(i))
            .collect()
    });
    let stat = |f: fn(&derma_skin::features::BioSample) -> f32| {
        generated.bio.channel(f).stats(mask.as_deref())
    };
    let bc = &generated.render.base_color;
    let inputs_json = json!({
        "config": args.config.as_ref().map(|p| json!({"path": p.display().to_string(), "sha256": sha256_file(p)})),
        "mesh": args.mesh.as_ref().map(|p| json!({"path": p.display().to_string(), "sha256": sha256_file(p), "unit": generated.mesh_unit})),
        "fields": args.fields.as_ref().map(|p| p.display().to_string()),
        "surface": format!("{:?}", if args.mesh.is_some() { SurfaceKind::Mesh } else { cfg.surface.kind }).to_lowercase(),
    });
    let report = json!({
        "derma_version": env!("CARGO_PKG_VERSION"),
        "command": "skin",
        "seed": cfg.seed,
        "size": cfg.size,
        "threads": pool.current_num_threads(),
        "appearance": generated.appearance,
        "inputs": inputs_json,
        "config": serde_json::to_value(&cfg)?,
        "surface_area_cm2": generated.surface_area_mm2 / 100.0,
        "counts": generated.features.counts(),
        "height_range": range,
        "statistics": {
            "melanin": stat(|s| s.melanin),
            "pheomelanin": stat(|s| s.pheomelanin),
            "blood": stat(|s| s.blood),
            "oxygenation": stat(|s| s.oxygenation),
            "epidermis_um": stat(|s| s.epidermis_um),
            "height_mm": stat(|s| s.height_mm),
            "base_color_linear": [bc[0].stats(mask.as_deref()), bc[1].stats(mask.as_deref()), bc[2].stats(mask.as_deref())],
        },
        "notes": generated.notes,
        "timings_s": timings.iter().map(|(k, v)| json!({"stage": k, "seconds": v})).collect::<Vec<_>>(),
    });
    derma_core::atomic::write_bytes(
        &args.out.join("report.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    if !quiet {
        let c = generated.features.counts();
        eprintln!(
            "wrote {} ({}², {} features: {} follicles, {} eyebrow hairs, {} freckles, {} moles, {} cysts, {} pores, {} wrinkles) in {:.1} s",
            args.out.display(),
            cfg.size,
            generated.features.total(),
            c.follicle,
            c.eyebrow,
            c.freckle,
            c.mole,
            c.cyst,
            c.pore,
            c.wrinkle,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
