//! `derma rig …`: the skin appearance rig of Jimenez et al. 2010 — build a basis from a neutral
//! hemoglobin map and targets, evaluate frames, animate weight curves, transfer to another
//! character, list the built-in expression library.

use crate::output::line;
use crate::progress::Bars;
use crate::DeviceArg;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_core::Map;
use derma_rig::maps::{melanin_for, read_map, read_optional, write_color, write_hemoglobin, Quantity};
use derma_rig::sequence::{render_sequence, FrameFormat, SequenceOptions};
use derma_rig::weights::frame_weights;
use derma_rig::{
    expression, rig_dir, BasisOptions, GlobalScale, Normalization, Rig, TargetSource, TargetSpec,
    TransferMode, WeightSpec,
};
use derma_shading::skin_color_lut::{LutOptions, SkinColorLut};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Subcommand)]
pub enum RigCommand {
    /// Build a rig: local statistics of the neutral map and each target → scale/bias basis.
    Build(BuildArgs),
    /// Evaluate one frame: weights → hemoglobin map → colour map.
    Eval(EvalArgs),
    /// Weight curves (CSV or JSON keyframes) → an image sequence of colour (and hemoglobin) maps.
    Animate(AnimateArgs),
    /// Apply a rig to another character's neutral hemoglobin map (appearance transfer).
    Transfer(TransferArgs),
    /// List the built-in expression library.
    Library,
}

/// A character's maps.
#[derive(Args)]
struct CharacterArgs {
    /// Neutral hemoglobin map H_n: EXR (dermal blood volume fraction; channel hemoglobin, blood,
    /// Y or the only one) or PNG (grey × the LUT's top, 0.32: Jimenez et al. 2010 table 1).
    #[arg(long)]
    neutral: PathBuf,
    /// Melanin map C_m (EXR volume fraction, or PNG grey × the LUT's top, 0.5), for colour output.
    #[arg(long)]
    melanin: Option<PathBuf>,
    /// Mask of the skin (grey, > 0 = skin): texels outside are left out of the statistics.
    #[arg(long)]
    mask: Option<PathBuf>,
}

impl CharacterArgs {
    fn paths(&self) -> Vec<&Path> {
        let mut v: Vec<&Path> = vec![&self.neutral];
        v.extend(self.melanin.as_deref());
        v.extend(self.mask.as_deref());
        v
    }

    /// (neutral, melanin, mask), PNGs scaled by `lut`'s axis tops.
    fn read(&self, lut: &LutOptions, bars: &Bars) -> Result<(Map, Option<Map>, Option<Map>)> {
        Ok((
            read_map(&self.neutral, Quantity::Hemoglobin, lut, bars)?,
            read_optional(self.melanin.as_deref(), Quantity::Melanin, lut, bars)?,
            read_optional(self.mask.as_deref(), Quantity::Mask, lut, bars)?,
        ))
    }
}

#[derive(Args)]
pub struct BuildArgs {
    #[command(flatten)]
    character: CharacterArgs,
    /// A measured or painted target hemoglobin map, aligned with the neutral: NAME=FILE (repeat).
    #[arg(long = "target", value_name = "NAME=FILE", value_parser = name_value::<PathBuf>)]
    targets: Vec<(String, PathBuf)>,
    /// Built-in library entries to add (comma-separated names, or "all"); they assume derma's
    /// face-template UV layout (e.g. maps from `derma skin`). See `derma rig library`.
    #[arg(long, value_delimiter = ',')]
    builtin: Vec<String>,
    /// Suggested global hemoglobin scale of a target at full weight: NAME=S (repeat).
    #[arg(long = "global", value_name = "NAME=S", value_parser = name_value::<f32>)]
    globals: Vec<(String, f32)>,
    /// Disk radius r of the local statistics, in texels of the neutral map.
    #[arg(long)]
    radius: f64,
    /// Resolution of the scale/bias textures (Jimenez et al. 2010 §6: 256); must divide the map.
    #[arg(long, default_value_t = derma_rig::basis::DEFAULT_BASIS_SIZE)]
    basis_size: usize,
    /// σ floor ε as a fraction of the neutral's RMS local σ (guards flat regions).
    #[arg(long, default_value_t = derma_rig::basis::DEFAULT_SIGMA_FLOOR)]
    sigma_floor: f32,
    /// Skin-colour LUT (.dtab from `derma match lut`); default: the built-in one.
    #[arg(long)]
    lut: Option<PathBuf>,
    /// Output rig directory.
    #[arg(long)]
    out: PathBuf,
}

