//! The `derma skin` configuration: every key with its unit, default and source, defined once.
//! [`KEY_DOCS`] documents each key; `--print-config` and validation are generated from it, and a
//! test checks that it and the serialized defaults name exactly the same keys.

// The keys (these structs' fields) are documented once, in KEY_DOCS, with unit, range and source;
// a doc comment per field would be a second copy to keep in step.
#![allow(missing_docs)]

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A closed range of a bio parameter: the baseline skin takes `min` plus band-limited noise of
/// amplitude φ·(max − min) (thesis §5.3.1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    pub min: f32,
    pub max: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// Every option of the main job, as `derma skin --config` reads it (keys documented in [`KEY_DOCS`]).
pub struct SkinConfig {
    pub seed: u64,
    pub size: u32,
    pub scatter_resolution: u32,
    pub surface: SurfaceConfig,
    /// Named fields: a PNG/EXR path or an expression over other fields (see `field.rs`).
    pub fields: BTreeMap<String, String>,
    pub baseline: BaselineConfig,
    pub lips: LipsConfig,
    pub cyst: CystConfig,
    pub mole: MoleConfig,
    pub freckle: FreckleConfig,
    pub wrinkle: WrinkleConfig,
    pub pore: PoreConfig,
    pub follicle: FollicleConfig,
    pub eyebrow: FollicleConfig,
    pub hair: HairConfig,
    pub material: MaterialConfig,
    pub detail: DetailConfig,
    pub relief: ReliefConfig,
    pub person: crate::regional::Person,
    pub regional: RegionalConfig,
    pub mottling: MottlingConfig,
}

/// `[mottling]`: centimetre-scale blotches of blood and pigment (see `mottling.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MottlingConfig {
    pub enabled: bool,
    pub wavelengths_mm: [f32; 3],
    pub blood: f32,
    pub melanin: f32,
}

impl Default for MottlingConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            wavelengths_mm: [20.0, 10.0, 5.0],
            blood: 1.2,
            melanin: 0.15,
        }
    }
}

/// `[relief]`: the micro-relief furrow network (see `features/relief.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReliefConfig {
    pub enabled: bool,
    pub field: String,
    pub vector_field: String,
    pub cell_mm: [f32; 3],
    pub depth_mm: [f32; 3],
    pub width_fraction: f32,
    pub dome_fraction: f32,
    pub anisotropy: f32,
}

impl Default for ReliefConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "relief".into(),
            vector_field: "tension_vectors".into(),
            cell_mm: [3.2, 1.1, 0.35],
            depth_mm: [0.06, 0.03, 0.012],
            width_fraction: 0.12,
            dome_fraction: 0.8,
            anisotropy: 0.6,
        }
    }
}

/// `[regional]`: the regional biology of the built-in head (see `regional.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RegionalConfig {
    pub enabled: bool,
}

impl Default for RegionalConfig {
    fn default() -> Self {
        Self { enabled: true }
    }
}

/// Exemplar micro-detail (see `detail.rs`): off while both paths are empty.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetailConfig {
    pub height: String,
    pub albedo: String,
    pub tile_size: u32,
    pub repeat: f32,
    pub patch: u32,
    pub highpass_texels: u32,
    pub height_mm: f32,
    pub albedo_contrast: f32,
    /// Region (field) name → height exemplar for that region.
    pub regions: BTreeMap<String, String>,
}

impl Default for DetailConfig {
    fn default() -> Self {
        Self {
            height: String::new(),
            albedo: String::new(),
            tile_size: 512,
            repeat: 8.0,
            patch: 32,
            highpass_texels: 6,
            height_mm: 0.01,
            albedo_contrast: 1.0,
            regions: BTreeMap::new(),
        }
    }
}

