//! A fitted head directory's readers never panic on bad files (docs/head.md, "Fitting your
//! head"): `head.json` truncated or with a byte changed, of arbitrary text, or with any scale
//! gives an error or a head that is whole — `store::read`, `store::frame`, and
//! `fitted::load_user_mesh`, which reads a user's mesh through the fitted head's frame.

use derma_core::head_mesh::{HeadUnit, MeshFrame};
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::Silent;
use derma_head::fit::{self, store, Alignment, FitOptions};
use derma_head::{fitted, Head};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-fitted-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A fitted head directory, written once: the built-in head fitted to its own skin by its own
/// landmarks (one stiff pass: quick, and a valid head.json all the same).
fn fitted_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let head = Head::builtin();
        let scan = head.skin.clone();
        let opts = FitOptions {
            alignment: Alignment::Landmarks(head.landmarks.clone()),
            stiffness: vec![40.0],
            iterations: 1,
            max_residual_mm: 1e3,
            ..FitOptions::default()
        };
        let fitted = fit::fit(scan.clone(), &opts, &Silent).expect("the head fits itself");
        let dir = scratch("valid");
        let frame = MeshFrame::scaled(None, 1.0);
        let info = store::ScanInfo {
            name: "scan.obj",
            frame: &frame,
            mesh: &scan,
        };
        store::write(&fitted, &info, &dir).unwrap();
        dir
    })
}

/// A user's mesh with UVs (one 200 mm quad), read through a fitted head's frame.
fn user_mesh() -> &'static Path {
    static MESH: OnceLock<PathBuf> = OnceLock::new();
    MESH.get_or_init(|| {
        let p = scratch("user.glb");
        std::fs::write(&p, derma_test_support::quad_glb()).unwrap();
        p
    })
}

/// A copy of the fitted head's head.json (in a directory of its own per `tag`) as `bytes`.
fn with_head_json(tag: &str, bytes: &[u8]) -> PathBuf {
    let dir = scratch(tag);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("head.json"), bytes).unwrap();
    dir
}

/// Reads the directory with every reader; only panics and unusable heads fail.
fn read_all(dir: &Path) -> Result<(), TestCaseError> {
    if let Ok(f) = store::read(dir) {
        prop_assert!(f.positions.iter().chain(&f.fine).all(|p| p.is_finite()));
        prop_assert!(f.eyes.iter().all(|e| e.radius > 0.0));
    }
    if let Ok(frame) = store::frame(dir) {
        prop_assert!(frame.mm_per_unit.is_finite() && frame.mm_per_unit > 0.0);
    }
    let read = fitted::load_user_mesh(
        Some(dir),
        user_mesh(),
        HeadUnit::Auto,
        &PartChoice::Auto,
        &Silent,
    );
    if let Ok((mesh, _)) = read {
        prop_assert!(mesh.positions.iter().all(|p| p.is_finite()));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(24)))]

    #[test]
    fn damaged_head_json_is_an_error_or_a_whole_head(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let original = std::fs::read(fitted_dir().join("head.json")).unwrap();
        read_all(&with_head_json("damaged", &damaged(&original, cut, at, flip)))?;
    }

    #[test]
    fn arbitrary_head_json_is_an_error(text in "\\PC{0,300}") {
        let dir = with_head_json("arbitrary", text.as_bytes());
        prop_assert!(store::read(&dir).is_err());
        prop_assert!(store::frame(&dir).is_err());
        read_all(&dir)?;
    }

    #[test]
    fn any_scale_is_refused_or_plausible(mm_per_unit in any::<f32>(), version_one in any::<bool>()) {
        let original = std::fs::read(fitted_dir().join("head.json")).unwrap();
        let mut json: serde_json::Value = serde_json::from_slice(&original).unwrap();
        json["mm_per_unit"] = serde_json::json!(mm_per_unit);
        if version_one {
            // Version 1 has no frame: the scale alone.
            json.as_object_mut().unwrap().remove("frame");
        } else {
            json["frame"]["mm_per_unit"] = serde_json::json!(mm_per_unit);
        }
        let dir = with_head_json("scale", &serde_json::to_vec(&json).unwrap());
        // Micrometres to kilometres per unit: beyond, the scaled mesh leaves f32's range.
        let plausible = (1e-6..=1e6).contains(&mm_per_unit);
        prop_assert_eq!(store::frame(&dir).is_ok(), plausible);
        // JSON has no NaN or infinity: those scales are null, which no head.json reads.
        prop_assert_eq!(store::read(&dir).is_ok(), mm_per_unit.is_finite());
        // Read through any scale, the user's mesh is refused or finite.
        if let Ok((mesh, _)) = fitted::load_user_mesh(Some(&dir), user_mesh(), HeadUnit::Auto, &PartChoice::Auto, &Silent) {
            prop_assert!(mesh.positions.iter().all(|p| p.is_finite()));
        }
    }
}

#[test]
fn the_valid_directory_reads() {
    let dir = fitted_dir();
    assert!(store::read(dir).is_ok());
    assert_eq!(store::frame(dir).unwrap().mm_per_unit, 1.0);
    assert!(fitted::load_user_mesh(
        Some(dir),
        user_mesh(),
        HeadUnit::Auto,
        &PartChoice::Auto,
        &Silent
    )
    .is_ok());
}
