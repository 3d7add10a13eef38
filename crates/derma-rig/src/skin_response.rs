//! The skin under a rig frame: each texel's colour re-shaded with the frame's hemoglobin through
//! the appearance that made the texture set's base colour (eq. 6 gives H; docs/rig.md "Composition").
//!
//! The rig changes only hemoglobin (Jimenez et al. 2010 §1), so a frame's colour is the set's own
//! `base_color.png` plus the change the appearance makes when the texel's dermal blood moves from
//! H_n to H, every other bio parameter (melanin, pheomelanin, oxygenation, layer thicknesses) and
//! the hair painted over it kept: moles, freckles, lips, regional melanin and synthesised detail
//! persist in every frame, and a neutral frame *is* `base_color.png`.
//!
//! For shaders the change is stored per texel as a quadratic in x = ∛H − ∛H_n (the cube-root
//! axis Jimenez et al. index their LUT by, eq. 7, along which skin colour is nearly linear):
//! colour = base + d1·x + d2·x², the quadratic through the appearance at H_n·[`RATIO_LOW`], H_n and
//! H_n·[`RATIO_HIGH`], scaled by the share of the texel that is skin, not hair. Two RGB maps serve
//! the CPU, `rig.wgsl`, the viewer and an engine alike; its error against re-shading every texel
//! exactly is measured by `crates/derma-rig/tests/composition.rs` and stated in docs/rig.md.

use crate::error::{invalid, Result, RigError};
use derma_core::color::srgb8_decode;
use derma_core::image_io::{read_exr_channels, srgb8};
use derma_core::Map;
use derma_optics::bio::names;
use derma_shading::{Appearance, BioTexel};
use rayon::prelude::*;
use std::path::Path;

/// Lower node of the quadratic, as a fraction of the texel's neutral hemoglobin.
pub const RATIO_LOW: f32 = 0.5;
/// Upper node of the quadratic, as a multiple of the texel's neutral hemoglobin.
pub const RATIO_HIGH: f32 = 2.0;
/// Neutral hemoglobin below which the nodes are placed as if it were this (volume fraction): a
/// bloodless texel (a gutter, a painted-out area) still gets a response a flush can move.
pub const H_FLOOR: f32 = 0.002;
/// Share of a set's texels whose base colour the appearance may miss by more than one 8-bit
/// level before the set is refused as made by another appearance (half-float bio channels
/// shift a few texels across a rounding boundary).
pub const MAX_MISMATCH_SHARE: f64 = 0.01;

/// The files of a texture set the composition reads.
pub mod files {
    /// The base colour the frames start from (8-bit sRGB).
    pub const BASE_COLOR: &str = "base_color.png";
    /// Melanin and pheomelanin (f32).
    pub const MELANIN: &str = "melanin.exr";
    /// Hemoglobin and oxygenation (f32).
    pub const HEMOGLOBIN: &str = "hemoglobin.exr";
    /// Every bio channel (half float): the layer thicknesses and the hair painted over the skin.
    pub const BIO: &str = "bio.exr";
    /// The run report, naming the appearance.
    pub const REPORT: &str = "report.json";
}

/// A texel's response: (d1, d2) per channel, linear sRGB per unit of x = ∛H − ∛H_n.
pub type Response = ([f32; 3], [f32; 3]);

/// The quadratic through (0, 0), (x1, y1) and (x2, y2), as (d1, d2) with y = d1·x + d2·x².
#[inline]
pub fn quadratic_through(x1: f32, y1: f32, x2: f32, y2: f32) -> (f32, f32) {
    let d2 = (y2 / x2 - y1 / x1) / (x2 - x1);
    (y1 / x1 - d2 * x1, d2)
}

/// The blood values at which the response is sampled for neutral hemoglobin `hn`, and their x.
#[inline]
pub fn nodes(hn: f32) -> [(f32, f32); 2] {
    let hf = hn.max(H_FLOOR);
    let c = hn.max(0.0).cbrt();
    [RATIO_LOW * hf, RATIO_HIGH * hf].map(|b| (b, b.cbrt() - c))
}

/// The response of one texel from the appearance's albedo at H_n (`a0`) and at the two
/// [`nodes`] (`a`), for a texel whose share `hair` is hair (its colour does not change).
#[inline]
pub fn response_of(hn: f32, a0: [f32; 3], a: [[f32; 3]; 2], hair: f32) -> Response {
    let [(_, x1), (_, x2)] = nodes(hn);
    let skin = 1.0 - hair.clamp(0.0, 1.0);
    let mut d1 = [0.0; 3];
    let mut d2 = [0.0; 3];
    for c in 0..3 {
        let (p, q) = quadratic_through(x1, skin * (a[0][c] - a0[c]), x2, skin * (a[1][c] - a0[c]));
        (d1[c], d2[c]) = (p, q);
    }
    (d1, d2)
}

