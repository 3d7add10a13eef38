//! Measured chromophore maps (a photographed face's, `derma photo chromophores`) and the colour
//! model they are inverted in: the skin's own appearance at the baseline's mean tissue, so that a
//! set painted from them (`[baseline] melanin_map`, `blood_map`) gives back the photo's colour.

use crate::config::SkinConfig;
use crate::generate::SkinGenerator;
use crate::Result;
use derma_shading::skin_color_lut::SkinColorLut;
use derma_shading::table_appearance::TableAppearance;
use std::path::Path;

/// Nodes per axis of the inversion's table: authored, nine times the match table's 7 melanin
/// nodes and sixteen times its 4 blood nodes, between which its colour is smooth (simplices in
/// log colour). The loop test (`derma/tests/photo_cli.rs`) bounds what the table and the
/// painter together leave: 0.79 ΔE*ab median, the features and 8-bit steps included.
pub const LUT_NODES: usize = 64;

/// The largest melanin volume fraction inverted to: the built-in match table's top node
/// (`match-grid.toml`, melanin 0.002–0.5).
pub const MELANIN_MAX: f64 = 0.5;

/// The largest dermal blood volume fraction inverted to: the built-in match table's top node
/// (`match-grid.toml`, blood 0.003–0.1); above it the table holds its colour, and a colour
/// cannot tell more blood apart.
pub const BLOOD_MAX: f64 = 0.1;

/// The table `derma photo chromophores` inverts colours with: derma-shading's built-in match
/// table (the appearance `derma skin` paints with by default) over melanin and dermal blood, at
/// `cfg`'s baseline mean tissue for the other parameters (the tissue measured maps are painted
/// at, [`crate::paint::BaselineMaps::tissue`]).
pub fn inversion_lut(cfg: &SkinConfig) -> SkinColorLut {
    SkinColorLut::from_appearance(
        &TableAppearance::builtin(),
        &cfg.baseline.mean_tissue(),
        LUT_NODES,
        MELANIN_MAX,
        BLOOD_MAX,
    )
}

/// [`inversion_lut`] of a skin config file, or of the default config.
pub fn inversion_lut_of(config: Option<&Path>) -> Result<SkinColorLut> {
    Ok(match config {
        Some(p) => inversion_lut(SkinGenerator::from_config_file(p)?.config()),
        None => inversion_lut(&SkinConfig::default()),
    })
}
