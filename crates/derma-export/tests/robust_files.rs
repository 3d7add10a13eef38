//! The export crate's readers never panic on bad files (docs/render.md's and docs/batch.md's
//! inputs): arbitrary or damaged bytes as a user's mesh give an error, or a mesh in millimetres;
//! any text as a batch spec gives an error, or a spec whose every identity can be drawn. A mesh
//! `derma skin` accepts, `derma render` and `derma export` accept too.

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

    #[test]
    fn any_text_as_a_batch_spec_is_an_error_or_a_spec_that_draws(
        count in 0usize..40, size in 0u32..20000, male in -1.0f32..2.0,
        a0 in -10.0f32..130.0, a1 in -10.0f32..130.0, extra in "\\PC{0,60}",
        damaged_at in 0usize..200,
    ) {
        let text = format!(
            "count = {count}\nsize = {size}\nmale = {male}\nage_years = [{a0:?}, {a1:?}]\n{extra}\n"
        );
        // Cut at a random place too: a spec written half-way.
        let cut: String = text.chars().take(damaged_at.max(1)).collect();
        for t in [text.as_str(), cut.as_str()] {
            if let Ok(spec) = derma_export::batch::BatchSpec::parse(t, "spec.toml") {
                for i in 0..spec.count.min(8) {
                    let id = spec.identity(i);
                    prop_assert!(id.ita_deg.is_finite() && id.age_years.is_finite());
                    prop_assert!((spec.age_years[0] - 0.05..=spec.age_years[1] + 0.05).contains(&id.age_years));
                }
            }
        }
    }
}
