//! Mesh files read: OBJ (`tobj`, split by object and material) and glTF/GLB
//! ([`crate::gltf_scene`]) into parts, the skin chosen among them ([`crate::mesh_parts`]), and
//! the file's own vertex order for topology-indexed landmarks.

use crate::error::{CoreError, Result};
use crate::mesh::TriMesh;
use crate::mesh_parts::{Chosen, Part, PartChoice};
use glam::{Vec2, Vec3};
use std::path::Path;

/// The vertex positions of a mesh file in the file's own order (OBJ `v` lines; glTF/GLB the
/// accessor order of the part `choice` picks, UVs or not), unscaled: what topology-indexed
/// landmarks (MediaPipe's 468 points) refer to. Loading for painting may reorder vertices (it
/// splits them at UV seams).
pub fn file_positions(path: &Path, choice: &PartChoice) -> Result<Vec<Vec3>> {
    let is_obj = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if !is_obj {
        return Ok(TriMesh::load_part(path, choice)?.0.positions);
    }
    let text = std::fs::read_to_string(path).map_err(|e| CoreError::Read {
        path: path.to_path_buf(),
        source: e,
    })?;
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .enumerate()
        .map(|(i, l)| {
            let v: Vec<f32> = l
                .split_whitespace()
                .take(3)
                .filter_map(|t| t.parse().ok())
                .collect();
            match v[..] {
                [x, y, z] => Ok(Vec3::new(x, y, z)),
                _ => Err(CoreError::Mesh {
                    path: path.to_path_buf(),
                    detail: format!("vertex {} is not three numbers: 'v {l}'", i + 1),
                }),
            }
        })
        .collect()
}

impl TriMesh {
    /// Loads an OBJ, glTF or GLB file (by extension); it must have UVs.
    pub fn load(path: &Path) -> Result<TriMesh> {
        let mesh = Self::load_geometry(path)?;
        mesh.require_uvs(path)?;
        Ok(mesh)
    }

    /// Loads an OBJ, glTF or GLB file (by extension) whether or not it has UVs: without them
    /// `uvs` is empty (for the tools that make UVs, such as `derma photo unwrap`). A file of
    /// several parts is read as [`crate::mesh_parts::choose`] picks its skin.
    pub fn load_geometry(path: &Path) -> Result<TriMesh> {
        Ok(Self::load_part(path, &PartChoice::Auto)?.0)
    }

    /// Loads the parts `choice` picks of an OBJ, glTF or GLB file (UVs optional), and says
    /// which.
    pub fn load_part(path: &Path, choice: &PartChoice) -> Result<(TriMesh, Chosen)> {
        let parts = load_parts(path)?;
        let chosen = crate::mesh_parts::choose(path, &parts, choice)?;
        let (mesh, _) = crate::mesh_parts::merge(&parts, &chosen.parts);
        mesh.validate(path)?;
        Ok((mesh, chosen))
    }

    fn validate(&self, path: &Path) -> Result<()> {
        let err = |detail: String| {
            Err(CoreError::Mesh {
                path: path.to_path_buf(),
                detail,
            })
        };
        if self.triangles.is_empty() {
            return err("it contains no triangles".into());
        }
        if !self.uvs.is_empty() && self.uvs.len() != self.positions.len() {
            return err(
                "only some vertices have texture coordinates (UVs); give every vertex one, or none"
                    .into(),
            );
        }
        let n = self.positions.len() as u32;
        if self.triangles.iter().any(|t| t.iter().any(|&i| i >= n)) {
            return err("a triangle refers to a vertex that does not exist".into());
        }
        if self.positions.iter().any(|p| !p.is_finite()) || self.uvs.iter().any(|p| !p.is_finite())
        {
            return err("it contains NaN or infinite coordinates".into());
        }
        Ok(())
    }
}

/// Every part of an OBJ, glTF or GLB file (by extension), in the file's frame and units.
pub fn load_parts(path: &Path) -> Result<Vec<Part>> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "obj" => load_obj(path),
        "gltf" | "glb" => crate::gltf_scene::read(path),
        _ => Err(CoreError::Mesh {
            path: path.to_path_buf(),
            detail: format!("unknown extension '.{ext}'; expected .obj, .gltf or .glb"),
        }),
    }
}

/// An OBJ's objects, each split by material (`usemtl`): the material names come from the OBJ
/// itself, so a missing `.mtl` file changes nothing.
fn load_obj(path: &Path) -> Result<Vec<Part>> {
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let text = std::fs::read(path).map_err(|e| CoreError::Read {
        path: path.to_path_buf(),
        source: e,
    })?;
    // The materials the OBJ uses, by name, stand in for its library.
    let mut used: Vec<String> = Vec::new();
    for line in text.split(|&b| b == b'\n') {
        let line = String::from_utf8_lossy(line);
        if let Some(m) = line.trim_start().strip_prefix("usemtl") {
            let m = m.trim().to_string();
            if !m.is_empty() && !used.contains(&m) {
                used.push(m);
            }
        }
    }
    let library = || -> tobj::MTLLoadResult {
        let materials = used
            .iter()
            .map(|n| tobj::Material {
                name: n.clone(),
                ..Default::default()
            })
            .collect();
        let map = used
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        Ok((materials, map))
    };
    let mut reader = std::io::BufReader::new(&text[..]);
    let (models, _) =
        tobj::load_obj_buf(&mut reader, &opts, |_| library()).map_err(|e| CoreError::Mesh {
            path: path.to_path_buf(),
            detail: format!("OBJ parse error: {e}"),
        })?;
    let mut order: Vec<String> = Vec::new();
    let mut parts = Vec::with_capacity(models.len());
    for m in models {
        let node_index = match order.iter().position(|n| *n == m.name) {
            Some(k) => k,
            None => {
                order.push(m.name.clone());
                order.len() - 1
            }
        };
        let material = m
            .mesh
            .material_id
            .and_then(|k| used.get(k).cloned())
            .unwrap_or_default();
        let geometry = obj_geometry(&m.mesh);
        if geometry.triangles.is_empty() {
            continue;
        }
        parts.push(Part {
            node: m.name.clone(),
            node_index,
            mesh: m.name,
            material,
            geometry,
            targets: Vec::new(),
        });
    }
    Ok(parts)
}

/// One tobj model as a mesh (normals computed where it has none).
fn obj_geometry(m: &tobj::Mesh) -> TriMesh {
    let nv = m.positions.len() / 3;
    let mut mesh = TriMesh {
        positions: m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect(),
        ..TriMesh::default()
    };
    if m.texcoords.len() / 2 == nv {
        mesh.uvs = m
            .texcoords
            .chunks_exact(2)
            .map(|t| Vec2::new(t[0], t[1]))
            .collect();
    }
    mesh.triangles = m
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    if m.normals.len() / 3 == nv {
        mesh.normals = m
            .normals
            .chunks_exact(3)
            .map(|n| Vec3::new(n[0], n[1], n[2]).normalize_or(Vec3::Z))
            .collect();
    } else {
        mesh.compute_normals();
    }
    mesh
}
