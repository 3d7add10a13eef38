//! The mesh file readers below `TriMesh::load` never panic on bad files: arbitrary bytes, and an
//! OBJ, a GLB and the glTF fixtures truncated or with a byte changed, give an error or parts
//! whose triangles index their own vertices — `mesh_file::load_parts`, `mesh_file::file_positions`
//! (the file's own vertex order, for topology-indexed landmarks) and `gltf_scene::read`.

use derma_core::mesh_parts::{Part, PartChoice};
use derma_core::{gltf_scene, mesh_file};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-mesh-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

const OBJ: &str = "o skin\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n\
                   o teeth\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n";

/// A compressed fixture of tests/gltf_as_shipped.rs (meshopt with filters).
fn meshopt_glb() -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf/face_meshopt.glb");
    std::fs::read(p).unwrap()
}

/// Whatever parts read are usable: every triangle indexes a vertex of its part, and UVs are
/// none or one per vertex.
fn usable(parts: &[Part]) -> bool {
    parts.iter().all(|p| {
        let g = &p.geometry;
        let n = g.positions.len() as u32;
        g.triangles.iter().all(|t| t.iter().all(|&i| i < n))
            && (g.uvs.is_empty() || g.uvs.len() == g.positions.len())
    })
}

/// Reads `bytes` as a file named `name` with every reader of this file; only panics and
/// unusable parts fail.
fn read_all(name: &str, bytes: &[u8]) -> Result<(), TestCaseError> {
    let p = scratch(name);
    std::fs::write(&p, bytes).unwrap();
    if let Ok(parts) = mesh_file::load_parts(&p) {
        prop_assert!(usable(&parts));
    }
    if !name.ends_with(".obj") {
        if let Ok(parts) = gltf_scene::read(&p) {
            prop_assert!(usable(&parts));
        }
    }
    for choice in [PartChoice::Auto, PartChoice::Named("teeth".into())] {
        if let Ok(points) = mesh_file::file_positions(&p, &choice) {
            prop_assert!(points.len() < 1 << 20);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn arbitrary_bytes_are_errors_not_panics(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        for name in ["a.obj", "a.glb", "a.gltf"] {
            read_all(name, &bytes)?;
            let p = scratch(name);
            prop_assert!(mesh_file::load_parts(&p).is_err() || name.ends_with(".obj"));
        }
    }

    #[test]
    fn damaged_meshes_are_errors_or_usable_parts(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        read_all("d.obj", &damaged(OBJ.as_bytes(), cut, at, flip))?;
        read_all("d.glb", &damaged(&derma_test_support::quad_glb(), cut, at, flip))?;
        read_all("d-meshopt.glb", &damaged(&meshopt_glb(), cut, at, flip))?;
    }
}

#[test]
fn the_valid_files_read() {
    let obj = scratch("valid.obj");
    std::fs::write(&obj, OBJ).unwrap();
    assert_eq!(mesh_file::load_parts(&obj).unwrap().len(), 2);
    // An OBJ's positions are its `v` lines, every object's.
    assert_eq!(
        mesh_file::file_positions(&obj, &PartChoice::Auto)
            .unwrap()
            .len(),
        6
    );
    let glb = scratch("valid.glb");
    std::fs::write(&glb, derma_test_support::quad_glb()).unwrap();
    assert_eq!(gltf_scene::read(&glb).unwrap().len(), 1);
}
