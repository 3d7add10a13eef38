//! A head fitted to a user's mesh (docs/head.md, "Fitting your head"), read from the directory
//! `derma head fit` wrote (see [`crate::fit`]); read once per process and directory, then
//! shared like the built-in head.

use crate::fit::store::{self, StoreError};
use crate::Head;
use derma_core::head_mesh::{load_head_mesh, HeadRead, HeadUnit, MeshFrame};
use derma_core::mesh::TriMesh;
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::Progress;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The fitted head in `dir`.
pub fn open(dir: &Path) -> Result<&'static Head, StoreError> {
    static OPEN: OnceLock<Mutex<HashMap<PathBuf, &'static Head>>> = OnceLock::new();
    let key = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    let cache = OPEN.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(h) = cache.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
        return Ok(h);
    }
    // Leaked on purpose: a process opens a handful of heads and keeps them to its end.
    let head: &'static Head = Box::leak(Box::new(store::read(dir)?.head()));
    cache
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .insert(key, head);
    Ok(head)
}

/// The mesh at `path` (with UVs) the head in `dir` was fitted to, read in the fit's frame
/// (`head.json`: its unit, axes and part); a unit or part asked for that contradicts it is an
/// error naming both.
pub fn load_scan(
    dir: &Path,
    path: &Path,
    unit: HeadUnit,
    part: &PartChoice,
    progress: &dyn Progress,
) -> Result<TriMesh, StoreError> {
    Ok(load_user_mesh(Some(dir), path, unit, part, progress)?.0)
}

/// A user's mesh in derma's frame, and the frame it was read in: through the fitted head's
/// frame when there is one ([`load_scan`]), else by derma-core's rules for a mesh alone.
pub fn load_user_mesh(
    head: Option<&Path>,
    path: &Path,
    unit: HeadUnit,
    part: &PartChoice,
    progress: &dyn Progress,
) -> Result<(TriMesh, MeshFrame), StoreError> {
    let fitted = head.map(store::frame).transpose()?;
    let how = HeadRead {
        unit,
        part: part.clone(),
        fitted: fitted.as_ref(),
    };
    load_head_mesh(path, &how, progress).map_err(|e| StoreError::File {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })
}

/// The fitted head in `dir`, or the built-in head when there is none.
pub fn or_builtin(dir: Option<&Path>) -> Result<&'static Head, StoreError> {
    match dir {
        Some(d) => open(d),
        None => Ok(Head::builtin()),
    }
}
