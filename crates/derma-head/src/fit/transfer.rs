//! What follows the skin's registration: face units carried onto the fitted skin by
//! deformation transfer (Sumner & Popović 2004, "Deformation transfer for triangle meshes",
//! SIGGRAPH, §3–4), and the parts (globes, teeth, tongue, lashes) moved by the registration's
//! local affine maps, blended from the nearest control vertices.

use super::nicp::Affines;
use derma_core::numerics::{NumericsError, SparseCholesky};
use glam::{Mat3, Vec3};
use std::collections::HashMap;

/// Control vertices blended for a point off the skin.
const NEIGHBOURS: usize = 8;

/// The registration's map near a point: blended affine of its nearest control vertices.
pub struct LocalMap<'a> {
    /// The maps.
    pub affines: &'a Affines,
    /// Control vertex positions (mm, aligned frame).
    pub control: &'a [Vec3],
}

impl LocalMap<'_> {
    fn weights(&self, p: Vec3) -> Vec<(usize, f32)> {
        let mut d: Vec<(usize, f32)> = self
            .control
            .iter()
            .enumerate()
            .map(|(j, c)| (j, (*c - p).length_squared()))
            .collect();
        let k = NEIGHBOURS.min(d.len() - 1);
        d.select_nth_unstable_by(k, |a, b| a.1.total_cmp(&b.1));
        d.truncate(NEIGHBOURS);
        // Inverse-square weights with a 1 mm² floor (no pole at a control vertex).
        let w: Vec<(usize, f32)> = d.iter().map(|&(j, d2)| (j, 1.0 / (d2 + 1.0))).collect();
        let total: f32 = w.iter().map(|x| x.1).sum();
        w.into_iter().map(|(j, x)| (j, x / total)).collect()
    }

    /// Where `p` (aligned frame) goes.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.weights(p)
            .iter()
            .map(|&(j, w)| self.affines.moved(j, p) * w)
            .sum()
    }

    /// The linear part of the map at `p` (for offsets and radii).
    pub fn linear(&self, p: Vec3) -> Mat3 {
        let mut m = Mat3::ZERO;
        for (j, w) in self.weights(p) {
            m += self.affines.linear(j) * w;
        }
        m
    }
}

/// Sumner & Popović's fourth vertex: the unit normal scaled by √(2·area), so a triangle's
/// frame [e₁ e₂ n] deforms like a tetrahedron (eq. 1).
fn frame(a: Vec3, b: Vec3, c: Vec3) -> Mat3 {
    let (e1, e2) = (b - a, c - a);
    let x = e1.cross(e2);
    let n = x / x.length().max(1e-12).sqrt();
    Mat3::from_cols(e1, e2, n)
}

/// Offsets of the target's control vertices for one face unit by deformation transfer: the
/// source's per-triangle deformation gradients Q = Ṽ V⁻¹ (eq. 2) applied to the target's
/// edges, integrated in least squares over the vertices the source moves (the others held).
/// `source` and `target` are the neutral control positions in one frame; `offsets` the unit's
/// source offsets by control vertex.
pub fn deformation_transfer(
    triangles: &[[u32; 3]],
    source: &[Vec3],
    target: &[Vec3],
    offsets: &HashMap<u32, Vec3>,
) -> Result<Vec<(u32, Vec3)>, NumericsError> {
    // Free vertices: those the source moves; their numbering in the system.
    let mut free: Vec<u32> = offsets.keys().copied().collect();
    free.sort_unstable();
    let slot: HashMap<u32, usize> = free.iter().enumerate().map(|(k, &v)| (v, k)).collect();
    let n = free.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    let moved = |v: u32| source[v as usize] + offsets.get(&v).copied().unwrap_or(Vec3::ZERO);
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    let mut rhs = vec![[0.0f64; 3]; n];
    for t in triangles {
        if !t.iter().any(|v| slot.contains_key(v)) {
            continue;
        }
        let [a, b, c] = *t;
        let vs = frame(source[a as usize], source[b as usize], source[c as usize]);
        let vd = frame(moved(a), moved(b), moved(c));
        if vs.determinant().abs() < 1e-12 {
            continue;
        }
        let q = vd * vs.inverse() - Mat3::IDENTITY;
        for (i, j) in [(a, b), (b, c), (c, a)] {
            // d_j − d_i ≈ (Q − I)(T_j − T_i).
            let r = q * (target[j as usize] - target[i as usize]);
            match (slot.get(&i), slot.get(&j)) {
                (Some(&si), Some(&sj)) => {
                    entries.push((si, si, 1.0));
                    entries.push((sj, sj, 1.0));
                    entries.push((si.max(sj), si.min(sj), -1.0));
                    for k in 0..3 {
                        rhs[sj][k] += r[k] as f64;
                        rhs[si][k] -= r[k] as f64;
                    }
                }
                (Some(&si), None) => {
                    // d_j = 0: d_i ≈ −r.
                    entries.push((si, si, 1.0));
                    for k in 0..3 {
                        rhs[si][k] -= r[k] as f64;
                    }
                }
                (None, Some(&sj)) => {
                    entries.push((sj, sj, 1.0));
                    for k in 0..3 {
                        rhs[sj][k] += r[k] as f64;
                    }
                }
                (None, None) => {}
            }
        }
    }
    // A vertex no triangle constrains (none here, but keep the system definite).
    for k in 0..n {
        entries.push((k, k, 1e-9));
    }
    let chol = SparseCholesky::new(n, &entries)?;
    let cols: Vec<Vec<f64>> = (0..3).map(|c| rhs.iter().map(|r| r[c]).collect()).collect();
    let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    let x = chol.solve_many(&refs)?;
    Ok(free
        .iter()
        .enumerate()
        .map(|(k, &v)| (v, Vec3::new(x[0][k] as f32, x[1][k] as f32, x[2][k] as f32)))
        .collect())
}

