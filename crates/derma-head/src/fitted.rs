//! A head fitted to a user's mesh (docs/head.md, "Fitting your head"), read from the directory
//! `derma head fit` wrote (see [`crate::fit`]); read once per process and directory, then
//! shared like the built-in head.

use crate::fit::store::{self, StoreError};
use crate::Head;
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

/// The mesh at `path` (with UVs) the head in `dir` was fitted to, read in mm at the scale the
/// fit read it (`head.json`'s millimetres per scan unit, whatever `--unit` the fit was given).
pub fn load_scan(dir: &Path, path: &Path) -> Result<derma_core::mesh::TriMesh, StoreError> {
    let scale = store::mm_per_unit(dir)?;
    let mut mesh = derma_core::mesh::TriMesh::load(path).map_err(|e| StoreError::File {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })?;
    mesh.scale(scale);
    Ok(mesh)
}

/// The fitted head in `dir`, or the built-in head when there is none.
pub fn or_builtin(dir: Option<&Path>) -> Result<&'static Head, StoreError> {
    match dir {
        Some(d) => open(d),
        None => Ok(Head::builtin()),
    }
}
