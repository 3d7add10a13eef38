//! Quality metrics of a synthesised image against its exemplar (as used by `bench/synth.sh`).
//!
//! `cargo run --release -p derma-synth --example 02_quality -- EXEMPLAR.png OUTPUT.png [STEP]`
//! prints: patch SWD at full, half and quarter resolution, contrast and grain ratios,
//! verbatim-copy ratio (32² blocks), seam energy at the given patch step.
//! Without arguments it scores two images of its own against a noise exemplar, to show what the
//! metrics see: the exemplar tiled 4 × 4 (a pure copy: verbatim ratio 1, patch statistics as the
//! exemplar's) and white noise (nothing copied, but far in patch statistics).

use derma_core::image_io::read_rgb;
use derma_core::rng::Philox;
use derma_synth::quality::Metrics;
use derma_synth::Texture;
use std::path::Path;

fn load(path: &str, color: Option<bool>) -> Result<(Texture, bool), Box<dyn std::error::Error>> {
    let img = read_rgb(Path::new(path))?;
    let color = color.unwrap_or(img.is_color);
    let maps: Vec<_> = if color {
        img.channels.iter().collect()
    } else {
        vec![&img.channels[0]]
    };
    Ok((Texture::from_maps(&maps)?, color))
}

fn score(out: &Texture, ex: &Texture, step: usize) -> Result<String, Box<dyn std::error::Error>> {
    let m = Metrics::measure(out, ex, 2 * step)?;
    Ok(format!(
        "swd {:.5} swd_half {:.5} swd_quarter {:.5} contrast {:.3} grain {:.3} verbatim {:.4} seam {:.4}",
        m.patch_swd,
        m.patch_swd_half,
        m.patch_swd_quarter,
        m.contrast_ratio,
        m.grain_ratio,
        m.verbatim_copy_ratio,
        m.seam_energy
    ))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() >= 2 {
        let (ex, color) = load(&args[0], None)?;
        let (out, _) = load(&args[1], Some(color))?;
        let step: usize = args.get(2).map_or(Ok(16), |s| s.parse())?;
        println!("{}", score(&out, &ex, step)?);
        return Ok(());
    }
    // A 64² exemplar: sums of two random sine waves, smooth like skin relief.
    let n = 64;
    let rng = Philox::new(3, 1);
    let [a, b, c, d] = rng.uniform4(0, 0);
    let wave = |x: usize, y: usize| {
        let (x, y) = (x as f32 / n as f32, y as f32 / n as f32);
        let t = std::f32::consts::TAU;
        0.5 + 0.25 * (t * (2.0 * x + 3.0 * y) + 6.0 * a).sin() * b
            + 0.25 * (t * (5.0 * x - y) + 6.0 * c).sin() * d
    };
    let ex = Texture::new(n, n, 1, (0..n * n).map(|i| wave(i % n, i / n)).collect())?;
    let tiled = Texture::new(
        4 * n,
        4 * n,
        1,
        (0..16 * n * n)
            .map(|i| ex.data[((i / (4 * n)) % n) * n + (i % (4 * n)) % n])
            .collect(),
    )?;
    let noise = Texture::new(
        4 * n,
        4 * n,
        1,
        (0..16 * n * n)
            .map(|i| rng.uniform4(1 + i as u64, 0)[0])
            .collect(),
    )?;
    println!("exemplar tiled 4×4: {}", score(&tiled, &ex, n)?);
    println!("white noise:        {}", score(&noise, &ex, n)?);
    Ok(())
}
