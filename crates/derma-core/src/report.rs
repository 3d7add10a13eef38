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

/// `value` as pretty-printed JSON with [`tidy_floats`] applied.
pub fn pretty_json(value: &impl serde::Serialize) -> Result<Vec<u8>, serde_json::Error> {
    let mut v = serde_json::to_value(value)?;
    tidy_floats(&mut v);
    serde_json::to_vec_pretty(&v)
}

/// The SHA-256 of a file's bytes as lowercase hex, or `None` when it cannot be read.
pub fn sha256_file(path: &Path) -> Option<String> {
    let bytes = std::fs::read(path).ok()?;
    Some(hex(&Sha256::digest(&bytes)))
}

/// Lowercase hex of bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
