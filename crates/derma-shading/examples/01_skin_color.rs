//! Skin colour from biology through derma's appearances: the base colour (linear sRGB and
//! sRGB hex) and subsurface scatter distance of fair, medium and dark skin at low and high
//! blood, from the built-in Monte Carlo match table and from the analytic spectral
//! Kubelka–Munk model, and the skin-colour LUT the rig colours with (Jimenez et al. 2010).
//!
//! `cargo run --release -p derma-shading --example 01_skin_color`

use derma_core::color::srgb_encode;
use derma_shading::skin_color_lut::SkinColorLut;
use derma_shading::{Appearance, BioTexel, SpectralKubelkaMunk, TableAppearance};

fn hex(rgb: [f32; 3]) -> String {
    rgb.iter()
        .map(|&c| format!("{:02x}", (srgb_encode(c) * 255.0).round() as u8))
        .collect()
}

fn main() {
    let table = TableAppearance::builtin();
    let analytic = SpectralKubelkaMunk::default();
    let lut = SkinColorLut::builtin();
    println!(
        "{:<22} {:>7}  {:<30} {:<30} {:>15}",
        "skin", "blood", "match table: base (sRGB)", "analytic: base (sRGB)", "scatter R,G,B mm"
    );
    for (label, melanin) in [
        ("fair (melanin 2 %)", 0.02),
        ("medium (10 %)", 0.10),
        ("dark (35 %)", 0.35),
    ] {
        for blood in [0.01, 0.05] {
            let bio = BioTexel {
                melanin,
                blood,
                ..BioTexel::FAIR
            };
            let (t, sub) = table.shade(&bio);
            let a = analytic.albedo(&bio);
            let r = sub.map_or([0.0; 3], |s| s.radius_mm);
            println!(
                "{label:<22} {blood:>7.2}  {:<30} {:<30} {:>5.2},{:.2},{:.2}",
                format!("{:.3?} #{}", t, hex(t)),
                format!("{:.3?} #{}", a, hex(a)),
                r[0],
                r[1],
                r[2]
            );
        }
    }
    // The rig's LUT: colour by melanin and dermal hemoglobin (eq. 7).
    println!(
        "\nskin-colour LUT ({}² entries), sRGB hex:",
        lut.options.size
    );
    for blood in [0.005, 0.02, 0.08] {
        let row: Vec<String> = [0.02, 0.1, 0.35]
            .iter()
            .map(|&m| hex(lut.lookup(m, blood).map(|c| c as f32)))
            .collect();
        println!(
            "  hemoglobin {blood:<5}  melanin 2 % / 10 % / 35 %: {}",
            row.join("  ")
        );
    }
}
