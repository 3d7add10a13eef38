//! The renderer's readers never panic on bad files (docs/render.md's inputs): a texture set with
//! a damaged map, and arbitrary or damaged bytes as a user's mesh, give an error (or maps of one
//! size and a mesh in millimetres). A mesh `derma skin` accepts, `derma render` accepts too.

use derma_core::image_io::write_png8;
use derma_core::Map;
use derma_render::glb::load_mesh_mm;
use derma_render::material::SkinMaps;
use derma_test_support::{damaged, quad_glb, scratch_dir};
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::OnceLock;

const MAPS: [&str; 4] = [
    "base_color.png",
    "normal.png",
    "roughness.png",
    "specular.png",
];

/// A valid 8 × 8 texture set (the four maps the renderer needs), written once.
fn texture_set() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = scratch_dir("robust-render-set");
        let m = |v: f32| Map::from_vec(8, 8, vec![v; 64]).unwrap();
        let (a, b, c) = (m(0.6), m(0.5), m(1.0));
        write_png8(&d.join(MAPS[0]), &[&a, &b, &b]).unwrap();
        write_png8(&d.join(MAPS[1]), &[&b, &b, &c]).unwrap();
        write_png8(&d.join(MAPS[2]), &[&b]).unwrap();
        write_png8(&d.join(MAPS[3]), &[&b]).unwrap();
        d
    })
}

#[test]
fn the_valid_set_reads() {
    SkinMaps::from_dir(texture_set()).unwrap();
}

/// One loader, one set of rules: a mesh in no head-sized unit (8.6 units tall) is fitted by the
/// renderer as by `derma skin`, not refused.
#[test]
fn a_mesh_in_no_unit_is_fitted_as_derma_skin_fits_it() {
    let d = scratch_dir("robust-render-fit");
    let p = d.join("small.obj");
    std::fs::write(
        &p,
        "v 0 0 0\nv 4 0 0\nv 0 8.6 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let m = load_mesh_mm(&p, &derma_core::progress::Silent).unwrap();
    let (_, scale) = derma_core::mesh::load_head_mesh(
        &p,
        derma_core::mesh::HeadUnit::Auto,
        &derma_core::progress::Silent,
    )
    .unwrap();
    assert!(scale.unit.is_none(), "fitted, not read in a unit");
    assert!(
        (m.extent() - derma_core::mesh::NOMINAL_HEAD_EXTENT_MM).abs() < 1e-3,
        "{}",
        m.extent()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn a_set_with_a_damaged_map_is_an_error_or_maps(
        which in 0usize..4, cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let src = texture_set();
        let d = scratch_dir("robust-render-damaged");
        for f in MAPS {
            std::fs::copy(src.join(f), d.join(f)).unwrap();
        }
        let bytes = damaged(&std::fs::read(src.join(MAPS[which])).unwrap(), cut, at, flip);
        std::fs::write(d.join(MAPS[which]), bytes).unwrap();
        let _ = SkinMaps::from_dir(&d);
    }

    #[test]
    fn bad_meshes_are_errors_or_meshes_in_millimetres(
        glb in any::<bool>(), cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
        text in "\\PC{0,200}",
    ) {
        let d = scratch_dir("robust-render-mesh");
        let p = if glb {
            let p = d.join("m.glb");
            std::fs::write(&p, damaged(&quad_glb(), cut, at, flip)).unwrap();
            p
        } else {
            let p = d.join("m.obj");
            std::fs::write(&p, format!("v 0 0 0\nv 100 0 0\nv 0 150 0\n{text}\nf 1 2 3\n")).unwrap();
            p
        };
        if let Ok(m) = load_mesh_mm(&p, &derma_core::progress::Silent) {
            prop_assert!(m.positions.iter().all(|v| v.is_finite()));
        }
    }
}
