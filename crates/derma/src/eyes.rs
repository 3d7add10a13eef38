//! `derma eyes …`: the eye region (derma-eyes, after the EyeMove thesis ch. 3–4) — train the
//! gaze-driven lid and skin model, write synthetic tracked data, animate the head, and the
//! screen-space distance fields with the lacrimal lake.

use crate::output::line;
use crate::progress::Bars;
use anyhow::Result;
use clap::{Args, Subcommand};
use derma_eyes::animate::Drive;
use derma_eyes::blink::Activity;
use derma_eyes::files::{self, AnimateOptions, Data, Targets};
use derma_eyes::Components;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Subcommand)]
pub enum EyesCommand {
    /// Train the model (eqs. 3.2–3.11) on tracked data or on the built-in head's rig.
    Train(TrainArgs),
    /// A synthetic tracked sequence (the rig driven by blinks and saccades, with tracking noise).
    Synthetic(SyntheticArgs),
    /// Animate the head: gaze and blink curves, an animated GLB, rendered frames.
    Animate(AnimateArgs),
    /// Screen-space distance fields (Table 4.1) and the lacrimal lake on a close-up of the eyes.
    Sdf(SdfArgs),
}

#[derive(Args)]
pub struct TrainArgs {
    #[command(flatten)]
    head: crate::args::HeadArg,
    /// Tracked data (JSON or CSV, docs/eyes.md); default: sampled poses of the built-in rig.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Rig poses to sample when no --data is given.
    #[arg(long, default_value_t = 300)]
    samples: usize,
    /// Eyelid shape components (the thesis: 5 or 13).
    #[arg(long, default_value_t = 5)]
    lid_components: usize,
    /// Skin motion components (the thesis: 4; at most 8).
    #[arg(long, default_value_t = 4)]
    skin_components: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory.
    #[arg(long, short)]
    out: PathBuf,
}

#[derive(Args)]
pub struct SyntheticArgs {
    #[command(flatten)]
    head: crate::args::HeadArg,
    #[arg(long, default_value_t = 20.0)]
    seconds: f32,
    #[arg(long, default_value_t = 30.0)]
    fps: f32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output file (.json or .csv).
    #[arg(long, short)]
    out: PathBuf,
}

#[derive(Args)]
pub struct AnimateArgs {
    #[command(flatten)]
    head: crate::args::HeadArg,
    /// Your own mesh (with UVs) the --head was fitted to: its vertices move, in place of the
    /// fitted head's skin.
    #[arg(long, requires = "head")]
    mesh: Option<PathBuf>,
    /// A trained model (model.json); default: trained on the rig now.
    #[arg(long)]
    model: Option<PathBuf>,
    #[arg(long, default_value_t = 4.0)]
    seconds: f32,
    #[arg(long, default_value_t = 30.0)]
    fps: f32,
    /// Blink rate: rest (17/min), conversation (26), reading (4.5) or watching (table 3.1).
    #[arg(long, default_value = "rest", value_parser = parse_activity)]
    activity: Activity,
    /// Gaze from a tracker CSV (columns time, h, v in degrees).
    #[arg(long, conflicts_with = "look_at")]
    tracker: Option<PathBuf>,
    /// Gaze on the salient points (Itti et al. 1998) of this image, seen across --fov degrees.
    #[arg(long)]
    look_at: Option<PathBuf>,
    /// Horizontal field of view (°) the --look-at image spans.
    #[arg(long, default_value_t = 40.0)]
    fov: f32,
    /// Distance (mm) of what the eyes look at (vergence).
    #[arg(long, default_value_t = 1000.0)]
    distance: f32,
    /// Render each frame at this width (px; the height from the eye band's aspect, 104:50);
    /// 0: no renders.
    #[arg(long, default_value_t = 480)]
    render: usize,
    /// Eyeball texture for the globes (`derma photo iris`'s eye.exr or eye.png).
    #[arg(long)]
    iris: Option<PathBuf>,
    /// Skin thickness over the globes (mm, a cap on each vertex's rest gap).
    #[arg(long, default_value_t = derma_eyes::sliding::THICKNESS)]
    thickness: f32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory.
    #[arg(long, short)]
    out: PathBuf,
}

