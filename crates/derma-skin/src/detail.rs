//! Exemplar micro-detail (`[detail]`): a tileable tile grown from skin exemplars by derma-synth
//! (Shen et al. 2014, two-pass synthesis), high-passed below the procedural features' scale and
//! blended into height (and so the normal map) and, through melanin, into the base colour.
//!
//! The height exemplar's fine relief (zero mean, unit RMS after the high-pass) is added as
//! `height_mm · d`. The colour exemplar's fine luminance contrast, L_hp / L_lp, scales melanin:
//! melanin · (1 + albedo_contrast · (−L_hp / L_lp)) — darker detail, more melanin — so the detail
//! goes through the same optics as everything else and bio.exr, the base colour and the rig's
//! colour stay one model. Both exemplars (registered, same size) are synthesised jointly.

use crate::config::DetailConfig;
use crate::features::BioSample;
use crate::SkinError;
use derma_core::color::luminance;
use derma_core::gpu::Device;
use derma_core::image_io::read_rgb;
use derma_core::progress::Progress;
use derma_core::Map;
use derma_synth::{Synthesizer, Texture};
use rayon::prelude::*;
use std::path::Path;

/// The high-passed detail tile: per texel, height detail (unit RMS) and relative luminance
/// contrast (L_hp / L_lp), each present when its exemplar was given.
pub struct DetailTile {
    /// Side of the tile in texels.
    pub size: usize,
    /// High-passed height detail, unit RMS (with a height exemplar).
    pub height: Option<Map>,
    /// Relative luminance contrast L_hp / L_lp (with a colour exemplar).
    pub contrast: Option<Map>,
}

fn config_error(detail: String) -> SkinError {
    SkinError::Key {
        key: "detail".into(),
        detail,
    }
}

/// Loads the exemplars, synthesises the tile on `device` (identical on every device) and
/// high-passes it.
pub fn build(
    cfg: &DetailConfig,
    height: Option<&Path>,
    albedo: Option<&Path>,
    seed: u64,
    device: Device,
    progress: &dyn Progress,
) -> Result<DetailTile, SkinError> {
    let mut maps: Vec<Map> = Vec::new();
    let mut size: Option<(usize, usize, std::path::PathBuf)> = None;
    let mut add = |path: &Path, color: bool, maps: &mut Vec<Map>| -> Result<usize, SkinError> {
        let img = read_rgb(path)?;
        let (w, h) = (img.channels[0].width(), img.channels[0].height());
        if let Some((w0, h0, p0)) = &size {
            let (w0, h0) = (*w0, *h0);
            if (w, h) != (w0, h0) {
                return Err(config_error(format!(
                    "the exemplars must be registered: '{}' is {w}×{h}, '{}' is {w0}×{h0}",
                    path.display(),
                    p0.display()
                )));
            }
        } else {
            size = Some((w, h, path.to_path_buf()));
        }
        let n = if color { 3 } else { 1 };
        maps.extend(img.channels.into_iter().take(n));
        Ok(n)
    };
    let height_channels = height.map(|p| add(p, false, &mut maps)).transpose()?;
    let albedo_channels = albedo.map(|p| add(p, true, &mut maps)).transpose()?;
    if maps.is_empty() {
        return Err(config_error(
            "neither detail.height nor detail.albedo is set".into(),
        ));
    }
    let texture = Texture::from_maps(&maps.iter().collect::<Vec<_>>())
        .map_err(|e| config_error(e.to_string()))?;
    let size = cfg.tile_size as usize;
    let tile = Synthesizer::new(texture)
        .size(size, size)
        .patch(cfg.patch as usize)
        .seed(seed)
        .tile(true)
        .device(device)
        .progress(progress)
        .run()
        .map_err(|e| config_error(e.to_string()))?
        .texture;
    let radius = cfg.highpass_texels as usize;
    let mut k = 0;
    let height = height_channels.map(|_| {
        let h = tile.channel(k);
        k += 1;
        let hp = high_pass(h.data(), size, radius);
        let rms = (hp.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / hp.len() as f64).sqrt();
        let scale = if rms > 0.0 { (1.0 / rms) as f32 } else { 0.0 };
        Map::from_fn(size, size, |i| hp[i] * scale)
    });
    let contrast = albedo_channels.map(|_| {
        let lum: Vec<f32> = (0..size * size)
            .map(|i| {
                let t = &tile.data[i * tile.channels + k..];
                luminance([t[0], t[1], t[2]])
            })
            .collect();
        let low = box_blur_wrapped(&lum, size, radius);
        Map::from_fn(size, size, |i| {
            let (l, m) = (lum[i], low[i]);
            if m > 1e-6 {
                (l - m) / m
            } else {
                0.0
            }
        })
    });
    Ok(DetailTile {
        size,
        height,
        contrast,
    })
}

