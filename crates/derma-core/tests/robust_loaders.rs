//! Loaders never panic or hang on bad files: arbitrary bytes, and valid files truncated or with
//! a byte changed, give an error (or, for a harmless change, a valid result) — images (PNG,
//! EXR), meshes (OBJ, glTF, GLB: quantized, meshopt- and Draco-compressed, texture-transformed,
//! skinned) and `.dtab` tables.

use derma_core::dtab::{Dtab, DtabAxis, DtabHeader, DtabValue};
use derma_core::image_io::{read_grey, read_rgb, write_exr, write_png16, write_png8, ExrPrecision};
use derma_core::mesh::TriMesh;
use derma_core::Map;
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-core-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// The bytes of a small valid file written by `write` at a path ending in `name`.
fn valid(name: &str, write: impl Fn(&Path)) -> Vec<u8> {
    let p = scratch(&format!("valid-{name}"));
    write(&p);
    std::fs::read(&p).unwrap()
}

fn gradient() -> Map {
    Map::from_vec(7, 5, (0..35).map(|i| i as f32 / 34.0).collect()).unwrap()
}

/// Loads `bytes` as a file named `name` with every loader that reads that kind of file; only
/// panics count as failures.
fn load_all(name: &str, bytes: &[u8]) {
    let p = scratch(name);
    std::fs::write(&p, bytes).unwrap();
    match Path::new(name).extension().and_then(|e| e.to_str()) {
        Some("png") | Some("exr") => {
            let _ = read_rgb(&p);
            let _ = read_grey(&p);
        }
        Some("dtab") => {
            let _ = Dtab::read(&p);
        }
        _ => {
            let _ = TriMesh::load(&p);
        }
    }
}

fn table() -> Dtab {
    Dtab {
        header: DtabHeader {
            axes: vec![DtabAxis {
                name: "melanin".into(),
                values: vec![0.0, 0.5],
            }],
            values: vec![DtabValue {
                name: "rgb".into(),
                len: 3,
            }],
            meta: serde_json::json!({"what": "test"}),
        },
        data: vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
    }
}

/// The decoding fixtures of tests/gltf_as_shipped.rs.
const GLTF_FIXTURES: [&str; 6] = [
    "face_quantized.glb",
    "face_meshopt.glb",
    "face_meshopt_oct.glb",
    "face_meshopt_exp.glb",
    "face_draco.glb",
    "rig_meshopt.glb",
];

fn gltf_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/gltf")
        .join(name)
}

const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn arbitrary_bytes_are_errors_not_panics(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        for name in ["a.png", "a.exr", "a.obj", "a.glb", "a.gltf", "a.dtab"] {
            load_all(name, &bytes);
        }
        prop_assert!(Dtab::from_bytes(&bytes, Path::new("x.dtab")).is_err());
    }

    #[test]
    fn damaged_images_are_errors_not_panics(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let png8 = valid("g8.png", |p| write_png8(p, &[&gradient()]).unwrap());
        let png16 = valid("g16.png", |p| write_png16(p, &[&gradient()]).unwrap());
        let exr = valid("g.exr", |p| write_exr(p, &[("Y", &gradient())], ExrPrecision::F16).unwrap());
        load_all("d8.png", &damaged(&png8, cut, at, flip));
        load_all("d16.png", &damaged(&png16, cut, at, flip));
        load_all("d.exr", &damaged(&exr, cut, at, flip));
    }

    #[test]
    fn damaged_meshes_and_tables_are_errors_not_panics(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        load_all("d.obj", &damaged(OBJ.as_bytes(), cut, at, flip));
        load_all("d.glb", &damaged(&derma_test_support::quad_glb(), cut, at, flip));
        // glTF as shipped: quantized, meshopt-compressed (with filters), Draco-compressed, under
        // texture transforms, skinned and morphing (tests/gltf_as_shipped.rs).
        for f in GLTF_FIXTURES {
            let bytes = std::fs::read(gltf_fixture(f)).unwrap();
            let name = format!("d-{f}");
            load_all(&name, &damaged(&bytes, cut, at, flip));
        }
        let t = table().to_bytes();
        let d = damaged(&t, cut, at, flip);
        // Any change to a table is caught: by the checksum, or by the length check.
        prop_assert!(Dtab::from_bytes(&d, Path::new("d.dtab")).is_err());
    }

    #[test]
    fn obj_text_of_arbitrary_lines_is_an_error_or_a_valid_mesh(lines in proptest::collection::vec("(v|vt|vn|f) [-0-9./ e]{0,24}", 0..12)) {
        let text = lines.join("\n");
        let p = scratch("lines.obj");
        std::fs::write(&p, &text).unwrap();
        if let Ok(m) = TriMesh::load(&p) {
            // Whatever loads is usable: every triangle indexes existing vertices with UVs.
            let n = m.positions.len() as u32;
            prop_assert!(m.triangles.iter().all(|t| t.iter().all(|&i| i < n)));
            prop_assert_eq!(m.uvs.len(), m.positions.len());
        }
    }
}

#[test]
fn a_png_claiming_a_huge_size_is_refused_without_allocating_it() {
    // A valid 1×1 PNG header rewritten to claim 60000 × 60000 pixels (14 GB as RGB f32).
    let mut b = valid("one.png", |p| {
        write_png8(p, &[&Map::filled(1, 1, 0.5)]).unwrap()
    });
    b[16..20].copy_from_slice(&60000u32.to_be_bytes());
    b[20..24].copy_from_slice(&60000u32.to_be_bytes());
    // The IHDR chunk's CRC (PNG uses the same CRC-32 as .dtab) over its type and data.
    let crc = derma_core::dtab::crc32(&b[12..29]);
    b[29..33].copy_from_slice(&crc.to_be_bytes());
    let p = scratch("huge.png");
    std::fs::write(&p, &b).unwrap();
    assert!(read_rgb(&p).is_err());
}

#[test]
fn an_exr_whose_data_window_claims_gigabytes_is_refused_before_reading() {
    // dataWindow is a box2i: "dataWindow\0box2i\0", its size (16), then xMin yMin xMax yMax.
    let mut b = valid("w.exr", |p| {
        write_exr(p, &[("Y", &gradient())], ExrPrecision::F32).unwrap()
    });
    let key = b"dataWindow\0box2i\0";
    let at = b.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
    b[at + 8..at + 12].copy_from_slice(&40_000i32.to_le_bytes());
    b[at + 12..at + 16].copy_from_slice(&40_000i32.to_le_bytes());
    let p = scratch("window.exr");
    std::fs::write(&p, &b).unwrap();
    let e = read_rgb(&p).err().expect("refused").to_string();
    assert!(e.contains("window.exr") && e.contains("damaged"), "{e}");
}
