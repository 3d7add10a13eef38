//! Triangle meshes with UVs: loading from OBJ (`tobj`) and glTF/GLB (`gltf`), unit detection,
//! vertex normals and MikkTSpace tangents (`bevy_mikktspace`, lives in derma-skin's normal map).

use crate::error::{CoreError, Result};
use glam::{Vec2, Vec3};
use std::path::Path;

/// An indexed triangle mesh with one UV set. Positions are in millimetres once
/// [`TriMesh::to_millimetres`] has been applied.
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals (computed when the file has none).
    pub normals: Vec<Vec3>,
    /// Texture coordinates per vertex, v up (OpenGL).
    pub uvs: Vec<Vec2>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// The length unit a mesh was authored in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LengthUnit {
    /// Millimetres.
    Mm,
    /// Centimetres.
    Cm,
    /// Metres.
    M,
}

impl LengthUnit {
    /// Millimetres per unit.
    pub fn to_mm(self) -> f32 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::Cm => 10.0,
            LengthUnit::M => 1000.0,
        }
    }

    /// The unit that puts a head or face of largest extent `extent` within [`HEAD_EXTENT_MM`]:
    /// millimetres, else centimetres, else metres; `None` when no unit does (fit it instead).
    pub fn for_head(extent: f32) -> Option<LengthUnit> {
        [LengthUnit::Mm, LengthUnit::Cm, LengthUnit::M]
            .into_iter()
            .find(|u| (HEAD_EXTENT_MM.0..=HEAD_EXTENT_MM.1).contains(&(extent * u.to_mm())))
    }

    /// Its name in words ("millimetres").
    pub fn long_name(self) -> &'static str {
        match self {
            LengthUnit::Mm => "millimetres",
            LengthUnit::Cm => "centimetres",
            LengthUnit::M => "metres",
        }
    }

    /// Its name as written in configs and reports.
    pub fn name(self) -> &'static str {
        match self {
            LengthUnit::Mm => "mm",
            LengthUnit::Cm => "cm",
            LengthUnit::M => "m",
        }
    }
}

/// Writes several meshes into one Wavefront OBJ, each a named object (`o NAME`) with positions,
/// UVs and normals (one index per corner), after a `# header` comment line; atomically.
pub fn write_obj_objects(path: &Path, header: &str, objects: &[(&str, &TriMesh)]) -> Result<()> {
    use std::fmt::Write;
    let size: usize = objects
        .iter()
        .map(|(_, m)| m.positions.len() * 80 + m.triangles.len() * 40)
        .sum();
    let mut s = String::with_capacity(size);
    let _ = writeln!(s, "# {header}");
    let mut base = 1usize;
    for &(name, m) in objects {
        let _ = writeln!(s, "o {name}");
        for p in &m.positions {
            let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
        }
        for t in &m.uvs {
            let _ = writeln!(s, "vt {} {}", t.x, t.y);
        }
        for n in &m.normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| i as usize + base);
            if m.uvs.is_empty() {
                let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
            } else {
                let _ = writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
            }
        }
        base += m.positions.len();
    }
    crate::atomic::write_bytes(path, s.as_bytes())
}

/// Largest bounding-box extent (mm) of a head or face mesh: from a face mask (~120 mm wide) to a
/// whole head with its neck (~300 mm tall), with a margin.
pub const HEAD_EXTENT_MM: (f32, f32) = (100.0, 350.0);

/// The extent a mesh in no recognisable unit is scaled to (mm): the vertex–gnathion height of an
/// adult head, about 215–230 mm (Farkas 1994, "Anthropometry of the Head and Face").
pub const NOMINAL_HEAD_EXTENT_MM: f32 = 225.0;

/// A fingerprint of a mesh's UV layout that survives the trips a mesh takes between files
/// (OBJ text, glTF's flipped v, vertex and triangle reordering) and ignores positions, so a
/// fitted or sculpted copy of a layout matches it: the triangle count, the signed UV area
/// (a flipped chart changes its sign), its area-weighted first and second moments and the
/// total UV edge length. Two layouts match within a relative 10⁻⁵; a texture set is only
/// right on a mesh whose layout matches the one it was painted on.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UvLayout {
    /// Triangles with UVs.
    pub triangles: usize,
    /// Σ signed UV area.
    pub signed_area: f64,
    /// Σ a·u, Σ a·v, Σ a·u², Σ a·u·v, Σ a·v² over triangles (a signed area, (u, v) centroid).
    pub moments: [f64; 5],
    /// Σ UV edge length (each triangle's three).
    pub edge_length: f64,
}

