//! A scan's unit and axes found from its face, not from its bounding box: the template's face
//! is tried at every axis-aligned orientation (±X/±Y/±Z up × facing), at face sizes from a
//! mask's to a full body's head, placed at the scan's forward-most points, and refined by a
//! similarity ICP with a free scale (Besl & McKay 1992; Umeyama 1991). The adult-face range
//! (Farkas 1994, "Anthropometry of the Head and Face": ±15 %) then tells a unit from a guess.

use super::align;
use super::options::{FitError, Similarity, SCALE_RANGE};
use super::scan::Scan;
use derma_core::head_mesh::{axis_name, upright, MeshFrame};
use derma_core::mesh::LengthUnit;
use glam::{Mat3, Vec2, Vec3};
use rayon::prelude::*;

/// The template's face as the search sees it (template mm, +Y up, facing +Z).
#[derive(Clone, Copy)]
pub struct Face<'a> {
    /// Points of the face.
    pub points: &'a [Vec3],
    /// Their normals.
    pub normals: &'a [Vec3],
    /// The nose tip.
    pub nose: Vec3,
    /// Menton to hairline (mm): the face's height.
    pub height: f32,
    /// Points of the whole head above the chin.
    pub head_points: &'a [Vec3],
    /// Their normals.
    pub head_normals: &'a [Vec3],
    /// Points of the nose (the face within 25 mm of its tip).
    pub nose_points: &'a [Vec3],
    /// Their normals.
    pub nose_normals: &'a [Vec3],
}

/// What the search found.
#[derive(Clone, Debug)]
pub struct Found {
    /// The scan's unit and axes (its part is the caller's to set).
    pub frame: MeshFrame,
    /// The template's placement in derma's frame (template mm → scan mm, turned upright).
    pub start: Similarity,
    /// The template's placement in the scan's own coordinates (template mm → scan units).
    pub placement: Similarity,
    /// The face's size relative to the template's, read in the frame's unit.
    pub face_scale: f32,
    /// How well the template's face fits there ([`MIN_SCORE`]).
    pub score: f32,
    /// How many placements were tried.
    pub tried: usize,
}

impl Found {
    /// How sure the unit is, in words.
    pub fn unit_in_words(&self) -> String {
        match self.frame.unit {
            Some(u) => format!(
                "{} ({} mm per unit: read so, the face is ×{:.2} the template's; adult faces span about ×0.85–1.15)",
                u.long_name(),
                self.frame.mm_per_unit,
                self.face_scale
            ),
            None => format!(
                "no unit of mm, cm or m: {:.4} mm per unit from the face's size (good to about ±15 %, as adult faces vary)",
                self.frame.mm_per_unit
            ),
        }
    }
}

/// The 24 rotations that map axes onto axes (file → derma).
pub fn axis_rotations() -> Vec<Mat3> {
    let axes = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let mut out = Vec::with_capacity(24);
    for &front in &axes {
        for &up in &axes {
            if up.dot(front).abs() < 0.5 {
                out.push(upright(up, front));
            }
        }
    }
    out
}

/// Share of the face's points whose placed position lies within `tau` (scan units) of the scan
/// where it faces the same way (the fit's matching rule).
fn share(scan: &Scan, points: &[Vec3], normals: &[Vec3], s: &Similarity, tau: f32) -> f32 {
    let hits = points
        .iter()
        .zip(normals)
        .filter(|(p, n)| scan.matched(s.apply(**p), s.rotation * **n, tau).is_some())
        .count();
    hits as f32 / points.len().max(1) as f32
}

/// Share of the head's points that the placement puts in the free space in front of the
/// scan: their closest scan point (within `reach`) lies more than `tau` behind them along the
/// scan's normal. A face placed upside down or sideways pushes its jaw, neck or cranium out
/// into the air; placed right, what the scan lacks (a mask's missing cranium) lies behind it
/// or out of reach and counts nothing, and hair covers the cranium.
fn in_front(scan: &Scan, points: &[Vec3], s: &Similarity, tau: f32, reach: f32) -> f32 {
    let hits = points
        .iter()
        .filter(|p| {
            let q = s.apply(**p);
            scan.bvh
                .closest(q, reach)
                .is_some_and(|c| (q - c.point).dot(scan.face_normals[c.triangle as usize]) > tau)
        })
        .count();
    hits as f32 / points.len().max(1) as f32
}