#[derive(Args)]
pub struct SdfArgs {
    #[arg(long, default_value_t = 1920)]
    width: usize,
    #[arg(long, default_value_t = 1080)]
    height: usize,
    /// Timed runs per method (the table reports the median).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    #[command(flatten)]
    device: crate::args::DeviceArg,
    /// Output directory.
    #[arg(long, short)]
    out: PathBuf,
}

fn parse_activity(s: &str) -> Result<Activity, String> {
    Activity::parse(s)
        .ok_or_else(|| format!("activity '{s}': expected rest, conversation, reading or watching"))
}

pub fn run(cmd: EyesCommand, bars: &Bars) -> Result<()> {
    let start = Instant::now();
    match cmd {
        EyesCommand::Train(a) => {
            let data = match a.data {
                Some(p) => Data::File(p),
                None => Data::Rig {
                    samples: a.samples,
                    seed: a.seed,
                    head: a.head.head,
                },
            };
            let c = Components {
                lids: a.lid_components,
                skin: a.skin_components,
            };
            let r = files::train(&data, c, &a.out, bars)?;
            bars.finish();
            line(format!(
                "trained on {} frames, {} tracked vertices, {} lid and {} skin components",
                r.frames, r.vertices, c.lids, c.skin
            ))?;
            for (k, (l, s)) in r.curve.lids.iter().zip(&r.curve.skin).enumerate() {
                line(format!(
                    "  {} components: held-out error lids {:.4}, skin {:.5}",
                    k + 1,
                    l,
                    s
                ))?;
            }
            for (e, side) in ["left", "right"].iter().enumerate() {
                line(format!(
                    "  {side} eye opening: {:.2} mm in primary gaze, {:.2} mm at 40° downgaze (Read et al. 2006: 9.7 ± 1.2, 6.4 ± 1.1)",
                    r.aperture_mm[e][0], r.aperture_mm[e][1]
                ))?;
            }
            for f in &r.files {
                line(format!("wrote {}", f.display()))?;
            }
        }
        EyesCommand::Synthetic(a) => {
            let n = files::synthetic(
                &a.out,
                a.seconds,
                a.fps,
                a.seed,
                a.head.head.as_deref(),
                bars,
            )?;
            bars.finish();
            line(format!("wrote {} ({n} frames)", a.out.display()))?;
        }
        EyesCommand::Animate(a) => {
            let targets = match (a.tracker, a.look_at) {
                (Some(p), _) => Targets::Tracker(p),
                (None, Some(p)) => Targets::Image(p, a.fov),
                _ => Targets::Idle,
            };
            let o = AnimateOptions {
                model: a.model,
                drive: Drive {
                    seconds: a.seconds,
                    fps: a.fps,
                    activity: a.activity,
                    seed: a.seed,
                    distance: a.distance,
                    fixations: None,
                    blinks: None,
                },
                targets,
                render: a.render,
                thickness: a.thickness,
                iris: a.iris,
                head: a.head.head,
                mesh: a.mesh,
            };
            let r = files::animate(&o, &a.out, bars)?;
            bars.finish();
            line(format!(
                "{} frames, {} blinks, {} vertices; {:.0} µs per model frame; GLB: {} morph targets, fit RMS {:.3} mm (max {:.3}), {:.1} MB",
                r.frames,
                r.blinks,
                r.vertices,
                r.frame_us,
                r.glb.targets,
                r.glb.rms_mm,
                r.glb.max_mm,
                r.glb.bytes as f64 / 1e6
            ))?;
            for f in &r.files {
                line(format!("wrote {}", f.display()))?;
            }
        }
        EyesCommand::Sdf(a) => {
            let rows =
                files::distance_fields(a.width, a.height, a.runs, a.device.device, &a.out, bars)?;
            bars.finish();
            line(derma_eyes::sdf::table::markdown(&rows, a.width, a.height))?;
            line(format!("wrote {}", a.out.display()))?;
        }
    }
    line(format!("done in {:.1} s", start.elapsed().as_secs_f64()))?;
    Ok(())
}