/// What the registration carries besides the skin: every asset vertex's position (the cage's
/// registered, the parts' by their local maps), the globes (radius by the cube root of the
/// local map's determinant, seated behind the lids), and the 52 face units (the skin's by
/// deformation transfer, the parts' through their local maps).
pub struct Carried {
    /// Every asset vertex (mm, the scan's frame).
    pub positions: Vec<Vec3>,
    /// Left and right globes.
    pub eyes: [crate::asset::EyeSphere; 2],
    /// The face units.
    pub targets: Vec<crate::asset::SparseTarget>,
}

/// Carries the asset through the registration `x` of its placed cage `control` (placed by
/// `sim`), the fine skin already fitted.
pub fn carry(
    asset: &crate::asset::Asset,
    tpl: &super::template::Template,
    sim: &super::options::Similarity,
    x: &Affines,
    control: &[Vec3],
    fine: &[Vec3],
) -> Result<Carried, NumericsError> {
    use crate::asset::{EyeSphere, SparseTarget};
    use rayon::prelude::*;
    let moved: Vec<Vec3> = (0..control.len()).map(|j| x.moved(j, control[j])).collect();
    let map = LocalMap {
        affines: x,
        control,
    };
    let local: HashMap<u32, u32> = tpl
        .coarse_ids
        .iter()
        .enumerate()
        .map(|(i, &v)| (v, i as u32))
        .collect();
    let mut positions = asset.positions.clone();
    for (j, &v) in tpl.coarse_ids.iter().enumerate() {
        positions[v as usize] = moved[j];
    }
    // Each part vertex's local map, once: its position and, for the face units, its offsets.
    let part_maps: HashMap<u32, Mat3> = (0..asset.positions.len() as u32)
        .into_par_iter()
        .filter(|v| !local.contains_key(v))
        .map(|v| (v, map.linear(sim.apply(asset.positions[v as usize]))))
        .collect();
    for (v, p) in positions.iter_mut().enumerate() {
        if !local.contains_key(&(v as u32)) {
            *p = map.point(sim.apply(asset.positions[v]));
        }
    }
    let eye = |side: &str| {
        let e = asset.meta.eyes[side];
        let c = sim.apply(Vec3::from(e.centre));
        let mut sphere = EyeSphere {
            centre: map.point(c).to_array(),
            radius: e.radius * sim.scale * map.linear(c).determinant().abs().cbrt(),
        };
        super::finish::seat_globe(&mut sphere, fine, &tpl.outer2, sim.rotation * Vec3::Z);
        sphere
    };
    let eyes = [eye("left"), eye("right")];
    let triangles: Vec<[u32; 3]> = tpl
        .coarse
        .quads
        .iter()
        .flat_map(|q| [[q[0].0, q[1].0, q[2].0], [q[0].0, q[2].0, q[3].0]])
        .collect();
    let sr = sim.rotation * sim.scale;
    let targets: Vec<SparseTarget> = asset
        .targets
        .par_iter()
        .map(|t| -> Result<SparseTarget, NumericsError> {
            let skin: HashMap<u32, Vec3> = t
                .offsets
                .iter()
                .filter_map(|&(v, d)| local.get(&v).map(|&l| (l, sr * d)))
                .collect();
            let mut offsets: Vec<(u32, Vec3)> =
                deformation_transfer(&triangles, control, &moved, &skin)?
                    .into_iter()
                    .filter(|(_, d)| d.length_squared() > 1e-10)
                    .map(|(l, d)| (tpl.coarse_ids[l as usize], d))
                    .collect();
            for &(v, d) in &t.offsets {
                if let Some(l) = part_maps.get(&v) {
                    offsets.push((v, *l * (sr * d)));
                }
            }
            offsets.sort_by_key(|o| o.0);
            Ok(SparseTarget {
                name: t.name.clone(),
                offsets,
            })
        })
        .collect::<Result<_, _>>()?;
    let mut targets = targets;
    calibrate_blinks(tpl, fine, &mut targets);
    Ok(Carried {
        positions,
        eyes,
        targets,
    })
}

