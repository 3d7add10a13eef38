//! The appearance basis (Jimenez et al. 2010 §4.2, eq. 4–5): the mean-free neutral map
//! H_0 = H_n − μ_n at full resolution, and per target a bias μ_i and a scale σ_i / σ_n, stored at
//! a low resolution (§6: 256²) and upsampled bilinearly when the rig is evaluated.
//!
//! H_0 is formed against the *upsampled* μ_n, so that evaluating the neutral pose (w_0 = 1)
//! returns H_n exactly. σ_n → 0 (flat, e.g. painted or clipped regions) is guarded by a floor:
//! scale_i = σ_i / max(σ_n, ε). Where σ_n ≥ ε this is the paper's ratio exactly; where the
//! neutral is flat its deviations |H_0| ≲ σ_n < ε are scaled by at most σ_i / ε, so the output
//! stays within σ_i·σ_n/ε of the target mean: no spikes, no division by zero.

use crate::error::{invalid, Result, RigError};
use crate::expression::{self, Expression};
use crate::local_stats::stats_on_grid;
use crate::upsample::Upsampler;
use derma_core::Map;
use rayon::prelude::*;

/// Default basis resolution (Jimenez et al. 2010 §6: scale and bias textures at 256 × 256).
pub const DEFAULT_BASIS_SIZE: usize = 256;

/// Default σ floor: this fraction of the neutral map's RMS local standard deviation. Authored:
/// 5 % leaves every texel whose neighbourhood has a twentieth of the typical texture exact.
pub const DEFAULT_SIGMA_FLOOR: f32 = 0.05;

/// Settings of a basis build.
#[derive(Clone, Debug, PartialEq)]
pub struct BasisOptions {
    /// Disk radius r in texels of the neutral map.
    pub radius: f64,
    /// Basis resolution (clamped to the map's size; must divide it).
    pub basis_size: (usize, usize),
    /// ε as a fraction of the RMS of σ_n over the map.
    pub sigma_floor: f32,
}

impl BasisOptions {
    /// Options for disk radius `radius` (texels) with the default basis size and σ floor.
    pub fn new(radius: f64) -> Self {
        Self {
            radius,
            basis_size: (DEFAULT_BASIS_SIZE, DEFAULT_BASIS_SIZE),
            sigma_floor: DEFAULT_SIGMA_FLOOR,
        }
    }
}

/// Where a target's statistics come from.
pub enum TargetSource<'a> {
    /// A measured or painted hemoglobin map, aligned with the neutral.
    Map(&'a Map),
    /// A built-in library entry, applied to the neutral's own statistics (the built-in head's UV layout).
    Builtin(&'static Expression),
}

/// A target to build.
pub struct TargetSpec<'a> {
    /// The target's name (letters, digits, `_`, `-`).
    pub name: String,
    /// Where its statistics come from.
    pub source: TargetSource<'a>,
    /// Global hemoglobin scale suggested at full weight (1 when not given).
    pub global_scale: Option<f32>,
}

/// One target of the basis, at basis resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// The target's name.
    pub name: String,
    /// bias_i = μ_i.
    pub bias: Map,
    /// σ_i (kept for appearance transfer).
    pub sigma: Map,
    /// scale_i = σ_i / max(σ_n, ε).
    pub scale: Map,
    /// Global hemoglobin scale suggested at full weight.
    pub global_scale: f32,
    /// "map" or "builtin:NAME".
    pub source: String,
}

/// A built rig: everything eq. 6 needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    /// r in texels of the full-resolution maps.
    pub radius: f64,
    /// H_0 = H_n − up(μ_n), full resolution.
    pub h0: Map,
    /// bias_0 = μ_n at basis resolution.
    pub neutral_mean: Map,
    /// σ_n at basis resolution.
    pub neutral_sigma: Map,
    /// ε (absolute, volume fraction).
    pub sigma_floor: f32,
    /// The targets, in weight order.
    pub targets: Vec<Target>,
    /// Static melanin C_m at full resolution, when given (melanin does not change with
    /// expression: Jimenez et al. 2010 §1).
    pub melanin: Option<Map>,
    /// The texture set's base colour and its response to hemoglobin, when the rig was built from
    /// a set: frames then keep the set's skin ([`crate::skin_response`]); without it they are
    /// the LUT's colour of (C_m, H) (eq. 7).
    pub skin: Option<crate::skin_response::SkinResponse>,
}

