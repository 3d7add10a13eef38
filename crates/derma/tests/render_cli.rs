//! End-to-end tests of `derma render`, `derma export glb|web` and `derma view`: the files each
//! writes, what engines read from the GLB, the web export's 16-bit round trip, and the errors
//! users meet.

use crate::common;

use common::{run, s};
use std::path::{Path, PathBuf};

fn tmp(tag: &str) -> PathBuf {
    common::tmp("rendercli", tag)
}

fn skin(d: &Path) -> PathBuf {
    let out = d.join("skin");
    let (ok, _, err) = run(&["skin", "--size", "256", "--out", s(&out)]);
    assert!(ok, "{err}");
    out
}

fn rgb(p: &Path) -> derma_core::image_io::LoadedImage {
    derma_core::image_io::read_rgb(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn render_writes_each_lighting_a_sheet_and_linear_exr() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    let d = tmp("render");
    let set = skin(&d);
    let out = d.join("r");
    let (ok, _, err) = run(&[
        "render",
        s(&set),
        "--size",
        "320x240",
        "--sheet",
        "--exr",
        "--yaw",
        "20",
        "--device",
        "gpu",
        "--out",
        s(&out),
    ]);
    assert!(ok, "{err}");
    for f in ["studio.png", "window.png"] {
        let img = rgb(&out.join(f));
        let c = &img.channels[0];
        assert_eq!((c.width(), c.height()), (320, 240), "{f}");
    }
    assert!(out.join("sheet.png").is_file());
    let exr = derma_core::image_io::read_exr_channels(&out.join("studio.exr")).unwrap();
    let mut names: Vec<&str> = exr.iter().map(|c| c.0.as_str()).collect();
    names.sort();
    assert_eq!(names, ["B", "G", "R"]);
    // Linear radiance: non-negative, zero on the background, positive on the head.
    let r = &exr.iter().find(|c| c.0 == "R").unwrap().1;
    assert!(r.data().iter().all(|&v| v >= 0.0));
    assert_eq!(r.get(0, 0), 0.0);
    assert!(r.get(160, 120) > 0.0);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("render.json")).unwrap()).unwrap();
    assert_eq!(report["size"], serde_json::json!([320, 240]));
    assert_eq!(report["view"]["yaw_deg"], 20.0);
    // The studio and window setups light the head differently.
    assert!(
        std::fs::read(out.join("studio.png")).unwrap()
            != std::fs::read(out.join("window.png")).unwrap()
    );
}

#[test]
fn render_on_the_cpu_draws_the_same_scene_without_a_gpu_and_repeats_bit_for_bit() {
    let d = tmp("render-cpu");
    let set = skin(&d);
    let go = |out: &Path| {
        let (ok, _, err) = run(&[
            "render",
            s(&set),
            "--size",
            "200x160",
            "--lighting",
            "studio",
            "--device",
            "cpu",
            "--exr",
            "--out",
            s(out),
        ]);
        assert!(ok, "{err}");
    };
    let (a, b) = (d.join("a"), d.join("b"));
    go(&a);
    go(&b);
    let png = std::fs::read(a.join("studio.png")).unwrap();
    assert_eq!(png, std::fs::read(b.join("studio.png")).unwrap());
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("render.json")).unwrap()).unwrap();
    assert!(
        report["adapter"].as_str().unwrap().starts_with("CPU"),
        "{report}"
    );
    // The head in the middle of the frame, lit; the corners are background (zero radiance).
    let exr = derma_core::image_io::read_exr_channels(&a.join("studio.exr")).unwrap();
    let ch = |n: &str| &exr.iter().find(|c| c.0 == n).unwrap().1;
    let (r, g, bl) = (ch("R"), ch("G"), ch("B"));
    assert_eq!(r.get(0, 0), 0.0);
    // Cheek-level skin: warm (red above green above blue).
    let (x, y) = (100, 95);
    assert!(r.get(x, y) > g.get(x, y) && g.get(x, y) > bl.get(x, y) && bl.get(x, y) > 0.0);
}

