//! End-to-end tests of `derma photo …` on a small synthetic set, and its errors for bad input.

use crate::common;
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

#[test]
fn chromophores_from_a_real_skin_paint_back_to_its_colour() {
    // One colour model from photo to skin: a real scan's skin (a forehead crop of the Lee
    // Perry-Smith scan's photographed albedo, CC BY 3.0, ../shared/data), mirrored-tiled over
    // the built-in head's UV square, is inverted to melanin and hemoglobin by `derma photo
    // chromophores`; `derma skin` paints a set from those maps as its baseline; its base colour
    // must give back the colour the maps stand for, and the albedo (over the exposure the
    // inversion fitted) within what the inversion itself leaves, over the head's texels
    // (features paint on top of a few).
    let Some(crop) = derma_test_support::shared_data("skin_albedo_forehead_256x128.png") else {
        eprintln!("skipped: ../shared/data is absent");
        return;
    };
    use derma_core::color::{linear_srgb_to_xyz, xyz_to_lab};
    use derma_photo::photo::RgbImage;
    let d = tmp("loop");
    let skin = RgbImage::read_linear(&crop).unwrap();
    let n = 256usize;
    let tile = |t: f32, k: f32| {
        let x = (t * k).rem_euclid(2.0);
        if x > 1.0 {
            2.0 - x
        } else {
            x
        }
    };
    let albedo = RgbImage {
        width: n,
        height: n,
        data: (0..n * n)
            .map(|i| {
                let (u, v) = ((i % n) as f32 / n as f32, (i / n) as f32 / n as f32);
                let (x, y) = (tile(u, 4.0), tile(v, 8.0));
                skin.sample(glam::DVec2::new(
                    (x * (skin.width as f32 - 1.0) + 0.5) as f64,
                    (y * (skin.height as f32 - 1.0) + 0.5) as f64,
                ))
            })
            .collect(),
    };
    let tex = d.join("albedo.exr");
    albedo.write_linear(&tex).unwrap();
    let chromo = d.join("chromo");
    let (ok, out, err) = run(&[
        "photo",
        "chromophores",
        "--texture",
        s(&tex),
        "--out",
        s(&chromo),
    ]);
    assert!(ok, "{err}");
    // A figure of the command's line: the number after `label`, up to `end`.
    let figure = |label: &str, end: char| -> f64 {
        out.split(label)
            .nth(1)
            .and_then(|t| t.split(end).next())
            .and_then(|t| t.trim().parse().ok())
            .unwrap_or_else(|| panic!("no {label} in {out}"))
    };
    let exposure = figure("exposure ", ';');
    let cfg = d.join("skin.toml");
    std::fs::write(
        &cfg,
        format!(
            "[baseline]\nmelanin_map = \"{}\"\nblood_map = \"{}\"\n",
            chromo.join("melanin.exr").display(),
            chromo.join("hemoglobin.exr").display()
        ),
    )
    .unwrap();
    let set = d.join("set");
    let (ok, _, err) = run(&[
        "skin",
        "--config",
        s(&cfg),
        "--size",
        "256",
        "--out",
        s(&set),
    ]);
    assert!(ok, "{err}");
    let painted = RgbImage::read_linear(&set.join("base_color.png")).unwrap();
    let raster = derma_core::raster::UvRaster::new(&derma_head::Head::builtin().skin, n, n);
    let lab = |c: [f32; 3], e: f64| xyz_to_lab(linear_srgb_to_xyz(c.map(|x| x as f64 / e)));
    // ΔE*ab of the painted base colour against `other` (over `e`) at every covered texel, sorted.
    let sorted_delta_e = |other: &dyn Fn(usize) -> [f32; 3], e: f64| -> Vec<f64> {
        let mut d: Vec<f64> = (0..n * n)
            .filter(|&i| raster.triangle[i] != derma_core::raster::NO_TRIANGLE)
            .map(|i| {
                let (a, b) = (lab(painted.data[i], 1.0), lab(other(i), e));
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
            })
            .collect();
        d.sort_by(f64::total_cmp);
        d
    };
    let de = sorted_delta_e(&|i| albedo.data[i], exposure);
    // The painter against the inversion's own model: the colour the maps stand for (the
    // table the inversion used, looked up at each texel's melanin and hemoglobin).
    let lut = derma_skin::measured::inversion_lut(&derma_skin::config::SkinConfig::default());
    let read = |f: &str| {
        derma_core::image_io::read_exr_channels(&chromo.join(f))
            .unwrap()
            .remove(0)
            .1
    };
    let (m, h) = (read("melanin.exr"), read("hemoglobin.exr"));
    let dp = sorted_delta_e(
        &|i| {
            lut.lookup(m.data()[i] as f64, h.data()[i] as f64)
                .map(|x| x as f32)
        },
        1.0,
    );
    let (median, painter) = (de[de.len() / 2], dp[dp.len() / 2]);
    let fitted = figure("ΔE*ab median ", ',');
    eprintln!(
        "loop ΔE*ab median {median:.2} (90th percentile {:.2}) over {} texels; the inversion's own residual {fitted:.2}; painter against the maps' colour {painter:.2}",
        de[de.len() * 9 / 10],
        de.len()
    );
    // One colour model: the set paints the colour the maps were inverted to (0.79 when this
    // was written: 8-bit steps and the features painted on top). End to end the loop adds
    // little to what the inversion itself leaves (its spatial prior smooths the skin's finest
    // detail: 1.66): 2.88 when this was written. With the two colour models before (the
    // skin-colour LUT inverted, the match table painted) the old set's base colour differed
    // from this one by 2.6 median, and over all 256² texels (gutter included) the loop went
    // from 3.73 to 3.38. Issue 61's 2 is not reached on this sharp crop; the inversion's
    // residual bounds it.
    assert!(
        painter <= 1.0,
        "painter against the maps' colour: ΔE*ab median {painter}"
    );
    assert!(
        median <= fitted + 1.5,
        "loop ΔE*ab median {median} against the inversion's {fitted}"
    );
}
