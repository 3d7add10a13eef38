//! `derma synth`: grow a skin-detail texture of any size from a small exemplar (derma-synth,
//! after Shen et al.), on the CPU or the GPU, optionally tileable and guided by a mask.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use derma_core::image_io::{read_rgb, write_exr, write_png16, write_png8, ExrPrecision};
use derma_core::Map;
use derma_synth::quality::{patch_swd, seam_energy, verbatim_copy_ratio, SwdOptions};
use derma_synth::{
    synthesize, CpuMatcher, ExemplarSet, GpuMatcher, Guide, Matcher, ProgressSink, SynthOptions,
    Texture,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(Args)]
pub struct SynthArgs {
    /// Exemplar image (PNG or EXR; grey → 1 channel, colour → 3). Give it more than once, with
    /// --guide, to draw different regions from different exemplars.
    #[arg(long, required = true)]
    exemplar: Vec<PathBuf>,
    /// Further channels registered with the exemplar, synthesised jointly: NAME=FILE[,NAME=FILE…]
    /// (e.g. height=h.png,normal=n.png). With several --exemplar, give it once per exemplar, in
    /// the same order, with the same names.
    #[arg(long)]
    exemplar_channels: Vec<String>,
    /// Output size: W or WxH texels.
    #[arg(long, default_value = "512", value_parser = parse_size)]
    size: (usize, usize),
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Tileable output (wraps at the edges).
    #[arg(long)]
    tile: bool,
    #[arg(long, value_enum, default_value = "cpu")]
    device: Device,
    /// Output file (.png or .exr); further channels go to FILE_NAME.ext beside it.
    #[arg(long)]
    out: PathBuf,
    /// Patch side N (even); the displacement is N/2 (Shen et al. §3.2).
    #[arg(long, default_value_t = 32)]
    patch: usize,
    /// Optimisation passes, each with a quarter of the last one's neighbourhood (≥ 3 in §3.3).
    #[arg(long, default_value_t = 3)]
    passes: usize,
    /// Choice among near-best patches: image quilting's ε (0 = the best match only).
    #[arg(long, default_value_t = 0.1)]
    tolerance: f64,
    /// Weight of the occurrence penalty that keeps the whole exemplar in use (0 = off).
    #[arg(long, default_value_t = 1.0)]
    occurrence: f64,
    /// Guide map (grey): level v draws from exemplar round(v·(count − 1)).
    #[arg(long)]
    guide: Option<PathBuf>,
    /// Also print quality metrics against the (first) exemplar: patch SWD, verbatim-copy
    /// ratio, seam energy.
    #[arg(long)]
    metrics: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum Device {
    Cpu,
    Gpu,
}

fn parse_size(s: &str) -> std::result::Result<(usize, usize), String> {
    let parse = |v: &str| {
        v.trim()
            .parse::<usize>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("'{s}' is not a size: expected W or WxH, positive integers"))
    };
    match s.split_once(['x', 'X']) {
        Some((w, h)) => Ok((parse(w)?, parse(h)?)),
        None => parse(s).map(|n| (n, n)),
    }
}

/// One named group of channels of an exemplar set (the main image, or NAME=FILE).
struct Group {
    name: Option<String>,
    channels: usize,
}

/// Loads an image as its channels: colour → 3, grey → 1.
fn load_channels(path: &Path) -> Result<Vec<Map>> {
    let img = read_rgb(path).with_context(|| format!("reading exemplar '{}'", path.display()))?;
    Ok(if img.is_colour {
        img.channels
    } else {
        img.channels.into_iter().take(1).collect()
    })
}

fn parse_channels(spec: &str) -> Result<Vec<(String, PathBuf)>> {
    spec.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|item| {
            let (name, file) = item.split_once('=').with_context(|| {
                format!("--exemplar-channels '{item}': expected NAME=FILE (e.g. height=h.png)")
            })?;
            let name = name.trim();
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                bail!("--exemplar-channels: the name '{name}' must be letters, digits, '_' or '-'");
            }
            Ok((name.to_string(), PathBuf::from(file.trim())))
        })
        .collect()
}

