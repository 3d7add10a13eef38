//! The flags of `derma rig …`, defined once with their help text (the commands are in
//! `rig.rs`).

use crate::args::DeviceArg;
use clap::{Args, Subcommand, ValueEnum};
use derma_rig::from_files::{CharacterFiles, SetFiles};
use derma_rig::{GlobalScale, Normalization, WeightSpec};
use std::path::PathBuf;

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
pub struct CharacterArgs {
    /// A texture set from `derma skin`: its hemoglobin and melanin maps, and its skin, which
    /// every frame keeps (the base colour re-shaded with the frame's hemoglobin).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["neutral", "melanin"])]
    pub set: Option<PathBuf>,
    /// The match table the --set was made with (`derma skin --table`), when not the built-in one.
    #[arg(long, value_name = "FILE.dtab", requires = "set")]
    pub table: Option<PathBuf>,
    /// Neutral hemoglobin map H_n, without a set: EXR (dermal blood volume fraction; channel
    /// hemoglobin, blood, Y or the only one) or PNG (grey × the LUT's top, 0.32: Jimenez et al.
    /// 2010 table 1). Frames are then the LUT's colour.
    #[arg(long, required_unless_present = "set")]
    pub neutral: Option<PathBuf>,
    /// Melanin map C_m (EXR volume fraction, or PNG grey × the LUT's top, 0.5), for colour output.
    #[arg(long)]
    pub melanin: Option<PathBuf>,
    /// Mask of the skin (grey, > 0 = skin): texels outside are left out of the statistics.
    #[arg(long)]
    pub mask: Option<PathBuf>,
}

impl CharacterArgs {
    pub fn files(&self) -> CharacterFiles {
        match &self.set {
            Some(dir) => CharacterFiles::of_set(
                SetFiles {
                    dir: dir.clone(),
                    table: self.table.clone(),
                },
                self.mask.clone(),
            ),
            None => CharacterFiles {
                neutral: self.neutral.clone().expect("clap: --neutral or --set"),
                melanin: self.melanin.clone(),
                mask: self.mask.clone(),
                set: None,
            },
        }
    }
}

#[derive(Args)]
pub struct BuildArgs {
    #[command(flatten)]
    pub character: CharacterArgs,
    /// A measured or painted target hemoglobin map, aligned with the neutral: NAME=FILE (repeat).
    #[arg(long = "target", value_name = "NAME=FILE", value_parser = crate::args::named_file)]
    pub targets: Vec<(String, PathBuf)>,
    /// Built-in library entries to add (comma-separated names, or "all"), placed on derma's
    /// UV layout (maps from `derma skin`, also on a fitted head), or with --mesh on yours. See
    /// `derma rig library`.
    #[arg(long, value_delimiter = ',')]
    pub builtin: Vec<String>,
    #[command(flatten)]
    pub head: crate::args::HeadArg,
    /// The mesh (with its own UVs) the maps were painted on (`derma skin --mesh M --head DIR`):
    /// the built-in entries are placed on it through the --head fitted to it.
    #[arg(long, requires = "head")]
    pub mesh: Option<PathBuf>,
    /// Suggested global hemoglobin scale of a target at full weight: NAME=S (repeat).
    #[arg(long = "global", value_name = "NAME=S", value_parser = crate::args::named_number)]
    pub globals: Vec<(String, f32)>,
    /// Disk radius r of the local statistics, in texels of the neutral map.
    #[arg(long)]
    pub radius: f64,
    /// Resolution of the scale/bias textures (Jimenez et al. 2010 §6: 256); must divide the map.
    #[arg(long, default_value_t = derma_rig::basis::DEFAULT_BASIS_SIZE)]
    pub basis_size: usize,
    /// σ floor ε as a fraction of the neutral's RMS local σ (guards flat regions).
    #[arg(long, default_value_t = derma_rig::basis::DEFAULT_SIGMA_FLOOR)]
    pub sigma_floor: f32,
    /// Skin-colour LUT (.dtab from `derma match lut`); default: the built-in one.
    #[arg(long)]
    pub lut: Option<PathBuf>,
    /// Output rig directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ModeArg {
    /// Keep the targets' local statistics (eq. 6 as written).
    Absolute,
    /// Carry each target's change relative to the source neutral over to the new character.
    Relative,
}

#[derive(Args)]
pub struct TransferArgs {
    /// Rig directory to transfer from.
    #[arg(long)]
    pub rig: PathBuf,
    /// The other character's maps.
    #[command(flatten)]
    pub character: CharacterArgs,
    #[arg(long, value_enum, default_value = "absolute")]
    pub mode: ModeArg,
    #[arg(long, default_value_t = derma_rig::basis::DEFAULT_SIGMA_FLOOR)]
    pub sigma_floor: f32,
    /// Output rig directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args, Clone)]
pub struct FrameOptions {
    /// Global hemoglobin scale: "auto" (blend of the targets' suggestions: anger 1.27, fear 0.81)
    /// or a factor.
    #[arg(long, default_value = "auto")]
    pub global_scale: GlobalScale,
    /// Rescale weights that sum to more than one instead of failing.
    #[arg(long)]
    pub normalize: bool,
    /// Melanin map to colour with (default: the rig's).
    #[arg(long)]
    pub melanin: Option<PathBuf>,
}

impl FrameOptions {
    pub fn normalization(&self) -> Normalization {
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
    pub rig: PathBuf,
    /// Target weights NAME=W,… (the neutral takes the rest); empty = the neutral pose.
    #[arg(long, default_value = "")]
    pub weights: WeightSpec,
    #[command(flatten)]
    pub frame: FrameOptions,
    /// Colour map: .png (8-bit sRGB) or .exr (linear float RGB).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Hemoglobin map: .exr (volume fraction, channel hemoglobin) or .png (16-bit, value / 0.32).
    #[arg(long)]
    pub hemoglobin: Option<PathBuf>,
    /// Where to evaluate: the CPU's exact path, or the rig's `rig.wgsl` on a GPU.
    #[command(flatten)]
    pub device: DeviceArg,
    /// A preview: the built-in head rendered with the colour, beside its hemoglobin map (dark =
    /// more blood, as Jimenez et al. 2010 fig. 2). Needs maps on the head's UV layout.
    #[arg(long)]
    pub preview: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
pub enum FormatArg {
    /// 8-bit sRGB PNG through the real-time path.
    Png,
    /// Linear float RGB EXR through the exact path.
    Exr,
}

#[derive(Args)]
pub struct AnimateArgs {
    #[arg(long)]
    pub rig: PathBuf,
    /// Keyframed weights: CSV (time,NAME,…[,global_scale]) or JSON ({"fps", "curves", "global_scale"}).
    #[arg(long)]
    pub curves: PathBuf,
    /// Frames per second (default: the curves' fps, else 24).
    #[arg(long)]
    pub fps: Option<f64>,
    #[command(flatten)]
    pub frame: FrameOptions,
    #[arg(long, value_enum, default_value = "png")]
    pub format: FormatArg,
    /// Also write hemoglobin_NNNNN.exr per frame.
    #[arg(long)]
    pub hemoglobin: bool,
    /// Replace the frames of a different animation already in --out.
    #[arg(long)]
    pub force: bool,
    /// Output directory (re-running resumes: frames already written are kept).
    #[arg(long)]
    pub out: PathBuf,
}