/// Share of the face's points whose closest scan point (within `reach`) faces within `cos` of
/// the placed point's normal.
fn aligned(
    scan: &Scan,
    points: &[Vec3],
    normals: &[Vec3],
    s: &Similarity,
    reach: f32,
    cos: f32,
) -> f32 {
    let hits = points
        .iter()
        .zip(normals)
        .filter(|(p, n)| {
            scan.bvh
                .closest(s.apply(**p), reach)
                .is_some_and(|c| scan.face_normals[c.triangle as usize].dot(s.rotation * **n) > cos)
        })
        .count();
    hits as f32 / points.len().max(1) as f32
}

/// How well a placement fits: the face's share within `tau` less the head's share in front of
/// the scan.
fn score(
    scan: &Scan,
    face: &[Vec3],
    normals: &[Vec3],
    head: &[Vec3],
    s: &Similarity,
    tau: f32,
) -> f32 {
    share(scan, face, normals, s, tau * s.scale)
        - in_front(scan, head, s, 6.0 * s.scale, 40.0 * s.scale)
}

/// Share of the face's points near the scan whose scan point, mirrored across the placement's
/// midsagittal plane, is on the scan too: a face is symmetric about its own midline, not about
/// a plane across it (a placement turned sideways).
fn mirrored(scan: &Scan, points: &[Vec3], s: &Similarity, tau: f32) -> f32 {
    let normal = (s.rotation * Vec3::X).normalize_or_zero();
    let origin = s.translation;
    let hits = points
        .iter()
        .filter_map(|p| scan.bvh.closest(s.apply(*p), 2.0 * tau))
        .filter(|c| {
            let q = c.point - 2.0 * (c.point - origin).dot(normal) * normal;
            scan.bvh.closest(q, tau).is_some()
        })
        .count();
    hits as f32 / points.len().max(1) as f32
}

/// The refined placement's score, of at most 4: the face's share within 3 mm; its share
/// facing within 25° of the scan (a face upside down keeps much of its surface near a smooth
/// sculpture, not its normals); its share whose scan point mirrors onto the scan (symmetry
/// about its own midline); its nose's share within 3 mm; less the head's share in front of the
/// scan. A placement whose nose misses the scan (under [`MIN_NOSE`]) is no face: smooth,
/// symmetric things (a cylinder, a sphere) fit the rest well enough.
fn final_score(
    scan: &Scan,
    face: &Face,
    pts: &[Vec3],
    nrm: &[Vec3],
    head: &[Vec3],
    s: &Similarity,
) -> f32 {
    let nose = share(scan, face.nose_points, face.nose_normals, s, 3.0 * s.scale);
    if nose < MIN_NOSE {
        return f32::NEG_INFINITY;
    }
    score(scan, pts, nrm, head, s, 3.0)
        + aligned(scan, pts, nrm, s, 6.0 * s.scale, 0.9)
        + mirrored(scan, pts, s, 3.0 * s.scale)
        + nose
}

/// The share of the nose (the face within 25 mm of its tip) a face needs within 3 mm of the
/// scan: real heads and sculptures 0.68–0.90, a cylinder 0.08, a sphere 0.03.
pub const MIN_NOSE: f32 = 0.3;

/// Every `k`-th element, at most about `n` of them.
fn thin<T: Copy>(v: &[T], n: usize) -> Vec<T> {
    v.iter()
        .step_by((v.len() / n.max(1)).max(1))
        .copied()
        .collect()
}

/// A placement to try: scan units per template mm, the rotation template → scan, the nose.
#[derive(Clone, Copy)]
struct Try {
    scale: f32,
    rotation: Mat3,
    nose: Vec3,
}

impl Try {
    fn similarity(&self, face: &Face) -> Similarity {
        Similarity {
            scale: self.scale,
            rotation: self.rotation,
            translation: self.nose - self.scale * (self.rotation * face.nose),
        }
    }
}

/// What is known of the scan before the search: its unit and its axes, when given.
#[derive(Clone, Copy, Debug, Default)]
pub struct Given {
    /// Millimetres per unit (then only the axes and the placement are searched).
    pub mm_per_unit: Option<f32>,
    /// The rotation from the file's axes to derma's (then only the unit and the placement).
    pub axes: Option<Mat3>,
}

