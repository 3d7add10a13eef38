//! The rig's readers of a texture set and its inputs never panic on bad files (Jimenez et al.
//! 2010's maps, docs/rig.md): a set's base colour, chromophore and bio maps or report.json
//! truncated or with a byte changed, a map file damaged, a skin-colour LUT damaged and JSON
//! keyframes of any values give an error or a valid result — `skin_response::appearance_of_set`,
//! `SkinResponse::of_set`, `maps::read_map`, `from_files::load_lut` and `Curves::from_json`.

use derma_core::image_io::{write_exr, write_png8, write_png8_srgb, ExrPrecision};
use derma_core::progress::Silent;
use derma_core::Map;
use derma_optics::bio::names;
use derma_rig::animation::Curves;
use derma_rig::from_files::load_lut;
use derma_rig::maps::{read_map, Quantity};
use derma_rig::skin_response::{appearance_of_set, SkinResponse};
use derma_shading::skin_color_lut::{LutOptions, SkinColorLut};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-rig-sets-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// An 8² map of values between `lo` and `hi`.
fn map(lo: f32, hi: f32) -> Map {
    Map::from_vec(
        8,
        8,
        (0..64)
            .map(|i| lo + (hi - lo) * ((i * 37 % 17) as f32 / 17.0))
            .collect(),
    )
    .unwrap()
}

/// The files of a small texture set (8² maps) the rig reads, written once.
const SET_FILES: [&str; 5] = [
    "base_color.png",
    "melanin.exr",
    "hemoglobin.exr",
    "bio.exr",
    "report.json",
];

fn saved_set() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = scratch("set");
        std::fs::create_dir_all(&dir).unwrap();
        let p = |f: &str| dir.join(f);
        write_png8_srgb(
            &p("base_color.png"),
            &[&map(0.4, 0.7), &map(0.3, 0.5), &map(0.2, 0.4)],
        )
        .unwrap();
        let (mel, pheo) = (map(0.02, 0.2), map(0.0, 0.05));
        write_exr(
            &p("melanin.exr"),
            &[(names::MELANIN, &mel), (names::PHEOMELANIN, &pheo)],
            ExrPrecision::F32,
        )
        .unwrap();
        let (blood, oxy) = (map(0.005, 0.05), map(0.6, 0.9));
        write_exr(
            &p("hemoglobin.exr"),
            &[(names::HEMOGLOBIN, &blood), (names::OXYGENATION, &oxy)],
            ExrPrecision::F32,
        )
        .unwrap();
        let (sc, epi, zero) = (map(10.0, 20.0), map(60.0, 100.0), map(0.0, 0.0));
        write_exr(
            &p("bio.exr"),
            &[
                (names::STRATUM_CORNEUM_UM, &sc),
                (names::EPIDERMIS_UM, &epi),
                ("extra.R", &zero),
                ("extra.G", &zero),
                ("extra.B", &zero),
                ("extra.A", &zero),
            ],
            ExrPrecision::F32,
        )
        .unwrap();
        std::fs::write(p("report.json"), r#"{"appearance": "match-table"}"#).unwrap();
        dir
    })
}

/// A copy of the saved set (a directory of its own per `tag`) with file `name` as `bytes`.
fn damaged_set(tag: &str, name: &str, bytes: &[u8]) -> PathBuf {
    let dst = scratch(&format!("{tag}-{name}"));
    std::fs::create_dir_all(&dst).unwrap();
    for f in SET_FILES {
        std::fs::copy(saved_set().join(f), dst.join(f)).unwrap();
    }
    std::fs::write(dst.join(name), bytes).unwrap();
    dst
}

/// Reads the set in `dir` as the rig does; only panics fail.
fn read_set(dir: &Path) {
    if let Ok(appearance) = appearance_of_set(dir, None) {
        if let Ok(r) = SkinResponse::of_set(dir, appearance.as_ref()) {
            let _ = r;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(32)))]

    #[test]
    fn damaged_set_files_are_errors_or_a_response(
        file in prop_oneof![Just("base_color.png"), Just("melanin.exr"), Just("hemoglobin.exr"), Just("bio.exr"), Just("report.json")],
        cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let original = std::fs::read(saved_set().join(file)).unwrap();
        read_set(&damaged_set("damaged", file, &damaged(&original, cut, at, flip)));
    }

    #[test]
    fn an_arbitrary_report_is_an_error(text in "\\PC{0,200}") {
        let dir = damaged_set("report", "report.json", text.as_bytes());
        prop_assert!(appearance_of_set(&dir, None).is_err());
        // A table named for a set that is not a table's is refused, whatever the report says.
        let table = dir.join("base_color.png");
        if let Ok(a) = appearance_of_set(&dir, Some(&table)) {
            let _ = SkinResponse::of_set(&dir, a.as_ref());
        }
    }

    #[test]
    fn damaged_maps_are_errors_or_maps(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let lut = LutOptions::default();
        for (name, q) in [("melanin.exr", Quantity::Melanin), ("hemoglobin.exr", Quantity::Hemoglobin), ("base_color.png", Quantity::Mask)] {
            let original = std::fs::read(saved_set().join(name)).unwrap();
            let p = scratch(&format!("map-{name}"));
            std::fs::write(&p, damaged(&original, cut, at, flip)).unwrap();
            if let Ok(m) = read_map(&p, q, &lut, &Silent) {
                prop_assert!(m.width() * m.height() == m.data().len());
            }
        }
        let grey = scratch("grey.png");
        write_png8(&grey, &[&map(0.0, 1.0)]).unwrap();
        let bytes = std::fs::read(&grey).unwrap();
        std::fs::write(&grey, damaged(&bytes, cut, at, flip)).unwrap();
        let _ = read_map(&grey, Quantity::Hemoglobin, &lut, &Silent);
    }

    #[test]
    fn a_damaged_lut_is_an_error(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let valid = scratch("lut.dtab");
        if !valid.exists() {
            SkinColorLut::builtin().write(&valid).unwrap();
        }
        let p = scratch("damaged-lut.dtab");
        std::fs::write(&p, damaged(&std::fs::read(&valid).unwrap(), cut, at, flip)).unwrap();
        prop_assert!(load_lut(Some(&p)).is_err());
    }

    #[test]
    fn json_keyframes_of_any_values_are_errors_or_curves(
        fps in prop_oneof![Just(None), any::<f64>().prop_map(Some)],
        keys in proptest::collection::vec((any::<f64>(), any::<f32>()), 0..6),
        name in "[a-zA-Z]{0,8}",
    ) {
        let text = serde_json::json!({ "fps": fps, "curves": { name: keys } }).to_string();
        if let Ok(c) = Curves::from_json(&text, Path::new("c.json")) {
            if c.frame_count(24.0) < 10_000 {
                let _ = c.frame_times(24.0);
            }
            let _ = c.weights_at(0.5);
        }
    }
}

#[test]
fn the_saved_set_and_lut_read() {
    let a = appearance_of_set(saved_set(), None).unwrap();
    // A hand-made set: its base colour is not the appearance's, so its response is refused.
    let _ = SkinResponse::of_set(saved_set(), a.as_ref());
    let p = scratch("valid-lut.dtab");
    SkinColorLut::builtin().write(&p).unwrap();
    assert!(load_lut(Some(&p)).is_ok());
    let map = read_map(
        &saved_set().join("melanin.exr"),
        Quantity::Melanin,
        &LutOptions::default(),
        &Silent,
    )
    .unwrap();
    assert_eq!((map.width(), map.height()), (8, 8));
}
