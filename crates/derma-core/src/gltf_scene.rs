//! glTF 2.0 files as the web ships them: every node's primitives placed by the node transforms
//! (skinned meshes at their bind pose), geometry quantized (`KHR_mesh_quantization`) or
//! compressed (`EXT_meshopt_compression`, `KHR_draco_mesh_compression`), UVs under
//! `KHR_texture_transform`, morph targets with their names; extensions of textures and
//! materials never block the geometry. Follows the glTF 2.0 specification (§3.5 buffers, §3.6
//! accessors, §3.7.2 meshes, §3.7.3 skins) and the Khronos and EXT extension specifications.

use crate::error::{CoreError, Result};
use crate::mesh::TriMesh;
use crate::mesh_parts::{MorphTargets, Part};
use glam::{Mat3, Mat4, Quat, Vec2, Vec3};
use gltf::json::{self, validation::Validate};
use std::path::{Path, PathBuf};

/// Extensions derma reads, or that concern only what derma does not read (textures,
/// materials, lights), so they never block the geometry.
fn extension_is_understood(name: &str) -> bool {
    matches!(
        name,
        "KHR_mesh_quantization"
            | "EXT_meshopt_compression"
            | "KHR_draco_mesh_compression"
            | "KHR_texture_transform"
            | "KHR_texture_basisu"
            | "EXT_texture_webp"
            | "EXT_texture_avif"
            | "MSFT_texture_dds"
            | "KHR_lights_punctual"
    ) || name.starts_with("KHR_materials_")
}

/// A primitive's geometry as read: positions, normals, UVs and indices.
type Geometry = (
    Vec<Vec3>,
    Option<Vec<Vec3>>,
    Option<Vec<Vec2>>,
    Option<Vec<u32>>,
);

/// Largest element count an accessor may declare (2²⁸): more is a damaged file, refused before
/// any allocation.
const MAX_COUNT: u64 = 1 << 28;

/// Reads every triangle primitive of a glTF or GLB file's default scene (or of every root node
/// when it names none).
pub fn read(path: &Path) -> Result<Vec<Part>> {
    let bytes = std::fs::read(path).map_err(|e| CoreError::Read {
        path: path.to_path_buf(),
        source: e,
    })?;
    let doc = Doc::parse(path, &bytes)?;
    doc.parts()
}

struct Doc {
    path: PathBuf,
    root: json::Root,
    buffers: Vec<Option<Vec<u8>>>,
}

impl Doc {
    fn err(&self, detail: impl Into<String>) -> CoreError {
        mesh_err(&self.path, detail)
    }