/// Parses NAME=VALUE.
fn name_value<T: std::str::FromStr>(s: &str) -> std::result::Result<(String, T), String> {
    let (n, v) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}': expected NAME=VALUE"))?;
    let v = v
        .trim()
        .parse()
        .map_err(|_| format!("'{s}': '{}' is not a valid value", v.trim()))?;
    Ok((n.trim().to_string(), v))
}

#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    /// Keep the targets' local statistics (eq. 6 as written).
    Absolute,
    /// Carry each target's change relative to the source neutral over to the new character.
    Relative,
}

#[derive(Args)]
pub struct TransferArgs {
    /// Rig directory to transfer from.
    #[arg(long)]
    rig: PathBuf,
    /// The other character's maps.
    #[command(flatten)]
    character: CharacterArgs,
    #[arg(long, value_enum, default_value = "absolute")]
    mode: ModeArg,
    #[arg(long, default_value_t = derma_rig::basis::DEFAULT_SIGMA_FLOOR)]
    sigma_floor: f32,
    /// Output rig directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Clone)]
struct FrameOptions {
    /// Global hemoglobin scale: "auto" (blend of the targets' suggestions: anger 1.27, fear 0.81)
    /// or a factor.
    #[arg(long, default_value = "auto")]
    global_scale: GlobalScale,
    /// Rescale weights that sum to more than one instead of failing.
    #[arg(long)]
    normalize: bool,
    /// Melanin map to colour with (default: the rig's).
    #[arg(long)]
    melanin: Option<PathBuf>,
}

impl FrameOptions {
    fn normalization(&self) -> Normalization {
        if self.normalize {
            Normalization::Rescale
        } else {
            Normalization::NeutralTakesRest
        }
    }
}

#[derive(Args)]
pub struct EvalArgs {
    #[arg(long)]
    rig: PathBuf,
    /// Target weights NAME=W,… (the neutral takes the rest); empty = the neutral pose.
    #[arg(long, default_value = "")]
    weights: WeightSpec,
    #[command(flatten)]
    frame: FrameOptions,
    /// Colour map: .png (8-bit sRGB) or .exr (linear float RGB).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Hemoglobin map: .exr (volume fraction, channel hemoglobin) or .png (16-bit, value / 0.32).
    #[arg(long)]
    hemoglobin: Option<PathBuf>,
    /// Where to evaluate: the CPU's exact path, or the rig's `rig.wgsl` on a GPU.
    #[command(flatten)]
    device: DeviceArg,
    /// A preview: the face template rendered with the colour, beside its hemoglobin map (dark =
    /// more blood, as Jimenez et al. 2010 fig. 2). Needs maps on the template's UV layout.
    #[arg(long)]
    preview: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum FormatArg {
    /// 8-bit sRGB PNG through the real-time path.
    Png,
    /// Linear float RGB EXR through the exact path.
    Exr,
}

#[derive(Args)]
pub struct AnimateArgs {
    #[arg(long)]
    rig: PathBuf,
    /// Keyframed weights: CSV (time,NAME,…[,global_scale]) or JSON ({"fps", "curves", "global_scale"}).
    #[arg(long)]
    curves: PathBuf,
    /// Frames per second (default: the curves' fps, else 24).
    #[arg(long)]
    fps: Option<f64>,
    #[command(flatten)]
    frame: FrameOptions,
    #[arg(long, value_enum, default_value = "png")]
    format: FormatArg,
    /// Also write hemoglobin_NNNNN.exr per frame.
    #[arg(long)]
    hemoglobin: bool,
    /// Replace the frames of a different animation already in --out.
    #[arg(long)]
    force: bool,
    /// Output directory (re-running resumes: frames already written are kept).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(cmd: RigCommand, bars: &Bars) -> Result<()> {
    match cmd {
        RigCommand::Build(a) => build(a, bars),
        RigCommand::Eval(a) => eval(a, bars),
        RigCommand::Animate(a) => animate(a, bars),
        RigCommand::Transfer(a) => transfer(a, bars),
        RigCommand::Library => {
            for e in &expression::LIBRARY {
                line(format!(
                    "{:<10} {:<10} global ×{:<5} {}",
                    e.name,
                    format!("{:?}", e.kind).to_lowercase(),
                    e.global_scale,
                    e.notes
                ))?;
            }
            line("(authored approximations of Jimenez et al. 2010's observations on derma's face template, not measurements)")
        }
    }
}

/// Fails before any work when the rig directory `out` would hold an input.
fn check_out(out: &Path, inputs: &[&Path]) -> Result<()> {
    derma_core::atomic::ensure_writable_dir(out)?;
    derma_core::atomic::check_inputs_spared(&[out.to_path_buf()], inputs)?;
    Ok(())
}

fn load_lut(path: Option<&Path>) -> Result<SkinColorLut> {
    match path {
        None => Ok(SkinColorLut::builtin()),
        Some(p) => {
            let t = derma_core::dtab::Dtab::read(p)?;
            Ok(SkinColorLut::from_dtab(&t, &p.display().to_string())?)
        }
    }
}

fn build(a: BuildArgs, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    let mut inputs = a.character.paths();
    inputs.extend(a.targets.iter().map(|(_, p)| p.as_path()));
    check_out(&a.out, &inputs)?;
    let lut = load_lut(a.lut.as_deref())?;
    let (neutral, melanin, mask) = a.character.read(&lut.options, bars)?;
    let maps: Vec<(String, Map)> = a
        .targets
        .iter()
        .map(|(n, p)| {
            let m = read_map(p, Quantity::Hemoglobin, &lut.options, bars)
                .with_context(|| format!("target '{n}'"))?;
            Ok((n.clone(), m))
        })
        .collect::<Result<_>>()?;
    let global = |name: &str| a.globals.iter().find(|(n, _)| n == name).map(|g| g.1);
    let mut specs: Vec<TargetSpec> = maps
        .iter()
        .map(|(n, m)| TargetSpec {
            name: n.clone(),
            source: TargetSource::Map(m),
            global_scale: global(n),
        })
        .collect();
    for e in expression::select(&a.builtin)? {
        specs.push(TargetSpec {
            name: e.name.into(),
            source: TargetSource::Builtin(e),
            global_scale: global(e.name),
        });
    }
    if let Some((n, _)) = a.globals.iter().find(|(n, _)| !specs.iter().any(|s| &s.name == n)) {
        bail!("--global '{n}=…': no target of that name");
    }
    if specs.is_empty() {
        bail!("no targets: give --target NAME=FILE and/or --builtin NAMES|all");
    }
    let opts = BasisOptions {
        radius: a.radius,
        basis_size: (a.basis_size, a.basis_size),
        sigma_floor: a.sigma_floor,
    };
    let t_read = t0.elapsed();
    let t1 = Instant::now();
    let rig = Rig::build(&neutral, mask.as_ref(), melanin, &specs, &opts)?;
    let t_build = t1.elapsed();
    let json = rig_dir::save(&rig, &lut, &a.out)?;
    let (w, h) = rig.size();
    bars.say(format!(
        "rig: {} targets ({}), {w}×{h} maps, basis {}×{}, r = {} texels, σ floor {:.3e}; read {:.2} s, basis {:.3} s, total {:.2} s → {}",
        json.targets.len(),
        json.targets.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", "),
        json.basis_size[0],
        json.basis_size[1],
        a.radius,
        rig.sigma_floor,
        t_read.as_secs_f64(),
        t_build.as_secs_f64(),
        t0.elapsed().as_secs_f64(),
        a.out.display()
    ));
    Ok(())
}

fn transfer(a: TransferArgs, bars: &Bars) -> Result<()> {
    let mut inputs = a.character.paths();
    inputs.push(&a.rig);
    check_out(&a.out, &inputs)?;
    let (rig, lut, _) = rig_dir::load(&a.rig)?;
    let (neutral, melanin, mask) = a.character.read(&lut.options, bars)?;
    let mode = match a.mode {
        ModeArg::Absolute => TransferMode::Absolute,
        ModeArg::Relative => TransferMode::Relative,
    };
    let moved = rig.transfer(&neutral, mask.as_ref(), melanin, mode, a.sigma_floor)?;
    rig_dir::save(&moved, &lut, &a.out)?;
    bars.say(format!(
        "transferred {} targets onto '{}' → {}",
        moved.targets.len(),
        a.character.neutral.display(),
        a.out.display()
    ));
    Ok(())
}

fn eval(a: EvalArgs, bars: &Bars) -> Result<()> {
    if a.out.is_none() && a.hemoglobin.is_none() && a.preview.is_none() {
        bail!("nothing to write: give --out (colour), --hemoglobin and/or --preview");
    }
    let (rig, lut, _) = rig_dir::load(&a.rig)?;
    let (w, g) = frame_weights(
        &rig,
        &a.weights,
        a.frame.normalization(),
        a.frame.global_scale,
    )?;
    let wants_color = a.out.is_some() || a.preview.is_some();
    let melanin = wants_color
        .then(|| melanin_for(&rig, a.frame.melanin.as_deref(), &lut.options, bars))
        .transpose()?;
    let (h, rgb) = derma_rig::evaluate::evaluate_frame(
        &rig,
        &lut,
        &w,
        g,
        melanin.as_ref(),
        a.device.device,
    )?;
    if let Some(p) = &a.hemoglobin {
        write_hemoglobin(p, &h, &lut.options)?;
    }
    if let Some(rgb) = &rgb {
        if let Some(p) = &a.out {
            write_color(p, rgb)?;
        }
        if let Some(p) = &a.preview {
            derma_rig::preview::write_preview(p, rgb, &h)?;
        }
    }
    line(format!(
        "weights: neutral={:.4}{} global scale {g:.4}",
        w[0],
        rig.targets
            .iter()
            .zip(&w[1..])
            .filter(|(_, x)| **x > 0.0)
            .map(|(t, x)| format!(", {}={x:.4}", t.name))
            .collect::<String>()
    ))
}

fn animate(a: AnimateArgs, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    check_out(&a.out, &[&a.rig, &a.curves])?;
    let opts = SequenceOptions {
        fps: a.fps,
        format: match a.format {
            FormatArg::Png => FrameFormat::Png,
            FormatArg::Exr => FrameFormat::Exr,
        },
        hemoglobin: a.hemoglobin,
        force: a.force,
        normalization: a.frame.normalization(),
        global_scale: a.frame.global_scale,
        melanin: a.frame.melanin.clone(),
    };
    let run = render_sequence(&a.rig, &a.curves, &opts, &a.out, bars)?;
    bars.finish();
    bars.say(format!(
        "{} frames at {} fps ({} already there) in {:.2} s → {}",
        run.frames,
        run.fps,
        run.kept,
        t0.elapsed().as_secs_f64(),
        a.out.display()
    ));
    Ok(())
}
