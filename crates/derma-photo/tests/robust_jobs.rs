//! `derma photo calibrate` and `derma photo bake` never panic on bad files (Tarini et al. 2002's
//! inputs, docs/photo.md): a correspondence or landmark file of arbitrary text, and a
//! cameras.json, a mesh or a photo truncated or with a byte changed give an error or a result —
//! `files::calibrate` and `files::bake_files`.

use derma_core::image_io::write_png8;
use derma_core::progress::Silent;
use derma_core::Map;
use derma_photo::bake::{BakeOptions, BakeReport};
use derma_photo::camera::Camera;
use derma_photo::files::{self, CalibrateInputs, CameraEntry, CamerasFile, MeshSource};
use derma_photo::resection::ResectionOptions;
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-photo-jobs-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A 200 mm quad with UVs, facing the camera.
const OBJ: &str = "v -100 -100 0\nv 100 -100 0\nv 100 100 0\nv -100 100 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";

/// A photo (32 × 24 PNG) and a mesh, written once, and a cameras.json seeing the mesh through
/// the photo.
fn bake_inputs() -> &'static (PathBuf, Vec<u8>) {
    static FILES: OnceLock<(PathBuf, Vec<u8>)> = OnceLock::new();
    FILES.get_or_init(|| {
        let m = |k: usize| {
            Map::from_vec(
                32,
                24,
                (0..768)
                    .map(|i| 0.2 + ((i * k) % 29) as f32 / 50.0)
                    .collect(),
            )
            .unwrap()
        };
        write_png8(&scratch("photo.png"), &[&m(3), &m(5), &m(7)]).unwrap();
        let mesh = scratch("quad.obj");
        std::fs::write(&mesh, OBJ).unwrap();
        let cameras = CamerasFile {
            photos: vec![CameraEntry {
                image: PathBuf::from("photo.png"),
                camera: Camera {
                    width: 32,
                    height: 24,
                    rotation: [0.0, 0.0, 0.0],
                    translation: [0.0, 0.0, 600.0],
                    focal_px: 60.0,
                    principal: [16.0, 12.0],
                    k1: 0.0,
                    k2: 0.0,
                },
                rms_px: 0.5,
                outliers: Vec::new(),
                points: Vec::new(),
                focal_se_px: None,
                distance_se: 0.0,
            }],
        };
        let json = serde_json::to_vec_pretty(&cameras).unwrap();
        (mesh, json)
    })
}

/// Bakes with cameras.json (beside the photo, named after `tag`) as `cameras` and the mesh as
/// `mesh`.
fn bake(tag: &str, cameras: &[u8], mesh: &[u8]) -> derma_photo::Result<BakeReport> {
    bake_inputs();
    let path = scratch(&format!("{tag}-cameras.json"));
    std::fs::write(&path, cameras).unwrap();
    let m = scratch(&format!("{tag}-mesh.obj"));
    std::fs::write(&m, mesh).unwrap();
    let opts = BakeOptions {
        size: 16,
        ..BakeOptions::default()
    };
    files::bake_files(&m, &path, &opts, &scratch(&format!("{tag}-baked")), &Silent)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(24)))]

    #[test]
    fn arbitrary_correspondences_and_landmarks_are_errors(text in "\\PC{0,300}", csv in any::<bool>(), landmarks in any::<bool>()) {
        let p = scratch(if csv { "points.csv" } else { "points.json" });
        std::fs::write(&p, &text).unwrap();
        let lm = scratch("landmarks.json");
        std::fs::write(&lm, &text).unwrap();
        let mesh = MeshSource::Builtin;
        let inputs = CalibrateInputs {
            correspondences: &p,
            mesh: &mesh,
            landmarks: landmarks.then_some(lm.as_path()),
            mediapipe_topology: false,
            exif: false,
        };
        let out = scratch("calibrated.json");
        prop_assert!(files::calibrate(&inputs, &ResectionOptions::default(), &out, &Silent).is_err());
    }

    #[test]
    fn a_damaged_cameras_file_or_mesh_is_an_error_or_a_bake(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255, which in any::<bool>()) {
        let (_, cameras) = bake_inputs();
        let _ = if which {
            bake("damaged", &damaged(cameras, cut, at, flip), OBJ.as_bytes())
        } else {
            bake("damaged", cameras, &damaged(OBJ.as_bytes(), cut, at, flip))
        };
    }

    #[test]
    fn arbitrary_cameras_text_is_an_error(text in "\\PC{0,200}") {
        prop_assert!(bake("text", text.as_bytes(), OBJ.as_bytes()).is_err());
    }
}

#[test]
fn the_valid_inputs_bake() {
    let (_, cameras) = bake_inputs();
    bake("valid", cameras, OBJ.as_bytes()).unwrap();
}
