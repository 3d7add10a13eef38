//! A fitted head on disk (docs/head.md, "Fitting your head"): `head.json` (what differs from
//! the built-in head: positions, globes, face units, the fit's report), the fitted template as
//! an OBJ with derma's UVs, the landmarks in the scan's units, and the dense correspondence
//! both ways (the EyeMove thesis' B map, eq. 3.4).

use super::{FitReport, Fitted, Similarity, SurfacePoint};
use crate::asset::{EyeSphere, SparseTarget};
use derma_core::atomic;
use derma_core::head_mesh::MeshFrame;
use glam::{Mat3, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format name in `head.json`.
pub const FORMAT: &str = "derma fitted head";
/// Its version: 2 adds the scan's frame (unit, axes, part); version 1 files read as scale only.
pub const VERSION: u32 = 2;

/// The files a fitted head directory holds.
pub const FILES: [&str; 6] = [
    "head.json",
    "template.obj",
    "template_parts.obj",
    "landmarks.json",
    "template_to_scan.bin",
    "scan_to_template.bin",
];

/// Why a fitted head could not be read.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// A file could not be read or written.
    #[error("{path}: {detail}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        detail: String,
    },
}

#[derive(Serialize, Deserialize)]
struct Unit {
    name: String,
    offsets: Vec<(u32, [f32; 3])>,
}

#[derive(Serialize, Deserialize)]
struct File {
    format: String,
    version: u32,
    unit: String,
    /// The scan the head was fitted to, and millimetres per scan unit.
    scan: String,
    mm_per_unit: f32,
    /// How the scan's coordinates become the fitted head's (version 2).
    #[serde(default)]
    frame: Option<MeshFrame>,
    similarity: [f32; 13],
    report: FitReport,
    eyes: [EyeSphere; 2],
    positions: Vec<[f32; 3]>,
    fine: Vec<[f32; 3]>,
    face_units: Vec<Unit>,
}

fn err(path: &Path, detail: impl Into<String>) -> StoreError {
    StoreError::File {
        path: path.to_path_buf(),
        detail: detail.into(),
    }
}

/// What the fit knows of its scan.
pub struct ScanInfo<'a> {
    /// The scan's file name as given.
    pub name: &'a str,
    /// How its coordinates became derma's.
    pub frame: &'a MeshFrame,
    /// The scan (mm, derma's frame).
    pub mesh: &'a derma_core::mesh::TriMesh,
}

/// Writes a fitted head to `dir` (each file atomically).
pub fn write(fitted: &Fitted, scan: &ScanInfo, dir: &Path) -> Result<(), StoreError> {
    std::fs::create_dir_all(dir).map_err(|e| err(dir, format!("cannot create it ({e})")))?;
    let s = &fitted.similarity;
    let r = s.rotation.to_cols_array();
    let mut sim = [0.0f32; 13];
    sim[0] = s.scale;
    sim[1..10].copy_from_slice(&r);
    sim[10..13].copy_from_slice(&s.translation.to_array());
    let file = File {
        format: FORMAT.into(),
        version: VERSION,
        unit: "mm".into(),
        scan: scan.name.into(),
        mm_per_unit: scan.frame.mm_per_unit,
        frame: Some(scan.frame.clone()),
        similarity: sim,
        report: fitted.report.clone(),
        eyes: fitted.eyes,
        positions: fitted.positions.iter().map(|p| p.to_array()).collect(),
        fine: fitted.fine.iter().map(|p| p.to_array()).collect(),
        face_units: fitted
            .targets
            .iter()
            .map(|t| Unit {
                name: t.name.clone(),
                offsets: t.offsets.iter().map(|(v, d)| (*v, d.to_array())).collect(),
            })
            .collect(),
    };
    let json = serde_json::to_vec(&file).map_err(|e| err(dir, e.to_string()))?;
    let put = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        atomic::write_bytes(&p, bytes).map_err(|e| err(&p, e.to_string()))
    };
    let head = fitted.head();
    let obj = dir.join("template.obj");
    let parts = dir.join("template_parts.obj");
    crate::export::write_obj(&head, &obj, &parts).map_err(|e| err(&obj, e.to_string()))?;
    let lm: std::collections::BTreeMap<&str, [f32; 3]> = head
        .landmarks
        .points
        .iter()
        .map(|(n, p)| (n.as_str(), scan.frame.to_file(*p).to_array()))
        .collect();
    put(
        "landmarks.json",
        &serde_json::to_vec_pretty(&lm).map_err(|e| err(dir, e.to_string()))?,
    )?;
    put(
        "template_to_scan.bin",
        &encode(&super::template_to_scan(&head, scan.mesh)),
    )?;
    put(
        "scan_to_template.bin",
        &encode(&super::scan_to_template(&head, scan.mesh)),
    )?;
    // Last: a directory with head.json is complete.
    put("head.json", &json)
}

/// Correspondence records: per vertex a little-endian u32 triangle (u32::MAX: none) and two f32
/// barycentric weights (corners 1 and 2).
pub fn encode(points: &[SurfacePoint]) -> Vec<u8> {
    let mut out = Vec::with_capacity(points.len() * 12);
    for p in points {
        let (t, b) = p.unwrap_or((u32::MAX, [0.0, 0.0]));
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&b[0].to_le_bytes());
        out.extend_from_slice(&b[1].to_le_bytes());
    }
    out
}

