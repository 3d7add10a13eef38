//! The export crate's readers of its own outputs and a user's files never panic on bad files
//! (docs/render.md): a web export's manifest of any text, a user's mesh damaged in any unit and a
//! set's loose maps of any bytes give an error or a valid result — `web::check_export`,
//! `glb::load_mesh_in` and `glb::write_maps`.

use derma_core::head_mesh::HeadUnit;
use derma_core::image_io::write_png8;
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::Silent;
use derma_core::Map;
use derma_export::glb::{self, MapNames, NormalConvention};
use derma_export::web;
use derma_render::material::SkinMaps;
use derma_test_support::{damaged, quad_glb};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-outputs-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A set's four maps the renderer reads (8²), written once.
fn texture_set() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = scratch("set");
        std::fs::create_dir_all(&d).unwrap();
        let m = |v: f32| Map::from_vec(8, 8, vec![v; 64]).unwrap();
        let (a, b, c) = (m(0.6), m(0.5), m(1.0));
        write_png8(&d.join("base_color.png"), &[&a, &b, &b]).unwrap();
        write_png8(&d.join("normal.png"), &[&b, &b, &c]).unwrap();
        write_png8(&d.join("roughness.png"), &[&b]).unwrap();
        write_png8(&d.join("specular.png"), &[&b]).unwrap();
        d
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(32)))]

    #[test]
    fn a_web_manifest_of_any_text_is_checked(text in "\\PC{0,120}", valid in any::<bool>(), cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=127) {
        let dir = scratch("web");
        std::fs::create_dir_all(&dir).unwrap();
        let good = serde_json::json!({ "format": web::FORMAT, "files": [] }).to_string();
        let bytes = if valid { damaged(good.as_bytes(), cut, at, flip) } else { text.into_bytes() };
        std::fs::write(dir.join("manifest.json"), &bytes).unwrap();
        let is_one = serde_json::from_slice::<serde_json::Value>(&bytes)
            .ok()
            .is_some_and(|v| v["format"] == web::FORMAT);
        prop_assert_eq!(web::check_export(&dir).is_ok(), is_one);
    }

    #[test]
    fn damaged_meshes_in_any_unit_are_errors_or_finite(
        glb in any::<bool>(), cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
        unit in prop_oneof![Just(HeadUnit::Auto), Just(HeadUnit::Fit)],
    ) {
        let p = if glb {
            let p = scratch("mesh.glb");
            std::fs::write(&p, damaged(&quad_glb(), cut, at, flip)).unwrap();
            p
        } else {
            let obj = "v 0 0 0\nv 100 0 0\nv 0 150 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
            let p = scratch("mesh.obj");
            std::fs::write(&p, damaged(obj.as_bytes(), cut, at, flip)).unwrap();
            p
        };
        if let Ok(m) = glb::load_mesh_in(&p, unit, &PartChoice::Auto, &Silent) {
            prop_assert!(m.positions.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn loose_maps_of_any_bytes_are_copied_as_they_are(
        bytes in proptest::collection::vec(any::<u8>(), 0..200),
        directx in any::<bool>(),
    ) {
        let skin = SkinMaps::from_dir(texture_set()).unwrap();
        let src = scratch("loose-src");
        std::fs::create_dir_all(&src).unwrap();
        std::fs::write(src.join("roughness.png"), &bytes).unwrap();
        let conv = if directx { NormalConvention::DirectX } else { NormalConvention::OpenGl };
        let out = scratch("loose-out");
        let written = glb::write_maps(&src, &skin, &out, MapNames::Derma, conv).unwrap();
        let copied = written.iter().find(|p| p.ends_with("roughness.png")).expect("copied");
        prop_assert_eq!(std::fs::read(copied).unwrap(), bytes);
    }
}
