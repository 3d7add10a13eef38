//! Plots of a skin simulation (SVG through derma-core's plotter): spectra, BRDF slices in the
//! plane of incidence and the radial profile — what `derma optics simulate --plot` writes.

use crate::simulate::SkinResult;
use derma_core::plot::{Plot, Series};
use std::path::{Path, PathBuf};

/// Series colours (matplotlib's first six, tab10).
const COLORS: [&str; 6] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

/// A spectrum of `r` (one value per wavelength sample) as a plot series.
pub fn spectrum_series(label: &str, color: &str, r: &SkinResult, values: &[f64]) -> Series {
    Series::new(
        label,
        color,
        r.wavelengths_nm.iter().copied().zip(values.iter().copied()),
    )
}

/// The plots of one skin simulation: diffuse and specular spectra (`spectrum.svg`), the
/// sampled BRDF in the plane of incidence at four incident angles (`brdf.svg`), and the radial
/// exit profile per channel (`profile.svg`).
pub fn skin_plots(r: &SkinResult) -> [(&'static str, Plot); 3] {
    let spectrum = Plot::new(
        "Diffuse reflectance of the skin specimen",
        "wavelength (nm)",
        "reflectance",
        vec![
            spectrum_series("diffuse", COLORS[0], r, &r.r_diffuse),
            spectrum_series("specular", COLORS[1], r, &r.r_specular),
        ],
    );
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
    let brdf = Plot::new(
        "Sampled BRDF, plane of incidence (G channel)",
        "outgoing zenith (°; negative = mirror side)",
        "BRDF (1/sr)",
        brdf_series,
    );
    let pb = r.profile_bins;
    let dr = pb.d_max_mm / pb.bins as f64;
    let names = ["R", "G", "B"];
    let profile = Plot::new(
        "Radial exit profile R(r)",
        "r (mm)",
        "R(r) (1/mm²)",
        (0..3)
            .map(|c| {
                Series::new(
                    names[c],
                    ["#d62728", "#2ca02c", "#1f77b4"][c],
                    (0..pb.bins).map(|i| ((i as f64 + 0.5) * dr, r.profile_rgb[i][c])),
                )
            })
            .collect(),
    )
    .with_log_y();
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
    let mut files = vec![dir.join("result.json")];
    derma_core::report::write_json(&files[0], r, derma_core::report::JsonFormat::DATA_PRETTY)?;
    if plots {
        for (name, p) in skin_plots(r) {
            let path = dir.join(name);
            derma_core::atomic::write_bytes(&path, p.to_svg().as_bytes())?;
            files.push(path);
        }
    }
    Ok(files)
}
