//! What derma writes about a run: JSON with numbers as the user wrote them, and SHA-256 hashes
//! of input files, so a report says exactly which inputs made an output.

use sha2::{Digest, Sha256};
use std::path::Path;

/// The value a user wrote for a number that passed through an `f32`: configs and parameters
/// are f32, and their exact binary value printed as f64 shows noise digits (0.04 becomes
/// 0.03999999910593033). A value that is exactly an f32 becomes the f64 of that f32's shortest
/// decimal form ("0.04"); any other value is returned unchanged.
pub fn as_written(x: f64) -> f64 {
    let f = x as f32;
    if !x.is_finite() || f as f64 != x {
        return x;
    }
    f.to_string().parse().unwrap_or(x)
}

/// Applies [`as_written`] to every float in a JSON value (integers are left alone).
pub fn tidy_floats(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Number(n) if n.is_f64() => {
            if let Some(x) = n
                .as_f64()
                .and_then(|x| serde_json::Number::from_f64(as_written(x)))
            {
                *n = x;
            }
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(tidy_floats),
        serde_json::Value::Object(o) => o.values_mut().for_each(tidy_floats),
        _ => {}
    }
}

/// How a JSON file is written: indented or on one line, and whether floats are shown as the
/// user wrote them ([`tidy_floats`], for files people read) or exactly (data read back by a
/// program, where an f64 that happens to equal an f32 must keep its bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JsonFormat {
    /// Indented, one key per line.
    pub pretty: bool,
    /// Floats as written ([`as_written`]).
    pub tidy: bool,
}

impl JsonFormat {
    /// Reports and manifests: indented, floats as written.
    pub const REPORT: JsonFormat = JsonFormat {
        pretty: true,
        tidy: true,
    };
    /// Data read back by a program (models, shards, curves): one line, exact.
    pub const DATA: JsonFormat = JsonFormat {
        pretty: false,
        tidy: false,
    };
    /// Data people also read (a rig's description, the viewer's manifest): indented, exact.
    pub const DATA_PRETTY: JsonFormat = JsonFormat {
        pretty: true,
        tidy: false,
    };
}

/// `value` as JSON bytes in `format`.
fn json_bytes(
    value: &impl serde::Serialize,
    format: JsonFormat,
) -> Result<Vec<u8>, serde_json::Error> {
    if !format.tidy {
        return if format.pretty {
            serde_json::to_vec_pretty(value)
        } else {
            serde_json::to_vec(value)
        };
    }
    let mut v = serde_json::to_value(value)?;
    tidy_floats(&mut v);
    if format.pretty {
        serde_json::to_vec_pretty(&v)
    } else {
        serde_json::to_vec(&v)
    }
}

/// Writes `value` to `path` as JSON in `format`, atomically (a temporary name, then a rename):
/// the one way derma writes a JSON file. The error names the file.
pub fn write_json(
    path: &Path,
    value: &impl serde::Serialize,
    format: JsonFormat,
) -> crate::Result<()> {
    let bytes = json_bytes(value, format).map_err(|e| crate::CoreError::Encode {
        path: path.to_path_buf(),
        detail: format!("as JSON: {e}"),
    })?;
    crate::atomic::write_bytes(path, &bytes)
}

/// The SHA-256 of a file's bytes as lowercase hex, or `None` when it cannot be read.
pub fn sha256_file(path: &Path) -> Option<String> {
    // Streamed in 1 MiB blocks: a 4096² set's maps are hashed without holding one in memory.
    use std::io::Read;
    let mut f = std::fs::File::open(path).ok()?;
    let (mut h, mut buf) = (Sha256::new(), vec![0u8; 1 << 20]);
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            return Some(hex(&h.finalize()));
        }
        h.update(&buf[..n]);
    }
}

/// Lowercase hex of bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Data keeps an f64's bits where a report shows the number as written; both read back.
    #[test]
    fn json_formats_keep_data_exact_and_reports_tidy() {
        let x = 0.04f32 as f64; // 0.03999999910593033, an f32 value held in an f64
        let v = serde_json::json!({"x": x, "n": 3});
        let data = json_bytes(&v, JsonFormat::DATA).unwrap();
        assert_eq!(
            String::from_utf8(data.clone()).unwrap(),
            r#"{"n":3,"x":0.03999999910593033}"#
        );
        let back: serde_json::Value = serde_json::from_slice(&data).unwrap();
        assert_eq!(back["x"].as_f64().unwrap().to_bits(), x.to_bits());
        let report = String::from_utf8(json_bytes(&v, JsonFormat::REPORT).unwrap()).unwrap();
        assert!(
            report.contains("\"x\": 0.04") && report.contains('\n'),
            "{report}"
        );
        let dir = std::env::temp_dir().join(format!("derma-json-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("r.json");
        write_json(&p, &v, JsonFormat::DATA_PRETTY).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains("0.03999999910593033") && text.contains('\n'));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn f32_values_print_as_written() {
        assert_eq!(as_written(0.04f32 as f64), 0.04);
        assert_eq!(as_written(0.028f32 as f64).to_string(), "0.028");
        assert_eq!(as_written(1e-6f32 as f64), 1e-6);
        // Values that are not f32s (true f64 results) are kept bit for bit.
        assert_eq!(as_written(0.1), 0.1);
        assert_eq!(as_written(1.0 / 3.0), 1.0 / 3.0);
        assert!(as_written(f64::NAN).is_nan());
        let mut v = serde_json::json!({"a": [0.6f32 as f64, 3], "b": {"c": 2048}});
        tidy_floats(&mut v);
        assert_eq!(v.to_string(), r#"{"a":[0.6,3],"b":{"c":2048}}"#);
    }

    #[test]
    fn sha256_of_a_known_file() {
        let p = derma_test_support::scratch_dir("sha").join("abc");
        std::fs::write(&p, b"abc").unwrap();
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            sha256_file(&p).unwrap(),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        std::fs::remove_file(&p).unwrap();
        assert!(sha256_file(&p).is_none());
    }
}
