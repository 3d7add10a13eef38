//! Grows a texture from an exemplar image through the library's builder and reports its
//! quality metrics. Without arguments it grows 256² from a 64² exemplar of its own (smooth
//! noise), so it runs anywhere.
//!
//! `cargo run --release -p derma-synth --example 01_grow -- [EXEMPLAR.png SIZE OUT.png [PATCH] [SEED]]`

use derma_core::image_io::write_png16;
use derma_core::rng::Philox;
use derma_synth::files::{load_channels, write_group};
use derma_synth::quality::Metrics;
use derma_synth::{Synthesizer, Texture};
use std::path::PathBuf;
use std::time::Instant;

/// A 64² exemplar of blurred white noise (a stand-in for a skin crop).
fn built_in_exemplar() -> Texture {
    let n = 64;
    let rng = Philox::new(7, 1);
    let noise: Vec<f32> = (0..n * n).map(|i| rng.uniform4(i as u64, 0)[0]).collect();
    let blurred: Vec<f32> = (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            let mut s = 0.0;
            for d in 0..9 {
                let (dx, dy) = (d % 3, d / 3);
                s += noise[((y + dy + n - 1) % n) * n + (x + dx + n - 1) % n];
            }
            s / 9.0
        })
        .collect();
    Texture::new(n, n, 1, blurred).expect("size")
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (exemplar, size, out) = if args.len() >= 3 {
        let maps = load_channels(&PathBuf::from(&args[0]))?;
        let exemplar = Texture::from_maps(&maps.iter().collect::<Vec<_>>())?;
        (exemplar, args[1].parse()?, PathBuf::from(&args[2]))
    } else {
        let e = built_in_exemplar();
        let p = std::env::temp_dir().join("derma-01-grow-exemplar.png");
        write_png16(&p, &[&e.channel(0)])?;
        println!("no exemplar given: a 64² noise exemplar ({})", p.display());
        (e, 256, std::env::temp_dir().join("derma-01-grow.png"))
    };
    let patch: usize = args.get(3).map_or(Ok(32), |s| s.parse())?;
    let seed: u64 = args.get(4).map_or(Ok(1), |s| s.parse())?;
    let t = Instant::now();
    let synthesis = Synthesizer::new(exemplar.clone())
        .size(size, size)
        .patch(patch)
        .seed(seed)
        .run()?;
    let secs = t.elapsed().as_secs_f64();
    let texture = &synthesis.texture;
    let channels: Vec<_> = (0..texture.channels).map(|k| texture.channel(k)).collect();
    write_group(&out, &channels)?;
    let m = Metrics::measure(texture, &exemplar, patch)?;
    println!(
        "{size}² in {secs:.2} s on {}; patch SWD {:.4}, verbatim-copy ratio {:.3}, seam energy {:.3} → {}",
        synthesis.matcher,
        m.patch_swd,
        m.verbatim_copy_ratio,
        m.seam_energy,
        out.display()
    );
    Ok(())
}
