//! Atomic file output: every file derma writes goes to a temporary name in the destination
//! directory and is renamed into place, so an interrupted run never leaves a half-written file.

use crate::error::{CoreError, Result};
use std::path::{Path, PathBuf};

/// The temporary sibling used while `path` is being written.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes through `write` into a temporary file, then renames it to `path`. On failure the
/// temporary file is removed and `path` is left untouched.
pub fn write_with<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&Path) -> Result<()>,
{
    let tmp = temp_path(path);
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|source| {
            let _ = std::fs::remove_file(&tmp);
            CoreError::Write {
                path: path.to_path_buf(),
                source,
            }
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Atomically writes `bytes` to `path`.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|source| CoreError::Write {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// Checks that `dir` exists (creating it if needed) and is writable, before any work is done.
pub fn ensure_writable_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| CoreError::Write {
        path: dir.to_path_buf(),
        source,
    })?;
    let probe = dir.join(format!(".derma-write-probe.{}", std::process::id()));
    std::fs::write(&probe, b"probe").map_err(|source| CoreError::Write {
        path: dir.to_path_buf(),
        source,
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_leaves_target_untouched() {
        let dir = std::env::temp_dir().join(format!("derma-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("a.txt");
        std::fs::write(&target, b"old").unwrap();
        let r = write_with(&target, |tmp| {
            std::fs::write(tmp, b"partial").unwrap();
            Err(CoreError::Invalid {
                what: "test".into(),
                detail: "boom".into(),
            })
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert!(!temp_path(&target).exists());
        write_bytes(&target, b"new").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