    fn parse(path: &Path, bytes: &[u8]) -> Result<Doc> {
        let (json_bytes, bin): (Vec<u8>, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
            let glb = gltf::binary::Glb::from_slice(bytes)
                .map_err(|e| mesh_err(path, format!("not a valid GLB container ({e})")))?;
            (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
        } else {
            (bytes.to_vec(), None)
        };
        let root = json::Root::from_slice(&json_bytes)
            .map_err(|e| mesh_err(path, format!("glTF JSON error: {e}")))?;
        check(path, &root)?;
        let buffers = load_buffers(path, &root, bin)?;
        Ok(Doc {
            path: path.to_path_buf(),
            root,
            buffers,
        })
    }

    /// The parts of every mesh node reachable from the scene, in node order.
    fn parts(&self) -> Result<Vec<Part>> {
        let roots: Vec<usize> = match self
            .root
            .scene
            .or_else(|| (!self.root.scenes.is_empty()).then(|| json::Index::new(0)))
        {
            Some(s) => self.root.scenes[s.value()]
                .nodes
                .iter()
                .map(|n| n.value())
                .collect(),
            None => {
                // No scene: the nodes no other node lists as a child.
                let mut child = vec![false; self.root.nodes.len()];
                for n in &self.root.nodes {
                    for c in n.children.iter().flatten() {
                        child[c.value()] = true;
                    }
                }
                (0..self.root.nodes.len()).filter(|&i| !child[i]).collect()
            }
        };
        let world = self.world_transforms(&roots)?;
        let names = self.node_names();
        let mut parts = Vec::new();
        for (i, node) in self.root.nodes.iter().enumerate() {
            let (Some(m), Some(xf)) = (node.mesh, world[i]) else {
                continue;
            };
            let xf = match node.skin {
                Some(s) => self.bind_transform(s.value(), &world)?,
                None => xf,
            };
            let mesh = &self.root.meshes[m.value()];
            let targets = target_names(mesh);
            for (k, prim) in mesh.primitives.iter().enumerate() {
                let within = |e: CoreError| match e {
                    CoreError::Mesh { path, detail } => CoreError::Mesh {
                        path,
                        detail: format!("mesh {} primitive {k}: {detail}", m.value()),
                    },
                    other => other,
                };
                if let Some(geometry) = self.primitive(prim, xf, &targets).map_err(within)? {
                    parts.push(Part {
                        node: names[i].clone(),
                        node_index: i,
                        mesh: mesh
                            .name
                            .clone()
                            .unwrap_or_else(|| format!("mesh {}", m.value())),
                        material: prim
                            .material
                            .and_then(|k| self.root.materials[k.value()].name.clone())
                            .unwrap_or_default(),
                        geometry: geometry.0,
                        targets: geometry.1,
                    });
                }
            }
        }
        Ok(parts)
    }

    /// Each node's name: its own, else its nearest named ancestor's (optimisers such as gltfpack
    /// move a named node's mesh to an unnamed child), else `node N`.
    fn node_names(&self) -> Vec<String> {
        let nodes = &self.root.nodes;
        let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            for c in n.children.iter().flatten() {
                parent[c.value()] = Some(i);
            }
        }
        (0..nodes.len())
            .map(|i| {
                let mut at = Some(i);
                // At most one step per node: a cycle (refused elsewhere) cannot loop here.
                for _ in 0..nodes.len() {
                    let Some(k) = at else { break };
                    if let Some(n) = &nodes[k].name {
                        return n.clone();
                    }
                    at = parent[k];
                }
                format!("node {i}")
            })
            .collect()
    }

    /// Each node's world transform (None for nodes outside the scene); refuses cycles.
    fn world_transforms(&self, roots: &[usize]) -> Result<Vec<Option<Mat4>>> {
        let nodes = &self.root.nodes;
        let mut world: Vec<Option<Mat4>> = vec![None; nodes.len()];
        let mut stack: Vec<(usize, Mat4)> = roots.iter().map(|&r| (r, Mat4::IDENTITY)).collect();
        while let Some((i, parent)) = stack.pop() {
            if world[i].is_some() {
                return Err(self.err(format!(
                    "node {i} is reached twice: the node hierarchy has a cycle or a shared child"
                )));
            }
            let xf = parent * local_transform(&nodes[i]);
            world[i] = Some(xf);
            for c in nodes[i].children.iter().flatten() {
                stack.push((c.value(), xf));
            }
        }
        Ok(world)
    }

    /// A skinned mesh's placement at its bind pose (§3.7.3: the skinned node's own transform is
    /// ignored): a joint's world transform after its inverse bind matrix, which every joint
    /// still in its bind pose shares — the one most joints agree on (a posed jaw or head joint
    /// does not move the mesh). Joints outside the scene are not counted.
    fn bind_transform(&self, skin: usize, world: &[Option<Mat4>]) -> Result<Mat4> {
        let s = &self.root.skins[skin];
        if s.joints.is_empty() {
            return Err(self.err(format!("skin {skin} has no joints")));
        }
        let ibm = match s.inverse_bind_matrices {
            Some(a) => {
                let (v, n) = self.accessor(a.value())?;
                if n != 16 || v.len() < 16 * s.joints.len() {
                    return Err(self.err(format!(
                        "skin {skin}'s inverse bind matrices are not one 4×4 matrix per joint"
                    )));
                }
                v.chunks_exact(16)
                    .map(|c| Mat4::from_cols_array(&std::array::from_fn(|k| c[k] as f32)))
                    .collect()
            }
            None => vec![Mat4::IDENTITY; s.joints.len()],
        };
        let placed: Vec<Mat4> = s
            .joints
            .iter()
            .zip(&ibm)
            .filter_map(|(j, m)| world.get(j.value()).copied().flatten().map(|w| w * *m))
            .collect();
        let agree = |a: &Mat4, b: &Mat4| {
            let tol = 1e-4
                * a.abs()
                    .to_cols_array()
                    .iter()
                    .fold(1.0f32, |m, x| m.max(*x));
            a.abs_diff_eq(*b, tol)
        };
        placed
            .iter()
            .rev() // the first of equals
            .max_by_key(|a| placed.iter().filter(|b| agree(a, b)).count())
            .copied()
            .ok_or_else(|| self.err(format!("skin {skin}'s joints are not in the scene")))
    }