/// Validates a target name: letters, digits, `_` and `-`, not "neutral".
pub fn check_name(name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if !ok || name == "neutral" {
        return Err(invalid(
            "target name",
            format!("'{name}': expected 1–64 letters, digits, '_' or '-', and not 'neutral'"),
        ));
    }
    Ok(())
}

fn same_size(what: &str, m: &Map, w: usize, h: usize) -> Result<()> {
    if (m.width(), m.height()) != (w, h) {
        return Err(RigError::Size {
            what: what.into(),
            got_w: m.width(),
            got_h: m.height(),
            want_w: w,
            want_h: h,
        });
    }
    Ok(())
}

/// Checks that a hemoglobin or melanin map holds volume fractions.
pub fn check_fractions(what: &str, m: &Map) -> Result<()> {
    // Both cores over chunks, and still the first offending texel (first chunk, then first
    // texel in it), so the message is the same whatever the thread count.
    let ok = |v: &f32| v.is_finite() && (0.0..=1.0).contains(v);
    const CHUNK: usize = 1 << 16;
    let bad = m
        .data()
        .par_chunks(CHUNK)
        .position_first(|c| !c.iter().all(ok))
        .and_then(|k| {
            let c = &m.data()[k * CHUNK..];
            c.iter()
                .take(CHUNK)
                .position(|v| !ok(v))
                .map(|j| k * CHUNK + j)
        });
    if let Some(i) = bad {
        let v = m.data()[i];
        return Err(invalid(
            what,
            format!(
                "texel ({}, {}) is {v}; expected a volume fraction in [0, 1]",
                i % m.width(),
                i / m.width()
            ),
        ));
    }
    Ok(())
}

/// The basis grid for a map: `want` clamped to the map, and checked to divide it.
pub fn basis_grid(w: usize, h: usize, want: (usize, usize)) -> Result<(usize, usize)> {
    let g = (want.0.min(w).max(1), want.1.min(h).max(1));
    if !w.is_multiple_of(g.0) || !h.is_multiple_of(g.1) {
        return Err(invalid(
            "basis size",
            format!(
                "{}×{} does not divide the {w}×{h} map; pick a size that does (e.g. a power of two for power-of-two maps)",
                g.0, g.1
            ),
        ));
    }
    Ok(g)
}

