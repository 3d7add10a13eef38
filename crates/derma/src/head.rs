//! `derma head fit`: fit the built-in head to your head or face mesh (derma_head::fit, after
//! Amberg et al. 2007), so every command follows it through `--head DIR`.

use crate::output::line;
use crate::progress::Bars;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use derma_core::mesh::HeadUnit;
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
    /// Your head or face mesh (OBJ, glTF or GLB; UVs optional), +Y up, facing +Z.
    #[arg(long)]
    mesh: PathBuf,
    /// Its landmarks: "mediapipe" (MediaPipe's 468-vertex topology) or a JSON file
    /// {"name": [x, y, z]} in the mesh's units with at least the four canthi, nose_tip and the
    /// mouth corners; none: found on the mesh (the nose tip, then an ICP of the face).
    #[arg(long)]
    landmarks: Option<String>,
    /// The mesh's unit: auto (the one that makes it head-sized), mm, cm, m, or fit.
    #[arg(long, default_value = "auto")]
    unit: String,
    /// The fitted head directory to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(cmd: HeadCommand, bars: &Bars) -> Result<()> {
    match cmd {
        HeadCommand::Fit(a) => {
            let Some(unit) = HeadUnit::parse(&a.unit) else {
                bail!("--unit {}: expected auto, fit, mm, cm or m", a.unit);
            };
            let landmarks = match a.landmarks.as_deref() {
                None => LandmarkSource::Auto,
                Some("mediapipe") => LandmarkSource::MediaPipe,
                Some(p) => LandmarkSource::File(p.into()),
            };
            let job = FitJob {
                mesh: a.mesh.clone(),
                unit,
                landmarks,
                out: a.out.clone(),
            };
            let r = job
                .run(bars)
                .with_context(|| format!("fitting the head to {}", a.mesh.display()))?;
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
