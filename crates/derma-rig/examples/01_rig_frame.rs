//! The rig through the library API: a neutral hemoglobin map on the built-in head's UV layout
//! (here synthetic: 1.2 % dermal blood with vascular-like noise), the built-in expression
//! library, one blended frame through the exact path and the real-time path.
//!
//!     cargo run --release -p derma-rig --example 01_rig_frame [OUT_DIR]

use derma_core::image_io::{write_exr, write_png8_srgb, ExrPrecision};
use derma_core::Map;
use derma_rig::evaluate::{color, hemoglobin, unpack_rgba8, FramePlan};
use derma_rig::weights::{global_scale, resolve};
use derma_rig::{
    expression, BasisOptions, GlobalScale, Normalization, Rig, TargetSource, TargetSpec,
};
use derma_shading::skin_color_lut::SkinColorLut;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| {
        std::env::temp_dir()
            .join("derma-rig-example")
            .display()
            .to_string()
    }));
    std::fs::create_dir_all(&out)?;
    let n = 1024;
    let rng = derma_core::rng::Philox::new(1, 0);
    let neutral = Map::from_vec(
        n,
        n,
        (0..n * n)
            .map(|i| 0.012 * (0.7 + 0.6 * rng.uniform4(i as u64, 0)[0]))
            .collect(),
    )?;
    let melanin = Map::filled(n, n, 0.02);
    let specs: Vec<TargetSpec> = expression::LIBRARY
        .iter()
        .map(|e| TargetSpec {
            name: e.name.into(),
            source: TargetSource::Builtin(e),
            global_scale: None,
        })
        .collect();
    let t = std::time::Instant::now();
    let rig = Rig::build(
        &neutral,
        None,
        Some(melanin.clone()),
        &specs,
        &BasisOptions::new(24.0),
    )?;
    println!(
        "built {} targets in {:.3} s",
        rig.targets.len(),
        t.elapsed().as_secs_f64()
    );

    let names: Vec<&str> = rig.targets.iter().map(|t| t.name.as_str()).collect();
    let w = resolve(
        &names,
        &"happiness=0.7,anger=0.3".parse()?,
        Normalization::NeutralTakesRest,
    )?;
    let suggested: Vec<f32> = rig.targets.iter().map(|t| t.global_scale).collect();
    let g = global_scale(GlobalScale::Auto, &w, &suggested);
    let h = hemoglobin(&rig, &w, g)?;
    println!(
        "w_0 = {:.2}, global scale {g:.3}; mean blood {:.4} (neutral {:.4})",
        w[0],
        h.stats(None).mean,
        neutral.stats(None).mean
    );
    let rgb = color(&h, &melanin, &SkinColorLut::builtin())?;
    write_exr(
        &out.join("hemoglobin.exr"),
        &[("blood", &h)],
        ExrPrecision::F32,
    )?;
    write_png8_srgb(&out.join("colour.png"), &[&rgb[0], &rgb[1], &rgb[2]])?;

    let mut plan = FramePlan::new(&rig, &melanin, &SkinColorLut::builtin())?;
    let mut frame = vec![0u32; n * n];
    let t = std::time::Instant::now();
    plan.render(&rig, &w, g, &mut frame)?;
    println!(
        "real-time frame {n}²: {:.2} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    let f = unpack_rgba8(&frame, n, n);
    derma_core::image_io::write_png8(&out.join("frame.png"), &[&f[0], &f[1], &f[2]])?;
    println!("wrote {}", out.display());
    Ok(())
}
