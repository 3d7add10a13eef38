//! The eye region of a head mesh (thesis §3.2): the skin vertices the model moves, welded across
//! UV seams, split into tracked vertices (visible skin) and untracked ones (the lids' inner
//! surfaces, §3.6), and the four lid margins as vertex chains from the inner to the outer canthus.

use derma_core::mesh::TriMesh;
use derma_head::Head;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// Face units whose support defines the region: they move the lids and the skin around them.
pub const REGION_UNITS: [&str; 14] = [
    "eyeLookUpLeft",
    "eyeLookDownLeft",
    "eyeLookInLeft",
    "eyeLookOutLeft",
    "eyeBlinkLeft",
    "eyeSquintLeft",
    "eyeWideLeft",
    "eyeLookUpRight",
    "eyeLookDownRight",
    "eyeLookInRight",
    "eyeLookOutRight",
    "eyeBlinkRight",
    "eyeSquintRight",
    "eyeWideRight",
];

/// A vertex moves with the region when some region unit moves it by more than this (mm): a
/// third of the ~0.3 mm texel of a 2048² texture, below anything a render shows.
const SUPPORT_MM: f32 = 0.1;

/// Height (mm) from the built-in head's globe centres down to its subnasale landmark: the face
/// height the region's box is authored on (measured on the asset; pinned by a test).
pub const EYE_TO_SUBNASALE_MM: f32 = 51.2;

/// Spacing (mm, in the modelling camera) of the tracked vertices of a capture-like region
/// ([`EyeRegion::of_head_sampled`]): one per 2.5 mm cell gives about a thousand over both eye
/// regions, the thesis' "about a thousand vertices" (§3.5); the rest of the region follows them
/// by extrapolation (eq. 3.5).
pub const TRACK_SPACING: f32 = 2.5;

/// A sampled tracked vertex faces the camera at least this much (n · z), so a video tracker
/// sees it (authored).
const VISIBLE_COS: f32 = 0.25;

/// The region of one head.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EyeRegion {
    /// Rest positions (mm) of the model vertices: tracked first, then untracked.
    pub rest: Vec<Vec3>,
    /// Rest normals of the model vertices.
    pub rest_normals: Vec<Vec3>,
    /// Number of tracked model vertices (the first `tracked` of `rest`).
    pub tracked: usize,
    /// Which eye (0 left, 1 right) each model vertex belongs to.
    pub eye: Vec<u8>,
    /// True for vertices only on the socket charts: the lids' inner surfaces and the
    /// conjunctiva, which follow the lid margins.
    pub inner: Vec<bool>,
    /// Lid margins: per eye, upper then lower, model-vertex indices from the inner to the outer
    /// canthus (both chains share their end vertices).
    pub margins: [[Vec<u32>; 2]; 2],
    /// For every skin vertex of the mesh, its model vertex, or `u32::MAX` outside the region.
    pub skin_to_model: Vec<u32>,
}

fn key(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
}

impl EyeRegion {
    /// The region of `head`: vertices the region units move, welded; margins from the seam
    /// between the skin and the eye-socket charts. Every skin-chart vertex is tracked (a rig
    /// gives them all); the lids' inner surfaces are extrapolated.
    pub fn of_head(head: &Head) -> crate::Result<EyeRegion> {
        Self::of_head_sampled(head, None)
    }

    /// As [`EyeRegion::of_head`] with the tracked vertices of a video capture: one visible
    /// vertex per `spacing` mm cell (e.g. [`TRACK_SPACING`]), the rest extrapolated.
    pub fn of_head_sampled(head: &Head, spacing: Option<f32>) -> crate::Result<EyeRegion> {
        let skin = &head.skin;
        let units = head.face_units();
        let mut moved = vec![false; skin.positions.len()];
        for name in REGION_UNITS {
            let t = units.iter().find(|t| t.name == name).ok_or_else(|| {
                derma_core::Invalid::new(
                    "the head's face units",
                    format!("one named '{name}'"),
                    "none",
                )
            })?;
            for &(i, d) in &t.skin {
                if d.length() > SUPPORT_MM {
                    moved[i as usize] = true;
                }
            }
        }
        let socket = |i: usize| head.regions.in_socket(skin.uvs[i]);
        let eyes = [head.eyes[0].centre, head.eyes[1].centre];
        Self::build(skin, &moved, &socket, eyes, &head.landmarks, spacing)
    }

