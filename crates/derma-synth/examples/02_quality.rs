//! Quality metrics of a synthesised image against its exemplar (as used by `bench/synth.sh`).
//!
//! `cargo run --release -p derma-synth --example 02_quality -- EXEMPLAR.png OUTPUT.png [STEP]`
//! prints: patch SWD, verbatim-copy ratio (32² blocks), seam energy at the given patch step.

use derma_core::image_io::read_rgb;
use derma_synth::quality::{patch_swd, seam_energy, verbatim_copy_ratio, SwdOptions};
use derma_synth::Texture;
use std::path::Path;

fn load(path: &str, colour: Option<bool>) -> Result<(Texture, bool), Box<dyn std::error::Error>> {
    let img = read_rgb(Path::new(path))?;
    let colour = colour.unwrap_or(img.is_colour);
    let maps: Vec<_> = if colour {
        img.channels.iter().collect()
    } else {
        vec![&img.channels[0]]
    };
    Ok((Texture::from_maps(&maps)?, colour))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        return Err("usage: 02_quality EXEMPLAR OUTPUT [STEP]".into());
    }
    let (ex, colour) = load(&args[0], None)?;
    let (out, _) = load(&args[1], Some(colour))?;
    let step: usize = args.get(2).map_or(Ok(16), |s| s.parse())?;
    println!(
        "swd {:.5} verbatim {:.4} seam {:.4}",
        patch_swd(&out, &ex, &SwdOptions::default())?,
        verbatim_copy_ratio(&out, &ex, 32)?,
        seam_energy(&out, step)?
    );
    Ok(())
}
