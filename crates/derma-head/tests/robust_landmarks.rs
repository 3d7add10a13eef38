//! Landmark inputs never panic: arbitrary text, a valid landmark file damaged, NaN and huge
//! coordinates, and MediaPipe point sets of any size give a landmark set or a named error.

use derma_head::{Head, Landmarks};
use derma_test_support::damaged;
use glam::Vec3;
use proptest::prelude::*;

fn valid_json() -> String {
    let m: std::collections::BTreeMap<&str, [f32; 3]> = Head::builtin()
        .landmarks
        .points
        .iter()
        .map(|(k, v)| (k.as_str(), v.to_array()))
        .collect();
    serde_json::to_string(&m).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn arbitrary_text_is_an_error_not_a_panic(text in ".{0,300}") {
        prop_assert!(Landmarks::from_json(&text, 1.0).is_err());
    }

    #[test]
    fn damaged_files_are_errors_or_landmarks(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=127) {
        let bytes = damaged(valid_json().as_bytes(), cut, at, flip);
        if let Ok(text) = String::from_utf8(bytes) {
            if let Ok(lm) = Landmarks::from_json(&text, 1.0) {
                prop_assert!(lm.check().is_ok());
            }
        }
    }

    #[test]
    fn any_point_sets_for_mediapipe(n in 0usize..600, x in -1e30f32..1e30, nan in any::<bool>()) {
        let mut pts: Vec<Vec3> = (0..n).map(|i| Vec3::new(x, i as f32, -(i as f32))).collect();
        if nan && n > 4 {
            pts[4] = Vec3::NAN;
        }
        if let Ok(lm) = Landmarks::mediapipe(&pts) {
            prop_assert!(lm.points.values().all(|p| p.is_finite()));
        }
    }

    #[test]
    fn huge_units_are_named_not_propagated(k in 1e37f32..3e38) {
        // Scaled past f32's range (coordinates of 30–110 mm times ≥ 1e37), they are refused.
        prop_assert!(Landmarks::from_json(&valid_json(), k).is_err());
    }
}
