//! The export crate's readers never panic on bad files (docs/render.md's
//! inputs): arbitrary or damaged bytes as a user's mesh give an error, or a mesh in millimetres.
//! A mesh `derma skin` accepts, `derma render` and `derma export` accept too.

use derma_export::glb::load_mesh_mm;
use derma_test_support::{damaged, quad_glb, scratch_dir};
use proptest::prelude::*;

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
    let (_, scale) = derma_core::head_mesh::load_head_mesh(
        &p,
        &derma_core::head_mesh::HeadRead::default(),
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
