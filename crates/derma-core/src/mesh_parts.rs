//! Which parts of a mesh file are the skin: a file's nodes (glTF) or objects (OBJ), each split
//! by material; eyes, teeth, lashes, brows and hair are left out by name and the node named
//! like a head or face is preferred, else the largest (docs/head.md, "Meshes as they come").

use crate::error::CoreError;
use crate::mesh::TriMesh;
use glam::Vec3;

/// Morph targets: name and per-vertex position offsets.
pub type MorphTargets = Vec<(String, Vec<Vec3>)>;

/// One primitive (glTF) or material group (OBJ) of a mesh file, in the file's frame.
#[derive(Clone, Debug)]
pub struct Part {
    /// The node's (glTF) or object's (OBJ) name.
    pub node: String,
    /// The node's index (glTF) or the object's order (OBJ): the parts of one node share it.
    pub node_index: usize,
    /// The mesh's name (glTF; the object's name for OBJ).
    pub mesh: String,
    /// The material's name (empty when it has none).
    pub material: String,
    /// Positions, normals, UVs (empty where the part has none) and triangles.
    pub geometry: TriMesh,
    /// Morph targets (glTF only).
    pub targets: MorphTargets,
}

/// Which parts to read.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum PartChoice {
    /// The skin, by the rules of [`choose`].
    #[default]
    Auto,
    /// Every part whose node, mesh or material has this name (case-insensitive).
    Named(String),
}

impl PartChoice {
    /// The name asked for (None: the skin by the rules).
    pub fn name(&self) -> Option<String> {
        match self {
            PartChoice::Named(n) => Some(n.clone()),
            PartChoice::Auto => None,
        }
    }
}

/// What was read, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Chosen {
    /// Indices of the parts read.
    pub parts: Vec<usize>,
    /// The node read (its name), when the file has several.
    pub node: Option<String>,
    /// One line for the user when the file has more than one node or left parts out; None
    /// when everything was read.
    pub note: Option<String>,
}

/// Substrings of names that mark a part that is not skin (lower case).
const NOT_SKIN: [&str; 24] = [
    "eye",
    "iris",
    "pupil",
    "sclera",
    "cornea",
    "lens",
    "lacrimal",
    "tear",
    "caruncle",
    "lash",
    "brow",
    "teeth",
    "tooth",
    "tongue",
    "gum",
    "hair",
    "beard",
    "moustache",
    "mustache",
    "occlusion",
    "cloth",
    "shirt",
    "glasses",
    "hat",
];
/// Names that contain a word of [`NOT_SKIN`] and are skin all the same.
const SKIN_AFTER_ALL: [&str; 4] = ["eyelid", "eyebag", "eye_socket", "socket"];

/// Whether a name marks a part that is not skin.
pub fn is_not_skin(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    if SKIN_AFTER_ALL.iter().any(|w| n.contains(w)) {
        return false;
    }
    NOT_SKIN.iter().any(|w| n.contains(w))
}

/// How strongly a node's name says "the head's skin": 0 (head, face), 1 (skin, body), 2.
fn rank(name: &str) -> u8 {
    let n = name.to_ascii_lowercase();
    if n.contains("head") || n.contains("face") {
        0
    } else if n.contains("skin") || n.contains("body") {
        1
    } else {
        2
    }
}

