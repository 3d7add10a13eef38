//! `derma`: the command-line tool. Thin: parses flags, calls the libraries, shows their
//! progress and notes, and prints results; the libraries do the work and write the files.
//! Each command's models and sources are in docs/ (skin.md, optics.md, matching.md, rig.md,
//! synth.md, photo.md, eyes.md, render.md, head.md).

mod args;
mod batch;
mod check;
mod export;
mod eyes;
mod head;
mod matching;
mod optics;
mod output;
mod photo;
mod photo_args;
mod progress;
mod render;
mod rig;
mod rig_args;
mod skin;
mod synth;

use clap::{Parser, Subcommand};

/// `derma --version`: the version and whether this build has the GPU backends.
#[cfg(feature = "gpu")]
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (with the gpu feature)");
#[cfg(not(feature = "gpu"))]
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (CPU only; build with --features gpu for --device gpu)"
);

#[derive(Parser)]
#[command(
    name = "derma",
    version = VERSION,
    about = "The appearance of digital humans, from biology"
)]
struct Cli {
    /// More log output (-v info, -vv debug).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    /// No progress bars or notes (for scripts).
    #[arg(short, long, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Procedural biological skin: scatter features, paint bio maps, write a texture set.
    Skin(skin::SkinArgs),
    /// Skin optics: Monte Carlo light transport in layered skin (CPU and GPU).
    #[command(subcommand)]
    Optics(optics::OpticsCommand),
    /// Model matching: fit render models to the optics, and the skin-colour LUT.
    #[command(subcommand)]
    Match(matching::MatchCommand),
    /// Dynamic facial colour: the skin appearance rig (hemoglobin by expression and emotion).
    #[command(subcommand)]
    Rig(rig_args::RigCommand),
    /// Exemplar synthesis: grow skin detail of any size from a small sample (CPU and GPU).
    Synth(synth::SynthArgs),
    /// Faces from photographs: calibrate, unwrap, bake, iris, teeth, chromophore maps.
    #[command(subcommand)]
    Photo(photo::PhotoCommand),
    /// The eye region: train the gaze-driven lid and skin model, animate it (GLB, curves,
    /// renders), synthetic tracked data, screen-space distance fields and lacrimal lakes.
    #[command(subcommand)]
    Eyes(eyes::EyesCommand),
    /// Render a texture set on the head or your mesh: subsurface scattering, specular, shadows,
    /// eyes; two lighting setups, turntables, contact sheets (wgpu in a build with the `gpu`
    /// feature, on any GPU or lavapipe; else the CPU renderer, without scattering or refraction).
    Render(render::RenderArgs),
    /// Files for engines and the web: a GLB with the PBR material, or the web viewer's files.
    #[command(subcommand)]
    Export(export::ExportCommand),
    /// Your own head: fit the built-in head to your mesh, for --head on every command.
    #[command(subcommand)]
    Head(head::HeadCommand),
    /// Serve the web viewer on localhost for a directory from `derma export web`.
    View(export::ViewArgs),
    /// Many identities from one spec (skin tone, sex, age, mesh distributions): resumable,
    /// sharded by a Slurm array or Kubernetes Indexed Job, merged into a manifest.
    Batch(batch::BatchArgs),
    /// Check a texture set against its manifest (every file's SHA-256; nothing missing or
    /// unlisted).
    Check(check::CheckArgs),
}

fn main() {
    // Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" (looking like an error
    // of derma's) when wgpu opens them without one, as on headless servers; give them the
    // temporary directory. Set before any thread starts.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let cli = Cli::parse();
    let fresh = fresh_outputs();
    use tracing_subscriber::{filter::Targets, prelude::*};
    let level = match cli.verbose {
        0 => Targets::new().with_default(tracing::Level::WARN),
        1 => Targets::new().with_default(tracing::Level::INFO),
        // Debug output of derma's own crates only (wgpu and naga are very chatty): a target
        // matches by prefix, so "derma" covers every derma_* crate.
        _ => Targets::new()
            .with_default(tracing::Level::INFO)
            .with_target("derma", tracing::Level::DEBUG),
    };
    tracing_subscriber::registry()
        .with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr))
        .with(level)
        .init();
    let bars = progress::Bars::new(cli.quiet);
    let result = match cli.command {
        Command::Skin(args) => skin::run(args, &bars),
        Command::Optics(cmd) => optics::run(cmd, &bars),
        Command::Match(cmd) => matching::run(cmd, &bars),
        Command::Rig(cmd) => rig::run(cmd, &bars),
        Command::Synth(args) => synth::run(args, &bars),
        Command::Photo(cmd) => photo::run(cmd, &bars),
        Command::Eyes(cmd) => eyes::run(cmd, &bars),
        Command::Render(args) => render::render(args, &bars),
        Command::Export(cmd) => export::export(cmd, &bars),
        Command::View(args) => export::view(args),
        Command::Head(cmd) => head::run(cmd, &bars),
        Command::Batch(args) => batch::run(args, &bars),
        Command::Check(args) => check::run(args),
    };
    bars.finish();
    if let Err(e) = result {
        if output::is_closed_pipe(&e) {
            // `derma … | head`: the reader has what it wanted.
            std::process::exit(0);
        }
        eprintln!("error: {e:#}");
        remove_if_empty(&fresh);
        std::process::exit(1);
    }
}

/// The `--out` paths of this command line that do not exist yet.
fn fresh_outputs() -> Vec<std::path::PathBuf> {
    let args: Vec<String> = std::env::args().collect();
    let mut out = Vec::new();
    for (i, a) in args.iter().enumerate() {
        let value = match a.strip_prefix("--out=") {
            Some(v) => Some(v.to_string()),
            None if a == "--out" => args.get(i + 1).cloned(),
            None => None,
        };
        if let Some(v) = value.map(std::path::PathBuf::from) {
            if !v.exists() {
                out.push(v);
            }
        }
    }
    out
}

/// After an error, removes the output directories this run made and left empty, so an early
/// error leaves nothing behind (a directory holding any file is kept).
fn remove_if_empty(made: &[std::path::PathBuf]) {
    for d in made {
        if d.is_dir() {
            let _ = std::fs::remove_dir(d);
        }
    }
}
