//! The files of a texture set (the project's design, §3 "Outputs"): every name, its colour
//! space and meaning, defined once. Writing, manifest.json and the check that no input is
//! overwritten all read this table. Names follow the Substance/Unreal convention; the maps the
//! renderer reads take derma-render's names ([`derma_render::material::files`]).

use derma_render::material::files;

/// `base_color.png`: diffuse albedo.
pub const BASE_COLOR: &str = files::BASE_COLOR;
/// `normal.png`: tangent-space normal.
pub const NORMAL: &str = files::NORMAL;
/// `wrinkle_normal.png`: the normal with every expression furrow at full activation.
pub const WRINKLE_NORMAL: &str = files::WRINKLE_NORMAL;
/// `wrinkle_masks.exr`: the regions of expression wrinkles.
pub const WRINKLE_MASKS: &str = files::WRINKLE_MASKS;
/// `height.exr`: displacement in mm.
pub const HEIGHT_EXR: &str = "height.exr";
/// `height.png`: displacement, normalised.
pub const HEIGHT_PNG: &str = "height.png";
/// `roughness.png`.
pub const ROUGHNESS: &str = files::ROUGHNESS;
/// `specular.png`.
pub const SPECULAR: &str = files::SPECULAR;
/// `hair_coverage.png`: the hair's coverage.
pub const HAIR_COVERAGE: &str = "hair_coverage.png";
/// `lashes.png`: the built-in head's lash cards.
pub const LASHES: &str = "lashes.png";
/// `melanin.exr`.
pub const MELANIN: &str = "melanin.exr";
/// `hemoglobin.exr`.
pub const HEMOGLOBIN: &str = "hemoglobin.exr";
/// `bio.exr`: every bio parameter.
pub const BIO: &str = "bio.exr";
/// `sss_color.png` (with a subsurface-aware appearance).
pub const SSS_COLOR: &str = files::SSS_COLOR;
/// `sss_radius.png` (with a subsurface-aware appearance).
pub const SSS_RADIUS: &str = files::SSS_RADIUS;
/// `features.json`: every placed feature.
pub const FEATURES: &str = "features.json";
/// `preview.png`.
pub const PREVIEW: &str = "preview.png";
/// `manifest.json`: this table, for the files written.
pub const MANIFEST: &str = "manifest.json";
/// `report.json`: the run.
pub const REPORT: &str = "report.json";

/// One output file as manifest.json lists it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct OutputFile {
    /// File name inside the output directory.
    pub file: &'static str,
    /// How its values are encoded ("sRGB", "linear", "linear (non-color)", "-").
    pub color_space: &'static str,
    /// What it holds, for a user opening it in an engine.
    pub meaning: &'static str,
}

const fn out(file: &'static str, color_space: &'static str, meaning: &'static str) -> OutputFile {
    OutputFile {
        file,
        color_space,
        meaning,
    }
}

/// Every file `derma skin` writes, in manifest order.
pub const OUTPUTS: [OutputFile; 19] = [
    out(BASE_COLOR, "sRGB", "diffuse albedo (glTF baseColor / Unreal Base Color), 8-bit sRGB"),
    out(NORMAL, "linear (non-colour)", "tangent-space normal, OpenGL +Y (green up), MikkTSpace frame on meshes; 16-bit, n·½+½"),
    out(WRINKLE_NORMAL, "linear (non-colour)", "normal.png with every expression wrinkle at full activation (furrows 4× deeper and 0.75× as wide); blend per texel n = normalize(lerp(normal, wrinkle_normal, m)), m = clamp(Σ_r w_r·mask_r, 0, 1) from wrinkle_masks.exr and the face units (docs/rig.md, Expression wrinkles); 16-bit"),
    out(WRINKLE_MASKS, "linear", "the regions of expression wrinkles (one half-float channel each: forehead, glabella, crow's feet, under-eye, nasolabial, left and right) at up to 1024²; written where the head's landmarks place them"),
    out(HEIGHT_EXR, "linear", "displacement in mm from the mean skin surface (height_mm) and what the expression wrinkles add at full activation (height_mm_furrow), float32"),
    out(HEIGHT_PNG, "linear (non-colour)", "displacement, 16-bit, 0 ↔ height_range.min_mm and 1 ↔ max_mm (report.json)"),
    out(ROUGHNESS, "linear (non-colour)", "glTF perceptual roughness (Unreal Roughness), 8-bit"),
    out(SPECULAR, "linear (non-colour)", "specular level F0/0.08 (Unreal/Substance Specular: 0.5 ↔ F0 = 4 %), 8-bit"),
    out(HAIR_COVERAGE, "linear (non-colour)", "coverage of hair (follicles, brow hairs, stubble), 8-bit: an alpha/opacity mask for hair cards or a shader that treats hair apart; base_color already has the hair painted in"),
    out(LASHES, "sRGB", "the built-in head's eyelash cards (its eyelashes meshes' UVs), 512², 8-bit RGBA: the hair's colour (sRGB) and single tapering lashes as alpha, for alpha testing; written on the built-in head only"),
    out(MELANIN, "linear", "melanosome volume fraction of the epidermis (melanin) and pheomelanin share"),
    out(HEMOGLOBIN, "linear", "whole-blood volume fraction of the dermis (hemoglobin) and its oxygenation"),
    out(BIO, "linear", "every bio parameter as a channel (half float): melanin, pheomelanin, blood, oxygenation, stratum_corneum_um, epidermis_um, height_mm, extra.RGBA, lips"),
    out(SSS_COLOR, "sRGB", "subsurface colour: Burley 2015 surface albedo A of the fitted diffusion profile (Unreal Subsurface Color, Blender Subsurface Color), 8-bit sRGB"),
    out(SSS_RADIUS, "linear (non-colour)", "subsurface scatter distance per channel (Christensen & Burley 2015 mean free path, Blender Subsurface Radius), 16-bit, 0 ↔ 0 mm and 1 ↔ 8 mm"),
    out(FEATURES, "-", "every placed feature with its parameters (mm)"),
    out(PREVIEW, "sRGB", "shaded preview and a contact sheet of the maps"),
    out(MANIFEST, "-", "this list: every file with its colour space, meaning and SHA-256 (report.json unhashed), and the seed, inputs, options and UV layout it was painted with; `derma check` verifies it"),
    out(REPORT, "-", "run report: version, seed, inputs with hashes, counts, statistics, timings"),
];

/// `head.glb`: the set on its head or mesh, for engines (written beside the maps on request).
pub const GLB: &str = "head.glb";

/// True for a name a set's directory may hold: its files, its GLB and the temporary files of
/// atomic writes. A directory holding anything else is not a set and is never replaced.
pub fn owned(name: &str) -> bool {
    output(name).is_some() || name == GLB || name.ends_with(".tmp")
}

/// The table's entry for `file`.
pub fn output(file: &str) -> Option<&'static OutputFile> {
    OUTPUTS.iter().find(|o| o.file == file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_is_listed_once() {
        let names: std::collections::HashSet<&str> = OUTPUTS.iter().map(|o| o.file).collect();
        assert_eq!(names.len(), OUTPUTS.len());
        assert!(output(SSS_RADIUS).is_some() && output("bio.png").is_none());
    }
}
