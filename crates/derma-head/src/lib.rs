//! derma's built-in head: MakeHuman's base mesh (CC0 1.0; head and neck cut out by
//! `scripts/make_head.py`, see `assets/PROVENANCE.md`) served as data: the skin with one UV
//! layout, eye globes with their own UVs, eyelashes, teeth and tongue, named landmarks, named
//! regions as masks on the UV layout, and the 52 face units (ARKit names) as morph targets.
//!
//! Units are millimetres; +Y up, the face towards +Z, +X the head's left. The skin is
//! Catmull–Clark subdivided twice at load ([`subdivision`]), teeth and tongue once.
//!
//! ```
//! let head = derma_head::Head::builtin();
//! assert!(head.skin.positions.len() > 60_000);
//! let blink = head.face_units().iter().find(|t| t.name == "eyeBlinkLeft").unwrap();
//! assert!(!blink.skin.is_empty());
//! ```

#![warn(missing_docs)]

pub mod asset;
pub mod brows;
pub mod export;
pub mod eye;
pub mod fit;
pub mod fitted;
pub mod landmarks;
pub mod lashes;
pub mod look;
pub mod regions;
pub mod subdivision;
pub mod wrinkle_regions;

pub use eye::Eye;
pub use landmarks::Landmarks;
pub use look::Look;
pub use regions::{Regions, REGIONS};

use derma_core::mesh::TriMesh;
use derma_core::raster::{apply_dilation, dilation_sources, UvRaster};
use derma_core::Map;
use glam::{Vec2, Vec3};
use std::collections::{BTreeMap, HashMap};
use std::sync::OnceLock;
use subdivision::{subdivide, QuadMesh, Stencils};

/// Catmull–Clark levels of the skin: 4.1 k coarse quads become 66 k, edges of ~1.5 mm, so
/// silhouettes stay smooth at 2048² renders of the whole head.
pub const SKIN_LEVELS: usize = 2;
/// Catmull–Clark levels of the teeth and tongue.
pub const PART_LEVELS: usize = 1;

/// Errors of the head crate.
#[derive(Debug, thiserror::Error)]
pub enum HeadError {
    /// A core error (writing files).
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
}

/// Result of the head crate.
pub type Result<T> = std::result::Result<T, HeadError>;

/// A part of the head other than the skin.
#[derive(Clone, Debug)]
pub struct Part {
    /// Its name: `eye_left`, `eye_right`, `eyelashes_left`, `eyelashes_right`, `teeth_upper`,
    /// `teeth_lower`, `tongue`.
    pub name: String,
    /// Its mesh (mm), with normals and its own UVs.
    pub mesh: TriMesh,
}

/// A face unit as a morph target: offsets (mm) of the vertices it moves.
#[derive(Clone, Debug)]
pub struct MorphTarget {
    /// ARKit name (`eyeBlinkLeft`, `jawOpen`, `mouthSmileLeft`, …).
    pub name: String,
    /// Offsets of skin vertices (indices into [`Head::skin`]).
    pub skin: Vec<(u32, Vec3)>,
    /// Offsets per part (index into [`Head::parts`], then vertex offsets); parts it does not
    /// move are absent.
    pub parts: Vec<(usize, Vec<(u32, Vec3)>)>,
}

/// How a subdivided mesh maps back to the asset's vertices (to carry morph targets along).
struct Lineage {
    /// Asset vertex index of each coarse local vertex.
    coarse: Vec<u32>,
    /// Coarse local vertices → subdivided topological vertices.
    stencils: Stencils,
    /// Triangle-mesh vertex → subdivided topological vertex.
    vertex: Vec<u32>,
}

/// The built-in head.
pub struct Head {
    /// The skin: head, neck, ears, lids, mouth cavity and eye sockets, one UV layout.
    pub skin: TriMesh,
    /// Eyes, eyelashes, teeth and tongue.
    pub parts: Vec<Part>,
    /// The eye globes: left (+x) then right.
    pub eyes: [Eye; 2],
    /// Named landmarks.
    pub landmarks: Landmarks,
    /// Named regions.
    pub regions: Regions,
    skin_lineage: Lineage,
    part_lineage: Vec<Option<Lineage>>,
    targets: Vec<asset::SparseTarget>,
    units: OnceLock<Vec<MorphTarget>>,
}

/// The groups that make the skin surface (one UV layout).
pub(crate) const SKIN_GROUPS: [&str; 4] = ["skin", "mouth", "socket_left", "socket_right"];

