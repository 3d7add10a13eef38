//! Helpers shared by the CLI end-to-end tests: a fresh scratch directory and a quiet run of
//! the `derma` binary.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test (`kind` and `tag` name it).
pub fn tmp(kind: &str, tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-{kind}-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `derma ARGS --quiet`: (success, stdout, stderr).
pub fn run(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_derma"))
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