/// Finds the scan's unit and axes from its face. A scan whose triangles face inward is told so
/// (its face is found on the scan turned inside out); two different placements that fit about as well
/// are refused as ambiguous, naming both.
pub fn search(scan: &Scan, face: &Face, given: Given) -> Result<Found, FitError> {
    let found = search_facing(scan, face, given);
    if !matches!(&found, Err(Miss::NoFace(_))) {
        return found.map_err(|m| FitError::Scan(m.to_string()));
    }
    // The scan turned inside out: its face is found there if its triangles face inward.
    let mut turned = scan.mesh.clone();
    for t in &mut turned.triangles {
        t.swap(1, 2);
    }
    match search_facing(&Scan::new(turned), face, given) {
        Ok(_) | Err(Miss::Ambiguous(_)) => Err(FitError::Scan(
            "the scan's triangles face inward (its face is found only with every normal turned): flip its normals (reverse the winding) and try again".into(),
        )),
        Err(_) => Err(FitError::Scan(found.err().map(|m| m.to_string()).unwrap_or_default())),
    }
}

/// Why no frame was found.
enum Miss {
    NoFace(String),
    Ambiguous(String),
}

impl std::fmt::Display for Miss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Miss::NoFace(s) | Miss::Ambiguous(s) => f.write_str(s),
        }
    }
}

fn search_facing(scan: &Scan, face: &Face, given: Given) -> Result<Found, Miss> {
    let extent = scan.mesh.extent();
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(Miss::NoFace(format!(
            "its largest extent is {extent}; expected a positive size"
        )));
    }
    // Face heights (scan units) to try: a face mask fills the mesh, a full body's face is a
    // tenth of it; with a unit, the adult range around the template's.
    let heights: Vec<f32> = match given.mm_per_unit {
        Some(k) => [0.85, 1.0, 1.18]
            .iter()
            .map(|f| f * face.height / k)
            .collect(),
        None => std::iter::successors(Some(1.2 * extent), |h| Some(h * 0.72))
            .take_while(|&h| h >= extent / 16.0)
            .collect(),
    };
    let rotations = match given.axes {
        Some(r) => vec![r],
        None => axis_rotations(),
    };
    let (tries, group) = placements(scan, face, &heights, &rotations);
    let refined = refine(scan, face, &tries, &group, given.mm_per_unit);
    decide(&refined, &heights, given, tries.len(), face.height)
}

/// Every placement to try: at each rotation, turned as [`TURNS`], each face height, the
/// template's nose on each of the scan's forward-most points; with each its orientation's
/// group (rotation and pitch).
fn placements(
    scan: &Scan,
    face: &Face,
    heights: &[f32],
    rotations: &[Mat3],
) -> (Vec<Try>, Vec<usize>) {
    // The height fields need only a sample of a fine scan's vertices.
    let sample = thin(&scan.mesh.positions, 20_000);
    let orientations: Vec<(usize, Mat3)> = rotations
        .iter()
        .flat_map(|r| {
            TURNS.iter().map(move |&(pitch, yaw)| {
                Mat3::from_rotation_y(yaw) * Mat3::from_rotation_x(pitch) * *r
            })
        })
        .enumerate()
        .collect();
    let per: Vec<Vec<(usize, Try)>> = orientations
        .par_iter()
        .map(|&(g, r)| {
            // Looking down (a bust's head bowed) or up, or aside: the nose is the forward-most
            // point along the turned front.
            let (right, up, front) = (r.row(0), r.row(1), r.row(2));
            heights
                .iter()
                .flat_map(|&h| {
                    forward_points(&sample, right, up, front, h)
                        .into_iter()
                        .map(move |nose| {
                            (
                                g,
                                Try {
                                    scale: h / face.height,
                                    rotation: r.transpose(),
                                    nose,
                                },
                            )
                        })
                })
                .collect()
        })
        .collect();
    let (group, tries): (Vec<usize>, Vec<Try>) = per.into_iter().flatten().unzip();
    (tries, group)
}

/// Head turns tried at each rotation: pitch and yaw (radians; ±26°).
const TURNS: [(f32, f32); 9] = [
    (0.0, 0.0),
    (-0.45, 0.0),
    (0.45, 0.0),
    (0.0, -0.45),
    (0.0, 0.45),
    (-0.45, -0.45),
    (-0.45, 0.45),
    (0.45, -0.45),
    (0.45, 0.45),
];

