//! Synthesis' readers never panic on bad files (Shen et al.'s inputs: exemplars and a region
//! guide): a damaged exemplar PNG, a damaged guide and arbitrary bytes under an image's name all
//! give an error (or images of a consistent size).

use derma_core::image_io::write_png8;
use derma_core::Map;
use derma_synth::files::{load_channels, load_exemplars};
use derma_synth::Guide;
use derma_test_support::{damaged, scratch_dir};
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::OnceLock;

/// A 12 × 10 grey exemplar, written once.
fn exemplar() -> &'static PathBuf {
    static FILE: OnceLock<PathBuf> = OnceLock::new();
    FILE.get_or_init(|| {
        let p = scratch_dir("robust-synth").join("ex.png");
        let m = Map::from_vec(
            12,
            10,
            (0..120).map(|i| (i * 37 % 101) as f32 / 100.0).collect(),
        )
        .unwrap();
        write_png8(&p, &[&m]).unwrap();
        p
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn damaged_exemplars_and_guides_are_errors_or_images(
        cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255, count in 0usize..4,
    ) {
        let d = scratch_dir("robust-synth-damaged");
        let p = d.join("bad.png");
        std::fs::write(&p, damaged(&std::fs::read(exemplar()).unwrap(), cut, at, flip)).unwrap();
        if let Ok(ch) = load_channels(&p) {
            prop_assert!(!ch.is_empty());
            prop_assert!(ch.iter().all(|m| m.data().len() == m.width() * m.height()));
        }
        let _ = load_exemplars(std::slice::from_ref(&p), &[]);
        if let Ok(g) = Guide::read(&p, count) {
            prop_assert!(count >= 2);
            prop_assert!(g.exemplar.iter().all(|&e| (e as usize) < count));
        }
    }

    #[test]
    fn arbitrary_bytes_are_not_an_exemplar(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let d = scratch_dir("robust-synth-bytes");
        let p = d.join("x.png");
        std::fs::write(&p, &bytes).unwrap();
        let _ = load_channels(&p);
        let _ = load_exemplars(std::slice::from_ref(&p), &[vec![("height".into(), p.clone())]]);
    }
}
