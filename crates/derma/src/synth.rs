//! `derma synth`: grow a skin-detail texture of any size from a small exemplar (derma-synth,
//! after Shen et al.), on the CPU or the GPU, optionally tileable and guided by a mask.

use crate::args::DeviceArg;
use crate::output::line;
use crate::progress::Bars;
use anyhow::{Context, Result};
use clap::Args;
use derma_synth::job::SynthJob;
use derma_synth::SynthOptions;
use std::path::PathBuf;

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
    /// Self-adaptive optimisation (Shen et al. §3.3): windows inside one whose best match lies
    /// in a region holding FACTOR times the mean share of matches are optimised once, not
    /// searched again (0, the default: every window every pass; 2 saves time with --search
    /// exhaustive).
    #[arg(long, value_name = "FACTOR", default_value_t = derma_synth::settle::DEFAULT_FACTOR)]
    settle: f32,
    /// Which windows each search verifies: coherent (each window's coherent guesses, the
    /// exemplar windows most like them and a few random ones: k-coherence, a cost that does
    /// not grow with the exemplar) or exhaustive (every window: the exact best match).
    #[arg(long, value_enum, default_value_t = SearchArg::Coherent)]
    search: SearchArg,
    /// Guide map (grey): level v draws from exemplar round(v·(count − 1)).
    #[arg(long)]
    guide: Option<PathBuf>,
    /// Also print quality metrics against the (first) exemplar: patch SWD, verbatim-copy
    /// ratio, seam energy.
    #[arg(long)]
    metrics: bool,
}

/// `--search`'s values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum SearchArg {
    Coherent,
    Exhaustive,
}

pub fn run(args: SynthArgs, bars: &Bars) -> Result<()> {
    let job = SynthJob {
        exemplars: args.exemplar.clone(),
        channels: args.exemplar_channels,
        guide: args.guide,
        out: args.out,
        options: SynthOptions {
            width: args.size.0 as usize,
            height: args.size.1 as usize,
            patch: args.patch,
            passes: args.passes,
            tolerance: args.tolerance,
            occurrence: args.occurrence,
            correction: args.correction,
            settle: args.settle,
            search: match args.search {
                SearchArg::Coherent => derma_synth::coherence::Scope::Coherent,
                SearchArg::Exhaustive => derma_synth::coherence::Scope::Exhaustive,
            },
            seed: args.seed,
            tile: args.tile,
        },
        device: args.device.device,
        metrics: args.metrics,
    };
    let r = derma_synth::job::run(&job, bars).context("synthesising")?;
    bars.finish();
    let files: Vec<String> = r.outputs.iter().map(|p| p.display().to_string()).collect();
    bars.say(format!(
        "{}×{} texels from {} exemplar(s) in {:.2} s on {}: {}",
        args.size.0,
        args.size.1,
        args.exemplar.len(),
        r.seconds,
        r.matcher,
        files.join(", ")
    ));
    for timing in &r.timings {
        tracing::info!("{}: {:.3} s", timing.stage, timing.seconds);
    }
    for p in &r.passes {
        tracing::info!(
            "pass {0}×{0}: {1} of {2} windows searched",
            p.w,
            p.searched,
            p.windows
        );
    }
    if let Some(m) = r.metrics_json() {
        line(m)?;
    }
    Ok(())
}