/// Quick scores on a few points; the best [`PER_ORIENTATION`] placements of every orientation
/// refined by a similarity ICP (free scale, or the unit's adult range) and scored in full.
fn refine(
    scan: &Scan,
    face: &Face,
    tries: &[Try],
    group: &[usize],
    fixed_mm: Option<f32>,
) -> Vec<(Similarity, f32)> {
    let quick_pts = thin(face.points, 64);
    let quick_nrm = thin(face.normals, 64);
    let quick_head = thin(face.head_points, 64);
    let quick: Vec<f32> = tries
        .par_iter()
        .map(|t| {
            score(
                scan,
                &quick_pts,
                &quick_nrm,
                &quick_head,
                &t.similarity(face),
                6.0,
            )
        })
        .collect();
    let mut order: Vec<usize> = (0..tries.len()).collect();
    order.sort_by(|&a, &b| quick[b].total_cmp(&quick[a]).then(a.cmp(&b)));
    let mut taken = vec![0usize; group.iter().max().map_or(0, |g| g + 1)];
    order.retain(|&i| {
        taken[group[i]] += 1;
        taken[group[i]] <= PER_ORIENTATION
    });
    // A short refinement of each on fewer points, then the best continued on more.
    let scale_ok = |s: &Similarity| {
        fixed_mm.is_none_or(|k| (SCALE_RANGE.0..=SCALE_RANGE.1).contains(&(s.scale * k)))
    };
    let judge = |s: Similarity, pts: &[Vec3], nrm: &[Vec3], head: &[Vec3]| {
        let fit = if scale_ok(&s) && resolved(scan, &s, face) {
            final_score(scan, face, pts, nrm, head, &s)
        } else {
            f32::NEG_INFINITY
        };
        (s, fit)
    };
    let (p1, n1, h1) = (
        thin(face.points, 150),
        thin(face.normals, 150),
        thin(face.head_points, 150),
    );
    let mut first: Vec<(Similarity, f32)> = order
        .par_iter()
        .map(|&i| {
            let t = tries[i];
            let (s, _) = align::icp(scan, &p1, &n1, t.similarity(face), 6, 30.0 * t.scale);
            judge(s, &p1, &n1, &h1)
        })
        .collect();
    first.sort_by(|a, b| b.1.total_cmp(&a.1));
    first.truncate(CONTINUED);
    let (pts, nrm, head) = (
        thin(face.points, 400),
        thin(face.normals, 400),
        thin(face.head_points, 400),
    );
    first
        .par_iter()
        .map(|&(start, _)| {
            let (s, _) = align::icp(scan, &pts, &nrm, start, 12, 18.0 * start.scale);
            judge(s, &pts, &nrm, &head)
        })
        .collect()
}

/// Placements continued past the first, short refinement.
const CONTINUED: usize = 40;

/// Whether the scan is fine enough where the face is placed to show one: the triangles at its
/// nose tip are at most a third of the face's height across (a face placed on a low-poly bump
/// is no face).
fn resolved(scan: &Scan, s: &Similarity, face: &Face) -> bool {
    let nose = s.apply(face.nose);
    let Some(c) = scan.bvh.closest(nose, f32::INFINITY) else {
        return false;
    };
    let t = scan.mesh.triangles[c.triangle as usize].map(|v| scan.mesh.positions[v as usize]);
    let longest = (0..3)
        .map(|k| t[k].distance(t[(k + 1) % 3]))
        .fold(0.0f32, f32::max);
    longest <= s.scale * face.height / 3.0
}

/// The best refined placement, unless another orientation or size fits about as well.
fn decide(
    refined: &[(Similarity, f32)],
    heights: &[f32],
    given: Given,
    tried: usize,
    face_height: f32,
) -> Result<Found, Miss> {
    let mut ranked: Vec<&(Similarity, f32)> = refined.iter().filter(|r| r.1.is_finite()).collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    let Some(&&(best, top)) = ranked.first() else {
        return Err(Miss::NoFace(not_found(
            None,
            heights,
            given,
            tried,
            face_height,
        )));
    };
    if top < MIN_SCORE {
        return Err(Miss::NoFace(not_found(
            Some((&best, top)),
            heights,
            given,
            tried,
            face_height,
        )));
    }
    let differs = |s: &Similarity| {
        !snap(s.rotation.transpose()).abs_diff_eq(snap(best.rotation.transpose()), 1e-3)
            || (s.scale / best.scale).ln().abs() > 0.2
    };
    if let Some(&&(other, second)) = ranked.iter().find(|r| differs(&r.0)) {
        if top - second < MARGIN {
            return Err(Miss::Ambiguous(format!(
                "the face's placement is ambiguous: {} fits about as well as {}; give the mesh's axes or its landmarks",
                placement_in_words(&best, top, face_height),
                placement_in_words(&other, second, face_height)
            )));
        }
    }
    Ok(settle(&best, top, given.mm_per_unit, tried))
}

