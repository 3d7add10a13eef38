//! Spherical harmonics up to order 2 for irradiance (Ramamoorthi & Hanrahan 2001, "An efficient
//! representation for irradiance environment maps", eqs. 3 and 8) and per-vertex transfer with
//! visibility (Sloan, Kautz & Snyder 2002, "Precomputed radiance transfer", §4: diffuse
//! shadowed transfer): a surface point's irradiance under any light of nine SH coefficients L is
//! T·L, T = ∫ V(ω) max(⟨n, ω⟩, 0) Y(ω) dω, estimated with stratified cosine-weighted rays.

use crate::bvh::Bvh;
use crate::rng::Philox;
use glam::Vec3;
use rayon::prelude::*;

/// Coefficients of order ≤ 2.
pub const SH9: usize = 9;

/// The convolution of each band with the clamped cosine, Â_l (Ramamoorthi & Hanrahan 2001,
/// eq. 8): π, 2π/3, π/4 for l = 0, 1, 2.
pub const COSINE_LOBE: [f32; 3] = [
    std::f32::consts::PI,
    2.0 * std::f32::consts::PI / 3.0,
    std::f32::consts::PI / 4.0,
];

/// The band l of coefficient i (0; 1, 1, 1; 2 × 5).
pub const fn band(i: usize) -> usize {
    match i {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

/// The real SH basis Y_i(d) for a unit direction d (Ramamoorthi & Hanrahan 2001, eq. 3; order
/// y, z, x within band 1 and xy, yz, 3z²−1, xz, x²−y² within band 2).
pub fn basis(d: Vec3) -> [f32; SH9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// The transfer of an unoccluded point with unit normal n: Â_l Y_i(n) (the Funk–Hecke theorem).
pub fn open_transfer(n: Vec3) -> [f32; SH9] {
    let y = basis(n);
    std::array::from_fn(|i| COSINE_LOBE[band(i)] * y[i])
}

/// The direction of a cosine-weighted sample (u1, u2) ∈ [0, 1)² about unit n (Malley's method:
/// a uniform disc point lifted onto the hemisphere; pdf cos θ / π).
pub fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let (t, b) = n.any_orthonormal_pair();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

/// The `k`-th of `side`² stratified, jittered cosine-weighted directions about n for point `index`
/// of stream `rng` (deterministic: the same directions at any thread count).
pub fn stratified_direction(n: Vec3, rng: &Philox, index: u64, k: usize, side: usize) -> Vec3 {
    let u = rng.uniform4(index, k as u32);
    let (i, j) = (k % side, k / side);
    cosine_direction(
        n,
        (i as f32 + u[0]) / side as f32,
        (j as f32 + u[1]) / side as f32,
    )
}

/// Diffuse shadowed transfer per point (Sloan et al. 2002 eq. 6 without interreflection):
/// T_i = ∫ V(ω) max(⟨n, ω⟩, 0) Y_i(ω) dω = π E[V Y_i] over cosine-weighted directions, `side`²
/// stratified rays per point, each cast from p + offset·n; V = 0 where the mesh in `bvh` is hit.
pub fn shadowed_transfer(
    points: &[Vec3],
    normals: &[Vec3],
    bvh: &Bvh,
    side: usize,
    offset: f32,
    seed: u64,
) -> Vec<[f32; SH9]> {
    let rng = Philox::new(seed, 0x5_4a);
    let rays = side * side;
    points
        .par_iter()
        .zip(normals)
        .enumerate()
        .map(|(v, (&p, &n))| {
            let n = n.normalize_or(Vec3::Z);
            let mut t = [0.0f32; SH9];
            let origin = p + n * offset;
            for k in 0..rays {
                let d = stratified_direction(n, &rng, v as u64, k, side);
                if bvh.occluded(origin, d, 0.0, f32::MAX) {
                    continue;
                }
                let y = basis(d);
                for i in 0..SH9 {
                    t[i] += y[i];
                }
            }
            t.map(|x| x * std::f32::consts::PI / rays as f32)
        })
        .collect()
}

/// The dot product T·L.
pub fn dot(t: &[f32; SH9], l: &[f32; SH9]) -> f32 {
    t.iter().zip(l).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere_points(n: usize) -> Vec<Vec3> {
        // A Fibonacci sphere.
        let g = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * (g * i as f32).cos(), r * (g * i as f32).sin(), z)
            })
            .collect()
    }

    #[test]
    fn the_basis_is_orthonormal_on_the_sphere() {
        let pts = sphere_points(20_000);
        let w = 4.0 * std::f64::consts::PI / pts.len() as f64;
        for i in 0..SH9 {
            for j in 0..SH9 {
                let s: f64 = pts
                    .iter()
                    .map(|p| {
                        let y = basis(*p);
                        y[i] as f64 * y[j] as f64 * w
                    })
                    .sum();
                let want = (i == j) as u8 as f64;
                assert!((s - want).abs() < 2e-3, "⟨Y{i}, Y{j}⟩ = {s}");
            }
        }
    }

    #[test]
    fn an_open_point_transfers_the_cosine_lobe() {
        // No occluder: the ray estimate converges to Â_l Y(n) (Funk–Hecke); 32² stratified rays.
        let far = Bvh::new(
            &[
                Vec3::new(100.0, 100.0, -100.0),
                Vec3::new(101.0, 100.0, -100.0),
                Vec3::new(100.0, 101.0, -100.0),
            ],
            &[[0, 1, 2]],
        );
        let normals = [
            Vec3::Z,
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.36, 0.48, 0.8),
        ];
        let pts = [Vec3::ZERO; 3];
        let t = shadowed_transfer(&pts, &normals, &far, 32, 0.0, 1);
        for (n, t) in normals.iter().zip(&t) {
            let want = open_transfer(*n);
            for i in 0..SH9 {
                assert!(
                    (t[i] - want[i]).abs() < 0.01,
                    "{n}: T{i} {} vs {}",
                    t[i],
                    want[i]
                );
            }
        }
        // Irradiance of a constant unit radiance (L_0 = √(4π)): π.
        let mut l = [0.0; SH9];
        l[0] = (4.0 * std::f32::consts::PI).sqrt();
        assert!((dot(&open_transfer(Vec3::Z), &l) - std::f32::consts::PI).abs() < 1e-4);
    }

    #[test]
    fn a_wall_halves_the_sky() {
        // A point facing a large wall 1 µm away in the plane x = −0.001 that covers z > 0: every
        // ray toward z > 0 hits it, so by symmetry half the cosine integral remains (π/2);
        // facing away from the wall, nothing is hidden (π).
        let h = 1000.0;
        let wall = Bvh::new(
            &[
                Vec3::new(-0.001, -h, 0.0),
                Vec3::new(-0.001, h, 0.0),
                Vec3::new(-0.001, 0.0, h),
            ],
            &[[0, 1, 2]],
        );
        let t = shadowed_transfer(&[Vec3::ZERO], &[Vec3::NEG_X], &wall, 32, 0.0, 3);
        let dc = t[0][0] / 0.282_095;
        assert!((dc - std::f32::consts::FRAC_PI_2).abs() < 0.08, "{dc}");
        let open = shadowed_transfer(&[Vec3::ZERO], &[Vec3::X], &wall, 32, 0.0, 3);
        assert!((open[0][0] / 0.282_095 - std::f32::consts::PI).abs() < 0.02);
    }
}