/// `v` minus its box blur of radius `r` (wrapping): the detail below the scale 2r + 1.
fn high_pass(v: &[f32], n: usize, r: usize) -> Vec<f32> {
    let low = box_blur_wrapped(v, n, r);
    v.iter().zip(&low).map(|(a, b)| a - b).collect()
}

/// Separable box blur of an n × n tile with wrap-around, radius r.
fn box_blur_wrapped(v: &[f32], n: usize, r: usize) -> Vec<f32> {
    let pass = |src: &[f32], horizontal: bool| -> Vec<f32> {
        let mut out = vec![0f32; n * n];
        let at = |a: usize, b: usize| if horizontal { b * n + a } else { a * n + b };
        let norm = 1.0 / (2 * r + 1) as f64;
        for b in 0..n {
            for a in 0..n {
                let mut s = 0f64;
                for d in 0..=2 * r {
                    let j = (a + n * (r / n + 1) + d - r) % n;
                    s += src[at(j, b)] as f64;
                }
                out[at(a, b)] = (s * norm) as f32;
            }
        }
        out
    };
    let h = pass(v, true);
    pass(&h, false)
}

impl DetailTile {
    /// Bilinear, wrapping sample of a tile map at tile coordinates (tx, ty) (texel centres at
    /// half-integers).
    fn sample(map: &Map, tx: f32, ty: f32) -> f32 {
        map.sample_texel(tx - 0.5, ty - 0.5, true)
    }

    /// Adds the detail to painted texels of a `width × height` texture (texel centres mapped
    /// to UV, the tile repeated `repeat` times across it).
    pub fn apply(&self, cfg: &DetailConfig, texels: &mut [BioSample], width: usize) {
        self.apply_weighted(cfg, texels, width, &|_, _| 1.0);
    }

