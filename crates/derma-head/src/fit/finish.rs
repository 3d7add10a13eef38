//! The fitted skin finished: moved onto the scan along its normals where the scan is as fine
//! as the skin, its folds opened (umbrella smoothing, then the placed template's shape over a
//! growing region), counted, and the globes seated behind the lids (docs/head.md, "Fitting
//! your head", steps 4–5).

use super::scan::{self, Scan};
use super::template::Template;
use crate::asset::EyeSphere;
use glam::Vec3;
use rayon::prelude::*;

/// The median distance (mm) of the fitted skin's face vertices (`face2`) to the scan, within
/// 10 mm; None when none is that close.
pub fn median_distance(scan: &Scan, fine: &[Vec3], face2: &[usize]) -> Option<f32> {
    let mut dist: Vec<f32> = face2
        .par_iter()
        .filter_map(|&i| scan.bvh.closest(fine[i], 10.0).map(|c| c.distance))
        .collect();
    dist.sort_by(f32::total_cmp);
    dist.get(dist.len() / 2).copied()
}

/// Moves the outer skin's fine vertices onto the scan along their normals (within 2.5 mm, where
/// the scan faces the same way), then undoes the move on any quad it would turn over.
pub fn project(scan: &Scan, tpl: &Template, fine: &mut [Vec3]) {
    let normals = Template::normals(&tpl.level2, fine);
    let moved: Vec<Option<Vec3>> = (0..fine.len())
        .into_par_iter()
        .map(|i| {
            if !tpl.outer2[i] {
                return None;
            }
            let (p, n) = (fine[i], normals[i]);
            let hit = |d: Vec3| scan.bvh.nearest(p, d, 0.0, 2.5).map(|h| (h.t, h.triangle));
            let best = match (hit(n), hit(-n)) {
                (Some(a), Some(b)) => Some(if a.0 <= b.0 {
                    (a.0, a.1, n)
                } else {
                    (b.0, b.1, -n)
                }),
                (Some(a), None) => Some((a.0, a.1, n)),
                (None, Some(b)) => Some((b.0, b.1, -n)),
                (None, None) => None,
            }?;
            let t = best.1 as usize;
            (!scan.on_border[t] && scan.face_normals[t].dot(n) >= scan::NORMAL_COS)
                .then(|| p + best.2 * best.0)
        })
        .collect();
    let before = fine.to_vec();
    for (f, m) in fine.iter_mut().zip(&moved) {
        if let Some(q) = m {
            *f = *q;
        }
    }
    // Undo on quads either of whose triangles turns against its pre-projection orientation
    // (or by more than 75°); repeat, as undoing one quad can turn a neighbour.
    for _ in 0..8 {
        let mut undone = false;
        for q in &tpl.level2.quads {
            let [a, b, c, d] = q.map(|c| c.0 as usize);
            let turned = [[a, b, c], [a, c, d]].iter().any(|t| {
                let n = |p: &[Vec3]| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
                let (n0, n1) = (n(&before), n(fine));
                n0.dot(n1) <= 0.25 * n0.length() * n1.length()
            });
            if turned {
                for v in [a, b, c, d] {
                    if fine[v] != before[v] {
                        fine[v] = before[v];
                        undone = true;
                    }
                }
            }
        }
        if !undone {
            break;
        }
    }
}

