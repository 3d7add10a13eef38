//! `derma render` (docs/render.md): flags → derma-export's render job (the set on the head or
//! your mesh, posed by a rig frame, face units or the eye model), and what was written.

use crate::progress::Bars;
use anyhow::Result;
use clap::Args;
use derma_export::files::{RenderJob, RigFrame};
use derma_render::{Setup, View};
use derma_rig::{GlobalScale, WeightSpec};
use std::path::PathBuf;

#[derive(Args)]
pub struct RenderArgs {
    /// A texture set from `derma skin --out DIR`.
    textures: PathBuf,
    /// Your mesh (OBJ, glTF, GLB) with the set's UVs; default: the built-in head with its
    /// eyes, lashes, teeth and tongue.
    #[arg(long)]
    mesh: Option<PathBuf>,
    #[command(flatten)]
    head: crate::args::HeadArg,
    /// Lighting setups, comma-separated: studio (three-point), window (one soft side light).
    #[arg(long, default_value = "studio,window", value_delimiter = ',', value_parser = parse_setup)]
    lighting: Vec<Setup>,
    /// Image size WxH (or one number for a square).
    #[arg(long, default_value = "1024", value_parser = crate::args::frame_size)]
    size: (u32, u32),
    /// Camera yaw in degrees (0 = front, 90 = the subject's left profile).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    yaw: f32,
    /// Camera pitch in degrees above the horizon.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pitch: f32,
    /// Camera distance as a multiple of the framing distance (below 1 is closer).
    #[arg(long, default_value_t = 1.0)]
    zoom: f32,
    /// Also a turntable of N frames per setup (animated PNG).
    #[arg(long, value_name = "N")]
    turntable: Option<usize>,
    /// Also sheet.png: front, three-quarter and profile under every setup beside the raw maps.
    #[arg(long)]
    sheet: bool,
    /// Also the linear radiance as EXR (before tone mapping).
    #[arg(long)]
    exr: bool,
    /// A rig built from this set (`derma rig build --set`): the skin re-shaded with its hemoglobin at --weights.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// Rig target weights NAME=W,… (with --rig); the library's expressions also pose the head
    /// through their face units, which drive the set's expression wrinkles.
    #[arg(long, default_value = "", requires = "rig")]
    weights: WeightSpec,
    /// Global hemoglobin scale with --rig: auto or a factor.
    #[arg(long, default_value = "auto", requires = "rig")]
    global_scale: GlobalScale,
    /// Face units posing the head, NAME=W,… (e.g. mouthSmileLeft=1,mouthSmileRight=1), and
    /// deepening the set's expression wrinkles they drive; with --mesh, through the --head it
    /// was fitted to.
    #[arg(long, default_value = "")]
    pose: WeightSpec,
    /// An eye texture on the head's eye UVs (`derma photo iris`).
    #[arg(long, conflicts_with = "mesh")]
    iris: Option<PathBuf>,
    /// A teeth texture on the head's teeth (`derma photo teeth`'s teeth.png).
    #[arg(long, conflicts_with = "mesh")]
    teeth: Option<PathBuf>,
    /// Gaze yaw,pitch in degrees (positive yaw: to the subject's left); on the head (not with
    /// --mesh) the lids and the skin around the eyes follow through the trained eye-region model.
    #[arg(long, default_value = "0,0", value_parser = crate::args::pair, allow_negative_numbers = true)]
    gaze: (f32, f32),
    /// Lid closure from 0 (open) to 1 (a full blink), through the eye-region model.
    #[arg(long, default_value_t = 0.0, value_parser = crate::args::unit_interval, conflicts_with = "mesh")]
    blink: f32,
    /// Pupil diameter in mm (about 2 in bright light to 8 in the dark; the eye texture's own is
    /// 4): the pupil dilates or constricts through the texture's coordinates, the limbus kept.
    #[arg(long, value_name = "MM", value_parser = pupil_mm)]
    pupil: Option<f32>,
    /// Leave out the lacrimal lake (the tear meniscus along the lid margins).
    #[arg(long)]
    no_lake: bool,
    /// Output directory.
    #[arg(long, default_value = "render")]
    out: PathBuf,
    #[command(flatten)]
    device: crate::args::DeviceArg,
}

fn pupil_mm(s: &str) -> Result<f32, String> {
    let (lo, hi) = derma_head::eye::PUPIL_RANGE_MM;
    match s.trim().parse::<f32>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!(
            "'{s}': expected a pupil diameter from {lo} to {hi} mm"
        )),
    }
}

fn parse_setup(s: &str) -> Result<Setup, String> {
    s.parse()
}

pub fn render(a: RenderArgs, bars: &Bars) -> Result<()> {
    let job = RenderJob {
        textures: a.textures,
        mesh: a.mesh,
        head: a.head.head,
        setups: a.lighting,
        size: a.size,
        view: View {
            yaw_deg: a.yaw,
            pitch_deg: a.pitch,
            zoom: a.zoom,
        },
        turntable: a.turntable,
        sheet: a.sheet,
        exr: a.exr,
        rig: a.rig.map(|dir| RigFrame {
            dir,
            weights: a.weights,
            global: a.global_scale,
        }),
        face_units: a.pose.entries,
        iris: a.iris,
        teeth: a.teeth,
        gaze: a.gaze,
        blink: a.blink,
        pupil_mm: a.pupil,
        lake: !a.no_lake,
        device: a.device.device,
        out: a.out,
    };
    let r = derma_export::files::run(&job, bars)?;
    bars.finish();
    bars.say(format!(
        "{} frames on {} ({:.0} ms each with read-back) → {}",
        r.frames,
        r.adapter,
        1e3 * r.seconds_per_frame,
        job.out.display()
    ));
    Ok(())
}
