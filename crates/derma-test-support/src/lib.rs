//! Helpers for derma's tests, kept out of the libraries' public APIs: a dev-dependency of the
//! crates whose tests use them, never a dependency of the product.
//!
//! - [`scratch_dir`]: a fresh empty directory per test.
//! - [`skip_without_gpu`]: GPU tests skip (with a note) on machines without an adapter, but
//!   fail where `DERMA_REQUIRE_GPU` is set (CI, on Mesa's lavapipe).
//! - [`shared_data`]: the reference data beside the repository (`../shared/data`), or a skip.

#![warn(missing_docs)]

use std::path::PathBuf;

/// A fresh, empty directory for one test, named after `tag` and the process.
pub fn scratch_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("creating a scratch directory");
    d
}

/// True (skip the test) when no GPU adapter opens, after a note on stderr; panics instead when
/// `DERMA_REQUIRE_GPU` is set, so a missing driver fails CI rather than passing silently.
pub fn skip_without_gpu() -> bool {
    match derma_core::gpu::context() {
        Ok(_) => false,
        Err(e) => {
            assert!(
                std::env::var("DERMA_REQUIRE_GPU").is_err(),
                "DERMA_REQUIRE_GPU is set but the GPU is unavailable: {e}"
            );
            eprintln!("skipped: {e}");
            true
        }
    }
}

/// `../shared/data/NAME` beside the workspace, or `None` after a note on stderr (tests that
/// need the reference data skip without it; the product never needs it).
pub fn shared_data(name: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(name);
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "skipped: {} not found (the shared reference data)",
            p.display()
        );
        None
    }
}
