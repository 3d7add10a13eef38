//! Grows a texture from an exemplar image and reports its quality metrics.
//!
//! `cargo run --release -p derma-synth --example 01_grow -- EXEMPLAR.png SIZE OUT.png [PATCH] [SEED]`

use derma_core::image_io::{read_rgb, write_png8};
use derma_synth::quality::{patch_swd, seam_energy, verbatim_copy_ratio, SwdOptions};
use derma_synth::{synthesize, CpuMatcher, ExemplarSet, ProgressSink, SynthOptions, Texture};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        return Err("usage: 01_grow EXEMPLAR.png SIZE OUT.png [PATCH] [SEED]".into());
    }
    let img = read_rgb(&PathBuf::from(&args[0]))?;
    let maps: Vec<_> = if img.is_colour {
        img.channels.iter().collect()
    } else {
        vec![&img.channels[0]]
    };
    let exemplar = Texture::from_maps(&maps)?;
    let size: usize = args[1].parse()?;
    let patch: usize = args.get(3).map_or(Ok(32), |s| s.parse())?;
    let seed: u64 = args.get(4).map_or(Ok(1), |s| s.parse())?;
    let tolerance: f64 = args.get(5).map_or(Ok(0.1), |s| s.parse())?;
    let passes: usize = args.get(6).map_or(Ok(3), |s| s.parse())?;
    let occurrence: f64 = args.get(7).map_or(Ok(1.0), |s| s.parse())?;
    let opts = SynthOptions {
        width: size,
        height: size,
        patch,
        seed,
        tolerance,
        passes,
        occurrence,
        ..Default::default()
    };
    let set = ExemplarSet::new(vec![exemplar.clone()], patch)?;
    let t = Instant::now();
    let out = synthesize(&set, &opts, None, &CpuMatcher, &ProgressSink::default())?;
    let secs = t.elapsed().as_secs_f64();
    let channels: Vec<_> = (0..out.texture.channels)
        .map(|k| out.texture.channel(k))
        .collect();
    write_png8(
        &PathBuf::from(&args[2]),
        &channels.iter().collect::<Vec<_>>(),
    )?;
    let swd = patch_swd(&out.texture, &exemplar, &SwdOptions::default())?;
    println!(
        "{size}² in {secs:.2} s; patch SWD {swd:.4}, verbatim-copy ratio {:.3}, seam energy {:.3}",
        verbatim_copy_ratio(&out.texture, &exemplar, 32)?,
        seam_energy(&out.texture, patch / 2)?
    );
    Ok(())
}
