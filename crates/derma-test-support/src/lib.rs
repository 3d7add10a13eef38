//! Helpers for derma's tests, kept out of the libraries' public APIs: a dev-dependency of the
//! crates whose tests use them, never a dependency of the product.
//!
//! - [`scratch_dir`]: a fresh empty directory per test.
//! - [`skip_without_gpu`]: GPU tests skip (with a note) on machines without an adapter, but
//!   fail where `DERMA_REQUIRE_GPU` is set (CI, on Mesa's lavapipe).
//! - [`shared_data`]: the reference data beside the repository (`../shared/data`), or a skip.
//! - [`quad_glb`]: a minimal valid GLB, for mesh loaders.
//! - [`proptest_cases`]: how many cases a property test runs.
//! - [`truth_scan`]: warps and placements that make scans with known correspondence.

#![warn(missing_docs)]

pub mod truth_scan;

use std::path::{Path, PathBuf};

/// A fresh, empty directory for one test, named after `tag` and the process.
pub fn scratch_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("creating a scratch directory");
    d
}

/// True (skip the test) when no GPU adapter opens (or the build has no `gpu` feature), after a
/// note on stderr; panics instead when `DERMA_REQUIRE_GPU` is set, so a missing driver or a
/// build without the feature fails CI rather than passing silently.
pub fn skip_without_gpu() -> bool {
    match derma_core::Device::Gpu.resolve() {
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

/// `bytes` truncated to the fraction `cut` of its length, with the byte at fraction `at` of
/// what remains xored by `flip`: a damaged file for loaders to refuse.
pub fn damaged(bytes: &[u8], cut: f64, at: f64, flip: u8) -> Vec<u8> {
    let mut b = bytes[..((bytes.len() as f64 * cut) as usize).min(bytes.len())].to_vec();
    if !b.is_empty() {
        let i = ((b.len() - 1) as f64 * at) as usize;
        b[i] ^= flip;
    }
    b
}

/// Cases per property test: `default` in the test command, or `PROPTEST_CASES` for a deeper
/// run (`PROPTEST_CASES=20000 cargo test --release robust`).
pub fn proptest_cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
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

/// A minimal GLB (glTF 2.0 binary): one 200 mm quad with positions, UVs and indices.
pub fn quad_glb() -> Vec<u8> {
    let pos: [f32; 12] = [
        0.0, 0.0, 0.0, 200.0, 0.0, 0.0, 200.0, 200.0, 0.0, 0.0, 200.0, 0.0,
    ];
    let uv: [f32; 8] = [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
    let idx: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = Vec::new();
    pos.iter()
        .for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    uv.iter()
        .for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    idx.iter()
        .for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2}}]}}],
"buffers":[{{"byteLength":{}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},{{"buffer":0,"byteOffset":80,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[200,200,0]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},{{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
        bin.len()
    );
    let mut j = json.into_bytes();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// The index of the point of `points` nearest `p` (None for no points).
pub fn nearest(points: &[glam::Vec3], p: glam::Vec3) -> Option<usize> {
    (0..points.len()).min_by(|&a, &b| {
        (points[a] - p)
            .length_squared()
            .total_cmp(&(points[b] - p).length_squared())
    })
}

/// Every file below `dir`, at any depth (for tests that copy a directory before damaging it).
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(files_under(&p));
        } else {
            out.push(p);
        }
    }
    out
}
