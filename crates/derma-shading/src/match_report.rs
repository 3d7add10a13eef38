//! What `derma match fit` writes beside a fitted table: the per-entry residuals as CSV and SVG
//! plots comparing the Monte Carlo BRDF and radial profile with every fitted model (thesis
//! §4.6: how well each render model matches the simulated skin).

use crate::brdf_fit::FitGeometry;
use crate::error::{Result, ShadingError};
use crate::match_table::{self, MatchOptions, MatchTable};
use crate::model_kind::ModelKind;
use crate::sum_of_gaussians;
use derma_core::color::luminance;
use derma_core::dtab::Dtab;
use derma_core::plot::{Plot, Series};
use derma_optics::bio::names;
use std::path::Path;

/// The per-entry residuals of a fitted table as CSV: node, its axis values, then each model's
/// relative RMS residual (`derma match fit` writes it beside the table).
pub fn residual_csv(table: &Dtab, opts: &MatchOptions) -> String {
    let h = &table.header;
    let mut names: Vec<String> = opts.models.iter().map(|m| m.name().to_string()).collect();
    names.push("burley".into());
    names.push("sog".into());
    let mut s = String::new();
    s.push_str("node");
    for ax in &h.axes {
        s.push(',');
        s.push_str(&ax.name);
    }
    for n in &names {
        s.push_str(&format!(",{n}_relative_rms"));
    }
    s.push('\n');
    let stride = h.stride();
    for node in 0..h.nodes() {
        s.push_str(&node.to_string());
        let idx = h.node_indices(node);
        for (k, ax) in h.axes.iter().enumerate() {
            s.push_str(&format!(",{}", ax.values[idx[k]]));
        }
        for n in &names {
            let (o, _) = h.offset(&format!("{n}.rms")).expect("layout");
            s.push_str(&format!(",{:.6}", table.data[node * stride + o]));
        }
        s.push('\n');
    }
    s
}

/// Nodes worth plotting: fair, medium and dark (melanin first/middle/last) with every other
/// axis at its middle node.
pub fn default_plot_nodes(pre: &Dtab) -> Vec<usize> {
    let axes = &pre.header.axes;
    let mel = axes
        .iter()
        .position(|a| a.name == names::MELANIN)
        .unwrap_or(0);
    let n_mel = axes[mel].values.len();
    let mut picks: Vec<usize> = vec![0, n_mel / 2, n_mel - 1];
    picks.dedup();
    picks
        .into_iter()
        .map(|m| {
            let mut flat = 0;
            for (k, a) in axes.iter().enumerate() {
                let i = if k == mel {
                    m
                } else {
                    (a.values.len() - 1) / 2
                };
                flat = flat * a.values.len() + i;
            }
            flat
        })
        .collect()
}

/// Series colours of the fitted models (matplotlib's tab10).
const COLORS: [&str; 4] = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd"];

