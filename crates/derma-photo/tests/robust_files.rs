//! The photo crate's readers never panic on bad input (Tarini et al. 2002's inputs: clicked
//! points, cameras, photos): arbitrary text as a correspondence file (JSON or CSV) or a cameras
//! file, arbitrary bytes as EXIF, and damaged photos all give an error (or a valid result).

use derma_photo::correspondences::{self, Surface};
use derma_photo::photo::RgbImage;
use derma_test_support::{damaged, scratch_dir};
use proptest::prelude::*;
use std::path::Path;

fn size(_: &Path) -> derma_photo::Result<(u32, u32)> {
    Ok((640, 480))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn arbitrary_correspondence_text_is_an_error_or_points_on_the_head(
        text in "\\PC{0,300}", csv in any::<bool>(),
    ) {
        let head = derma_head::Head::builtin();
        let surface = Surface { mesh: &head.skin, landmarks: Some(&head.landmarks), mediapipe_topology: false };
        let d = scratch_dir("robust-photo-text");
        let p = d.join(if csv { "c.csv" } else { "c.json" });
        std::fs::write(&p, &text).unwrap();
        if let Ok(entries) = correspondences::read(&p, &surface, &size) {
            prop_assert!(!entries.is_empty());
        }
        let _ = derma_photo::files::read_cameras(&p);
    }

    #[test]
    fn csv_rows_with_any_numbers_are_errors_or_finite_points(
        rows in proptest::collection::vec(
            (prop_oneof![Just("nose_tip".to_string()), Just("v:12".to_string()), Just("w:1;2;3".to_string()), "[a-z_:0-9;]{1,12}"],
             prop_oneof![Just(f64::NAN), Just(f64::INFINITY), -1e4f64..1e4],
             -1e4f64..1e4),
            1..8),
    ) {
        let head = derma_head::Head::builtin();
        let surface = Surface { mesh: &head.skin, landmarks: Some(&head.landmarks), mediapipe_topology: false };
        let mut text = String::from("image,point,x,y\n");
        for (label, x, y) in &rows {
            text.push_str(&format!("a.png,{label},{x},{y}\n"));
        }
        let d = scratch_dir("robust-photo-csv");
        let p = d.join("c.csv");
        std::fs::write(&p, &text).unwrap();
        if let Ok(entries) = correspondences::read(&p, &surface, &size) {
            for e in &entries {
                for pt in &e.points.points {
                    prop_assert!(pt.pixel.is_finite() && pt.world.is_finite(), "a non-finite point was accepted");
                }
            }
        }
    }

    #[test]
    fn arbitrary_exif_bytes_give_no_focal_or_a_positive_one(
        bytes in proptest::collection::vec(any::<u8>(), 0..600), w in 1u32..8000, h in 1u32..8000,
    ) {
        if let Some(f) = correspondences::exif_focal_px(&bytes, w, h) {
            prop_assert!(f.is_finite() && f > 0.0);
        }
    }

    #[test]
    fn damaged_photos_are_errors_or_images(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let d = scratch_dir("robust-photo-image");
        let good = d.join("good.png");
        let img = RgbImage { width: 9, height: 7, data: (0..63).map(|i| [i as f32 / 63.0, 0.5, 0.25]).collect() };
        img.write_linear(&good).unwrap();
        let p = d.join("bad.png");
        std::fs::write(&p, damaged(&std::fs::read(&good).unwrap(), cut, at, flip)).unwrap();
        if let Ok(back) = RgbImage::read_linear(&p) {
            prop_assert_eq!(back.data.len(), back.width * back.height);
        }
    }
}
