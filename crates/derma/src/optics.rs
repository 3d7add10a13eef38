//! `derma optics …`: the skin optics (Monte Carlo light transport in layered skin, docs/optics.md)
//! from the command line: flags → derma-optics, and what was written.

use crate::args::DeviceArg;
use crate::output::line;
use crate::progress::Bars;
use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use derma_core::progress::Silent;
use derma_optics::precompute::{self, Grid};
use derma_optics::simulate::{simulate_skin, SkinSimConfig};
use derma_optics::slab::{parse_layer, slab_stack, SlabResult};
use derma_optics::yellow_pigments::YellowPigments;
use derma_optics::{BioTexel, Run};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Subcommand)]
pub enum OpticsCommand {
    /// A generic layered slab under a normal pencil beam (validation against MCML and
    /// adding-doubling).
    Slab(SlabArgs),
    /// The skin specimen for one set of bio parameters: spectrum, colour, BRDF, radial profile.
    Simulate(SimulateArgs),
    /// Fill a table over a grid of bio parameters (resumable, shardable).
    Precompute(PrecomputeArgs),
    /// Join precompute directories into one .dtab table (+ JSON sidecar).
    Merge(MergeArgs),
}

#[derive(Args)]
pub struct SlabArgs {
    /// A layer, top first: d_mm,mua_per_cm,mus_per_cm,g,n (repeat for more layers).
    #[arg(long = "layer", required = true)]
    layers: Vec<String>,
    /// Refractive index above the slab.
    #[arg(long, default_value_t = 1.0)]
    above: f64,
    /// Refractive index below the slab.
    #[arg(long, default_value_t = 1.0)]
    below: f64,
    #[command(flatten)]
    run: RunArgs,
}

