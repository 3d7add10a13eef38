//! The eye crate's readers never panic on bad files: tracked data (JSON and CSV, thesis §3.4's
//! training data) written by derma then truncated or altered, arbitrary text as tracked data, as
//! a gaze-tracker CSV and as a trained model all give an error (or a valid result).

use derma_eyes::gaze::Fick;
use derma_eyes::model::EyeModel;
use derma_eyes::tracked::{Frame, Tracked, FORMAT};
use derma_test_support::{damaged, scratch_dir};
use glam::Vec2;
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::OnceLock;

/// A small valid tracked sequence: twelve frames, four lid points, five vertices.
fn tracked() -> Tracked {
    let frame = |k: usize| Frame {
        gaze: [
            Fick {
                h: k as f32,
                v: -1.0,
                ..Fick::default()
            },
            Fick {
                h: k as f32 - 0.5,
                v: -1.0,
                ..Fick::default()
            },
        ],
        lids: (0..16)
            .map(|i| Vec2::new(i as f32 * 0.7, (i % 4) as f32 + 0.1 * k as f32))
            .collect(),
        units: vec![0.1 * k as f32],
        vertices: (0..5)
            .map(|i| Vec2::new(i as f32, 2.0 - 0.05 * k as f32))
            .collect(),
        baseline: k != 1,
    };
    Tracked {
        format: FORMAT.into(),
        fps: 30.0,
        units: vec!["eyeBlinkLeft".into()],
        lid_points: 4,
        frames: (0..12).map(frame).collect(),
    }
}

/// The sequence written once as JSON and as CSV.
fn written() -> &'static (PathBuf, PathBuf) {
    static FILES: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    FILES.get_or_init(|| {
        let d = scratch_dir("robust-eyes");
        let (j, c) = (d.join("t.json"), d.join("t.csv"));
        tracked().write(&j).unwrap();
        tracked().write(&c).unwrap();
        (j, c)
    })
}

#[test]
fn the_written_files_read_back() {
    let (j, c) = written();
    assert_eq!(Tracked::read(j).unwrap(), tracked());
    let back = Tracked::read(c).unwrap();
    assert_eq!(back.frames.len(), 12);
    assert_eq!(back.lid_points, 4);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn damaged_tracked_files_are_errors_or_valid(
        csv in any::<bool>(), cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let (j, c) = written();
        let src = if csv { c } else { j };
        let bytes = damaged(&std::fs::read(src).unwrap(), cut, at, flip);
        let d = scratch_dir("robust-eyes-damaged");
        let p = d.join(if csv { "t.csv" } else { "t.json" });
        std::fs::write(&p, bytes).unwrap();
        if let Ok(t) = Tracked::read(&p) {
            // What reads is consistent: every frame has its lids and vertices.
            for f in &t.frames {
                prop_assert_eq!(f.lids.len(), 4 * t.lid_points);
                prop_assert_eq!(f.vertices.len(), t.frames[0].vertices.len());
            }
        }
    }

    #[test]
    fn arbitrary_text_is_never_a_panic(text in "\\PC{0,400}", ext in prop_oneof![Just("json"), Just("csv")]) {
        let d = scratch_dir("robust-eyes-text");
        let p = d.join(format!("x.{ext}"));
        std::fs::write(&p, &text).unwrap();
        let _ = Tracked::read(&p);
        let _ = derma_eyes::animate::read_tracker(&p);
        let _ = EyeModel::read(&p);
    }

    #[test]
    fn tracker_csv_rows_of_numbers_are_errors_or_fixations(
        rows in proptest::collection::vec((-1e3f64..1e3, -90f64..90.0, -90f64..90.0), 0..20),
        nan_at in proptest::option::of(0usize..20),
    ) {
        let mut text = String::from("time,h,v\n");
        for (i, (t, h, v)) in rows.iter().enumerate() {
            let h = if nan_at == Some(i) { f64::NAN } else { *h };
            text.push_str(&format!("{t},{h},{v}\n"));
        }
        let d = scratch_dir("robust-eyes-tracker");
        let p = d.join("gaze.csv");
        std::fs::write(&p, &text).unwrap();
        if let Ok(fix) = derma_eyes::animate::read_tracker(&p) {
            prop_assert!(nan_at.is_none_or(|i| i >= rows.len()), "a NaN angle was accepted");
            prop_assert!(fix.len() <= rows.len());
        }
    }
}
