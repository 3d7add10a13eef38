//! The pieces every derma crate shares, in one run: counter-based random numbers (the same
//! draw for the same (seed, stream, index) on any thread), planar maps with bilinear sampling,
//! atomic image files, colour science, numerics, and progress with stage timings.
//!
//! `cargo run --release -p derma-core --example 01_core_tour` (writes into the temp directory)

use derma_core::color::{luminance, reflectance_to_linear_srgb, N_WAVELENGTHS};
use derma_core::image_io::{read_grey, write_png16};
use derma_core::numerics::dense::{matrix_from_rows, svd};
use derma_core::progress::{Job, Note, Progress, Unit};
use derma_core::rng::Philox;
use derma_core::Map;
use rayon::prelude::*;

/// Prints stages and notes as they come.
struct Print;

impl Progress for Print {
    fn stage(&self, name: &str, total: u64, unit: Unit) {
        println!("stage {name}: {total} {}", unit.name());
    }
    fn note(&self, note: Note) {
        println!("note: {note}");
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::temp_dir().join("derma-core-tour");
    derma_core::atomic::ensure_writable_dir(&out)?;
    let job = Job::new(&Print);

    // Random numbers: texel i's draw depends on (seed, stream, i) only, so a parallel fill gives
    // the same map as a sequential one.
    job.stage("noise", 1, Unit::Steps);
    let rng = Philox::new(42, 1);
    let noise: Vec<f32> = (0..256 * 256)
        .into_par_iter()
        .map(|i| rng.uniform4(i as u64, 0)[0])
        .collect();
    let sequential: Vec<f32> = (0..256 * 256)
        .map(|i| rng.uniform4(i as u64, 0)[0])
        .collect();
    assert_eq!(noise, sequential);
    let map = Map::from_vec(256, 256, noise)?;
    println!(
        "bilinear sample at uv (0.5, 0.5): {:.4}",
        map.sample_uv(0.5, 0.5, true)
    );

    // Files are written to a temporary name and renamed: a crash never leaves half a PNG.
    job.stage("files", 1, Unit::Steps);
    let png = out.join("noise.png");
    write_png16(&png, &[&map])?;
    let back = read_grey(&png)?.channels.remove(0);
    let within_half_a_code = back
        .data()
        .iter()
        .zip(map.data())
        .all(|(a, b)| (a - b).abs() <= 0.5 / 65535.0);
    println!("16-bit PNG round trip within half a code: {within_half_a_code}");

    // Colour: a flat 50 % reflector under D65 is mid grey in linear sRGB.
    job.stage("colour", 1, Unit::Steps);
    let grey = reflectance_to_linear_srgb(&[0.5; N_WAVELENGTHS]);
    println!(
        "50 % reflector: linear sRGB {grey:.3?}, luminance {:.3}",
        luminance(grey)
    );

    // Numerics: the singular values of a 2 × 3 matrix (√12 and √10).
    job.stage("numerics", 1, Unit::Steps);
    let a = matrix_from_rows(2, 3, &[3.0, 1.0, 1.0, -1.0, 3.0, 1.0])?;
    println!(
        "singular values {:.6?} (expected √12 = 3.464102, √10 = 3.162278)",
        svd(&a)?.s
    );
    job.note(Note::info(format!("wrote {}", png.display())));

    for t in job.finish().timings {
        println!("  {:10} {:.4} s", t.stage, t.seconds);
    }
    Ok(())
}