impl UvLayout {
    /// True when `other` is this layout up to float noise (relative 10⁻⁵).
    pub fn matches(&self, other: &UvLayout) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1e-3);
        self.triangles == other.triangles
            && close(self.signed_area, other.signed_area)
            && close(self.edge_length, other.edge_length)
            && self
                .moments
                .iter()
                .zip(&other.moments)
                .all(|(a, b)| close(*a, *b))
    }
}

impl TriMesh {
    /// An error naming the file unless the mesh has UVs.
    pub fn require_uvs(&self, path: &Path) -> Result<()> {
        if self.uvs.is_empty() {
            return Err(CoreError::Mesh {
                path: path.to_path_buf(),
                detail: "it has no texture coordinates (UVs); derma paints textures in UV space, so unwrap the mesh first (`derma photo unwrap` makes a single-chart UV layout)".into(),
            });
        }
        Ok(())
    }

    /// Triangles wound against their vertex normals: the geometric normal (b − a) × (c − a) of
    /// a counter-clockwise front face (glTF's and OBJ's convention) points away from the mean
    /// of its corners' normals. Degenerate triangles and meshes without normals count none.
    /// Renderers that cull or shade by winding (Blender's Cycles, engines) show these from
    /// behind.
    pub fn inward_triangles(&self) -> usize {
        if self.normals.len() != self.positions.len() {
            return 0;
        }
        self.triangles
            .iter()
            .filter(|t| {
                let g = self.face_cross(**t);
                let n: Vec3 = t.iter().map(|&i| self.normals[i as usize]).sum();
                g.length_squared() > 1e-20 && g.dot(n) < 0.0
            })
            .count()
    }

    /// (b − a) × (c − a) of triangle `t`: its geometric normal by winding, twice its area long.
    pub fn face_cross(&self, t: [u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        (b - a).cross(c - a)
    }

    /// Largest extent of the axis-aligned bounding box.
    pub fn extent(&self) -> f32 {
        let (lo, hi) = self.bounds();
        (hi - lo).max_element()
    }

    /// The axis-aligned bounding box (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }

    /// Scales positions from `unit` to millimetres.
    pub fn to_millimetres(&mut self, unit: LengthUnit) {
        self.scale(unit.to_mm());
    }

    /// Multiplies every position by `s`.
    pub fn scale(&mut self, s: f32) {
        for p in &mut self.positions {
            *p *= s;
        }
    }

    /// Total surface area (in the mesh's units squared).
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| 0.5 * self.face_cross(*t).length() as f64)
            .sum()
    }

    /// Writes the mesh as Wavefront OBJ (positions, UVs, normals; one index per corner), atomically.
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        write_obj_objects(path, "written by derma", &[("mesh", self)])
    }

    /// The fingerprint of the mesh's UV layout ([`UvLayout`]).
    pub fn uv_layout(&self) -> UvLayout {
        let (mut n, mut area, mut edges) = (0usize, 0.0f64, 0.0f64);
        let (mut m1, mut m2) = ([0.0f64; 2], [0.0f64; 3]);
        for t in &self.triangles {
            let Some(c) = t
                .iter()
                .map(|&i| self.uvs.get(i as usize).map(|u| [u.x as f64, u.y as f64]))
                .collect::<Option<Vec<_>>>()
            else {
                continue;
            };
            let a = 0.5
                * ((c[1][0] - c[0][0]) * (c[2][1] - c[0][1])
                    - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]));
            let g = [
                (c[0][0] + c[1][0] + c[2][0]) / 3.0,
                (c[0][1] + c[1][1] + c[2][1]) / 3.0,
            ];
            n += 1;
            area += a;
            m1[0] += a * g[0];
            m1[1] += a * g[1];
            m2[0] += a * g[0] * g[0];
            m2[1] += a * g[0] * g[1];
            m2[2] += a * g[1] * g[1];
            for k in 0..3 {
                let (p, q) = (c[k], c[(k + 1) % 3]);
                edges += ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
            }
        }
        UvLayout {
            triangles: n,
            signed_area: area,
            moments: [m1[0], m1[1], m2[0], m2[1], m2[2]],
            edge_length: edges,
        }
    }

    /// Recomputes area-weighted vertex normals (used when the file has none).
    pub fn compute_normals(&mut self) {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let f = self.face_cross(*t);
            for &i in t {
                n[i as usize] += f;
            }
        }
        self.normals = n.into_iter().map(|v| v.normalize_or(Vec3::Z)).collect();
    }
}