    /// A triangle primitive as a mesh with its morph targets (None for points and lines).
    fn primitive(
        &self,
        prim: &json::mesh::Primitive,
        xf: Mat4,
        names: &[String],
    ) -> Result<Option<(TriMesh, MorphTargets)>> {
        use json::mesh::Mode;
        let mode = match prim.mode {
            json::validation::Checked::Valid(m) => m,
            json::validation::Checked::Invalid => {
                return Err(self.err("a primitive's mode is invalid"))
            }
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            return Ok(None);
        }
        let draco = prim
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("KHR_draco_mesh_compression"));
        let (tex_set, uv_xf) = self.texture_transform(prim);
        let (positions, normals, uvs, indices) = match draco {
            Some(ext) => self.draco(ext, tex_set)?,
            None => self.attributes(prim, tex_set)?,
        };
        let n = positions.len();
        if normals.as_ref().is_some_and(|v| v.len() != n)
            || uvs.as_ref().is_some_and(|v| v.len() != n)
        {
            return Err(self.err("a primitive's attributes have different counts"));
        }
        let indices = indices.unwrap_or_else(|| (0..n as u32).collect());
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(self.err(format!(
                "a primitive's index {bad} refers to a vertex that does not exist ({n} vertices)"
            )));
        }
        let mesh = placed(
            xf,
            &positions,
            normals,
            uvs,
            uv_xf,
            assemble(mode, &indices),
        );
        let targets = match draco {
            // The encoders leave primitives with targets uncompressed; one that is not would
            // lose them here, which is refused rather than done silently.
            Some(_) if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) => {
                return Err(self.err(
                    "a Draco-compressed primitive has morph targets, which derma does not read under Draco compression: store that mesh uncompressed",
                ))
            }
            Some(_) => Vec::new(),
            None => self.morph_targets(prim, Mat3::from_mat4(xf), n, names)?,
        };
        Ok(Some((mesh, targets)))
    }

    /// An uncompressed primitive's positions, normals, UVs (set `tex_set`) and indices.
    fn attributes(&self, prim: &json::mesh::Primitive, tex_set: u32) -> Result<Geometry> {
        use json::mesh::Semantic;
        let attr = |s: Semantic| {
            prim.attributes
                .get(&json::validation::Checked::Valid(s))
                .map(|a| a.value())
        };
        let Some(p) = attr(Semantic::Positions) else {
            return Err(self.err("a primitive has no POSITION attribute"));
        };
        let normals = attr(Semantic::Normals).map(|n| self.vec3s(n)).transpose()?;
        let uvs = attr(Semantic::TexCoords(tex_set))
            .map(|t| self.vec2s(t))
            .transpose()?;
        let indices = prim.indices.map(|i| self.indices(i.value())).transpose()?;
        Ok((self.vec3s(p)?, normals, uvs, indices))
    }

    /// A primitive's morph targets' position offsets, turned by the node's linear map.
    fn morph_targets(
        &self,
        prim: &json::mesh::Primitive,
        linear: Mat3,
        n: usize,
        names: &[String],
    ) -> Result<MorphTargets> {
        let mut targets = Vec::new();
        for (k, t) in prim.targets.iter().flatten().enumerate() {
            let Some(p) = t.positions else { continue };
            let d = self.vec3s(p.value())?;
            if d.len() != n {
                return Err(self.err(format!(
                    "morph target {k} has {} offsets for {n} vertices",
                    d.len()
                )));
            }
            let name = names
                .get(k)
                .cloned()
                .unwrap_or_else(|| format!("target {k}"));
            targets.push((name, d.iter().map(|v| linear * *v).collect()));
        }
        Ok(targets)
    }

    /// The UV set and transform of the primitive's material: its base colour texture's, else
    /// the first texture the material has (`KHR_texture_transform`; gltfpack stores quantized
    /// UVs' dequantization there).
    fn texture_transform(&self, prim: &json::mesh::Primitive) -> (u32, UvTransform) {
        let Some(m) = prim.material else {
            return (0, UvTransform::IDENTITY);
        };
        let mat = &self.root.materials[m.value()];
        let pbr = &mat.pbr_metallic_roughness;
        let infos = [
            pbr.base_color_texture.as_ref(),
            pbr.metallic_roughness_texture.as_ref(),
            mat.emissive_texture.as_ref(),
        ];
        let info = |i: &json::texture::Info| {
            let t = i
                .extensions
                .as_ref()
                .and_then(|e| e.texture_transform.as_ref());
            match t {
                Some(t) => (
                    t.tex_coord.unwrap_or(i.tex_coord),
                    UvTransform {
                        offset: Vec2::from(t.offset.0),
                        rotation: t.rotation.0,
                        scale: Vec2::from(t.scale.0),
                    },
                ),
                None => (i.tex_coord, UvTransform::IDENTITY),
            }
        };
        if let Some(i) = infos.into_iter().flatten().next() {
            return info(i);
        }
        // The normal and occlusion textures keep their extensions as raw JSON.
        let raw = mat
            .normal_texture
            .as_ref()
            .map(|n| (n.tex_coord, n.extensions.as_ref().map(|e| &e.others)))
            .or_else(|| {
                mat.occlusion_texture
                    .as_ref()
                    .map(|o| (o.tex_coord, o.extensions.as_ref().map(|e| &e.others)))
            });
        match raw {
            Some((set, others)) => {
                let t = others
                    .and_then(|o| o.get("KHR_texture_transform"))
                    .and_then(|v| serde_json::from_value::<RawTransform>(v.clone()).ok());
                match t {
                    Some(t) => (t.tex_coord.unwrap_or(set), t.into()),
                    None => (set, UvTransform::IDENTITY),
                }
            }
            None => (0, UvTransform::IDENTITY),
        }
    }
}

