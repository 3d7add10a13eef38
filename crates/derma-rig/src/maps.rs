//! The maps a rig reads and writes (Jimenez et al. 2010 §4, §6): hemoglobin (dermal blood
//! volume fraction) and melanin as EXR channels by name, or as PNG grey scaled by the
//! skin-colour LUT's axis tops (table 1: melanin ≤ 0.5, blood ≤ 0.32); the skin mask; colour
//! frames as sRGB PNG or linear EXR.

use crate::error::{Result, RigError};
use derma_core::image_io::{
    read_exr_channels, read_grey, write_exr, write_png16, write_png8_srgb, ExrPrecision,
};
use derma_core::progress::{Note, Progress};
use derma_core::Map;
use derma_optics::bio::names;
use derma_shading::skin_color_lut::LutOptions;
use std::path::Path;

/// Which quantity a map holds, for reading it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Dermal blood volume fraction (C_hd of eq. 7).
    Hemoglobin,
    /// Melanosome volume fraction of the epidermis (C_m).
    Melanin,
    /// Skin mask: > 0 where the statistics may look.
    Mask,
}

impl Quantity {
    /// EXR channels tried in order (after a file's only channel): the quantity's own name,
    /// then the generic grey ones. `blood` is hemoglobin.exr's channel before it was named
    /// `hemoglobin`, so older maps still read.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Quantity::Hemoglobin => &[names::HEMOGLOBIN, names::BLOOD, "Y", "R"],
            Quantity::Melanin => &[names::MELANIN, "Y", "R"],
            Quantity::Mask => &["mask", "Y", "A", "R"],
        }
    }

    /// The value of PNG grey 1: the LUT's axis top for hemoglobin and melanin, 1 for a mask.
    pub fn png_scale(self, lut: &LutOptions) -> f32 {
        match self {
            Quantity::Hemoglobin => lut.blood_max as f32,
            Quantity::Melanin => lut.melanin_max as f32,
            Quantity::Mask => 1.0,
        }
    }
}

fn is_exr(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Reads a scalar map: EXR by channel name (see [`Quantity::channels`]), other images as grey
/// × [`Quantity::png_scale`]. A colour image is read by its luminance, with a note.
pub fn read_map(
    path: &Path,
    q: Quantity,
    lut: &LutOptions,
    progress: &dyn Progress,
) -> Result<Map> {
    if is_exr(path) {
        let chans = read_exr_channels(path)?;
        if chans.len() == 1 {
            return Ok(chans.into_iter().next().expect("one").1);
        }
        for want in q.channels() {
            if let Some((_, m)) = chans.iter().find(|(n, _)| n.eq_ignore_ascii_case(want)) {
                return Ok(m.clone());
            }
        }
        return Err(RigError::File {
            path: path.to_path_buf(),
            detail: format!(
                "none of the channels {:?} found; it has {:?}",
                q.channels(),
                chans.iter().map(|c| c.0.as_str()).collect::<Vec<_>>()
            ),
        });
    }
    let img = read_grey(path)?;
    if img.is_color {
        progress.note(Note::warning(format!(
            "'{}' is a color image; using its luminance",
            path.display()
        )));
    }
    let m = img.channels.into_iter().next().expect("grey");
    let s = q.png_scale(lut);
    Ok(Map::from_vec(
        m.width(),
        m.height(),
        m.data().iter().map(|v| v * s).collect(),
    )?)
}

/// [`read_map`] of an optional path.
pub fn read_optional(
    path: Option<&Path>,
    q: Quantity,
    lut: &LutOptions,
    progress: &dyn Progress,
) -> Result<Option<Map>> {
    path.map(|p| read_map(p, q, lut, progress)).transpose()
}

/// The melanin map a rig's frames are coloured with: the file at `path` when given (checked
/// against the rig's size), else the rig's own. An error when neither exists.
pub fn melanin_for(
    rig: &crate::Rig,
    path: Option<&Path>,
    lut: &LutOptions,
    progress: &dyn Progress,
) -> Result<Map> {
    let m = match path {
        Some(p) => {
            let m = read_map(p, Quantity::Melanin, lut, progress)?;
            if (m.width(), m.height()) != rig.size() {
                return Err(RigError::Size {
                    what: p.display().to_string(),
                    got_w: m.width(),
                    got_h: m.height(),
                    want_w: rig.size().0,
                    want_h: rig.size().1,
                });
            }
            m
        }
        None => rig.melanin.clone().ok_or_else(|| {
            crate::error::invalid(
                "melanin",
                "the rig has no melanin map to color with; give a melanin map, or build the rig with one",
            )
        })?,
    };
    Ok(m)
}

/// Writes a colour frame: `.exr` as linear float R, G, B; anything else as 8-bit sRGB PNG.
pub fn write_color(path: &Path, rgb: &[Map; 3]) -> Result<()> {
    if is_exr(path) {
        write_exr(
            path,
            &[("R", &rgb[0]), ("G", &rgb[1]), ("B", &rgb[2])],
            ExrPrecision::F32,
        )?;
    } else {
        write_png8_srgb(path, &[&rgb[0], &rgb[1], &rgb[2]])?;
    }
    Ok(())
}

/// Writes a hemoglobin map: `.exr` as the volume fraction (channel `hemoglobin`), anything
/// else as a 16-bit PNG of value / the LUT's blood top.
pub fn write_hemoglobin(path: &Path, h: &Map, lut: &LutOptions) -> Result<()> {
    if is_exr(path) {
        write_exr(path, &[(names::HEMOGLOBIN, h)], ExrPrecision::F32)?;
    } else {
        let top = lut.blood_max as f32;
        let v = Map::from_vec(
            h.width(),
            h.height(),
            h.data().iter().map(|x| x / top).collect(),
        )?;
        write_png16(path, &[&v])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use derma_core::progress::Silent;

    #[test]
    fn exr_channels_by_name_png_by_scale_and_hemoglobin_round_trips() {
        let dir = derma_test_support::scratch_dir("rig-maps");
        let lut = LutOptions::default();
        let mut h = Map::filled(4, 3, 0.02);
        h.set(3, 2, 0.3);
        // EXR: written under `hemoglobin`, read back exactly; an old `blood` channel reads too.
        let p = dir.join("h.exr");
        write_hemoglobin(&p, &h, &lut).unwrap();
        assert_eq!(
            read_map(&p, Quantity::Hemoglobin, &lut, &Silent).unwrap(),
            h
        );
        let old = dir.join("old.exr");
        let o = Map::filled(4, 3, 0.6);
        write_exr(
            &old,
            &[(names::BLOOD, &h), (names::OXYGENATION, &o)],
            ExrPrecision::F32,
        )
        .unwrap();
        assert_eq!(
            read_map(&old, Quantity::Hemoglobin, &lut, &Silent).unwrap(),
            h
        );
        let e = read_map(&old, Quantity::Melanin, &lut, &Silent).unwrap_err();
        assert!(e.to_string().contains("old.exr"), "{e}");
        // PNG: grey 1 is the LUT's top (0.32 for blood), within 16-bit precision.
        let png = dir.join("h.png");
        write_hemoglobin(&png, &h, &lut).unwrap();
        let back = read_map(&png, Quantity::Hemoglobin, &lut, &Silent).unwrap();
        for (a, b) in back.data().iter().zip(h.data()) {
            assert!((a - b).abs() < 0.32 / 65535.0 + 1e-7, "{a} {b}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