    /// The region of `skin` from the vertices the region units move (`moved`), the socket
    /// charts' vertices (`socket`), the globe centres and the landmarks.
    fn build(
        skin: &TriMesh,
        moved: &[bool],
        socket: &dyn Fn(usize) -> bool,
        eyes: [Vec3; 2],
        lm: &derma_head::Landmarks,
        spacing: Option<f32>,
    ) -> crate::Result<EyeRegion> {
        // The face's height from the globes to the subnasale, as a fraction of the built-in
        // head's.
        let face = ((0.5 * (eyes[0].y + eyes[1].y) - lm.get("subnasale").y) / EYE_TO_SUBNASALE_MM)
            .clamp(0.5, 2.0);
        let (welded, of_vertex) = weld(skin, moved, socket, eyes, face);
        let chosen = tracked_choice(&welded, spacing);
        let model = model_vertices(&welded, &chosen);
        let adj = seam_adjacency(skin, socket, &of_vertex, &welded);
        let mut margins: [[Vec<u32>; 2]; 2] = Default::default();
        for (e, margin) in margins.iter_mut().enumerate() {
            *margin = lid_margin(&adj, &welded, &model.model_of, e, eyes[e], lm)?;
        }
        let skin_to_model = of_vertex
            .iter()
            .map(|id| model.model_of.get(id).copied().unwrap_or(u32::MAX))
            .collect();
        Ok(EyeRegion {
            rest: model.rest,
            rest_normals: model.rest_normals,
            tracked: model.tracked,
            eye: model.eye,
            inner: model.inner,
            margins,
            skin_to_model,
        })
    }

    /// Number of model vertices.
    pub fn len(&self) -> usize {
        self.rest.len()
    }

    /// True when the region has no vertices.
    pub fn is_empty(&self) -> bool {
        self.rest.is_empty()
    }
}

/// A welded vertex: position, normal (the skin chart's), and whether it moves with the region,
/// has a copy on the skin chart, has one on the socket charts.
type Welded = (Vec3, Vec3, bool, bool, bool);

/// Which eye's side `p` lies on (0 left, 1 right).
fn side(p: Vec3) -> usize {
    usize::from(p.x < 0.0)
}

/// The skin's vertices welded by position, and each skin vertex's welded vertex; `face` scales
/// the orbit's reach.
fn weld(
    skin: &TriMesh,
    moved: &[bool],
    socket: &dyn Fn(usize) -> bool,
    eyes: [Vec3; 2],
    face: f32,
) -> (Vec<Welded>, Vec<usize>) {
    // Weld skin vertices by position; a welded vertex is in the region when any copy moves
    // and is tracked when any copy lies on the skin chart.
    let mut weld: HashMap<[u32; 3], usize> = HashMap::new();
    let mut welded: Vec<Welded> = Vec::new();
    let mut of_vertex = Vec::with_capacity(skin.positions.len());
    for i in 0..skin.positions.len() {
        let id = *weld.entry(key(skin.positions[i])).or_insert_with(|| {
            welded.push((skin.positions[i], skin.normals[i], false, false, false));
            welded.len() - 1
        });
        let w = &mut welded[id];
        // Within the orbit's reach: 32 mm either side of the globe centre, from 30 mm below
        // it to the brow 32 mm above on the built-in head, heights scaled by the face's
        // eye-to-subnasale height (the units' far tails on cheek, nose and forehead stay
        // put: a shorter fitted face would otherwise bring its nostrils in), and outside
        // the socket no deeper than the orbit's rim, 15 mm behind the centre on the
        // built-in head (its temples reach 12.6 mm), scaled the same way.
        let in_socket = socket(i);
        let near = eyes.iter().any(|c| {
            let d = skin.positions[i] - *c;
            d.x.abs() < 32.0
                && d.y > -30.0 * face
                && d.y < 32.0 * face
                && (in_socket || d.z > -15.0 * face)
        });
        w.2 |= moved[i] && near;
        if in_socket {
            w.4 = true;
        } else {
            w.3 = true;
            w.1 = skin.normals[i];
        }
        of_vertex.push(id);
    }
    (welded, of_vertex)
}