/// `KHR_texture_transform` as raw JSON (on normal and occlusion textures).
#[derive(serde::Deserialize)]
#[serde(rename_all = "camelCase")]
struct RawTransform {
    #[serde(default)]
    offset: [f32; 2],
    #[serde(default)]
    rotation: f32,
    #[serde(default = "unit_scale")]
    scale: [f32; 2],
    tex_coord: Option<u32>,
}

fn unit_scale() -> [f32; 2] {
    [1.0, 1.0]
}

impl From<RawTransform> for UvTransform {
    fn from(t: RawTransform) -> Self {
        UvTransform {
            offset: Vec2::from(t.offset),
            rotation: t.rotation,
            scale: Vec2::from(t.scale),
        }
    }
}

/// `KHR_texture_transform`'s affine map of UVs (glTF's v-down convention): scale, then a
/// rotation, then the offset, `uv' = T R S uv` with `u' = cos r·u + sin r·v`,
/// `v' = −sin r·u + cos r·v` — the UVs turned counter-clockwise as the image shows them (v
/// down), which is what the specification's example asks (offset (0, 1), rotation π/2, scale
/// ½: the image's lower-left quadrant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Offset (in UV units).
    pub offset: Vec2,
    /// Rotation (radians).
    pub rotation: f32,
    /// Scale.
    pub scale: Vec2,
}

impl UvTransform {
    /// The identity.
    pub const IDENTITY: UvTransform = UvTransform {
        offset: Vec2::ZERO,
        rotation: 0.0,
        scale: Vec2::ONE,
    };

    /// Applies it to a UV.
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let s = uv * self.scale;
        let (sin, cos) = self.rotation.sin_cos();
        Vec2::new(cos * s.x + sin * s.y, -sin * s.x + cos * s.y) + self.offset
    }
}

fn mesh_err(path: &Path, detail: impl Into<String>) -> CoreError {
    CoreError::Mesh {
        path: path.to_path_buf(),
        detail: detail.into(),
    }
}

