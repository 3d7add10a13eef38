//! The lid region's depth and normals learnt from the head's own rig, as linear functions of the
//! model's coefficients e. The EyeMove thesis lifts its 2D model to 3D through a skull map
//! (§3.8), because a capture gives no depth; a map holds one surface per pixel, so the upper
//! lid's fold (skin hidden under the crease at rest) has to unfold onto it as it moves, and did
//! so raggedly, and a closing lid turned triangles over. derma's rig gives depth, so the depth
//! and normals are fitted to it like the thesis fits Ũ to positions (least squares over sampled
//! poses, eq. 3.6's form): a fold stays a fold, and a frame is still a few multiply-adds per
//! vertex.

use crate::gaze::Fick;
use crate::model::{EyeModel, Optimised, MAX_COEF};
use crate::rigdata::{Pose, Rig};
use crate::tracked::Tracked;
use derma_core::numerics::dense::{cholesky_solve, Matrix};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Poses sampled for the fit (the rig's sampled gazes, blinks, squints and widenings).
pub const SAMPLES: usize = 240;
/// A seed of its own, so the fit does not reuse the model's training poses.
const SEED: u64 = 0xDE97;
/// Ridge on the normal equations (relative to their trace), for coefficients the poses barely
/// excite.
const RIDGE: f64 = 1e-9;

/// Per vertex: depth and normal, each its value at e = 0 then `k` coefficient columns.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthModel {
    /// Coefficients used.
    pub k: usize,
    /// Per vertex, `4 (k + 1)` numbers: z₀, z₁…z_k, then n_x, n_y, n_z likewise.
    pub basis: Vec<f32>,
}

impl DepthModel {
    /// Fits the depth and normals of every region vertex of `rig` against the coefficients the
    /// `optimised` form of `model` gives its sampled poses.
    pub fn fit(model: &EyeModel, optimised: &Optimised, rig: &Rig) -> crate::Result<DepthModel> {
        let k = optimised.k;
        let poses = sweep(rig);
        let solve = normal_equations(&coefficient_rows(model, optimised, rig, &poses), k + 1)?;
        let posed: Vec<Posed> = poses
            .par_iter()
            .map(|p| {
                let x = rig.positions(&rig.weights(p));
                let n = rig.normals(&x);
                (x, n)
            })
            .collect();
        let basis: Vec<f32> = (0..rig.region.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let column = |f: &dyn Fn(&Posed) -> f32| -> Vec<f64> {
                    posed.iter().map(|p| f(p) as f64).collect()
                };
                [
                    column(&|p| p.0[i].z),
                    column(&|p| p.1[i].x),
                    column(&|p| p.1[i].y),
                    column(&|p| p.1[i].z),
                ]
                .into_iter()
                .flat_map(|c| solve(&c).into_iter().map(|v| v as f32))
                .collect::<Vec<f32>>()
            })
            .collect();
        Ok(DepthModel { k, basis })
    }

    /// Positions (the model's `u` with the fitted depth) and unit normals of every vertex.
    pub fn evaluate(
        &self,
        e: &[f32; MAX_COEF],
        u: &[Vec2],
        positions: &mut [Vec3],
        normals: &mut [Vec3],
    ) {
        let k1 = self.k + 1;
        let at = |b: &[f32]| b[0] + (0..self.k).map(|c| e[c] * b[1 + c]).sum::<f32>();
        for (i, b) in self.basis.chunks_exact(4 * k1).enumerate() {
            positions[i] = Vec3::new(u[i].x, u[i].y, at(&b[..k1]));
            let n = Vec3::new(at(&b[k1..2 * k1]), at(&b[2 * k1..3 * k1]), at(&b[3 * k1..]));
            normals[i] = n.normalize_or(Vec3::Z);
        }
    }
}

/// A posed region: positions and normals of its vertices.
type Posed = (Vec<Vec3>, Vec<Vec3>);

/// One row per pose: [1, e₁…e_k], the coefficients the model gives the pose's tracked frame.
fn coefficient_rows(
    model: &EyeModel,
    optimised: &Optimised,
    rig: &Rig,
    poses: &[Pose],
) -> Vec<Vec<f64>> {
    let tracked = Tracked {
        format: crate::tracked::FORMAT.into(),
        fps: 0.0,
        units: crate::rigdata::UNITS
            .iter()
            .map(|s| s.to_string())
            .collect(),
        lid_points: model.lid_points,
        frames: poses.iter().map(|p| rig.frame(p)).collect(),
    };
    tracked
        .frames
        .iter()
        .map(|f| {
            let e = optimised.coefficients(&model.gaze_of(&tracked, f));
            std::iter::once(1.0)
                .chain(e[..optimised.k].iter().map(|&x| x as f64))
                .collect()
        })
        .collect()
}

/// The poses the fit sees: the rig's sampled ones, and full blinks swept at a few gazes (the
/// closed lids are where depth changes most).
fn sweep(rig: &Rig) -> Vec<Pose> {
    let mut poses = rig.sample_poses(SAMPLES, SEED);
    for (h, v) in [(0.0, 0.0), (0.0, -25.0), (20.0, 0.0), (-20.0, 10.0)] {
        for s in 0..=8 {
            let b = s as f32 / 8.0;
            poses.push(Pose {
                gaze: [Fick { h, v, t: 0.0 }; 2],
                blink: [b; 2],
                ..Pose::default()
            });
        }
    }
    poses
}

/// The least-squares solver of `rows · c = y` for any `y`: (RᵀR + λI)⁻¹ Rᵀ, formed once.
fn normal_equations(rows: &[Vec<f64>], n: usize) -> crate::Result<impl Fn(&[f64]) -> Vec<f64>> {
    let mut g = Matrix::zeros(n, n);
    for r in rows {
        for a in 0..n {
            for b in 0..n {
                g[(a, b)] += r[a] * r[b];
            }
        }
    }
    let trace: f64 = (0..n).map(|a| g[(a, a)]).sum();
    for a in 0..n {
        g[(a, a)] += RIDGE * trace;
    }
    // G⁻¹ Rᵀ, one column per pose.
    let inv: Vec<Vec<f64>> = (0..n)
        .map(|j| {
            let unit: Vec<f64> = (0..n).map(|i| (i == j) as u8 as f64).collect();
            cholesky_solve(&g, &unit)
        })
        .collect::<Result<_, _>>()
        .map_err(|e| {
            derma_core::Invalid::new("the depth fit's normal equations", "a solvable system", e)
        })?;
    let pinv: Vec<Vec<f64>> = (0..n)
        .map(|a| {
            rows.iter()
                .map(|r| (0..n).map(|b| inv[b][a] * r[b]).sum())
                .collect()
        })
        .collect();
    Ok(move |y: &[f64]| -> Vec<f64> {
        pinv.iter()
            .map(|p| p.iter().zip(y).map(|(a, b)| a * b).sum())
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_least_squares_solver_recovers_a_linear_law() {
        // y = 2 + 3 a − b over scattered (a, b): exactly recovered.
        let rows: Vec<Vec<f64>> = (0..12)
            .map(|i| {
                let t = i as f64;
                vec![1.0, (t * 0.7).sin(), (t * 1.3).cos()]
            })
            .collect();
        let y: Vec<f64> = rows.iter().map(|r| 2.0 + 3.0 * r[1] - r[2]).collect();
        let solve = normal_equations(&rows, 3).unwrap();
        let c = solve(&y);
        for (got, want) in c.iter().zip([2.0, 3.0, -1.0]) {
            assert!((got - want).abs() < 1e-6, "{c:?}");
        }
    }
}