    /// [`Self::apply`] with a weight per texel (x, y) in [0, 1]: the detail is scaled by it (the
    /// per-region exemplars blend by their regions' masks).
    pub fn apply_weighted(
        &self,
        cfg: &DetailConfig,
        texels: &mut [BioSample],
        width: usize,
        weight: &(dyn Fn(usize, usize) -> f32 + Sync),
    ) {
        let height = texels.len() / width;
        let scale_x = cfg.repeat * self.size as f32 / width as f32;
        let scale_y = cfg.repeat * self.size as f32 / height as f32;
        texels
            .par_chunks_mut(width)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, t) in row.iter_mut().enumerate() {
                    let w = weight(x, y);
                    if w <= 0.0 {
                        continue;
                    }
                    let (tx, ty) = ((x as f32 + 0.5) * scale_x, (y as f32 + 0.5) * scale_y);
                    if let Some(h) = &self.height {
                        t.height_mm += w * cfg.height_mm * Self::sample(h, tx, ty);
                    }
                    if let Some(c) = &self.contrast {
                        let f = 1.0 - w * cfg.albedo_contrast * Self::sample(c, tx, ty);
                        t.tissue.melanin = (t.tissue.melanin * f.max(0.0)).clamp(0.0, 1.0);
                    }
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_high_pass_removes_a_constant_and_keeps_fine_detail() {
        let n = 16;
        let v: Vec<f32> = (0..n * n)
            .map(|i| 3.0 + if (i % n + i / n) % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let hp = high_pass(&v, n, 2);
        let mean: f32 = hp.iter().sum::<f32>() / hp.len() as f32;
        assert!(mean.abs() < 1e-5, "mean {mean}");
        // A checkerboard survives a radius-2 box blur almost whole (the blur of it is ±1/25).
        assert!((hp[0] - (1.0 - 1.0 / 25.0)).abs() < 1e-5, "{}", hp[0]);
        let flat = high_pass(&vec![2.5; n * n], n, 3);
        assert!(flat.iter().all(|v| v.abs() < 1e-6));
    }

    #[test]
    fn detail_adds_relief_of_the_configured_rms_and_modulates_melanin_about_one() {
        let dir = derma_test_support::scratch_dir("detail");
        // Registered exemplars: bumps in the height, the same bumps darker in the colour.
        let n = 72;
        let bump = |x: usize, y: usize| {
            let (fx, fy) = (x as f32 * 0.7, y as f32 * 0.55);
            0.5 + 0.2 * (fx.sin() * fy.cos()) + 0.1 * ((fx * 2.3 + fy).sin())
        };
        let h = Map::from_vec(n, n, (0..n * n).map(|i| bump(i % n, i / n)).collect()).unwrap();
        let dark = |k: f32| {
            Map::from_vec(
                n,
                n,
                (0..n * n).map(|i| k * (1.2 - bump(i % n, i / n))).collect(),
            )
            .unwrap()
        };
        let (r, g, b) = (dark(0.6), dark(0.45), dark(0.4));
        derma_core::image_io::write_png16(&dir.join("h.png"), &[&h]).unwrap();
        derma_core::image_io::write_png16(&dir.join("a.png"), &[&r, &g, &b]).unwrap();
        let cfg = DetailConfig {
            tile_size: 96,
            patch: 16,
            highpass_texels: 3,
            height_mm: 0.02,
            ..Default::default()
        };
        let tile = build(
            &cfg,
            Some(&dir.join("h.png")),
            Some(&dir.join("a.png")),
            3,
            Device::Cpu,
            &derma_core::progress::Silent,
        )
        .unwrap();
        let mut base = BioSample::default();
        base.tissue.melanin = 0.05;
        let w = 128;
        let mut texels = vec![base; w * w];
        tile.apply(&cfg, &mut texels, w);
        let dh: Vec<f64> = texels.iter().map(|t| t.height_mm as f64).collect();
        let mean = dh.iter().sum::<f64>() / dh.len() as f64;
        let rms = (dh.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / dh.len() as f64).sqrt();
        assert!(mean.abs() < 0.002, "mean relief {mean}");
        assert!(
            (rms - 0.02).abs() < 0.004,
            "relief RMS {rms} for height_mm 0.02"
        );
        // Melanin varies about its painted value, higher where the colour is darker, which in
        // these exemplars is where the relief is high.
        let mel: Vec<f64> = texels
            .iter()
            .map(|t| t.tissue.melanin as f64 / 0.05)
            .collect();
        let m_mean = mel.iter().sum::<f64>() / mel.len() as f64;
        assert!((m_mean - 1.0).abs() < 0.05, "mean melanin factor {m_mean}");
        let cov: f64 = mel
            .iter()
            .zip(&dh)
            .map(|(m, h)| (m - m_mean) * (h - mean))
            .sum::<f64>();
        assert!(cov > 0.0, "melanin should rise where the colour is darker");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn unregistered_exemplars_are_refused_by_name() {
        let dir = derma_test_support::scratch_dir("detail-bad");
        derma_core::image_io::write_png16(&dir.join("h.png"), &[&Map::filled(64, 64, 0.5)])
            .unwrap();
        let m = Map::filled(80, 64, 0.5);
        derma_core::image_io::write_png16(&dir.join("a.png"), &[&m, &m, &m]).unwrap();
        let e = build(
            &DetailConfig::default(),
            Some(&dir.join("h.png")),
            Some(&dir.join("a.png")),
            1,
            Device::Cpu,
            &derma_core::progress::Silent,
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("registered") && e.contains("80×64"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn sampling_wraps_and_interpolates() {
        let data = Map::from_vec(4, 4, (0..16).map(|i| (i % 4) as f32).collect()).unwrap();
        // Texel centres return texel values; between the last and the first column, the mean.
        assert_eq!(DetailTile::sample(&data, 1.5, 0.5), 1.0);
        assert!((DetailTile::sample(&data, 4.0, 0.5) - 1.5).abs() < 1e-6);
        assert_eq!(DetailTile::sample(&data, 5.5, 4.5), 1.0);
    }
}
