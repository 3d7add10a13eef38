//! `derma head fit`: fit the built-in head to your head or face mesh (derma_head::fit, after
//! Amberg et al. 2007), so every command follows it through `--head DIR`.

use crate::output::line;
use crate::progress::Bars;
use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use derma_head::fit::job::{FitJob, LandmarkSource};
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum HeadCommand {
    /// Register the built-in head onto your scan: landmarks, regions, face units, globes,
    /// teeth and lashes follow it; write a fitted head directory for --head.
    Fit(FitArgs),
}

#[derive(Args)]
pub struct FitArgs {
    /// Your head or face mesh (OBJ, glTF or GLB; UVs optional), in any unit and orientation:
    /// both are found from its face.
    #[arg(long)]
    mesh: PathBuf,
    /// Its landmarks: "mediapipe" (MediaPipe's 468-vertex topology) or a JSON file
    /// {"name": [x, y, z]} in the mesh's units with at least the four canthi, nose_tip and the
    /// mouth corners; none: found on the mesh (the nose tip, then an ICP of the face).
    #[arg(long)]
    landmarks: Option<String>,
    /// The mesh's unit and part.
    #[command(flatten)]
    read: crate::args::MeshReadArg,
    /// The mesh's axes as UP,FRONT (e.g. +Z,-Y: its +Z is up, its face looks along −Y); default:
    /// found from the face.
    #[arg(long, value_name = "UP,FRONT", value_parser = derma_core::head_mesh::parse_axes)]
    axes: Option<glam::Mat3>,
    /// The fitted head directory to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(cmd: HeadCommand, bars: &Bars) -> Result<()> {
    match cmd {
        HeadCommand::Fit(a) => {
            let unit = a.read.head_unit()?;
            let landmarks = match a.landmarks.as_deref() {
                None => LandmarkSource::Auto,
                Some("mediapipe") => LandmarkSource::MediaPipe,
                Some(p) => LandmarkSource::File(p.into()),
            };
            let job = FitJob {
                mesh: a.mesh.clone(),
                unit,
                part: a.read.part(),
                axes: a.axes,
                landmarks,
                out: a.out.clone(),
            };
            let r = job
                .run(bars)
                .with_context(|| format!("fitting the head to {}", a.mesh.display()))?;
            if let Some(f) = &r.frame {
                line(format!(
                    "found: {}; {} mm per unit ({}; the face ×{:.2} the template's)",
                    f.axes,
                    f.mm_per_unit,
                    f.unit
                        .as_deref()
                        .unwrap_or("no unit of mm, cm or m: from the face's size, ±15 %"),
                    f.face_scale
                ))?;
            }
            line(format!(
                "fitted ({}): scale {:.3}, {} iterations, face RMS {:.2} mm before projection, median {:.3} mm after, {:.0} % of the face matched, {} flipped triangles",
                r.alignment,
                r.scale,
                r.iterations,
                r.rms_mm,
                r.median_mm,
                100.0 * r.matched,
                r.flipped
            ))?;
            for (n, d) in &r.landmark_mm {
                line(format!("  landmark {n}: {d:.2} mm"))?;
            }
            if !r.detected.is_empty() {
                let worst = r.corner_gap_mm.iter().map(|g| g.1).fold(0.0f32, f32::max);
                line(format!(
                    "  eye and mouth corners found on the scan: {} of 6 ({}); the fit holds them within {worst:.2} mm",
                    r.detected.len(),
                    r.detected.iter().map(|d| d.0.as_str()).collect::<Vec<_>>().join(", ")
                ))?;
                if worst > 3.0 {
                    bars.say(format!(
                        "warning: the fit stays {worst:.1} mm from an eye or mouth corner found on the scan; check the fit (template.obj) or give landmarks (--landmarks)"
                    ));
                }
            }
            line(format!("wrote {}", a.out.display()))
        }
    }
}
