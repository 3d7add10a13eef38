//! Synthetic ground truth, end to end: a known texture on the built-in head's face, photos from
//! known cameras (varied light, exposure ×0.7–1.3, white balance, vignetting), landmarks clicked
//! with 1.5 px noise; then cameras, unwrap, bake and chromophores are recovered and scored.

use derma_photo::bake::{bake, BakeOptions};
use derma_photo::chromophores::invert;
use derma_photo::photo::Photo;
use derma_photo::resection::{resect, ResectionOptions};
use derma_photo::synthetic::{self, chromophores_at, evaluate};
use derma_photo::unwrap::{unwrap, UnwrapOptions};
use derma_shading::skin_color_lut::SkinColorLut;
use glam::Vec3;

struct Set {
    mesh: derma_core::mesh::TriMesh,
    photos: Vec<Photo>,
    recovered: Vec<Photo>,
}

fn set() -> Set {
    let head = derma_head::Head::builtin();
    let lut = SkinColorLut::builtin();
    let disc = synthetic::face_disc(head).unwrap();
    // A quick unwrap is enough to bake into (the stretch target is the benchmark's).
    let u = unwrap(
        &disc,
        &UnwrapOptions {
            view: Some(Vec3::NEG_Z),
            tolerance: 1e-3,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(u.stretch.flipped, 0);
    let mesh = u.mesh;
    let albedo = synthetic::truth_albedo(&lut, 1);
    let (photos, points) = synthetic::photo_set(head, &mesh, &albedo, (960, 720), 1.5, 0);
    let res = resect(&points, &ResectionOptions::default()).unwrap();
    let recovered = synthetic::with_cameras(&photos, &res);
    Set {
        mesh,
        photos,
        recovered,
    }
}

#[test]
fn cameras_texture_and_chromophores_are_recovered() {
    let s = set();
    let lut = SkinColorLut::builtin();
    // Cameras: focal length within 3 %, centres within 3 % of the 550 mm distance, and the
    // recovered cameras put a surface point within a few pixels of the true ones.
    for (t, r) in s.photos.iter().zip(&s.recovered) {
        let f = (r.camera.focal_px / t.camera.focal_px - 1.0).abs();
        let c = (r.camera.centre() - t.camera.centre()).length();
        assert!(f < 0.03, "{}: focal error {f}", t.name);
        assert!(c < 0.03 * 550.0, "{}: centre error {c} mm", t.name);
        let p = s.mesh.positions[s.mesh.positions.len() / 2].as_dvec3();
        let d = (r.camera.project(p).unwrap() - t.camera.project(p).unwrap()).length();
        assert!(d < 4.0, "{}: a vertex lands {d} px off", t.name);
    }
    let albedo = synthetic::truth_albedo(&lut, 1);
    let run = |gain: bool, multiband: bool| {
        let opts = BakeOptions {
            size: 384,
            gain_compensation: gain,
            multiband,
            ..Default::default()
        };
        let b = bake(&s.mesh, &s.recovered, &opts, &derma_core::Silent).unwrap();
        (evaluate(&s.mesh, &b, &albedo), b)
    };
    let (plain, _) = run(false, false);
    let (gained, _) = run(true, false);
    let (full, baked) = run(true, true);
    eprintln!("plain {plain:?}\ngain {gained:?}\ngain + splines {full:?}");
    // Gain compensation removes most of the exposure and white-balance differences.
    assert!(
        gained.psnr_db > plain.psnr_db + 3.0,
        "{gained:?} vs {plain:?}"
    );
    assert!(full.psnr_db > plain.psnr_db + 3.0);
    // Seams: far less error gradient across photo boundaries than without compensation.
    assert!(full.seam_gradient_energy < 0.5 * plain.seam_gradient_energy);
    // No region stays empty: every chart texel is coloured, and most come from photos.
    assert!(baked.report.photo_coverage > 0.9, "{:?}", baked.report);
    let raster = derma_core::raster::UvRaster::new(&s.mesh, 384, 384);
    for i in 0..384 * 384 {
        if raster.covered(i) {
            let c = baked.texture.data[i];
            assert!(
                c.iter().all(|v| v.is_finite()) && c.iter().sum::<f32>() > 0.01,
                "texel {i}: {c:?}"
            );
        }
    }
    // Chromophores at the exposure that matches the photos' mean level (a grey card's job):
    // hemoglobin and melanin follow the truth.
    let mask: Vec<bool> = baked
        .source
        .iter()
        .map(|v| (*v as usize) < s.photos.len())
        .collect();
    let c = invert(&lut, &baked.texture, Some(&mask), 0.9).unwrap();
    let (mut em, mut eh, mut n) = (0.0f64, 0.0f64, 0usize);
    let (mut tm, mut th) = (0.0f64, 0.0f64);
    for i in 0..384 * 384 {
        if mask[i] {
            let (m, h) = chromophores_at(raster.position(&s.mesh, i), 1);
            em += (c.melanin.data()[i] - m).abs() as f64;
            eh += (c.hemoglobin.data()[i] - h).abs() as f64;
            tm += m as f64;
            th += h as f64;
            n += 1;
        }
    }
    let (em, eh, tm, th) = (em / n as f64, eh / n as f64, tm / n as f64, th / n as f64);
    eprintln!("melanin mean |error| {em:.4} of mean {tm:.4}; hemoglobin {eh:.4} of {th:.4}");
    assert!(em < 0.35 * tm, "melanin error {em} of {tm}");
    assert!(eh < 0.6 * th, "hemoglobin error {eh} of {th}");
}

#[test]
fn a_bake_is_the_same_at_any_thread_count() {
    let s = set();
    let opts = BakeOptions {
        size: 256,
        ..Default::default()
    };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let a = one.install(|| bake(&s.mesh, &s.recovered, &opts, &derma_core::Silent).unwrap());
    let b = bake(&s.mesh, &s.recovered, &opts, &derma_core::Silent).unwrap();
    assert!(
        a.texture.data == b.texture.data,
        "texture differs between 1 thread and the pool"
    );
    assert_eq!(a.source, b.source);
}
