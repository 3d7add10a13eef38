//! `derma optics …`: the skin optics (Monte Carlo light transport) from the command line.

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_core::plot::{Plot, Series};
use derma_optics::precompute::{self, Grid, Shard};
use derma_optics::run::Device;
use derma_optics::simulate::{simulate_skin, SkinResult, SkinSimConfig};
use derma_optics::slab::{parse_layer, slab_stack, SlabResult};
use derma_optics::{BioTexel, Run};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
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

#[derive(Clone, Copy, ValueEnum)]
pub enum DeviceArg {
    /// The GPU when one can be opened, else the CPU.
    Auto,
    Cpu,
    Gpu,
}

pub fn resolve(d: DeviceArg) -> Device {
    match d {
        DeviceArg::Cpu => Device::Cpu,
        DeviceArg::Gpu => Device::Gpu,
        DeviceArg::Auto => {
            if derma_optics::gpu::available().is_some() {
                Device::Gpu
            } else {
                Device::Cpu
            }
        }
    }
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
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long, value_enum, default_value = "cpu")]
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
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long, value_enum, default_value = "auto")]
    device: DeviceArg,
    /// Directory for result.json (and the plots).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write spectrum.svg, brdf.svg and profile.svg.
    #[arg(long)]
    plot: bool,
    /// Print the whole result as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
pub struct PrecomputeArgs {
    /// Grid file (TOML), or `default` for the built-in grid.
    #[arg(long, default_value = "default")]
    grid: String,
    #[arg(long)]
    out: Option<PathBuf>,
    /// This process's share of the grid, k/n (1-based).
    #[arg(long, default_value = "1/1")]
    shard: String,
    #[arg(long, value_enum, default_value = "auto")]
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

pub fn run(cmd: OpticsCommand, quiet: bool) -> Result<()> {
    match cmd {
        OpticsCommand::Slab(a) => slab(a),
        OpticsCommand::Simulate(a) => simulate(a, quiet),
        OpticsCommand::Precompute(a) => precompute(a, quiet),
        OpticsCommand::Merge(a) => merge(a),
    }
}

fn bar(total: u64, quiet: bool, msg: &str) -> Option<ProgressBar> {
    progress_bar(total, quiet, msg, "photons")
}

/// A progress bar counting `unit` (none when `quiet`).
pub fn progress_bar(total: u64, quiet: bool, msg: &str, unit: &str) -> Option<ProgressBar> {
    (!quiet).then(|| {
        let b = ProgressBar::new(total);
        b.set_style(
            ProgressStyle::with_template(&format!(
                "{{msg}} [{{bar:30}}] {{pos}}/{{len}} {unit} {{elapsed}} (eta {{eta}})"
            ))
            .expect("template")
            .progress_chars("=> "),
        );
        b.set_message(msg.to_string());
        b
    })
}

fn slab(a: SlabArgs) -> Result<()> {
    let layers = a
        .layers
        .iter()
        .map(|l| parse_layer(l))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let device = resolve(a.device);
    let run = Run::totals(slab_stack(layers, a.above, a.below), a.photons, a.seed);
    let t0 = Instant::now();
    let tally = derma_optics::backend::run_on(&run, device, &|_| {})?;
    let r = SlabResult::from_tally(&tally, t0.elapsed().as_secs_f64(), device.name());
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "specular R   {:.6} ± {:.6}",
            r.r_specular, r.stderr.r_specular
        );
        println!(
            "diffuse R    {:.6} ± {:.6}",
            r.r_diffuse, r.stderr.r_diffuse
        );
        println!("total T      {:.6} ± {:.6}", r.t_total, r.stderr.t_total);
        println!("absorbed A   {:.6} ± {:.6}", r.absorbed, r.stderr.absorbed);
        for (i, v) in r.absorbed_per_layer.iter().enumerate() {
            println!("  layer {}    {v:.6}", i + 1);
        }
        println!(
            "photons      {} in {:.3} s = {:.3e} photons/s on {}",
            r.photons, r.seconds, r.photons_per_s, r.device
        );
    }
    Ok(())
}