/// The tracked welded vertices: every moved skin-chart one, or with `spacing` one visible one
/// per grid cell of the modelling camera.
fn tracked_choice(welded: &[Welded], spacing: Option<f32>) -> BTreeSet<usize> {
    // Tracked: one visible skin-chart vertex per grid cell of the modelling camera (the one
    // nearest the cell centre); every other moved vertex is untracked.
    let mut cells: BTreeMap<(i32, i32), (f32, usize)> = BTreeMap::new();
    for (id, w) in welded.iter().enumerate() {
        let Some(spacing) = spacing else {
            if w.2 && w.3 {
                cells.insert((id as i32, 0), (0.0, id));
            }
            continue;
        };
        if w.2 && w.3 && w.1.z > VISIBLE_COS {
            let c = w.0.truncate() / spacing;
            let cell = (c.x.floor() as i32, c.y.floor() as i32);
            let d = (c - c.floor() - Vec2::splat(0.5)).length_squared();
            let e = cells.entry(cell).or_insert((f32::MAX, id));
            if d < e.0 || (d == e.0 && id < e.1) {
                *e = (d, id);
            }
        }
    }
    cells.values().map(|v| v.1).collect()
}

/// The model vertices, tracked first, then untracked.
struct ModelVertices {
    /// Model vertex of each welded vertex in the region.
    model_of: BTreeMap<usize, u32>,
    /// As [`EyeRegion::rest`].
    rest: Vec<Vec3>,
    /// As [`EyeRegion::rest_normals`].
    rest_normals: Vec<Vec3>,
    /// As [`EyeRegion::eye`].
    eye: Vec<u8>,
    /// As [`EyeRegion::inner`].
    inner: Vec<bool>,
    /// As [`EyeRegion::tracked`].
    tracked: usize,
}

/// The Morton code of `p`'s camera position (x, y) on 0.25 mm cells.
fn morton(p: Vec3) -> u32 {
    let q = |v: f32| ((v + 128.0).clamp(0.0, 255.99) * 4.0) as u32; // 0.25 mm cells
    let spread = |mut v: u32| {
        v &= 0x3FF;
        v = (v | (v << 16)) & 0x0300_00FF;
        v = (v | (v << 8)) & 0x0300_F00F;
        v = (v | (v << 4)) & 0x030C_30C3;
        (v | (v << 2)) & 0x0924_9249
    };
    spread(q(p.x)) | (spread(q(p.y)) << 1)
}

/// The moved welded vertices as model vertices: the `chosen` (tracked) ones first, then the
/// rest.
fn model_vertices(welded: &[Welded], chosen: &BTreeSet<usize>) -> ModelVertices {
    let mut m = ModelVertices {
        model_of: BTreeMap::new(),
        rest: Vec::new(),
        rest_normals: Vec::new(),
        eye: Vec::new(),
        inner: Vec::new(),
        tracked: 0,
    };
    // Model vertices in Morton order of their camera position: neighbours in memory are
    // neighbours on the face, so a frame's radial-map reads near a globe stay in cache.
    let mut order: Vec<usize> = (0..welded.len()).collect();
    order.sort_by_key(|&id| (morton(welded[id].0), id));
    for pass in [true, false] {
        for &id in &order {
            let w = &welded[id];
            if w.2 && chosen.contains(&id) == pass {
                m.model_of.insert(id, m.rest.len() as u32);
                m.rest.push(w.0);
                m.rest_normals.push(w.1);
                m.eye.push(side(w.0) as u8);
                m.inner.push(!w.3);
            }
        }
        if pass {
            m.tracked = m.rest.len();
        }
    }
    m
}

