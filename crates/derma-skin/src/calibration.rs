//! The person applied to a config (thesis §5.3.1's baseline, set by skin tone and age): wrinkles
//! scaled by age, and the baseline melanin calibrated by bisection so the cheeks and forehead
//! land on the person's ITA° (Chardon et al. 1991) under the chosen appearance.

use crate::config::SkinConfig;
use crate::regional::{age_factor, gains, ita_deg, NEUTRAL};
use derma_head::regions;

/// The config with the person applied: wrinkles scaled by age, and (with
/// `person.calibrate_melanin`) the baseline melanin range shifted so that the mean cheek and
/// forehead texel has the person's ITA° under `appearance`. Returns the config and the
/// calibrated mean melanin fraction, if calibrated.
pub fn apply_person(
    cfg: &SkinConfig,
    appearance: &dyn derma_shading::Appearance,
    regional_gains: bool,
) -> crate::Result<(SkinConfig, Option<f32>)> {
    let mut out = cfg.clone();
    let p = &cfg.person;
    let age = age_factor(p.age_years);
    out.wrinkle.density_per_cm2 *= age;
    out.wrinkle.depth_mm.min *= age.sqrt();
    out.wrinkle.depth_mm.max *= age.sqrt();
    out.relief.depth_mm = out.relief.depth_mm.map(|d| d * age.sqrt());
    // A measured melanin map (baseline.melanin_map) is the person's own: nothing to calibrate.
    if !p.calibrate_melanin || !cfg.baseline.melanin_map.trim().is_empty() {
        return Ok((out, None));
    }
    let b = &cfg.baseline;
    let mean = b.mean_tissue();
    // The cheeks and the forehead, each under its own regional gains (`gains`, or none
    // without regional gains); the ITA of their mean colour is what is calibrated.
    let sample: Vec<[f32; 4]> = ["cheeks", "forehead"]
        .iter()
        .map(|name| {
            if !regional_gains {
                return NEUTRAL;
            }
            let mut w = [0.0; regions::REGIONS.len()];
            w[regions::index(name).expect("a region of derma-head")] = 1.0;
            gains(&w)
        })
        .collect();
    let texel = |melanin: f32, g: [f32; 4]| derma_shading::BioTexel {
        melanin: melanin * g[1],
        blood: (mean.blood * g[0]).min(1.0),
        oxygenation: (mean.oxygenation + g[2]).clamp(0.0, 1.0),
        epidermis_um: mean.epidermis_um * g[3],
        ..mean
    };
    let ita_of = |m: f32| {
        let mut lab = [0.0; 3];
        for &r in &sample {
            let rgb = appearance.albedo(&texel(m, r)).map(f64::from);
            let l = derma_core::color::xyz_to_lab(derma_core::color::linear_srgb_to_xyz(rgb));
            for k in 0..3 {
                lab[k] += l[k] / sample.len() as f64;
            }
        }
        ita_deg(lab)
    };
    // ITA falls monotonically as melanin rises; bisect on [0.001, 0.6].
    let (mut lo, mut hi) = (0.001f32, 0.6f32);
    let target = p.ita_deg as f64;
    if ita_of(lo) < target || ita_of(hi) > target {
        return Err(crate::SkinError::Key {
            key: "person.ita_deg".into(),
            detail: format!(
                "{target}° is outside what melanin 0.001–0.6 reaches under the '{}' appearance ({:.1}° to {:.1}°)",
                appearance.name(),
                ita_of(hi),
                ita_of(lo)
            ),
        });
    }
    for _ in 0..40 {
        let m = 0.5 * (lo + hi);
        if ita_of(m) > target {
            lo = m;
        } else {
            hi = m;
        }
    }
    let m = 0.5 * (lo + hi);
    // Shift the range so its mean under the baseline noise is m, keeping its width.
    let half = 0.5 * b.phi * (b.melanin.max - b.melanin.min);
    let shift = m - (b.melanin.min + half);
    out.baseline.melanin.min = (b.melanin.min + shift).max(0.0);
    out.baseline.melanin.max = (b.melanin.max + shift).max(out.baseline.melanin.min);
    Ok((out, Some(m)))
}
