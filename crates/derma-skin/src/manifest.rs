//! What a texture set holds (the project's design, §3 "Outputs"): manifest.json records the
//! seed, inputs, options, UV layout and a SHA-256 per file, so a set can be checked and matched.
//!
//! report.json is listed but not hashed: it carries the thread count and timings, so two runs
//! with one seed differ there and nowhere else.

use crate::outputs;
use crate::{Result, SkinError};
use derma_core::report::sha256_file;
use serde_json::{json, Value};
use std::path::Path;

/// What the manifest says of the run, besides its files.
pub struct Made<'a> {
    /// Texture size (square).
    pub size: u32,
    /// The seed.
    pub seed: u64,
    /// "template", "mesh" or "patch".
    pub surface: &'a str,
    /// The UV layout the set was painted on ([`derma_core::mesh::TriMesh::uv_layout`]);
    /// `None` for patches.
    pub uv_layout: Option<derma_core::mesh::UvLayout>,
    /// The inputs, with their hashes (report.json's "inputs").
    pub inputs: Value,
    /// The options as given.
    pub options: Value,
}

/// The file whose hash the manifest leaves out.
const UNHASHED: &str = outputs::REPORT;

/// manifest.json for the files `files` of `dir` (every one but the manifest itself).
pub fn manifest(made: &Made, dir: &Path, files: &[&str]) -> Result<Value> {
    use rayon::prelude::*;
    // One file per worker: hashing a 4096² set is I/O and SHA-256 over ~0.4 GB.
    let entries: Vec<Value> = files
        .par_iter()
        .map(|f| file_entry(dir, f))
        .collect::<Result<_>>()?;
    Ok(json!({
        "generator": format!("derma {}", env!("CARGO_PKG_VERSION")),
        "size": [made.size, made.size],
        "seed": made.seed,
        "surface": made.surface,
        "uv_layout": made.uv_layout,
        "conventions": {
            "uv": "OpenGL: v up; row 0 of every image is v = 1",
            "normal": "tangent space, OpenGL +Y (green up); MikkTSpace tangents on meshes",
            "lengths": "mm"
        },
        "inputs": made.inputs,
        "options": made.options,
        "maps": entries,
    }))
}

/// One file's entry: name, SHA-256 (not for report.json), colour space and meaning.
fn file_entry(dir: &Path, file: &str) -> Result<Value> {
    let mut e = match outputs::output(file) {
        Some(o) => json!(o),
        None => json!({"file": file}),
    };
    e["sha256"] = if file == UNHASHED {
        Value::Null
    } else {
        json!(
            sha256_file(&dir.join(file)).ok_or_else(|| SkinError::Input {
                path: dir.join(file),
                detail: "cannot be read back to hash".into(),
            })?
        )
    };
    Ok(e)
}

/// Adds `file` of `dir` (written after the set, such as head.glb) to its manifest.
pub fn add_file(dir: &Path, file: &str, meaning: &str) -> Result<()> {
    let path = dir.join(outputs::MANIFEST);
    let mut m = read(&path)?;
    let mut e = file_entry(dir, file)?;
    e["meaning"] = json!(meaning);
    e["color_space"] = json!("-");
    if let Some(maps) = m["maps"].as_array_mut() {
        maps.retain(|x| x["file"] != file);
        maps.push(e);
    }
    derma_core::report::write_json(&path, &m, derma_core::report::JsonFormat::REPORT)?;
    Ok(())
}

/// Reads a manifest.json.
pub fn read(path: &Path) -> Result<Value> {
    let bytes = std::fs::read(path).map_err(|e| SkinError::Input {
        path: path.to_path_buf(),
        detail: format!("cannot read the set's manifest ({e})"),
    })?;
    serde_json::from_slice(&bytes).map_err(|e| SkinError::Input {
        path: path.to_path_buf(),
        detail: format!("not a manifest: {e}"),
    })
}

/// What [`check`] found wrong with a set; empty when it holds what its manifest says.
#[derive(Debug, Default, PartialEq)]
pub struct Findings {
    /// Files listed but absent.
    pub missing: Vec<String>,
    /// Files whose bytes are not the ones the manifest hashed.
    pub changed: Vec<String>,
    /// Files in the directory the manifest does not list.
    pub unlisted: Vec<String>,
    /// Files checked and found as written.
    pub intact: usize,
}

impl Findings {
    /// True when nothing is missing, changed or unlisted.
    pub fn ok(&self) -> bool {
        self.missing.is_empty() && self.changed.is_empty() && self.unlisted.is_empty()
    }
}

/// Checks the set in `dir` against its manifest: every listed file present with its hash,
/// nothing else beside them.
pub fn check(dir: &Path) -> Result<Findings> {
    let m = read(&dir.join(outputs::MANIFEST))?;
    let maps = m["maps"].as_array().ok_or_else(|| SkinError::Input {
        path: dir.join(outputs::MANIFEST),
        detail: "no \"maps\" list (a manifest from before sets were hashed: paint the set again)"
            .into(),
    })?;
    let mut f = Findings::default();
    let mut listed = vec![outputs::MANIFEST.to_string()];
    for e in maps {
        let Some(file) = e["file"].as_str() else {
            continue;
        };
        listed.push(file.to_string());
        let path = dir.join(file);
        if !path.is_file() {
            f.missing.push(file.into());
            continue;
        }
        match e["sha256"].as_str() {
            Some(want) if sha256_file(&path).as_deref() != Some(want) => {
                f.changed.push(file.into())
            }
            None if file != UNHASHED => f.changed.push(format!("{file} (no hash listed)")),
            _ => f.intact += 1,
        }
    }
    let entries = std::fs::read_dir(dir).map_err(|source| derma_core::CoreError::Read {
        path: dir.to_path_buf(),
        source,
    })?;
    for e in entries.filter_map(|e| e.ok()) {
        let name = e.file_name().to_string_lossy().into_owned();
        if !listed.contains(&name) {
            f.unlisted.push(name);
        }
    }
    f.unlisted.sort();
    Ok(f)
}