#[test]
fn a_teeth_texture_reaches_the_teeth_and_nothing_else() {
    // `derma photo teeth`'s texture on the head's teeth, the mouth opened: a blue texture turns
    // only teeth pixels blue; on a user mesh (no teeth) it is refused, naming the file.
    let d = tmp("render-teeth");
    let set = skin(&d);
    let teeth = d.join("teeth.png");
    let plane = |v: f32| derma_core::map::Map::filled(32, 32, v);
    derma_core::image_io::write_png8(&teeth, &[&plane(0.15), &plane(0.35), &plane(0.9)]).unwrap();
    let go = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "render",
            s(&set),
            "--pose",
            "jawOpen=1",
            "--size",
            "256",
            "--lighting",
            "studio",
            "--device",
            "cpu",
            "--out",
            s(out),
        ];
        args.extend_from_slice(extra);
        run(&args)
    };
    let (a, b) = (d.join("plain"), d.join("blue"));
    assert!(go(&a, &[]).0);
    let (ok, _, err) = go(&b, &["--teeth", s(&teeth)]);
    assert!(ok, "{err}");
    let (pa, pb) = (rgb(&a.join("studio.png")), rgb(&b.join("studio.png")));
    let (w, h) = (pa.channels[0].width(), pa.channels[0].height());
    let (mut changed, mut bluer, mut rows) = (0, 0, (usize::MAX, 0));
    for i in 0..w * h {
        let (p, q) = (
            [0, 1, 2].map(|c| pa.channels[c].data()[i]),
            [0, 1, 2].map(|c| pb.channels[c].data()[i]),
        );
        if p != q {
            changed += 1;
            bluer += usize::from(q[2] - q[0] > p[2] - p[0]);
            rows = (rows.0.min(i / w), rows.1.max(i / w));
        }
    }
    // Every changed pixel is bluer, and they lie in the lower half of the frame (the mouth).
    assert!(
        changed > 50 && bluer == changed,
        "{changed} changed, {bluer} bluer"
    );
    assert!(rows.0 > h / 2, "changed rows {rows:?} of {}", h);
    let mesh = d.join("head.obj");
    derma_head::Head::builtin().skin.write_obj(&mesh).unwrap();
    let (ok, _, err) = run(&[
        "render",
        s(&set),
        "--mesh",
        s(&mesh),
        "--teeth",
        s(&teeth),
        "--out",
        s(&d.join("m")),
    ]);
    assert!(!ok && err.contains("--teeth"), "{err}");
}

#[test]
fn a_set_is_only_rendered_on_the_uv_layout_it_was_painted_on() {
    // A set painted on a quad's UVs drawn on the head's (before: drawn without a word, the
    // quad's texels scattered over the face); the quad itself takes it.
    let d = tmp("layout");
    let quad = d.join("quad.glb");
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(&quad, derma_test_support::quad_glb()).unwrap();
    let set = d.join("set");
    let (ok, _, err) = run(&["skin", "--mesh", s(&quad), "--size", "64", "--out", s(&set)]);
    assert!(ok, "{err}");
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(set.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["uv_layout"]["triangles"], 2, "{m}");
    let r = d.join("r");
    let args = |extra: &[&str]| {
        let mut a = vec!["render", s(&set), "--size", "64x64", "--out", s(&r)];
        a.extend_from_slice(extra);
        run(&a)
    };
    let (ok, _, err) = args(&["--device", "cpu"]);
    assert!(
        !ok && err.contains("another UV layout") && err.contains("built-in head"),
        "{err}"
    );
    let (ok, _, err) = args(&["--device", "cpu", "--mesh", s(&quad)]);
    assert!(ok, "{err}");
}

#[test]
fn render_names_what_is_wrong() {
    let d = tmp("render-errors");
    std::fs::create_dir_all(d.join("empty")).unwrap();
    let (ok, _, err) = run(&["render", s(&d.join("empty")), "--out", s(&d.join("r"))]);
    assert!(!ok);
    assert!(
        !d.join("r").exists(),
        "an early error leaves no output directory"
    );
    assert!(
        err.contains("base_color.png") && err.contains("derma skin"),
        "{err}"
    );
    let (ok, _, err) = run(&["render", s(&d.join("empty")), "--lighting", "disco"]);
    assert!(!ok);
    assert!(err.contains("disco"), "{err}");
}

