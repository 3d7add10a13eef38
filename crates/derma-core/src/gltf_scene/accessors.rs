//! glTF accessors read whatever their component type — float, or the integer and normalized
//! integer attributes of `KHR_mesh_quantization` — their byte stride and their sparse
//! substitutions (glTF 2.0 §3.6.2, "Accessor data types", and §3.6.2.3, "Sparse accessors").

use super::{Doc, MAX_COUNT};
use crate::error::Result;
use glam::{Vec2, Vec3};
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;

/// Bytes per component.
fn bytes_per(ct: ComponentType) -> usize {
    match ct {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// Components per element.
fn components(t: Type) -> usize {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 | Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

/// One component's value from its little-endian bytes; normalized integers map to [0, 1] or
/// [−1, 1] as §3.6.2.2 ("Normalized data") defines: `max(c / (2ⁿ⁻¹ − 1), −1)` for signed,
/// `c / (2ⁿ − 1)` for unsigned.
pub(super) fn component(ct: ComponentType, normalized: bool, b: &[u8]) -> f64 {
    let (v, max) = match ct {
        ComponentType::I8 => (b[0] as i8 as f64, 127.0),
        ComponentType::U8 => (b[0] as f64, 255.0),
        ComponentType::I16 => (i16::from_le_bytes([b[0], b[1]]) as f64, 32767.0),
        ComponentType::U16 => (u16::from_le_bytes([b[0], b[1]]) as f64, 65535.0),
        ComponentType::U32 => (
            u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            4_294_967_295.0,
        ),
        ComponentType::F32 => return f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    };
    if normalized {
        (v / max).max(-1.0)
    } else {
        v
    }
}

impl Doc {
    /// Accessor `i`'s values (every component exactly, as f64) and its component count.
    pub(super) fn accessor(&self, i: usize) -> Result<(Vec<f64>, usize)> {
        let a = &self.root.accessors[i];
        let (Checked::Valid(ct), Checked::Valid(ty)) = (&a.component_type, &a.type_) else {
            return Err(self.err(format!("accessor {i} has an invalid type")));
        };
        let (ct, n) = (ct.0, components(*ty));
        if matches!(ty, Type::Mat2 | Type::Mat3 | Type::Mat4) && ct != ComponentType::F32 {
            return Err(self.err(format!("accessor {i}: integer matrices are not read")));
        }
        let count = a.count.0;
        if count > MAX_COUNT {
            return Err(self.err(format!("accessor {i} declares {count} elements")));
        }
        let count = count as usize;
        let mut out = match a.buffer_view {
            Some(v) => self.strided(i, v.value(), a, ct, n, count)?,
            None if a.sparse.is_some() => {
                // Zeros under the substitutions (§3.6.2.3): a size the file does not bound.
                let need = (count * n * 8) as f64;
                if let Some((want, have)) = crate::memory::shortfall(need) {
                    return Err(self.err(format!(
                        "accessor {i}: {count} sparse elements need {want:.1} GiB, {have:.1} GiB are available"
                    )));
                }
                vec![0.0f64; count * n]
            }
            None => {
                return Err(self.err(format!(
                    "accessor {i} has no data (neither a bufferView nor sparse values)"
                )))
            }
        };
        if let Some(sp) = &a.sparse {
            self.sparse(i, sp, ct, a.normalized, n, &mut out)?;
        }
        Ok((out, n))
    }

    /// Accessor `i`'s `count` elements of `n` components from buffer view `v`, its bounds
    /// checked before anything is allocated (the values then take at most 8 bytes per byte of
    /// the view).
    fn strided(
        &self,
        i: usize,
        v: usize,
        a: &gltf::json::Accessor,
        ct: ComponentType,
        n: usize,
        count: usize,
    ) -> Result<Vec<f64>> {
        let elem = n * bytes_per(ct);
        let data = self.view(v)?;
        let stride = self.root.buffer_views[v]
            .byte_stride
            .map(|s| s.0)
            .unwrap_or(elem);
        let offset = a.byte_offset.map(|o| o.0).unwrap_or(0) as usize;
        if stride < elem {
            return Err(self.err(format!(
                "accessor {i}: its buffer view's stride {stride} is shorter than an element ({elem} bytes)"
            )));
        }
        let end = (count.max(1) - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(offset + elem));
        if count > 0 && end.is_none_or(|e| e > data.len()) {
            return Err(self.err(format!(
                "accessor {i} reads past its buffer view ({count} elements of {elem} bytes every {stride} from {offset}; the view holds {})",
                data.len()
            )));
        }
        let s = bytes_per(ct);
        let mut out = vec![0.0f64; count * n];
        for (k, dst) in out.chunks_exact_mut(n).enumerate() {
            let at = offset + k * stride;
            for (c, d) in dst.iter_mut().enumerate() {
                *d = component(ct, a.normalized, &data[at + c * s..at + (c + 1) * s]);
            }
        }
        Ok(out)
    }

    /// Applies an accessor's sparse substitutions to its values.
    fn sparse(
        &self,
        i: usize,
        sp: &gltf::json::accessor::sparse::Sparse,
        ct: ComponentType,
        normalized: bool,
        n: usize,
        out: &mut [f64],
    ) -> Result<()> {
        let count = sp.count.0 as usize;
        let Checked::Valid(ict) = &sp.indices.component_type else {
            return Err(self.err(format!(
                "accessor {i}'s sparse indices have an invalid type"
            )));
        };
        let ict = ict.0;
        let idx = self.view(sp.indices.buffer_view.value())?;
        let val = self.view(sp.values.buffer_view.value())?;
        let (io, vo) = (
            sp.indices.byte_offset.0 as usize,
            sp.values.byte_offset.0 as usize,
        );
        let (is, vs) = (bytes_per(ict), n * bytes_per(ct));
        let fits = |len: usize, off: usize, size: usize| {
            count
                .checked_mul(size)
                .and_then(|x| x.checked_add(off))
                .is_some_and(|e| e <= len)
        };
        if !fits(idx.len(), io, is) || !fits(val.len(), vo, vs) {
            return Err(self.err(format!(
                "accessor {i}'s sparse data reads past its buffer views"
            )));
        }
        let elements = out.len() / n.max(1);
        for k in 0..count {
            let target = component(ict, false, &idx[io + k * is..io + (k + 1) * is]) as usize;
            if target >= elements {
                return Err(self.err(format!(
                    "accessor {i}'s sparse index {target} is outside its {elements} elements"
                )));
            }
            for c in 0..n {
                let at = vo + k * vs + c * bytes_per(ct);
                out[target * n + c] = component(ct, normalized, &val[at..at + bytes_per(ct)]);
            }
        }
        Ok(())
    }

    /// Accessor `i` as 3-vectors.
    pub(super) fn vec3s(&self, i: usize) -> Result<Vec<Vec3>> {
        let (v, n) = self.accessor(i)?;
        if n != 3 {
            return Err(self.err(format!("accessor {i} has {n} components; expected 3")));
        }
        Ok(v.chunks_exact(3)
            .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
            .collect())
    }

    /// Accessor `i` as 2-vectors.
    pub(super) fn vec2s(&self, i: usize) -> Result<Vec<Vec2>> {
        let (v, n) = self.accessor(i)?;
        if n != 2 {
            return Err(self.err(format!("accessor {i} has {n} components; expected 2")));
        }
        Ok(v.chunks_exact(2)
            .map(|c| Vec2::new(c[0] as f32, c[1] as f32))
            .collect())
    }

    /// Accessor `i` as vertex indices.
    pub(super) fn indices(&self, i: usize) -> Result<Vec<u32>> {
        let (v, n) = self.accessor(i)?;
        if n != 1 {
            return Err(self.err(format!("index accessor {i} has {n} components; expected 1")));
        }
        Ok(v.into_iter().map(|x| x as u32).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalized_components_follow_the_specification() {
        // §3.6.2.2: signed values clamp at −1; unsigned map to [0, 1].
        assert_eq!(component(ComponentType::I8, true, &[0x81]), -1.0);
        assert_eq!(component(ComponentType::I8, true, &[0x80]), -1.0);
        assert_eq!(component(ComponentType::I8, true, &[127]), 1.0);
        assert_eq!(component(ComponentType::U8, true, &[255]), 1.0);
        assert_eq!(
            component(ComponentType::U16, true, &32768u16.to_le_bytes()),
            32768.0 / 65535.0
        );
        assert_eq!(
            component(ComponentType::I16, true, &(-16384i16).to_le_bytes()),
            -16384.0 / 32767.0
        );
        // Not normalized: the integer itself (quantized positions are dequantized by the node's
        // transform).
        assert_eq!(
            component(ComponentType::I16, false, &(-300i16).to_le_bytes()),
            -300.0
        );
        assert_eq!(
            component(ComponentType::U32, false, &70000u32.to_le_bytes()),
            70000.0
        );
        assert_eq!(
            component(ComponentType::F32, false, &1.5f32.to_le_bytes()),
            1.5
        );
    }
}