/// Loads every exemplar with its registered channels into textures of one layout.
fn load_exemplars(args: &SynthArgs) -> Result<(Vec<Texture>, Vec<Group>, Vec<PathBuf>)> {
    if !args.exemplar_channels.is_empty() && args.exemplar_channels.len() != args.exemplar.len() {
        bail!(
            "--exemplar-channels was given {} times for {} --exemplar; give it once per exemplar",
            args.exemplar_channels.len(),
            args.exemplar.len()
        );
    }
    let mut textures = Vec::new();
    let mut layout: Option<Vec<Group>> = None;
    let mut inputs = Vec::new();
    for (i, path) in args.exemplar.iter().enumerate() {
        let main = load_channels(path)?;
        inputs.push(path.clone());
        let mut groups = vec![Group {
            name: None,
            channels: main.len(),
        }];
        let mut maps = main;
        if let Some(spec) = args.exemplar_channels.get(i) {
            for (name, file) in parse_channels(spec)? {
                let extra = load_channels(&file)?;
                inputs.push(file.clone());
                if (extra[0].width(), extra[0].height()) != (maps[0].width(), maps[0].height()) {
                    bail!(
                        "exemplar channel '{name}' ('{}') is {}×{}, but '{}' is {}×{}: registered channels must have the exemplar's size",
                        file.display(),
                        extra[0].width(),
                        extra[0].height(),
                        path.display(),
                        maps[0].width(),
                        maps[0].height()
                    );
                }
                groups.push(Group {
                    name: Some(name),
                    channels: extra.len(),
                });
                maps.extend(extra);
            }
        }
        match &layout {
            None => layout = Some(groups),
            Some(l) => {
                let same = l.len() == groups.len()
                    && l.iter()
                        .zip(&groups)
                        .all(|(a, b)| a.name == b.name && a.channels == b.channels);
                if !same {
                    bail!(
                        "exemplar '{}' has another channel layout than the first; all exemplars need the same channels",
                        path.display()
                    );
                }
            }
        }
        textures.push(Texture::from_maps(&maps.iter().collect::<Vec<_>>())?);
    }
    Ok((textures, layout.unwrap_or_default(), inputs))
}

/// Path of a channel group's output: the main one is `out`, NAME goes to `stem_NAME.ext`.
fn group_path(out: &Path, name: Option<&str>) -> PathBuf {
    match name {
        None => out.to_path_buf(),
        Some(n) => {
            let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("synth");
            let ext = out.extension().and_then(|s| s.to_str()).unwrap_or("png");
            out.with_file_name(format!("{stem}_{n}.{ext}"))
        }
    }
}

fn write_group(path: &Path, maps: &[Map]) -> Result<()> {
    let refs: Vec<&Map> = maps.iter().collect();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => {
            let names: &[&str] = if maps.len() == 3 {
                &["R", "G", "B"]
            } else {
                &["Y"]
            };
            let ch: Vec<(&str, &Map)> = names.iter().copied().zip(refs).collect();
            write_exr(path, &ch, ExrPrecision::F32)?
        }
        // Colour as 8-bit (as stored: no transfer applied), single channels as 16-bit so
        // heights keep their precision.
        Some("png") if maps.len() == 3 => write_png8(path, &refs)?,
        Some("png") => write_png16(path, &refs)?,
        _ => bail!(
            "--out '{}': expected a .png or .exr file name",
            path.display()
        ),
    }
    Ok(())
}