#[test]
fn glb_carries_the_set_as_pbr_with_tangents_units_and_engine_maps() {
    let d = tmp("glb");
    let set = skin(&d);
    let glb = d.join("head.glb");
    let maps = d.join("unreal");
    // An eye texture as `derma photo iris` writes one (sRGB PNG): a green eye.
    let iris = d.join("eye.png");
    let plane = |v: f32| derma_core::map::Map::filled(64, 64, v);
    derma_core::image_io::write_png8(&iris, &[&plane(0.2), &plane(0.6), &plane(0.3)]).unwrap();
    // A teeth texture as `derma photo teeth` writes one (sRGB PNG, 2:1, alpha 0 on the voids):
    // ivory, a void on its right quarter.
    let teeth = d.join("teeth.png");
    let ivory = |v: f32| derma_core::map::Map::filled(32, 16, v);
    let voids = derma_core::map::Map::from_fn(32, 16, |i| if i % 32 < 24 { 1.0 } else { 0.0 });
    derma_core::image_io::write_png8(&teeth, &[&ivory(0.8), &ivory(0.75), &ivory(0.6), &voids])
        .unwrap();
    let (ok, _, err) = run(&[
        "export",
        "glb",
        s(&set),
        "--out",
        s(&glb),
        "--maps",
        s(&maps),
        "--names",
        "unreal",
        "--normal",
        "directx",
        "--iris",
        s(&iris),
        "--teeth",
        s(&teeth),
        "--volume",
    ]);
    assert!(ok, "{err}");
    let (doc, buffers, images) = gltf::import(&glb).unwrap();
    // Both teeth carry the given teeth texture; nothing else does.
    let holders: Vec<&str> = doc
        .materials()
        .filter(|m| {
            m.pbr_metallic_roughness()
                .base_color_texture()
                .is_some_and(|t| {
                    let img = &images[t.texture().source().index()];
                    let px = &img.pixels[..3];
                    (img.width, img.height) == (32, 16)
                        && px
                            .iter()
                            .zip([204, 191, 153])
                            .all(|(&a, b)| a.abs_diff(b) <= 1)
                })
        })
        .filter_map(|m| m.name())
        .collect();
    assert_eq!(holders, ["teeth_upper", "teeth_lower"]);
    // Their voids cut out, as the renderers cut them.
    for t in holders {
        let m = doc.materials().find(|m| m.name() == Some(t)).unwrap();
        assert_eq!(m.alpha_mode(), gltf::material::AlphaMode::Mask, "{t}");
        assert_eq!(m.alpha_cutoff(), Some(0.5), "{t}");
    }
    // The globes carry the given eye texture (its sRGB codes back within a level).
    for eye in ["eye_left", "eye_right"] {
        let m = doc.materials().find(|m| m.name() == Some(eye)).unwrap();
        let t = m.pbr_metallic_roughness().base_color_texture().unwrap();
        let img = &images[t.texture().source().index()];
        assert_eq!((img.width, img.height), (64, 64), "{eye}");
        let px = &img.pixels[..3];
        for (got, want) in px.iter().zip([0.2f32, 0.6, 0.3]) {
            assert!((*got as f32 - want * 255.0).abs() <= 1.0, "{eye}: {px:?}");
        }
    }
    let used: Vec<&str> = doc.extensions_used().collect();
    for e in [
        "KHR_materials_specular",
        "KHR_materials_volume",
        "KHR_materials_diffuse_transmission",
    ] {
        assert!(used.contains(&e), "{e} in {used:?}");
    }
    let names: Vec<&str> = doc.meshes().filter_map(|m| m.name()).collect();
    for n in ["skin", "eye_left", "eye_right"] {
        assert!(names.contains(&n), "mesh {n} in {names:?}");
    }
    // The lash cards carry the set's lashes.png: the hair's colour, single lashes as alpha.
    let lash_card = doc
        .materials()
        .find(|m| m.name() == Some("eyelashes_left"))
        .unwrap();
    // Blended: a lash thinner than a pixel fades instead of breaking into dots.
    assert_eq!(lash_card.alpha_mode(), gltf::material::AlphaMode::Blend);
    let tex = lash_card
        .pbr_metallic_roughness()
        .base_color_texture()
        .unwrap();
    let gltf::image::Source::View { view, .. } = tex.texture().source().source() else {
        panic!("the lash image is not embedded");
    };
    let embedded = &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
    assert!(embedded == std::fs::read(set.join("lashes.png")).unwrap().as_slice());
    // The brows as a card: blended, with the skin's face units as morph targets.
    let brows = doc.meshes().find(|m| m.name() == Some("eyebrows")).unwrap();
    let bp = brows.primitives().next().unwrap();
    assert_eq!(bp.material().alpha_mode(), gltf::material::AlphaMode::Blend);
    // `--hair-mask`: both alpha-tested at ½ instead, for engines that sort no transparency.
    let masked = d.join("masked.glb");
    let (ok, _, err) = run(&["export", "glb", s(&set), "--out", s(&masked), "--hair-mask"]);
    assert!(ok, "{err}");
    let (mdoc, _, _) = gltf::import(&masked).unwrap();
    for name in ["eyelashes_left", "eyelashes_right", "eyebrows"] {
        let m = mdoc.materials().find(|m| m.name() == Some(name)).unwrap();
        assert_eq!(m.alpha_mode(), gltf::material::AlphaMode::Mask, "{name}");
        assert_eq!(m.alpha_cutoff(), Some(0.5), "{name}");
    }
    let br = bp.reader(|b| Some(&buffers[b.index()]));
    let skin_prim = doc
        .meshes()
        .find(|m| m.name() == Some("skin"))
        .unwrap()
        .primitives()
        .next()
        .unwrap();
    let sr = skin_prim.reader(|b| Some(&buffers[b.index()]));
    assert_eq!(
        br.read_morph_targets().count(),
        sr.read_morph_targets().count()
    );
    let lifted = bp
        .material()
        .pbr_metallic_roughness()
        .base_color_texture()
        .unwrap();
    let alpha = &images[lifted.texture().source().index()];
    assert_eq!(alpha.format, gltf::image::Format::R8G8B8A8);
    assert!(
        alpha.pixels.chunks(4).any(|p| p[3] > 128),
        "no hair in the brow card"
    );
    assert!(names.iter().any(|n| n.contains("teeth")), "{names:?}");
    let skin_mesh = doc.meshes().find(|m| m.name() == Some("skin")).unwrap();
    let prim = skin_mesh.primitives().next().unwrap();
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    // MikkTSpace tangents: unit xyz, handedness ±1, one per vertex.
    let tangents: Vec<[f32; 4]> = reader.read_tangents().unwrap().collect();
    let count = reader.read_positions().unwrap().count();
    assert_eq!(tangents.len(), count);
    assert!(tangents.iter().all(|t| {
        let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        (l - 1.0).abs() < 1e-3 && t[3].abs() == 1.0
    }));
    // Face units as morph targets, named.
    let extras = skin_mesh.extras().as_ref().map(|r| r.get().to_string());
    let extras = extras.unwrap_or_default();
    assert!(
        extras.contains("mouthSmileLeft") && extras.contains("eyeBlinkLeft"),
        "{extras}"
    );
    assert_eq!(
        reader.read_morph_targets().count(),
        serde_json::from_str::<serde_json::Value>(&extras).unwrap()["targetNames"]
            .as_array()
            .unwrap()
            .len()
    );
    // The globes dilate and constrict their pupils by morph (8 and 2 mm against 4).
    let eye = doc.meshes().find(|m| m.name() == Some("eye_left")).unwrap();
    let eye_extras = eye
        .extras()
        .as_ref()
        .map(|r| r.get().to_string())
        .unwrap_or_default();
    assert!(
        eye_extras.contains("pupilDilate") && eye_extras.contains("pupilConstrict"),
        "{eye_extras}"
    );
    let eye_prim = eye.primitives().next().unwrap();
    assert_eq!(eye_prim.morph_targets().count(), 2);
    // The material: base colour and normal from the set; metallic 0, roughness in G.
    let mat = prim.material();
    let pbr = mat.pbr_metallic_roughness();
    assert_eq!(pbr.metallic_factor(), 0.0);
    assert!(pbr.base_color_texture().is_some() && mat.normal_texture().is_some());
    let orm = pbr
        .metallic_roughness_texture()
        .unwrap()
        .texture()
        .source()
        .index();
    let orm = &images[orm];
    let rough = rgb(&set.join("roughness.png"));
    let mean_set =
        rough.channels[0].data().iter().sum::<f32>() / rough.channels[0].data().len() as f32;
    let stride = orm.pixels.len() / (orm.width * orm.height) as usize;
    let g_mean = orm
        .pixels
        .chunks(stride)
        .map(|p| p[1] as f32 / 255.0)
        .sum::<f32>()
        / (orm.width * orm.height) as f32;
    assert!(
        (g_mean - mean_set).abs() < 2.0 / 255.0,
        "ORM green {g_mean} vs roughness.png {mean_set}"
    );
    // Unreal's loose normal map is DirectX: green flipped against the set's OpenGL one.
    let n_gl = rgb(&set.join("normal.png"));
    let n_dx = rgb(&maps.join("T_Head_N.png"));
    let (a, b) = (&n_gl.channels[1], &n_dx.channels[1]);
    let worst = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x + y - 1.0).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1.0 / 65535.0 + 1e-6, "green not flipped: {worst}");
    assert_eq!(n_gl.channels[0].data(), n_dx.channels[0].data());
    assert!(maps.join("T_Head_BC.png").is_file() && maps.join("T_Head_ORM.png").is_file());
}