/// Linear colour of a texel of base colour code `base` under x = ∛H − ∛H_n.
#[inline]
pub fn compose(base: [u8; 3], (d1, d2): &Response, x: f32) -> [f32; 3] {
    std::array::from_fn(|c| srgb8_decode(base[c]) + (d1[c] + d2[c] * x) * x)
}

/// x = ∛H − ∛H_n, exactly 0 when the two are equal.
#[inline]
pub fn cube_root_step(h: f32, hn: f32) -> f32 {
    if h == hn {
        0.0
    } else {
        h.max(0.0).cbrt() - hn.max(0.0).cbrt()
    }
}

/// A texture set's base colour and each texel's response to hemoglobin.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinResponse {
    width: usize,
    height: usize,
    /// base_color.png's codes, rows from the top.
    pub base: Vec<[u8; 3]>,
    /// d1 per channel (linear sRGB per unit of x).
    pub d1: [Map; 3],
    /// d2 per channel.
    pub d2: [Map; 3],
    /// Name of the appearance that made the set and the response.
    pub appearance: String,
}

/// A set's maps, one entry per texel.
struct SetMaps {
    width: usize,
    height: usize,
    base: Vec<[u8; 3]>,
    tissue: Vec<BioTexel>,
    /// The hair's colour (linear) and coverage painted over the skin.
    hair: Vec<[f32; 4]>,
}

fn channel<'a>(path: &Path, chans: &'a [(String, Map)], name: &str) -> Result<&'a Map> {
    chans
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, m)| m)
        .ok_or_else(|| RigError::File {
            path: path.to_path_buf(),
            detail: format!(
                "no channel '{name}'; found {:?} (expected a texture set from derma skin)",
                chans.iter().map(|c| c.0.as_str()).collect::<Vec<_>>()
            ),
        })
}

fn read_set(dir: &Path) -> Result<SetMaps> {
    let bp = dir.join(files::BASE_COLOR);
    let img = derma_core::image_io::read_rgb(&bp)?;
    let (w, h) = (img.channels[0].width(), img.channels[0].height());
    let code = |v: f32| (v * 255.0).round().clamp(0.0, 255.0) as u8;
    let base: Vec<[u8; 3]> = (0..w * h)
        .map(|i| std::array::from_fn(|c| code(img.channels[c].data()[i])))
        .collect();
    let mut maps: Vec<(std::path::PathBuf, Vec<(String, Map)>)> = Vec::new();
    for f in [files::MELANIN, files::HEMOGLOBIN, files::BIO] {
        let p = dir.join(f);
        let c = read_exr_channels(&p)?;
        for (n, m) in &c {
            if (m.width(), m.height()) != (w, h) {
                return Err(RigError::File {
                    path: p.clone(),
                    detail: format!(
                        "channel '{n}' is {}×{}; {} is {w}×{h}",
                        m.width(),
                        m.height(),
                        files::BASE_COLOR
                    ),
                });
            }
        }
        maps.push((p, c));
    }
    let (mp, mc) = (&maps[0].0, &maps[0].1);
    let (hp, hc) = (&maps[1].0, &maps[1].1);
    let (bp, bc) = (&maps[2].0, &maps[2].1);
    fn plane<'a>(p: &Path, c: &'a [(String, Map)], n: &str) -> Result<&'a [f32]> {
        channel(p, c, n).map(Map::data)
    }
    let mel = plane(mp, mc, names::MELANIN)?;
    let pheo = plane(mp, mc, names::PHEOMELANIN)?;
    let blood = plane(hp, hc, names::HEMOGLOBIN)?;
    let oxy = plane(hp, hc, names::OXYGENATION)?;
    let sc = plane(bp, bc, names::STRATUM_CORNEUM_UM)?;
    let epi = plane(bp, bc, names::EPIDERMIS_UM)?;
    let extra: [&[f32]; 4] = [
        plane(bp, bc, "extra.R")?,
        plane(bp, bc, "extra.G")?,
        plane(bp, bc, "extra.B")?,
        plane(bp, bc, "extra.A")?,
    ];
    let tissue = (0..w * h)
        .map(|i| BioTexel {
            melanin: mel[i],
            pheomelanin: pheo[i],
            blood: blood[i],
            oxygenation: oxy[i],
            stratum_corneum_um: sc[i],
            epidermis_um: epi[i],
        })
        .collect();
    let hair = (0..w * h)
        .map(|i| std::array::from_fn(|c| extra[c][i]))
        .collect();
    Ok(SetMaps {
        width: w,
        height: h,
        base,
        tissue,
        hair,
    })
}

