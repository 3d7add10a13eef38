//! `derma render`, `derma export` and `derma view` (docs/render.md): flags → derma-render, and
//! what was written or served.

use crate::progress::Bars;
use anyhow::{bail, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_export::files::{RenderJob, RigFrame};
use derma_export::glb::{GlbOptions, MapNames, NormalConvention};
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
    /// Leave out the lacrimal lake (the tear meniscus along the lid margins).
    #[arg(long)]
    no_lake: bool,
    /// Output directory.
    #[arg(long, default_value = "render")]
    out: PathBuf,
    #[command(flatten)]
    device: crate::args::DeviceArg,
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

#[derive(Subcommand)]
pub enum ExportCommand {
    /// A glTF 2.0 binary for engines: the head (or your mesh) with the texture set as a PBR
    /// material (KHR_materials_specular, _volume, _diffuse_transmission), tangents, face units.
    Glb(GlbArgs),
    /// The web viewer's files: the GLB, and the rig as 16-bit PNG textures with a JSON manifest.
    Web(WebArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum NormalArg {
    /// +Y up (glTF, Blender, Unity, three.js).
    Opengl,
    /// −Y (Unreal).
    Directx,
}

#[derive(Clone, Copy, ValueEnum)]
enum NamesArg {
    /// base_color.png, normal.png, …
    Derma,
    /// head_BaseColor.png, head_Normal.png, … (Substance Painter).
    Substance,
    /// T_Head_BC.png, T_Head_N.png, … (Unreal / MetaHuman style).
    Unreal,
}

#[derive(Args)]
pub struct GlbArgs {
    /// A texture set from `derma skin --out DIR`.
    textures: PathBuf,
    /// Your mesh with the set's UVs; default: the built-in head and its parts.
    #[arg(long)]
    mesh: Option<PathBuf>,
    #[command(flatten)]
    head: crate::args::HeadArg,
    /// The GLB to write.
    #[arg(long, default_value = "head.glb")]
    out: PathBuf,
    /// Also write the maps as loose files into DIR (named by --names, normal by --normal).
    #[arg(long, value_name = "DIR")]
    maps: Option<PathBuf>,
    /// Naming of the loose maps.
    #[arg(long, value_enum, default_value = "derma")]
    names: NamesArg,
    /// Normal-map convention of the loose maps (the GLB's is glTF's, OpenGL, by its spec).
    #[arg(long, value_enum, default_value = "opengl")]
    normal: NormalArg,
    /// An eye texture for the globes (`derma photo iris`'s eye.png or eye.exr).
    #[arg(long)]
    iris: Option<PathBuf>,
}

fn glb_options(textures: PathBuf, mesh: Option<PathBuf>, out: PathBuf) -> GlbOptions {
    GlbOptions {
        textures,
        mesh,
        unit: derma_core::mesh::HeadUnit::Auto,
        head: None,
        out,
        maps: None,
        wrinkles: true,
        iris: None,
    }
}

#[derive(Args)]
pub struct WebArgs {
    /// A texture set from `derma skin --out DIR`.
    textures: PathBuf,
    /// A rig built from the set (`derma rig build`), for the expression sliders.
    #[arg(long)]
    rig: Option<PathBuf>,
    #[command(flatten)]
    head: crate::args::HeadArg,
    /// Output directory (what `derma view` serves).
    #[arg(long, default_value = "web")]
    out: PathBuf,
    /// An eye texture for the globes (`derma photo iris`'s eye.png or eye.exr).
    #[arg(long)]
    iris: Option<PathBuf>,
}

pub fn export(cmd: ExportCommand, bars: &Bars) -> Result<()> {
    match cmd {
        ExportCommand::Glb(a) => {
            let mut o = glb_options(a.textures, a.mesh, a.out);
            o.head = a.head.head;
            o.iris = a.iris;
            o.maps = a.maps.map(|d| {
                (
                    d,
                    match a.names {
                        NamesArg::Derma => MapNames::Derma,
                        NamesArg::Substance => MapNames::Substance,
                        NamesArg::Unreal => MapNames::Unreal,
                    },
                    match a.normal {
                        NormalArg::Opengl => NormalConvention::OpenGl,
                        NormalArg::Directx => NormalConvention::DirectX,
                    },
                )
            });
            let r = derma_export::glb::export(&o, bars)?;
            bars.say(format!(
                "{} ({:.1} MB): meshes {}; {} morph targets; {}{}",
                r.path.display(),
                r.bytes as f64 / 1e6,
                r.meshes.join(", "),
                r.morph_targets,
                r.extensions.join(", "),
                if r.maps.is_empty() {
                    String::new()
                } else {
                    format!("; {} loose maps", r.maps.len())
                }
            ));
            Ok(())
        }
        ExportCommand::Web(a) => {
            let r = derma_export::web::export(
                &a.textures,
                a.rig.as_deref(),
                a.head.head.as_deref(),
                a.iris.as_deref(),
                &a.out,
            )?;
            bars.say(format!(
                "{}: head.glb, {} rig targets → `derma view {}`",
                a.out.display(),
                r.targets,
                a.out.display()
            ));
            Ok(())
        }
    }
}

#[derive(Args)]
pub struct ViewArgs {
    /// A directory from `derma export web`.
    dir: PathBuf,
    /// Port on localhost (0: any free one).
    #[arg(long, default_value_t = 8017)]
    port: u16,
    /// The built viewer (`npm --prefix viewer run build`); default: viewer/dist of this source tree.
    #[arg(long)]
    viewer: Option<PathBuf>,
}

pub fn view(a: ViewArgs) -> Result<()> {
    let viewer = a
        .viewer
        .unwrap_or_else(derma_export::serve::default_viewer_dir);
    derma_export::web::check_export(&a.dir)?;
    if !viewer.join("index.html").is_file() {
        bail!(
            "no built viewer at {}: run `npm --prefix viewer ci && npm --prefix viewer run build` (or give --viewer DIR)",
            viewer.display()
        );
    }
    let server = derma_export::serve::Server::bind(&viewer, &a.dir, a.port)?;
    // On stdout (and flushed) so scripts that start the viewer can read the address.
    crate::output::text(&format!(
        "derma viewer on http://{}/ (Ctrl-C to stop)\n",
        server.addr()
    ))?;
    server.run()?;
    Ok(())
}