#[test]
fn web_export_round_trips_the_rig_within_one_16_bit_step_and_view_serves_it() {
    let d = tmp("web");
    let set = skin(&d);
    let rig = d.join("rig");
    let (ok, _, err) = run(&[
        "rig",
        "build",
        "--set",
        s(&set),
        "--builtin",
        "all",
        "--radius",
        "8",
        "--out",
        s(&rig),
    ]);
    assert!(ok, "{err}");
    let web = d.join("web");
    // A teeth texture reaches the viewer's head.glb (the GLB export's own test checks its texels).
    let teeth = d.join("teeth.png");
    let ivory = |v: f32| derma_core::map::Map::filled(32, 16, v);
    derma_core::image_io::write_png8(&teeth, &[&ivory(0.8), &ivory(0.75), &ivory(0.6)]).unwrap();
    let (ok, _, err) = run(&[
        "export",
        "web",
        s(&set),
        "--rig",
        s(&rig),
        "--teeth",
        s(&teeth),
        "--out",
        s(&web),
    ]);
    assert!(ok, "{err}");
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(web.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["format"], "derma-web");
    let (doc, _, images) = gltf::import(web.join(m["glb"].as_str().unwrap())).unwrap();
    for t in ["teeth_upper", "teeth_lower"] {
        let mat = doc.materials().find(|x| x.name() == Some(t)).unwrap();
        let tex = mat.pbr_metallic_roughness().base_color_texture();
        let img = &images[tex.expect(t).texture().source().index()];
        assert_eq!((img.width, img.height), (32, 16), "{t}");
    }
    let targets = m["rig"]["targets"].as_array().unwrap();
    assert!(
        targets.iter().any(|t| t["name"] == "happiness"),
        "{targets:?}"
    );
    assert_eq!(m["rig"]["basis"]["tiles"], targets.len() + 1);
    // Every region's probe point lies in [0, 1]².
    for (name, p) in m["regions"].as_object().unwrap() {
        let (u, v) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
        assert!(
            (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v),
            "{name}"
        );
    }
    // h0 decodes to the rig's own map within one 16-bit step of its range.
    let h0 = &m["rig"]["h0"];
    let (lo, hi) = (
        h0["range"][0].as_f64().unwrap() as f32,
        h0["range"][1].as_f64().unwrap() as f32,
    );
    let png = rgb(&web.join(h0["file"].as_str().unwrap()));
    let (rig_model, _, _) = derma_rig::rig_dir::load(&rig).unwrap();
    let worst = png.channels[0]
        .data()
        .iter()
        .zip(rig_model.h0.data())
        .map(|(q, v)| (lo + (hi - lo) * q - v).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 0.5 * (hi - lo) / 65535.0 * 1.01,
        "h0 off by {worst} (range {lo}..{hi})"
    );

    // `derma view` refuses a directory that is not a web export, naming what it wanted.
    let (ok, _, err) = run(&["view", s(&set)]);
    assert!(!ok);
    assert!(
        err.contains("manifest.json") && err.contains("export web"),
        "{err}"
    );

    // …and serves one: the viewer at /, the export under /data/, nothing outside either.
    let viewer = d.join("viewer");
    std::fs::create_dir_all(&viewer).unwrap();
    std::fs::write(viewer.join("index.html"), "<!doctype html><title>v</title>").unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_derma"))
        .args(["view", s(&web), "--viewer", s(&viewer), "--port", "0"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(child.stdout.take().unwrap()),
        &mut line,
    )
    .unwrap();
    let addr = line
        .split("http://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .to_string();
    let get = |path: &str| -> (String, Vec<u8>) {
        use std::io::{Read, Write};
        let mut c = std::net::TcpStream::connect(&addr).unwrap();
        write!(c, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
        let mut buf = Vec::new();
        c.read_to_end(&mut buf).unwrap();
        let split = buf.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        (
            String::from_utf8_lossy(&buf[..split]).into_owned(),
            buf[split + 4..].to_vec(),
        )
    };
    let (head, body) = get("/");
    assert!(
        head.starts_with("HTTP/1.1 200") && head.contains("text/html"),
        "{head}"
    );
    assert_eq!(body, b"<!doctype html><title>v</title>");
    let (head, body) = get("/data/manifest.json");
    assert!(head.contains("application/json"), "{head}");
    assert_eq!(body, std::fs::read(web.join("manifest.json")).unwrap());
    let (head, body) = get("/data/head.glb");
    assert!(head.contains("model/gltf-binary"), "{head}");
    assert_eq!(&body[..4], b"glTF");
    for bad in [
        "/data/../skin/manifest.json",
        "/../Cargo.toml",
        "/data/missing.png",
    ] {
        assert!(get(bad).0.starts_with("HTTP/1.1 404"), "{bad}");
    }
    child.kill().unwrap();
    child.wait().unwrap();
}

#[test]
fn skin_glb_writes_the_set_and_its_head_in_one_run() {
    let d = tmp("skin-glb");
    let out = d.join("set");
    let (ok, _, err) = run(&["skin", "--size", "128", "--glb", "--out", s(&out)]);
    assert!(ok, "{err}");
    assert!(out.join("base_color.png").is_file() && out.join("lashes.png").is_file());
    let (doc, _, _) = gltf::import(out.join("head.glb")).unwrap();
    // No volume unless asked: without transmission it does nothing in glTF, and Blender's
    // importer makes it a volume absorption that darkens Eevee.
    let used: Vec<&str> = doc.extensions_used().collect();
    assert!(!used.contains(&"KHR_materials_volume"), "{used:?}");
    assert!(used.contains(&"KHR_materials_specular"), "{used:?}");
    // The skin's node names the expressions by the face units they pose (Blender's importer
    // makes them custom properties; the add-on drives the shape keys from them).
    let bytes = std::fs::read(out.join("head.glb")).unwrap();
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
    let skin = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|n| n["name"] == "skin")
        .unwrap();
    let happiness = &skin["extras"]["derma_expressions"]["happiness"];
    assert_eq!(happiness["mouthSmileLeft"], 1.0, "{skin}");
    let target_names = &json["meshes"][skin["mesh"].as_u64().unwrap() as usize]["extras"];
    for unit in happiness.as_object().unwrap().keys() {
        assert!(
            target_names["targetNames"]
                .as_array()
                .unwrap()
                .iter()
                .any(|t| t == unit.as_str()),
            "{unit}"
        );
    }
    let names: Vec<&str> = doc.meshes().filter_map(|m| m.name()).collect();
    for n in [
        "skin",
        "eyelashes_left",
        "eyelashes_right",
        "tongue",
        "eyebrows",
    ] {
        assert!(names.contains(&n), "mesh {n} in {names:?}");
    }
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_users_mesh_renders_animates_and_takes_the_rig_through_its_fitted_head() {
    // derma's own head as a user's mesh: exported, fitted, painted through the fit.
    let d = tmp("render-fitted");
    let t = d.join("template");
    let (ok, _, err) = run(&["skin", "--export-template", s(&t)]);
    assert!(ok, "{err}");
    let mesh = t.join("head.obj");
    let fitted = d.join("fitted");
    let (ok, _, err) = run(&["head", "fit", "--mesh", s(&mesh), "--out", s(&fitted)]);
    assert!(ok, "{err}");
    let set = d.join("set");
    let (ok, _, err) = run(&[
        "skin",
        "--mesh",
        s(&mesh),
        "--head",
        s(&fitted),
        "--size",
        "128",
        "--out",
        s(&set),
    ]);
    assert!(ok, "{err}");
    let parts = |extra: &[&str], tag: &str| -> Vec<String> {
        let out = d.join(tag);
        let mut args = vec![
            "render",
            s(&set),
            "--mesh",
            s(&mesh),
            "--size",
            "96",
            "--device",
            "cpu",
            "--out",
            s(&out),
        ];
        args.extend_from_slice(extra);
        let (ok, _, err) = run(&args);
        assert!(ok, "{err}");
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("render.json")).unwrap()).unwrap();
        r["parts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(parts(&[], "plain"), ["skin"]);
    let with = parts(&["--head", s(&fitted)], "with-head");
    for p in [
        "eye_left",
        "eye_right",
        "teeth_upper",
        "eyelashes_left",
        "tongue",
    ] {
        assert!(
            with.iter().any(|n| n.starts_with(p)),
            "{p} missing from {with:?}"
        );
    }
    // A mesh the head was not fitted to is refused, naming it.
    let other = d.join("other.obj");
    let mut moved = derma_core::mesh::TriMesh::load(&mesh).unwrap();
    moved.positions.iter_mut().for_each(|p| p.x += 80.0);
    moved.write_obj(&other).unwrap();
    let (ok, _, err) = run(&[
        "render",
        s(&set),
        "--mesh",
        s(&other),
        "--head",
        s(&fitted),
        "--size",
        "64",
        "--device",
        "cpu",
        "--out",
        s(&d.join("other")),
    ]);
    assert!(
        !ok && err.contains("other.obj") && err.contains("fitted"),
        "{err}"
    );

    // Its lids animated: the GLB's skin is the user's mesh, moved by morph targets.
    let anim = d.join("anim");
    let (ok, _, err) = run(&[
        "eyes",
        "animate",
        "--head",
        s(&fitted),
        "--mesh",
        s(&mesh),
        "--seconds",
        "0.5",
        "--render",
        "0",
        "--out",
        s(&anim),
    ]);
    assert!(ok, "{err}");
    let g = gltf::Gltf::open(anim.join("head.glb")).unwrap();
    let skin = g.meshes().find(|m| m.name() == Some("skin")).unwrap();
    let prim = skin.primitives().next().unwrap();
    let n = prim.get(&gltf::Semantic::Positions).unwrap().count();
    let user = derma_core::mesh::TriMesh::load(&mesh).unwrap();
    assert_eq!(n, user.positions.len());
    assert!(prim.morph_targets().count() >= 2);
    // The rig's library on its UVs, through the fit; --head alone is refused with the reason.
    let neutral = set.join("hemoglobin.exr");
    let rig = |extra: &[&str], out: &str| {
        let mut args = vec![
            "rig",
            "build",
            "--neutral",
            s(&neutral),
            "--builtin",
            "happiness",
            "--radius",
            "4",
            "--head",
            s(&fitted),
        ];
        args.extend_from_slice(extra);
        let out = d.join(out);
        args.extend_from_slice(&["--out", s(&out)]);
        let (ok, _, err) = run(&args);
        (ok, err)
    };
    let (ok, err) = rig(&["--mesh", s(&mesh)], "rig");
    assert!(ok, "{err}");
    let (ok, err) = rig(&[], "rig2");
    assert!(!ok && err.contains("--mesh"), "{err}");
}
