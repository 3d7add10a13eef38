//! The streamed main job ([`SkinGenerator::write_to`]: painted, converted and written band by
//! band) writes the files the whole set writes ([`derma_skin::TextureSet::write`]), bit for
//! bit: on the built-in head (the gutter's dilation, bands that do not divide the size, the
//! preview's reduction by 2), on a mesh derma did not make (MediaPipe's face), and on patches
//! with and without wrapping; at another thread count than the whole run's.

use derma_core::progress::Silent;
use derma_skin::config::{SkinConfig, SurfaceKind};
use derma_skin::SkinGenerator;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-streamed-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// report.json without its timings and thread count, which differ from run to run.
fn report_without_timings(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("report.json")).unwrap();
    let mut r: serde_json::Value = serde_json::from_str(&text).unwrap();
    r.as_object_mut().unwrap().remove("timings_s");
    r.as_object_mut().unwrap().remove("threads");
    r
}

/// Writes the set of `make()` whole (2 threads) and streamed (`threads`), and compares every
/// file.
fn same_files(name: &str, threads: usize, make: impl Fn() -> SkinGenerator<'static>) {
    let (whole, streamed) = (
        scratch(&format!("{name}-whole")),
        scratch(&format!("{name}-band")),
    );
    let set = make().threads(2).run().unwrap();
    let written = set.write(&whole, &Silent).unwrap();
    drop(set);
    let (summary, streamed_written) = make().threads(threads).write_to(&streamed).unwrap();
    assert_eq!(
        written.files, streamed_written.files,
        "{name}: the files written"
    );
    assert_eq!(summary.config.size, make().config().size);
    for f in &written.files {
        if *f == "report.json" {
            let (a, b) = (
                report_without_timings(&whole),
                report_without_timings(&streamed),
            );
            let differ: Vec<&String> = a
                .as_object()
                .unwrap()
                .iter()
                .filter(|(k, v)| b.get(k.as_str()) != Some(v))
                .map(|(k, _)| k)
                .collect();
            assert!(a == b, "{name}: report.json differs in {differ:?}");
            continue;
        }
        let (a, b) = (
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(streamed.join(f)).unwrap(),
        );
        assert!(
            a == b,
            "{name}: {f} differs between the whole and the streamed job"
        );
    }
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&streamed);
}

fn config(size: u32) -> SkinConfig {
    SkinConfig {
        size,
        scatter_resolution: 256,
        ..SkinConfig::default()
    }
}

#[test]
fn the_head_streamed_is_the_head_whole() {
    // 1100 rows: bands of 128 and a last one of 76; the preview reduces by 2.
    same_files("head", 1, || SkinGenerator::new(config(1100)));
}

#[test]
fn a_user_mesh_streamed_is_the_mesh_whole() {
    let Some(mesh) = derma_test_support::shared_data("canonical_face_model.obj") else {
        return;
    };
    same_files("mesh", 2, move || {
        SkinGenerator::new(config(300)).mesh(&mesh)
    });
}

#[test]
fn patches_streamed_are_patches_whole_wrapping_or_not() {
    for tileable in [true, false] {
        same_files(&format!("patch-{tileable}"), 1, move || {
            let mut cfg = config(300);
            cfg.surface.kind = SurfaceKind::Patch;
            cfg.surface.tileable = tileable;
            cfg.surface.patch_size_mm = [20.0, 14.0];
            SkinGenerator::new(cfg)
        });
    }
}