impl DetailConfig {
    /// Whether an exemplar is given (the detail is synthesised and added).
    pub fn enabled(&self) -> bool {
        !self.height.trim().is_empty() || !self.albedo.trim().is_empty() || !self.regions.is_empty()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
/// What the texture set is painted on.
pub enum SurfaceKind {
    /// The built-in head (derma-head).
    Template,
    /// A flat patch of `patch_size_mm`.
    Patch,
    /// A user mesh (`mesh` key or `--mesh`).
    Mesh,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[surface]`: what to paint on.
pub struct SurfaceConfig {
    pub kind: SurfaceKind,
    pub patch_size_mm: [f32; 2],
    pub tileable: bool,
    pub mesh: String,
    pub unit: String,
    pub part: String,
    pub landmarks: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[baseline]`: the skin between features (thesis §5.3.1).
pub struct BaselineConfig {
    pub phi: f32,
    pub noise_wavelengths_mm: [f32; 3],
    /// A melanin map in the mesh's UV layout (e.g. from `derma photo chromophores`) that
    /// replaces the baseline's melanin and its regional gain; empty = none.
    pub melanin_map: String,
    /// A dermal blood (hemoglobin) map, as `melanin_map`.
    pub blood_map: String,
    pub melanin: Range,
    pub pheomelanin: Range,
    pub blood: Range,
    pub oxygenation: Range,
    pub stratum_corneum_um: Range,
    pub epidermis_um: Range,
    pub height_mm: Range,
}

impl BaselineConfig {
    /// The baseline's mean tissue: each range at min + ½ φ (max − min), the mean of its noise.
    /// Measured maps are painted at it (their melanin and blood replacing its own), and
    /// `derma photo chromophores` inverts colours at it, so that a set painted from a photo's
    /// maps gives back the photo's colour.
    pub fn mean_tissue(&self) -> derma_shading::BioTexel {
        let mid = |r: Range| r.min + 0.5 * self.phi * (r.max - r.min);
        derma_shading::BioTexel {
            melanin: mid(self.melanin),
            pheomelanin: mid(self.pheomelanin),
            blood: mid(self.blood),
            oxygenation: mid(self.oxygenation),
            stratum_corneum_um: mid(self.stratum_corneum_um),
            epidermis_um: mid(self.epidermis_um),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[lips]` (thesis §5.3.6).
pub struct LipsConfig {
    pub enabled: bool,
    pub field: String,
    pub blood: f32,
    pub pheomelanin: f32,
    pub epidermis_um: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[cyst]` (thesis §5.3.2).
pub struct CystConfig {
    pub enabled: bool,
    pub field: String,
    pub density_per_cm2: f32,
    pub radius_sigma_mm: f32,
    pub radius_offset_mm: f32,
    pub height_max_mm: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[mole]` (thesis §5.3.3).
pub struct MoleConfig {
    pub enabled: bool,
    pub field: String,
    pub density_per_cm2: f32,
    pub radius_sigma_mm: f32,
    pub melanin: Range,
    pub height_mm: Range,
    pub perimeter_roughness: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[freckle]` (thesis §5.3.5).
pub struct FreckleConfig {
    pub enabled: bool,
    pub field: String,
    pub power: f32,
    pub density_per_cm2: f32,
    pub radius_mean_mm: f32,
    pub radius_sigma_mm: f32,
    pub melanin_max: f32,
    pub pheomelanin_scale: f32,
    pub perimeter_roughness: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[wrinkle]` (thesis §5.3.7).
pub struct WrinkleConfig {
    pub enabled: bool,
    pub field: String,
    pub vector_field: String,
    pub density_per_cm2: f32,
    pub max_length_mm: f32,
    pub width_mm: Range,
    pub depth_mm: Range,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[pore]` (ours; thesis §7.4 lists pores as missing).
pub struct PoreConfig {
    pub enabled: bool,
    pub field: String,
    pub density_per_cm2: f32,
    pub radius_mean_mm: f32,
    pub radius_sigma_mm: f32,
    pub depth_mm: f32,
    pub melanin_add: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[follicle]` and `[eyebrow]` (thesis §5.3.4).
pub struct FollicleConfig {
    pub enabled: bool,
    pub field: String,
    pub density_per_cm2: f32,
    pub inner_radius_mm: f32,
    pub outer_radius_mm: f32,
    pub height_mm: f32,
    pub blood_reduction: f32,
    pub gland_radius_mm: f32,
}

/// `[hair]`: strands grown from the eyebrow and beard follicles, and the hair's melanins
/// (see `features/strand.rs`, `derma_shading::hair`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HairConfig {
    pub strands: bool,
    pub melanin_from_skin: bool,
    pub eumelanin: f32,
    pub pheomelanin: f32,
    pub vector_field: String,
    pub brow_length_mm: Range,
    pub brow_radius_mm: f32,
    pub stubble_length_mm: f32,
    pub stubble_radius_mm: f32,
    pub beard_field: String,
}

impl Default for HairConfig {
    fn default() -> Self {
        Self {
            strands: true,
            melanin_from_skin: true,
            eumelanin: 0.9,
            pheomelanin: 0.15,
            vector_field: "hair_vectors".into(),
            brow_length_mm: Range {
                min: 6.0,
                max: 12.0,
            },
            brow_radius_mm: 0.05,
            stubble_length_mm: 1.0,
            stubble_radius_mm: 0.05,
            beard_field: "beard".into(),
        }
    }
}

impl HairConfig {
    /// The hair's melanins: from the person's skin tone
    /// ([`derma_shading::hair::HairMelanin::for_skin_tone`]) or as given.
    pub fn melanin(&self, person: &crate::regional::Person) -> derma_shading::hair::HairMelanin {
        if self.melanin_from_skin {
            derma_shading::hair::HairMelanin::for_skin_tone(person.ita_deg)
        } else {
            derma_shading::hair::HairMelanin {
                eumelanin: self.eumelanin,
                pheomelanin: self.pheomelanin,
            }
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
/// `[material]`: specular and roughness of skin, lips and hair.
pub struct MaterialConfig {
    pub fitted_surface: bool,
    pub roughness_skin: f32,
    pub roughness_lips: f32,
    pub roughness_hair: f32,
    pub specular_f0: f32,
}

impl Default for SkinConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            size: 2048,
            scatter_resolution: 1024,
            surface: SurfaceConfig::default(),
            fields: BTreeMap::new(),
            baseline: BaselineConfig::default(),
            lips: LipsConfig::default(),
            cyst: CystConfig::default(),
            mole: MoleConfig::default(),
            freckle: FreckleConfig::default(),
            wrinkle: WrinkleConfig::default(),
            pore: PoreConfig::default(),
            follicle: FollicleConfig::default(),
            eyebrow: FollicleConfig::eyebrow(),
            hair: HairConfig::default(),
            material: MaterialConfig::default(),
            detail: DetailConfig::default(),
            relief: ReliefConfig::default(),
            person: crate::regional::Person::default(),
            regional: RegionalConfig::default(),
            mottling: MottlingConfig::default(),
        }
    }
}

impl Default for SurfaceConfig {
    fn default() -> Self {
        Self {
            kind: SurfaceKind::Template,
            patch_size_mm: [40.0, 40.0],
            tileable: true,
            mesh: String::new(),
            unit: "auto".into(),
            part: String::new(),
            landmarks: String::new(),
        }
    }
}

impl Default for BaselineConfig {
    fn default() -> Self {
        Self {
            phi: 0.1,
            noise_wavelengths_mm: [24.0, 6.0, 1.5],
            melanin_map: String::new(),
            blood_map: String::new(),
            melanin: Range {
                min: 0.013,
                max: 0.063,
            },
            pheomelanin: Range {
                min: 0.3,
                max: 0.45,
            },
            blood: Range {
                min: 0.003,
                max: 0.02,
            },
            oxygenation: Range { min: 0.6, max: 0.9 },
            stratum_corneum_um: Range {
                min: 10.0,
                max: 20.0,
            },
            epidermis_um: Range {
                min: 50.0,
                max: 100.0,
            },
            height_mm: Range {
                min: 0.0,
                max: 0.05,
            },
        }
    }
}

impl Default for LipsConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "lips".into(),
            blood: 0.05,
            pheomelanin: 0.6,
            epidermis_um: 40.0,
        }
    }
}

impl Default for CystConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "cysts".into(),
            density_per_cm2: crate::builtin_head::DEFAULT_DENSITY.cyst,
            radius_sigma_mm: 0.2,
            radius_offset_mm: 0.01,
            height_max_mm: 0.5,
        }
    }
}

impl Default for MoleConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "moles".into(),
            density_per_cm2: crate::builtin_head::DEFAULT_DENSITY.mole,
            radius_sigma_mm: 0.4,
            melanin: Range { min: 0.1, max: 0.4 },
            height_mm: Range { min: 0.3, max: 1.0 },
            perimeter_roughness: 0.15,
        }
    }
}

impl Default for FreckleConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "freckles".into(),
            power: 1.0,
            density_per_cm2: crate::builtin_head::DEFAULT_DENSITY.freckle,
            radius_mean_mm: 0.8,
            radius_sigma_mm: 0.4,
            melanin_max: 0.12,
            pheomelanin_scale: 0.015,
            perimeter_roughness: 0.25,
        }
    }
}

impl Default for WrinkleConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "wrinkles".into(),
            vector_field: "wrinkle_vectors".into(),
            density_per_cm2: crate::builtin_head::DEFAULT_DENSITY.wrinkle,
            max_length_mm: 40.0,
            width_mm: Range { min: 0.4, max: 1.2 },
            depth_mm: Range {
                min: 0.03,
                max: 0.12,
            },
        }
    }
}

impl Default for PoreConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "pores".into(),
            density_per_cm2: 150.0,
            radius_mean_mm: 0.08,
            radius_sigma_mm: 0.02,
            depth_mm: 0.03,
            melanin_add: 0.01,
        }
    }
}

impl Default for FollicleConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            field: "scalp".into(),
            density_per_cm2: crate::builtin_head::DEFAULT_DENSITY.follicle,
            inner_radius_mm: 0.04,
            outer_radius_mm: 0.1,
            height_mm: 0.02,
            blood_reduction: 0.5,
            gland_radius_mm: 0.3,
        }
    }
}

impl FollicleConfig {
    fn eyebrow() -> Self {
        Self {
            field: "eyebrows".into(),
            density_per_cm2: crate::builtin_head::DEFAULT_DENSITY.eyebrow,
            outer_radius_mm: 0.12,
            ..Self::default()
        }
    }
}

impl Default for MaterialConfig {
    fn default() -> Self {
        Self {
            fitted_surface: true,
            roughness_skin: 0.6,
            roughness_lips: 0.45,
            roughness_hair: 0.75,
            specular_f0: 0.028,
        }
    }
}

/// Documentation of one config key: unit, allowed range, meaning and source.
pub struct KeyDoc {
    pub key: &'static str,
    pub unit: &'static str,
    pub range: (f64, f64),
    pub doc: &'static str,
}

const fn k(key: &'static str, unit: &'static str, lo: f64, hi: f64, doc: &'static str) -> KeyDoc {
    KeyDoc {
        key,
        unit,
        range: (lo, hi),
        doc,
    }
}

/// Every key of [`SkinConfig`] (arrays and ranges documented once, at their own key).
pub const KEY_DOCS: &[KeyDoc] = &[
    k("seed", "-", 0.0, 1.8446744073709552e19, "random seed; same seed → bit-identical outputs at any thread count"),
    k("size", "texels", 16.0, 16384.0, "texture width and height"),
    k("scatter_resolution", "texels", 64.0, 8192.0, "resolution at which features are scattered; fixed so that the same seed places the same features at any output size"),
    k("surface.kind", "-", 0.0, 0.0, "\"template\" (the built-in head, derma-head), \"patch\" (flat patch) or \"mesh\" (surface.mesh)"),
    k("surface.patch_size_mm", "mm", 0.1, 10000.0, "physical width and height of a patch"),
    k("surface.tileable", "-", 0.0, 0.0, "patch wraps around so the output tiles seamlessly (thesis §3.3, a modulo space)"),
    k("surface.mesh", "path", 0.0, 0.0, "OBJ, glTF or GLB mesh with UVs (kind = \"mesh\")"),
    k("surface.unit", "-", 0.0, 0.0, "mesh length unit: \"auto\" (with a fitted head, the unit and axes its fit found; else the first of mm, cm, m, in that order, that makes its largest extent a head or face, 100–350 mm, otherwise as \"fit\", with a warning), \"fit\" (scaled so its largest extent is 225 mm, adult vertex–gnathion height, Farkas 1994), \"mm\", \"cm\" or \"m\"; a unit that contradicts a fitted head's is an error"),
    k("surface.part", "-", 0.0, 0.0, "the part of a mesh file of several to paint: a node, mesh or material name; empty = the skin, chosen by name and size (eyes, teeth, lashes, brows and hair left out; the node named head or face first, else the largest); with a fitted head, the part it was fitted to"),
    k("surface.landmarks", "-", 0.0, 0.0, "landmarks of a user mesh, so the built-in head's default fields and regional biology follow it: \"mediapipe\" (the mesh has MediaPipe's 468-point topology, vertex index = landmark id) or a JSON file {\"name\": [x, y, z]} in the mesh's units with every name of derma_head::landmarks::NAMES; +Y up, facing +Z; empty = none"),
    k("fields", "-", 0.0, 0.0, "named fields: name = \"file.png\" or an expression such as \"face - eyes - lips\" (operators + - * / and min, max, clamp, pow, smooth)"),
    k("baseline.phi", "-", 0.0, 1.0, "noise amplitude as a share of each parameter's plausible range (thesis §5.3.1: φ = 0.1)"),
    k("baseline.noise_wavelengths_mm", "mm", 0.01, 1000.0, "wavelengths of the three band-limited noise octaves (weights ½, ⅓, ⅙)"),
    k("baseline.melanin_map", "path", 0.0, 0.0, "melanin map in the mesh's UV layout (EXR channel melanin, or PNG grey × 0.5, the skin-colour LUT's top) replacing the baseline melanin and its regional gain, e.g. from `derma photo chromophores` (empty = none); features paint on top"),
    k("baseline.blood_map", "path", 0.0, 0.0, "dermal blood map as baseline.melanin_map (EXR channel hemoglobin or blood, or PNG grey × 0.32)"),
    k("baseline.melanin", "volume fraction", 0.0, 1.0, "melanosome fraction of the epidermis; default 1.3–6.3 % for light-skinned adults (Jacques 1998, skin optics summary); moderately pigmented 11–16 %, dark 18–43 %"),
    k("baseline.pheomelanin", "fraction", 0.0, 1.0, "pheomelanin share of melanin; around Jimenez et al. 2010 §6 (eumelanin 0.61 → pheomelanin 0.39), spread authored"),
    k("baseline.blood", "volume fraction", 0.0, 1.0, "whole-blood fraction of the dermis before the regional gains: 0.3–2 % (Jacques' 0.2–7 %), which the regions multiply by up to 5.5 (regional.rs) to BioSpec's papillary 1.2 % and above on cheeks and nose; set so the presets' facial a* and b* land near measured faces (docs/head.md)"),
    k("baseline.oxygenation", "fraction", 0.0, 1.0, "oxygenated share of hemoglobin; BioSpec default 0.75 lies inside"),
    k("baseline.stratum_corneum_um", "µm", 0.0, 1000.0, "stratum corneum thickness; BioSpec default 10 µm as minimum"),
    k("baseline.epidermis_um", "µm", 0.0, 2000.0, "living epidermis thickness; BioSpec 100 µm, facial epidermis thinner (Sandby-Møller et al. 2003)"),
    k("baseline.height_mm", "mm", -10.0, 10.0, "baseline displacement range"),
    k("lips.enabled", "-", 0.0, 0.0, "paint lips (thesis §5.3.6)"),
    k("lips.field", "field", 0.0, 0.0, "lip field ∆(p)"),
    k("lips.blood", "volume fraction", 0.0, 1.0, "lip blood ratio B (authored: the vermilion is highly vascular and its thin epidermis shows it; 5 % keeps the lips redder than the well-perfused cheeks with the orange-red hue of photographed lips — 10 % turned them mauve, b* 7 against two scans' 14, docs/skin.md \"Beside a real face\")"),
    k("lips.pheomelanin", "fraction", 0.0, 1.0, "lip pheomelanin ratio H (authored)"),
    k("lips.epidermis_um", "µm", 0.0, 2000.0, "epidermis thickness inside the lips (thin vermilion epidermis; authored)"),
    k("cyst.enabled", "-", 0.0, 0.0, "scatter cysts (thesis §5.3.2)"),
    k("cyst.field", "field", 0.0, 0.0, "cyst density field ∆cysts"),
    k("cyst.density_per_cm2", "1/cm²", 0.0, 1e6, "peak density where the field is 1; default: the thesis' 5000 cysts over the built-in head's cyst field"),
    k("cyst.radius_sigma_mm", "mm", 0.0, 100.0, "r = |σ·Norm(0,1) + offset| (thesis: σ = 0.2)"),
    k("cyst.radius_offset_mm", "mm", 0.0, 100.0, "offset in r (thesis: 0.01)"),
    k("cyst.height_max_mm", "mm", 0.0, 10.0, "h = height_max·U (thesis: ½U)"),
    k("mole.enabled", "-", 0.0, 0.0, "scatter moles (thesis §5.3.3)"),
    k("mole.field", "field", 0.0, 0.0, "mole density field ∆mole"),
    k("mole.density_per_cm2", "1/cm²", 0.0, 1e6, "peak density; default: the thesis' 700 moles over the built-in head's mole field"),
    k("mole.radius_sigma_mm", "mm", 0.0, 100.0, "r = |σ·Norm(0,1)| (thesis: 0.04, read in cm: in mm moles would be invisible)"),
    k("mole.melanin", "volume fraction", 0.0, 1.0, "maximum melanocyte ratio M drawn uniformly in this range (authored; the thesis gives no distribution)"),
    k("mole.height_mm", "mm", 0.0, 10.0, "h drawn uniformly in this range (thesis: 0.7U + 0.3); p_z += h·p_m"),
    k("mole.perimeter_roughness", "-", 0.0, 0.9, "amplitude of random perimeter harmonics (ours, thesis §7.4 asks for less regular shapes)"),
    k("freckle.enabled", "-", 0.0, 0.0, "scatter freckles (thesis §5.3.5)"),
    k("freckle.field", "field", 0.0, 0.0, "freckle density field ∆freckle"),
    k("freckle.power", "-", 0.01, 100.0, "power i applied to the field, concentrating (i > 1) or spreading (i < 1) freckles"),
    k("freckle.density_per_cm2", "1/cm²", 0.0, 1e6, "peak density; default: the thesis' 3000 freckles over the built-in head's freckle field"),
    k("freckle.radius_mean_mm", "mm", 0.0, 100.0, "r ~ Norm(mean, σ) (thesis: Norm(0.8, 0.4)), clamped to ≥ 0.1 mm"),
    k("freckle.radius_sigma_mm", "mm", 0.0, 100.0, "σ of the freckle radius"),
    k("freckle.melanin_max", "volume fraction", 0.0, 1.0, "M = melanin_max·U (thesis: 0.12U)"),
    k("freckle.pheomelanin_scale", "-", 0.0, 1.0, "H = scale·(M + U) (thesis: 0.015)"),
    k("freckle.perimeter_roughness", "-", 0.0, 0.9, "amplitude of random perimeter harmonics (ours)"),
    k("wrinkle.enabled", "-", 0.0, 0.0, "draw wrinkles (thesis §5.3.7)"),
    k("wrinkle.field", "field", 0.0, 0.0, "where wrinkles start"),
    k("wrinkle.vector_field", "field", 0.0, 0.0, "RGB vector field: R,G direction in UV (0.5 = 0), B length (thesis §5.3.7)"),
    k("wrinkle.density_per_cm2", "1/cm²", 0.0, 1e4, "start points per cm² where the field is 1; default: 40 wrinkles (authored) over the built-in head's wrinkle field"),
    k("wrinkle.max_length_mm", "mm", 0.0, 1000.0, "wrinkle length for B = 1 (authored)"),
    k("wrinkle.width_mm", "mm", 0.0, 100.0, "maximum half-width w drawn uniformly in this range (authored)"),
    k("wrinkle.depth_mm", "mm", 0.0, 10.0, "maximum depth h drawn uniformly in this range (authored)"),
    k("pore.enabled", "-", 0.0, 0.0, "scatter pores (ours; thesis §7.4 lists them as missing)"),
    k("pore.field", "field", 0.0, 0.0, "pore density field"),
    k("pore.density_per_cm2", "1/cm²", 0.0, 1e6, "peak pore density (authored: tens to a few hundred per cm² on cheek and nose)"),
    k("pore.radius_mean_mm", "mm", 0.0, 10.0, "pore radius mean (visible facial pores 0.05–0.25 mm across)"),
    k("pore.radius_sigma_mm", "mm", 0.0, 10.0, "pore radius σ"),
    k("pore.depth_mm", "mm", 0.0, 10.0, "pore depth"),
    k("pore.melanin_add", "volume fraction", 0.0, 1.0, "extra melanin at the pore centre (slightly darker ostium)"),
    k("follicle.enabled", "-", 0.0, 0.0, "scatter scalp follicles (thesis §5.3.4)"),
    k("follicle.field", "field", 0.0, 0.0, "follicle density field ∆follicle"),
    k("follicle.density_per_cm2", "1/cm²", 0.0, 1e6, "peak density; default: the thesis' 170 000 hairs over the built-in head's scalp field"),
    k("follicle.inner_radius_mm", "mm", 0.0, 10.0, "hair stalk radius r_i (thesis: 0.04)"),
    k("follicle.outer_radius_mm", "mm", 0.0, 10.0, "visible subdermal hair radius r_o (thesis: 0.1)"),
    k("follicle.height_mm", "mm", 0.0, 10.0, "displacement of a shaven hair stalk (the thesis' 'maximum'; 0.02 mm authored)"),
    k("follicle.blood_reduction", "-", 0.0, 1.0, "share of blood removed at the follicle by the sebaceous gland (thesis §4.8.5 interaction; 0.5 authored)"),
    k("follicle.gland_radius_mm", "mm", 0.0, 10.0, "radius of that blood reduction (0.3 mm authored, about a sebaceous gland)"),
    k("eyebrow.enabled", "-", 0.0, 0.0, "scatter eyebrow follicles"),
    k("eyebrow.field", "field", 0.0, 0.0, "eyebrow field"),
    k("eyebrow.density_per_cm2", "1/cm²", 0.0, 1e6, "peak density; default: 500 hairs (≈ 250 per brow) over the built-in head's eyebrow field"),
    k("eyebrow.inner_radius_mm", "mm", 0.0, 10.0, "hair stalk radius"),
    k("eyebrow.outer_radius_mm", "mm", 0.0, 10.0, "visible radius"),
    k("eyebrow.height_mm", "mm", 0.0, 10.0, "stalk displacement"),
    k("eyebrow.blood_reduction", "-", 0.0, 1.0, "blood removed at the follicle"),
    k("eyebrow.gland_radius_mm", "mm", 0.0, 10.0, "radius of the blood reduction"),
    k("hair.strands", "-", 0.0, 0.0, "grow hair strands from the eyebrow follicles and (men) the beard follicles: painted into base colour, height and normal, their coverage in hair_coverage.png (features/strand.rs); scalp hair is out of scope"),
    k("hair.melanin_from_skin", "-", 0.0, 0.0, "the hair's melanins follow person.ita_deg (derma_shading::hair::HairMelanin::for_skin_tone: light brown at very light skin to black at dark; authored); false: hair.eumelanin and hair.pheomelanin"),
    k("hair.eumelanin", "-", 0.0, 50.0, "the hair fibre's eumelanin in d'Eon et al. 2011's units (blonde ≈ 0.3, brown ≈ 1.3, black ≈ 8; pbrt-v3 §9.9), used when hair.melanin_from_skin = false; the colour of follicles, brows, stubble and lashes"),
    k("hair.pheomelanin", "-", 0.0, 50.0, "the hair fibre's pheomelanin (red hair: several units), used when hair.melanin_from_skin = false"),
    k("hair.vector_field", "field", 0.0, 0.0, "vector field of the hair's growth direction, its length scaling the hair's (built-in head: the brows' flow, medial hairs up and the tail down, the upper row angled down and the lower up; beard hair down; medial brow hairs half as long); absent: strands grow along +v of the UV layout"),
    k("hair.brow_length_mm", "mm", 0.0, 50.0, "length of a brow hair's visible part, drawn uniformly (authored; eyebrow hairs are about a centimetre long and lie at a shallow angle)"),
    k("hair.brow_radius_mm", "mm", 0.0, 1.0, "brow hair radius (coarse terminal fibres of about 0.1 mm diameter; authored)"),
    k("hair.stubble_length_mm", "mm", 0.0, 20.0, "stubble on a man's beard follicles: about 1 mm is two to three days of growth at the beard's ≈ 0.4 mm a day (authored); 0 = clean-shaven"),
    k("hair.stubble_radius_mm", "mm", 0.0, 1.0, "beard hair radius (coarse terminal hair, about 0.1 mm across; authored)"),
    k("hair.beard_field", "field", 0.0, 0.0, "field of the beard area: a follicle grows stubble with probability BEARD_TO_SCALP·beard / follicle field there (men only)"),
    k("material.fitted_surface", "-", 0.0, 0.0, "the skin's roughness and specular level from the appearance's fit of the Monte Carlo surface (the match table's: glTF GGX fitted to the light the surface reflects without entering, docs/matching.md), lips and hair blended over it as below; false, or the analytic appearance (no surface model): material.roughness_skin and material.specular_f0 — a config that sets either without this key means false"),
    k("material.roughness_skin", "-", 0.0, 1.0, "glTF perceptual roughness of skin where the surface is not fitted: √α with α ≈ m = 0.3–0.45 (Weyrich et al. 2006, Torrance–Sparrow fits of faces) → 0.6"),
    k("material.roughness_lips", "-", 0.0, 1.0, "roughness on the lips (moist, glossier; authored)"),
    k("material.roughness_hair", "-", 0.0, 1.0, "roughness under hair (authored)"),
    k("detail.height", "path", 0.0, 0.0, "grey exemplar of fine relief (PNG/EXR; empty = none), synthesised into a tileable tile by derma-synth and added to the height (and so the normals)"),
    k("detail.albedo", "path", 0.0, 0.0, "colour exemplar of fine skin colour (empty = none; registered with detail.height when both are given); its luminance contrast modulates melanin"),
    k("detail.tile_size", "texels", 64.0, 4096.0, "side of the synthesised tileable detail tile"),
    k("detail.repeat", "-", 0.01, 1000.0, "times the tile repeats across the texture's UV range"),
    k("detail.patch", "texels", 4.0, 128.0, "synthesis patch side N (even; exemplars at least 2N)"),
    k("detail.highpass_texels", "texels", 1.0, 256.0, "box high-pass radius on the tile: keeps detail finer than 2r + 1 tile texels, below the procedural features"),
    k("detail.height_mm", "mm", 0.0, 10.0, "RMS of the added relief (authored; skin micro-relief is tens of µm)"),
    k("detail.regions", "-", 0.0, 0.0, "one height exemplar per region, as Graham et al. 2013 grow measured microgeometry per facial region: a table region = path (a field name, e.g. the built-in head's cheeks, forehead, nose); each grows its own tile, blended by the region's mask, the global exemplar (if any) filling the rest"),
    k("detail.albedo_contrast", "-", 0.0, 10.0, "gain of the colour exemplar's relative luminance contrast on melanin (1 = as in the exemplar, to first order)"),
    k("relief.enabled", "-", 0.0, 0.0, "the micro-relief furrow network between features (features/relief.rs), on by default"),
    k("relief.field", "-", 0.0, 0.0, "field scaling the furrow depth (built-in head: by region; patches and meshes without landmarks: 1)"),
    k("relief.vector_field", "-", 0.0, 0.0, "vector field of the skin's tension lines (relaxed skin tension lines, Borges 1984); furrows along it are the deep ones; absent: isotropic"),
    k("relief.cell_mm", "mm", 0.01, 20.0, "plateau size of the three octaves: secondary lines divide the skin into plateaus of 0.1–0.5 mm and primary lines outline polygons of about 0.5–2 mm (skin-replica studies, e.g. Hashimoto 1974); the coarsest octave (3.2 mm) is larger, authored so the normal map's tilt statistics at 1024² reach a head scan's (issue 21)"),
    k("relief.depth_mm", "mm", 0.0, 0.5, "furrow depth per octave: primary lines ≈ 20–100 µm, secondary ≈ 5–40 µm (replica profilometry, Hashimoto 1974); deeper with age (× √ of regional::age_factor)"),
    k("relief.width_fraction", "-", 0.0, 0.5, "furrow half-width as a fraction of the cell size (authored; never below ¾ texel, cross-section kept)"),
    k("relief.dome_fraction", "-", 0.0, 2.0, "plateau dome height as a fraction of the octave's furrow depth (authored)"),
    k("relief.anisotropy", "-", 0.0, 1.0, "how much shallower furrows across the tension lines are (0 isotropic, 1 only parallel ones; authored)"),
    k("person.ita_deg", "°", -90.0, 90.0, "skin tone as the individual typology angle of cheeks and forehead, atan((L*−50)/b*) (Chardon et al. 1991): very light > 55, light 41–55, intermediate 28–41, tan 10–28, brown −30–10, dark < −30; default 48 (light)"),
    k("person.calibrate_melanin", "-", 0.0, 0.0, "set baseline.melanin so the mean cheek/forehead colour has person.ita_deg under the chosen appearance (bisection on melanin); false keeps baseline.melanin as given — a config that sets baseline.melanin without this key means false"),
    k("person.sex", "-", 0.0, 0.0, "\"male\" (terminal beard follicles on the beard region, builtin_head::BEARD_TO_SCALP) or \"female\" (vellus only)"),
    k("person.age_years", "years", 10.0, 100.0, "age: wrinkle density × age_factor and depth × √age_factor (1 at 40, 0.2 at ≤ 20, 2.2 at ≥ 70; regional::age_factor)"),
    k("mottling.enabled", "-", 0.0, 0.0, "centimetre-scale blotches of blood and pigment (mottling.rs): the uneven colour within a region of a real face"),
    k("mottling.wavelengths_mm", "mm", 1.0, 1000.0, "wavelengths of the mottling's three noise octaves (weights ½, ⅓, ⅙): blotches from millimetres to centimetres, the band of measured facial colour heterogeneity"),
    k("mottling.blood", "-", 0.0, 3.0, "log amplitude of the blood's mottling: the factor exp(a (2n − 1)) spans e^±a; authored (1.2): two photographed albedos vary 1.6–3.3 in a* within a region after a 2 mm blur (docs/skin.md, \"Beside a real face\"), which 0.7 reached only halfway; the regions still carry the face's coarse redness"),
    k("mottling.melanin", "-", 0.0, 3.0, "log amplitude of the melanin's mottling (pigment blotches, independent of the blood's)"),
    k("regional.enabled", "-", 0.0, 0.0, "regional biology of the built-in head (regional.rs GAINS): blood, melanin, oxygenation and epidermis by region"),
    k("material.specular_f0", "-", 0.0, 1.0, "normal-incidence reflectance of skin where the surface is not fitted: ((n−1)/(n+1))² for n = 1.4 (Donner & Jensen 2006, the analytic appearance's index) = 0.028"),
];

/// How a config's errors name where it came from: a file as "config 'FILE'", a description
/// ("the options", beginning with "the") as it is.
fn origin(source: &str) -> String {
    if source.starts_with("the ") {
        source.to_string()
    } else {
        format!("config '{source}'")
    }
}

impl SkinConfig {
    /// Every field name this configuration reads: the features', hair's and relief's fields,
    /// the detail regions and the names `[fields]` defines (a fields directory may hold any).
    pub fn field_names(&self) -> std::collections::BTreeSet<String> {
        [
            &self.lips.field,
            &self.cyst.field,
            &self.mole.field,
            &self.freckle.field,
            &self.wrinkle.field,
            &self.wrinkle.vector_field,
            &self.pore.field,
            &self.follicle.field,
            &self.eyebrow.field,
            &self.hair.vector_field,
            &self.hair.beard_field,
            &self.relief.field,
            &self.relief.vector_field,
        ]
        .into_iter()
        .chain(self.detail.regions.keys())
        .chain(self.fields.keys())
        .cloned()
        .collect()
    }

    /// Parses TOML, rejecting unknown keys and out-of-range values. `source` names the file.
    ///
    /// A config that sets `baseline.melanin` and says nothing of `person.calibrate_melanin`
    /// means that melanin: calibration to `person.ita_deg` is then off. Likewise one that sets
    /// `material.roughness_skin` or `material.specular_f0` and says nothing of
    /// `material.fitted_surface` means those values.
    pub fn from_toml(text: &str, source: &str) -> Result<SkinConfig, crate::SkinError> {
        let mut cfg: SkinConfig = toml::from_str(text).map_err(|e| crate::SkinError::Config {
            origin: origin(source),
            detail: e.to_string(),
        })?;
        let table: toml::Table = toml::from_str(text).map_err(|e| crate::SkinError::Config {
            origin: origin(source),
            detail: e.to_string(),
        })?;
        let has = |section: &str, key: &str| {
            table
                .get(section)
                .and_then(|t| t.as_table())
                .is_some_and(|t| t.contains_key(key))
        };
        if has("baseline", "melanin") && !has("person", "calibrate_melanin") {
            cfg.person.calibrate_melanin = false;
        }
        if (has("material", "roughness_skin") || has("material", "specular_f0"))
            && !has("material", "fitted_surface")
        {
            cfg.material.fitted_surface = false;
        }
        cfg.validate(source)?;
        Ok(cfg)
    }

    /// Checks every numeric value against its documented range (NaN is always rejected).
    pub fn validate(&self, source: &str) -> Result<(), crate::SkinError> {
        let value = toml::Value::try_from(self).map_err(|e| crate::SkinError::Config {
            origin: origin(source),
            detail: e.to_string(),
        })?;
        let mut problems = Vec::new();
        walk(&value, "", &mut |key, v| {
            let Some(x) = v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) else {
                return;
            };
            let doc_key = doc_key_for(key);
            let Some(doc) = KEY_DOCS.iter().find(|d| d.key == doc_key) else {
                return;
            };
            let (lo, hi) = doc.range;
            if x.is_nan() || (lo < hi && !(lo..=hi).contains(&x)) {
                problems.push(format!(
                    "{key} = {x}: expected a value in [{lo}, {hi}] ({})",
                    doc.unit
                ));
            }
        });
        for (name, r) in [
            ("baseline.melanin", self.baseline.melanin),
            ("baseline.pheomelanin", self.baseline.pheomelanin),
            ("baseline.blood", self.baseline.blood),
            ("baseline.oxygenation", self.baseline.oxygenation),
            (
                "baseline.stratum_corneum_um",
                self.baseline.stratum_corneum_um,
            ),
            ("baseline.epidermis_um", self.baseline.epidermis_um),
            ("baseline.height_mm", self.baseline.height_mm),
            ("mole.melanin", self.mole.melanin),
            ("mole.height_mm", self.mole.height_mm),
            ("wrinkle.width_mm", self.wrinkle.width_mm),
            ("wrinkle.depth_mm", self.wrinkle.depth_mm),
        ] {
            if r.min > r.max {
                problems.push(format!(
                    "{name}: min {} is larger than max {}",
                    r.min, r.max
                ));
            }
        }
        if self.follicle.inner_radius_mm > self.follicle.outer_radius_mm {
            problems
                .push("follicle.inner_radius_mm must not exceed follicle.outer_radius_mm".into());
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(crate::SkinError::Config {
                origin: origin(source),
                detail: problems.join("; "),
            })
        }
    }

    /// The full default configuration as commented TOML (`derma skin --print-config`).
    pub fn print_default() -> String {
        let mut value =
            toml::Value::try_from(SkinConfig::default()).expect("default config serializes");
        tidy_floats(&mut value);
        let mut out = String::from(
            "# derma skin configuration: every key, its unit, default and source.\n# Unknown keys are errors. Lengths in mm, layer thicknesses in µm, fractions in [0, 1].\n",
        );
        let table = value.as_table().expect("table");
        let doc = |key: &str| KEY_DOCS.iter().find(|d| d.key == key);
        let line = |out: &mut String, key: &str, short: &str, v: &toml::Value| {
            if let Some(d) = doc(key) {
                out.push_str(&format!("# {} [{}]\n", d.doc, d.unit));
            }
            out.push_str(&format!("{short} = {v}\n"));
        };
        for (k, v) in table {
            if !v.is_table() {
                line(&mut out, k, k, v);
            }
        }
        out.push_str("\n[fields]\n# ");
        out.push_str(doc("fields").map(|d| d.doc).unwrap_or(""));
        out.push_str("\n# built-in names on the head: scalp, eyebrows, lips, freckles, moles, cysts, pores, wrinkles, wrinkle_vectors, face, eyes, every region (forehead, periorbital, eyelids, nose, cheeks, ears, upper_lip, beard, chin, neck, mouth_interior, eye_sockets) and regional_blood/melanin/oxygenation/epidermis\n");
        for (k, v) in table {
            if let Some(t) = v.as_table() {
                if k == "fields" {
                    continue;
                }
                out.push_str(&format!("\n[{k}]\n"));
                for (k2, v2) in t {
                    line(&mut out, &format!("{k}.{k2}"), k2, v2);
                }
            }
        }
        out
    }
}

/// Prints every float as the value written in the source (0.04, not 0.03999999910593033): the
/// config's fields are f32, which TOML serializes through f64.
fn tidy_floats(v: &mut toml::Value) {
    match v {
        toml::Value::Float(x) => *x = derma_core::report::as_written(*x),
        toml::Value::Array(a) => a.iter_mut().for_each(tidy_floats),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| tidy_floats(v)),
        _ => {}
    }
}

/// Maps a serialized key path (which may go into a range's min/max or an array index) to its
/// documented key.
fn doc_key_for(key: &str) -> String {
    let key = key.split('[').next().unwrap_or(key);
    for suffix in [".min", ".max"] {
        if let Some(stem) = key.strip_suffix(suffix) {
            if KEY_DOCS.iter().any(|d| d.key == stem) {
                return stem.to_string();
            }
        }
    }
    key.to_string()
}

fn walk(v: &toml::Value, prefix: &str, f: &mut dyn FnMut(&str, &toml::Value)) {
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                walk(v, &key, f);
            }
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                walk(v, &format!("{prefix}[{i}]"), f);
            }
        }
        other => f(prefix, other),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn docs_cover_exactly_the_serialized_keys() {
        let value = toml::Value::try_from(SkinConfig::default()).unwrap();
        let mut keys = std::collections::BTreeSet::new();
        walk(&value, "", &mut |k, _| {
            keys.insert(doc_key_for(k));
        });
        keys.insert("fields".to_string());
        keys.insert("detail.regions".to_string());
        let documented: std::collections::BTreeSet<String> =
            KEY_DOCS.iter().map(|d| d.key.to_string()).collect();
        assert_eq!(keys, documented);
    }

    #[test]
    fn defaults_validate_and_print_roundtrips() {
        SkinConfig::default().validate("default").unwrap();
        let printed = SkinConfig::print_default();
        let back = SkinConfig::from_toml(&printed, "printed").unwrap();
        assert_eq!(back, SkinConfig::default());
        assert!(printed.contains("Jacques 1998"));
        // Floats print as written: 0.028, not the f32's binary value in full.
        assert!(printed.contains("specular_f0 = 0.028\n"), "{printed}");
        assert!(!printed.contains("0.0279999"), "{printed}");
    }

    #[test]
    fn a_config_that_sets_the_skins_roughness_or_f0_keeps_them() {
        let m = |t: &str| {
            SkinConfig::from_toml(t, "m")
                .unwrap()
                .material
                .fitted_surface
        };
        assert!(m("seed = 3\n"));
        assert!(!m("[material]\nroughness_skin = 0.5\n"));
        assert!(!m("[material]\nspecular_f0 = 0.04\n"));
        assert!(m("[material]\nspecular_f0 = 0.04\nfitted_surface = true\n"));
        assert!(m("[material]\nroughness_lips = 0.3\n"));
    }

    #[test]
    fn a_config_that_sets_melanin_keeps_it() {
        let c =
            SkinConfig::from_toml("[baseline]\nmelanin = { min = 0.1, max = 0.2 }\n", "m").unwrap();
        assert!(!c.person.calibrate_melanin);
        let c = SkinConfig::from_toml(
            "[baseline]\nmelanin = { min = 0.1, max = 0.2 }\n[person]\ncalibrate_melanin = true\n",
            "m",
        )
        .unwrap();
        assert!(c.person.calibrate_melanin);
        assert!(
            SkinConfig::from_toml("seed = 3\n", "m")
                .unwrap()
                .person
                .calibrate_melanin
        );
    }

    #[test]
    fn bad_values_are_named() {
        let e = SkinConfig::from_toml("[mole]\nradius_sigma_mm = -1.0\n", "my.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("my.toml") && e.contains("mole.radius_sigma_mm") && e.contains("-1"),
            "{e}"
        );
        let e = SkinConfig::from_toml("[freckle]\npower = nan\n", "c.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("freckle.power"), "{e}");
        let e = SkinConfig::from_toml("[mole]\nradius = 1.0\n", "c.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field") && e.contains("radius"), "{e}");
        let e = SkinConfig::from_toml("[baseline]\nmelanin = { min = 0.5, max = 0.1 }\n", "c.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("baseline.melanin"), "{e}");
    }
}
