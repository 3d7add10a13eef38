//! End-to-end tests of `derma rig …`: build from `derma skin`'s maps with the built-in library
//! and a painted target, eval (colour, hemoglobin, preview), animate with resume, transfer, and
//! the errors users meet.

use crate::common;

use common::{run, s};
use std::path::Path;

fn tmp(tag: &str) -> std::path::PathBuf {
    common::tmp("rigcli", tag)
}

/// Writes a hemoglobin map under the channel name older derma versions used (`blood`): it
/// must still read.
fn write_blood(p: &Path, m: &derma_core::Map) {
    derma_core::image_io::write_exr(p, &[("blood", m)], derma_core::image_io::ExrPrecision::F32)
        .unwrap();
}

fn blood(p: &Path) -> derma_core::Map {
    derma_core::image_io::read_exr_channels(p)
        .unwrap()
        .into_iter()
        .find(|c| c.0 == "hemoglobin")
        .unwrap()
        .1
}

#[test]
fn build_eval_animate_transfer_from_skin_maps() {
    let d = tmp("e2e");
    let skin = d.join("skin");
    let (ok, _, err) = run(&["skin", "--size", "256", "--out", s(&skin)]);
    assert!(ok, "{err}");
    // A painted target: the neutral map scaled by 1.5 (an affine target, eq. 3).
    let neutral = blood(&skin.join("hemoglobin.exr"));
    let flushed =
        derma_core::Map::from_vec(256, 256, neutral.data().iter().map(|v| 1.5 * v).collect())
            .unwrap();
    let target = d.join("flush.exr");
    write_blood(&target, &flushed);
    let rig = d.join("rig");
    let tgt = format!("flush={}", s(&target));
    let (ok, _, err) = run(&[
        "rig",
        "build",
        "--neutral",
        s(&skin.join("hemoglobin.exr")),
        "--melanin",
        s(&skin.join("melanin.exr")),
        "--builtin",
        "all",
        "--target",
        &tgt,
        "--global",
        "flush=1.1",
        "--radius",
        "8",
        "--basis-size",
        "64",
        // No σ floor: eq. 3 is then exact everywhere, flat regions included.
        "--sigma-floor",
        "0",
        "--out",
        s(&rig),
    ]);
    assert!(ok, "{err}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(rig.join("rig.json")).unwrap()).unwrap();
    assert_eq!(json["targets"].as_array().unwrap().len(), 9);
    assert_eq!(json["basis_size"][0], 64);
    for f in [
        "h0.exr",
        "neutral.exr",
        "melanin.exr",
        "skin_color_lut.png",
        "skin_color_lut.exr",
        "targets/anger.exr",
        "targets/flush.exr",
    ] {
        assert!(rig.join(f).exists(), "{f}");
    }

    // One frame: the affine target comes back exactly; the global scale from --global applies.
    let h = d.join("h.exr");
    let (ok, out, err) = run(&[
        "rig",
        "eval",
        "--rig",
        s(&rig),
        "--weights",
        "flush=1",
        "--global-scale",
        "1",
        "--hemoglobin",
        s(&h),
        "--out",
        s(&d.join("c.png")),
        "--preview",
        s(&d.join("p.png")),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("flush=1.0000"), "{out}");
    let got = blood(&h);
    // On the head's surface (the gutter between UV charts, flat after dilation, has σ_n = 0 at
    // some basis nodes, where eq. 3's ratio is undefined and the floor takes over).
    let raster =
        derma_core::raster::UvRaster::new(&derma_skin::builtin_head::head_mesh(), 256, 256);
    let worst = got
        .data()
        .iter()
        .zip(flushed.data())
        .enumerate()
        .filter(|(i, _)| raster.covered(*i))
        .map(|(_, (a, b))| (a - b).abs())
        .fold(0.0f32, f32::max);
    let at = got
        .data()
        .iter()
        .zip(flushed.data())
        .position(|(a, b)| (a - b).abs() == worst)
        .unwrap();
    assert!(
        worst < 1e-5,
        "affine target off by {worst} at {at}: {} vs {}",
        got.data()[at],
        flushed.data()[at]
    );
    let (ok, out, _) = run(&[
        "rig",
        "eval",
        "--rig",
        s(&rig),
        "--weights",
        "anger=0.5,flush=0.5",
        "--out",
        s(&d.join("c2.exr")),
    ]);
    assert!(ok);
    // auto global scale: 1 + 0.5·0.27 + 0.5·0.1.
    assert!(out.contains("global scale 1.1850"), "{out}");
    assert!(rig.join("rig.wgsl").exists());
    // The shipped shader on the GPU gives the CPU's map (lavapipe in CI).
    if !derma_test_support::skip_without_gpu() {
        let hg = d.join("hg.exr");
        let (ok, _, err) = run(&[
            "rig",
            "eval",
            "--rig",
            s(&rig),
            "--weights",
            "flush=1",
            "--global-scale",
            "1",
            "--device",
            "gpu",
            "--hemoglobin",
            s(&hg),
        ]);
        assert!(ok, "{err}");
        let dg = blood(&hg)
            .data()
            .iter()
            .zip(got.data())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(dg < 1e-6, "GPU vs CPU: {dg}");
    }
    let png = image_dims(&d.join("p.png"));
    assert_eq!(png, (1024, 512));

    // Animation: CSV curves, resumable, refuses a different animation in the same folder.
    let curves = d.join("curves.csv");
    std::fs::write(&curves, "time,happiness,anger\n0,0,0\n0.5,1,0\n1,0,1\n").unwrap();
    let anim = d.join("anim");
    let animate = || {
        run(&[
            "rig",
            "animate",
            "--rig",
            s(&rig),
            "--curves",
            s(&curves),
            "--fps",
            "4",
            "--hemoglobin",
            "--out",
            s(&anim),
        ])
    };
    let (ok, _, err) = animate();
    assert!(ok, "{err}");
    let frames: serde_json::Value =
        serde_json::from_slice(&std::fs::read(anim.join("animation.json")).unwrap()).unwrap();
    assert_eq!(frames["frames"].as_array().unwrap().len(), 5);
    let f2 = &frames["frames"][2];
    assert_eq!(
        f2["weights"][2],
        serde_json::json!(["happiness", 1.0]),
        "t = 0.5: {f2}"
    );
    assert!(anim.join("color_00004.png").exists() && anim.join("hemoglobin_00004.exr").exists());
    let before = std::fs::metadata(anim.join("color_00001.png"))
        .unwrap()
        .modified()
        .unwrap();
    std::fs::remove_file(anim.join("color_00003.png")).unwrap();
    let (ok, _, err) = animate();
    assert!(ok, "{err}");
    assert!(anim.join("color_00003.png").exists(), "resumed frame");
    assert_eq!(
        std::fs::metadata(anim.join("color_00001.png"))
            .unwrap()
            .modified()
            .unwrap(),
        before,
        "kept frame"
    );
    let (ok, _, err) = run(&[
        "rig",
        "animate",
        "--rig",
        s(&rig),
        "--curves",
        s(&curves),
        "--fps",
        "8",
        "--out",
        s(&anim),
    ]);
    assert!(!ok && err.contains("different animation"), "{err}");

    // Transfer onto another character (a different seed of the skin).
    let skin2 = d.join("skin2");
    assert!(run(&["skin", "--size", "256", "--seed", "7", "--out", s(&skin2)]).0);
    let rig2 = d.join("rig2");
    let (ok, _, err) = run(&[
        "rig",
        "transfer",
        "--rig",
        s(&rig),
        "--neutral",
        s(&skin2.join("hemoglobin.exr")),
        "--melanin",
        s(&skin2.join("melanin.exr")),
        "--mode",
        "relative",
        "--out",
        s(&rig2),
    ]);
    assert!(ok, "{err}");
    let h2 = d.join("h2.exr");
    assert!(run(&["rig", "eval", "--rig", s(&rig2), "--hemoglobin", s(&h2)]).0);
    let n2 = blood(&skin2.join("hemoglobin.exr"));
    let worst = blood(&h2)
        .data()
        .iter()
        .zip(n2.data())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst < 1e-6,
        "transferred neutral pose is the new character: {worst}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

fn image_dims(p: &Path) -> (usize, usize) {
    let img = derma_core::image_io::read_rgb(p).unwrap();
    (img.channels[0].width(), img.channels[0].height())
}

#[test]
fn rig_errors_name_the_problem() {
    let d = tmp("err");
    let n = derma_core::Map::filled(64, 64, 0.02);
    let np = d.join("n.exr");
    write_blood(&np, &n);
    let small = d.join("small.exr");
    write_blood(&small, &derma_core::Map::filled(32, 32, 0.02));
    let bad = d.join("bad.exr");
    write_blood(&bad, &derma_core::Map::filled(64, 64, 1.5));
    let rig = d.join("rig");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["--target".into(), format!("t={}", s(&small))], "32×32"),
        (
            vec!["--target".into(), format!("t={}", s(&bad))],
            "volume fraction",
        ),
        (
            vec!["--target".into(), format!("neutral={}", s(&np))],
            "not 'neutral'",
        ),
        (vec!["--builtin".into(), "joy".into()], "not in the library"),
        (vec!["--target".into(), s(&np).into()], "NAME=FILE"),
        (vec![], "no targets"),
    ];
    for (extra, want) in cases {
        let mut args = vec![
            "rig",
            "build",
            "--neutral",
            s(&np),
            "--radius",
            "4",
            "--basis-size",
            "16",
            "--out",
            s(&rig),
        ];
        args.extend(extra.iter().map(|x| x.as_str()));
        let (ok, _, err) = run(&args);
        assert!(!ok && err.contains(want), "{extra:?}: {err}");
    }
    let (ok, _, err) = run(&[
        "rig",
        "build",
        "--neutral",
        s(&np),
        "--builtin",
        "anger",
        "--radius",
        "4",
        "--basis-size",
        "48",
        "--out",
        s(&rig),
    ]);
    assert!(!ok && err.contains("does not divide"), "{err}");
    // Inputs are never overwritten: an output directory holding an input is refused.
    let (ok, _, err) = run(&[
        "rig",
        "build",
        "--neutral",
        s(&np),
        "--builtin",
        "anger",
        "--radius",
        "4",
        "--out",
        s(&d),
    ]);
    assert!(!ok && err.contains("inside the output directory"), "{err}");
    assert!(
        run(&[
            "rig",
            "build",
            "--neutral",
            s(&np),
            "--builtin",
            "anger,fear",
            "--radius",
            "4",
            "--basis-size",
            "16",
            "--out",
            s(&rig)
        ])
        .0
    );
    for (w, want) in [
        ("anger=0.8,fear=0.5", "--normalize"),
        ("smile=1", "no target 'smile'"),
        ("anger", "NAME=WEIGHT"),
    ] {
        let (ok, _, err) = run(&[
            "rig",
            "eval",
            "--rig",
            s(&rig),
            "--weights",
            w,
            "--hemoglobin",
            s(&d.join("x.exr")),
        ]);
        assert!(!ok && err.contains(want), "{w}: {err}");
    }
    let (ok, _, _) = run(&[
        "rig",
        "eval",
        "--rig",
        s(&rig),
        "--weights",
        "anger=0.8,fear=0.5",
        "--normalize",
        "--hemoglobin",
        s(&d.join("x.exr")),
    ]);
    assert!(ok);
    let (ok, _, err) = run(&[
        "rig",
        "eval",
        "--rig",
        s(&rig),
        "--out",
        s(&d.join("x.png")),
    ]);
    assert!(!ok && err.contains("no melanin"), "{err}");
    let (ok, _, err) = run(&["rig", "eval", "--rig", s(&d), "--out", s(&d.join("x.png"))]);
    assert!(!ok && err.contains("rig.json"), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}