fn simulate(a: SimulateArgs, quiet: bool) -> Result<()> {
    let bio = BioTexel {
        melanin: a.melanin,
        pheomelanin: a.pheomelanin,
        blood: a.blood,
        oxygenation: a.oxygenation,
        stratum_corneum_um: a.sc_um,
        epidermis_um: a.epidermis_um,
    };
    check_bio(&bio)?;
    if a.plot && a.out.is_none() {
        bail!("--plot writes into --out DIR; give an output directory");
    }
    let cfg = SkinSimConfig {
        photons: a.photons,
        seed: a.seed,
        ..SkinSimConfig::default()
    };
    let device = resolve(a.device);
    let pb = bar(a.photons, quiet || a.json, "simulate");
    let r = simulate_skin(&bio, &cfg, device, &|d| {
        if let Some(b) = &pb {
            b.set_position(d)
        }
    })?;
    if let Some(b) = pb {
        b.finish_and_clear();
    }
    if let Some(dir) = &a.out {
        derma_core::atomic::ensure_writable_dir(dir)?;
        let json = serde_json::to_vec_pretty(&r)?;
        derma_core::atomic::write_bytes(&dir.join("result.json"), &json)?;
        if a.plot {
            write_plots(&r, dir)?;
        }
    }
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        let c = r.linear_srgb;
        println!(
            "diffuse reflectance (albedo) linear sRGB  {:.4} {:.4} {:.4}",
            c[0], c[1], c[2]
        );
        println!(
            "XYZ                                      {:.4} {:.4} {:.4}",
            r.xyz[0], r.xyz[1], r.xyz[2]
        );
        println!(
            "reflected: specular {:.4}, diffuse {:.4}",
            r.reflected_specular, r.reflected_diffuse
        );
        for (name, a) in r.layer_names.iter().zip(&r.absorbed) {
            let parts: Vec<String> = r
                .absorber_names
                .iter()
                .zip(a)
                .filter(|(_, v)| **v > 0.0)
                .map(|(n, v)| format!("{n} {v:.4}"))
                .collect();
            println!(
                "absorbed in {name:<17} {:.4}  ({})",
                a.iter().sum::<f64>(),
                parts.join(", ")
            );
        }
        println!(
            "{} photons in {:.2} s = {:.3e} photons/s on {}",
            r.config.photons,
            r.seconds,
            r.config.photons as f64 / r.seconds.max(1e-9),
            r.device.name()
        );
    }
    Ok(())
}

fn check_bio(b: &BioTexel) -> Result<()> {
    for (name, v) in [
        ("--melanin", b.melanin),
        ("--pheomelanin", b.pheomelanin),
        ("--blood", b.blood),
        ("--oxygenation", b.oxygenation),
    ] {
        if !(0.0..=1.0).contains(&v) {
            bail!("{name} {v} is outside [0, 1]");
        }
    }
    for (name, v) in [
        ("--sc-um", b.stratum_corneum_um),
        ("--epidermis-um", b.epidermis_um),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= 2000.0) {
            bail!("{name} {v} must be a thickness in (0, 2000] µm");
        }
    }
    Ok(())
}

const COLORS: [&str; 6] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

