//! A batch's merge (docs/batch.md): every identity present, its record the spec's draw, every
//! file its hash; then the leftovers removed and the manifest written, a JSON line per identity.

use crate::error::{BatchError, Result};
use crate::layout::{
    hashes, io, read_spec_file, IDENTITY_FILE, MANIFEST, PARTIAL, SPEC_FILE, UNHASHED,
};
use crate::spec::Identity;
use derma_core::progress::{Job, Progress, Unit};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What [`merge`] found and wrote.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The manifest written.
    pub manifest: PathBuf,
    /// Identities in it.
    pub identities: usize,
    /// Files checked against their hashes.
    pub files: usize,
    /// Unfinished directories of killed or duplicate workers, removed.
    pub removed: usize,
}

/// One manifest line: the identity's record and the seconds its sets took (their report.json's).
#[derive(Serialize)]
struct ManifestLine<'a> {
    #[serde(flatten)]
    identity: &'a Identity,
    seconds: Option<f64>,
}

/// Checks that every identity of the batch in `out` is present and complete — its record
/// matches the spec's draws and every file its hash — and writes `out/manifest.jsonl`.
/// The error lists what is missing or wrong.
pub fn merge(out: &Path, progress: &dyn Progress) -> Result<Merged> {
    let spec = read_spec_file(&out.join(SPEC_FILE))?;
    let job = Job::new(progress);
    job.stage("check", spec.count as u64, Unit::Steps);
    let mut lines = String::new();
    let mut problems: Vec<String> = Vec::new();
    let mut files = 0;
    for i in 0..spec.count {
        job.advance(1);
        let want = spec.identity(i);
        let dir = out.join(&want.dir);
        let record = dir.join(IDENTITY_FILE);
        let Ok(text) = std::fs::read_to_string(&record) else {
            problems.push(format!("{}: missing", want.dir));
            continue;
        };
        let got: Identity = match serde_json::from_str(&text) {
            Ok(g) => g,
            Err(e) => {
                problems.push(format!("{}: unreadable record ({e})", want.dir));
                continue;
            }
        };
        let drawn = Identity {
            files: BTreeMap::new(),
            ..got.clone()
        };
        if drawn != want {
            problems.push(format!(
                "{}: its record is not this spec's identity {i}",
                want.dir
            ));
            continue;
        }
        let now = hashes(&dir)?;
        if now != got.files {
            let differ: Vec<&str> = got
                .files
                .iter()
                .filter(|(n, h)| now.get(*n) != Some(*h))
                .map(|(n, _)| n.as_str())
                .collect();
            let extra: Vec<&str> = now
                .keys()
                .filter(|n| !got.files.contains_key(*n))
                .map(String::as_str)
                .collect();
            let mut what = Vec::new();
            if !differ.is_empty() {
                what.push(format!("changed or missing: {}", differ.join(", ")));
            }
            if !extra.is_empty() {
                what.push(format!("not in its record: {}", extra.join(", ")));
            }
            problems.push(format!(
                "{}: {} (delete {}/ and run its shard again)",
                want.dir,
                what.join("; "),
                want.dir
            ));
            continue;
        }
        files += now.len();
        // The sets' own totals (each size's report.json), summed.
        let seconds = spec
            .size
            .dirs()
            .iter()
            .map(|(_, sub)| {
                std::fs::read_to_string(dir.join(sub).join(UNHASHED))
                    .ok()
                    .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                    .and_then(|v| total_seconds(&v))
            })
            .sum::<Option<f64>>();
        let line = serde_json::to_string(&ManifestLine {
            identity: &got,
            seconds,
        })
        .map_err(|e| derma_core::CoreError::Encode {
            path: out.join(MANIFEST),
            detail: e.to_string(),
        })?;
        lines.push_str(&line);
        lines.push('\n');
    }
    if !problems.is_empty() {
        let n = problems.len();
        problems.truncate(20);
        return Err(BatchError::from(derma_core::CoreError::Format {
            path: out.to_path_buf(),
            message: format!(
                "{n} of {} identities are not complete (run their shards again): {}{}",
                spec.count,
                problems.join("; "),
                if n > 20 { "; …" } else { "" }
            ),
        }));
    }
    // Every identity is complete: an unfinished directory left now is a killed or duplicate
    // worker's (on any host), never needed again.
    let mut removed = 0;
    for e in std::fs::read_dir(out).map_err(|e| io(out, e))?.flatten() {
        if e.file_name().to_string_lossy().contains(PARTIAL) && e.path().is_dir() {
            let path = e.path();
            std::fs::remove_dir_all(&path).map_err(|e| io(&path, e))?;
            removed += 1;
        }
    }
    let manifest = out.join(MANIFEST);
    derma_core::atomic::write_bytes(&manifest, lines.as_bytes())?;
    Ok(Merged {
        manifest,
        identities: spec.count,
        files,
        removed,
    })
}

/// The whole run's seconds from a set's report.json (its `timings_s` stage "total").
fn total_seconds(report: &serde_json::Value) -> Option<f64> {
    report
        .get("timings_s")?
        .as_array()?
        .iter()
        .find(|t| t.get("stage").and_then(|s| s.as_str()) == Some("total"))?
        .get("seconds")?
        .as_f64()
}
