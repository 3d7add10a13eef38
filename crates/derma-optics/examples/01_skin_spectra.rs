//! Diffuse reflectance spectra of fair, medium and dark skin from the Monte Carlo specimen,
//! plotted into one SVG (docs/images/optics-spectra.svg in the repository).
//!
//! `cargo run --release -p derma-optics --example 01_skin_spectra -- [OUT.svg] [PHOTONS]`

use derma_core::plot::Plot;
use derma_core::progress::Silent;
use derma_optics::plots::spectrum_series;
use derma_optics::simulate::{simulate_skin, SkinSimConfig};
use derma_optics::{BioTexel, Device};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| {
        std::env::temp_dir()
            .join("derma-optics-spectra.svg")
            .display()
            .to_string()
    });
    let photons: u64 = args.next().map_or(Ok(2_050_000), |s| s.parse())?;
    let cfg = SkinSimConfig {
        photons,
        ..SkinSimConfig::default()
    };
    let mut series = Vec::new();
    for (label, melanin, color) in [
        ("fair (melanin 2 %)", 0.02, "#e377c2"),
        ("medium (10 %)", 0.10, "#bc6c25"),
        ("dark (35 %)", 0.35, "#4a2c1d"),
    ] {
        let bio = BioTexel {
            melanin,
            ..BioTexel::FAIR
        };
        let r = simulate_skin(&bio, &cfg, Device::Cpu, &Silent)?;
        println!(
            "{label}: linear sRGB {:.3?}, {:.1} s",
            r.linear_srgb, r.seconds
        );
        series.push(spectrum_series(label, color, &r, &r.r_diffuse));
    }
    let plot = Plot::new(
        format!("Skin diffuse reflectance, Monte Carlo ({photons} photons each)"),
        "wavelength (nm)",
        "diffuse reflectance",
        series,
    );
    derma_core::atomic::write_bytes(std::path::Path::new(&out), plot.to_svg().as_bytes())?;
    println!("wrote {out}");
    Ok(())
}
