//! Prints the colour table of docs/head.md: for each skin-tone preset, the mean CIELAB (D65) and
//! ITA° of the base colour per region of the built-in head, and the coarse a* deviation over the
//! face. Run: `cargo run --release -p derma-skin --example 02_preset_color_table [SIZE [SEED]]`
//! (seed 1 by default; another seed checks the calibration on skin it was not tuned on).

use derma_skin::color_stats::{coarse_std, region_colors};
use derma_skin::regional::{Preset, Sex};
use derma_skin::{SkinConfig, SkinGenerator};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let size: u32 = std::env::args().nth(1).map_or(Ok(512), |s| s.parse())?;
    let seed: u64 = std::env::args().nth(2).map_or(Ok(1), |s| s.parse())?;
    let regions = [
        "forehead",
        "cheeks",
        "nose",
        "periorbital",
        "ears",
        "lips",
        "chin",
        "neck",
    ];
    println!("| preset (ITA° band) | region | L* | a* | b* | ITA° |");
    println!("|---|---|---|---|---|---|");
    for p in Preset::ALL {
        let cfg = SkinConfig {
            size,
            seed,
            person: p.person(Sex::Male, 35.0),
            ..SkinConfig::default()
        };
        let set = SkinGenerator::new(cfg).run()?;
        let (lo, hi) = p.band();
        for c in region_colors(&set, &regions)? {
            println!(
                "| {} ({lo:.0}…{hi:.0}) | {} | {:.1} | {:.1} | {:.1} | {:.1} |",
                p.name(),
                c.region,
                c.lab[0],
                c.lab[1],
                c.lab[2],
                c.ita_deg
            );
        }
        let sd = coarse_std(&set, "face", 5.0)?;
        println!(
            "| {} | face, coarse σ (5 mm blocks) | {:.1} | {:.1} | {:.1} | |",
            p.name(),
            sd[0],
            sd[1],
            sd[2]
        );
    }
    Ok(())
}
