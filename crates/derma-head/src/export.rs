//! Writing the head for other tools: a Wavefront OBJ with one named object per sub-mesh and a
//! glTF 2.0 binary (GLB) with one named node per sub-mesh and the face units as morph targets
//! (sparse accessors, names in `extras.targetNames` as Blender, three.js and Unity read them).
//! glTF's unit is the metre, so the GLB is scaled to metres; the OBJ stays in millimetres like
//! every other derma mesh.

use crate::{Head, MorphTarget};
use derma_core::mesh::TriMesh;
use glam::Vec3;
use serde_json::{json, Value};
use std::path::Path;

/// glTF metres per derma millimetre.
pub const M_PER_MM: f32 = 1e-3;

/// Writes the skin alone as `path` (the mesh `derma skin --mesh` paints) and every other part as
/// named objects in `parts_path` (`eye_left`, `eye_right`, `eyelashes_left`, …), OBJ in mm,
/// atomically.
pub fn write_obj(head: &Head, path: &Path, parts_path: &Path) -> crate::Result<()> {
    write_objects(path, &[("skin", &head.skin)])?;
    let parts: Vec<(&str, &TriMesh)> = head
        .parts
        .iter()
        .map(|p| (p.name.as_str(), &p.mesh))
        .collect();
    write_objects(parts_path, &parts)
}

fn write_objects(path: &Path, meshes: &[(&str, &TriMesh)]) -> crate::Result<()> {
    let header = "derma built-in head (MakeHuman base mesh, CC0 1.0), millimetres";
    Ok(derma_core::mesh::write_obj_objects(path, header, meshes)?)
}

/// A GLB under construction: the binary chunk and the JSON arrays (shared with the crates that
/// export animated heads).
#[derive(Default)]
pub struct Glb {
    /// The binary chunk.
    pub bin: Vec<u8>,
    /// bufferViews.
    pub views: Vec<Value>,
    /// accessors.
    pub accessors: Vec<Value>,
}

impl Glb {
    /// The GLB file of `doc` (whose buffers and views must be this builder's) and the binary.
    pub fn finish(mut self, doc: &Value) -> Vec<u8> {
        // A `Value` always serialises: its Display is the compact JSON text.
        let mut js = doc.to_string().into_bytes();
        while !js.len().is_multiple_of(4) {
            js.push(b' ');
        }
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let total = 12 + 8 + js.len() + 8 + self.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(js.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&js);
        out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        out
    }

