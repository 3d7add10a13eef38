//! The skin's file readers never panic on bad files (docs/skin.md's inputs and outputs): a config
//! file truncated, with a byte changed or of arbitrary text, a set's manifest.json of arbitrary
//! bytes, and detail exemplars damaged give an error or a valid result —
//! `SkinGenerator::from_config_file`, `manifest::read` (and `manifest::check` on it) and
//! `detail::build`.

use derma_core::gpu::Device;
use derma_core::image_io::write_png8;
use derma_core::progress::Silent;
use derma_core::Map;
use derma_skin::config::DetailConfig;
use derma_skin::{detail, manifest, SkinConfig, SkinGenerator};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-skin-files-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// The default config as TOML: a valid config file to damage.
fn config_text() -> &'static str {
    static TEXT: OnceLock<String> = OnceLock::new();
    TEXT.get_or_init(|| toml::to_string(&SkinConfig::default()).unwrap())
}

/// A 24² exemplar (PNG), written once.
fn exemplar() -> &'static Path {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| {
        let m = |k: usize| {
            Map::from_vec(
                24,
                24,
                (0..576).map(|i| ((i * k) % 23) as f32 / 23.0).collect(),
            )
            .unwrap()
        };
        let p = scratch("exemplar.png");
        write_png8(&p, &[&m(7), &m(11), &m(13)]).unwrap();
        p
    })
}

/// A detail tile small enough to synthesise in every case.
fn small_tile() -> DetailConfig {
    DetailConfig {
        tile_size: 16,
        patch: 8,
        highpass_texels: 2,
        ..DetailConfig::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(32)))]

    #[test]
    fn a_damaged_config_file_is_an_error_or_a_generator(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let p = scratch("damaged.toml");
        std::fs::write(&p, damaged(config_text().as_bytes(), cut, at, flip)).unwrap();
        if let Ok(g) = SkinGenerator::from_config_file(&p) {
            prop_assert!(g.config().size > 0);
        }
    }

    #[test]
    fn arbitrary_config_and_manifest_text_are_errors(text in "\\PC{0,200}") {
        let p = scratch("arbitrary.toml");
        std::fs::write(&p, &text).unwrap();
        let _ = SkinGenerator::from_config_file(&p);
        let dir = scratch("arbitrary-set");
        std::fs::create_dir_all(&dir).unwrap();
        let m = dir.join("manifest.json");
        std::fs::write(&m, &text).unwrap();
        if manifest::read(&m).is_ok() {
            // JSON, but no set's manifest: check names what is wrong.
            let _ = manifest::check(&dir);
        } else {
            prop_assert!(manifest::check(&dir).is_err());
        }
    }

    #[test]
    fn arbitrary_manifest_bytes_are_errors(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let p = scratch("bytes-manifest.json");
        std::fs::write(&p, &bytes).unwrap();
        let json = serde_json::from_slice::<serde_json::Value>(&bytes).is_ok();
        prop_assert_eq!(manifest::read(&p).is_ok(), json);
    }

    #[test]
    fn damaged_exemplars_are_errors_or_a_tile(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255, colour in any::<bool>()) {
        let p = scratch("damaged-exemplar.png");
        std::fs::write(&p, damaged(&std::fs::read(exemplar()).unwrap(), cut, at, flip)).unwrap();
        let (height, albedo) = if colour { (None, Some(p.as_path())) } else { (Some(p.as_path()), None) };
        if let Ok(tile) = detail::build(&small_tile(), height, albedo, 7, Device::Cpu, &Silent) {
            let map = tile.height.or(tile.contrast).expect("one exemplar, one map");
            prop_assert!(map.data().iter().all(|v| v.is_finite()));
        }
    }
}

#[test]
fn the_valid_files_read() {
    let p = scratch("valid.toml");
    std::fs::write(&p, config_text()).unwrap();
    assert!(SkinGenerator::from_config_file(&p).is_ok());
    let tile = detail::build(
        &small_tile(),
        Some(exemplar()),
        Some(exemplar()),
        7,
        Device::Cpu,
        &Silent,
    )
    .unwrap();
    assert!(tile.height.is_some() && tile.contrast.is_some());
}