/// What every simulation takes: how many photons, their seed, where they run, the output form.
#[derive(Args)]
pub struct RunArgs {
    /// Photons to trace.
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    /// Seed of the photons' random streams.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    device: DeviceArg,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
pub struct SimulateArgs {
    /// Melanosome volume fraction of the epidermis.
    #[arg(long, default_value_t = BioTexel::FAIR.melanin)]
    melanin: f32,
    /// Pheomelanin share of the melanin.
    #[arg(long, default_value_t = BioTexel::FAIR.pheomelanin)]
    pheomelanin: f32,
    /// Blood volume fraction of the papillary dermis.
    #[arg(long, default_value_t = BioTexel::FAIR.blood)]
    blood: f32,
    /// Oxygenated share of the hemoglobin.
    #[arg(long, default_value_t = BioTexel::FAIR.oxygenation)]
    oxygenation: f32,
    /// Stratum corneum thickness (µm).
    #[arg(long, default_value_t = BioTexel::FAIR.stratum_corneum_um)]
    sc_um: f32,
    /// Epidermis thickness (µm).
    #[arg(long, default_value_t = BioTexel::FAIR.epidermis_um)]
    epidermis_um: f32,
    /// The skin surface: smith (visible normals, masking, multiple scattering) or thesis
    /// (BioSpec's unmasked sampling, for comparison).
    #[arg(long, default_value = "smith")]
    surface: derma_optics::specimen::SurfaceModel,
    /// β-carotene in the stratum corneum and epidermis, g/L (BioSpec's baseline).
    #[arg(long, default_value_t = YellowPigments::BIOSPEC.carotene_epidermis_g_per_l)]
    carotene_epidermis: f64,
    /// β-carotene in the dermis, g/L (BioSpec's baseline).
    #[arg(long, default_value_t = YellowPigments::BIOSPEC.carotene_dermis_g_per_l)]
    carotene_dermis: f64,
    /// Bilirubin in whole blood, g/L (BioSpec's baseline; jaundice is several times more).
    #[arg(long, default_value_t = YellowPigments::BIOSPEC.bilirubin_blood_g_per_l)]
    bilirubin: f64,
    #[command(flatten)]
    run: RunArgs,
    /// Directory for result.json (and the plots).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write spectrum.svg, brdf.svg and profile.svg.
    #[arg(long, requires = "out")]
    plot: bool,
}

#[derive(Args)]
pub struct PrecomputeArgs {
    /// Grid file (TOML), or `default` for the built-in grid.
    #[arg(long, default_value = "default")]
    grid: String,
    #[arg(long, required_unless_present = "print_grid")]
    out: Option<PathBuf>,
    #[command(flatten)]
    shard: crate::args::ShardArg,
    #[command(flatten)]
    device: DeviceArg,
    /// Print the built-in grid and exit.
    #[arg(long)]
    print_grid: bool,
}

#[derive(Args)]
pub struct MergeArgs {
    /// Precompute directories (all started with the same grid).
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// The table to write (.dtab; a .dtab.json sidecar is written beside it).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(cmd: OpticsCommand, bars: &Bars) -> Result<()> {
    match cmd {
        OpticsCommand::Slab(a) => slab(a),
        OpticsCommand::Simulate(a) => simulate(a, bars),
        OpticsCommand::Precompute(a) => precompute(a, bars),
        OpticsCommand::Merge(a) => merge(a),
    }
}

fn slab(a: SlabArgs) -> Result<()> {
    let layers = a
        .layers
        .iter()
        .map(|l| parse_layer(l))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let run = Run::totals(
        slab_stack(layers, a.above, a.below),
        a.run.photons,
        a.run.seed,
    );
    let t0 = Instant::now();
    let (tally, device) = derma_optics::backend::run_on(&run, a.run.device.device, &Silent)?;
    let r = SlabResult::from_tally(&tally, t0.elapsed().as_secs_f64(), device.name());
    if a.run.json {
        return line(serde_json::to_string(&r)?);
    }
    let s = &r.stderr;
    line(format!(
        "specular R   {:.6} ± {:.6}",
        r.r_specular, s.r_specular
    ))?;
    line(format!(
        "diffuse R    {:.6} ± {:.6}",
        r.r_diffuse, s.r_diffuse
    ))?;
    line(format!("total T      {:.6} ± {:.6}", r.t_total, s.t_total))?;
    line(format!(
        "absorbed A   {:.6} ± {:.6}",
        r.absorbed, s.absorbed
    ))?;
    for (i, v) in r.absorbed_per_layer.iter().enumerate() {
        line(format!("  layer {}    {v:.6}", i + 1))?;
    }
    line(format!(
        "photons      {} in {:.3} s = {:.3e} photons/s on {}",
        r.photons, r.seconds, r.photons_per_s, r.device
    ))
}

fn simulate(a: SimulateArgs, bars: &Bars) -> Result<()> {
    let bio = BioTexel {
        melanin: a.melanin,
        pheomelanin: a.pheomelanin,
        blood: a.blood,
        oxygenation: a.oxygenation,
        stratum_corneum_um: a.sc_um,
        epidermis_um: a.epidermis_um,
    };
    let cfg = SkinSimConfig {
        photons: a.run.photons,
        seed: a.run.seed,
        surface: a.surface,
        yellow: YellowPigments {
            carotene_epidermis_g_per_l: a.carotene_epidermis,
            carotene_dermis_g_per_l: a.carotene_dermis,
            bilirubin_blood_g_per_l: a.bilirubin,
        },
        ..SkinSimConfig::default()
    };
    let r = simulate_skin(&bio, &cfg, a.run.device.device, bars)?;
    bars.finish();
    if let Some(dir) = &a.out {
        derma_optics::plots::write_result(&r, dir, a.plot)?;
    }
    if a.run.json {
        return line(serde_json::to_string(&r)?);
    }
    let c = r.linear_srgb;
    line(format!(
        "diffuse reflectance (albedo) linear sRGB  {:.4} {:.4} {:.4}",
        c[0], c[1], c[2]
    ))?;
    line(format!(
        "XYZ                                      {:.4} {:.4} {:.4}",
        r.xyz[0], r.xyz[1], r.xyz[2]
    ))?;
    line(format!(
        "reflected: specular {:.4}, diffuse {:.4}",
        r.reflected_specular, r.reflected_diffuse
    ))?;
    for (name, a) in r.layer_names.iter().zip(&r.absorbed) {
        let parts: Vec<String> = r
            .absorber_names
            .iter()
            .zip(a)
            .filter(|(_, v)| **v > 0.0)
            .map(|(n, v)| format!("{n} {v:.4}"))
            .collect();
        line(format!(
            "absorbed in {name:<17} {:.4}  ({})",
            a.iter().sum::<f64>(),
            parts.join(", ")
        ))?;
    }
    line(format!(
        "{} photons in {:.2} s = {:.3e} photons/s on {}",
        r.config.photons,
        r.seconds,
        r.config.photons as f64 / r.seconds.max(1e-9),
        r.device
    ))
}

fn precompute(a: PrecomputeArgs, bars: &Bars) -> Result<()> {
    if a.print_grid {
        return crate::output::text(precompute::DEFAULT_GRID);
    }
    let Some(out) = a.out else {
        bail!("--out DIR is required (or --print-grid)");
    };
    let grid = Grid::load(&a.grid)?;
    let (shard, source) = a.shard.resolve()?;
    bars.say(format!("shard {}/{} ({source})", shard.k, shard.n));
    let t0 = Instant::now();
    let done = precompute::run_shard(&out, &grid, shard, a.device.device, bars)?;
    bars.finish();
    bars.say(format!(
        "{} entries in {:.1} s",
        done.computed,
        t0.elapsed().as_secs_f64()
    ));
    Ok(())
}

fn merge(a: MergeArgs) -> Result<()> {
    let table = precompute::merge(&a.dirs)?;
    table.write(&a.out)?;
    line(format!(
        "wrote {} ({} entries × {} values)",
        a.out.display(),
        table.header.nodes(),
        table.header.stride()
    ))
}
