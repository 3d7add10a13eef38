//! The one CPU shading: lighting.wgsl's `light_surface` (three directional lights over GGX with
//! height-correlated Smith visibility, a hemisphere environment through Karis 2014's split-sum
//! fit) without the key light's shadow, for every CPU image of the crate — the CPU renderer, its
//! previews and the lacrimal lake's compositing.

use crate::brdf::{env_brdf, ggx_d, schlick, smith_vis};
use crate::lighting::Lighting;
use glam::Vec3;
use std::f32::consts::PI;

/// What is shaded at a pixel: the shading and geometric normals and the material there.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// Unit shading normal (normal-mapped), world space.
    pub n: Vec3,
    /// Unit geometric normal (facing the viewer where the part is two-sided), world space.
    pub ng: Vec3,
    /// Unit direction towards the viewer.
    pub v: Vec3,
    /// Diffuse albedo, linear RGB.
    pub albedo: Vec3,
    /// Perceptual roughness of the specular lobe.
    pub roughness: f32,
    /// Normal-incidence reflectance of the specular lobe.
    pub f0: f32,
    /// The diffuse light is that of a matte surface (an eye: the iris and sclera under a clear
    /// tear film scatter like a rough dielectric; the film alone reflects).
    pub matte_under_film: bool,
}

/// The lights and environment of a frame in world space.
#[derive(Clone, Copy, Debug)]
pub struct Env {
    /// Direction towards each light (world space, unit) and its irradiance.
    pub lights: [(Vec3, Vec3); 3],
    /// Sky radiance, above the horizon.
    pub sky: Vec3,
    /// Ground radiance, below it.
    pub ground: Vec3,
}

impl Env {
    /// `lighting`'s lights (camera space) turned into world space by `to_world`.
    pub fn new(lighting: &Lighting, to_world: impl Fn(Vec3) -> Vec3) -> Env {
        Env {
            lights: lighting.lights.map(|l| (to_world(l.dir), l.irradiance)),
            sky: lighting.sky,
            ground: lighting.ground,
        }
    }

    /// Hemisphere environment: sky above, ground below, blended over ±0.3 of the up component.
    pub fn environment(&self, d: Vec3) -> Vec3 {
        let t = ((d.y + 0.3) / 0.6).clamp(0.0, 1.0);
        self.ground.lerp(self.sky, t * t * (3.0 - 2.0 * t))
    }

    /// Diffuse irradiance (× albedo) and specular radiance of a surface (lighting.wgsl's
    /// `light_surface` without the key light's shadow).
    pub fn light(&self, n: Vec3, ng: Vec3, v: Vec3, rough: f32, f0: f32) -> (Vec3, Vec3) {
        let a = (rough * rough).max(0.002);
        let nv = n.dot(v).max(1e-4);
        let (mut diffuse, mut specular) = (Vec3::ZERO, Vec3::ZERO);
        for &(l, e) in &self.lights {
            let nl = n.dot(l).max(0.0) * if ng.dot(l) >= 0.0 { 1.0 } else { 0.0 };
            if nl <= 0.0 {
                continue;
            }
            let h = (l + v).normalize();
            let spec =
                ggx_d(n.dot(h).max(0.0), a) * smith_vis(nl, nv, a) * schlick(f0, v.dot(h).max(0.0));
            diffuse += e * nl * (1.0 - schlick(f0, nl)) / PI;
            specular += e * nl * spec;
        }
        diffuse += self.environment(n) * (1.0 - f0);
        let r = 2.0 * n.dot(v) * n - v;
        let (scale, bias) = env_brdf(rough, nv);
        specular += self
            .environment(r)
            .lerp(0.5 * (self.sky + self.ground), rough)
            * (f0 * scale + bias);
        (diffuse, specular)
    }

    /// The radiance leaving `s` towards the viewer.
    pub fn shade(&self, s: &Surface) -> Vec3 {
        if s.matte_under_film {
            let (d, _) = self.light(s.n, s.ng, s.v, 1.0, 0.0);
            let (_, sp) = self.light(s.n, s.ng, s.v, s.roughness, s.f0);
            return d * s.albedo + sp;
        }
        let (d, sp) = self.light(s.n, s.ng, s.v, s.roughness, s.f0);
        d * s.albedo + sp
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lighting::Setup;

    #[test]
    fn a_white_matte_surface_under_one_light_is_lambertian() {
        // One unit light at 60° from the normal, no environment: a white surface with F0 = 0
        // reflects E cos θ (1 − F(θ)) / π, F(60°) = 0.5⁵ (the diffuse keeps what Schlick's
        // Fresnel does not reflect), whatever the view; the lobe adds the specular term.
        let mut lighting = Setup::Studio.lighting();
        lighting.lights[0].dir = Vec3::new(0.866, 0.0, 0.5);
        lighting.lights[0].irradiance = Vec3::ONE;
        for l in &mut lighting.lights[1..] {
            l.irradiance = Vec3::ZERO;
        }
        (lighting.sky, lighting.ground) = (Vec3::ZERO, Vec3::ZERO);
        let env = Env::new(&lighting, |d| d);
        for v in [Vec3::Z, Vec3::new(-0.6, 0.0, 0.8)] {
            let s = Surface {
                n: Vec3::Z,
                ng: Vec3::Z,
                v,
                albedo: Vec3::ONE,
                roughness: 0.5,
                f0: 0.0,
                matte_under_film: false,
            };
            let (d, sp) = env.light(s.n, s.ng, s.v, s.roughness, s.f0);
            let lambert = 0.5 * (1.0 - 0.5f32.powi(5)) / PI;
            assert!((d.x - lambert).abs() < 1e-6, "{d} vs {lambert}");
            assert_eq!(env.shade(&s), d + sp);
        }
        // Lit from behind its geometric normal: dark.
        lighting.lights[0].dir = Vec3::new(0.0, 0.0, -1.0);
        let env = Env::new(&lighting, |d| d);
        let s = Surface {
            n: Vec3::Z,
            ng: Vec3::Z,
            v: Vec3::Z,
            albedo: Vec3::ONE,
            roughness: 0.5,
            f0: 0.04,
            matte_under_film: false,
        };
        assert_eq!(env.shade(&s), Vec3::ZERO);
    }
}
