//! The photo pipeline in the library, end to end on synthetic ground truth: five photos of the
//! built-in face from known cameras, feature points clicked with 1.5 px noise; cameras by
//! resection, a stretch-minimising unwrap, a 1024² bake with gains and splines, and melanin /
//! hemoglobin maps; each step scored against the truth. Writes the texture and maps to a
//! temporary directory (or the one given).
//!   cargo run --release -p derma-photo --example 01_photo_pipeline [OUT_DIR]

use derma_photo::bake::{bake, BakeOptions};
use derma_photo::chromophores::invert;
use derma_photo::resection::{resect, ResectionOptions};
use derma_photo::synthetic::{self, evaluate};
use derma_photo::unwrap::{unwrap, UnwrapOptions};
use derma_shading::skin_color_lut::SkinColorLut;
use glam::Vec3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("derma-photo-pipeline"));
    std::fs::create_dir_all(&out)?;
    let head = derma_head::Head::builtin();
    let lut = SkinColorLut::builtin();
    let disc = synthetic::face_disc(head)?;
    let u = unwrap(
        &disc,
        &UnwrapOptions {
            view: Some(Vec3::NEG_Z),
            ..Default::default()
        },
    )?;
    println!(
        "unwrap: {} triangles, L2 stretch {:.4} (weighted {:.4}), {} flipped",
        u.mesh.triangles.len(),
        u.stretch.l2,
        u.stretch.weighted_l2,
        u.stretch.flipped
    );
    let mesh = u.mesh;
    let albedo = synthetic::truth_albedo(&lut, 1);
    let (photos, points) = synthetic::photo_set(head, &mesh, &albedo, (1200, 900), 1.5, 0);
    let res = resect(&points, &ResectionOptions::default())?;
    for (r, p) in res.iter().zip(&photos) {
        println!(
            "{}: RMS {:.2} px, focal error {:+.2} %, centre error {:.1} mm",
            r.photo,
            r.rms_px,
            100.0 * (r.camera.focal_px / p.camera.focal_px - 1.0),
            (r.camera.centre() - p.camera.centre()).length()
        );
    }
    let recovered = synthetic::with_cameras(&photos, &res);
    for (gain, multiband) in [(false, false), (true, false), (true, true)] {
        let opts = BakeOptions {
            size: 1024,
            gain_compensation: gain,
            multiband,
            ..Default::default()
        };
        let b = bake(&mesh, &recovered, &opts, &derma_core::Silent)?;
        let s = evaluate(&mesh, &b, &albedo);
        println!(
            "bake (gains {gain}, splines {multiband}): PSNR {:.2} dB, seam gradient energy {:.2e}",
            s.psnr_db, s.seam_gradient_energy
        );
        if gain && multiband {
            b.texture.write_linear(&out.join("texture.png"))?;
            let mask: Vec<bool> = b
                .source
                .iter()
                .map(|v| (*v as usize) < photos.len())
                .collect();
            let c = invert(&lut, &b.texture, Some(&mask), 0.9)?;
            println!(
                "chromophores: ΔE*ab median {:.2}, 95th percentile {:.2}",
                c.report.median_delta_e, c.report.p95_delta_e
            );
            derma_core::image_io::write_exr(
                &out.join("chromophores.exr"),
                &[("melanin", &c.melanin), ("hemoglobin", &c.hemoglobin)],
                derma_core::image_io::ExrPrecision::F32,
            )?;
        }
    }
    println!("wrote {}", out.display());
    Ok(())
}
