//! The renderer's texture readers never panic on bad files (docs/render.md's inputs): a hair
//! coverage map or an iris or teeth albedo (PNG or EXR) truncated, with a byte changed, or of
//! arbitrary bytes gives an error or maps of one size — `material::read_hair_coverage` and
//! `material::read_albedo`.

use derma_core::image_io::{write_exr, write_png8, ExrPrecision};
use derma_core::Map;
use derma_render::material::{read_albedo, read_hair_coverage};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::PathBuf;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-textures-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn gradient() -> Map {
    Map::from_vec(7, 5, (0..35).map(|i| i as f32 / 34.0).collect()).unwrap()
}

/// The bytes of valid texture files: grey and RGB PNG, RGB EXR.
fn valid() -> [(&'static str, Vec<u8>); 3] {
    let g = gradient();
    let write = |name: &str, f: &dyn Fn(&std::path::Path)| {
        let p = scratch(&format!("valid-{name}"));
        f(&p);
        std::fs::read(&p).unwrap()
    };
    [
        (
            "grey.png",
            write("grey.png", &|p| write_png8(p, &[&g]).unwrap()),
        ),
        (
            "rgb.png",
            write("rgb.png", &|p| write_png8(p, &[&g, &g, &g]).unwrap()),
        ),
        (
            "rgb.exr",
            write("rgb.exr", &|p| {
                write_exr(p, &[("R", &g), ("G", &g), ("B", &g)], ExrPrecision::F16).unwrap()
            }),
        ),
    ]
}

/// Reads `bytes` as texture `name` with both readers; only panics and ragged maps fail.
fn read_both(name: &str, bytes: &[u8]) -> Result<(), TestCaseError> {
    let p = scratch(name);
    std::fs::write(&p, bytes).unwrap();
    if let Ok(m) = read_hair_coverage(&p) {
        prop_assert_eq!(m.data().len(), m.width() * m.height());
    }
    if let Ok(t) = read_albedo(&p) {
        let size = (t.rgb[0].width(), t.rgb[0].height());
        prop_assert!(t.rgb.iter().all(|m| (m.width(), m.height()) == size));
        prop_assert!(t.alpha.iter().all(|m| (m.width(), m.height()) == size));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn damaged_textures_are_errors_or_maps(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        for (name, bytes) in valid() {
            read_both(&format!("d-{name}"), &damaged(&bytes, cut, at, flip))?;
        }
    }

    #[test]
    fn arbitrary_bytes_are_not_a_texture(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        for name in ["a.png", "a.exr", "a.jpg"] {
            read_both(name, &bytes)?;
            let p = scratch(name);
            prop_assert!(read_hair_coverage(&p).is_err() && read_albedo(&p).is_err());
        }
    }
}

#[test]
fn the_valid_textures_read() {
    for (name, bytes) in valid() {
        let p = scratch(&format!("ok-{name}"));
        std::fs::write(&p, bytes).unwrap();
        assert_eq!(read_hair_coverage(&p).unwrap().width(), 7);
        assert_eq!(read_albedo(&p).unwrap().rgb[0].height(), 5);
    }
}
