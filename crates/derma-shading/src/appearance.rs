//! The bio → render interface (thesis §4.8.6, the model-match function mmd): what a texel's
//! biology looks like to a renderer. Implementations: analytic spectral model (this crate).

pub use derma_optics::BioTexel;

/// Converts bio parameters to render parameters.
pub trait Appearance: Send + Sync {
    /// Short name for reports ("spectral-km").
    fn name(&self) -> &'static str;
    /// Diffuse albedo in linear sRGB (the renderer's base colour before encoding): body
    /// reflectance under D65 including internal reflection at the skin surface, excluding the
    /// external specular reflection, which the renderer adds from the specular map.
    fn albedo(&self, bio: &BioTexel) -> [f32; 3];
}