/// The appearance that made the set in `dir`: the one its report.json names, with `table` the
/// match table it was made with when not the built-in one.
pub fn appearance_of_set(dir: &Path, table: Option<&Path>) -> Result<Box<dyn Appearance>> {
    let rp = dir.join(files::REPORT);
    let bad = |detail: String| RigError::File {
        path: rp.clone(),
        detail,
    };
    let text = std::fs::read_to_string(&rp).map_err(|e| {
        bad(format!(
            "cannot read ({e}); is '{}' a texture set from derma skin?",
            dir.display()
        ))
    })?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON ({e})")))?;
    let name = v
        .get("appearance")
        .and_then(|a| a.as_str())
        .ok_or_else(|| bad("no \"appearance\" field".into()))?;
    match (name, table) {
        ("match-table", None) => Ok(Box::new(derma_shading::TableAppearance::builtin())),
        ("match-table", Some(p)) => Ok(Box::new(derma_shading::TableAppearance::read(p)?)),
        ("spectral-km", None) => Ok(Box::new(derma_shading::SpectralKubelkaMunk::default())),
        ("spectral-km", Some(p)) => Err(invalid(
            "match table",
            format!(
                "'{}' given, but the set's appearance is the analytic spectral-km",
                p.display()
            ),
        )),
        (other, _) => Err(bad(format!(
            "appearance '{other}'; expected match-table or spectral-km"
        ))),
    }
}

/// Texels shaded per parallel task.
const CHUNK: usize = 4096;

impl SkinResponse {
    /// The response of the texture set in `dir` under `appearance` (the one that made it; see
    /// [`appearance_of_set`]). Refused when the appearance does not reproduce the set's base
    /// colour (more than [`MAX_MISMATCH_SHARE`] of the texels off by over one level).
    pub fn of_set(dir: &Path, appearance: &dyn Appearance) -> Result<Self> {
        let s = read_set(dir)?;
        let n = s.width * s.height;
        let mut d1 = vec![[0.0f32; 3]; n];
        let mut d2 = vec![[0.0f32; 3]; n];
        let off: usize = d1
            .par_chunks_mut(CHUNK)
            .zip(d2.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(k, (o1, o2))| {
                let first = k * CHUNK;
                let len = o1.len();
                let t = &s.tissue[first..first + len];
                let mut bio = Vec::with_capacity(3 * len);
                bio.extend_from_slice(t);
                for node in 0..2 {
                    bio.extend(t.iter().map(|b| BioTexel {
                        blood: nodes(b.blood)[node].0,
                        ..*b
                    }));
                }
                let mut shade = vec![([0.0f32; 3], None); 3 * len];
                appearance.shade_batch(&bio, &mut shade);
                let mut off = 0;
                for j in 0..len {
                    let i = first + j;
                    let a0 = shade[j].0;
                    let hair = s.hair[i];
                    let ea = hair[3].clamp(0.0, 1.0);
                    let again: [u8; 3] =
                        std::array::from_fn(|c| srgb8(a0[c] + (hair[c] - a0[c]) * ea));
                    if (0..3).any(|c| again[c].abs_diff(s.base[i][c]) > 1) {
                        off += 1;
                    }
                    let r =
                        response_of(t[j].blood, a0, [shade[len + j].0, shade[2 * len + j].0], ea);
                    (o1[j], o2[j]) = r;
                }
                off
            })
            .sum();
        let share = off as f64 / n.max(1) as f64;
        if share > MAX_MISMATCH_SHARE {
            return Err(RigError::File {
                path: dir.join(files::BASE_COLOR),
                detail: format!(
                    "the '{}' appearance of the set's bio maps differs from it by more than one level on {:.1} % of the texels; was the set made with another match table?",
                    appearance.name(),
                    100.0 * share
                ),
            });
        }
        let planes = |v: &[[f32; 3]]| Map::planes(s.width, s.height, |i| v[i]);
        Ok(Self {
            width: s.width,
            height: s.height,
            base: s.base,
            d1: planes(&d1),
            d2: planes(&d2),
            appearance: appearance.name().into(),
        })
    }

    /// A response from its parts (as a rig directory stores them).
    pub fn from_parts(
        base: Vec<[u8; 3]>,
        d1: [Map; 3],
        d2: [Map; 3],
        appearance: &str,
    ) -> Result<Self> {
        let (w, h) = (d1[0].width(), d1[0].height());
        if base.len() != w * h
            || d1
                .iter()
                .chain(&d2)
                .any(|m| (m.width(), m.height()) != (w, h))
        {
            return Err(invalid(
                "skin response",
                format!("its maps differ in size from the {w}×{h} of d1"),
            ));
        }
        Ok(Self {
            width: w,
            height: h,
            base,
            d1,
            d2,
            appearance: appearance.into(),
        })
    }

    /// (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The response of texel `i`.
    #[inline]
    pub fn at(&self, i: usize) -> Response {
        (
            std::array::from_fn(|c| self.d1[c].data()[i]),
            std::array::from_fn(|c| self.d2[c].data()[i]),
        )
    }

