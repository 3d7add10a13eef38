//! The one CPU shading: lighting.wgsl's `light_surface` (three directional lights over GGX with
//! height-correlated Smith visibility, a hemisphere environment through Karis 2014's split-sum
//! fit), the key light's shadow given per pixel, for every CPU image — the CPU renderer's frame
//! ([`crate::frame`]): the `CpuRenderer`, the previews and the lake.

use crate::brdf::{env_brdf, f90, ggx_d, schlick, smith_vis};
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
    /// Fraction of the key light (light 0, the one that casts shadows) that reaches it: 0 in
    /// its shadow.
    pub key_seen: f32,
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
    /// `light_surface`) that sees `key_seen` of the key light.
    pub fn light(&self, lobe: Lobe, key_seen: f32) -> (Vec3, Vec3) {
        let Lobe {
            n,
            ng,
            v,
            rough,
            f0,
        } = lobe;
        let a = (rough * rough).max(0.002);
        let nv = n.dot(v).max(1e-4);
        let (mut diffuse, mut specular) = (Vec3::ZERO, Vec3::ZERO);
        for (k, &(l, e)) in self.lights.iter().enumerate() {
            let e = if k == 0 { e * key_seen } else { e };
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
            * (f0 * scale + f90(f0) * bias);
        (diffuse, specular)
    }

    /// The radiance leaving `s` towards the viewer.
    pub fn shade(&self, s: &Surface) -> Vec3 {
        let lobe = s.lobe();
        if s.matte_under_film {
            let matte = Lobe {
                rough: 1.0,
                f0: 0.0,
                ..lobe
            };
            let (d, _) = self.light(matte, s.key_seen);
            let (_, sp) = self.light(lobe, s.key_seen);
            return d * s.albedo + sp;
        }
        let (d, sp) = self.light(lobe, s.key_seen);
        d * s.albedo + sp
    }
}

/// A specular lobe at a point: shading and geometric normals, the direction to the viewer, the
/// perceptual roughness and F0.
#[derive(Clone, Copy, Debug)]
pub struct Lobe {
    /// Unit shading normal.
    pub n: Vec3,
    /// Unit geometric normal.
    pub ng: Vec3,
    /// Unit direction towards the viewer.
    pub v: Vec3,
    /// Perceptual roughness.
    pub rough: f32,
    /// Normal-incidence reflectance.
    pub f0: f32,
}

impl Surface {
    /// Its specular lobe.
    pub fn lobe(&self) -> Lobe {
        Lobe {
            n: self.n,
            ng: self.ng,
            v: self.v,
            rough: self.roughness,
            f0: self.f0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lighting::Setup;

    /// One unit key light at 60° from +Z (in the xz plane), the others dark, sky and ground of
    /// radiance `sky`.
    fn key_at_60(sky: f32) -> Lighting {
        let mut lighting = Setup::Studio.lighting();
        lighting.lights[0].dir = Vec3::new(0.866, 0.0, 0.5);
        lighting.lights[0].irradiance = Vec3::ONE;
        for l in &mut lighting.lights[1..] {
            l.irradiance = Vec3::ZERO;
        }
        (lighting.sky, lighting.ground) = (Vec3::splat(sky), Vec3::splat(sky));
        lighting
    }

    #[test]
    fn a_white_matte_surface_under_one_light_is_lambertian() {
        // One unit light at 60° from the normal, no environment: a white surface reflects
        // E cos θ (1 − F(θ)) / π whatever the view (the diffuse keeps what Schlick's Fresnel does
        // not reflect) — with F0 = 0 nothing is reflected (f90 = 0): E cos θ / π and no lobe;
        // with F0 = 0.04, F(60°) = 0.04 + 0.96 · 0.5⁵ and the lobe adds the specular term.
        let mut lighting = key_at_60(0.0);
        let env = Env::new(&lighting, |d| d);
        for (v, f0) in [Vec3::Z, Vec3::new(-0.6, 0.0, 0.8)]
            .into_iter()
            .flat_map(|v| [(v, 0.0), (v, 0.04)])
        {
            let s = Surface {
                n: Vec3::Z,
                ng: Vec3::Z,
                v,
                albedo: Vec3::ONE,
                roughness: 0.5,
                f0,
                matte_under_film: false,
                key_seen: 1.0,
            };
            let (d, sp) = env.light(s.lobe(), s.key_seen);
            let fresnel = if f0 == 0.0 {
                0.0
            } else {
                f0 + (1.0 - f0) * 0.5f32.powi(5)
            };
            let lambert = 0.5 * (1.0 - fresnel) / PI;
            assert!((d.x - lambert).abs() < 1e-6, "{d} vs {lambert}");
            assert_eq!(sp == Vec3::ZERO, f0 == 0.0, "{sp}");
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
            key_seen: 1.0,
        };
        assert_eq!(env.shade(&s), Vec3::ZERO);
    }

    #[test]
    fn the_key_shadow_takes_away_the_keys_light_only() {
        // Key at 60° (irradiance 1), sky and ground 0.2: in the key's shadow only the
        // environment remains, and a half shadow takes half the key.
        let env = Env::new(&key_at_60(0.2), |d| d);
        let lobe = Lobe {
            n: Vec3::Z,
            ng: Vec3::Z,
            v: Vec3::Z,
            rough: 0.5,
            f0: 0.04,
        };
        let (open, shadow) = (env.light(lobe, 1.0), env.light(lobe, 0.0));
        let key_only = 0.5 * (1.0 - schlick(0.04, 0.5)) / PI;
        assert!((open.0.x - shadow.0.x - key_only).abs() < 1e-6);
        assert!((shadow.0.x - 0.2 * 0.96).abs() < 1e-6, "{}", shadow.0);
        let half = env.light(lobe, 0.5);
        assert!((half.0.x - 0.5 * (open.0.x + shadow.0.x)).abs() < 1e-6);
        assert!((half.1.x - 0.5 * (open.1.x + shadow.1.x)).abs() < 1e-6);
    }
}
