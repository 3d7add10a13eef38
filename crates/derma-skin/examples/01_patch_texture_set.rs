//! Build a tileable 20 × 20 mm skin patch through the library (no CLI) and write its maps.
//! `cargo run --release -p derma-skin --example 01_patch_texture_set -- out-patch/`

use derma_skin::config::{SkinConfig, SurfaceKind};
use derma_skin::generate::{generate, write_outputs, Inputs, NoProgress};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "out-patch".into());
    let mut cfg = SkinConfig {
        size: 512,
        seed: 3,
        ..SkinConfig::default()
    };
    cfg.surface.kind = SurfaceKind::Patch;
    cfg.surface.patch_size_mm = [20.0, 20.0];
    cfg.surface.tileable = true;
    // Moderately pigmented skin (Jacques 1998: 11–16 % melanosomes) with more freckles.
    cfg.baseline.melanin = derma_skin::config::Range {
        min: 0.11,
        max: 0.16,
    };
    cfg.freckle.density_per_cm2 = 60.0;
    let generated = generate(&cfg, &Inputs::default(), &NoProgress)?;
    let dir = std::path::Path::new(&out);
    derma_core::atomic::ensure_writable_dir(dir)?;
    let mut timings = generated.timings.clone();
    let (files, _) = write_outputs(dir, &generated, &mut timings)?;
    println!(
        "{} features; wrote {} files to {}",
        generated.features.total(),
        files.len(),
        dir.display()
    );
    for (stage, s) in timings {
        println!("  {stage:14} {s:.2} s");
    }
    Ok(())
}