/// "+Y up, facing +Z, a face 0.18 units tall (score 1.22)".
fn placement_in_words(s: &Similarity, score: f32, face_height: f32) -> String {
    let r = snap(s.rotation.transpose()).transpose();
    format!(
        "{} up, facing {}, a face {:.3} units tall (score {score:.2})",
        axis_name(r * Vec3::Y).unwrap_or("?"),
        axis_name(r * Vec3::Z).unwrap_or("?"),
        s.scale * face_height
    )
}

/// Placements refined per orientation (axis rotation and turn).
const PER_ORIENTATION: usize = 2;

/// The score a face needs ([`final_score`], of at most 4). Real heads and faces score 3.0–3.6,
/// museum busts 2.6–2.8; the best wrong placements on them 1.6–2.0, and a stylized low-poly game
/// head's 1.8 (its cartoon nose misses the template's: give its axes or landmarks).
pub const MIN_SCORE: f32 = 2.2;

/// How far the best placement must score above any other orientation or size.
pub const MARGIN: f32 = 0.3;

fn not_found(
    best: Option<(&Similarity, f32)>,
    heights: &[f32],
    given: Given,
    tried: usize,
    face_height: f32,
) -> String {
    let best = best
        .map(|(s, t)| {
            format!(
                "; the best, {}, scored below {MIN_SCORE}",
                placement_in_words(s, t, face_height)
            )
        })
        .unwrap_or_default();
    let sizes = match given.mm_per_unit {
        Some(k) => format!("at {k} mm per unit"),
        None => format!(
            "faces {:.3}–{:.3} units tall",
            heights.last().copied().unwrap_or(0.0),
            heights.first().copied().unwrap_or(0.0)
        ),
    };
    let axes = match given.axes {
        Some(_) => "at the axes given",
        None => "every axis up (±X, ±Y, ±Z) and facing",
    };
    format!(
        "no face found on the scan: tried {tried} placements — {axes}, bowed, raised and turned aside, {sizes}{best}; check it is a head or face, or give its landmarks"
    )
}

/// The frame a placement (template mm → scan units) implies: the unit (when the face, read in
/// it, is an adult's size) or the face's own scale; the axis rotation nearest its rotation.
fn settle(s: &Similarity, score: f32, fixed_mm: Option<f32>, tried: usize) -> Found {
    let face_mm = 1.0 / s.scale;
    let (unit, mm) = match fixed_mm {
        Some(k) => (
            [LengthUnit::Mm, LengthUnit::Cm, LengthUnit::M]
                .into_iter()
                .find(|u| u.to_mm() == k),
            k,
        ),
        None => {
            let fits = |u: &LengthUnit| {
                let r = u.to_mm() / face_mm;
                (SCALE_RANGE.0..=SCALE_RANGE.1).contains(&r)
            };
            match [LengthUnit::Mm, LengthUnit::Cm, LengthUnit::M]
                .into_iter()
                .filter(fits)
                .min_by(|a, b| {
                    (a.to_mm() / face_mm)
                        .ln()
                        .abs()
                        .total_cmp(&(b.to_mm() / face_mm).ln().abs())
                }) {
                Some(u) => (Some(u), u.to_mm()),
                None => (None, face_mm),
            }
        }
    };
    let rotation = snap(s.rotation.transpose());
    let frame = MeshFrame {
        unit,
        mm_per_unit: mm,
        rotation,
        part: None,
    };
    let start = Similarity {
        scale: s.scale * mm,
        rotation: rotation * s.rotation,
        translation: rotation * (s.translation * mm),
    };
    Found {
        frame,
        start,
        placement: *s,
        face_scale: s.scale * mm,
        score,
        tried,
    }
}

/// The axis rotation nearest `r` (largest trace of `q · rᵀ`).
fn snap(r: Mat3) -> Mat3 {
    axis_rotations()
        .into_iter()
        .max_by(|a, b| {
            let t = |q: &Mat3| (0..3).map(|i| q.col(i).dot(r.col(i))).sum::<f32>();
            t(a).total_cmp(&t(b))
        })
        .unwrap_or(Mat3::IDENTITY)
}

/// The frame of a placement from landmarks (template mm → scan units, by Umeyama).
pub fn from_landmarks(s: &Similarity, fixed_mm: Option<f32>) -> Found {
    settle(s, 1.0, fixed_mm, 1)
}

