//! `derma export` and `derma view` (docs/render.md): flags → derma-export's GLB and web
//! exports and its server, and what was written or served.

use crate::progress::Bars;
use anyhow::{bail, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_export::glb::{GlbOptions, MapNames, NormalConvention};
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum ExportCommand {
    /// A glTF 2.0 binary for engines: the head (or your mesh) with the texture set as a PBR
    /// material (KHR_materials_specular, _diffuse_transmission, _volume on request), tangents,
    /// face units.
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
    read: crate::args::MeshReadArg,
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
    /// A teeth texture for the head's teeth (`derma photo teeth`'s teeth.png).
    #[arg(long)]
    teeth: Option<PathBuf>,
    /// Also KHR_materials_volume (the subsurface mean free paths as attenuation). glTF gives it
    /// no effect without transmission; Blender's importer makes it a volume that darkens Eevee.
    #[arg(long)]
    volume: bool,
    /// The lash and brow cards alpha-tested at ½ (glTF `MASK`) instead of blended (`BLEND`),
    /// for engines that do not sort transparent materials.
    #[arg(long)]
    hair_mask: bool,
}

fn glb_options(textures: PathBuf, mesh: Option<PathBuf>, out: PathBuf) -> GlbOptions {
    GlbOptions {
        textures,
        mesh,
        unit: derma_core::head_mesh::HeadUnit::Auto,
        part: Default::default(),
        head: None,
        out,
        maps: None,
        wrinkles: true,
        iris: None,
        teeth: None,
        volume: false,
        hair_mask: false,
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
    /// A teeth texture for the head's teeth (`derma photo teeth`'s teeth.png).
    #[arg(long)]
    teeth: Option<PathBuf>,
}

pub fn export(cmd: ExportCommand, bars: &Bars) -> Result<()> {
    match cmd {
        ExportCommand::Glb(a) => {
            let mut o = glb_options(a.textures, a.mesh, a.out);
            o.unit = a.read.head_unit()?;
            o.part = a.read.part();
            o.head = a.head.head;
            o.iris = a.iris;
            o.teeth = a.teeth;
            o.volume = a.volume;
            o.hair_mask = a.hair_mask;
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
                derma_export::web::PartTextures {
                    iris: a.iris.as_deref(),
                    teeth: a.teeth.as_deref(),
                },
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