/// Chooses the parts to read. `Named`: every part whose node, mesh or material is called so.
/// `Auto`: parts whose node, mesh or material name marks them as not skin ([`is_not_skin`])
/// are left out (all are kept when that leaves none); then, of the nodes left, the one whose
/// name says head or face (else skin or body, else any) with the largest surface; all its
/// remaining parts are read. Errors name what the file holds.
pub fn choose(
    path: &std::path::Path,
    parts: &[Part],
    choice: &PartChoice,
) -> Result<Chosen, CoreError> {
    let err = |detail: String| CoreError::Mesh {
        path: path.to_path_buf(),
        detail,
    };
    if parts.is_empty() {
        return Err(err("it contains no triangles".into()));
    }
    let label = |p: &Part| {
        if p.material.is_empty() {
            p.node.clone()
        } else {
            format!("{} ({})", p.node, p.material)
        }
    };
    if let PartChoice::Named(name) = choice {
        let hit = |s: &str| s.eq_ignore_ascii_case(name);
        let chosen: Vec<usize> = (0..parts.len())
            .filter(|&i| hit(&parts[i].node) || hit(&parts[i].mesh) || hit(&parts[i].material))
            .collect();
        if chosen.is_empty() {
            return Err(err(format!(
                "no node, mesh or material is called '{name}'; it holds {}",
                names(parts.iter().map(label))
            )));
        }
        return Ok(Chosen {
            node: Some(name.clone()),
            note: None,
            parts: chosen,
        });
    }
    let skin_like =
        |p: &Part| !(is_not_skin(&p.node) || is_not_skin(&p.mesh) || is_not_skin(&p.material));
    let mut kept: Vec<usize> = (0..parts.len()).filter(|&i| skin_like(&parts[i])).collect();
    if kept.is_empty() {
        kept = (0..parts.len()).collect();
    }
    // The nodes left, best first: by name, then by surface.
    let mut nodes: Vec<(u8, f64, usize)> = Vec::new();
    for &i in &kept {
        let p = &parts[i];
        let area = p.geometry.area();
        match nodes.iter_mut().find(|n| n.2 == p.node_index) {
            Some(n) => n.1 += area,
            None => nodes.push((rank(&p.node).min(rank(&p.mesh)), area, p.node_index)),
        }
    }
    nodes.sort_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)).then(a.2.cmp(&b.2)));
    let best = nodes[0];
    let chosen: Vec<usize> = kept
        .iter()
        .copied()
        .filter(|&i| parts[i].node_index == best.2)
        .collect();
    let node = parts[chosen[0]].node.clone();
    let left: Vec<String> = (0..parts.len())
        .filter(|i| !chosen.contains(i))
        .map(|i| label(&parts[i]))
        .collect();
    let note = (!left.is_empty()).then(|| {
        let why = match best.0 {
            0 => "its name says head or face",
            1 => "its name says skin or body",
            _ => "the largest",
        };
        let read: Vec<String> = chosen.iter().map(|&i| label(&parts[i])).collect();
        format!(
            "read {} ({why}); left out {}; choose another part by its node, mesh or material name",
            names(read.into_iter()),
            names(left.into_iter())
        )
    });
    Ok(Chosen {
        parts: chosen,
        node: (nodes.len() > 1).then_some(node),
        note,
    })
}

/// Up to eight names, quoted, then how many more.
fn names(it: impl Iterator<Item = String>) -> String {
    let all: Vec<String> = it.collect();
    let mut s: Vec<String> = all.iter().take(8).map(|n| format!("'{n}'")).collect();
    if all.len() > 8 {
        s.push(format!("and {} more", all.len() - 8));
    }
    s.join(", ")
}

