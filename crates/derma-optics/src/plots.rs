//! Plots of a skin simulation (SVG through derma-core's plotter): spectra, BRDF slices in the
//! plane of incidence and the radial profile — what `derma optics simulate --plot` writes.

use crate::simulate::SkinResult;
use derma_core::plot::{Plot, Series};
use std::path::{Path, PathBuf};

/// Series colours (matplotlib's first six, tab10).
const COLORS: [&str; 6] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

/// The plots of one skin simulation: diffuse and specular spectra (`spectrum.svg`), the
/// sampled BRDF in the plane of incidence at four incident angles (`brdf.svg`), and the radial
/// exit profile per channel (`profile.svg`).
pub fn skin_plots(r: &SkinResult) -> [(&'static str, Plot); 3] {
    let spectrum = Plot {
        title: "Diffuse reflectance of the skin specimen".into(),
        x_label: "wavelength (nm)".into(),
        y_label: "reflectance".into(),
        log_y: false,
        series: vec![
            Series {
                label: "diffuse".into(),
                color: COLORS[0].into(),
                points: r
                    .wavelengths_nm
                    .iter()
                    .copied()
                    .zip(r.r_diffuse.iter().copied())
                    .collect(),
            },
            Series {
                label: "specular".into(),
                color: COLORS[1].into(),
                points: r
                    .wavelengths_nm
                    .iter()
                    .copied()
                    .zip(r.r_specular.iter().copied())
                    .collect(),
            },
        ],
    };
    let b = r.brdf_bins;
    // In-plane slices (Δφ bins nearest 0 and π) for a few incident angles, luminance-like green.
    let mut brdf_series = Vec::new();
    for (k, ti) in [0, b.theta_in / 3, 2 * b.theta_in / 3, b.theta_in - 1]
        .into_iter()
        .enumerate()
    {
        let (t_in, _, _) = b.centre(ti, 0, 0);
        let mut pts = Vec::new();
        for to in (0..b.theta_out).rev() {
            let (_, t_out, _) = b.centre(ti, to, 0);
            pts.push((
                -t_out.to_degrees(),
                r.brdf_rgb[b.index(ti, to, b.phi - 1)][1],
            ));
        }
        for to in 0..b.theta_out {
            let (_, t_out, _) = b.centre(ti, to, 0);
            pts.push((t_out.to_degrees(), r.brdf_rgb[b.index(ti, to, 0)][1]));
        }
        brdf_series.push(Series {
            label: format!("θi = {:.0}°", t_in.to_degrees()),
            color: COLORS[k].into(),
            points: pts,
        });
    }
    let brdf = Plot {
        title: "Sampled BRDF, plane of incidence (G channel)".into(),
        x_label: "outgoing zenith (°; negative = mirror side)".into(),
        y_label: "BRDF (1/sr)".into(),
        log_y: false,
        series: brdf_series,
    };
    let pb = r.profile_bins;
    let dr = pb.d_max_mm / pb.bins as f64;
    let names = ["R", "G", "B"];
    let profile = Plot {
        title: "Radial exit profile R(r)".into(),
        x_label: "r (mm)".into(),
        y_label: "R(r) (1/mm²)".into(),
        log_y: true,
        series: (0..3)
            .map(|c| Series {
                label: names[c].into(),
                color: ["#d62728", "#2ca02c", "#1f77b4"][c].into(),
                points: (0..pb.bins)
                    .map(|i| ((i as f64 + 0.5) * dr, r.profile_rgb[i][c]))
                    .collect(),
            })
            .collect(),
    };
    [
        ("spectrum.svg", spectrum),
        ("brdf.svg", brdf),
        ("profile.svg", profile),
    ]
}

/// Writes `result.json` (the whole result) into `dir`, and with `plots` the three plots of
/// [`skin_plots`]; returns the files written.
pub fn write_result(r: &SkinResult, dir: &Path, plots: bool) -> crate::Result<Vec<PathBuf>> {
    derma_core::atomic::ensure_writable_dir(dir)?;
    let json =
        serde_json::to_vec_pretty(r).map_err(|e| crate::OpticsError::Invalid(e.to_string()))?;
    let mut files = vec![dir.join("result.json")];
    derma_core::atomic::write_bytes(&files[0], &json)?;
    if plots {
        for (name, p) in skin_plots(r) {
            let path = dir.join(name);
            derma_core::atomic::write_bytes(&path, p.to_svg().as_bytes())?;
            files.push(path);
        }
    }
    Ok(files)
}