/// Validates the document's references (so later indexing cannot fail) and its required
/// extensions.
fn check(path: &Path, root: &json::Root) -> Result<()> {
    let mut errors: Vec<String> = Vec::new();
    root.validate(root, json::Path::new, &mut |p, e| {
        let p = p().to_string();
        // Required extensions are judged below, by what derma reads; an accessor without a
        // buffer view holds zeros (§3.6.2.1), or its data lies in a compressed primitive.
        // Textures, images and samplers (and materials' references to them) are never read:
        // they never block geometry.
        let zeros = p.starts_with("accessors[") && p.ends_with("].bufferView");
        let unread = ["extensionsRequired", "textures", "images", "samplers"]
            .iter()
            .any(|k| p.starts_with(k))
            || (p.starts_with("materials[") && p.contains("Texture"));
        if !unread && !zeros {
            errors.push(format!("{p}: {e}"));
        }
    });
    if let Some(first) = errors.first() {
        return Err(mesh_err(
            path,
            format!(
                "invalid glTF ({} problems; the first: {first})",
                errors.len()
            ),
        ));
    }
    if let Some(x) = root
        .extensions_required
        .iter()
        .find(|x| !extension_is_understood(x))
    {
        return Err(mesh_err(
            path,
            format!("it requires the glTF extension {x}, which derma does not read"),
        ));
    }
    Ok(())
}

