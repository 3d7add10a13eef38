//! glTF as the web ships it, decoded against the mesh it was made from: MediaPipe's canonical
//! face (../shared/data, read by tobj from its OBJ) encoded by tools derma does not contain —
//! gltfpack 1.3.0 (KHR_mesh_quantization, EXT_meshopt_compression with its filters,
//! KHR_texture_transform) and glTF Transform 4.2.1 (KHR_draco_mesh_compression); a skinned,
//! morphing, node-transformed file before and after gltfpack. `scripts/make_gltf_fixtures.py`
//! made the files; tests/data/gltf/PROVENANCE.md says how.

use derma_core::mesh::TriMesh;
use derma_core::mesh_file::load_parts;
use derma_core::mesh_parts::Part;
use glam::Vec3;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/gltf")
        .join(name)
}

/// The source mesh, or None (the test skips) without the shared data.
fn truth() -> Option<TriMesh> {
    let p = derma_test_support::shared_data("canonical_face_model.obj")?;
    Some(TriMesh::load(&p).expect("the shared data's canonical face"))
}

fn one(name: &str) -> Part {
    let mut parts = load_parts(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(parts.len(), 1, "{name}");
    parts.remove(0)
}

/// Per decoded vertex, the nearest vertex of the truth: the largest position and UV errors.
fn worst(m: &TriMesh, t: &TriMesh) -> (f32, f32) {
    let (mut dp, mut du) = (0f32, 0f32);
    for (i, p) in m.positions.iter().enumerate() {
        let (j, d) = t
            .positions
            .iter()
            .enumerate()
            .map(|(j, q)| (j, q.distance(*p)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        dp = dp.max(d);
        if !m.uvs.is_empty() {
            du = du.max(m.uvs[i].distance(t.uvs[j]));
        }
    }
    (dp, du)
}

#[test]
fn quantized_compressed_and_transformed_uvs_decode_to_the_source() {
    let Some(t) = truth() else { return };
    let extent = t.extent();
    // gltfpack's defaults: 14-bit positions, 12-bit UVs (half a step of the range is the
    // largest rounding; UVs span about 0.06 of the texture here, so their error is tiny
    // unless the transform is ignored, when it is the whole scale of 13–16).
    let pos_step = extent / (1 << 14) as f32;
    for (name, vertices) in [
        ("face_plain.glb", 468),
        ("face_quantized.glb", 468),
        ("face_meshopt.glb", 468),
        ("face_meshopt_oct.glb", 489),
        ("face_meshopt_exp.glb", 468),
        ("face_draco.glb", 468),
        ("face_basisu.glb", 468),
    ] {
        let p = one(name);
        let m = &p.geometry;
        assert_eq!(m.triangles.len(), 898, "{name}");
        assert_eq!(m.positions.len(), vertices, "{name}");
        assert_eq!(m.uvs.len(), vertices, "{name}: every vertex keeps its UV");
        let (dp, du) = worst(m, &t);
        assert!(dp <= pos_step, "{name}: position error {dp} > {pos_step}");
        assert!(du <= 2e-4, "{name}: UV error {du}");
        assert!(
            m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3),
            "{name}"
        );
    }
    // The octahedral normals (gltfpack generated them at a 60° crease) face the way the
    // surface does: against the area-weighted normals of the decoded triangles.
    let p = one("face_meshopt_oct.glb");
    let mut own = p.geometry.clone();
    own.compute_normals();
    let agree = own
        .normals
        .iter()
        .zip(&p.geometry.normals)
        .filter(|(a, b)| a.dot(**b) > 0.8)
        .count();
    assert!(
        agree * 100 >= 95 * own.normals.len(),
        "{agree} of {}",
        own.normals.len()
    );
}

#[test]
fn skins_morph_targets_and_node_transforms_place_the_geometry() {
    let Some(t) = truth() else { return };
    for name in ["rig.gltf", "rig_meshopt.glb"] {
        let parts = load_parts(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(parts.len(), 2, "{name}");
        // The skinned face at its bind pose: its armature's −90° about X and ×100 undo how it
        // was stored; the skinned node's own ×7 is ignored (glTF 2.0 §3.7.3).
        let face = &parts[0];
        assert_eq!(
            face.node, "Head",
            "{name}: a mesh moved to an unnamed child keeps its node's name"
        );
        let (dp, _) = worst(&face.geometry, &t);
        // gltfpack quantizes the skinned positions in their bind space: within 0.1 % of the
        // face; a wrong bind pose is off by centimetres to metres.
        assert!(
            dp < 1e-3 * t.extent(),
            "{name}: the bind pose is off by {dp}"
        );
        let names: Vec<&str> = face.targets.iter().map(|t| t.0.as_str()).collect();
        assert_eq!(names, ["smile", "blink"], "{name}");
        // Targets turn with the armature: smile moves +X by (i mod 7) cm; blink (sparse) moves
        // two vertices along the face's height.
        let smile = &face.targets[0].1;
        let blink = &face.targets[1].1;
        for d in smile {
            assert!(d.y.abs() < 1e-3 && d.z.abs() < 1e-3, "{name}");
            let steps = d.x.round();
            assert!(
                (0.0..=6.0).contains(&steps) && (d.x - steps).abs() < 2e-3,
                "{name}: {}",
                d.x
            );
        }
        let mut moved: Vec<f32> = blink
            .iter()
            .filter(|d| d.length() > 1e-3)
            .map(|d| d.y)
            .collect();
        moved.sort_by(f32::total_cmp);
        assert_eq!(moved.len(), 2, "{name}");
        assert!(
            (moved[0] + 3.0).abs() < 1e-2 && (moved[1] - 2.0).abs() < 1e-2,
            "{name}: {moved:?}"
        );
        // The eye under a node matrix: ×2 and moved to (10, 20, 30).
        let eye = &parts[1];
        assert_eq!(eye.node, "Eye_L");
        let (lo, hi) = eye.geometry.bounds();
        assert!(
            lo.distance(Vec3::new(10.0, 20.0, 30.0)) < 1e-3,
            "{name}: {lo}"
        );
        assert!(
            hi.distance(Vec3::new(12.0, 22.0, 30.0)) < 1e-3,
            "{name}: {hi}"
        );
    }
}

#[test]
fn a_required_extension_derma_does_not_read_is_named() {
    let d = derma_test_support::scratch_dir("gltf-ext");
    let p = d.join("instanced.gltf");
    std::fs::write(
        &p,
        r#"{"asset":{"version":"2.0"},"extensionsUsed":["EXT_mesh_gpu_instancing"],"extensionsRequired":["EXT_mesh_gpu_instancing"]}"#,
    )
    .unwrap();
    let e = load_parts(&p).unwrap_err().to_string();
    assert!(
        e.contains("instanced.gltf") && e.contains("EXT_mesh_gpu_instancing"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn broken_references_and_missing_data_are_errors_naming_them() {
    // rig.gltf with one accessor pointing past the buffer views, or with no data at all: an
    // error naming the accessor or view, never a panic or a mesh of zeros.
    let src: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fixture("rig.gltf")).unwrap()).unwrap();
    let d = derma_test_support::scratch_dir("gltf-broken");
    let buffer = src["buffers"][0]["uri"].as_str().unwrap().to_string();
    if !buffer.starts_with("data:") {
        std::fs::copy(fixture(&buffer), d.join(&buffer)).unwrap();
    }
    for (name, edit, want) in [
        ("view.gltf", serde_json::json!(999), "buffer view 999"),
        (
            "none.gltf",
            serde_json::Value::Null,
            "accessor 0 has no data",
        ),
    ] {
        let mut g = src.clone();
        match edit {
            serde_json::Value::Null => {
                g["accessors"][0]
                    .as_object_mut()
                    .unwrap()
                    .remove("bufferView");
            }
            v => g["accessors"][0]["bufferView"] = v,
        }
        let p = d.join(name);
        std::fs::write(&p, serde_json::to_vec(&g).unwrap()).unwrap();
        let e = load_parts(&p).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(want), "{e}");
    }
    // A material's texture that is not there never blocks the geometry.
    let mut g = src.clone();
    g["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 99}}}]);
    g["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
    let p = d.join("texture.gltf");
    std::fs::write(&p, serde_json::to_vec(&g).unwrap()).unwrap();
    assert_eq!(load_parts(&p).unwrap().len(), 2);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Standard base64 (RFC 4648), padded or not.
fn base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        _ => 63,
    };
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=').map(value).collect();
    digits
        .chunks(4)
        .flat_map(|q| {
            let n = q.iter().fold(0u32, |a, &d| a << 6 | d as u32) << (6 * (4 - q.len()));
            n.to_be_bytes()[1..q.len()].to_vec()
        })
        .collect()
}

#[test]
fn a_skin_sits_where_most_of_its_joints_put_it() {
    // rig.gltf's skin given two more joints under its root, in their bind pose, and the first
    // joint (a jaw) posed: the face stays where the bind pose puts it.
    let src: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fixture("rig.gltf")).unwrap()).unwrap();
    let uri = src["buffers"][0]["uri"].as_str().unwrap();
    let bytes = base64(uri.split_once(',').unwrap().1);
    let ibm_of = |k: usize| {
        let view =
            &src["bufferViews"][src["accessors"][k]["bufferView"].as_u64().unwrap() as usize];
        let at = view["byteOffset"].as_u64().unwrap() as usize;
        let f: Vec<f32> = bytes[at..at + 64]
            .chunks(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        glam::Mat4::from_cols_slice(&f)
    };
    let root_ibm = ibm_of(src["skins"][0]["inverseBindMatrices"].as_u64().unwrap() as usize);
    let (jaw_at, spine_at) = (Vec3::new(0.0, -0.02, 0.01), Vec3::new(0.0, 0.05, 0.0));
    let ibms = [
        glam::Mat4::from_translation(-jaw_at) * root_ibm,
        root_ibm,
        glam::Mat4::from_translation(-spine_at) * root_ibm,
    ];
    let d = derma_test_support::scratch_dir("gltf-skin");
    let bin: Vec<u8> = ibms
        .iter()
        .flat_map(|m| m.to_cols_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    std::fs::write(d.join("ibm.bin"), &bin).unwrap();
    let mut g = src.clone();
    let nodes = g["nodes"].as_array_mut().unwrap();
    let (jaw, spine) = (nodes.len(), nodes.len() + 1);
    nodes.push(
        serde_json::json!({"name": "Jaw", "translation": jaw_at.to_array(),
        "rotation": [0.2588190, 0.0, 0.0, 0.9659258]}),
    );
    nodes.push(serde_json::json!({"name": "Spine", "translation": spine_at.to_array()}));
    nodes[1]["children"] = serde_json::json!([jaw, spine]);
    let buffer = g["buffers"].as_array().unwrap().len();
    g["buffers"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"uri": "ibm.bin", "byteLength": 192}));
    let view = g["bufferViews"].as_array().unwrap().len();
    g["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"buffer": buffer, "byteLength": 192}));
    let accessor = g["accessors"].as_array().unwrap().len();
    g["accessors"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!(
        {"bufferView": view, "componentType": 5126, "count": 3, "type": "MAT4"}));
    g["skins"][0] = serde_json::json!({"joints": [jaw, 1, spine], "inverseBindMatrices": accessor});
    let p = d.join("posed.gltf");
    std::fs::write(&p, serde_json::to_vec(&g).unwrap()).unwrap();
    let bind = &load_parts(&fixture("rig.gltf")).unwrap()[0].geometry;
    let posed = &load_parts(&p).unwrap()[0].geometry;
    let off = bind
        .positions
        .iter()
        .zip(&posed.positions)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    assert!(off < 1e-3 * bind.extent(), "the face moved by {off}");
    std::fs::remove_dir_all(&d).unwrap();
}
