//! Atomic file output: every file derma writes goes to a temporary name in the destination
//! directory and is renamed into place, so an interrupted run never leaves a half-written file.

use crate::error::{CoreError, Result};
use std::path::{Path, PathBuf};

/// A name part that no other writer into the same directory uses at the same time:
/// `HOST.PID.N` — the host (containers sharing a volume all run as process 1), the process, and
/// a counter within it.
pub fn unique_tag() -> String {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!("{}.{}.{n}", host(), std::process::id())
}

/// This machine's name as [`unique_tag`] writes it: ASCII letters, digits and '-', at most 40
/// ("host" when it has none).
pub fn host() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        let raw = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .or_else(|| std::env::var("HOSTNAME").ok())
            .or_else(|| std::env::var("COMPUTERNAME").ok())
            .unwrap_or_default();
        let clean: String = raw
            .trim()
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
            .take(40)
            .collect();
        if clean.is_empty() {
            "host".into()
        } else {
            clean
        }
    })
}

/// The temporary sibling used while `path` is being written (unique to this writer).
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", unique_tag()))
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
    probe_writable(dir)
}

/// Writes and removes a probe file in `dir`: an error naming `dir` unless it can be written.
fn probe_writable(dir: &Path) -> Result<()> {
    let probe = dir.join(format!(".derma-write-probe.{}", unique_tag()));
    std::fs::write(&probe, b"probe").map_err(|source| CoreError::Write {
        path: dir.to_path_buf(),
        source,
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Checks, before any work and without creating anything, that `dir` could be made and
/// written: it is a writable directory, or its nearest existing ancestor is (so an early
/// error leaves no empty directory behind).
pub fn check_writable_dest(dir: &Path) -> Result<()> {
    let mut at = dir;
    while !at.exists() {
        match at.parent() {
            Some(p) if !p.as_os_str().is_empty() => at = p,
            _ => {
                at = Path::new(".");
                break;
            }
        }
    }
    if !at.is_dir() {
        return Err(crate::Invalid::new(
            format!("output directory '{}'", dir.display()),
            "a directory or a path to make one",
            format!("'{}', a file", at.display()),
        )
        .into());
    }
    probe_writable(at)
}

/// Fails unless `dest` is absent, or a directory holding only files `owned` says are the
/// output's (a previous output, which [`StagedDir`] replaces whole): another's files are never
/// replaced. Checked before any work and again when the output is staged.
pub fn check_owned(dest: &Path, owned: &dyn Fn(&str) -> bool) -> Result<()> {
    if dest.is_file() {
        return Err(crate::Invalid::new(
            format!("output directory '{}'", dest.display()),
            "a directory",
            "a file",
        )
        .into());
    }
    if dest.is_dir() {
        let entries = std::fs::read_dir(dest).map_err(|source| CoreError::Read {
            path: dest.to_path_buf(),
            source,
        })?;
        let mut foreign: Vec<String> = entries
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| !owned(n) && !n.starts_with(".derma-write-probe."))
            .collect();
        foreign.sort();
        if !foreign.is_empty() {
            return Err(crate::Invalid::new(
                format!("output directory '{}'", dest.display()),
                "an empty or new directory, or one holding only a previous output (derma replaces it whole)",
                format!("files that are not this output's: {}", foreign.join(", ")),
            )
            .into());
        }
    }
    Ok(())
}

/// A directory of outputs written whole: its files go into a staging directory beside the
/// destination, and [`StagedDir::commit`] swaps it in (the previous contents removed after),
/// so a killed run leaves the previous set as it was, never a mix of two. A destination that
/// holds files the writer does not own (`owned` says which names are) is refused, not
/// replaced. Uncommitted staging is removed on drop.
pub struct StagedDir {
    dest: PathBuf,
    staging: PathBuf,
    committed: bool,
}

impl StagedDir {
    /// Creates the staging directory beside `dest` (and `dest`'s missing parents).
    pub fn begin(dest: &Path, owned: &dyn Fn(&str) -> bool) -> Result<Self> {
        check_owned(dest, owned)?;
        let staging = sibling(dest, "derma-partial");
        std::fs::create_dir_all(&staging).map_err(|source| CoreError::Write {
            path: staging.clone(),
            source,
        })?;
        Ok(Self {
            dest: dest.to_path_buf(),
            staging,
            committed: false,
        })
    }

    /// Where the files are written until the commit.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Puts the staged directory in the destination's place: the previous destination is
    /// renamed aside, the staging renamed in, the previous one removed.
    pub fn commit(mut self) -> Result<()> {
        let old = sibling(&self.dest, "derma-old");
        let had = self.dest.exists();
        let rename = |a: &Path, b: &Path| {
            std::fs::rename(a, b).map_err(|source| CoreError::Write {
                path: b.to_path_buf(),
                source,
            })
        };
        if had {
            rename(&self.dest, &old)?;
        }
        if let Err(e) = rename(&self.staging, &self.dest) {
            if had {
                let _ = std::fs::rename(&old, &self.dest);
            }
            return Err(e);
        }
        self.committed = true;
        if had {
            let _ = std::fs::remove_dir_all(&old);
        }
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// A hidden sibling of `dest` for `purpose`, unique to this writer.
fn sibling(dest: &Path, purpose: &str) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let parent = match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    parent.join(format!(".{name}.{purpose}.{}", unique_tag()))
}

/// Fails before any work when writing `outputs` would touch an input: an output that is an
/// input file, an input inside an output directory (a directory derma fills, such as a rig),
/// or an output inside an input directory (a fields directory, say). Paths that do not exist
/// yet are compared by their nearest existing ancestor.
pub fn check_inputs_spared(outputs: &[PathBuf], inputs: &[&Path]) -> Result<()> {
    let refuse = |message: String| {
        Err(crate::Invalid::new(
            "output",
            "a place apart from the inputs (derma never writes over its inputs — pick another output)",
            message,
        )
        .into())
    };
    for o in outputs {
        let oc = canonical(o);
        for i in inputs {
            let Ok(ic) = i.canonicalize() else { continue };
            if ic == oc {
                return refuse(format!(
                    "output '{}' is the input '{}'",
                    o.display(),
                    i.display()
                ));
            }
            if ic.starts_with(&oc) {
                return refuse(format!(
                    "input '{}' lies inside the output directory '{}'",
                    i.display(),
                    o.display()
                ));
            }
            if oc.starts_with(&ic) {
                let same = oc.parent() == Some(ic.as_path());
                return refuse(format!(
                    "output '{}' would be written into the input directory '{}'{}",
                    o.display(),
                    i.display(),
                    if same {
                        " (input and output are the same directory)"
                    } else {
                        ""
                    }
                ));
            }
        }
    }
    Ok(())
}

/// `p` made absolute through its nearest existing ancestor (the rest appended as given).
fn canonical(p: &Path) -> PathBuf {
    let mut tail = Vec::new();
    let mut head = p;
    loop {
        if let Ok(c) = head.canonicalize() {
            return tail.iter().rev().fold(c, |acc: PathBuf, t| acc.join(t));
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                tail.push(name.to_os_string());
                head = if parent.as_os_str().is_empty() {
                    Path::new(".")
                } else {
                    parent
                };
            }
            _ => return p.to_path_buf(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A staged directory replaces the destination whole on commit, leaves it untouched when
    /// dropped uncommitted (a killed or failed run), and refuses a destination holding files
    /// that are not its own.
    #[test]
    fn staged_directories_swap_whole_or_not_at_all() {
        let root = std::env::temp_dir().join(format!("derma-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dest = root.join("set");
        let owned = |n: &str| n.ends_with(".png");
        let s = StagedDir::begin(&dest, &owned).unwrap();
        assert!(!dest.exists());
        std::fs::write(s.path().join("a.png"), b"1").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(dest.join("a.png")).unwrap(), b"1");
        // A rerun that dies before its commit leaves the first set as it was.
        let s = StagedDir::begin(&dest, &owned).unwrap();
        std::fs::write(s.path().join("a.png"), b"2").unwrap();
        std::fs::write(s.path().join("b.png"), b"2").unwrap();
        drop(s);
        assert_eq!(std::fs::read(dest.join("a.png")).unwrap(), b"1");
        assert!(!dest.join("b.png").exists());
        // A completed rerun leaves only its own files.
        let s = StagedDir::begin(&dest, &owned).unwrap();
        std::fs::write(s.path().join("b.png"), b"3").unwrap();
        s.commit().unwrap();
        assert!(!dest.join("a.png").exists());
        assert_eq!(std::fs::read(dest.join("b.png")).unwrap(), b"3");
        let names: Vec<_> = std::fs::read_dir(&root)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "nothing left beside the set: {names:?}");
        // Somebody else's file in the destination: refused, named.
        std::fs::write(dest.join("notes.txt"), b"mine").unwrap();
        let e = StagedDir::begin(&dest, &owned).err().unwrap().to_string();
        assert!(e.contains("notes.txt"), "{e}");
        // A destination whose parents do not exist is only checked, not made.
        let deep = root.join("x/y/z");
        check_writable_dest(&deep).unwrap();
        assert!(!root.join("x").exists());
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn temporary_names_are_unique_to_the_writer() {
        // Pods on a shared volume all run as process 1: the host and a counter keep two
        // writers of the same file (two shards writing batch.toml) off each other's temporary.
        let p = Path::new("/some/dir/batch.toml");
        let (a, b) = (temp_path(p), temp_path(p));
        assert_ne!(a, b);
        assert_eq!(a.parent(), p.parent());
        let name = a.file_name().unwrap().to_str().unwrap();
        assert!(
            name.starts_with(".batch.toml.") && name.ends_with(".tmp"),
            "{name}"
        );
        assert!(
            name.contains(&format!(".{}.", std::process::id())),
            "{name}"
        );
    }

    #[test]
    fn failed_write_leaves_target_untouched() {
        let dir = derma_test_support::scratch_dir("atomic");
        let target = dir.join("a.txt");
        std::fs::write(&target, b"old").unwrap();
        let r = write_with(&target, |tmp| {
            std::fs::write(tmp, b"partial").unwrap();
            Err(crate::Invalid::new("test", "no failure", "boom").into())
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert!(!temp_path(&target).exists());
        write_bytes(&target, b"new").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn inputs_are_spared() {
        let dir = derma_test_support::scratch_dir("spare");
        let fields = dir.join("fields");
        std::fs::create_dir_all(&fields).unwrap();
        let mesh = dir.join("head.obj");
        std::fs::write(&mesh, b"v 0 0 0").unwrap();
        let out = |names: &[&str]| -> Vec<PathBuf> { names.iter().map(|n| dir.join(n)).collect() };
        // Files beside an input, and new directories, are fine.
        check_inputs_spared(&out(&["base_color.png", "new/x.png"]), &[&mesh, &fields]).unwrap();
        // The same file, through another spelling of the path.
        let e = check_inputs_spared(&[dir.join("fields/../head.obj")], &[&mesh]).unwrap_err();
        assert!(e.to_string().contains("is the input"), "{e}");
        // An output written into an input directory.
        let e = check_inputs_spared(&[fields.join("base_color.png")], &[&fields]).unwrap_err();
        assert!(e.to_string().contains("same directory"), "{e}");
        // An input inside a directory derma fills.
        let e = check_inputs_spared(std::slice::from_ref(&dir), &[&mesh]).unwrap_err();
        assert!(e.to_string().contains("inside the output directory"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
