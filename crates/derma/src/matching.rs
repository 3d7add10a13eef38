//! `derma match …`: fit render models to the Monte Carlo table (docs/matching.md) and build the
//! skin-colour LUT of Jimenez et al. 2010; flags → derma-shading, and what was written.

use crate::args::DeviceArg;
use crate::output::line;
use crate::progress::Bars;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_shading::annealing::Schedule;
use derma_shading::brdf_fit::{FitOptions, Weighting};
use derma_shading::fit_job::FitJob;
use derma_shading::match_table::MatchOptions;
use derma_shading::model_kind::ModelKind;
use derma_shading::skin_color_lut::{LutOptions, SkinColorLut};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Subcommand)]
pub enum MatchCommand {
    /// Fit render models to every entry of a precompute table (from `derma optics merge`).
    Fit(FitArgs),
    /// The skin-colour lookup table of Jimenez et al. 2010 (melanin × hemoglobin → RGB).
    Lut(LutArgs),
    /// Add the skin surface's specular fit (the roughness and specular maps' source) to a match
    /// table fitted before `derma match fit` made it.
    Surface(SurfaceArgs),
}

#[derive(Args)]
pub struct SurfaceArgs {
    /// The match table (.dtab from `derma match fit`); it is read, not changed.
    #[arg(long)]
    table: PathBuf,
    /// The match table to write, with the fit (a .json sidecar is written beside it).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
enum WeightingArg {
    /// cosθi·cosθo: error in rendered radiance (default).
    Cosine,
    /// Every (θi, θo, Δφ) bin alike, as the thesis' integral.
    Uniform,
}

#[derive(Args)]
pub struct FitArgs {
    /// Precompute table (.dtab from `derma optics merge`).
    #[arg(long)]
    grid: PathBuf,
    /// Output match table (.dtab; a .json sidecar and a .residuals.csv are written beside it).
    #[arg(long)]
    out: PathBuf,
    /// Models to fit, comma-separated: ggx, ashikhmin-shirley, kelemen, skin-dual-lobe, or all.
    #[arg(long, default_value = "all", value_delimiter = ',')]
    model: Vec<String>,
    #[arg(long, value_enum, default_value = "cosine")]
    weighting: WeightingArg,
    /// Simulated-annealing steps per entry and model (before the Levenberg–Marquardt polish).
    #[arg(long, default_value_t = Schedule::default().steps)]
    anneal_steps: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Leave BRDF bins beyond this zenith angle (degrees, incident or outgoing) out of the fit.
    #[arg(long, default_value_t = derma_shading::brdf_fit::DEFAULT_MAX_ZENITH_DEG)]
    max_zenith: f64,
    /// Gaussians in the sum-of-Gaussians profile fit.
    #[arg(long, default_value_t = 6)]
    gaussians: usize,
    /// Write SVG plots (simulated vs fitted BRDF at several incident angles, radial profiles)
    /// into this directory.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Nodes to plot (default: fair, medium and dark melanin with the other axes mid-range).
    #[arg(long, value_delimiter = ',')]
    plot_nodes: Vec<usize>,
}

#[derive(Args)]
pub struct LutArgs {
    /// Output: FILE.png (16-bit, sRGB-encoded) and/or FILE.dtab (linear); repeatable.
    #[arg(long, required = true)]
    out: Vec<PathBuf>,
    /// Entries per axis.
    #[arg(long, default_value_t = LutOptions::default().size)]
    size: usize,
    /// Photons per entry.
    #[arg(long, default_value_t = LutOptions::default().photons)]
    photons: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    device: DeviceArg,
}

pub fn run(cmd: MatchCommand, bars: &Bars) -> Result<()> {
    match cmd {
        MatchCommand::Fit(a) => fit(a, bars),
        MatchCommand::Lut(a) => lut(a, bars),
        MatchCommand::Surface(a) => {
            let f = derma_shading::fit_job::add_surface(&a.table, &a.out, bars)
                .with_context(|| format!("fitting the surface of {}", a.table.display()))?;
            bars.finish();
            line(format!(
                "surface ({}): roughness {:.4}, F0 {:.4} (relative RMS {:.3}; albedo {:.4} under diffuse light; {} photons) → {}",
                f.surface.name(), f.roughness, f.f0, f.relative_rms, f.albedo, f.photons, a.out.display()
            ))
        }
    }
}

fn parse_models(names: &[String]) -> Result<Vec<ModelKind>> {
    if names.iter().any(|n| n == "all") {
        return Ok(ModelKind::ALL.to_vec());
    }
    let mut out = Vec::new();
    for n in names {
        let k = ModelKind::parse(n.trim()).with_context(|| {
            let all: Vec<&str> = ModelKind::ALL.iter().map(|k| k.name()).collect();
            format!("--model '{n}': expected one of {} or all", all.join(", "))
        })?;
        if !out.contains(&k) {
            out.push(k);
        }
    }
    Ok(out)
}

fn fit(a: FitArgs, bars: &Bars) -> Result<()> {
    let job = FitJob {
        grid: a.grid.clone(),
        out: a.out.clone(),
        options: MatchOptions {
            models: parse_models(&a.model)?,
            weighting: match a.weighting {
                WeightingArg::Cosine => Weighting::Cosine,
                WeightingArg::Uniform => Weighting::Uniform,
            },
            fit: FitOptions {
                schedule: Schedule {
                    steps: a.anneal_steps,
                    ..Schedule::default()
                },
                seed: a.seed,
                ..FitOptions::default()
            },
            gaussians: a.gaussians.clamp(1, 6),
            max_zenith_deg: a.max_zenith,
        },
        plots: a.plots,
        plot_nodes: a.plot_nodes,
    };
    let r = derma_shading::fit_job::run(&job, bars)
        .with_context(|| format!("fitting {}", a.grid.display()))?;
    bars.finish();
    line(format!(
        "fitted {} entries × {} models in {:.1} s ({} weighting) → {}",
        r.entries,
        job.options.models.len(),
        r.seconds,
        job.options.weighting.name(),
        a.out.display()
    ))?;
    line("relative RMS residual over the grid:")?;
    line(format!(
        "  {:<20} {:>8} {:>8} {:>8} {:>8}  worst node",
        "model", "mean", "median", "p90", "max"
    ))?;
    for s in &r.summary {
        line(format!(
            "  {:<20} {:>8.4} {:>8.4} {:>8.4} {:>8.4}  {}",
            s.name, s.mean, s.median, s.p90, s.max, s.worst_node
        ))?;
    }
    line(format!("per-entry residuals: {}", r.residuals.display()))?;
    if let Some((n, dir)) = &r.plots {
        line(format!("{n} plots in {}", dir.display()))?;
    }
    Ok(())
}

fn lut(a: LutArgs, bars: &Bars) -> Result<()> {
    for p in &a.out {
        if !matches!(p.extension().and_then(|e| e.to_str()), Some("png" | "dtab")) {
            bail!("--out {}: expected a .png or .dtab file name", p.display());
        }
    }
    let opts = LutOptions {
        size: a.size,
        photons: a.photons,
        seed: a.seed,
        ..LutOptions::default()
    };
    let t0 = Instant::now();
    let lut = SkinColorLut::build(opts, a.device.device, bars)?;
    bars.finish();
    for p in &a.out {
        lut.write(p)
            .with_context(|| format!("writing {}", p.display()))?;
        line(format!("wrote {}", p.display()))?;
    }
    bars.say(format!(
        "{}×{} entries × {} photons in {:.1} s",
        a.size,
        a.size,
        a.photons,
        t0.elapsed().as_secs_f64()
    ));
    Ok(())
}
