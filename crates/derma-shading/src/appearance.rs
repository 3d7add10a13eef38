//! The bio → render interface (thesis §4.8.6, the model-match function mmd): what a texel's
//! biology looks like to a renderer. Implementations: the analytic spectral model
//! ([`crate::SpectralKubelkaMunk`]) and the Monte Carlo match table ([`crate::TableAppearance`]).

pub use derma_optics::BioTexel;

/// Subsurface scattering parameters engines take, per linear-sRGB channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Subsurface {
    /// Surface albedo of the diffusion profile (Burley's A; Unreal/Blender subsurface colour),
    /// linear.
    pub color: [f32; 3],
    /// Scatter distance in mm (Christensen & Burley 2015's mean free path ℓ).
    pub radius_mm: [f32; 3],
}

/// The skin surface's specular lobe, as glTF's metallic-roughness material (and Unreal's and
/// Unity's) takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSpecular {
    /// glTF perceptual roughness (α = r²).
    pub roughness: f32,
    /// Normal-incidence reflectance F0.
    pub f0: f32,
}

/// Converts bio parameters to render parameters.
pub trait Appearance: Send + Sync {
    /// Short name for reports ("spectral-km").
    fn name(&self) -> &'static str;
    /// Diffuse albedo in linear sRGB (the renderer's base colour before encoding): body
    /// reflectance under D65 including internal reflection at the skin surface, excluding the
    /// external specular reflection, which the renderer adds from the specular map.
    fn albedo(&self, bio: &BioTexel) -> [f32; 3];
    /// Subsurface parameters, where the implementation knows them.
    fn subsurface(&self, _bio: &BioTexel) -> Option<Subsurface> {
        None
    }
    /// The surface's specular lobe, where the implementation has a model of the surface (the
    /// match table's fit, [`crate::surface_fit`]); `None`: the caller's authored values.
    fn specular(&self) -> Option<SurfaceSpecular> {
        None
    }
    /// Albedo and subsurface together (one table lookup for implementations that can).
    fn shade(&self, bio: &BioTexel) -> ([f32; 3], Option<Subsurface>) {
        (self.albedo(bio), self.subsurface(bio))
    }
    /// [`Self::shade`] of many texels (`out[i]` for `bio[i]`); implementations may work across
    /// texels at once, with the same values.
    fn shade_batch(&self, bio: &[BioTexel], out: &mut [([f32; 3], Option<Subsurface>)]) {
        for (o, b) in out.iter_mut().zip(bio) {
            *o = self.shade(b);
        }
    }
}