/// The forward-most of `pts` (a scan's vertices) along `front` (unit; `right` and `up` span the view): the
/// local maxima of its height field over windows a fifth of a face of height `h` wide, the
/// twelve highest.
fn forward_points(pts: &[Vec3], right: Vec3, up: Vec3, front: Vec3, h: f32) -> Vec<Vec3> {
    let cell = h / 25.0;
    let uv = |p: Vec3| Vec2::new(p.dot(right), p.dot(up));
    let (lo, hi) = pts.iter().fold(
        (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(uv(*p)), hi.max(uv(*p))),
    );
    let dims = ((hi - lo) / cell).ceil().as_uvec2() + 1;
    let (w, hgt) = (dims.x as usize, dims.y as usize);
    if w * hgt > 1 << 20 {
        return Vec::new();
    }
    // Per cell: the highest point along `front`.
    let mut best: Vec<(f32, u32)> = vec![(f32::NEG_INFINITY, u32::MAX); w * hgt];
    for (i, p) in pts.iter().enumerate() {
        let c = ((uv(*p) - lo) / cell).as_uvec2();
        let k = c.y as usize * w + c.x as usize;
        let d = p.dot(front);
        if d > best[k].0 {
            best[k] = (d, i as u32);
        }
    }
    // Separable running maximum over a window of ±r cells.
    let r = 5usize;
    let height: Vec<f32> = best.iter().map(|b| b.0).collect();
    let mut rows = vec![f32::NEG_INFINITY; w * hgt];
    for y in 0..hgt {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(r), (x + r).min(w - 1));
            rows[y * w + x] = height[y * w + a..=y * w + b]
                .iter()
                .copied()
                .fold(f32::NEG_INFINITY, f32::max);
        }
    }
    let mut window = vec![f32::NEG_INFINITY; w * hgt];
    for y in 0..hgt {
        let (a, b) = (y.saturating_sub(r), (y + r).min(hgt - 1));
        for x in 0..w {
            window[y * w + x] = (a..=b)
                .map(|yy| rows[yy * w + x])
                .fold(f32::NEG_INFINITY, f32::max);
        }
    }
    let mut peaks: Vec<(f32, u32)> = (0..w * hgt)
        .filter(|&k| best[k].1 != u32::MAX && best[k].0 >= window[k])
        .map(|k| best[k])
        .collect();
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    peaks.truncate(12);
    peaks.into_iter().map(|(_, i)| pts[i as usize]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_axis_rotations_are_the_24_proper_ones() {
        let r = axis_rotations();
        assert_eq!(r.len(), 24);
        for (i, a) in r.iter().enumerate() {
            assert!((a.determinant() - 1.0).abs() < 1e-6);
            assert!((*a * a.transpose()).abs_diff_eq(Mat3::IDENTITY, 1e-6));
            for b in &r[..i] {
                assert!(!a.abs_diff_eq(*b, 1e-6), "duplicate");
            }
        }
        // A Z-up scan facing −Y: its +Z goes to derma's +Y, its −Y to derma's +Z.
        let z_up = upright(Vec3::Z, Vec3::NEG_Y);
        assert!((z_up * Vec3::Z).abs_diff_eq(Vec3::Y, 1e-6));
        assert!((z_up * Vec3::NEG_Y).abs_diff_eq(Vec3::Z, 1e-6));
        // Snapping a slightly turned rotation returns the axis rotation.
        let tilted = Mat3::from_rotation_x(0.3) * z_up;
        assert!(snap(tilted).abs_diff_eq(z_up, 1e-6));
    }

    #[test]
    fn a_unit_is_taken_only_where_the_face_is_an_adults() {
        let s = |scale: f32| Similarity {
            scale,
            rotation: Mat3::IDENTITY,
            translation: Vec3::ZERO,
        };
        // A face at ×1.05 in centimetres: 0.105 units per template mm.
        let f = from_landmarks(&s(0.105), None);
        assert_eq!(f.frame.unit, Some(LengthUnit::Cm));
        assert!((f.face_scale - 1.05).abs() < 1e-4);
        // 1 unit ≈ 42 mm: no unit makes it an adult's face; the face's own scale is taken.
        let g = from_landmarks(&s(1.0 / 42.0), None);
        assert_eq!(g.frame.unit, None);
        assert!((g.frame.mm_per_unit - 42.0).abs() < 1e-3);
        assert!((g.start.scale - 1.0).abs() < 1e-5);
        // A given unit is kept, whatever the face's size.
        let h = from_landmarks(&s(0.05), Some(10.0));
        assert_eq!(h.frame.unit, Some(LengthUnit::Cm));
        assert!((h.face_scale - 0.5).abs() < 1e-5);
    }
}
