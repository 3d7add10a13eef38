//! A batch directory's layout (docs/batch.md): the spec's copy, each identity's record and its
//! files' hashes, and the unfinished directories of the processes that paint them.

use crate::error::{BatchError, Result};
use crate::spec::BatchSpec;
use derma_core::report::sha256_file;
use std::collections::BTreeMap;
use std::path::Path;

/// The file a batch directory keeps its spec in (paths resolved), to resume and merge by.
pub const SPEC_FILE: &str = "batch.toml";
/// The merged manifest: one JSON object per line, identity 0 first.
pub const MANIFEST: &str = "manifest.jsonl";
/// Each identity's record, written last into its directory (the directory is renamed into
/// place after it, so a directory under its final name is complete).
pub const IDENTITY_FILE: &str = "identity.json";
/// The set's report: it carries timings, so it is not hashed.
pub(crate) const UNHASHED: &str = derma_skin::outputs::REPORT;
/// What follows an identity's directory name in an unfinished directory's:
/// `NNNNNN.partial.HOST.PID.N` (derma_core::atomic::unique_tag).
pub(crate) const PARTIAL: &str = ".partial.";

/// Removes the unfinished directories of identity `dir` that no live process is writing:
/// those of this host whose process has ended (or is this one). Those of other hosts are left
/// to their writers, or to [`super::merge()`] once the batch is complete. Returns how many it removed.
pub(crate) fn remove_stale_partials(out: &Path, dir: &str) -> Result<usize> {
    // Whether a process has ended is known only where /proc is.
    if !Path::new("/proc/self").exists() {
        return Ok(0);
    }
    let (host, pid) = (derma_core::atomic::host(), std::process::id().to_string());
    let mut removed = 0;
    for e in std::fs::read_dir(out).map_err(|e| io(out, e))?.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix(dir).and_then(|r| r.strip_prefix(PARTIAL)) else {
            continue;
        };
        let mut parts = rest.split('.');
        let (h, p) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
        let ended = p == pid || !Path::new("/proc").join(p).exists();
        if h == host && ended {
            let path = e.path();
            std::fs::remove_dir_all(&path).map_err(|e| io(&path, e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Writes the spec into `out` on the first run, or checks that the one there is the same:
/// a batch directory holds one batch.
pub fn prepare(out: &Path, spec: &BatchSpec) -> Result<()> {
    derma_core::atomic::ensure_writable_dir(out)?;
    let path = out.join(SPEC_FILE);
    let text = toml::to_string(spec).map_err(|e| derma_core::CoreError::Encode {
        path: path.clone(),
        detail: e.to_string(),
    })?;
    if path.exists() {
        let old = read_spec_file(&path)?;
        if &old != spec {
            return Err(BatchError::from(derma_core::CoreError::Format {
                path,
                message: "this directory holds another batch (its spec differs); use a new output \
                         directory or the same spec"
                    .into(),
            }));
        }
        return Ok(());
    }
    derma_core::atomic::write_bytes(&path, text.as_bytes())?;
    Ok(())
}

pub(crate) fn read_spec_file(path: &Path) -> Result<BatchSpec> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        BatchError::from(derma_core::CoreError::Format {
            path: path.to_path_buf(),
            message: format!("cannot read ({e})"),
        })
    })?;
    BatchSpec::parse(&text, &path.display().to_string())
}

pub(crate) fn io(path: &Path, e: std::io::Error) -> BatchError {
    BatchError::from(derma_core::CoreError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// SHA-256 of every file under `dir` (one level of size directories deep) but the sets'
/// report.json and the record itself, by path relative to `dir` ("1024/base_color.png").
pub(crate) fn hashes(dir: &Path) -> Result<BTreeMap<String, String>> {
    let mut out = BTreeMap::new();
    let entries = |d: &Path| -> Result<Vec<std::fs::DirEntry>> {
        Ok(std::fs::read_dir(d)
            .map_err(|e| io(d, e))?
            .filter_map(|e| e.ok())
            .collect())
    };
    for e in entries(dir)? {
        let name = e.file_name().to_string_lossy().into_owned();
        let files = if e.path().is_dir() {
            entries(&e.path())?
                .into_iter()
                .filter(|f| f.path().is_file())
                .map(|f| {
                    (
                        format!("{name}/{}", f.file_name().to_string_lossy()),
                        f.path(),
                    )
                })
                .collect()
        } else {
            vec![(name, e.path())]
        };
        for (key, p) in files {
            let base = key.rsplit('/').next().unwrap_or(&key);
            if base == UNHASHED || key == IDENTITY_FILE {
                continue;
            }
            let h = sha256_file(&p).ok_or_else(|| {
                BatchError::from(derma_core::CoreError::Format {
                    path: p.clone(),
                    message: "cannot read to hash".into(),
                })
            })?;
            out.insert(key, h);
        }
    }
    Ok(out)
}
