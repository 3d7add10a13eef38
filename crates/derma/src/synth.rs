//! `derma synth`: grow a skin-detail texture of any size from a small exemplar (derma-synth,
//! after Shen et al.), on the CPU or the GPU, optionally tileable and guided by a mask.

use crate::output::line;
use crate::progress::Bars;
use crate::DeviceArg;
use anyhow::{bail, Context, Result};
use clap::Args;
use derma_synth::files::{load_exemplars, output_paths, write_outputs};
use derma_synth::quality::Metrics;
use derma_synth::{Guide, SynthOptions, Synthesizer};
use std::path::PathBuf;
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
    #[arg(long, value_parser = crate::args::named_files)]
    exemplar_channels: Vec<Vec<(String, PathBuf)>>,
    /// Output size: W or WxH texels.
    #[arg(long, default_value = "512", value_parser = crate::args::size)]
    size: (u32, u32),
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Tileable output (wraps at the edges).
    #[arg(long)]
    tile: bool,
    /// Where the searches run (the same texture on every device).
    #[command(flatten)]
    device: DeviceArg,
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
    /// Texel-level coherent correction passes after the optimisation, which restore the
    /// exemplar's finest grain (0 = off, as the paper).
    #[arg(long, default_value_t = 1)]
    correction: usize,
    /// Guide map (grey): level v draws from exemplar round(v·(count − 1)).
    #[arg(long)]
    guide: Option<PathBuf>,
    /// Also print quality metrics against the (first) exemplar: patch SWD, verbatim-copy
    /// ratio, seam energy.
    #[arg(long)]
    metrics: bool,
}

pub fn run(args: SynthArgs, bars: &Bars) -> Result<()> {
    let files = load_exemplars(&args.exemplar, &args.exemplar_channels)?;
    let outputs = output_paths(&args.out, &files.groups)?;
    for o in &outputs {
        if let Some(parent) = o.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("cannot create '{}'", parent.display()))?;
        }
    }
    let mut inputs: Vec<&std::path::Path> = files.inputs.iter().map(PathBuf::as_path).collect();
    inputs.extend(args.guide.as_deref());
    derma_core::atomic::check_inputs_spared(&outputs, &inputs)?;
    let mut textures = files.textures.into_iter();
    let first = textures.next().context("no exemplar")?;
    // The metrics compare with the first exemplar; keep a copy only when they are asked for.
    let exemplar = args.metrics.then(|| first.clone());
    let mut synth = Synthesizer::new(first)
        .options(SynthOptions {
            width: args.size.0 as usize,
            height: args.size.1 as usize,
            patch: args.patch,
            passes: args.passes,
            tolerance: args.tolerance,
            occurrence: args.occurrence,
            correction: args.correction,
            seed: args.seed,
            tile: args.tile,
            ..Default::default()
        })
        .device(args.device.device)
        .progress(bars);
    for t in textures {
        synth = synth.exemplar(t);
    }
    if let Some(g) = &args.guide {
        if args.exemplar.len() < 2 {
            bail!("--guide chooses among exemplars: give at least two --exemplar");
        }
        synth = synth.guide(
            Guide::read(g, args.exemplar.len())
                .with_context(|| format!("reading the guide '{}'", g.display()))?,
        );
    }
    let t = Instant::now();
    let out = synth.run().context("synthesising")?;
    let secs = t.elapsed().as_secs_f64();
    bars.finish();
    write_outputs(&outputs, &files.groups, &out.texture)?;
    bars.say(format!(
        "{}×{} texels from {} exemplar(s) in {secs:.2} s on {}: {}",
        args.size.0,
        args.size.1,
        args.exemplar.len(),
        out.matcher,
        outputs
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    ));
    for timing in &out.timings {
        tracing::info!("{}: {:.3} s", timing.stage, timing.seconds);
    }
    if let Some(exemplar) = &exemplar {
        let stages: serde_json::Map<String, serde_json::Value> = out
            .timings
            .iter()
            .map(|t| (t.stage.clone(), serde_json::json!(t.seconds)))
            .collect();
        let m = Metrics::measure(&out.texture, exemplar, args.patch)?;
        let metrics = serde_json::json!({
            "seconds": secs,
            "stages": stages,
            "patch_swd": m.patch_swd,
            "patch_swd_half": m.patch_swd_half,
            "patch_swd_quarter": m.patch_swd_quarter,
            "contrast_ratio": m.contrast_ratio,
            "grain_ratio": m.grain_ratio,
            "verbatim_copy_ratio": m.verbatim_copy_ratio,
            "seam_energy": m.seam_energy,
        });
        line(metrics)?;
    }
    Ok(())
}
