//! End-to-end tests of `derma skin` at small sizes, and its error messages for bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

fn derma() -> Command {
    Command::new(env!("CARGO_BIN_EXE_derma"))
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs derma with its notes on stderr (no --quiet).
fn run_loud(args: &[&str]) -> (bool, String) {
    let out = derma().args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn run(args: &[&str]) -> (bool, String) {
    let out = derma().args(args).arg("--quiet").output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const ALL: [derma_skin::outputs::OutputFile; 19] = derma_skin::outputs::OUTPUTS;

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn default_run_writes_the_whole_set_with_plausible_statistics() {
    let d = tmp("default");
    let (ok, err) = run(&["skin", "--size", "128", "--out", d.to_str().unwrap()]);
    assert!(ok, "{err}");
    for f in ALL.map(|o| o.file) {
        assert!(d.join(f).exists(), "{f} missing");
    }
    // No temporary files left behind.
    assert!(std::fs::read_dir(&d).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .ends_with(".tmp")));
    let r = report(&d);
    let bc = &r["statistics"]["base_color_linear"];
    let (red, green, blue) = (
        bc[0]["mean"].as_f64().unwrap(),
        bc[1]["mean"].as_f64().unwrap(),
        bc[2]["mean"].as_f64().unwrap(),
    );
    assert!(
        red > green && green > blue && (0.25..0.7).contains(&red),
        "{red} {green} {blue}"
    );
    assert!(r["counts"]["follicle"].as_u64().unwrap() > 160_000);
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["maps"].as_array().unwrap().len(), ALL.len() - 1);
    // The normal map decodes to unit vectors pointing out of the surface.
    let n = derma_core::image_io::read_rgb(&d.join("normal.png")).unwrap();
    for i in (0..128 * 128).step_by(97) {
        let v = [0, 1, 2].map(|k| 2.0 * n.channels[k].data()[i] - 1.0);
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((len - 1.0).abs() < 0.01 && v[2] > 0.0);
    }
    // Same seed → identical files; bio.exr channels are all there.
    let d2 = tmp("default2");
    let (ok, _) = run(&[
        "skin",
        "--size",
        "128",
        "--threads",
        "1",
        "--out",
        d2.to_str().unwrap(),
    ]);
    assert!(ok);
    // Every file but report.json (which records timings) is byte-identical.
    for f in ALL.map(|o| o.file).iter().filter(|f| **f != "report.json") {
        assert!(
            std::fs::read(d.join(f)).unwrap() == std::fs::read(d2.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let ch = derma_core::image_io::read_exr_channels(&d.join("bio.exr")).unwrap();
    assert_eq!(ch.len(), 12);
}

#[test]
fn patch_and_print_config() {
    let d = tmp("patch");
    let (ok, err) = run(&[
        "skin",
        "--patch",
        "20x20",
        "--size",
        "64",
        "--out",
        d.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert_eq!(report(&d)["inputs"]["surface"], "patch");
    let out = derma().args(["skin", "--print-config"]).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("[freckle]") && text.contains("density_per_cm2") && text.contains("thesis")
    );
}

fn write_quad_obj(path: &Path, scale: f32) {
    let s = scale;
    std::fs::write(
        path,
        format!("v 0 0 0\nv {s} 0 0\nv {s} {s} 0\nv 0 {s} 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"),
    )
    .unwrap();
}

#[test]
fn user_meshes_obj_and_glb_any_scale() {
    let d = tmp("mesh");
    let obj = d.join("quad.obj");
    write_quad_obj(&obj, 0.2); // 20 cm written in metres
    let out = d.join("out");
    let o = derma()
        .args([
            "skin",
            "--mesh",
            obj.to_str().unwrap(),
            "--size",
            "64",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("read as metres") && err.contains("uniform fields"),
        "{err}"
    );
    let r = report(&out);
    assert!((r["surface_area_cm2"].as_f64().unwrap() - 400.0).abs() < 1.0);

    // A mesh no length unit makes head-sized (8.6 units: 86 mm in cm, 8.6 m in metres) is
    // scaled to a nominal 225 mm head, said so, and the scale reported.
    let odd = d.join("odd.obj");
    write_quad_obj(&odd, 8.6);
    let out3 = d.join("out3");
    let odd_s = odd.to_str().unwrap();
    let (ok, err) = run_loud(&[
        "skin",
        "--mesh",
        odd_s,
        "--size",
        "64",
        "--out",
        out3.to_str().unwrap(),
    ]);
    assert!(ok && err.contains("nominal 225 mm head"), "{err}");
    let r = report(&out3);
    assert_eq!(r["inputs"]["mesh"]["unit"], "fit", "{r}");
    let k = r["inputs"]["mesh"]["mm_per_unit"].as_f64().unwrap();
    assert!((k - 225.0 / 8.6).abs() < 1e-3, "{k}");
    assert!((r["surface_area_cm2"].as_f64().unwrap() - 506.25).abs() < 1.0);

    // The same quad as a binary glTF.
    let glb = d.join("quad.glb");
    std::fs::write(&glb, derma_test_support::quad_glb()).unwrap();
    let out2 = d.join("out2");
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        glb.to_str().unwrap(),
        "--size",
        "64",
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!((report(&out2)["surface_area_cm2"].as_f64().unwrap() - 400.0).abs() < 1.0);
}

/// Share of base_color texels more than 2/255 apart (any channel) between two sets, and the
/// relative differences of the bio maps' means (bio.exr, every channel).
fn set_difference(a: &Path, b: &Path) -> (f64, Vec<(String, f64)>) {
    use derma_core::image_io::{read_exr_channels, read_rgb};
    let (ca, cb) = (
        read_rgb(&a.join("base_color.png")).unwrap().channels,
        read_rgb(&b.join("base_color.png")).unwrap().channels,
    );
    let n = ca[0].data().len();
    let apart = (0..n)
        .filter(|&i| (0..3).any(|c| (ca[c].data()[i] - cb[c].data()[i]).abs() > 2.5 / 255.0))
        .count();
    let mean = |m: &derma_core::Map| m.data().iter().map(|&v| v as f64).sum::<f64>() / n as f64;
    let (ba, bb) = (
        read_exr_channels(&a.join("bio.exr")).unwrap(),
        read_exr_channels(&b.join("bio.exr")).unwrap(),
    );
    let rel = ba
        .iter()
        .zip(&bb)
        .map(|((name, x), (_, y))| {
            let (x, y) = (mean(x), mean(y));
            (name.clone(), (x - y).abs() / x.abs().max(1e-12))
        })
        .collect();
    (apart as f64 / n as f64, rel)
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn exported_template_round_trips_through_mesh_and_fields() {
    // Export the head and its fields, then run on them as a user would before painting: the
    // default set comes back (before: the regional blood clipped to [0, 1] in a PNG and the
    // person's calibration made without the regional gains — blood −16 %, melanin +30 %).
    let d = tmp("export");
    let t = d.join("template");
    let (ok, err) = run(&["skin", "--export-template", t.to_str().unwrap()]);
    assert!(ok, "{err}");
    for f in [
        "head.obj",
        "head.glb",
        "cheeks.png",
        "regional_blood.exr",
        "scalp.png",
        "lips.png",
        "freckles.png",
        "wrinkle_vectors.png",
    ] {
        assert!(t.join(f).exists(), "{f}");
    }
    let paint = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "skin",
            "--size",
            "256",
            "--seed",
            "3",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (ok, err) = run(&args);
        assert!(ok, "{err}");
    };
    let def = d.join("default");
    paint(&def, &[]);
    let (obj, glb) = (t.join("head.obj"), t.join("head.glb"));
    for (tag, mesh) in [("obj", &obj), ("glb", &glb)] {
        let out = d.join(tag);
        paint(
            &out,
            &[
                "--mesh",
                mesh.to_str().unwrap(),
                "--fields",
                t.to_str().unwrap(),
            ],
        );
        let (apart, means) = set_difference(&def, &out);
        assert!(
            apart <= 0.01,
            "{tag}: {:.2} % of base_color texels apart",
            100.0 * apart
        );
        for (name, rel) in means {
            assert!(
                rel <= 0.01,
                "{tag}: bio '{name}' mean off by {:.2} %",
                100.0 * rel
            );
        }
        // The GLB's skin node alone is painted (not its eyes, lashes and teeth).
        let r = report(&out);
        assert_eq!(r["counts"], report(&def)["counts"], "{tag}");
    }
    // A partial fields directory keeps the built-in fields it does not replace: the brows, lips
    // and regional colour stay (before: dropped, uniform fields in their place).
    let part = d.join("partial");
    std::fs::create_dir_all(&part).unwrap();
    std::fs::copy(t.join("freckles.png"), part.join("freckles.png")).unwrap();
    let out = d.join("partial-out");
    paint(
        &out,
        &[
            "--mesh",
            obj.to_str().unwrap(),
            "--fields",
            part.to_str().unwrap(),
        ],
    );
    let (apart, _) = set_difference(&def, &out);
    assert!(apart <= 0.01, "{:.2} % apart", 100.0 * apart);
    let r = report(&out);
    assert_eq!(
        r["inputs"]["field_origins"]["freckles"],
        part.join("freckles.png").display().to_string()
    );
    assert_eq!(r["inputs"]["field_origins"]["lips"], "built-in");
    // A misnamed field file is an error naming it and listing the known fields (before: ignored).
    std::fs::copy(t.join("freckles.png"), part.join("frekles.png")).unwrap();
    let (ok, err) = run(&[
        "skin",
        "--size",
        "64",
        "--mesh",
        obj.to_str().unwrap(),
        "--fields",
        part.to_str().unwrap(),
        "--out",
        d.join("bad").to_str().unwrap(),
    ]);
    assert!(
        !ok && err.contains("frekles.png")
            && err.contains("known fields")
            && err.contains("freckles"),
        "{err}"
    );
    assert!(
        !d.join("bad").exists(),
        "an early error leaves no output directory"
    );
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_set_knows_what_it_holds_and_a_rerun_replaces_it_whole() {
    let d = tmp("manifest");
    let set = d.join("set");
    let paint = |seed: &str| {
        run(&[
            "skin",
            "--size",
            "64",
            "--seed",
            seed,
            "--out",
            set.to_str().unwrap(),
        ])
    };
    let (ok, err) = paint("1");
    assert!(ok, "{err}");
    let m = |p: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p.join("manifest.json")).unwrap()).unwrap()
    };
    let m1 = m(&set);
    assert_eq!(m1["seed"], 1);
    assert_eq!(m1["options"]["config"]["size"], 64);
    let hashed: Vec<&str> = m1["maps"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["sha256"].is_string())
        .map(|e| e["file"].as_str().unwrap())
        .collect();
    assert!(
        hashed.contains(&"base_color.png") && !hashed.contains(&"report.json"),
        "{hashed:?}"
    );
    let check = |dir: &Path| {
        let out = derma()
            .args(["check", dir.to_str().unwrap()])
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
        )
    };
    assert!(check(&set).0);
    // The same seed again: every file but report.json byte for byte, the manifest included.
    let again = d.join("again");
    let (ok, err) = run(&[
        "skin",
        "--size",
        "64",
        "--seed",
        "1",
        "--threads",
        "1",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    for f in ["manifest.json", "base_color.png", "features.json"] {
        assert_eq!(
            std::fs::read(set.join(f)).unwrap(),
            std::fs::read(again.join(f)).unwrap(),
            "{f}"
        );
    }
    // A rerun with another seed replaces the set whole, leaving nothing beside it.
    let (ok, err) = paint("2");
    assert!(ok, "{err}");
    assert_eq!(m(&set)["seed"], 2);
    assert!(check(&set).0);
    let beside: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(beside.len(), 2, "{beside:?}");
    // A changed map and a stray file are found.
    std::fs::write(set.join("normal.png"), b"not a normal map").unwrap();
    std::fs::write(set.join("notes.txt"), b"mine").unwrap();
    let (ok, out) = check(&set);
    assert!(
        !ok && out.contains("changed: normal.png") && out.contains("notes.txt"),
        "{out}"
    );
    // A directory holding somebody else's file is not painted over.
    let (ok, err) = paint("3");
    assert!(!ok && err.contains("notes.txt"), "{err}");
    assert_eq!(m(&set)["seed"], 2);
}

#[test]
fn flags_are_named_in_their_errors() {
    for (args, want) in [
        (vec!["skin", "--size", "0"], "--size"),
        (vec!["skin", "--size", "100000"], "--size"),
        (vec!["skin", "--age", "5"], "--age"),
    ] {
        let (ok, err) = run(&args);
        assert!(
            !ok && err.contains(want) && !err.contains("config"),
            "{args:?}: {err}"
        );
    }
    // MediaPipe landmarks on a mesh of another topology say so.
    let d = tmp("mp");
    let t = d.join("t");
    assert!(run(&["skin", "--export-template", t.to_str().unwrap()]).0);
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        t.join("head.obj").to_str().unwrap(),
        "--landmarks",
        "mediapipe",
        "--size",
        "64",
        "--out",
        d.join("o").to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("not MediaPipe's topology"), "{err}");
}

#[test]
fn canonical_face_model_from_shared_data() {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/canonical_face_model.obj");
    if !p.exists() {
        eprintln!("skipping: {} is absent", p.display());
        return;
    }
    let d = tmp("canon");
    let mesh = p.to_str().unwrap();
    let (ok, err) = run_loud(&[
        "skin",
        "--mesh",
        mesh,
        "--size",
        "128",
        "--out",
        d.to_str().unwrap(),
    ]);
    assert!(ok && err.contains("centimetres"), "unit note: {err}");
    let r = report(&d);
    // A face mask of ~15 cm × 20 cm: a few hundred cm².
    let a = r["surface_area_cm2"].as_f64().unwrap();
    assert!((100.0..600.0).contains(&a), "{a}");
    assert!(r["counts"]["mole"].as_u64().unwrap() > 0);
    // With its landmarks (MediaPipe topology), the head's default fields and regional biology
    // follow the mask: lips, eyebrows and wrinkles appear, the cheeks are redder than the chin's
    // neighbourhood would be without regions.
    let d2 = tmp("canon-lm");
    let out = d2.to_str().unwrap();
    let (ok, err) = run_loud(&[
        "skin",
        "--mesh",
        mesh,
        "--landmarks",
        "mediapipe",
        "--out",
        out,
    ]);
    assert!(
        ok && err.contains("placed on the mesh by its landmarks"),
        "{err}"
    );
    let r = report(&d2);
    assert!(
        r["counts"]["eyebrow"].as_u64().unwrap() > 50,
        "{}",
        r["counts"]
    );
    assert!(
        r["counts"]["wrinkle"].as_u64().unwrap() > 0,
        "{}",
        r["counts"]
    );
    // A landmark file missing names is a clear error naming the missing one.
    let bad = d2.join("lm.json");
    std::fs::write(&bad, r#"{"nose_tip": [0, 0, 10]}"#).unwrap();
    let x = d2.join("x");
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        mesh,
        "--landmarks",
        bad.to_str().unwrap(),
        "--out",
        x.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("lm.json") && err.contains("is missing"),
        "{err}"
    );
}

#[test]
fn bad_inputs_get_clear_errors() {
    let d = tmp("bad");
    let out = d.join("out");
    let o = out.to_str().unwrap();
    // Missing mesh.
    let (ok, err) = run(&["skin", "--mesh", "/nonexistent/head.obj", "--out", o]);
    assert!(!ok && err.contains("head.obj"), "{err}");
    // Corrupt mesh.
    let bad = d.join("bad.obj");
    std::fs::write(&bad, "v 1 2\nf 1 2 3 4 5\n").unwrap();
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        bad.to_str().unwrap(),
        "--size",
        "32",
        "--out",
        o,
    ]);
    assert!(!ok && err.contains("bad.obj"), "{err}");
    // Mesh without UVs.
    let nouv = d.join("nouv.obj");
    std::fs::write(&nouv, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        nouv.to_str().unwrap(),
        "--size",
        "32",
        "--out",
        o,
    ]);
    assert!(
        !ok && err.contains("nouv.obj") && err.contains("texture coordinates"),
        "{err}"
    );
    // Unknown key, NaN and out-of-range values name the key and file.
    let cfg = d.join("c.toml");
    for (text, key) in [
        ("[mole]\nsize = 3\n", "size"),
        ("[freckle]\npower = nan\n", "freckle.power"),
        ("size = 3\n", "size"),
    ] {
        std::fs::write(&cfg, text).unwrap();
        let (ok, err) = run(&["skin", "--config", cfg.to_str().unwrap(), "--out", o]);
        assert!(
            !ok && err.contains("c.toml") && err.contains(key),
            "{text}: {err}"
        );
    }
    // A size beyond the largest is refused before any work, naming the key. (The memory check
    // no longer refuses 16384² here: the streamed job needs about 10 GB of this machine's 24.)
    let (ok, err) = run(&["skin", "--size", "16385", "--out", o]);
    assert!(
        !ok && err.contains("size") && err.contains("16385"),
        "{err}"
    );
    // Unwritable output directory (a file where a directory should be).
    let file = d.join("afile");
    std::fs::write(&file, "x").unwrap();
    let (ok, err) = run(&[
        "skin",
        "--size",
        "32",
        "--out",
        file.join("sub").to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("not writable"), "{err}");
    // Colour image as a probability field: converted with a warning.
    let fields = d.join("fields");
    std::fs::create_dir_all(&fields).unwrap();
    let r = derma_core::Map::filled(8, 8, 1.0);
    let z = derma_core::Map::filled(8, 8, 0.0);
    derma_core::image_io::write_png8(&fields.join("moles.png"), &[&r, &z, &z]).unwrap();
    let obj = d.join("q.obj");
    write_quad_obj(&obj, 100.0);
    let o2 = derma()
        .args([
            "skin",
            "--mesh",
            obj.to_str().unwrap(),
            "--fields",
            fields.to_str().unwrap(),
            "--size",
            "32",
            "--out",
            o,
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o2.stderr);
    assert!(
        o2.status.success() && err.contains("moles") && err.contains("colour image"),
        "{err}"
    );
    // Fields and outputs in one directory could overwrite the painted fields: refused.
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        obj.to_str().unwrap(),
        "--fields",
        fields.to_str().unwrap(),
        "--out",
        fields.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("same directory"), "{err}");
    // Corrupt field image.
    std::fs::write(fields.join("freckles.png"), b"garbage").unwrap();
    let (ok, err) = run(&[
        "skin",
        "--mesh",
        obj.to_str().unwrap(),
        "--fields",
        fields.to_str().unwrap(),
        "--size",
        "32",
        "--out",
        o,
    ]);
    assert!(!ok && err.contains("freckles.png"), "{err}");
}

#[test]
fn optics_slab_json_and_errors() {
    let out = derma()
        .args([
            "-q",
            "optics",
            "slab",
            "--layer",
            "0.2,10,90,0.75,1",
            "--photons",
            "20000",
            "--device",
            "cpu",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for k in [
        "r_specular",
        "r_diffuse",
        "t_total",
        "absorbed",
        "photons",
        "photons_per_s",
        "device",
    ] {
        assert!(v.get(k).is_some(), "missing key {k}");
    }
    for k in ["r_specular", "r_diffuse", "t_total", "absorbed"] {
        assert!(v["stderr"][k].is_number(), "stderr.{k}");
    }
    assert_eq!(v["device"], "cpu");
    assert_eq!(v["photons"], 20000);
    let sum = ["r_specular", "r_diffuse", "t_total", "absorbed"]
        .iter()
        .map(|k| v[k].as_f64().unwrap())
        .sum::<f64>();
    assert!((sum - 1.0).abs() < 0.01);

    let (ok, err) = run(&["optics", "slab", "--layer", "0.2,10,90,1.5,1"]);
    assert!(
        !ok && err.contains("anisotropy g") && err.contains("got 1.5"),
        "{err}"
    );
    let (ok, err) = run(&["optics", "slab", "--layer", "0.2,ten,90,0.5,1"]);
    assert!(
        !ok && err.contains("mua_per_cm") && err.contains("got 'ten'"),
        "{err}"
    );
    let (ok, err) = run(&["optics", "simulate", "--melanin", "1.5", "--device", "cpu"]);
    assert!(
        !ok && err.contains("melanin: expected") && err.contains("got 1.5"),
        "{err}"
    );
}

#[test]
fn optics_simulate_writes_result_and_plots() {
    let dir = tmp("optics-sim");
    let (ok, err) = run(&[
        "optics",
        "simulate",
        "--photons",
        "8200",
        "--device",
        "cpu",
        "--plot",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    for f in ["result.json", "spectrum.svg", "brdf.svg", "profile.svg"] {
        assert!(dir.join(f).exists(), "{f}");
    }
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("result.json")).unwrap()).unwrap();
    assert_eq!(r["r_diffuse"].as_array().unwrap().len(), 41);
    assert!(r["bookkeeping_error"].as_f64().unwrap().abs() < 1e-9);
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn match_fit_table_plots_and_skin_with_it() {
    let dir = tmp("match");
    let grid = dir.join("grid.toml");
    std::fs::write(
        &grid,
        "photons = 30000\nseed = 3\nbrdf = [6, 6, 8]\nprofile_bins = 32\nprofile_d_max_mm = 6.0\n\
         [axes]\nmelanin = [0.01, 0.3]\npheomelanin = [0.3]\nblood = [0.02]\noxygenation = [0.75]\n\
         stratum_corneum_um = [15.0]\nepidermis_um = [80.0]\n",
    )
    .unwrap();
    let pre = dir.join("pre");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (ok, err) = run(&[
        "optics",
        "precompute",
        "--grid",
        &s(&grid),
        "--out",
        &s(&pre),
        "--device",
        "cpu",
    ]);
    assert!(ok, "{err}");
    let pre_t = dir.join("pre.dtab");
    let (ok, err) = run(&["optics", "merge", &s(&pre), "--out", &s(&pre_t)]);
    assert!(ok, "{err}");
    let table = dir.join("table.dtab");
    let plots = dir.join("plots");
    let out = derma()
        .args([
            "match",
            "fit",
            "--grid",
            &s(&pre_t),
            "--out",
            &s(&table),
            "--model",
            "ggx,kelemen",
            "--anneal-steps",
            "60",
            "--plots",
            &s(&plots),
            "--quiet",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("ggx") && stdout.contains("burley"),
        "{stdout}"
    );
    assert!(table.exists() && dir.join("table.dtab.json").exists());
    let csv = std::fs::read_to_string(dir.join("table.residuals.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with("node,melanin,"));
    assert!(plots.join("profile-node0.svg").exists());
    assert!(std::fs::read_dir(&plots).unwrap().count() >= 4);
    // The table drives the skin job: subsurface maps appear, darker melanin node → darker.
    let t = derma_shading::MatchTable::read(&table).unwrap();
    let fair = t
        .value_at(&[0.01, 0.3, 0.02, 0.75, 15.0, 80.0], "ggx")
        .unwrap();
    let dark = t
        .value_at(&[0.3, 0.3, 0.02, 0.75, 15.0, 80.0], "ggx")
        .unwrap();
    assert!(dark[0] < fair[0] && dark[1] < fair[1], "{fair:?} {dark:?}");
    let sk = dir.join("skin");
    let (ok, err) = run(&[
        "skin",
        "--size",
        "64",
        "--table",
        &s(&table),
        "--out",
        &s(&sk),
    ]);
    assert!(ok, "{err}");
    assert!(sk.join("sss_radius.png").exists() && sk.join("sss_color.png").exists());
    assert_eq!(report(&sk)["appearance"], "match-table");
    // The analytic appearance writes no subsurface maps.
    let an = dir.join("analytic");
    let (ok, err) = run(&[
        "skin",
        "--size",
        "64",
        "--appearance",
        "analytic",
        "--out",
        &s(&an),
    ]);
    assert!(ok, "{err}");
    assert!(!an.join("sss_radius.png").exists());
    assert_eq!(report(&an)["appearance"], "spectral-km");
    // Errors name the problem.
    let (ok, err) = run(&[
        "match",
        "fit",
        "--grid",
        &s(&pre_t),
        "--out",
        &s(&table),
        "--model",
        "phong",
    ]);
    assert!(
        !ok && err.contains("phong") && err.contains("kelemen"),
        "{err}"
    );
    let (ok, err) = run(&["match", "fit", "--grid", &s(&pre_t), "--out", &s(&pre_t)]);
    assert!(!ok && err.contains("is the input"), "{err}");
    let (ok, err) = run(&[
        "skin",
        "--size",
        "64",
        "--table",
        &s(&pre_t),
        "--out",
        &s(&sk),
    ]);
    assert!(!ok && err.contains("not a derma match table"), "{err}");
}

#[test]
fn match_lut_png_and_dtab() {
    let dir = tmp("lut");
    let png = dir.join("lut.png");
    let dt = dir.join("lut.dtab");
    let (ok, err) = run(&[
        "match",
        "lut",
        "--size",
        "3",
        "--photons",
        "3000",
        "--out",
        png.to_str().unwrap(),
        "--out",
        dt.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let img = derma_core::image_io::read_rgb(&png).unwrap();
    assert_eq!(img.channels[0].width(), 3);
    let t = derma_core::dtab::Dtab::read(&dt).unwrap();
    assert_eq!(t.header.nodes(), 9);
    assert_eq!(t.header.meta["eumelanin_blend"], 0.61);
    let (ok, err) = run(&[
        "match",
        "lut",
        "--out",
        dir.join("lut.jpg").to_str().unwrap(),
    ]);
    assert!(!ok && err.contains(".png or .dtab"), "{err}");
}

#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    // `derma … | head`: the reader is gone before derma writes; derma must exit quietly, not
    // panic on the broken pipe.
    for args in [
        vec!["skin", "--print-config"],
        vec!["rig", "library"],
        vec!["optics", "precompute", "--print-grid"],
    ] {
        let mut child = derma()
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success() && !err.contains("panicked"),
            "{args:?}: {:?} {err}",
            out.status
        );
    }
}
