//! The micro-relief on its own: a tileable 20 × 20 mm patch with every feature off but the
//! relief, its height field's radially averaged power spectrum (with the power-law slope fitted
//! between the plateau size and four texels, as an SVG plot), and the patch under a grazing light
//! with and without the relief.
//! Run: `cargo run --release -p derma-skin --example 03_relief [OUT_DIR] [SIZE]` (default: a
//! `derma-relief` folder in the temporary directory, 256²).

use derma_core::plot::{Plot, Series};
use derma_render::cpu::{render_lit, single_light, tile};
use derma_skin::config::{Range, SurfaceKind};
use derma_skin::{SkinConfig, SkinGenerator, TextureSet};
use glam::Vec3;

const PATCH_MM: f32 = 20.0;

fn patch(size: u32, relief: bool) -> Result<TextureSet, Box<dyn std::error::Error>> {
    let mut cfg = SkinConfig {
        size,
        ..SkinConfig::default()
    };
    cfg.surface.kind = SurfaceKind::Patch;
    cfg.surface.patch_size_mm = [PATCH_MM, PATCH_MM];
    cfg.relief.enabled = relief;
    // Only the relief: no features, no baseline height noise.
    cfg.baseline.height_mm = Range { min: 0.0, max: 0.0 };
    cfg.cyst.enabled = false;
    cfg.mole.enabled = false;
    cfg.freckle.enabled = false;
    cfg.wrinkle.enabled = false;
    cfg.pore.enabled = false;
    cfg.follicle.enabled = false;
    cfg.eyebrow.enabled = false;
    Ok(SkinGenerator::new(cfg).run()?)
}

/// Radially averaged periodogram of a square periodic height map (mm) of side `side_mm`: bins of
/// spatial frequency (1/mm, log-spaced) and mean |H(f)|² in each, by a separable DFT.
fn radial_spectrum(h: &[f32], n: usize, side_mm: f64) -> Vec<(f64, f64)> {
    use std::f64::consts::TAU;
    let mean = h.iter().map(|&v| v as f64).sum::<f64>() / h.len() as f64;
    let (cos, sin): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|k| {
            (
                (TAU * k as f64 / n as f64).cos(),
                (TAU * k as f64 / n as f64).sin(),
            )
        })
        .unzip();
    // Rows, then columns.
    let mut re = vec![0.0f64; n * n];
    let mut im = vec![0.0f64; n * n];
    for y in 0..n {
        for k in 0..n {
            let (mut a, mut b) = (0.0, 0.0);
            for x in 0..n {
                let v = h[y * n + x] as f64 - mean;
                let j = (k * x) % n;
                a += v * cos[j];
                b -= v * sin[j];
            }
            re[y * n + k] = a;
            im[y * n + k] = b;
        }
    }
    let mut power = vec![0.0f64; n * n];
    for kx in 0..n {
        for ky in 0..n {
            let (mut a, mut b) = (0.0, 0.0);
            for y in 0..n {
                let j = (ky * y) % n;
                let (r, i) = (re[y * n + kx], im[y * n + kx]);
                a += r * cos[j] + i * sin[j];
                b += i * cos[j] - r * sin[j];
            }
            power[ky * n + kx] = a * a + b * b;
        }
    }
    let bins = 40;
    let (f_lo, f_hi) = (1.0 / side_mm, n as f64 / (2.0 * side_mm));
    let mut sum = vec![(0.0f64, 0.0f64, 0usize); bins];
    for ky in 0..n {
        for kx in 0..n {
            let fx = if kx <= n / 2 {
                kx as f64
            } else {
                kx as f64 - n as f64
            } / side_mm;
            let fy = if ky <= n / 2 {
                ky as f64
            } else {
                ky as f64 - n as f64
            } / side_mm;
            let f = (fx * fx + fy * fy).sqrt();
            if f < f_lo || f > f_hi {
                continue;
            }
            let b = (((f / f_lo).ln() / (f_hi / f_lo).ln()) * bins as f64) as usize;
            let e = &mut sum[b.min(bins - 1)];
            e.0 += f;
            e.1 += power[ky * n + kx];
            e.2 += 1;
        }
    }
    sum.into_iter()
        .filter(|e| e.2 > 0)
        .map(|(f, p, c)| (f / c as f64, p / c as f64))
        .collect()
}

/// Least-squares slope of log10 P against log10 f for f in [lo, hi].
fn slope(spec: &[(f64, f64)], lo: f64, hi: f64) -> f64 {
    let pts: Vec<(f64, f64)> = spec
        .iter()
        .filter(|(f, p)| *f >= lo && *f <= hi && *p > 0.0)
        .map(|(f, p)| (f.log10(), p.log10()))
        .collect();
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx) * (p.1 - my), a.1 + (p.0 - mx).powi(2))
    });
    sxy / sxx
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).map_or_else(
        || std::env::temp_dir().join("derma-relief"),
        std::path::PathBuf::from,
    );
    let size: usize = std::env::args().nth(2).map_or(Ok(256), |s| s.parse())?;
    std::fs::create_dir_all(&out)?;
    let on = patch(size as u32, true)?;
    let texel = PATCH_MM as f64 / size as f64;
    let spec = radial_spectrum(
        on.bio.channel(|s| s.height_mm).data(),
        size,
        PATCH_MM as f64,
    );
    let plateau = on.config.relief.cell_mm[0] as f64;
    let (lo, hi) = (1.0 / plateau, 1.0 / (4.0 * texel));
    let s = slope(&spec, lo, hi);
    println!(
        "relief height spectrum: slope {s:.2} (log10 power per log10 frequency) between {lo:.2} and {hi:.2} /mm ({size}², {texel:.3} mm texels)"
    );
    let fit_at = |f: f64| {
        let (f0, p0) = spec
            .iter()
            .copied()
            .filter(|(f, _)| *f >= lo)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap_or((lo, 1.0));
        p0.log10() + s * (f.log10() - f0.log10())
    };
    let plot = Plot::new(
        "Micro-relief height: radially averaged power spectrum",
        "log10 spatial frequency (1/mm)",
        "log10 power (mm^2 per bin, arbitrary scale)",
        vec![
            Series::new(
                "relief",
                "#b03a2e",
                spec.iter().map(|(f, p)| (f.log10(), p.max(1e-30).log10())),
            ),
            Series::new(
                format!("fit, slope {s:.2}"),
                "#1f618d",
                [(lo.log10(), fit_at(lo)), (hi.log10(), fit_at(hi))],
            ),
        ],
    );
    std::fs::write(out.join("relief-spectrum.svg"), plot.to_svg())?;
    // The patch under a grazing light (10° above the surface, from the left), with and without.
    let off = patch(size as u32, false)?;
    let (m, t) = tile(PATCH_MM);
    let grazing = single_light(
        Vec3::new(-0.985, 0.0, 0.174),
        Vec3::splat(6.0 * std::f32::consts::PI),
    );
    let views: Vec<[derma_core::Map; 3]> = [&off, &on]
        .iter()
        .map(|set| {
            let tex = set.render.material(true, glam::Vec2::ONE);
            render_lit(&m, &t, &tex, &[], 0.0, 512, &grazing)
        })
        .collect();
    let sheet = derma_render::sheet::compose(&views, &[], 512);
    derma_core::image_io::write_png8(
        &out.join("relief-grazing.png"),
        &[&sheet[0], &sheet[1], &sheet[2]],
    )?;
    println!(
        "wrote {}/relief-spectrum.svg and relief-grazing.png (left: without, right: with)",
        out.display()
    );
    Ok(())
}