    /// Linear colour of a frame whose hemoglobin is `h`, the neutral's being `hn` (both the
    /// rig's evaluation, so a neutral frame gives x = 0 and the base colour exactly).
    pub fn color(&self, h: &Map, hn: &Map) -> Result<[Map; 3]> {
        for (what, m) in [("hemoglobin map", h), ("neutral hemoglobin map", hn)] {
            if (m.width(), m.height()) != self.size() {
                return Err(invalid(
                    what,
                    format!(
                        "{}×{}; the skin response is {}×{}",
                        m.width(),
                        m.height(),
                        self.width,
                        self.height
                    ),
                ));
            }
        }
        let rgb: Vec<[f32; 3]> = (0..self.width * self.height)
            .into_par_iter()
            .map(|i| {
                let x = cube_root_step(h.data()[i], hn.data()[i]);
                compose(self.base[i], &self.at(i), x).map(|v| v.clamp(0.0, 1.0))
            })
            .collect();
        Ok(Map::planes(self.width, self.height, |i| rgb[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quadratic_passes_through_its_nodes() {
        let (d1, d2) = quadratic_through(-0.1, -0.03, 0.2, 0.05);
        assert!((d1 * -0.1 + d2 * 0.01 + 0.03).abs() < 1e-7);
        assert!((d1 * 0.2 + d2 * 0.04 - 0.05).abs() < 1e-7);
        // A straight line stays one.
        let (d1, d2) = quadratic_through(-0.1, -0.2, 0.3, 0.6);
        assert!((d1 - 2.0).abs() < 1e-5 && d2.abs() < 1e-4, "{d1} {d2}");
    }

    #[test]
    fn nodes_straddle_the_neutral_and_respect_the_floor() {
        let [(b1, x1), (b2, x2)] = nodes(0.04);
        assert!((b1 - 0.02).abs() < 1e-7 && (b2 - 0.08).abs() < 1e-7);
        assert!(x1 < 0.0 && x2 > 0.0);
        let [(b1, _), (b2, x2)] = nodes(0.0);
        assert_eq!((b1, b2), (RATIO_LOW * H_FLOOR, RATIO_HIGH * H_FLOOR));
        assert!(x2 > 0.0);
    }

    #[test]
    fn a_neutral_texel_keeps_its_base_code_and_hair_does_not_change() {
        // x = 0 gives the decoded base colour, which encodes back to the same code, every code.
        let r = ([0.3, -0.2, 0.1], [1.0, 2.0, -3.0]);
        for code in 0..=255u8 {
            let c = compose([code; 3], &r, cube_root_step(0.031, 0.031));
            assert_eq!(c.map(srgb8), [code; 3]);
        }
        // Fully hair: no response.
        let (d1, d2) = response_of(0.03, [0.5; 3], [[0.6; 3], [0.3; 3]], 1.0);
        assert_eq!((d1, d2), ([0.0; 3], [0.0; 3]));
        // Half hair: half the response.
        let full = response_of(0.03, [0.5; 3], [[0.6; 3], [0.3; 3]], 0.0);
        let half = response_of(0.03, [0.5; 3], [[0.6; 3], [0.3; 3]], 0.5);
        assert!((half.0[0] - 0.5 * full.0[0]).abs() < 1e-6);
    }

    #[test]
    fn the_response_follows_the_analytic_appearance_between_its_nodes() {
        // Against re-shading exactly: within 1.5 8-bit levels from half to twice the neutral
        // blood, for fair to dark skin (the cube-root axis keeps it nearly linear).
        let a = derma_shading::SpectralKubelkaMunk::default();
        for &m in &[0.01f32, 0.05, 0.2] {
            for &hn in &[0.005f32, 0.02, 0.06] {
                let t = |b: f32| BioTexel {
                    melanin: m,
                    pheomelanin: 0.3,
                    blood: b,
                    oxygenation: 0.7,
                    stratum_corneum_um: 15.0,
                    epidermis_um: 80.0,
                };
                let a0 = a.albedo(&t(hn));
                let [(b1, _), (b2, _)] = nodes(hn);
                let r = response_of(hn, a0, [a.albedo(&t(b1)), a.albedo(&t(b2))], 0.0);
                let base = a0.map(srgb8);
                for k in 0..=20 {
                    let h = hn * (0.5 + 1.5 * k as f32 / 20.0);
                    let exact = a.albedo(&t(h)).map(srgb8);
                    let got = compose(base, &r, cube_root_step(h, hn)).map(srgb8);
                    for c in 0..3 {
                        assert!(
                            exact[c].abs_diff(got[c]) <= 2,
                            "m {m} hn {hn} h {h}: {exact:?} vs {got:?}"
                        );
                    }
                }
            }
        }
    }
}
