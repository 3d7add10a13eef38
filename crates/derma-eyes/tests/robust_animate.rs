//! `derma eyes animate`'s job never panics on bad files (the EyeMove thesis' drivers, docs/eyes.md):
//! a trained model truncated, with a byte changed or of arbitrary bytes, a gaze-tracker CSV of
//! any rows and a look-at image or an iris texture damaged give an error or an animation —
//! `files::animate`.

use derma_core::image_io::write_png8;
use derma_core::progress::Silent;
use derma_core::Map;
use derma_eyes::animate::Drive;
use derma_eyes::files::{self, AnimateOptions, Targets};
use derma_eyes::model::{Components, EyeModel};
use derma_eyes::rigdata::Rig;
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-animate-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A model trained on the built-in head's rig, written once.
fn model() -> &'static Path {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| {
        let rig = Rig::new(derma_head::Head::builtin()).unwrap();
        let m = EyeModel::fit(&rig.samples(300, 1), Components::default()).unwrap();
        let p = scratch("model.json");
        m.write(&p).unwrap();
        p
    })
}

/// A small RGB image (PNG) to look at or to use as an iris, written once.
fn image() -> &'static [u8] {
    static B: OnceLock<Vec<u8>> = OnceLock::new();
    B.get_or_init(|| {
        let m = |k: usize| {
            Map::from_vec(
                16,
                12,
                (0..192).map(|i| ((i * k) % 31) as f32 / 31.0).collect(),
            )
            .unwrap()
        };
        let p = scratch("image.png");
        write_png8(&p, &[&m(3), &m(5), &m(7)]).unwrap();
        std::fs::read(p).unwrap()
    })
}

/// A short clip with `model`, `targets` and `iris`, no renders.
fn options(model: &Path, targets: Targets, iris: Option<PathBuf>) -> AnimateOptions {
    AnimateOptions {
        model: Some(model.to_path_buf()),
        drive: Drive {
            seconds: 0.5,
            fps: 10.0,
            ..Drive::default()
        },
        targets,
        render: 0,
        thickness: 1.0,
        iris,
        head: None,
        mesh: None,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(6)))]

    #[test]
    fn a_damaged_or_arbitrary_model_is_an_error_or_an_animation(
        arbitrary in proptest::collection::vec(any::<u8>(), 0..200),
        use_arbitrary in any::<bool>(), cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let bytes = if use_arbitrary {
            arbitrary
        } else {
            damaged(&std::fs::read(model()).unwrap(), cut, at, flip)
        };
        let p = scratch("bad-model.json");
        std::fs::write(&p, &bytes).unwrap();
        let out = scratch("out-model");
        let r = files::animate(&options(&p, Targets::Idle, None), &out, &Silent);
        prop_assert!(r.is_err() || !use_arbitrary);
    }

    #[test]
    fn tracker_rows_of_any_text_are_an_error_or_an_animation(text in "[0-9a-z,.\\n -]{0,160}") {
        let csv = scratch("tracker.csv");
        std::fs::write(&csv, format!("time,h,v\n{text}")).unwrap();
        let out = scratch("out-tracker");
        if let Ok(r) = files::animate(&options(model(), Targets::Tracker(csv), None), &out, &Silent) {
            prop_assert!(r.frames > 0);
        }
    }

    #[test]
    fn damaged_images_and_irises_are_errors_or_an_animation(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255, iris in any::<bool>()) {
        let p = scratch(if iris { "iris.png" } else { "look.png" });
        std::fs::write(&p, damaged(image(), cut, at, flip)).unwrap();
        let o = if iris {
            options(model(), Targets::Idle, Some(p))
        } else {
            options(model(), Targets::Image(p, 40.0), None)
        };
        let _ = files::animate(&o, &scratch("out-image"), &Silent);
    }
}

#[test]
fn the_valid_inputs_animate() {
    let look = scratch("valid-look.png");
    std::fs::write(&look, image()).unwrap();
    let o = options(model(), Targets::Image(look.clone(), 40.0), Some(look));
    let r = files::animate(&o, &scratch("out-valid"), &Silent).unwrap();
    assert!(r.frames > 0);
}