    /// Appends `bytes` (4-byte aligned) as a buffer view; returns its index.
    pub fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// Adds an accessor; returns its index.
    pub fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// A VEC3 float accessor (vertex attribute), with min/max when asked.
    pub fn vec3s(&mut self, v: &[Vec3], with_bounds: bool) -> usize {
        let bytes: Vec<u8> = v
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes, Some(34962));
        let mut a =
            json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3"});
        if with_bounds {
            let (lo, hi) = bounds(v.iter().copied());
            a["min"] = json!(lo.to_array());
            a["max"] = json!(hi.to_array());
        }
        self.accessor(a)
    }

    /// A sparse morph-target accessor over `count` vertices (zeros except `offs`, mm).
    pub fn sparse(&mut self, count: usize, offs: &[(u32, Vec3)]) -> usize {
        // glTF requires at least one sparse entry; an empty target stores a zero at vertex 0.
        let zero = [(0u32, Vec3::ZERO)];
        let offs = if offs.is_empty() { &zero[..] } else { offs };
        let idx: Vec<u8> = offs.iter().flat_map(|o| o.0.to_le_bytes()).collect();
        let val: Vec<u8> = offs
            .iter()
            .flat_map(|o| (o.1 * M_PER_MM).to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let iv = self.view(&idx, None);
        let vv = self.view(&val, None);
        // min/max over the accessor after substitution: the zeros count unless every vertex is
        // listed (glTF 2.0 §3.6.2.4, sparse accessors).
        let (mut lo, mut hi) = bounds(offs.iter().map(|o| o.1 * M_PER_MM));
        if offs.len() < count {
            lo = lo.min(Vec3::ZERO);
            hi = hi.max(Vec3::ZERO);
        }
        self.accessor(json!({
            "componentType": 5126, "count": count, "type": "VEC3",
            "min": lo.to_array(), "max": hi.to_array(),
            "sparse": {"count": offs.len(),
                "indices": {"bufferView": iv, "componentType": 5125},
                "values": {"bufferView": vv}}
        }))
    }

    /// A mesh (mm, written in metres) with named sparse morph targets (mm offsets).
    pub fn mesh(&mut self, name: &str, m: &TriMesh, targets: &[(&str, &[(u32, Vec3)])]) -> Value {
        let pos: Vec<Vec3> = m.positions.iter().map(|p| *p * M_PER_MM).collect();
        let p = self.vec3s(&pos, true);
        let n = self.vec3s(&m.normals, false);
        // glTF's texture origin is the top-left corner: v' = 1 − v.
        let uv: Vec<u8> = m
            .uvs
            .iter()
            .flat_map(|t| [t.x, 1.0 - t.y])
            .flat_map(f32::to_le_bytes)
            .collect();
        let uvv = self.view(&uv, Some(34962));
        let t = self.accessor(
            json!({"bufferView": uvv, "componentType": 5126, "count": m.uvs.len(), "type": "VEC2"}),
        );
        let idx: Vec<u8> = m
            .triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let iv = self.view(&idx, Some(34963));
        let i = self.accessor(json!({"bufferView": iv, "componentType": 5125, "count": m.triangles.len() * 3, "type": "SCALAR"}));
        let mut prim = json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t}, "indices": i, "mode": 4});
        let mut mesh = json!({"name": name, "primitives": []});
        if !targets.is_empty() {
            let ts: Vec<Value> = targets
                .iter()
                .map(|(_, offs)| json!({"POSITION": self.sparse(m.positions.len(), offs)}))
                .collect();
            prim["targets"] = json!(ts);
            mesh["weights"] = json!(vec![0.0; targets.len()]);
            mesh["extras"] =
                json!({"targetNames": targets.iter().map(|t| t.0).collect::<Vec<_>>()});
        }
        mesh["primitives"] = json!([prim]);
        mesh
    }
}

fn bounds(it: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    it.fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    )
}

/// The face units' morph offsets of part `part` (teeth, tongue, …) for a GLB mesh: one target per
/// unit, in the units' order (an empty one where a unit leaves the part still), or none at all
/// when no unit moves the part (glTF then carries no targets for it).
pub fn part_targets(units: &[MorphTarget], part: usize) -> Vec<(&str, &[(u32, Vec3)])> {
    if !units
        .iter()
        .any(|u| u.parts.iter().any(|(p, _)| *p == part))
    {
        return Vec::new();
    }
    units
        .iter()
        .map(|u| {
            let offs = u
                .parts
                .iter()
                .find(|(p, _)| *p == part)
                .map_or(&[][..], |(_, o)| o.as_slice());
            (u.name.as_str(), offs)
        })
        .collect()
}

/// Writes `head.glb`: nodes `skin`, `eye_left`, …; the skin, teeth and tongue carry all 52 face
/// units as morph targets (the same names and order on each mesh, so one weight array drives
/// them together).
pub fn write_glb(head: &Head, path: &Path) -> crate::Result<()> {
    let units: &[MorphTarget] = head.face_units();
    let mut g = Glb::default();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    let skin_targets: Vec<(&str, &[(u32, Vec3)])> = units
        .iter()
        .map(|u| (u.name.as_str(), u.skin.as_slice()))
        .collect();
    meshes.push(g.mesh("skin", &head.skin, &skin_targets));
    for (k, part) in head.parts.iter().enumerate() {
        meshes.push(g.mesh(&part.name, &part.mesh, &part_targets(units, k)));
    }
    for (i, m) in meshes.iter().enumerate() {
        nodes.push(json!({"name": m["name"], "mesh": i}));
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "derma",
            "copyright": "MakeHuman base mesh and Face Units by the MakeHuman community and Mika Suominen, CC0 1.0"},
        "scene": 0,
        "scenes": [{"name": "derma head", "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "buffers": [{"byteLength": g.bin.len()}],
        "bufferViews": g.views,
        "accessors": g.accessors,
    });
    let out = g.finish(&doc);
    derma_core::atomic::write_bytes(path, &out)?;
    Ok(())
}
