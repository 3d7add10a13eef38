//! The rig's readers never panic on bad files: a saved rig directory with rig.json or a map
//! truncated or altered, arbitrary rig.json text, keyframe curves (CSV and JSON) and weight and
//! global-scale strings of arbitrary text all give an error (or a valid result).

use derma_core::Map;
use derma_rig::animation::Curves;
use derma_rig::{rig_dir, BasisOptions, GlobalScale, Rig, TargetSource, TargetSpec, WeightSpec};
use derma_shading::skin_color_lut::SkinColorLut;
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-rig-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A small valid rig directory (32² maps, one target), saved once.
fn saved_rig() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let map = |f: fn(usize) -> f32| Map::from_vec(32, 32, (0..1024).map(f).collect()).unwrap();
        let neutral = map(|i| 0.012 + 0.004 * ((i * 37 % 17) as f32 / 17.0));
        let target = map(|i| 0.02 + 0.006 * ((i * 53 % 13) as f32 / 13.0));
        let spec = TargetSpec {
            name: "flush".into(),
            source: TargetSource::Map(&target),
            global_scale: None,
        };
        let opts = BasisOptions {
            radius: 4.0,
            basis_size: (8, 8),
            ..BasisOptions::new(4.0)
        };
        let rig = Rig::build(&neutral, None, Some(neutral.clone()), &[spec], &opts).unwrap();
        let dir = scratch("rig");
        rig_dir::save(&rig, &SkinColorLut::builtin(), &dir).unwrap();
        dir
    })
}

/// A copy of the saved rig (in a directory of its own per `tag`) with file `name` replaced by
/// `bytes`.
fn damaged_rig(tag: &str, name: &str, bytes: &[u8]) -> PathBuf {
    let src = saved_rig();
    let dst = scratch(&format!("{tag}-{}", name.replace('/', "-")));
    let _ = std::fs::remove_dir_all(&dst);
    std::fs::create_dir_all(dst.join("targets")).unwrap();
    for e in derma_test_support::files_under(src) {
        let rel = e.strip_prefix(src).unwrap();
        std::fs::copy(&e, dst.join(rel)).unwrap();
    }
    std::fs::write(dst.join(name), bytes).unwrap();
    dst
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(32)))]

    #[test]
    fn damaged_rig_files_are_errors_or_a_valid_rig(
        file in prop_oneof![Just("rig.json"), Just("h0.exr"), Just("neutral.exr"), Just("targets/flush.exr"), Just("skin_color_lut.dtab")],
        cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let original = std::fs::read(saved_rig().join(file)).unwrap();
        let dir = damaged_rig("damaged", file, &damaged(&original, cut, at, flip));
        if let Ok((rig, _, _)) = rig_dir::load(&dir) {
            // Whatever loads evaluates.
            let w = vec![0.5, 0.5];
            prop_assert!(derma_rig::evaluate::hemoglobin(&rig, &w, 1.0).is_ok());
        }
    }

    #[test]
    fn arbitrary_rig_json_is_an_error(text in "\\PC{0,300}") {
        let dir = damaged_rig("arbitrary", "rig.json", text.as_bytes());
        prop_assert!(rig_dir::load(&dir).is_err());
    }

    #[test]
    fn curves_weights_and_scales_of_arbitrary_text_are_not_panics(text in "[0-9a-z,.=\\n\\[\\]{}\": -]{0,120}") {
        for name in ["c.csv", "c.json"] {
            let p = scratch(&format!("curves-{name}"));
            std::fs::write(&p, &text).unwrap();
            if let Ok(c) = Curves::read(&p) {
                // Whatever parses samples at any time without panicking.
                if c.frame_count(24.0) < 10_000 {
                    let _ = c.frame_times(24.0);
                }
                let _ = c.weights_at(0.5);
            }
        }
        let _ = text.parse::<WeightSpec>();
        let _ = text.parse::<GlobalScale>();
    }
}

#[test]
fn curves_spanning_years_are_refused_before_frames_are_made() {
    let curves = scratch("years.csv");
    std::fs::write(&curves, "time,flush\n0,0\n1e9,1\n").unwrap();
    let out = scratch("years-out");
    let opts = derma_rig::sequence::SequenceOptions::default();
    let e = derma_rig::sequence::render_sequence(
        saved_rig(),
        &curves,
        &opts,
        &out,
        &derma_core::progress::Silent,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("years.csv") && e.contains("frames"), "{e}");
}