/// A quad mesh of some of the asset's groups, with local vertex and uv numbering.
pub(crate) fn local_quads(a: &asset::Asset, groups: &[&str]) -> (QuadMesh, Vec<u32>) {
    let mut vmap: BTreeMap<u32, u32> = BTreeMap::new();
    let mut tmap: HashMap<u32, u32> = HashMap::new();
    let mut m = QuadMesh::default();
    let mut coarse = Vec::new();
    for (name, g) in &a.groups {
        if !groups.contains(&name.as_str()) {
            continue;
        }
        for q in &g.quads {
            m.quads.push(q.map(|(v, t)| {
                let lv = *vmap.entry(v).or_insert_with(|| {
                    coarse.push(v);
                    m.positions.push(a.positions[v as usize]);
                    (coarse.len() - 1) as u32
                });
                let lt = *tmap.entry(t).or_insert_with(|| {
                    m.uvs.push(a.uvs[t as usize]);
                    (m.uvs.len() - 1) as u32
                });
                (lv, lt)
            }));
        }
    }
    (m, coarse)
}

/// Triangulates a quad mesh into a [`TriMesh`], one vertex per (position, uv) pair, with
/// area-weighted normals shared across UV seams. Returns the mesh and each vertex's position
/// index.
fn to_trimesh(q: &QuadMesh) -> (TriMesh, Vec<u32>) {
    let mut normals = vec![Vec3::ZERO; q.positions.len()];
    for f in &q.quads {
        let [a, b, c, d] = f.map(|c| q.positions[c.0 as usize]);
        let n = (c - a).cross(d - b);
        for c in f {
            normals[c.0 as usize] += n;
        }
    }
    let mut m = TriMesh::default();
    let mut index: HashMap<(u32, u32), u32> = HashMap::new();
    let mut vertex = Vec::new();
    let mut id = |c: (u32, u32), m: &mut TriMesh| {
        *index.entry(c).or_insert_with(|| {
            m.positions.push(q.positions[c.0 as usize]);
            m.normals.push(normals[c.0 as usize].normalize_or(Vec3::Y));
            m.uvs.push(q.uvs[c.1 as usize]);
            vertex.push(c.0);
            (m.positions.len() - 1) as u32
        })
    };
    for f in &q.quads {
        let [a, b, c, d] = f.map(|c| id(c, &mut m));
        m.triangles.push([a, b, c]);
        m.triangles.push([a, c, d]);
    }
    (m, vertex)
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from(a)
}

