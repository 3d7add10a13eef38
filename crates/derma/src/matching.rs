//! `derma match …`: fit render models to the Monte Carlo table, and the skin-colour LUT.

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_core::dtab::Dtab;
use derma_core::plot::{Plot, Series};
use derma_shading::annealing::Schedule;
use derma_shading::brdf_fit::{FitGeometry, FitOptions, Weighting};
use derma_shading::match_table::{self, MatchOptions, MatchTable};
use derma_shading::render_model::ModelKind;
use derma_shading::skin_color_lut::{LutOptions, SkinColorLut};
use derma_shading::{burley, sum_of_gaussians};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Subcommand)]
pub enum MatchCommand {
    /// Fit render models to every entry of a precompute table (from `derma optics merge`).
    Fit(FitArgs),
    /// The skin-colour lookup table of Jimenez et al. 2010 (melanin × hemoglobin → RGB).
    Lut(LutArgs),
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
    #[arg(long, value_enum, default_value = "cpu")]
    device: crate::optics::DeviceArg,
}

pub fn run(cmd: MatchCommand, quiet: bool) -> Result<()> {
    match cmd {
        MatchCommand::Fit(a) => fit(a, quiet),
        MatchCommand::Lut(a) => lut(a, quiet),
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

fn fit(a: FitArgs, quiet: bool) -> Result<()> {
    if a.out == a.grid {
        bail!("--out must differ from --grid (inputs are never overwritten)");
    }
    let models = parse_models(&a.model)?;
    let pre = Dtab::read(&a.grid).with_context(|| format!("reading {}", a.grid.display()))?;
    let opts = MatchOptions {
        models,
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
    };
    if !(a.max_zenith > 0.0 && a.max_zenith <= 90.0) {
        bail!("--max-zenith {}: expected degrees in (0, 90]", a.max_zenith);
    }
    let nodes = pre.header.nodes();
    let pb = crate::optics::progress_bar(nodes as u64, quiet, "fit", "entries");
    let t0 = Instant::now();
    let (table, summary) = match_table::fit_table(&pre, &opts, &|done| {
        if let Some(b) = &pb {
            b.set_position(done as u64)
        }
    })
    .with_context(|| format!("fitting {}", a.grid.display()))?;
    if let Some(b) = pb {
        b.finish_and_clear();
    }
    let secs = t0.elapsed().as_secs_f64();
    table
        .write(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    let csv_path = a.out.with_extension("residuals.csv");
    derma_core::atomic::write_bytes(&csv_path, residual_csv(&table, &opts).as_bytes())
        .with_context(|| format!("writing {}", csv_path.display()))?;
    println!(
        "fitted {nodes} entries × {} models in {secs:.1} s ({} weighting) → {}",
        opts.models.len(),
        opts.weighting.name(),
        a.out.display()
    );
    println!("relative RMS residual over the grid:");
    println!(
        "  {:<20} {:>8} {:>8} {:>8} {:>8}  worst node",
        "model", "mean", "median", "p90", "max"
    );
    for s in &summary {
        println!(
            "  {:<20} {:>8.4} {:>8.4} {:>8.4} {:>8.4}  {}",
            s.name, s.mean, s.median, s.p90, s.max, s.worst_node
        );
    }
    println!("per-entry residuals: {}", csv_path.display());
    if let Some(dir) = &a.plots {
        let mt = MatchTable::new(table, &a.out)?;
        let chosen = if a.plot_nodes.is_empty() {
            default_plot_nodes(&pre)
        } else {
            a.plot_nodes.clone()
        };
        for &n in &chosen {
            if n >= nodes {
                bail!("--plot-nodes: node {n} outside the table's {nodes} entries");
            }
        }
        derma_core::atomic::ensure_writable_dir(dir)?;
        let files = write_plots(&pre, &mt, &opts, &chosen, dir)?;
        println!("{} plots in {}", files, dir.display());
    }
    Ok(())
}

fn residual_csv(table: &Dtab, opts: &MatchOptions) -> String {
    let h = &table.header;
    let mut names: Vec<String> = opts.models.iter().map(|m| m.name().to_string()).collect();
    names.push("burley".into());
    names.push("sog".into());
    let mut s = String::new();
    s.push_str("node");
    for ax in &h.axes {
        s.push(',');
        s.push_str(&ax.name);
    }
    for n in &names {
        s.push_str(&format!(",{n}_relative_rms"));
    }
    s.push('\n');
    let stride = h.stride();
    for node in 0..h.nodes() {
        s.push_str(&node.to_string());
        let idx = node_indices(&h.axes, node);
        for (k, ax) in h.axes.iter().enumerate() {
            s.push_str(&format!(",{}", ax.values[idx[k]]));
        }
        for n in &names {
            let (o, _) = h.offset(&format!("{n}.rms")).expect("layout");
            s.push_str(&format!(",{:.6}", table.data[node * stride + o]));
        }
        s.push('\n');
    }
    s
}

/// Fair, medium and dark (melanin first/middle/last) with every other axis at its middle node.
fn default_plot_nodes(pre: &Dtab) -> Vec<usize> {
    let axes = &pre.header.axes;
    let mel = axes.iter().position(|a| a.name == "melanin").unwrap_or(0);
    let n_mel = axes[mel].values.len();
    let mut picks: Vec<usize> = vec![0, n_mel / 2, n_mel - 1];
    picks.dedup();
    picks
        .into_iter()
        .map(|m| {
            let mut flat = 0;
            for (k, a) in axes.iter().enumerate() {
                let i = if k == mel {
                    m
                } else {
                    (a.values.len() - 1) / 2
                };
                flat = flat * a.values.len() + i;
            }
            flat
        })
        .collect()
}

/// Per-axis node indices of flat node `node` (first axis slowest, as `.dtab` stores them).
fn node_indices(axes: &[derma_core::dtab::DtabAxis], node: usize) -> Vec<usize> {
    let mut rest = node;
    let mut idx = vec![0; axes.len()];
    for k in (0..axes.len()).rev() {
        idx[k] = rest % axes[k].values.len();
        rest /= axes[k].values.len();
    }
    idx
}

const COLOURS: [&str; 4] = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd"];

fn luminance(c: [f64; 3]) -> f64 {
    // Rec. 709 / sRGB luminance weights (ITU-R BT.709).
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn write_plots(
    pre: &Dtab,
    mt: &MatchTable,
    opts: &MatchOptions,
    nodes: &[usize],
    dir: &Path,
) -> Result<usize> {
    let grid = match_table::precompute_grid(pre)?;
    let bins = derma_optics::tally::BrdfBins {
        theta_in: grid.brdf[0],
        theta_out: grid.brdf[1],
        phi: grid.brdf[2],
    };
    let geom = FitGeometry::with_cutoff(bins, opts.weighting, opts.max_zenith_deg);
    let pstride = pre.header.stride();
    let mstride = mt.dtab.header.stride();
    let (bo, bl) = pre
        .header
        .offset("brdf_rgb")
        .context("precompute has no brdf_rgb")?;
    let (po, pl) = pre
        .header
        .offset("profile_rgb")
        .context("precompute has no profile_rgb")?;
    let mut count = 0;
    for &node in nodes {
        let sim: Vec<[f64; 3]> = pre.data[node * pstride + bo..node * pstride + bo + bl]
            .chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect();
        let row = &mt.dtab.data[node * mstride..(node + 1) * mstride];
        let fitted: Vec<(ModelKind, Vec<[f64; 3]>, f32)> = opts
            .models
            .iter()
            .map(|m| {
                let (o, l) = mt.dtab.header.offset(m.name()).expect("layout");
                let (ro, _) = mt
                    .dtab
                    .header
                    .offset(&format!("{}.rms", m.name()))
                    .expect("layout");
                let p: Vec<f64> = row[o..o + l].iter().map(|&v| v as f64).collect();
                (*m, geom.sample(m.model(), &p), row[ro])
            })
            .collect();
        let bio = describe_node(pre, node);
        let dtheta = 90.0 / bins.theta_out as f64;
        let ti_list: Vec<usize> = {
            let mut v = vec![0, bins.theta_in / 2, bins.theta_in.saturating_sub(2)];
            v.dedup();
            v
        };
        for &ti in &ti_list {
            // Incidence plane: Δφ bin 0 (light side, plotted at −θo) and the last bin (mirror
            // side, +θo).
            let curve = |v: &[[f64; 3]]| -> Vec<(f64, f64)> {
                let mut pts = Vec::new();
                for to in (0..bins.theta_out).rev() {
                    pts.push((
                        -(to as f64 + 0.5) * dtheta,
                        luminance(v[bins.index(ti, to, 0)]),
                    ));
                }
                for to in 0..bins.theta_out {
                    pts.push((
                        (to as f64 + 0.5) * dtheta,
                        luminance(v[bins.index(ti, to, bins.phi - 1)]),
                    ));
                }
                pts
            };
            let mut series = vec![Series {
                label: "Monte Carlo".into(),
                color: "#000000".into(),
                points: curve(&sim),
            }];
            for (k, (m, v, rms)) in fitted.iter().enumerate() {
                series.push(Series {
                    label: format!("{} ({:.1}%)", m.name(), rms * 100.0),
                    color: COLOURS[k % COLOURS.len()].into(),
                    points: curve(v),
                });
            }
            let theta_deg = (ti as f64 + 0.5) * 90.0 / bins.theta_in as f64;
            let plot = Plot {
                title: format!(
                    "BRDF in the plane of incidence, θi ≈ {theta_deg:.0}°, node {node} ({bio})"
                ),
                x_label: "θo (°): negative towards the light, positive on the mirror side".into(),
                y_label: "BRDF luminance (1/sr)".into(),
                log_y: true,
                series,
            };
            let name = format!("brdf-node{node}-theta{theta_deg:.0}.svg");
            derma_core::atomic::write_bytes(&dir.join(&name), plot.to_svg().as_bytes())
                .with_context(|| format!("writing {name}"))?;
            count += 1;
        }
        // Radial profile: simulation vs Burley and sum of Gaussians, red and blue.
        let prof: Vec<[f64; 3]> = pre.data[node * pstride + po..node * pstride + po + pl]
            .chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect();
        let dr = grid.profile_d_max_mm / grid.profile_bins as f64;
        let get = |name: &str| -> Vec<f64> {
            let (o, l) = mt.dtab.header.offset(name).expect("layout");
            row[o..o + l].iter().map(|&v| v as f64).collect()
        };
        let (ba, bd) = (get("burley.albedo"), get("burley.d_mm"));
        let var = get("sog.variance_mm2");
        let w = get("sog.weights");
        let sog = sum_of_gaussians::SogFit {
            weights: (0..var.len())
                .map(|k| [w[3 * k], w[3 * k + 1], w[3 * k + 2]])
                .collect(),
            variances_mm2: var,
            relative_rms: 0.0,
        };
        let mut series = Vec::new();
        for (c, cname, col) in [(0usize, "red", "#d62728"), (2, "blue", "#1f77b4")] {
            let rs: Vec<f64> = (0..grid.profile_bins)
                .map(|i| (i as f64 + 0.5) * dr)
                .filter(|&r| r <= 4.0)
                .collect();
            series.push(Series {
                label: format!("Monte Carlo {cname}"),
                color: "#000000".into(),
                points: rs
                    .iter()
                    .enumerate()
                    .map(|(i, &r)| (r, prof[i][c].max(1e-6)))
                    .collect(),
            });
            series.push(Series {
                label: format!("Burley {cname}"),
                color: col.into(),
                points: rs
                    .iter()
                    .map(|&r| (r, burley::profile(r, ba[c], bd[c]).max(1e-6)))
                    .collect(),
            });
            series.push(Series {
                label: format!("sum of Gaussians {cname}"),
                color: if c == 0 { "#ff9896" } else { "#aec7e8" }.into(),
                points: rs
                    .iter()
                    .map(|&r| (r, sum_of_gaussians::eval(&sog, r, c).max(1e-6)))
                    .collect(),
            });
        }
        let plot = Plot {
            title: format!("Radial diffusion profile, node {node} ({bio})"),
            x_label: "r (mm)".into(),
            y_label: "R(r) (1/mm²)".into(),
            log_y: true,
            series,
        };
        let name = format!("profile-node{node}.svg");
        derma_core::atomic::write_bytes(&dir.join(&name), plot.to_svg().as_bytes())
            .with_context(|| format!("writing {name}"))?;
        count += 1;
    }
    Ok(count)
}

fn describe_node(pre: &Dtab, node: usize) -> String {
    let axes = &pre.header.axes;
    node_indices(axes, node)
        .iter()
        .zip(axes)
        .filter(|(_, a)| a.name == "melanin" || a.name == "blood")
        .map(|(&i, a)| format!("{} {}", a.name, a.values[i]))
        .collect::<Vec<_>>()
        .join(", ")
}

fn lut(a: LutArgs, quiet: bool) -> Result<()> {
    for p in &a.out {
        match p.extension().and_then(|e| e.to_str()) {
            Some("png") | Some("dtab") => {}
            _ => bail!("--out {}: expected a .png or .dtab file name", p.display()),
        }
    }
    let opts = LutOptions {
        size: a.size,
        photons: a.photons,
        seed: a.seed,
        ..LutOptions::default()
    };
    let device = crate::optics::resolve(a.device);
    let pb = crate::optics::progress_bar(
        (a.size * a.size) as u64,
        quiet,
        "skin colour LUT",
        "entries",
    );
    let t0 = Instant::now();
    let lut = SkinColorLut::build(opts, device, &|d| {
        if let Some(b) = &pb {
            b.set_position(d as u64)
        }
    })?;
    if let Some(b) = pb {
        b.finish_and_clear();
    }
    for p in &a.out {
        if p.extension().and_then(|e| e.to_str()) == Some("png") {
            let ch = lut.channels().map(|mut m| {
                m.data_mut()
                    .iter_mut()
                    .for_each(|v| *v = derma_core::color::srgb_encode(v.clamp(0.0, 1.0)));
                m
            });
            derma_core::image_io::write_png16(p, &[&ch[0], &ch[1], &ch[2]])
                .with_context(|| format!("writing {}", p.display()))?;
        } else {
            lut.to_dtab()
                .write(p)
                .with_context(|| format!("writing {}", p.display()))?;
        }
        println!("wrote {}", p.display());
    }
    if !quiet {
        eprintln!(
            "{}×{} entries × {} photons in {:.1} s",
            a.size,
            a.size,
            a.photons,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
