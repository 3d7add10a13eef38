//! An eyeball texture from one eye photo (Tarini et al. 2002 §4.1): a synthetic eye with lids
//! (or the photo given) → centre and radius, removals, the 1-D Markov chain in polar
//! coordinates, laid out on derma-head's eye globe UVs. Writes eye.png and iris_polar.png to a
//! temporary directory (or the one given).
//!   cargo run --release -p derma-photo --example 02_iris_texture [OUT_DIR [EYE_PHOTO]]

use derma_photo::iris::{iris_texture, synthetic_eye, IrisOptions};
use derma_photo::photo::RgbImage;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = args
        .get(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("derma-iris"));
    std::fs::create_dir_all(&out)?;
    let photo = match args.get(2) {
        Some(p) => RgbImage::read_linear(std::path::Path::new(p))?,
        None => synthetic_eye(320, 240, [161.3, 118.7], 64.0, 7),
    };
    let t = iris_texture(
        &photo,
        &IrisOptions {
            size: 512,
            ..Default::default()
        },
    )?;
    let r = &t.report;
    println!(
        "iris centre ({:.2}, {:.2}) radius {:.2} px, pupil {:.2} px, {:.0} % kept, sector {:.1}°, {}",
        r.centre[0], r.centre[1], r.radius, r.pupil_radius, 100.0 * r.kept_share, r.sector_deg, r.synthesis
    );
    t.texture.write_linear(&out.join("eye.png"))?;
    t.polar.write_linear(&out.join("iris_polar.png"))?;
    println!("wrote {}", out.display());
    Ok(())
}
