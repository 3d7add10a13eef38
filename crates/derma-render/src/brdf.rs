//! The microfacet terms every renderer of this crate shares: the GGX / Trowbridge–Reitz
//! distribution (Walter et al. 2007), Schlick's Fresnel (Schlick 1994), the height-correlated
//! Smith visibility (Heitz 2014, eq. 99), Karis 2014's split-sum environment fit and Frostbite's
//! grazing reflectance ([`f90`]) — the CPU's
//! forms of brdf.wgsl's functions, which a GPU test holds equal.

use glam::{Vec3, Vec4};
use std::f32::consts::PI;

/// brdf.wgsl: the same terms as the shaders' source, prepended to the passes that light.
pub const WGSL: &str = include_str!("brdf.wgsl");

/// GGX / Trowbridge–Reitz distribution D(h) at n·h = `nh` for α = `a` (roughness²).
#[inline]
pub fn ggx_d(nh: f32, a: f32) -> f32 {
    let a2 = a * a;
    let d = nh * nh * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Height-correlated Smith visibility G₂ / (4 n·l n·v) (Heitz 2014, eq. 99).
#[inline]
pub fn smith_vis(nl: f32, nv: f32, a: f32) -> f32 {
    let a2 = a * a;
    let gv = nl * (nv * nv * (1.0 - a2) + a2).sqrt();
    let gl = nv * (nl * nl * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl).max(1e-5)
}

/// Reflectance at grazing incidence for normal-incidence reflectance `f0`: 1 for every real
/// dielectric (F0 ≥ 2 %: n ≥ 1.33), falling to 0 with F0 below it — a surface of F0 = 0
/// reflects nothing at all, and F0 under 2 %, which no material has, reads as occluded specular
/// (Lagarde & de Rousiers 2014, "Moving Frostbite to PBR", f90 = saturate(50 F0)).
#[inline]
pub fn f90(f0: f32) -> f32 {
    (50.0 * f0).clamp(0.0, 1.0)
}

/// Schlick's Fresnel at cos θ = `vh` towards [`f90`] (clamped, an integer power: finite even
/// where a rounded cosine passes 1).
#[inline]
pub fn schlick(f0: f32, vh: f32) -> f32 {
    f0 + (f90(f0) - f0) * (1.0 - vh).clamp(0.0, 1.0).powi(5)
}

/// The specular lobe D·V·F (per unit n·l irradiance) of unit normal `n` lit from unit `l` and
/// seen from unit `v`, α = `a`, normal-incidence reflectance `f0`.
#[inline]
pub fn specular(n: Vec3, l: Vec3, v: Vec3, a: f32, f0: f32) -> f32 {
    let h = (l + v).normalize();
    let (nl, nv) = (n.dot(l).max(0.0), n.dot(v).max(1e-4));
    ggx_d(n.dot(h).max(0.0), a) * smith_vis(nl, nv, a) * schlick(f0, v.dot(h).max(0.0))
}

/// Karis 2014 ("Physically based shading on mobile"): the split-sum environment BRDF's F0
/// scale and bias (the bias is [`f90`]'s share) at perceptual roughness `rough` and n·v = `nv`.
#[inline]
pub fn env_brdf(rough: f32, nv: f32) -> (f32, f32) {
    let c0 = Vec4::new(-1.0, -0.0275, -0.572, 0.022);
    let c1 = Vec4::new(1.0, 0.0425, 1.04, -0.04);
    let r = rough * c0 + c1;
    let a004 = (r.x * r.x).min((-9.28 * nv).exp2()) * r.x + r.y;
    (-1.04 * a004 + r.z, 1.04 * a004 + r.w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ggx_integrates_to_one_and_schlick_spans_f0_to_one() {
        // ∫ D (n·h) dω = 1 over the hemisphere (Walter et al. 2007, eq. 4).
        let (a, n) = (0.3, 4000);
        let s: f32 = (0..n)
            .map(|i| {
                let t = (i as f32 + 0.5) / n as f32 * 0.5 * PI;
                ggx_d(t.cos(), a) * t.cos() * t.sin() * 2.0 * PI * (0.5 * PI / n as f32)
            })
            .sum();
        assert!((s - 1.0).abs() < 1e-2, "{s}");
        assert_eq!(schlick(0.04, 1.0), 0.04);
        assert_eq!(schlick(0.04, 0.0), 1.0);
        // No reflectance at normal incidence, none at grazing: F0 = 0 reflects nothing.
        assert_eq!((schlick(0.0, 0.0), schlick(0.0, 0.5)), (0.0, 0.0));
        assert_eq!((f90(0.01), f90(0.02), f90(0.3)), (0.5, 1.0, 1.0));
        // Smith visibility of a smooth surface at normal incidence: 1 / (4 n·l n·v) = ¼.
        assert!((smith_vis(1.0, 1.0, 0.0) - 0.25).abs() < 1e-6);
        // Karis 2014: a mirror seen head-on reflects all of F0 (scale ≈ 1, bias ≈ 0).
        let (s, b) = env_brdf(0.0, 1.0);
        assert!((s - 1.0).abs() < 0.03 && b.abs() < 0.03, "{s} {b}");
    }

    #[test]
    fn the_lobe_keeps_energy_below_one() {
        // White furnace for one light direction: ∫ f_spec (n·l) dω_l ≤ 1 (no energy created),
        // for a rough and a smooth surface seen at 30°.
        let v = Vec3::new(0.5, 0.0, 0.866);
        for a in [0.05f32, 0.5] {
            let (nt, np) = (400, 200);
            let mut e = 0.0;
            for i in 0..nt {
                let t = (i as f32 + 0.5) / nt as f32 * 0.5 * PI;
                for j in 0..np {
                    let p = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                    let l = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                    let dw = t.sin() * (0.5 * PI / nt as f32) * (2.0 * PI / np as f32);
                    e += specular(Vec3::Z, l, v, a, 1.0) * l.z * dw;
                }
            }
            assert!(e > 0.6 && e <= 1.0 + 1e-2, "α {a}: albedo {e}");
        }
    }

    /// brdf.wgsl evaluated on the GPU (lavapipe in CI) at the inputs `x` (nh/nl, nv/vh, a/rough,
    /// f0 per row): per row ggx_d, smith_vis, schlick, env_brdf's two terms and f90.
    #[cfg(feature = "gpu")]
    fn on_gpu(x: &[[f32; 4]]) -> Option<Vec<[f32; 8]>> {
        let gpu = derma_core::gpu::context().ok()?;
        let src = format!(
            "{WGSL}\n@group(0) @binding(0) var<uniform> n: vec4<u32>;\n\
             @group(0) @binding(1) var<storage, read> x: array<vec4<f32>>;\n\
             @group(0) @binding(2) var<storage, read_write> y: array<array<f32, 8>>;\n\
             @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
               let i = id.x; if (i >= n.x) {{ return; }}\n\
               let p = x[i]; let e = env_brdf(p.z, p.y);\n\
               y[i] = array<f32, 8>(ggx_d(p.x, p.z), smith_vis(p.x, p.y, p.z), schlick(p.w, p.y),\n\
                                    e.x, e.y, f90(p.w), 0.0, 0.0);\n\
             }}\n"
        );
        let (layout, [pipe]) = gpu.entry_points("brdf check", &src, 1, 1, ["main"]).ok()?;
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let count = gpu.upload(
            "n",
            bytemuck::cast_slice(&[x.len() as u32, 0, 0, 0]),
            wgpu::BufferUsages::UNIFORM,
        );
        let input = gpu.upload("x", bytemuck::cast_slice(x), usage);
        let out = gpu.upload("y", &vec![0u8; 32 * x.len()], usage);
        let group = gpu.bind_buffers("brdf check", &layout, &[&count, &input, &out]);
        gpu.submit_passes(&group, &[(&pipe, derma_core::gpu::grid(x.len(), 64))]);
        let flat: Vec<f32> = gpu.read_back(&out, 8 * x.len()).ok()?;
        Some(flat.chunks(8).map(|c| c.try_into().unwrap()).collect())
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn brdf_wgsl_agrees_with_brdf_rs() {
        let mut x = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                for a in [0.002f32, 0.05, 0.3, 0.8] {
                    let (c1, c2) = ((i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 8.0);
                    x.push([c1, c2, a, 0.02 + 0.1 * c1]);
                }
            }
        }
        // The edges: cosines of 1 and 0 (Schlick's clamp; the NaN a negative base once made on
        // lavapipe), the mirror peak (α 0.05: smaller ones cancel to f32 rounding), Smith's floor at grazing light and view.
        for (nh, nv, a) in [
            (1.0, 1.0, 0.05),
            (1.0, 0.0, 0.05),
            (0.0, 1.0, 0.3),
            (0.0, 0.0, 0.002),
        ] {
            x.push([nh, nv, a, 0.04]);
        }
        // F0 below 2 %, where f90 falls.
        for f0 in [0.0, 0.005, 0.0199] {
            x.push([0.7, 0.3, 0.3, f0]);
        }
        if derma_test_support::skip_without_gpu() {
            return;
        }
        let gpu = on_gpu(&x).expect("brdf.wgsl compiles and runs");
        for (p, g) in x.iter().zip(&gpu) {
            let (s, b) = env_brdf(p[2], p[1]);
            let cpu = [
                ggx_d(p[0], p[2]),
                smith_vis(p[0], p[1], p[2]),
                schlick(p[3], p[1]),
                s,
                b,
                f90(p[3]),
            ];
            for k in 0..6 {
                let tol = 1e-4 * cpu[k].abs().max(1.0);
                assert!(
                    (cpu[k] - g[k]).abs() <= tol,
                    "term {k} at {p:?}: CPU {} GPU {}",
                    cpu[k],
                    g[k]
                );
            }
        }
    }
}