/// MikkTSpace tangents of a mesh, per triangle corner (xyz, sign).
pub fn mikktspace_tangents(mesh: &TriMesh) -> Vec<[f32; 4]> {
    struct G<'a> {
        m: &'a TriMesh,
        out: Vec<[f32; 4]>,
    }
    impl bevy_mikktspace::Geometry for G<'_> {
        fn num_faces(&self) -> usize {
            self.m.triangles.len()
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.m.positions[self.m.triangles[face][vert] as usize].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.m.normals[self.m.triangles[face][vert] as usize].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.m.uvs[self.m.triangles[face][vert] as usize].to_array()
        }
        fn set_tangent(
            &mut self,
            ts: Option<bevy_mikktspace::TangentSpace>,
            face: usize,
            vert: usize,
        ) {
            if let Some(ts) = ts {
                self.out[3 * face + vert] = ts.tangent_encoded();
            }
        }
    }
    let mut g = G {
        m: mesh,
        out: vec![[1.0, 0.0, 0.0, 1.0]; mesh.triangles.len() * 3],
    };
    // Degenerate input only leaves the default frame in place; it is not fatal.
    let _ = bevy_mikktspace::generate_tangents(&mut g);
    g.out
}

/// A mesh whose vertices each carry one tangent, for formats with per-vertex tangents (glTF's
/// TANGENT) and GPU vertex buffers: vertices whose corners got different MikkTSpace tangents
/// (UV seams, mirrored islands) are split. Returns the mesh, its tangents and, per new vertex,
/// the vertex of `mesh` it came from (to carry morph targets over).
pub fn split_by_tangent(mesh: &TriMesh, corner: &[[f32; 4]]) -> (TriMesh, Vec<[f32; 4]>, Vec<u32>) {
    assert_eq!(
        corner.len(),
        3 * mesh.triangles.len(),
        "one tangent per corner"
    );
    // Corners within 1e-3 (≈ 0.06°) share a vertex; the sign must match exactly.
    let same =
        |a: &[f32; 4], b: &[f32; 4]| a[3] == b[3] && (0..3).all(|k| (a[k] - b[k]).abs() < 1e-3);
    let n = mesh.positions.len();
    // Per original vertex: the (tangent, new index) variants seen so far.
    let mut variants: Vec<Vec<([f32; 4], u32)>> = vec![Vec::new(); n];
    let mut out = TriMesh::default();
    let mut tangents = Vec::new();
    let mut origin = Vec::new();
    for (f, tri) in mesh.triangles.iter().enumerate() {
        let mut new_tri = [0u32; 3];
        for (k, &v) in tri.iter().enumerate() {
            let t = corner[3 * f + k];
            let slot = &mut variants[v as usize];
            let idx = match slot.iter().find(|(u, _)| same(u, &t)) {
                Some(&(_, i)) => i,
                None => {
                    let i = out.positions.len() as u32;
                    out.positions.push(mesh.positions[v as usize]);
                    if let Some(nm) = mesh.normals.get(v as usize) {
                        out.normals.push(*nm);
                    }
                    if let Some(uv) = mesh.uvs.get(v as usize) {
                        out.uvs.push(*uv);
                    }
                    tangents.push(t);
                    origin.push(v);
                    slot.push((t, i));
                    i
                }
            };
            new_tri[k] = idx;
        }
        out.triangles.push(new_tri);
    }
    (out, tangents, origin)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The UV fingerprint ignores vertex order, triangle order, the starting corner, positions
    /// and float noise, and changes with a moved UV, a flipped winding or a changed topology.
    #[test]
    fn uv_layout_names_the_layout_not_the_file() {
        let m = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::new(0.9, 0.8)],
            triangles: vec![[0, 1, 2], [1, 3, 2]],
        };
        let h = m.uv_layout();
        // Vertices renumbered (3 ↔ 0), triangles swapped and rotated, positions moved, v
        // flipped twice through f32 (glTF's convention).
        let flip = |v: f32| 1.0 - (1.0 - v);
        let r = TriMesh {
            positions: vec![Vec3::splat(9.0), Vec3::X, Vec3::Y, Vec3::ZERO],
            normals: vec![Vec3::Z; 4],
            uvs: vec![
                Vec2::new(0.9, flip(0.8)),
                Vec2::X,
                Vec2::new(0.0, flip(1.0)),
                Vec2::ZERO,
            ],
            triangles: vec![[0, 2, 1], [2, 3, 1]],
        };
        assert!(r.uv_layout().matches(&h));
        let mut moved = m.clone();
        moved.uvs[3] = Vec2::new(0.9, 0.79);
        assert!(!moved.uv_layout().matches(&h));
        let mut flipped = m.clone();
        flipped.triangles[0] = [0, 2, 1];
        assert!(!flipped.uv_layout().matches(&h));
        let mut fewer = m.clone();
        fewer.triangles.pop();
        assert!(!fewer.uv_layout().matches(&h));
    }

    #[test]
    fn split_by_tangent_keeps_shared_corners_and_splits_mirrored_ones() {
        // Two triangles sharing an edge; the second's UVs are mirrored, so its tangent flips.
        let m = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            normals: vec![Vec3::Z; 4],
            // Vertex 3 at (1, 1) maps to UV (0, 0): the second UV triangle winds the other way.
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ZERO],
            triangles: vec![[0, 1, 2], [1, 3, 2]],
        };
        let t = mikktspace_tangents(&m);
        let (s, tan, origin) = split_by_tangent(&m, &t);
        assert_eq!(s.triangles.len(), 2);
        assert_eq!(tan.len(), s.positions.len());
        // Every corner's tangent is kept exactly at its (new) vertex.
        for (f, tri) in s.triangles.iter().enumerate() {
            for k in 0..3 {
                assert_eq!(tan[tri[k] as usize], t[3 * f + k]);
                assert_eq!(
                    s.positions[tri[k] as usize],
                    m.positions[origin[tri[k] as usize] as usize]
                );
            }
        }
        // The shared edge's vertices differ in tangent between the triangles → split.
        assert!(s.positions.len() > 4, "{}", s.positions.len());
        // A mesh with consistent UVs is not split at all.
        let mut c = m.clone();
        c.uvs[3] = Vec2::ONE;
        let (s2, _, _) = split_by_tangent(&c, &mikktspace_tangents(&c));
        assert_eq!(s2.positions.len(), 4);
    }

    #[test]
    fn head_units_follow_the_head_size_range() {
        assert_eq!(LengthUnit::for_head(0.22), Some(LengthUnit::M));
        assert_eq!(LengthUnit::for_head(15.0), Some(LengthUnit::Cm));
        assert_eq!(LengthUnit::for_head(230.0), Some(LengthUnit::Mm));
        // A head scan whose largest extent is 8.6 units is 86 mm in cm and 8.6 m in metres:
        // no unit makes it a head, so it is fitted.
        assert_eq!(LengthUnit::for_head(8.6), None);
        assert_eq!(LengthUnit::for_head(2.0), None);
    }

    #[test]
    fn obj_without_uvs_is_a_clear_error() {
        let d = derma_test_support::scratch_dir("mesh");
        let p = d.join("nouv.obj");
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let e = TriMesh::load(&p).unwrap_err().to_string();
        assert!(
            e.contains("nouv.obj") && e.contains("texture coordinates"),
            "{e}"
        );
        // Geometry alone loads (for the tools that make UVs), and writes back without UVs.
        let g = TriMesh::load_geometry(&p).unwrap();
        assert!(g.uvs.is_empty() && g.normals.len() == 3);
        let pg = d.join("geom.obj");
        g.write_obj(&pg).unwrap();
        let g2 = TriMesh::load_geometry(&pg).unwrap();
        assert_eq!(g2.positions, g.positions);
        assert!(g2.uvs.is_empty());
        let p2 = d.join("ok.obj");
        std::fs::write(
            &p2,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
        )
        .unwrap();
        let m = TriMesh::load(&p2).unwrap();
        assert_eq!(m.triangles.len(), 1);
        // Round trip through the writer.
        let p3 = d.join("rt.obj");
        m.write_obj(&p3).unwrap();
        let back = TriMesh::load(&p3).unwrap();
        assert_eq!(back.positions, m.positions);
        assert_eq!(back.uvs, m.uvs);
        assert!((m.area() - 0.5).abs() < 1e-9);
        assert!((m.normals[0] - Vec3::Z).length() < 1e-6);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