/// ε from the neutral's σ_n map: `fraction` × RMS(σ_n), never below 1e-7.
fn floor_of(sigma_n: &Map, fraction: f32) -> f32 {
    let n = sigma_n.data().len().max(1) as f64;
    let rms = (sigma_n
        .data()
        .iter()
        .map(|&s| (s as f64).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    ((fraction as f64 * rms) as f32).max(1e-7)
}

/// scale = σ_i / max(σ_n, ε), texel by texel.
pub fn scale_map(sigma_i: &Map, sigma_n: &Map, eps: f32) -> Map {
    sigma_i.zip_map(sigma_n, |si, sn| si / sn.max(eps))
}

/// H_0 = H_n − up(μ_n).
fn mean_free(neutral: &Map, mean_n: &Map) -> Map {
    let (w, h) = (neutral.width(), neutral.height());
    let up = Upsampler::new((mean_n.width(), mean_n.height()), (w, h));
    let wide = up.widen(mean_n.data());
    Map::from_par_rows(w, h, |y, row| {
        up.row_of_wide(&wide, y, row);
        for (o, &hn) in row.iter_mut().zip(&neutral.data()[y * w..(y + 1) * w]) {
            *o = hn - *o;
        }
    })
}

impl Rig {
    /// Checks that `melanin` has the rig's full resolution.
    pub fn check_melanin(&self, melanin: &Map) -> Result<()> {
        let (w, h) = self.size();
        if (melanin.width(), melanin.height()) != (w, h) {
            return Err(invalid(
                "melanin map",
                format!(
                    "{}×{}; expected the rig's {w}×{h}",
                    melanin.width(),
                    melanin.height()
                ),
            ));
        }
        Ok(())
    }

    /// Builds the basis of `neutral` (dermal hemoglobin C_hd, volume fraction) for `targets`.
    /// `mask` (optional) weights texels in the statistics (0 = not skin).
    pub fn build(
        neutral: &Map,
        mask: Option<&Map>,
        melanin: Option<Map>,
        targets: &[TargetSpec],
        opts: &BasisOptions,
    ) -> Result<Rig> {
        Self::build_placed(
            neutral,
            mask,
            melanin,
            targets,
            opts,
            &expression::Placement::Builtin,
        )
    }

    /// As [`Rig::build`], built-in library entries placed by `placement` (a user's mesh in its
    /// own UV layout) instead of on the built-in head's layout.
    pub fn build_placed(
        neutral: &Map,
        mask: Option<&Map>,
        melanin: Option<Map>,
        targets: &[TargetSpec],
        opts: &BasisOptions,
        placement: &expression::Placement,
    ) -> Result<Rig> {
        let (w, h) = (neutral.width(), neutral.height());
        check_fractions("neutral hemoglobin map", neutral)?;
        if let Some(m) = &melanin {
            same_size("melanin", m, w, h)?;
            check_fractions("melanin map", m)?;
        }
        let (gw, gh) = basis_grid(w, h, opts.basis_size)?;
        if !(opts.sigma_floor.is_finite() && opts.sigma_floor >= 0.0) {
            return Err(invalid(
                "sigma floor",
                format!("{}; expected a fraction ≥ 0", opts.sigma_floor),
            ));
        }
        let mut names = std::collections::HashSet::new();
        for t in targets {
            check_name(&t.name)?;
            if !names.insert(t.name.as_str()) {
                return Err(invalid("target name", format!("'{}' given twice", t.name)));
            }
            if let TargetSource::Map(m) = &t.source {
                same_size(&format!("target '{}'", t.name), m, w, h)?;
                check_fractions(&format!("target '{}'", t.name), m)?;
            }
            if let Some(g) = t.global_scale {
                if !(g.is_finite() && g > 0.0) {
                    return Err(invalid(
                        format!("global scale of '{}'", t.name),
                        format!("{g}; expected a positive factor"),
                    ));
                }
            }
        }
        let neutral_stats = stats_on_grid(neutral, mask, opts.radius, gw, gh)?;
        let eps = floor_of(&neutral_stats.sigma, opts.sigma_floor);
        let needs_head = targets
            .iter()
            .any(|t| matches!(t.source, TargetSource::Builtin(_)));
        let points = needs_head.then(|| placement.points(gw, gh));
        let built: Vec<Target> = targets
            .par_iter()
            .map(|t| -> Result<Target> {
                let (bias, sigma, source, g) = match &t.source {
                    TargetSource::Map(m) => {
                        let s = stats_on_grid(m, mask, opts.radius, gw, gh)?;
                        (s.mean, s.sigma, "map".to_string(), 1.0)
                    }
                    TargetSource::Builtin(e) => {
                        let pts = points.as_ref().expect("computed when a builtin is present");
                        let (gm, gs) = expression::gain_maps(e, pts, placement.regions(), gw, gh);
                        let mul = |a: &Map, b: &Map| a.zip_map(b, |x, y| x * y);
                        (
                            mul(&neutral_stats.mean, &gm),
                            mul(&neutral_stats.sigma, &gs),
                            format!("builtin:{}", e.name),
                            e.global_scale,
                        )
                    }
                };
                Ok(Target {
                    name: t.name.clone(),
                    scale: scale_map(&sigma, &neutral_stats.sigma, eps),
                    bias,
                    sigma,
                    global_scale: t.global_scale.unwrap_or(g),
                    source,
                })
            })
            .collect::<Result<_>>()?;
        Ok(Rig {
            radius: opts.radius,
            h0: mean_free(neutral, &neutral_stats.mean),
            neutral_mean: neutral_stats.mean,
            neutral_sigma: neutral_stats.sigma,
            sigma_floor: eps,
            targets: built,
            melanin,
            skin: None,
        })
    }

    /// Full-resolution map size.
    pub fn size(&self) -> (usize, usize) {
        (self.h0.width(), self.h0.height())
    }

    /// Basis resolution.
    pub fn basis_size(&self) -> (usize, usize) {
        (self.neutral_mean.width(), self.neutral_mean.height())
    }

    /// The neutral map H_n = up(μ_n) + H_0 (what the rig was built on, or transferred to).
    pub fn neutral(&self) -> Map {
        let (w, h) = self.size();
        let up = Upsampler::new(self.basis_size(), (w, h)).apply(&self.neutral_mean);
        up.zip_map(&self.h0, |a, b| a + b)
    }

    /// Index of target `name`.
    pub fn target_index(&self, name: &str) -> Option<usize> {
        self.targets.iter().position(|t| t.name == name)
    }

    /// Appearance transfer (§4.2, §7): the rig applied to another character's neutral map.
    /// The new H_0 comes from `neutral`'s own local statistics (radius scaled with the map's
    /// width), so its fine structure is kept. [`TransferMode::Absolute`] keeps the targets'
    /// statistics (eq. 6 as written: each target's local mean and spread are taken over);
    /// [`TransferMode::Relative`] carries each target's change relative to the source neutral
    /// (μ_i/μ_n and σ_i/σ_n) over to the new character's own statistics.
    pub fn transfer(
        &self,
        neutral: &Map,
        mask: Option<&Map>,
        melanin: Option<Map>,
        mode: TransferMode,
        sigma_floor_fraction: f32,
    ) -> Result<Rig> {
        check_fractions("neutral hemoglobin map", neutral)?;
        let (w, h) = (neutral.width(), neutral.height());
        if let Some(m) = &melanin {
            same_size("melanin", m, w, h)?;
            check_fractions("melanin map", m)?;
        }
        let (gw, gh) = self.basis_size();
        if w % gw != 0 || h % gh != 0 {
            return Err(invalid(
                "neutral map for transfer",
                format!("{w}×{h} is not a multiple of the rig's {gw}×{gh} basis"),
            ));
        }
        let radius = self.radius * w as f64 / self.size().0 as f64;
        let st = stats_on_grid(neutral, mask, radius, gw, gh)?;
        let eps = floor_of(&st.sigma, sigma_floor_fraction);
        let targets = self
            .targets
            .iter()
            .map(|t| {
                let (bias, sigma) = match mode {
                    TransferMode::Absolute => (t.bias.clone(), t.sigma.clone()),
                    TransferMode::Relative => {
                        let ratio = |num: f32, den: f32| if den > 1e-7 { num / den } else { 1.0 };
                        let b = Map::from_fn(gw, gh, |i| {
                            st.mean.data()[i] * ratio(t.bias.data()[i], self.neutral_mean.data()[i])
                        });
                        let s = Map::from_fn(gw, gh, |i| {
                            st.sigma.data()[i] * t.sigma.data()[i]
                                / self.neutral_sigma.data()[i].max(self.sigma_floor)
                        });
                        (b, s)
                    }
                };
                Target {
                    name: t.name.clone(),
                    scale: scale_map(&sigma, &st.sigma, eps),
                    bias,
                    sigma,
                    global_scale: t.global_scale,
                    source: t.source.clone(),
                }
            })
            .collect();
        Ok(Rig {
            radius,
            h0: mean_free(neutral, &st.mean),
            neutral_mean: st.mean,
            neutral_sigma: st.sigma,
            sigma_floor: eps,
            targets,
            melanin,
            skin: None,
        })
    }
}

/// How [`Rig::transfer`] carries targets to a new character.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransferMode {
    /// Keep the targets' local statistics (eq. 6 as written).
    Absolute,
    /// Carry each target's change relative to the source neutral over to the new character.
    Relative,
}
