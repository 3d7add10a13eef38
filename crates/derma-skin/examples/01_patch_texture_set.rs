//! Build a tileable 20 × 20 mm skin patch through the library (no CLI) and write its texture
//! set: the builder, the result in memory, and every file with manifest and report.
//! `cargo run --release -p derma-skin --example 01_patch_texture_set -- [OUT_DIR]`

use derma_skin::config::{Range, SurfaceKind};
use derma_skin::{SkinConfig, SkinGenerator};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| {
        std::env::temp_dir()
            .join("derma-patch")
            .display()
            .to_string()
    });
    let mut cfg = SkinConfig {
        size: 256,
        seed: 3,
        ..SkinConfig::default()
    };
    cfg.surface.kind = SurfaceKind::Patch;
    cfg.surface.patch_size_mm = [20.0, 20.0];
    cfg.surface.tileable = true;
    // Moderately pigmented skin (Jacques 1998: 11–16 % melanosomes) with more freckles.
    cfg.baseline.melanin = Range {
        min: 0.11,
        max: 0.16,
    };
    cfg.freckle.density_per_cm2 = 60.0;
    let dir = std::path::Path::new(&out);
    let generator = SkinGenerator::new(cfg);
    generator.check_output(dir)?;
    let set = generator.run()?;
    println!(
        "{} features: {}",
        set.features.total(),
        set.features.counts().summary()
    );
    let written = set.write(dir, &derma_core::progress::Silent)?;
    println!("wrote {} files to {}", written.files.len(), dir.display());
    for t in &written.log.timings {
        println!("  {:14} {:.2} s", t.stage, t.seconds);
    }
    Ok(())
}
