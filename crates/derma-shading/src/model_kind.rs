//! The registry of render BRDF models derma fits (thesis §4.6): one [`ModelKind`] per model
//! module, with its command-line name. Kept apart from the [`RenderModel`] trait so that the
//! models depend on the trait and the registry on the models, never in a circle.

use crate::ashikhmin_shirley::AshikhminShirley;
use crate::ggx::GltfGgx;
use crate::kelemen::KelemenSzirmayKalos;
use crate::render_model::RenderModel;
use crate::skin_dual_lobe::SkinDualLobe;

/// The models derma can fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModelKind {
    /// glTF's GGX with `KHR_materials_specular` ([`GltfGgx`]).
    Ggx,
    /// Ashikhmin–Shirley 2000 ([`AshikhminShirley`]).
    AshikhminShirley,
    /// Kelemen & Szirmay-Kalos 2001 ([`KelemenSzirmayKalos`]).
    Kelemen,
    /// derma's skin model: two GGX lobes, sheen, Fresnel-transmitted diffuse ([`SkinDualLobe`]).
    SkinDualLobe,
}

impl ModelKind {
    /// Every model, in the order tables store them.
    pub const ALL: [ModelKind; 4] = [
        ModelKind::Ggx,
        ModelKind::AshikhminShirley,
        ModelKind::Kelemen,
        ModelKind::SkinDualLobe,
    ];

    /// The model's implementation.
    pub fn model(self) -> &'static dyn RenderModel {
        match self {
            ModelKind::Ggx => &GltfGgx,
            ModelKind::AshikhminShirley => &AshikhminShirley,
            ModelKind::Kelemen => &KelemenSzirmayKalos,
            ModelKind::SkinDualLobe => &SkinDualLobe,
        }
    }

    /// Its command-line name ("ggx", "skin-dual-lobe").
    pub fn name(self) -> &'static str {
        self.model().name()
    }

    /// The model of a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_are_unique() {
        for k in ModelKind::ALL {
            assert_eq!(ModelKind::parse(k.name()), Some(k));
        }
        let mut names: Vec<&str> = ModelKind::ALL.iter().map(|k| k.name()).collect();
        names.dedup();
        assert_eq!(names.len(), ModelKind::ALL.len());
        assert_eq!(ModelKind::parse("phong"), None);
    }
}
