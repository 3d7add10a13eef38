//! derma-batch's readers of its own files never panic (docs/batch.md): a batch directory's spec
//! or an identity's record truncated, with a byte changed or of arbitrary text, gives an error or
//! a complete batch — `BatchSpec::read`, `layout::prepare`, `merge::merge`; any text as a spec
//! gives an error or a spec whose every identity can be drawn (`BatchSpec::parse`).

use derma_batch::{layout, merge, BatchSpec, IDENTITY_FILE, SPEC_FILE};
use derma_core::progress::Silent;
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-batch-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

const SPEC: &str = "count = 3\nsize = 64\nmale = 0.5\nage_years = [20.0, 60.0]\n";

/// A complete batch directory of three identities (their records, no sets), written once.
fn batch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let out = scratch("batch");
        let spec = BatchSpec::parse(SPEC, "spec.toml").unwrap();
        layout::prepare(&out, &spec).unwrap();
        for i in 0..spec.count {
            let id = spec.identity(i);
            std::fs::create_dir_all(out.join(&id.dir)).unwrap();
            let record = serde_json::to_string(&id).unwrap();
            std::fs::write(out.join(&id.dir).join(IDENTITY_FILE), record).unwrap();
        }
        out
    })
}

/// A copy of the batch directory (one of its own per `tag`) with file `rel` as `bytes`.
fn damaged_batch(tag: &str, rel: &str, bytes: &[u8]) -> PathBuf {
    let src = batch_dir();
    let dst = scratch(&format!("batch-{tag}"));
    let _ = std::fs::remove_dir_all(&dst);
    for e in derma_test_support::files_under(src) {
        let to = dst.join(e.strip_prefix(src).unwrap());
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(&e, to).unwrap();
    }
    let _ = std::fs::remove_file(dst.join(layout::MANIFEST));
    std::fs::write(dst.join(rel), bytes).unwrap();
    dst
}

/// The record of identity 0, relative to the batch directory.
fn record_0() -> String {
    let spec = BatchSpec::parse(SPEC, "spec.toml").unwrap();
    format!("{}/{IDENTITY_FILE}", spec.identity(0).dir)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(32)))]

    #[test]
    fn damaged_batch_files_are_errors_or_a_complete_batch(
        spec_file in any::<bool>(), cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let rel = if spec_file { SPEC_FILE.to_string() } else { record_0() };
        let original = std::fs::read(batch_dir().join(&rel)).unwrap();
        let dir = damaged_batch("damaged", &rel, &damaged(&original, cut, at, flip));
        if let Ok(spec) = BatchSpec::read(&dir.join(SPEC_FILE)) {
            // A spec that reads can be prepared again in its own directory or refused there.
            let _ = layout::prepare(&dir, &spec);
        }
        let spec = BatchSpec::parse(SPEC, "spec.toml").unwrap();
        let again = layout::prepare(&dir, &spec);
        if let Ok(m) = merge::merge(&dir, &Silent) {
            // A merge that succeeds saw the whole batch, under the spec it was prepared with.
            prop_assert!(again.is_ok());
            prop_assert_eq!(m.identities, 3);
        }
    }

    #[test]
    fn arbitrary_batch_text_is_an_error(text in "\\PC{0,200}") {
        let dir = damaged_batch("arbitrary", SPEC_FILE, text.as_bytes());
        let spec = BatchSpec::parse(SPEC, "spec.toml").unwrap();
        prop_assert!(layout::prepare(&dir, &spec).is_err());
        prop_assert!(merge::merge(&dir, &Silent).is_err());
        let _ = BatchSpec::read(&dir.join(SPEC_FILE));
        let dir = damaged_batch("arbitrary-record", &record_0(), text.as_bytes());
        prop_assert!(merge::merge(&dir, &Silent).is_err());
    }

    #[test]
    fn any_text_as_a_batch_spec_is_an_error_or_a_spec_that_draws(
        count in 0usize..40, size in 0u32..20000, male in -1.0f32..2.0,
        a0 in -10.0f32..130.0, a1 in -10.0f32..130.0, extra in "\\PC{0,60}",
        damaged_at in 0usize..200,
    ) {
        let text = format!(
            "count = {count}\nsize = {size}\nmale = {male}\nage_years = [{a0:?}, {a1:?}]\n{extra}\n"
        );
        // Cut at a random place too: a spec written half-way.
        let cut: String = text.chars().take(damaged_at.max(1)).collect();
        for t in [text.as_str(), cut.as_str()] {
            if let Ok(spec) = BatchSpec::parse(t, "spec.toml") {
                for i in 0..spec.count.min(8) {
                    let id = spec.identity(i);
                    prop_assert!(id.ita_deg.is_finite() && id.age_years.is_finite());
                    prop_assert!((spec.age_years[0] - 0.05..=spec.age_years[1] + 0.05).contains(&id.age_years));
                }
            }
        }
    }
}

#[test]
fn the_valid_batch_merges_and_reads() {
    let dir = damaged_batch("valid", "unrelated.txt", b"");
    std::fs::remove_file(dir.join("unrelated.txt")).unwrap();
    assert_eq!(merge::merge(&dir, &Silent).unwrap().identities, 3);
    assert_eq!(BatchSpec::read(&dir.join(SPEC_FILE)).unwrap().count, 3);
}