/// The lid margins' graph: welded vertices with copies on both charts, linked by skin-chart
/// edges.
fn seam_adjacency(
    skin: &TriMesh,
    socket: &dyn Fn(usize) -> bool,
    of_vertex: &[usize],
    welded: &[Welded],
) -> BTreeMap<usize, Vec<usize>> {
    let mut adj: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for t in &skin.triangles {
        if t.iter().any(|&i| socket(i as usize)) {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (of_vertex[t[k] as usize], of_vertex[t[(k + 1) % 3] as usize]);
            let seam = |id: usize| welded[id].3 && welded[id].4;
            if seam(a) && seam(b) {
                adj.entry(a).or_default().push(b);
                adj.entry(b).or_default().push(a);
            }
        }
    }
    adj
}

/// The upper and lower lid margins of eye `e` (0 left, 1 right; its globe centred at `centre`)
/// as model vertices from the inner to the outer canthus.
fn lid_margin(
    adj: &BTreeMap<usize, Vec<usize>>,
    welded: &[Welded],
    model_of: &BTreeMap<usize, u32>,
    e: usize,
    centre: Vec3,
    lm: &derma_head::Landmarks,
) -> crate::Result<[Vec<u32>; 2]> {
    let name = ["left", "right"][e];
    let ring = loop_around(adj, welded, |p| side(p) == e, centre).ok_or_else(|| {
        derma_core::Invalid::new(
            format!("the lid margin around the {name} eye"),
            "a closed loop along the seam between the skin and the socket charts",
            "none found",
        )
    })?;
    let nearest = |p: Vec3| {
        (0..ring.len())
            .min_by(|&a, &b| {
                (welded[ring[a]].0 - p)
                    .length_squared()
                    .total_cmp(&(welded[ring[b]].0 - p).length_squared())
            })
            .expect("non-empty ring")
    };
    let inner = nearest(lm.get(&format!("canthus_inner_{name}")));
    let outer = nearest(lm.get(&format!("canthus_outer_{name}")));
    let n = ring.len();
    let walk = |step: usize| {
        let mut c = vec![ring[inner]];
        let mut k = inner;
        while k != outer {
            k = (k + step) % n;
            c.push(ring[k]);
        }
        c
    };
    let (a, b) = (walk(1), walk(n - 1));
    let mean_y = |c: &[usize]| c.iter().map(|&i| welded[i].0.y).sum::<f32>() / c.len() as f32;
    let (upper, lower) = if mean_y(&a) > mean_y(&b) {
        (a, b)
    } else {
        (b, a)
    };
    let to_model = |c: Vec<usize>| -> crate::Result<Vec<u32>> {
        c.iter()
            .map(|id| {
                model_of.get(id).copied().ok_or_else(|| {
                    crate::EyesError::Invalid(derma_core::Invalid::new(
                        format!("the lid margin of the {name} eye"),
                        "vertices all moved by the eye units",
                        "a vertex they do not move",
                    ))
                })
            })
            .collect()
    };
    Ok([to_model(upper)?, to_model(lower)?])
}

/// The closed loop of seam vertices on one side, the one nearest the eye centre.
fn loop_around(
    adj: &BTreeMap<usize, Vec<usize>>,
    welded: &[Welded],
    on_side: impl Fn(Vec3) -> bool,
    centre: Vec3,
) -> Option<Vec<usize>> {
    let start = adj
        .keys()
        .copied()
        .filter(|&v| on_side(welded[v].0))
        .min_by(|&a, &b| {
            let d = |v: usize| {
                let p = welded[v].0 - centre;
                Vec2::new(p.x, p.y).length()
            };
            d(a).total_cmp(&d(b))
        })?;
    let mut ring = vec![start];
    let mut prev = usize::MAX;
    let mut cur = start;
    loop {
        let next = adj[&cur].iter().copied().find(|&n| n != prev && n != cur)?;
        if next == start {
            break;
        }
        if ring.len() > adj.len() {
            return None;
        }
        ring.push(next);
        prev = cur;
        cur = next;
    }
    (ring.len() >= 8).then_some(ring)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_box_is_authored_on_the_built_in_heads_face_height() {
        let head = derma_head::Head::builtin();
        let eyes = 0.5 * (head.eyes[0].centre.y + head.eyes[1].centre.y);
        let h = eyes - head.landmarks.get("subnasale").y;
        assert!((h - super::EYE_TO_SUBNASALE_MM).abs() < 0.05, "{h}");
    }
}