/// The chosen parts as one mesh: vertices concatenated; UVs kept only where every part has
/// them; morph targets of the same name concatenated (zero where a part lacks one).
pub fn merge(parts: &[Part], chosen: &[usize]) -> (TriMesh, MorphTargets) {
    let mut mesh = TriMesh::default();
    let all_uvs = chosen.iter().all(|&i| !parts[i].geometry.uvs.is_empty());
    let mut target_names: Vec<String> = Vec::new();
    for &i in chosen {
        for (n, _) in &parts[i].targets {
            if !target_names.contains(n) {
                target_names.push(n.clone());
            }
        }
    }
    let mut targets: MorphTargets = target_names.into_iter().map(|n| (n, Vec::new())).collect();
    for &i in chosen {
        let g = &parts[i].geometry;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend_from_slice(&g.positions);
        mesh.normals.extend_from_slice(&g.normals);
        if all_uvs {
            mesh.uvs.extend_from_slice(&g.uvs);
        }
        mesh.triangles
            .extend(g.triangles.iter().map(|t| t.map(|v| v + base)));
        for (name, d) in &mut targets {
            match parts[i].targets.iter().find(|t| &t.0 == name) {
                Some(t) => d.extend_from_slice(&t.1),
                None => d.extend(std::iter::repeat_n(Vec3::ZERO, g.positions.len())),
            }
        }
    }
    (mesh, targets)
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: &str = "parts.glb";

    fn part(node: &str, index: usize, material: &str, size: f32) -> Part {
        Part {
            node: node.into(),
            node_index: index,
            mesh: node.into(),
            material: material.into(),
            geometry: TriMesh {
                positions: vec![Vec3::ZERO, Vec3::X * size, Vec3::Y * size],
                normals: vec![Vec3::Z; 3],
                uvs: Vec::new(),
                triangles: vec![[0, 1, 2]],
            },
            targets: Vec::new(),
        }
    }

    #[test]
    fn the_head_skin_is_chosen_and_the_rest_reported() {
        // A game character: the body is larger, but the head node is the one to read, and its
        // eyes, brows and hair are not skin.
        let parts = vec![
            part("Casual_Body", 0, "Skin", 10.0),
            part("Casual_Body", 0, "Purple", 10.0),
            part("Casual_Head", 1, "Skin", 3.0),
            part("Casual_Head", 1, "Eyebrows", 1.0),
            part("Casual_Head", 1, "Eye", 1.0),
            part("Casual_Head", 1, "Hair", 4.0),
        ];
        let c = choose(P.as_ref(), &parts, &PartChoice::Auto).unwrap();
        assert_eq!(c.parts, vec![2]);
        assert_eq!(c.node.as_deref(), Some("Casual_Head"));
        let note = c.note.unwrap();
        assert!(
            note.contains("head or face") && note.contains("'Casual_Head (Eye)'"),
            "{note}"
        );
        // derma's own template: the skin among eyes, lashes, teeth and tongue.
        let tpl = vec![
            part("eye_left", 1, "", 5.0),
            part("skin", 0, "", 3.0),
            part("teeth_upper", 2, "", 1.0),
            part("eyelashes_left", 3, "", 1.0),
        ];
        assert_eq!(
            choose(P.as_ref(), &tpl, &PartChoice::Auto).unwrap().parts,
            vec![1]
        );
        // One object split by material (ICT-FaceKit's layout): both skin materials are read.
        let one = vec![
            part("face", 0, "M_Face", 5.0),
            part("face", 0, "M_BackHead", 5.0),
            part("face", 0, "M_ScleraLeft", 1.0),
            part("face", 0, "M_EyeLashes", 1.0),
            part("face", 0, "M_GumsTongue", 1.0),
        ];
        let c = choose(P.as_ref(), &one, &PartChoice::Auto).unwrap();
        assert_eq!(c.parts, vec![0, 1]);
        assert_eq!(c.node, None);
        // Without names, the largest node.
        let plain = vec![part("a", 0, "", 1.0), part("b", 1, "", 2.0)];
        assert_eq!(
            choose(P.as_ref(), &plain, &PartChoice::Auto).unwrap().parts,
            vec![1]
        );
        // Names that contain a non-skin word and are skin.
        assert!(!is_not_skin("upper_eyelid") && is_not_skin("EyeLeft"));
    }

    #[test]
    fn a_named_part_is_chosen_or_the_error_lists_what_there_is() {
        let parts = vec![part("skin", 0, "", 3.0), part("eye_left", 1, "iris", 1.0)];
        let c = choose(P.as_ref(), &parts, &PartChoice::Named("EYE_LEFT".into())).unwrap();
        assert_eq!(c.parts, vec![1]);
        let by_material = choose(P.as_ref(), &parts, &PartChoice::Named("iris".into())).unwrap();
        assert_eq!(by_material.parts, vec![1]);
        let e = choose(P.as_ref(), &parts, &PartChoice::Named("face".into()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("'face'") && e.contains("'skin'") && e.contains("'eye_left (iris)'"),
            "{e}"
        );
    }

    #[test]
    fn merging_keeps_indices_and_targets_aligned() {
        let mut a = part("a", 0, "", 1.0);
        a.targets.push(("smile".into(), vec![Vec3::X; 3]));
        let b = part("a", 0, "m", 1.0);
        let (m, t) = merge(&[a, b], &[0, 1]);
        assert_eq!(m.positions.len(), 6);
        assert_eq!(m.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].1[..3], [Vec3::X; 3]);
        assert_eq!(t[0].1[3..], [Vec3::ZERO; 3]);
    }
}
