//! Compressed glTF geometry: buffer views under `EXT_meshopt_compression` (decoded by the
//! `meshopt` crate, meshoptimizer's own decoders and filters) and primitives under
//! `KHR_draco_mesh_compression` (decoded by the pure-Rust `draco-core`), as the two extension
//! specifications define them.

use super::{Doc, Geometry, MAX_COUNT};
use crate::error::Result;
use glam::{Vec2, Vec3};
use std::borrow::Cow;

/// `EXT_meshopt_compression` on a buffer view.
#[derive(serde::Deserialize)]
#[serde(rename_all = "camelCase")]
struct Meshopt {
    buffer: usize,
    #[serde(default)]
    byte_offset: u64,
    byte_length: u64,
    byte_stride: u64,
    count: u64,
    mode: String,
    #[serde(default)]
    filter: Option<String>,
}

/// `KHR_draco_mesh_compression` on a primitive.
#[derive(serde::Deserialize)]
#[serde(rename_all = "camelCase")]
struct Draco {
    buffer_view: usize,
    attributes: std::collections::BTreeMap<String, u32>,
}

impl Doc {
    /// A buffer view's bytes: a slice of its buffer, or the view decoded from its
    /// `EXT_meshopt_compression` stream.
    pub(super) fn view(&self, i: usize) -> Result<Cow<'_, [u8]>> {
        let v = self
            .root
            .buffer_views
            .get(i)
            .ok_or_else(|| self.err(format!("buffer view {i} does not exist")))?;
        if let Some(ext) = v
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("EXT_meshopt_compression"))
        {
            let m: Meshopt = serde_json::from_value(ext.clone())
                .map_err(|e| self.err(format!("buffer view {i}'s EXT_meshopt_compression: {e}")))?;
            let (count, stride) = (m.count as usize, m.byte_stride as usize);
            if count.checked_mul(stride) != Some(v.byte_length.0 as usize) {
                return Err(self.err(format!(
                    "buffer view {i}'s EXT_meshopt_compression decodes {count} × {stride} bytes, the view declares {}",
                    v.byte_length.0
                )));
            }
            if let Some((want, have)) = crate::memory::shortfall((count * stride) as f64) {
                return Err(self.err(format!(
                    "buffer view {i} decodes to {want:.1} GiB, {have:.1} GiB are available"
                )));
            }
            return self.meshopt(i, &m).map(Cow::Owned);
        }
        let data = self.buffer(v.buffer.value())?;
        let off = v.byte_offset.map(|o| o.0).unwrap_or(0);
        slice(data, off, v.byte_length.0)
            .map(Cow::Borrowed)
            .ok_or_else(|| self.err(format!("buffer view {i} lies outside its buffer")))
    }

    fn buffer(&self, b: usize) -> Result<&[u8]> {
        self.buffers
            .get(b)
            .and_then(|d| d.as_deref())
            .ok_or_else(|| {
                self.err(format!(
                    "buffer {b} is an EXT_meshopt_compression fallback with no data, read outside a compressed view"
                ))
            })
    }

    /// Decodes a meshopt-compressed buffer view into `count × byteStride` bytes.
    fn meshopt(&self, i: usize, m: &Meshopt) -> Result<Vec<u8>> {
        let src = self
            .buffers
            .get(m.buffer)
            .and_then(|d| d.as_deref())
            .and_then(|d| slice(d, m.byte_offset, m.byte_length))
            .ok_or_else(|| {
                self.err(format!(
                    "buffer view {i}'s compressed stream lies outside its buffer"
                ))
            })?;
        let (count, stride) = (m.count, m.byte_stride);
        let bad =
            |what: &str| self.err(format!("buffer view {i}'s EXT_meshopt_compression: {what}"));
        // The extension's constraints (its "Specifying compressed views"), checked before the
        // decoders see them.
        let stride_ok = match m.mode.as_str() {
            "ATTRIBUTES" => stride > 0 && stride <= 256 && stride % 4 == 0,
            "TRIANGLES" => (stride == 2 || stride == 4) && count % 3 == 0,
            "INDICES" => stride == 2 || stride == 4,
            other => return Err(bad(&format!("unknown mode '{other}'"))),
        };
        if !stride_ok || count > MAX_COUNT {
            return Err(bad(&format!(
                "byteStride {stride} and count {count} do not fit mode {}",
                m.mode
            )));
        }
        let filter = m.filter.as_deref().unwrap_or("NONE");
        let filter_ok = match filter {
            "NONE" => true,
            "OCTAHEDRAL" => stride == 4 || stride == 8,
            "QUATERNION" => stride == 8,
            "EXPONENTIAL" => stride % 4 == 0,
            _ => false,
        };
        if !filter_ok || (filter != "NONE" && m.mode != "ATTRIBUTES") {
            return Err(bad(&format!(
                "filter {filter} with byteStride {stride} in mode {}",
                m.mode
            )));
        }
        let (count, stride) = (count as usize, stride as usize);
        let mut out = vec![0u8; count * stride];
        // SAFETY: `out` holds exactly `count × stride` bytes, which each decoder writes and no
        // more; `src` is a live slice; the sizes passed meet each function's documented
        // preconditions (checked above), and the decoders return non-zero on malformed streams
        // instead of reading past `src`.
        let rc = unsafe {
            use meshopt::ffi;
            let dst = out.as_mut_ptr().cast();
            match m.mode.as_str() {
                "ATTRIBUTES" => {
                    ffi::meshopt_decodeVertexBuffer(dst, count, stride, src.as_ptr(), src.len())
                }
                "TRIANGLES" => {
                    ffi::meshopt_decodeIndexBuffer(dst, count, stride, src.as_ptr(), src.len())
                }
                _ => ffi::meshopt_decodeIndexSequence(dst, count, stride, src.as_ptr(), src.len()),
            }
        };
        if rc != 0 {
            return Err(bad(&format!(
                "the stream does not decode (meshoptimizer's code {rc})"
            )));
        }
        // SAFETY: `out` holds `count` elements of `stride` bytes, and the stride meets the
        // filter's precondition (checked above).
        unsafe {
            use meshopt::ffi;
            let p = out.as_mut_ptr().cast();
            match filter {
                "OCTAHEDRAL" => ffi::meshopt_decodeFilterOct(p, count, stride),
                "QUATERNION" => ffi::meshopt_decodeFilterQuat(p, count, stride),
                "EXPONENTIAL" => ffi::meshopt_decodeFilterExp(p, count, stride),
                _ => {}
            }
        }
        Ok(out)
    }

    /// A Draco-compressed primitive's positions, normals, UVs (set `tex_set`) and indices.
    pub(super) fn draco(&self, ext: &serde_json::Value, tex_set: u32) -> Result<Geometry> {
        let d: Draco = serde_json::from_value(ext.clone())
            .map_err(|e| self.err(format!("KHR_draco_mesh_compression: {e}")))?;
        if d.buffer_view >= self.root.buffer_views.len() {
            return Err(self.err(format!(
                "KHR_draco_mesh_compression names buffer view {}, which does not exist",
                d.buffer_view
            )));
        }
        let bytes = self.view(d.buffer_view)?;
        let decoded = std::panic::catch_unwind(|| decode_draco(&bytes));
        let mesh = match decoded {
            Ok(Ok(m)) => m,
            Ok(Err(e)) => return Err(self.err(format!("its Draco stream does not decode ({e})"))),
            Err(_) => return Err(self.err("its Draco stream does not decode (the decoder failed)")),
        };
        let n = mesh.num_points();
        let read = |name: &str, k: usize| -> Result<Option<Vec<f32>>> {
            let Some(&id) = d.attributes.get(name) else {
                return Ok(None);
            };
            let att = mesh.attribute_by_unique_id(id).ok_or_else(|| {
                self.err(format!("its Draco stream has no attribute {id} for {name}"))
            })?;
            Ok(Some(att.read_f32s(n, k)))
        };
        let positions = read("POSITION", 3)?
            .ok_or_else(|| self.err("a Draco primitive has no POSITION attribute"))?;
        let v3 = |v: Vec<f32>| {
            v.chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect()
        };
        let normals = read("NORMAL", 3)?.map(v3);
        let uvs = read(&format!("TEXCOORD_{tex_set}"), 2)?
            .map(|v| v.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect());
        let indices = mesh
            .faces()
            .iter()
            .flat_map(|f| f.iter().map(|p| p.0))
            .collect();
        Ok((v3(positions), normals, uvs, Some(indices)))
    }
}

fn decode_draco(bytes: &[u8]) -> std::result::Result<draco_core::mesh::Mesh, String> {
    use draco_core::decoder_buffer::DecoderBuffer;
    // A head scan is at most a few million points; the limits refuse absurd headers before
    // any allocation.
    let mut limits = draco_core::decode_limits::DecodeLimits::default();
    limits.max_points = 1 << 26;
    limits.max_faces = 1 << 27;
    limits.max_decoded_bytes = 1 << 31;
    let mut buffer = DecoderBuffer::new(bytes).with_limits(limits);
    let mut mesh = draco_core::mesh::Mesh::new();
    draco_core::mesh_decoder::MeshDecoder::new()
        .decode(&mut buffer, &mut mesh)
        .map_err(|e| format!("{e:?}"))?;
    Ok(mesh)
}

/// `data[off..off + len]`, or None where it does not fit.
fn slice(data: &[u8], off: u64, len: u64) -> Option<&[u8]> {
    let end = off.checked_add(len)?;
    data.get(usize::try_from(off).ok()?..usize::try_from(end).ok()?)
}
