//! `.dtab`, derma's binary table (the table format of the project's design): a grid over named
//! axes, a fixed-length f32 vector per grid node, little-endian, checked by CRC-32, with a JSON
//! sidecar for humans.
//!
//! Layout: b"DTAB", u32 version (1), u32 header length, header (JSON: axes with node values,
//! value names and lengths, free-form metadata), f32 payload (node-major, axes row-major with
//! the first axis slowest), u32 CRC-32 (IEEE 802.3) of everything before it.

use crate::error::{CoreError, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file's first four bytes.
pub const MAGIC: &[u8; 4] = b"DTAB";
/// The format version this code reads and writes.
pub const VERSION: u32 = 1;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
/// One axis of the grid: its name and node values (increasing).
pub struct DtabAxis {
    /// Name, e.g. "melanin".
    pub name: String,
    /// Node values along the axis.
    pub values: Vec<f64>,
}

/// A named slice of each node's vector.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DtabValue {
    /// Name, e.g. "linear_srgb".
    pub name: String,
    /// Number of f32 values.
    pub len: usize,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
/// The JSON header: the grid's axes, the layout of each node's vector, metadata.
pub struct DtabHeader {
    /// The axes, first one slowest in the payload.
    pub axes: Vec<DtabAxis>,
    /// The named slices of each node's vector, in order.
    pub values: Vec<DtabValue>,
    #[serde(default)]
    /// Free-form metadata (what made the table, its units).
    pub meta: serde_json::Value,
}

impl DtabHeader {
    /// Number of grid nodes (the product of the axes' lengths).
    pub fn nodes(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// Values per node (the sum of the value lengths).
    pub fn stride(&self) -> usize {
        self.values.iter().map(|v| v.len).sum()
    }

    /// Per-axis node indices of flat node `node` (first axis slowest, as the payload stores
    /// them).
    pub fn node_indices(&self, node: usize) -> Vec<usize> {
        let mut rest = node;
        let mut idx = vec![0; self.axes.len()];
        for (k, axis) in self.axes.iter().enumerate().rev() {
            let n = axis.values.len().max(1);
            idx[k] = rest % n;
            rest /= n;
        }
        idx
    }

    /// Flat node of per-axis indices `idx` (the inverse of [`DtabHeader::node_indices`]).
    pub fn node_of(&self, idx: &[usize]) -> usize {
        self.axes
            .iter()
            .zip(idx)
            .fold(0, |flat, (axis, &i)| flat * axis.values.len() + i)
    }

    /// Offset of value `name` within a node's vector.
    pub fn offset(&self, name: &str) -> Option<(usize, usize)> {
        let mut o = 0;
        for v in &self.values {
            if v.name == name {
                return Some((o, v.len));
            }
            o += v.len;
        }
        None
    }
}

#[derive(Clone, Debug, PartialEq)]
/// A table in memory: its header and the payload, node-major.
pub struct Dtab {
    /// Axes, value layout and metadata.
    pub header: DtabHeader,
    /// `nodes() × stride()` values.
    pub data: Vec<f32>,
}

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), bitwise.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

impl Dtab {
    /// The file's bytes (magic, version, header, payload, CRC-32).
    pub fn to_bytes(&self) -> Vec<u8> {
        let header = serde_json::to_vec(&self.header).unwrap_or_default();
        let mut out = Vec::with_capacity(16 + header.len() + 4 * self.data.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(header.len() as u32).to_le_bytes());
        out.extend_from_slice(&header);
        for v in &self.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let crc = crc32(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// Parses a table from its bytes; `path` names it in errors (bad magic, version, checksum, sizes).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let bad = |m: &str| CoreError::Format {
            path: path.to_path_buf(),
            message: m.to_string(),
        };
        if bytes.len() < 16 || &bytes[..4] != MAGIC {
            return Err(bad("not a .dtab table (missing DTAB magic)"));
        }
        let word =
            |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
        let version = word(4);
        if version != VERSION {
            return Err(bad(&format!(
                "unsupported .dtab version {version} (expected {VERSION})"
            )));
        }
        let body = bytes.len() - 4;
        if crc32(&bytes[..body]) != word(body) {
            return Err(bad("checksum mismatch: the table is truncated or corrupt"));
        }
        let hl = word(8) as usize;
        if 12 + hl > body {
            return Err(bad("header length runs past the end of the file"));
        }
        let header: DtabHeader = serde_json::from_slice(&bytes[12..12 + hl])
            .map_err(|e| bad(&format!("header: {e}")))?;
        let payload = &bytes[12 + hl..body];
        let expected = header.nodes() * header.stride() * 4;
        if payload.len() != expected {
            return Err(bad(&format!(
                "payload has {} bytes, the header describes {expected}",
                payload.len()
            )));
        }
        let data = payload
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Ok(Self { header, data })
    }

    /// Writes the table and its JSON sidecar (`<path>.json`) atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::atomic::write_bytes(path, &self.to_bytes())?;
        let mut side = path.as_os_str().to_owned();
        side.push(".json");
        crate::report::write_json(
            Path::new(&side),
            &self.header,
            crate::report::JsonFormat::DATA_PRETTY,
        )
    }

    /// Reads and checks the table at `path`.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| CoreError::Read {
            path: path.to_path_buf(),
            source: e,
        })?;
        Self::from_bytes(&bytes, path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_check_value() {
        // The standard check value of CRC-32/ISO-HDLC.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn round_trip_and_corruption() {
        let t = Dtab {
            header: DtabHeader {
                axes: vec![DtabAxis {
                    name: "a".into(),
                    values: vec![0.0, 1.0],
                }],
                values: vec![DtabValue {
                    name: "rgb".into(),
                    len: 3,
                }],
                meta: serde_json::json!({"photons": 10}),
            },
            data: vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
        };
        let b = t.to_bytes();
        let p = Path::new("t.dtab");
        assert_eq!(Dtab::from_bytes(&b, p).unwrap(), t);
        let mut c = b.clone();
        c[20] ^= 1;
        let e = Dtab::from_bytes(&c, p).unwrap_err().to_string();
        assert!(e.contains("checksum"), "{e}");
        assert!(Dtab::from_bytes(&b[..b.len() - 8], p).is_err());
    }

    #[test]
    fn node_indices_invert_node_of() {
        let axis = |name: &str, n: usize| DtabAxis {
            name: name.into(),
            values: (0..n).map(|i| i as f64).collect(),
        };
        let h = DtabHeader {
            axes: vec![axis("a", 3), axis("b", 4), axis("c", 2)],
            values: vec![],
            meta: serde_json::Value::Null,
        };
        assert_eq!(h.node_indices(0), vec![0, 0, 0]);
        // First axis slowest: node 1 steps the last axis.
        assert_eq!(h.node_indices(1), vec![0, 0, 1]);
        assert_eq!(h.node_indices(23), vec![2, 3, 1]);
        for n in 0..h.nodes() {
            assert_eq!(h.node_of(&h.node_indices(n)), n);
        }
    }
}