/// Scales each transferred eyeBlink unit so that at full weight its upper lid margin meets the
/// lower one, as the template's does (its lower-lid landmark is where its closing upper lid
/// lands): deformation transfer carries the template's lid travel, which over- or under-closes
/// an eye opened more or less than the template's. The scale s minimises the margins' gap
/// |Δp + s Δd| (Δp the rest gap, Δd the difference of the margins' offsets), kept within
/// ×0.5–2.
fn calibrate_blinks(
    tpl: &super::template::Template,
    fine: &[Vec3],
    targets: &mut [crate::asset::SparseTarget],
) {
    for (side, unit) in [("left", "eyeBlinkLeft"), ("right", "eyeBlinkRight")] {
        let Some(t) = targets.iter_mut().find(|t| t.name == unit) else {
            continue;
        };
        let offset: HashMap<u32, Vec3> = t.offsets.iter().copied().collect();
        let moved = |landmark: &str| -> Vec3 {
            tpl.stencils2.rows[tpl.landmarks[landmark]]
                .iter()
                .map(|&(l, w)| {
                    w * offset
                        .get(&tpl.coarse_ids[l as usize])
                        .copied()
                        .unwrap_or(Vec3::ZERO)
                })
                .sum()
        };
        let (up, low) = (format!("lid_upper_{side}"), format!("lid_lower_{side}"));
        let dp = fine[tpl.landmarks[&up]] - fine[tpl.landmarks[&low]];
        let dd = moved(&up) - moved(&low);
        if dd.length_squared() < 1e-8 {
            continue;
        }
        let s = (-dp.dot(dd) / dd.length_squared()).clamp(0.5, 2.0);
        for o in &mut t.offsets {
            o.1 *= s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5 × 5 grid of two triangles per square.
    fn grid(scale: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for y in 0..5u32 {
            for x in 0..5u32 {
                p.push(Vec3::new(x as f32, y as f32, 0.0) * scale);
                if x > 0 && y > 0 {
                    let (a, b, c, d) = (
                        (y - 1) * 5 + x - 1,
                        (y - 1) * 5 + x,
                        y * 5 + x,
                        y * 5 + x - 1,
                    );
                    t.push([a, b, c]);
                    t.push([a, c, d]);
                }
            }
        }
        (p, t)
    }

    #[test]
    fn transfer_onto_the_same_mesh_returns_the_source_offsets() {
        let (p, t) = grid(Vec3::splat(10.0));
        let offsets: HashMap<u32, Vec3> = [
            (12u32, Vec3::new(0.0, 0.0, 3.0)),
            (13, Vec3::new(0.5, 0.0, 1.0)),
        ]
        .into_iter()
        .collect();
        let d = deformation_transfer(&t, &p, &p, &offsets).unwrap();
        for (v, o) in d {
            assert!(
                (o - offsets[&v]).length() < 1e-3,
                "{v}: {o} vs {}",
                offsets[&v]
            );
        }
    }

    #[test]
    fn transfer_onto_a_scaled_mesh_scales_the_offsets() {
        // Every edge of the target is twice the source's, so each gradient applied to it gives
        // twice the change: the offsets double, in and out of the plane.
        let (s, t) = grid(Vec3::splat(10.0));
        let (g, _) = grid(Vec3::splat(20.0));
        let offsets: HashMap<u32, Vec3> = [
            (12u32, Vec3::new(1.0, 0.0, 0.5)),
            (7, Vec3::new(0.0, -0.5, 0.2)),
        ]
        .into_iter()
        .collect();
        let d = deformation_transfer(&t, &s, &g, &offsets).unwrap();
        for (v, o) in d {
            assert!((o - 2.0 * offsets[&v]).length() < 1e-3, "{v}: {o}");
        }
    }
}