impl Head {
    /// The built-in head, built once per process (about a second on one core).
    pub fn builtin() -> &'static Head {
        static HEAD: OnceLock<Head> = OnceLock::new();
        HEAD.get_or_init(|| Head::from_asset(asset::parse(), None))
    }

    /// A head from an asset (the built-in one, or one fitted to a user's mesh by [`fit`]);
    /// `fine`, when given, replaces the subdivided skin's positions (one per topological vertex
    /// of the twice-subdivided skin: a fit's final projection onto the scan).
    pub(crate) fn from_asset(a: asset::Asset, fine: Option<&[Vec3]>) -> Head {
        let (coarse_skin, coarse) = local_quads(&a, &SKIN_GROUPS);
        assert_eq!(
            coarse.len(),
            a.meta.skin_vertices,
            "head.json's skin vertex count"
        );
        let (mut fine_q, stencils) = subdivide(&coarse_skin, SKIN_LEVELS);
        if let Some(f) = fine {
            assert_eq!(f.len(), fine_q.positions.len(), "fine skin positions");
            fine_q.positions = f.to_vec();
        }
        let fine = fine_q;
        let (skin, vertex) = to_trimesh(&fine);
        // Local skin vertex of each asset vertex (the script numbers skin vertices first, so the
        // map is the identity; kept general).
        let local: HashMap<u32, u32> = coarse
            .iter()
            .enumerate()
            .map(|(i, &v)| (v, i as u32))
            .collect();
        let eye = |side: &str| {
            let e = a.meta.eyes[side];
            Eye {
                centre: v3(e.centre),
                radius: e.radius,
            }
        };
        let eyes = [eye("left"), eye("right")];
        let mut points: BTreeMap<String, Vec3> = BTreeMap::new();
        for (name, &v) in &a.meta.landmarks {
            points.insert(name.clone(), fine.positions[local[&v] as usize]);
        }
        points.insert("eye_centre_left".into(), eyes[0].centre);
        points.insert("eye_centre_right".into(), eyes[1].centre);
        let landmarks = Landmarks { points };
        landmarks
            .check()
            .expect("the built-in head has every landmark");
        let rect = |k: &str| a.meta.charts[k];
        let regions = Regions::new(
            landmarks.clone(),
            vec![rect("mouth")],
            vec![rect("socket_left"), rect("socket_right")],
        );
        let mut parts = vec![
            Part {
                name: "eye_left".into(),
                mesh: eyes[0].mesh(),
            },
            Part {
                name: "eye_right".into(),
                mesh: eyes[1].mesh(),
            },
        ];
        let mut part_lineage = vec![None, None];
        for (name, levels) in [
            ("eyelashes_left", 0),
            ("eyelashes_right", 0),
            ("teeth_upper", PART_LEVELS),
            ("teeth_lower", PART_LEVELS),
            ("tongue", PART_LEVELS),
        ] {
            let (q, coarse) = local_quads(&a, &[name]);
            let (fine, stencils) = subdivide(&q, levels);
            let (mesh, vertex) = to_trimesh(&fine);
            parts.push(Part {
                name: name.into(),
                mesh,
            });
            part_lineage.push(Some(Lineage {
                coarse,
                stencils,
                vertex,
            }));
        }
        Head {
            skin,
            parts,
            eyes,
            landmarks,
            regions,
            skin_lineage: Lineage {
                coarse,
                stencils,
                vertex,
            },
            part_lineage,
            targets: a.targets,
            units: OnceLock::new(),
        }
    }

    /// A part by name.
    pub fn part(&self, name: &str) -> Option<&Part> {
        self.parts.iter().find(|p| p.name == name)
    }

    /// The 52 face units as morph targets on the subdivided meshes (computed on first use).
    pub fn face_units(&self) -> &[MorphTarget] {
        self.units.get_or_init(|| {
            use rayon::prelude::*;
            self.targets
                .par_iter()
                .map(|t| {
                    let by_asset: HashMap<u32, Vec3> = t.offsets.iter().copied().collect();
                    let carry = |l: &Lineage| -> Vec<(u32, Vec3)> {
                        let coarse: Vec<Vec3> = l
                            .coarse
                            .iter()
                            .map(|v| by_asset.get(v).copied().unwrap_or(Vec3::ZERO))
                            .collect();
                        if coarse.iter().all(|d| *d == Vec3::ZERO) {
                            return Vec::new();
                        }
                        let fine = l.stencils.apply(&coarse);
                        l.vertex
                            .iter()
                            .enumerate()
                            .filter_map(|(i, &v)| {
                                let d = fine[v as usize];
                                (d.length_squared() > 1e-8).then_some((i as u32, d))
                            })
                            .collect()
                    };
                    let parts = self
                        .part_lineage
                        .iter()
                        .enumerate()
                        .filter_map(|(k, l)| {
                            let offs = carry(l.as_ref()?);
                            (!offs.is_empty()).then_some((k, offs))
                        })
                        .collect();
                    MorphTarget {
                        name: t.name.clone(),
                        skin: carry(&self.skin_lineage),
                        parts,
                    }
                })
                .collect()
        })
    }

    /// The skin with `weights` (face unit name → weight) applied.
    pub fn posed_skin(&self, weights: &[(&str, f32)]) -> TriMesh {
        let mut m = self.skin.clone();
        for (name, w) in weights {
            if let Some(t) = self.face_units().iter().find(|t| t.name == *name) {
                for &(i, d) in &t.skin {
                    m.positions[i as usize] += *w * d;
                }
            }
        }
        m
    }

    /// Every region as a mask on the skin's UV layout at `resolution`², dilated into the
    /// gutter (same layout as the texture set).
    pub fn region_masks(&self, resolution: usize) -> Vec<(&'static str, Map)> {
        masks_on(&self.skin, &self.regions, resolution)
    }
}

/// Region masks of `regions` on `mesh`'s UV layout at `n`², dilated into the gutter.
pub fn masks_on(mesh: &TriMesh, regions: &Regions, n: usize) -> Vec<(&'static str, Map)> {
    use rayon::prelude::*;
    let raster = UvRaster::new(mesh, n, n);
    let w: Vec<regions::Weights> = (0..n * n)
        .into_par_iter()
        .map(|i| {
            if raster.covered(i) {
                let uv = Vec2::new(
                    ((i % n) as f32 + 0.5) / n as f32,
                    1.0 - ((i / n) as f32 + 0.5) / n as f32,
                );
                regions.weights(raster.position(mesh, i), uv)
            } else {
                [0.0; REGIONS.len()]
            }
        })
        .collect();
    let covered: Vec<bool> = (0..n * n).map(|i| raster.covered(i)).collect();
    let src = dilation_sources(&covered, n, n);
    REGIONS
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let mut m = Map::from_fn(n, n, |i| w[i][k]);
            if let Some(src) = &src {
                apply_dilation(m.data_mut(), src);
            }
            (*name, m)
        })
        .collect()
}
