//! End-to-end tests of `derma photo …` on a small synthetic set, and its errors for bad input.

mod common;
use common::{run, s};

fn tmp(tag: &str) -> std::path::PathBuf {
    common::tmp("photo-cli", tag)
}

#[test]
fn the_pipeline_runs_from_synthetic_photos_to_a_rig() {
    let d = tmp("pipeline");
    let set = d.join("set");
    let (ok, _, err) = run(&["photo", "synthetic", "--width", "800", "--out", s(&set)]);
    assert!(ok, "{err}");
    let cams = d.join("cameras.json");
    let (ok, out, err) = run(&[
        "photo",
        "calibrate",
        "--points",
        s(&set.join("points.json")),
        "--out",
        s(&cams),
    ]);
    assert!(ok, "{err}");
    assert_eq!(out.lines().count(), 5, "{out}");
    let uv = d.join("face_uv.obj");
    let (ok, out, err) = run(&[
        "photo",
        "unwrap",
        "--mesh",
        s(&set.join("face.obj")),
        "--out",
        s(&uv),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("0 flipped"), "{out}");
    let bake = d.join("bake");
    let (ok, out, err) = run(&[
        "photo",
        "bake",
        "--mesh",
        s(&uv),
        "--cameras",
        s(&cams),
        "--size",
        "256",
        "--out",
        s(&bake),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("gain"), "{out}");
    assert!(out.contains("lighting:"), "{out}");
    for f in [
        "albedo.png",
        "albedo.exr",
        "shading_0.png",
        "source.png",
        "mask.png",
        "bake.json",
    ] {
        assert!(bake.join(f).exists(), "{f}");
    }
    let chromo = d.join("chromo");
    let (ok, out, err) = run(&[
        "photo",
        "chromophores",
        "--texture",
        s(&bake.join("albedo.exr")),
        "--mask",
        s(&bake.join("mask.png")),
        "--out",
        s(&chromo),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("ΔE*ab median"), "{out}");
    // The photographed face's hemoglobin map becomes a rig: a flushed target (×1.3 blood) in
    // the same UV layout, as a second photo session would give.
    let hb = derma_core::image_io::read_exr_channels(&chromo.join("hemoglobin.exr")).unwrap();
    let (_, neutral) = &hb[0];
    let flushed = derma_core::Map::from_vec(
        neutral.width(),
        neutral.height(),
        neutral.data().iter().map(|v| (v * 1.3).min(0.32)).collect(),
    )
    .unwrap();
    let target = d.join("flush.exr");
    derma_core::image_io::write_exr(
        &target,
        &[("hemoglobin", &flushed)],
        derma_core::image_io::ExrPrecision::F32,
    )
    .unwrap();
    let rig = d.join("rig");
    let flush = format!("flush={}", s(&target));
    let (ok, _, err) = run(&[
        "rig",
        "build",
        "--neutral",
        s(&chromo.join("hemoglobin.exr")),
        "--melanin",
        s(&chromo.join("melanin.exr")),
        "--mask",
        s(&bake.join("mask.png")),
        "--target",
        &flush,
        "--radius",
        "8",
        "--basis-size",
        "64",
        "--out",
        s(&rig),
    ]);
    assert!(ok, "{err}");
    assert!(rig.join("rig.json").exists());
    // Inputs are never outputs.
    let (ok, _, err) = run(&["photo", "unwrap", "--mesh", s(&uv), "--out", s(&uv)]);
    assert!(!ok && err.contains("never writes over its inputs"), "{err}");
}

#[test]
fn a_photo_that_is_not_an_eye_or_teeth_is_refused() {
    // A crop of real skin (shared/data, a scan's albedo) and a derma base colour are neither an
    // eye nor a smile: refused with the figure (before: an iris "found" off the eye, teeth
    // textures made of skin).
    let d = tmp("not-parts");
    let mut photos = vec![];
    let real = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/skin_albedo_forehead_256x128.png");
    if real.exists() {
        photos.push(real);
    }
    let flat = d.join("flat.png");
    let img = derma_core::image::Rgb {
        width: 200,
        height: 120,
        data: (0..200 * 120)
            .map(|i| {
                let v = 0.35 + 0.1 * (((i * 7919) % 101) as f32 / 101.0);
                [v, 0.8 * v, 0.7 * v]
            })
            .collect(),
    };
    img.write_linear(&flat).unwrap();
    photos.push(flat);
    for p in &photos {
        let (ok, _, err) = run(&[
            "photo",
            "iris",
            "--photo",
            s(p),
            "--size",
            "64",
            "--out",
            s(&d.join("i")),
        ]);
        assert!(
            !ok && err.contains("no iris found"),
            "{}: {err}",
            p.display()
        );
        let (ok, _, err) = run(&[
            "photo",
            "teeth",
            "--photo",
            s(p),
            "--size",
            "64",
            "--out",
            s(&d.join("t")),
        ]);
        assert!(
            !ok && (err.contains("no teeth found") || err.contains("tooth pixels")),
            "{}: {err}",
            p.display()
        );
        // A refused input leaves no output directory behind.
        assert!(!d.join("i").exists() && !d.join("t").exists());
    }
}

#[test]
fn iris_and_teeth_from_single_photos() {
    let d = tmp("parts");
    let eye = d.join("eye.png");
    derma_photo::iris::synthetic_eye(240, 180, [118.0, 92.0], 48.0, 1)
        .write_linear(&eye)
        .unwrap();
    let (ok, out, err) = run(&[
        "photo",
        "iris",
        "--photo",
        s(&eye),
        "--size",
        "256",
        "--out",
        s(&d.join("iris")),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("markov-chain-1d"), "{out}");
    assert!(d.join("iris/eye.png").exists());
    let smile = d.join("smile.png");
    derma_photo::teeth::synthetic_smile(320, 160)
        .0
        .write_linear(&smile)
        .unwrap();
    let (ok, out, err) = run(&[
        "photo",
        "teeth",
        "--photo",
        s(&smile),
        "--size",
        "256",
        "--out",
        s(&d.join("teeth")),
    ]);
    assert!(ok, "{err}");
    assert!(
        out.contains("teeth") && d.join("teeth/teeth.png").exists(),
        "{out}"
    );
}

#[test]
fn bad_input_gets_a_clear_error() {
    let d = tmp("bad");
    // A closed surface (a tetrahedron) is not a disc.
    let tet = d.join("tet.obj");
    std::fs::write(
        &tet,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n",
    )
    .unwrap();
    let (ok, _, err) = run(&[
        "photo",
        "unwrap",
        "--mesh",
        s(&tet),
        "--out",
        s(&d.join("o.obj")),
    ]);
    assert!(!ok && err.contains("0 boundary loops"), "{err}");
    // Too few correspondences.
    let pts = d.join("few.json");
    std::fs::write(&pts, r#"{"photos": [{"image": "a.png", "width": 100, "height": 100, "points": [{"name": "nose_tip", "pixel": [50, 50]}]}]}"#).unwrap();
    let (ok, _, err) = run(&[
        "photo",
        "calibrate",
        "--points",
        s(&pts),
        "--out",
        s(&d.join("c.json")),
    ]);
    assert!(
        !ok && err.contains("1 correspondences") && err.contains("a.png"),
        "{err}"
    );
    // A photo that does not load.
    let cams = d.join("cams.json");
    let cam = serde_json::json!({"width": 100, "height": 100, "rotation": [0.0, 0.0, 0.0], "translation": [0.0, 0.0, 500.0], "focal_px": 100.0, "principal": [50.0, 50.0], "k1": 0.0, "k2": 0.0});
    std::fs::write(&cams, serde_json::json!({"photos": [{"image": "missing.png", "camera": cam, "rms_px": 1.0, "outliers": []}]}).to_string()).unwrap();
    let uvmesh = d.join("tri.obj");
    std::fs::write(
        &uvmesh,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let (ok, _, err) = run(&[
        "photo",
        "bake",
        "--mesh",
        s(&uvmesh),
        "--cameras",
        s(&cams),
        "--out",
        s(&d.join("b")),
    ]);
    assert!(!ok && err.contains("missing.png"), "{err}");
    // A texture outside the skin gamut is clamped, with its residual reported.
    let blue = d.join("blue.png");
    derma_photo::photo::RgbImage::filled(8, 8, [0.02, 0.05, 0.7])
        .write_linear(&blue)
        .unwrap();
    let (ok, out, err) = run(&[
        "photo",
        "chromophores",
        "--texture",
        s(&blue),
        "--exposure",
        "1",
        "--out",
        s(&d.join("c")),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("100.00 % clamped"), "{out}");
}