/// Each buffer's bytes: the GLB's binary chunk, a data URI or a file beside the glTF; `None`
/// for an `EXT_meshopt_compression` fallback buffer, which holds no data.
fn load_buffers(
    path: &Path,
    root: &json::Root,
    mut bin: Option<Vec<u8>>,
) -> Result<Vec<Option<Vec<u8>>>> {
    let base = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::with_capacity(root.buffers.len());
    for (i, b) in root.buffers.iter().enumerate() {
        let fallback = b
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("EXT_meshopt_compression"))
            .and_then(|v| v.get("fallback"))
            .and_then(|v| v.as_bool())
            .unwrap_or(false);
        let data = match b.uri.as_deref() {
            None if fallback => None,
            None => Some(bin.take().ok_or_else(|| {
                mesh_err(
                    path,
                    format!("buffer {i} has no URI and there is no GLB binary chunk for it"),
                )
            })?),
            Some(uri) if uri.starts_with("data:") => {
                Some(decode_data_uri(uri).ok_or_else(|| {
                    mesh_err(path, format!("buffer {i}'s data URI is not base64 data"))
                })?)
            }
            Some(uri) => {
                let file = base.join(percent_decode(uri));
                Some(std::fs::read(&file).map_err(|e| {
                    mesh_err(
                        path,
                        format!("buffer {i}: cannot read '{}' ({e})", file.display()),
                    )
                })?)
            }
        };
        if let Some(d) = &data {
            if (d.len() as u64) < b.byte_length.0 {
                return Err(mesh_err(
                    path,
                    format!(
                        "buffer {i} holds {} bytes; its byteLength says {}",
                        d.len(),
                        b.byte_length.0
                    ),
                ));
            }
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes of a `data:…;base64,` URI (RFC 2397, RFC 4648 §4).
fn decode_data_uri(uri: &str) -> Option<Vec<u8>> {
    let (_, b64) = uri.split_once(";base64,")?;
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let s: Vec<u8> = b64
        .bytes()
        .filter(|&c| c != b'=' && !c.is_ascii_whitespace())
        .collect();
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    for chunk in s.chunks(4) {
        let mut acc = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            acc |= value(c)? << (18 - 6 * k);
        }
        let bytes = acc.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    Some(out)
}

/// A relative URI's `%XX` escapes decoded (RFC 3986 §2.1).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let Some(v) = uri
                .get(i + 1..i + 3)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
            {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A node's local transform: its matrix, else translation · rotation · scale (§3.5.3).
fn local_transform(n: &json::Node) -> Mat4 {
    if let Some(m) = n.matrix {
        return Mat4::from_cols_array(&m);
    }
    let t = Vec3::from(n.translation.unwrap_or([0.0; 3]));
    let r = n
        .rotation
        .map(|q| Quat::from_array(q.0).normalize())
        .unwrap_or(Quat::IDENTITY);
    let s = Vec3::from(n.scale.unwrap_or([1.0; 3]));
    Mat4::from_scale_rotation_translation(s, r, t)
}

/// The morph targets' names, from the mesh's `extras.targetNames` (the de-facto convention of
/// Blender, three.js and gltfpack).
fn target_names(mesh: &json::Mesh) -> Vec<String> {
    #[derive(serde::Deserialize)]
    struct Extras {
        #[serde(rename = "targetNames", default)]
        target_names: Vec<String>,
    }
    mesh.extras
        .as_ref()
        .and_then(|raw| serde_json::from_str::<Extras>(raw.get()).ok())
        .map(|e| e.target_names)
        .unwrap_or_default()
}

/// A primitive's mesh placed by its node's transform: normals by the inverse transpose (computed
/// where it has none), UVs through the material's texture transform and turned to derma's v up,
/// the winding kept front-facing under a mirroring transform.
fn placed(
    xf: Mat4,
    positions: &[Vec3],
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    uv_xf: UvTransform,
    mut triangles: Vec<[u32; 3]>,
) -> TriMesh {
    if xf.determinant() < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    let normal_xf = Mat3::from_mat4(xf).inverse().transpose();
    let mut mesh = TriMesh {
        positions: positions.iter().map(|p| xf.transform_point3(*p)).collect(),
        normals: Vec::new(),
        // glTF puts v = 0 at the top of the image; derma uses OpenGL's v up.
        uvs: uvs
            .unwrap_or_default()
            .into_iter()
            .map(|uv| {
                let q = uv_xf.apply(uv);
                Vec2::new(q.x, 1.0 - q.y)
            })
            .collect(),
        triangles,
    };
    match normals {
        Some(nv) => {
            mesh.normals = nv
                .iter()
                .map(|v| (normal_xf * *v).normalize_or(Vec3::Z))
                .collect()
        }
        None => mesh.compute_normals(),
    }
    mesh
}

/// Triangles from a primitive's index list in its mode (§3.7.2.1).
fn assemble(mode: json::mesh::Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    use json::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    }
}

mod accessors;
mod compressed;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_transforms_follow_the_extension() {
        // The specification's example: offset (0, 1), rotation π/2, scale ½ maps the unit
        // square onto the image's lower-left quadrant, u in [0, ½], v in [½, 1].
        let t = UvTransform {
            offset: Vec2::new(0.0, 1.0),
            rotation: std::f32::consts::FRAC_PI_2,
            scale: Vec2::splat(0.5),
        };
        for (uv, want) in [
            (Vec2::ZERO, Vec2::new(0.0, 1.0)),
            (Vec2::X, Vec2::new(0.0, 0.5)),
            (Vec2::Y, Vec2::new(0.5, 1.0)),
            (Vec2::ONE, Vec2::new(0.5, 0.5)),
        ] {
            assert!(
                (t.apply(uv) - want).length() < 1e-6,
                "{uv} → {}",
                t.apply(uv)
            );
        }
        // Its second: offset (0, 1), scale (1, −1) flips v.
        let flip = UvTransform {
            offset: Vec2::new(0.0, 1.0),
            rotation: 0.0,
            scale: Vec2::new(1.0, -1.0),
        };
        assert!((flip.apply(Vec2::new(0.3, 0.2)) - Vec2::new(0.3, 0.8)).length() < 1e-6);
        assert_eq!(
            UvTransform::IDENTITY.apply(Vec2::new(0.3, 0.7)),
            Vec2::new(0.3, 0.7)
        );
    }

    #[test]
    fn data_uris_and_escaped_names_decode() {
        // RFC 4648's test vectors, padded and not.
        for (b64, text) in [
            ("Zm9vYmFy", "foobar"),
            ("Zm9vYg==", "foob"),
            ("Zg==", "f"),
            ("", ""),
        ] {
            let uri = format!("data:application/octet-stream;base64,{b64}");
            assert_eq!(decode_data_uri(&uri).unwrap(), text.as_bytes());
        }
        assert!(decode_data_uri("data:application/octet-stream;base64,Zm9v!").is_none());
        assert!(decode_data_uri("data:text/plain,hello").is_none());
        assert_eq!(percent_decode("my%20head.bin"), "my head.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("a%zzb"), "a%zzb");
    }

    #[test]
    fn strips_and_fans_become_triangles() {
        use json::mesh::Mode;
        assert_eq!(
            assemble(Mode::TriangleStrip, &[0, 1, 2, 3, 4]),
            vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]
        );
        assert_eq!(
            assemble(Mode::TriangleFan, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [0, 2, 3]]
        );
    }
}