pub fn run(args: SynthArgs, quiet: bool) -> Result<()> {
    let (textures, groups, inputs) = load_exemplars(&args)?;
    let outputs: Vec<PathBuf> = groups
        .iter()
        .map(|g| group_path(&args.out, g.name.as_deref()))
        .collect();
    for o in &outputs {
        let ext = o
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("png" | "exr")) {
            bail!("--out '{}': expected a .png or .exr file name", o.display());
        }
        if let Some(parent) = o.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("cannot create '{}'", parent.display()))?;
        }
        for i in inputs.iter().chain(args.guide.iter()) {
            let same = match (i.canonicalize(), o.canonicalize()) {
                (Ok(a), Ok(b)) => a == b,
                _ => false,
            };
            if same {
                bail!(
                    "output '{}' is the input '{}'; derma never writes over its inputs — pick another --out",
                    o.display(),
                    i.display()
                );
            }
        }
    }
    let set = ExemplarSet::new(textures, args.patch).context("preparing the exemplars")?;
    let guide = match &args.guide {
        None => None,
        Some(path) => {
            if args.exemplar.len() < 2 {
                bail!("--guide chooses among exemplars: give at least two --exemplar");
            }
            let g = derma_core::image_io::read_grey(path)
                .with_context(|| format!("reading the guide '{}'", path.display()))?;
            let m = &g.channels[0];
            Some(Guide::from_levels(
                m.width(),
                m.height(),
                m.data(),
                args.exemplar.len(),
            ))
        }
    };
    let opts = SynthOptions {
        width: args.size.0,
        height: args.size.1,
        patch: args.patch,
        passes: args.passes,
        tolerance: args.tolerance,
        occurrence: args.occurrence,
        seed: args.seed,
        tile: args.tile,
        ..Default::default()
    };
    let matcher: Box<dyn Matcher> = match args.device {
        Device::Cpu => Box::new(CpuMatcher),
        Device::Gpu => Box::new(GpuMatcher::new().context("--device gpu")?),
    };
    let bar = crate::optics::progress_bar(0, quiet, "synth", "windows").map(Arc::new);
    let progress = match &bar {
        None => ProgressSink::default(),
        Some(b) => {
            let (b1, b2) = (b.clone(), b.clone());
            ProgressSink {
                on_stage: Some(Box::new(move |name, total| {
                    b1.set_message(name.to_string());
                    b1.set_length(total);
                    b1.set_position(0);
                })),
                on_advance: Some(Box::new(move |n| b2.inc(n))),
            }
        }
    };
    let t = Instant::now();
    let out = synthesize(&set, &opts, guide.as_ref(), matcher.as_ref(), &progress)
        .context("synthesising")?;
    let secs = t.elapsed().as_secs_f64();
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut k = 0;
    for (g, path) in groups.iter().zip(&outputs) {
        let maps: Vec<Map> = (k..k + g.channels)
            .map(|c| out.texture.channel(c))
            .collect();
        k += g.channels;
        write_group(path, &maps).with_context(|| format!("writing '{}'", path.display()))?;
    }
    if !quiet {
        eprintln!(
            "{}×{} texels from {} exemplar(s) in {secs:.2} s on {}: {}",
            opts.width,
            opts.height,
            set.exemplars.len(),
            matcher.name(),
            outputs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for (stage, s) in &out.stage_seconds {
        tracing::info!("{stage}: {s:.3} s");
    }
    if args.metrics {
        let ex = &set.exemplars[0].texture;
        let stages: serde_json::Map<String, serde_json::Value> = out
            .stage_seconds
            .iter()
            .map(|(k, v)| (k.clone(), serde_json::json!(v)))
            .collect();
        let metrics = serde_json::json!({
            "seconds": secs,
            "stages": stages,
            "patch_swd": patch_swd(&out.texture, ex, &SwdOptions::default())?,
            "verbatim_copy_ratio": verbatim_copy_ratio(&out.texture, ex, 32)?,
            "seam_energy": seam_energy(&out.texture, args.patch / 2)?,
        });
        println!("{metrics}");
    }
    Ok(())
}
