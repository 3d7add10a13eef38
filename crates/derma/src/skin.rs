//! `derma skin`: the main job, procedural biological skin (docs/skin.md): flags and config →
//! derma-skin's generator, and the files it wrote.

use crate::progress::Bars;
use anyhow::{Context, Result};
use clap::Args;
use derma_skin::config::SurfaceKind;
use derma_skin::{AppearanceChoice, SkinConfig, SkinGenerator};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct SkinArgs {
    /// Output directory (created if needed; existing texture files in it are replaced atomically).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Texture size in texels (square, 16–16384). Overrides `size` in the config.
    #[arg(long, value_parser = |s: &str| in_range::<u32>("size", s))]
    size: Option<u32>,
    /// Random seed. Overrides `seed` in the config.
    #[arg(long)]
    seed: Option<u64>,
    /// Mesh with UVs (OBJ, glTF, GLB) instead of the built-in head.
    #[arg(long, conflicts_with = "patch")]
    mesh: Option<PathBuf>,
    #[command(flatten)]
    read: crate::args::MeshReadArg,
    /// Landmarks of the --mesh: `mediapipe` (MediaPipe's 468-point topology) or a JSON file
    /// {"name": [x, y, z]} (see --print-config, surface.landmarks); the built-in head's default
    /// fields and regional biology then follow the mesh.
    #[arg(long, value_name = "mediapipe|FILE.json", requires = "mesh")]
    landmarks: Option<String>,
    /// With --mesh: the scan the head was fitted to gives its landmarks and regions; alone: the
    /// fitted template is painted (derma's UV layout).
    #[command(flatten)]
    head: crate::args::HeadArg,
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
    #[arg(long, value_name = "WxH", value_parser = crate::args::mm_size)]
    patch: Option<[f32; 2]>,
    /// With --patch: do not wrap (by default patches tile seamlessly).
    #[arg(long)]
    no_tile: bool,
    /// Print the full default configuration with units and sources, then exit.
    #[arg(long)]
    print_config: bool,
    /// Write the built-in head (head.obj: the skin in mm; head_parts.obj: eyes, lashes, teeth,
    /// tongue; head.glb: every part a named node, metres, the 52 face units as morph targets) and
    /// its default fields, regions and regional biology (PNG) into DIR, then exit: paint over
    /// the fields and run `derma skin --mesh DIR/head.obj --fields DIR`.
    #[arg(long, value_name = "DIR")]
    export_template: Option<PathBuf>,
    /// Bio → render conversion: `table` (the Monte Carlo match table, default; adds
    /// sss_color.png and sss_radius.png) or `analytic` (spectral Kubelka–Munk, colour only).
    #[arg(long, value_enum, default_value = "table")]
    appearance: AppearanceArg,
    /// A match table from `derma match fit` instead of the built-in one (implies table).
    #[arg(long, value_name = "FILE.dtab", conflicts_with = "appearance")]
    table: Option<PathBuf>,
    /// Skin tone preset, an ITA° band of Chardon et al. 1991: very-light (> 55°), light
    /// (41–55°), intermediate (28–41°), tan (10–28°), brown (−30–10°) or dark (< −30°); sets
    /// person.ita_deg. Default: the config's person (light, 48°).
    #[arg(long, value_parser = parse_preset)]
    preset: Option<derma_skin::regional::Preset>,
    /// Skin tone as an ITA° (cheeks and forehead; e.g. a scan's own, which --compare-albedo
    /// prints): sets person.ita_deg, after --preset, and calibrates the melanin to it.
    #[arg(long, value_name = "DEG", value_parser = |s: &str| in_range::<f32>("person.ita_deg", s))]
    ita: Option<f32>,
    /// Sex of the person (beard follicles for male). Overrides person.sex.
    #[arg(long, value_enum)]
    sex: Option<SexArg>,
    /// Age in years (10–100; wrinkles). Overrides person.age_years.
    #[arg(long, value_parser = |s: &str| in_range::<f32>("person.age_years", s))]
    age: Option<f32>,
    /// Also head.glb in --out: the head (or --mesh) with the texture set as glTF PBR, for
    /// Blender, Unreal, Unity and three.js (see `derma export glb` for loose maps and naming).
    #[arg(long, conflicts_with = "patch")]
    glb: bool,
    /// Where `[detail]`'s exemplar synthesis and the preview's renderer run (the texture files
    /// are the same on every device; the preview is drawn by derma-render on a GPU and by its
    /// CPU renderer otherwise).
    #[command(flatten)]
    device: crate::args::DeviceArg,
    /// A photographed albedo of --mesh (its own UV layout, sRGB): the painted set is compared
    /// with it region by region (mean L*a*b*, ΔE*ab, a* spread), printed and kept in report.json.
    #[arg(long, value_name = "IMAGE", requires = "mesh")]
    compare_albedo: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AppearanceArg {
    Table,
    Analytic,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SexArg {
    Male,
    Female,
}

/// A flag's value checked against the range of the config key it sets (derma-skin's
/// KEY_DOCS), so the error names the flag, not the config.
fn in_range<T: std::str::FromStr + Into<f64> + Copy>(key: &str, s: &str) -> Result<T, String> {
    let doc = derma_skin::config::KEY_DOCS.iter().find(|d| d.key == key);
    let (lo, hi) = doc.map_or((f64::MIN, f64::MAX), |d| d.range);
    let unit = doc.map_or("", |d| d.unit);
    match s.trim().parse::<T>() {
        Ok(v) if (lo..=hi).contains(&v.into()) => Ok(v),
        _ => Err(format!(
            "'{s}': expected a number from {lo} to {hi} ({unit})"
        )),
    }
}

fn parse_preset(s: &str) -> std::result::Result<derma_skin::regional::Preset, String> {
    derma_skin::regional::Preset::parse(s).ok_or_else(|| {
        format!(
            "'{s}': expected one of {}",
            derma_skin::regional::Preset::ALL
                .map(|p| p.name())
                .join(", ")
        )
    })
}

/// Applies --preset, --sex and --age to the config's person.
fn apply_person(cfg: &mut SkinConfig, args: &SkinArgs) {
    use derma_skin::regional::Sex;
    if let Some(s) = args.sex {
        cfg.person.sex = match s {
            SexArg::Male => Sex::Male,
            SexArg::Female => Sex::Female,
        };
    }
    if let Some(a) = args.age {
        cfg.person.age_years = a;
    }
    if let Some(p) = args.preset {
        cfg.person = p.person(cfg.person.sex, cfg.person.age_years);
    }
    if let Some(ita) = args.ita {
        // A tone asked for is painted: the melanin is calibrated to it (as --preset does), even
        // where the config set the melanin itself.
        cfg.person.ita_deg = ita;
        cfg.person.calibrate_melanin = true;
    }
}

pub fn run(args: SkinArgs, bars: &Bars) -> Result<()> {
    if args.print_config {
        return crate::output::text(&SkinConfig::print_default());
    }
    if let Some(dir) = &args.export_template {
        let mut cfg = SkinConfig::default();
        apply_person(&mut cfg, &args);
        let files = derma_skin::builtin_head::export(dir, &cfg.person)
            .with_context(|| format!("cannot export the template to '{}'", dir.display()))?;
        bars.say(format!(
            "wrote {} files to {}: {}",
            files.len(),
            dir.display(),
            files.join(", ")
        ));
        return Ok(());
    }
    let start = Instant::now();
    let mut generator = match &args.config {
        Some(p) => SkinGenerator::from_config_file(p)?,
        None => SkinGenerator::new(SkinConfig::default()),
    };
    let cfg = generator.config_mut();
    if let Some(s) = args.size {
        cfg.size = s;
    }
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    apply_person(cfg, &args);
    if let Some(l) = &args.landmarks {
        cfg.surface.landmarks = l.clone();
    }
    if let Some(u) = &args.read.unit {
        args.read.head_unit()?;
        cfg.surface.unit = u.clone();
    }
    if let Some(n) = &args.read.node {
        cfg.surface.part = n.clone();
    }
    if let Some(p) = args.patch {
        cfg.surface.kind = SurfaceKind::Patch;
        cfg.surface.patch_size_mm = p;
        cfg.surface.tileable = !args.no_tile;
    }
    let appearance = match (&args.table, args.appearance) {
        (Some(p), _) => AppearanceChoice::Table(std::sync::Arc::new(
            derma_shading::TableAppearance::read(p)
                .with_context(|| format!("reading match table {}", p.display()))?,
        )),
        (None, AppearanceArg::Table) => AppearanceChoice::Default,
        (None, AppearanceArg::Analytic) => AppearanceChoice::Analytic,
    };
    generator = generator
        .appearance(appearance)
        .device(args.device.device)
        .progress(bars);
    if let Some(m) = &args.mesh {
        generator = generator.mesh(m);
    }
    if let Some(h) = &args.head.head {
        generator = generator.head(h);
    }
    if let Some(f) = &args.fields {
        generator = generator.fields(f);
    }
    if let Some(n) = args.threads {
        generator = generator.threads(n);
    }
    if let Some(a) = &args.compare_albedo {
        generator = generator.compare_albedo(a);
    }
    let derma_export::skin::SkinOutput { set, glb, .. } =
        derma_export::skin::run(&generator, &args.out, args.glb, bars)?;
    if let Some(report) = glb {
        bars.say(format!(
            "wrote {} ({:.1} MB; meshes {}; {} morph targets)",
            report.path.display(),
            report.bytes as f64 / 1e6,
            report.meshes.join(", "),
            report.morph_targets
        ));
    }
    bars.finish();
    if let Some(c) = &set.albedo_comparison {
        print_comparison(c)?;
    }
    bars.say(format!(
        "wrote {} ({}², {} features: {}) in {:.1} s",
        args.out.display(),
        set.config.size,
        set.features.total(),
        set.features.counts().summary(),
        start.elapsed().as_secs_f64()
    ));
    Ok(())
}

/// The albedo comparison as a Markdown table.
fn print_comparison(c: &derma_skin::albedo_compare::AlbedoComparison) -> Result<()> {
    let mut t = format!(
        "{} beside the set: the photo's ITA {:.0}° on cheeks and forehead ({:.0}° on the cheeks); its exposure ×{:.2} matches derma's luminance there\n| region | skin in the photo | photo L* a* b* | derma L* a* b* | ΔE*ab | matched exposure: photo L* a* b* | ΔE*ab | a* spread photo / derma |\n|---|---:|---|---|---:|---|---:|---|\n",
        c.albedo, c.photo_ita_deg, c.photo_cheek_ita_deg, c.exposure_gain
    );
    let lab = |l: [f64; 3]| format!("{:.1} {:.1} {:.1}", l[0], l[1], l[2]);
    for r in &c.regions {
        t += &format!(
            "| {} | {:.0} % | {} | {} | {:.1} | {} | {:.1} | {:.2} / {:.2} |\n",
            r.region,
            100.0 * r.skin_share,
            lab(r.photo.lab),
            lab(r.derma.lab),
            r.delta_e,
            lab(r.photo_matched),
            r.delta_e_matched,
            r.photo.a_spread,
            r.derma.a_spread
        );
    }
    t += &format!(
        "median ΔE*ab {:.1}, at the matched exposure {:.1} (regions the photo shows as skin over half their texels)\n",
        c.median_delta_e, c.median_delta_e_matched
    );
    crate::output::text(&t)
}
