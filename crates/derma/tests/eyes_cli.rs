//! End-to-end tests of `derma eyes …`: synthetic tracked data → a trained model → an animated
//! GLB that glTF readers open, the distance-field table, and errors for bad input.

use crate::common;
use common::{run, s};

fn tmp(tag: &str) -> std::path::PathBuf {
    common::tmp("eyes-cli", tag)
}

#[test]
fn synthetic_data_trains_a_model_that_animates_the_head() {
    let d = tmp("pipeline");
    let data = d.join("tracked.csv");
    let (ok, out, err) = run(&[
        "eyes",
        "synthetic",
        "--seconds",
        "3",
        "--fps",
        "10",
        "--out",
        s(&data),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("32 frames"), "{out}");
    let model = d.join("model");
    let (ok, out, err) = run(&["eyes", "train", "--data", s(&data), "--out", s(&model)]);
    assert!(ok, "{err}");
    assert!(
        out.contains("held-out error") && out.contains("Read et al."),
        "{out}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(model.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["frames"], 32);
    let anim = d.join("anim");
    let (ok, out, err) = run(&[
        "eyes",
        "animate",
        "--model",
        s(&model.join("model.json")),
        "--seconds",
        "1",
        "--fps",
        "10",
        "--render",
        "160",
        "--out",
        s(&anim),
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("10 frames"), "{out}");
    // The GLB opens in a glTF reader with its animation, morph targets and eye nodes.
    let (doc, _, _) = gltf::import(anim.join("head.glb")).unwrap();
    let anims: Vec<_> = doc.animations().collect();
    assert_eq!(anims.len(), 1);
    assert!(anims[0].channels().count() >= 3);
    let names: Vec<String> = doc
        .nodes()
        .filter_map(|n| n.name().map(str::to_string))
        .collect();
    for n in ["skin", "eye_left", "eye_right", "cornea_left", "iris_right"] {
        assert!(names.iter().any(|x| x == n), "{n} missing from {names:?}");
    }
    assert_eq!(std::fs::read_dir(anim.join("frames")).unwrap().count(), 10);
    let curves = std::fs::read_to_string(anim.join("curves.csv")).unwrap();
    assert_eq!(curves.lines().count(), 11);
}

#[test]
fn the_distance_field_table_lists_every_method() {
    let d = tmp("sdf");
    let (ok, out, err) = run(&[
        "eyes",
        "sdf",
        "--width",
        "480",
        "--height",
        "270",
        "--runs",
        "1",
        "--out",
        s(&d),
    ]);
    assert!(ok, "{err}");
    for m in [
        "exact EDT",
        "jump flooding",
        "equiangular 64",
        "exponential 8x8",
        "backtracking 8x8",
    ] {
        assert!(out.contains(m), "{m} missing: {out}");
    }
    for f in [
        "table.md",
        "table.json",
        "mask.png",
        "exact.png",
        "lake.png",
        "lake-closeup.png",
    ] {
        assert!(d.join(f).exists(), "{f}");
    }
}

#[test]
fn an_iris_texture_reaches_the_glb() {
    let d = tmp("iris");
    // Any RGB image on the eye UVs will do: the distance-field command's lake render.
    let (ok, _, err) = run(&[
        "eyes",
        "sdf",
        "--width",
        "256",
        "--height",
        "144",
        "--runs",
        "1",
        "--out",
        s(&d.join("sdf")),
    ]);
    assert!(ok, "{err}");
    let image_of = |dir: &std::path::Path| {
        let (doc, buffers, images) = gltf::import(dir.join("head.glb")).unwrap();
        // Every morph weight of the animation within glTF's [0, 1] (Blender clamps at ±10).
        let mut n = 0;
        for a in doc.animations() {
            for c in a.channels() {
                let r = c.reader(|b| Some(&buffers[b.index()]));
                if let Some(gltf::animation::util::ReadOutputs::MorphTargetWeights(w)) =
                    r.read_outputs()
                {
                    for x in w.into_f32() {
                        assert!((0.0..=1.0).contains(&x), "morph weight {x}");
                        n += 1;
                    }
                }
            }
        }
        assert!(n > 0, "no morph weights animated");
        // The lashes are blended cards with a coverage texture, not opaque slabs.
        let lashes = doc
            .materials()
            .find(|m| m.name() == Some("lashes"))
            .expect("a lash material");
        assert_eq!(lashes.alpha_mode(), gltf::material::AlphaMode::Blend);
        let t = lashes
            .pbr_metallic_roughness()
            .base_color_texture()
            .unwrap();
        let img = &images[t.texture().source().index()];
        assert_eq!(img.format, gltf::image::Format::R8G8B8A8);
        let alpha: Vec<u8> = img.pixels.chunks_exact(4).map(|p| p[3]).collect();
        assert!(alpha.iter().any(|&a| a > 200) && alpha.iter().any(|&a| a < 50));
        images[0].pixels.clone()
    };
    let mut images = Vec::new();
    for (tag, iris) in [
        ("plain", None),
        ("photo", Some(d.join("sdf").join("lake.png"))),
    ] {
        let out = d.join(tag);
        let mut args = vec![
            "eyes",
            "animate",
            "--seconds",
            "0.2",
            "--fps",
            "10",
            "--render",
            "0",
            "--out",
            s(&out),
        ];
        if let Some(p) = &iris {
            args.extend(["--iris", s(p)]);
        }
        let (ok, _, err) = run(&args);
        assert!(ok, "{err}");
        images.push(image_of(&out));
    }
    assert_eq!(images[0].len(), images[1].len());
    assert_ne!(
        images[0], images[1],
        "the --iris texture should replace the default eye"
    );
    let (ok, _, err) = run(&[
        "eyes",
        "animate",
        "--iris",
        s(&d.join("missing.png")),
        "--render",
        "0",
        "--out",
        s(&d.join("x")),
    ]);
    assert!(!ok && err.contains("missing.png"), "{err}");
}

#[test]
fn bad_input_is_named() {
    let d = tmp("bad");
    std::fs::create_dir_all(&d).unwrap();
    let csv = d.join("short.csv");
    std::fs::write(&csv, "fps,gaze_left_h,gaze_left_v,gaze_left_t,gaze_right_h,gaze_right_v,gaze_right_t\n30,0,0,0,0,0,0\n").unwrap();
    let (ok, _, err) = run(&["eyes", "train", "--data", s(&csv), "--out", s(&d.join("m"))]);
    assert!(
        !ok && err.contains("short.csv") && err.contains("lid points"),
        "{err}"
    );
    let tracker = d.join("gaze.csv");
    std::fs::write(&tracker, "time,h,v\n0,0,0\n0.5,abc,1\n").unwrap();
    let (ok, _, err) = run(&[
        "eyes",
        "animate",
        "--tracker",
        s(&tracker),
        "--render",
        "0",
        "--out",
        s(&d.join("a")),
    ]);
    assert!(
        !ok && err.contains("gaze.csv") && err.contains("row 3"),
        "{err}"
    );
    let (ok, _, err) = run(&[
        "eyes",
        "animate",
        "--activity",
        "sleeping",
        "--out",
        s(&d.join("b")),
    ]);
    assert!(!ok && err.contains("sleeping"), "{err}");
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn the_animated_glb_is_the_same_at_any_thread_count() {
    // 120 frames: a blink and eleven morph targets, the Gram matrix of the fit and the frames
    // evaluated in parallel. One and two worker threads must write the same bytes.
    let d = tmp("threads");
    let out = |threads: &str| {
        let dir = d.join(format!("t{threads}"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_derma"))
            .args(["eyes", "animate", "--seconds", "4", "--fps", "30"])
            .args(["--render", "0", "--quiet", "--out", s(&dir)])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dir
    };
    let (a, b) = (out("1"), out("2"));
    for f in ["head.glb", "curves.csv", "curves.json"] {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(!x.is_empty());
        assert!(x == y, "{f} differs between 1 and 2 threads");
    }
}