/// Reads correspondence records (see [`encode`]).
pub fn decode(bytes: &[u8]) -> Option<Vec<SurfacePoint>> {
    if !bytes.len().is_multiple_of(12) {
        return None;
    }
    Some(
        bytes
            .chunks_exact(12)
            .map(|c| {
                let w = |k: usize| [c[k], c[k + 1], c[k + 2], c[k + 3]];
                let t = u32::from_le_bytes(w(0));
                (t != u32::MAX).then(|| (t, [f32::from_le_bytes(w(4)), f32::from_le_bytes(w(8))]))
            })
            .collect(),
    )
}

/// `head.json` of the fitted head directory `dir`, parsed as `T`, with its path.
fn head_json<T: serde::de::DeserializeOwned>(dir: &Path) -> Result<(T, PathBuf), StoreError> {
    let path = dir.join("head.json");
    let text = std::fs::read(&path).map_err(|e| {
        err(
            &path,
            format!(
                "cannot read it ({e}); a fitted head directory is what 'derma head fit' writes"
            ),
        )
    })?;
    let t = serde_json::from_slice(&text)
        .map_err(|e| err(&path, format!("not a fitted head ({e})")))?;
    Ok((t, path))
}

/// How the scan a fitted head directory's head was fitted to is read: its unit, axes and part
/// (`head.json`; a version-1 file gives its scale only).
pub fn frame(dir: &Path) -> Result<MeshFrame, StoreError> {
    #[derive(Deserialize)]
    struct Scale {
        mm_per_unit: f32,
        #[serde(default)]
        frame: Option<MeshFrame>,
    }
    let (s, path) = head_json::<Scale>(dir)?;
    let f = s
        .frame
        .unwrap_or_else(|| MeshFrame::scaled(None, s.mm_per_unit));
    let rotation_ok = (f.rotation * f.rotation.transpose()).abs_diff_eq(Mat3::IDENTITY, 1e-4)
        && (f.rotation.determinant() - 1.0).abs() < 1e-4;
    // Scans come in any unit (micrometres to kilometres fit the range); beyond it a mesh's
    // positions leave f32's range once scaled.
    let scale_ok = (MIN_MM_PER_UNIT..=MAX_MM_PER_UNIT).contains(&f.mm_per_unit);
    if !(scale_ok && rotation_ok) {
        return Err(err(
            &path,
            format!(
                "mm_per_unit {} and rotation {:?}; expected a scale in [1e-6, 1e6] and a rotation",
                f.mm_per_unit,
                f.rotation.to_cols_array()
            ),
        ));
    }
    Ok(f)
}

/// The smallest scale a fitted head may record (mm per unit of its scan).
const MIN_MM_PER_UNIT: f32 = 1e-6;
/// The largest.
const MAX_MM_PER_UNIT: f32 = 1e6;

/// Reads a fitted head directory's `head.json`.
pub fn read(dir: &Path) -> Result<Fitted, StoreError> {
    let (f, path) = head_json::<File>(dir)?;
    if f.format != FORMAT || !(1..=VERSION).contains(&f.version) {
        return Err(err(
            &path,
            format!(
                "format '{}' version {}; expected '{FORMAT}' version 1 to {VERSION}",
                f.format, f.version
            ),
        ));
    }
    let a = crate::asset::parse();
    let (coarse, _) = crate::local_quads(&a, &crate::SKIN_GROUPS);
    let fine_n = crate::subdivision::vertex_count(&coarse, crate::SKIN_LEVELS);
    if f.positions.len() != a.positions.len() || f.fine.len() != fine_n {
        return Err(err(
            &path,
            format!(
                "{} positions and {} fine skin positions; the built-in head has {} and {fine_n}",
                f.positions.len(),
                f.fine.len(),
                a.positions.len()
            ),
        ));
    }
    let finite = |v: &[f32; 3]| v.iter().all(|x| x.is_finite());
    if !f.positions.iter().chain(&f.fine).all(finite)
        || !f
            .eyes
            .iter()
            .all(|e| finite(&e.centre) && e.radius > 0.0 && e.radius.is_finite())
        || !f
            .face_units
            .iter()
            .flat_map(|u| &u.offsets)
            .all(|o| finite(&o.1))
    {
        return Err(err(
            &path,
            "it holds non-finite positions or a globe of no size",
        ));
    }
    let n = a.positions.len() as u32;
    let mut targets = Vec::with_capacity(f.face_units.len());
    for u in f.face_units {
        if let Some((v, _)) = u.offsets.iter().find(|(v, _)| *v >= n) {
            return Err(err(
                &path,
                format!("face unit '{}' moves vertex {v} of {n}", u.name),
            ));
        }
        targets.push(SparseTarget {
            name: u.name,
            offsets: u
                .offsets
                .into_iter()
                .map(|(v, d)| (v, Vec3::from(d)))
                .collect(),
        });
    }
    let s = f.similarity;
    Ok(Fitted {
        positions: f.positions.into_iter().map(Vec3::from).collect(),
        fine: f.fine.into_iter().map(Vec3::from).collect(),
        eyes: f.eyes,
        targets,
        report: f.report,
        similarity: Similarity {
            scale: s[0],
            rotation: Mat3::from_cols_slice(&s[1..10]),
            translation: Vec3::new(s[10], s[11], s[12]),
        },
    })
}
