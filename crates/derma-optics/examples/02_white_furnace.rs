//! The skin surface in the white furnace: π·BRDF against the outgoing zenith for three
//! incidences, with the Smith microsurface (derma's default) and with the thesis' sampling, and
//! the light each outgoing zenith receives from all incidences (1 where energy is conserved).
//!
//! cargo run --release -p derma-optics --example 02_white_furnace -- [OUT.svg] [PHOTONS]
//! (default: a temporary file and 200 000 photons; docs/images/optics-furnace.svg used 10⁷)

use derma_core::progress::Silent;
use derma_optics::furnace::{furnace, plot};
use derma_optics::specimen::SurfaceModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args
        .first()
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("derma-optics-furnace.svg"));
    let photons: u64 = args
        .get(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(200_000);
    let smith = furnace(SurfaceModel::Smith, photons, 1, 9, &Silent)?;
    let thesis = furnace(SurfaceModel::Thesis, photons, 1, 9, &Silent)?;
    println!("θo      light received (Smith, thesis)   π·f at θi 5° (Smith, thesis)");
    for to in 0..9 {
        println!(
            "{:>2}–{:<2}°  {:>6.3} {:>6.3}                    {:>6.3} {:>6.3}",
            10 * to,
            10 * to + 10,
            smith.reciprocal_albedo[to],
            thesis.reciprocal_albedo[to],
            smith.pi_brdf[0][to],
            thesis.pi_brdf[0][to]
        );
    }
    let svg = plot(
        &[
            (SurfaceModel::Thesis, &thesis),
            (SurfaceModel::Smith, &smith),
        ],
        &[0, 4, 7],
    )
    .to_svg();
    derma_core::atomic::write_bytes(&out, svg.as_bytes())?;
    println!("{}", out.display());
    Ok(())
}