fn write_plots(r: &SkinResult, dir: &Path) -> Result<()> {
    let spectrum = Plot {
        title: "Diffuse reflectance of the skin specimen".into(),
        x_label: "wavelength (nm)".into(),
        y_label: "reflectance".into(),
        log_y: false,
        series: vec![
            Series {
                label: "diffuse".into(),
                color: COLORS[0].into(),
                points: r
                    .wavelengths_nm
                    .iter()
                    .copied()
                    .zip(r.r_diffuse.iter().copied())
                    .collect(),
            },
            Series {
                label: "specular".into(),
                color: COLORS[1].into(),
                points: r
                    .wavelengths_nm
                    .iter()
                    .copied()
                    .zip(r.r_specular.iter().copied())
                    .collect(),
            },
        ],
    };
    let b = r.brdf_bins;
    // In-plane slices (Δφ bins nearest 0 and π) for a few incident angles, luminance-like green.
    let mut brdf_series = Vec::new();
    for (k, ti) in [0, b.theta_in / 3, 2 * b.theta_in / 3, b.theta_in - 1]
        .into_iter()
        .enumerate()
    {
        let (t_in, _, _) = b.centre(ti, 0, 0);
        let mut pts = Vec::new();
        for to in (0..b.theta_out).rev() {
            let (_, t_out, _) = b.centre(ti, to, 0);
            pts.push((
                -t_out.to_degrees(),
                r.brdf_rgb[b.index(ti, to, b.phi - 1)][1],
            ));
        }
        for to in 0..b.theta_out {
            let (_, t_out, _) = b.centre(ti, to, 0);
            pts.push((t_out.to_degrees(), r.brdf_rgb[b.index(ti, to, 0)][1]));
        }
        brdf_series.push(Series {
            label: format!("θi = {:.0}°", t_in.to_degrees()),
            color: COLORS[k].into(),
            points: pts,
        });
    }
    let brdf = Plot {
        title: "Sampled BRDF, plane of incidence (G channel)".into(),
        x_label: "outgoing zenith (°; negative = mirror side)".into(),
        y_label: "BRDF (1/sr)".into(),
        log_y: false,
        series: brdf_series,
    };
    let pb = r.profile_bins;
    let dr = pb.d_max_mm / pb.bins as f64;
    let names = ["R", "G", "B"];
    let profile = Plot {
        title: "Radial exit profile R(r)".into(),
        x_label: "r (mm)".into(),
        y_label: "R(r) (1/mm²)".into(),
        log_y: true,
        series: (0..3)
            .map(|c| Series {
                label: names[c].into(),
                color: ["#d62728", "#2ca02c", "#1f77b4"][c].into(),
                points: (0..pb.bins)
                    .map(|i| ((i as f64 + 0.5) * dr, r.profile_rgb[i][c]))
                    .collect(),
            })
            .collect(),
    };
    for (name, p) in [
        ("spectrum.svg", spectrum),
        ("brdf.svg", brdf),
        ("profile.svg", profile),
    ] {
        derma_core::atomic::write_bytes(&dir.join(name), p.to_svg().as_bytes())
            .with_context(|| format!("writing {name}"))?;
    }
    Ok(())
}

fn precompute(a: PrecomputeArgs, quiet: bool) -> Result<()> {
    if a.print_grid {
        print!("{}", precompute::DEFAULT_GRID);
        return Ok(());
    }
    let Some(out) = a.out else {
        bail!("--out DIR is required (or --print-grid)");
    };
    let grid = if a.grid == "default" {
        Grid::default_grid()
    } else {
        let p = Path::new(&a.grid);
        let text = std::fs::read_to_string(p)
            .with_context(|| format!("reading grid '{}'", p.display()))?;
        Grid::parse(&text, p)?
    };
    let shard = Shard::parse(&a.shard)?;
    let device = resolve(a.device);
    precompute::prepare_dir(&out, &grid)?;
    let todo = precompute::pending(&out, &grid, shard);
    let owned = (0..grid.len()).filter(|&i| shard.owns(i)).count();
    if !quiet {
        eprintln!(
            "grid: {} entries × {} photons; shard {}/{} owns {owned}, {} already done, {} to go, on {}",
            grid.len(),
            grid.photons,
            shard.k,
            shard.n,
            owned - todo.len(),
            todo.len(),
            device.name()
        );
    }
    let pb = bar(todo.len() as u64 * grid.photons, quiet, "precompute");
    let t0 = Instant::now();
    for (j, &i) in todo.iter().enumerate() {
        let base = j as u64 * grid.photons;
        precompute::compute_entry(&out, &grid, i, device, &|d| {
            if let Some(b) = &pb {
                b.set_position(base + d)
            }
        })
        .with_context(|| format!("grid entry {i}"))?;
    }
    if let Some(b) = pb {
        b.finish_and_clear();
    }
    if !quiet {
        eprintln!(
            "{} entries in {:.1} s",
            todo.len(),
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

fn merge(a: MergeArgs) -> Result<()> {
    let table = precompute::merge(&a.dirs)?;
    table.write(&a.out)?;
    println!(
        "wrote {} ({} entries × {} values)",
        a.out.display(),
        table.header.nodes(),
        table.header.stride()
    );
    Ok(())
}