/// Smooths away folds, locally, in two passes (what remains is reported as `flipped`):
/// 1. the corners of every triangle turned over against the template, and their ring, move to
///    their neighbours' mean (umbrella smoothing), for at most 50 rounds: small folds on the
///    surface open;
/// 2. where folds remain (an ear or a canthus the registration folded, its scan's shape unlike
///    the template's), the displacement from the placed template is smoothed instead, over a
///    region that grows by a ring at a time: the template's own shape returns there, moved
///    with its surroundings.
pub fn untangle(tpl: &Template, fine: &mut [Vec3], template: &[Vec3]) {
    let ring = vertex_rings(tpl, fine.len());
    for _ in 0..50 {
        let bad = folded(tpl, fine, template, 0.1);
        if bad.is_empty() {
            return;
        }
        let region = grown(&bad, &ring, 1);
        let next: Vec<Vec3> = region
            .iter()
            .map(|&v| mean(&ring[v], |u| fine[u]))
            .collect();
        for (&v, p) in region.iter().zip(next) {
            fine[v] = p;
        }
    }
    for rings in 1..=40 {
        let bad = folded(tpl, fine, template, 0.1);
        if bad.is_empty() {
            return;
        }
        let region = grown(&bad, &ring, rings);
        // Enough sweeps for the displacement to settle over the region (diffusion over k
        // rings takes about k² of them).
        for _ in 0..(4 * rings * rings).clamp(20, 400) {
            let next: Vec<Vec3> = region
                .iter()
                .map(|&v| template[v] + mean(&ring[v], |u| fine[u] - template[u]))
                .collect();
            for (&v, p) in region.iter().zip(next) {
                fine[v] = p;
            }
        }
    }
}

/// Each fine skin vertex's neighbours along quad edges.
fn vertex_rings(tpl: &Template, n: usize) -> Vec<Vec<u32>> {
    let mut ring: Vec<Vec<u32>> = vec![Vec::new(); n];
    for q in &tpl.level2.quads {
        for k in 0..4 {
            let (a, b) = (q[k].0, q[(k + 1) % 4].0);
            ring[a as usize].push(b);
            ring[b as usize].push(a);
        }
    }
    for r in &mut ring {
        r.sort_unstable();
        r.dedup();
    }
    ring
}

/// The corners of triangles turned (by more than acos `cos`) against the template's.
fn folded(tpl: &Template, fine: &[Vec3], template: &[Vec3], cos: f32) -> Vec<usize> {
    let mut bad: Vec<usize> = Vec::new();
    for q in &tpl.level2.quads {
        let [a, b, c, d] = q.map(|c| c.0 as usize);
        for t in [[a, b, c], [a, c, d]] {
            let n = |p: &[Vec3]| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
            let (n0, n1) = (n(template), n(fine));
            if n0.length_squared() > 1e-12 && n0.dot(n1) <= cos * n0.length() * n1.length() {
                bad.extend(t);
            }
        }
    }
    bad.sort_unstable();
    bad.dedup();
    bad
}

/// `seed` and its `k`-ring.
fn grown(seed: &[usize], ring: &[Vec<u32>], k: usize) -> Vec<usize> {
    let mut region = seed.to_vec();
    for _ in 0..k {
        region = region
            .iter()
            .flat_map(|&v| ring[v].iter().map(|&u| u as usize).chain([v]))
            .collect();
        region.sort_unstable();
        region.dedup();
    }
    region
}

/// The mean of `f` over a ring.
fn mean(ring: &[u32], f: impl Fn(usize) -> Vec3) -> Vec3 {
    ring.iter().map(|&u| f(u as usize)).sum::<Vec3>() / ring.len().max(1) as f32
}

/// Triangles of the fitted skin turned over against the template's (placed) orientation.
pub fn flipped_quads(tpl: &Template, fine: &[Vec3], template: &[Vec3]) -> usize {
    tpl.level2
        .quads
        .iter()
        .flat_map(|q| {
            let [a, b, c, d] = q.map(|c| c.0 as usize);
            [[a, b, c], [a, c, d]]
        })
        .filter(|t| {
            let n = |p: &[Vec3]| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
            let (n0, n1) = (n(template), n(fine));
            n0.length_squared() > 1e-12 && n0.dot(n1) <= 0.0
        })
        .count()
}

/// Pushes a globe back along the head's forward axis until no outer skin vertex lies within
/// 0.3 mm inside it (a lid resting on the globe, not through it).
pub fn seat_globe(e: &mut EyeSphere, fine: &[Vec3], outer: &[bool], forward: Vec3) {
    let c = Vec3::from(e.centre);
    let worst = fine
        .iter()
        .zip(outer)
        .filter(|(p, o)| **o && (**p - c).length() < 2.0 * e.radius)
        .map(|(p, _)| (*p - c).length() - e.radius)
        .fold(f32::INFINITY, f32::min);
    if worst < 0.3 {
        e.centre = (c - forward * (0.3 - worst)).to_array();
    }
}