/// Writes, for each of `nodes`, the BRDF in the plane of incidence at three incident angles
/// (simulation against every fitted model, `brdf-nodeN-thetaT.svg`) and the radial profile
/// (simulation against Burley and the sum of Gaussians, `profile-nodeN.svg`) into `dir`;
/// returns how many plots it wrote.
pub fn write_plots(
    pre: &Dtab,
    mt: &MatchTable,
    opts: &MatchOptions,
    nodes: &[usize],
    dir: &Path,
) -> Result<usize> {
    let nodes_in_table = pre.header.nodes();
    if let Some(&n) = nodes.iter().find(|&&n| n >= nodes_in_table) {
        return Err(ShadingError::Invalid(derma_core::Invalid::new(
            "plot node",
            format!("an entry of the table (below {nodes_in_table})"),
            n,
        )));
    }
    derma_core::atomic::ensure_writable_dir(dir)?;
    let grid = match_table::precompute_grid(pre)?;
    let bins = grid.brdf_bins();
    let geom = FitGeometry::with_cutoff(bins, opts.weighting, opts.max_zenith_deg);
    let pstride = pre.header.stride();
    let mstride = mt.dtab.header.stride();
    let missing = |name: &str| {
        ShadingError::Invalid(derma_core::Invalid::new(
            format!("value '{name}' of the precompute table"),
            "a value every derma optics precompute table has (make one with `derma optics merge`)",
            "none",
        ))
    };
    let (bo, bl) = pre
        .header
        .offset("brdf_rgb")
        .ok_or_else(|| missing("brdf_rgb"))?;
    let (po, pl) = pre
        .header
        .offset("profile_rgb")
        .ok_or_else(|| missing("profile_rgb"))?;
    let mut count = 0;
    for &node in nodes {
        let sim: Vec<[f64; 3]> = pre.data[node * pstride + bo..node * pstride + bo + bl]
            .chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect();
        let row = &mt.dtab.data[node * mstride..(node + 1) * mstride];
        let fitted: Vec<(ModelKind, Vec<[f64; 3]>, f32)> = opts
            .models
            .iter()
            .map(|m| {
                let (o, l) = mt.dtab.header.offset(m.name()).expect("layout");
                let (ro, _) = mt
                    .dtab
                    .header
                    .offset(&format!("{}.rms", m.name()))
                    .expect("layout");
                let p: Vec<f64> = row[o..o + l].iter().map(|&v| v as f64).collect();
                (*m, geom.sample(m.model(), &p), row[ro])
            })
            .collect();
        let bio = describe_node(pre, node);
        let dtheta = 90.0 / bins.theta_out as f64;
        let ti_list: Vec<usize> = {
            let mut v = vec![0, bins.theta_in / 2, bins.theta_in.saturating_sub(2)];
            v.dedup();
            v
        };
        for &ti in &ti_list {
            // Incidence plane: Δφ bin 0 (light side, plotted at −θo) and the last bin (mirror
            // side, +θo).
            let curve = |v: &[[f64; 3]]| -> Vec<(f64, f64)> {
                let mut pts = Vec::new();
                for to in (0..bins.theta_out).rev() {
                    pts.push((
                        -(to as f64 + 0.5) * dtheta,
                        luminance(v[bins.index(ti, to, 0)]),
                    ));
                }
                for to in 0..bins.theta_out {
                    pts.push((
                        (to as f64 + 0.5) * dtheta,
                        luminance(v[bins.index(ti, to, bins.phi - 1)]),
                    ));
                }
                pts
            };
            let mut series = vec![Series {
                label: "Monte Carlo".into(),
                color: "#000000".into(),
                points: curve(&sim),
            }];
            for (k, (m, v, rms)) in fitted.iter().enumerate() {
                series.push(Series {
                    label: format!("{} ({:.1}%)", m.name(), rms * 100.0),
                    color: COLORS[k % COLORS.len()].into(),
                    points: curve(v),
                });
            }
            let theta_deg = (ti as f64 + 0.5) * 90.0 / bins.theta_in as f64;
            let plot = Plot::new(
                format!(
                    "BRDF in the plane of incidence, θi ≈ {theta_deg:.0}°, node {node} ({bio})"
                ),
                "θo (°): negative towards the light, positive on the mirror side",
                "BRDF luminance (1/sr)",
                series,
            )
            .with_log_y();
            let name = format!("brdf-node{node}-theta{theta_deg:.0}.svg");
            derma_core::atomic::write_bytes(&dir.join(&name), plot.to_svg().as_bytes())?;
            count += 1;
        }
        // Radial profile: simulation vs Burley and sum of Gaussians, red and blue.
        let prof: Vec<[f64; 3]> = pre.data[node * pstride + po..node * pstride + po + pl]
            .chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect();
        let dr = grid.profile_d_max_mm / grid.profile_bins as f64;
        let get = |name: &str| -> Vec<f64> {
            let (o, l) = mt.dtab.header.offset(name).expect("layout");
            row[o..o + l].iter().map(|&v| v as f64).collect()
        };
        let (ba, bd) = (get("burley.albedo"), get("burley.d_mm"));
        let var = get("sog.variance_mm2");
        let w = get("sog.weights");
        let sog = sum_of_gaussians::SogFit {
            weights: (0..var.len())
                .map(|k| [w[3 * k], w[3 * k + 1], w[3 * k + 2]])
                .collect(),
            variances_mm2: var,
            relative_rms: 0.0,
        };
        let mut series = Vec::new();
        for (c, cname, col) in [(0usize, "red", "#d62728"), (2, "blue", "#1f77b4")] {
            let rs: Vec<f64> = (0..grid.profile_bins)
                .map(|i| (i as f64 + 0.5) * dr)
                .filter(|&r| r <= 4.0)
                .collect();
            series.push(Series {
                label: format!("Monte Carlo {cname}"),
                color: "#000000".into(),
                points: rs
                    .iter()
                    .enumerate()
                    .map(|(i, &r)| (r, prof[i][c].max(1e-6)))
                    .collect(),
            });
            series.push(Series {
                label: format!("Burley {cname}"),
                color: col.into(),
                points: rs
                    .iter()
                    .map(|&r| (r, derma_render::burley::profile(r, ba[c], bd[c]).max(1e-6)))
                    .collect(),
            });
            series.push(Series {
                label: format!("sum of Gaussians {cname}"),
                color: if c == 0 { "#ff9896" } else { "#aec7e8" }.into(),
                points: rs
                    .iter()
                    .map(|&r| (r, sum_of_gaussians::eval(&sog, r, c).max(1e-6)))
                    .collect(),
            });
        }
        let plot = Plot::new(
            format!("Radial diffusion profile, node {node} ({bio})"),
            "r (mm)",
            "R(r) (1/mm²)",
            series,
        )
        .with_log_y();
        let name = format!("profile-node{node}.svg");
        derma_core::atomic::write_bytes(&dir.join(&name), plot.to_svg().as_bytes())?;
        count += 1;
    }
    Ok(count)
}

/// "melanin 0.05, blood 0.02" for a node, for plot titles.
pub fn describe_node(pre: &Dtab, node: usize) -> String {
    let axes = &pre.header.axes;
    pre.header
        .node_indices(node)
        .iter()
        .zip(axes)
        .filter(|(_, a)| a.name == names::MELANIN || a.name == names::BLOOD)
        .map(|(&i, a)| format!("{} {}", a.name, a.values[i]))
        .collect::<Vec<_>>()
        .join(", ")
}
