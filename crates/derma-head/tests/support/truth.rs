//! Ground truth for the fit: the built-in head's outer skin retriangulated (the other quad
//! diagonal), its vertices slid along the surface, warped, rotated, moved and put in cm.

use derma_core::mesh::TriMesh;
use derma_head::fit::{template::Template, Fitted};
use derma_test_support::truth_scan::{slide, Placement, Warp};
use glam::{Mat3, Vec3};

/// A scan with known correspondence.
pub struct Case {
    /// The scan (mm: the placement's unit change undone, as the loader would).
    pub scan: TriMesh,
    /// The same scan in centimetres, as a user's file would hold it.
    pub scan_cm: TriMesh,
    /// Where each template fine vertex truly lies (mm, the scan's frame).
    pub truth: Vec<Vec3>,
    /// Template fine vertices of the face (where accuracy is asked).
    pub face: Vec<usize>,
    /// The true landmarks (mm, scan frame).
    pub landmarks: derma_head::Landmarks,
}

/// Errors of a fit against the truth (mm).
pub struct Measured {
    pub rms: f32,
    pub p95: f32,
    pub max: f32,
    pub landmark_max: f32,
}

/// The case of `seed`, warped by up to `peak_mm`; `levels` more subdivisions change density.
pub fn case(seed: u64, peak_mm: f32, sigma_mm: f32) -> Case {
    case_split(seed, peak_mm, sigma_mm, 0)
}

/// [`case`] with the scan's triangles split `splits` times.
pub fn case_split(seed: u64, peak_mm: f32, sigma_mm: f32, splits: usize) -> Case {
    let asset = derma_head::asset::parse();
    let tpl = Template::of(&asset);
    let p2 = tpl.stencils2.apply(&tpl.coarse.positions);
    let n2 = Template::normals(&tpl.level2, &p2);
    let warp = Warp::random(seed, &p2, 14, sigma_mm, peak_mm);
    let a = seed as f32;
    let place = Placement {
        rotation: Mat3::from_euler(
            glam::EulerRot::YXZ,
            (0.15 * (a * 1.3).sin()).to_radians() * 60.0,
            (0.08 * (a * 2.1).cos()).to_radians() * 60.0,
            (0.05 * (a * 0.7).sin()).to_radians() * 60.0,
        ),
        translation: Vec3::new(12.0 * a.sin(), -30.0, 40.0),
        mm_per_unit: 10.0,
    };
    let mm = |p: Vec3| place.apply(p) * place.mm_per_unit;
    // Scan vertices: the outer skin's, slid along the surface, then warped and placed.
    let mut verts = p2.clone();
    slide(&mut verts, &n2, 1.5, 0.35, seed);
    // One scan vertex per (position, UV) corner of the outer skin's chart: the chart has a
    // seam (the back of the head), where a position has two UVs, as scans with UVs do.
    let chart = asset.meta.charts["skin"];
    let in_chart =
        |u: glam::Vec2| u.x >= chart[0] && u.x <= chart[2] && u.y >= chart[1] && u.y <= chart[3];
    let mut index: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    let mut scan = TriMesh::default();
    for q in &tpl.level2.quads {
        if !q
            .iter()
            .all(|c| tpl.outer2[c.0 as usize] && in_chart(tpl.level2.uvs[c.1 as usize]))
        {
            continue;
        }
        let [a, b, c, d] = q.map(|(v, t)| {
            *index.entry((v, t)).or_insert_with(|| {
                scan.positions.push(mm(warp.apply(verts[v as usize])));
                scan.uvs.push(tpl.level2.uvs[t as usize]);
                (scan.positions.len() - 1) as u32
            })
        });
        scan.triangles.push([a, b, d]);
        scan.triangles.push([b, c, d]);
    }
    scan.compute_normals();
    // Subdivided `splits` times (each triangle into four at its edge midpoints), for timing
    // the fit at other densities.
    for _ in 0..splits {
        scan = split(&scan);
    }
    let mut scan_cm = scan.clone();
    scan_cm.scale(0.1);
    let truth: Vec<Vec3> = p2.iter().map(|p| mm(warp.apply(*p))).collect();
    let head = derma_head::Head::builtin();
    let lm = &head.landmarks;
    let ear_z = 0.5 * (lm.get("ear_left").z + lm.get("ear_right").z);
    let (lo, hi) = (lm.get("menton").y, lm.get("hairline").y);
    let face = (0..p2.len())
        .filter(|&i| tpl.outer2[i] && p2[i].z > ear_z + 30.0 && (lo..hi).contains(&p2[i].y))
        .collect();
    let landmarks = derma_head::Landmarks {
        points: lm
            .points
            .iter()
            .filter(|(n, _)| !n.starts_with("eye_centre"))
            .map(|(n, p)| (n.clone(), mm(warp.apply(*p))))
            .collect(),
    };
    Case {
        scan,
        scan_cm,
        truth,
        face,
        landmarks,
    }
}

/// Each triangle into four at its edge midpoints (flat: the surface is kept).
fn split(m: &TriMesh) -> TriMesh {
    let mut out = m.clone();
    out.triangles.clear();
    let mut mid: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    let mut at = |a: u32, b: u32, out: &mut TriMesh| {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let (a, b) = (a as usize, b as usize);
            out.positions.push(0.5 * (m.positions[a] + m.positions[b]));
            out.normals
                .push((m.normals[a] + m.normals[b]).normalize_or_zero());
            out.uvs.push(0.5 * (m.uvs[a] + m.uvs[b]));
            (out.positions.len() - 1) as u32
        })
    };
    for t in &m.triangles {
        let [a, b, c] = *t;
        let (ab, bc, ca) = (at(a, b, &mut out), at(b, c, &mut out), at(c, a, &mut out));
        out.triangles
            .extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    out
}

impl Case {
    /// The fit's errors on the face and at the landmarks.
    pub fn measure(&self, f: &Fitted) -> Measured {
        let mut e: Vec<f32> = self
            .face
            .iter()
            .map(|&i| (f.fine[i] - self.truth[i]).length())
            .collect();
        let rms = (e.iter().map(|x| x * x).sum::<f32>() / e.len() as f32).sqrt();
        e.sort_by(f32::total_cmp);
        let asset = derma_head::asset::parse();
        let landmark_max = self
            .landmarks
            .points
            .keys()
            .filter(|n| !n.starts_with("ear") && *n != "hairline")
            .map(|n| {
                let v = asset.meta.landmarks[n] as usize;
                (f.fine[v] - self.truth[v]).length()
            })
            .fold(0.0f32, f32::max);
        Measured {
            rms,
            p95: e[e.len() * 95 / 100],
            max: *e.last().unwrap(),
            landmark_max,
        }
    }
}
