//! `derma rig …`: the skin appearance rig of Jimenez et al. 2010 — build a basis from a neutral
//! hemoglobin map and targets, evaluate frames, animate weight curves, transfer to another
//! character, list the built-in expression library.

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use derma_core::image_io::{
    read_exr_channels, read_grey, write_exr, write_png16, write_png8_srgb, ExrPrecision,
};
use derma_core::Map;
use derma_rig::evaluate::{color, hemoglobin, unpack_rgba8, FramePlan};
use derma_rig::weights::{global_scale, resolve};
use derma_rig::{
    expression, rig_dir, BasisOptions, GlobalScale, Normalization, Rig, TargetSource, TargetSpec,
    TransferMode, WeightSpec,
};
use derma_shading::skin_color_lut::SkinColorLut;
use sha2::Digest;
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
    /// Neutral hemoglobin map H_n: EXR (dermal blood volume fraction; channel blood, hemoglobin,
    /// Y or the only one) or PNG (grey × 0.32, the LUT's top, Jimenez et al. 2010 table 1).
    #[arg(long)]
    neutral: PathBuf,
    /// Melanin map C_m (EXR volume fraction, or PNG grey × 0.5), for colour output.
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

    /// (neutral, melanin, mask).
    fn read(&self) -> Result<(Map, Option<Map>, Option<Map>)> {
        Ok((
            read_map(&self.neutral, Quantity::Hemoglobin)?,
            read_optional(self.melanin.as_deref(), Quantity::Melanin)?,
            read_optional(self.mask.as_deref(), Quantity::Mask)?,
        ))
    }
}

#[derive(Args)]
pub struct BuildArgs {
    #[command(flatten)]
    character: CharacterArgs,
    /// A measured or painted target hemoglobin map, aligned with the neutral: NAME=FILE (repeat).
    #[arg(long = "target", value_name = "NAME=FILE")]
    targets: Vec<String>,
    /// Built-in library entries to add (comma-separated names, or "all"); they assume derma's
    /// face-template UV layout (e.g. maps from `derma skin`). See `derma rig library`.
    #[arg(long, value_delimiter = ',')]
    builtin: Vec<String>,
    /// Suggested global hemoglobin scale of a target at full weight: NAME=S (repeat).
    #[arg(long = "global", value_name = "NAME=S")]
    globals: Vec<String>,
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
    global_scale: String,
    /// Rescale weights that sum to more than one instead of failing.
    #[arg(long)]
    normalize: bool,
    /// Melanin map to colour with (default: the rig's).
    #[arg(long)]
    melanin: Option<PathBuf>,
}

#[derive(Args)]
pub struct EvalArgs {
    #[arg(long)]
    rig: PathBuf,
    /// Target weights NAME=W,… (the neutral takes the rest); empty = the neutral pose.
    #[arg(long, default_value = "")]
    weights: String,
    #[command(flatten)]
    frame: FrameOptions,
    /// Colour map: .png (8-bit sRGB) or .exr (linear float RGB).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Hemoglobin map: .exr (volume fraction, channel blood) or .png (16-bit, value / 0.32).
    #[arg(long)]
    hemoglobin: Option<PathBuf>,
    /// Where to evaluate: cpu, or gpu (the rig's `rig.wgsl` on wgpu).
    #[arg(long, value_enum, default_value = "cpu")]
    device: DeviceArg,
    /// A preview: the face template rendered with the colour, beside its hemoglobin map (dark =
    /// more blood, as Jimenez et al. 2010 fig. 2). Needs maps on the template's UV layout.
    #[arg(long)]
    preview: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum DeviceArg {
    Cpu,
    Gpu,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum FrameFormat {
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
    format: FrameFormat,
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

pub fn run(cmd: RigCommand, quiet: bool) -> Result<()> {
    match cmd {
        RigCommand::Build(a) => build(a, quiet),
        RigCommand::Eval(a) => eval(a),
        RigCommand::Animate(a) => animate(a, quiet),
        RigCommand::Transfer(a) => transfer(a, quiet),
        RigCommand::Library => {
            for e in &expression::LIBRARY {
                println!(
                    "{:<10} {:<10} global ×{:<5} {}",
                    e.name,
                    format!("{:?}", e.kind).to_lowercase(),
                    e.global_scale,
                    e.notes
                );
            }
            println!("(authored approximations of Jimenez et al. 2010's observations on derma's face template, not measurements)");
            Ok(())
        }
    }
}

/// Which quantity a map holds, for reading it.
#[derive(Clone, Copy)]
enum Quantity {
    Hemoglobin,
    Melanin,
    Mask,
}

impl Quantity {
    fn channels(self) -> &'static [&'static str] {
        match self {
            Quantity::Hemoglobin => &["blood", "hemoglobin", "Y", "R"],
            Quantity::Melanin => &["melanin", "Y", "R"],
            Quantity::Mask => &["mask", "Y", "A", "R"],
        }
    }
    /// PNG grey 1 ↔ this value: the LUT's axis tops (Jimenez et al. 2010 table 1).
    fn png_scale(self) -> f32 {
        match self {
            Quantity::Hemoglobin => 0.32,
            Quantity::Melanin => 0.5,
            Quantity::Mask => 1.0,
        }
    }
}

/// Reads a scalar map: EXR by channel name, other images as grey × the quantity's scale.
fn read_map(path: &Path, q: Quantity) -> Result<Map> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        let chans = read_exr_channels(path)?;
        if chans.len() == 1 {
            return Ok(chans.into_iter().next().expect("one").1);
        }
        for want in q.channels() {
            if let Some((_, m)) = chans.iter().find(|(n, _)| n.eq_ignore_ascii_case(want)) {
                return Ok(m.clone());
            }
        }
        bail!(
            "'{}': none of the channels {:?} found; it has {:?}",
            path.display(),
            q.channels(),
            chans.iter().map(|c| c.0.as_str()).collect::<Vec<_>>()
        );
    }
    let img = read_grey(path)?;
    if img.is_colour {
        tracing::warn!(
            "'{}' is a colour image; using its luminance",
            path.display()
        );
    }
    let m = img.channels.into_iter().next().expect("grey");
    let s = q.png_scale();
    Ok(Map::from_vec(
        m.width(),
        m.height(),
        m.data().iter().map(|v| v * s).collect(),
    )?)
}

/// [`read_map`] of an optional path.
fn read_optional(path: Option<&Path>, q: Quantity) -> Result<Option<Map>> {
    path.map(|p| read_map(p, q)).transpose()
}

/// Refuses outputs that would overwrite an input.
fn check_inputs_outside(out: &Path, inputs: &[&Path]) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create '{}'", out.display()))?;
    let out = out.canonicalize()?;
    for i in inputs {
        if let Ok(c) = i.canonicalize() {
            if c.starts_with(&out) {
                bail!(
                    "input '{}' lies inside the output directory '{}'; derma never writes over its inputs — pick another --out",
                    i.display(),
                    out.display()
                );
            }
        }
    }
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

fn build(a: BuildArgs, quiet: bool) -> Result<()> {
    let t0 = Instant::now();
    let mut inputs = a.character.paths();
    let parsed: Vec<(String, PathBuf)> = a
        .targets
        .iter()
        .map(|t| {
            t.split_once('=')
                .map(|(n, f)| (n.trim().to_string(), PathBuf::from(f.trim())))
                .with_context(|| format!("--target '{t}': expected NAME=FILE"))
        })
        .collect::<Result<_>>()?;
    for (_, p) in &parsed {
        inputs.push(p);
    }
    check_inputs_outside(&a.out, &inputs)?;
    let lut = load_lut(a.lut.as_deref())?;
    let (neutral, melanin, mask) = a.character.read()?;
    let maps: Vec<(String, Map)> = parsed
        .iter()
        .map(|(n, p)| {
            Ok((
                n.clone(),
                read_map(p, Quantity::Hemoglobin).with_context(|| format!("target '{n}'"))?,
            ))
        })
        .collect::<Result<_>>()?;
    let mut globals = std::collections::HashMap::new();
    for g in &a.globals {
        let (n, s) = g
            .split_once('=')
            .with_context(|| format!("--global '{g}': expected NAME=S"))?;
        let s: f32 = s
            .trim()
            .parse()
            .with_context(|| format!("--global '{g}': '{s}' is not a number"))?;
        globals.insert(n.trim().to_string(), s);
    }
    let mut specs: Vec<TargetSpec> = maps
        .iter()
        .map(|(n, m)| TargetSpec {
            name: n.clone(),
            source: TargetSource::Map(m),
            global_scale: globals.get(n).copied(),
        })
        .collect();
    let builtin: Vec<&'static expression::Expression> = if a.builtin.iter().any(|b| b == "all") {
        expression::LIBRARY.iter().collect()
    } else {
        a.builtin
            .iter()
            .filter(|b| !b.is_empty())
            .map(|b| {
                expression::find(b).with_context(|| {
                    format!(
                        "--builtin '{b}': not in the library ({})",
                        expression::LIBRARY
                            .iter()
                            .map(|e| e.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })
            })
            .collect::<Result<_>>()?
    };
    for e in builtin {
        specs.push(TargetSpec {
            name: e.name.into(),
            source: TargetSource::Builtin(e),
            global_scale: globals.get(e.name).copied(),
        });
    }
    for n in globals.keys() {
        if !specs.iter().any(|s| &s.name == n) {
            bail!("--global '{n}=…': no target of that name");
        }
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
    if !quiet {
        let (w, h) = rig.size();
        eprintln!(
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
        );
    }
    Ok(())
}

fn transfer(a: TransferArgs, quiet: bool) -> Result<()> {
    let mut inputs = a.character.paths();
    inputs.push(&a.rig);
    check_inputs_outside(&a.out, &inputs)?;
    let (rig, lut, _) = rig_dir::load(&a.rig)?;
    let (neutral, melanin, mask) = a.character.read()?;
    let mode = match a.mode {
        ModeArg::Absolute => TransferMode::Absolute,
        ModeArg::Relative => TransferMode::Relative,
    };
    let moved = rig.transfer(&neutral, mask.as_ref(), melanin, mode, a.sigma_floor)?;
    rig_dir::save(&moved, &lut, &a.out)?;
    if !quiet {
        eprintln!(
            "transferred {} targets onto '{}' → {}",
            moved.targets.len(),
            a.character.neutral.display(),
            a.out.display()
        );
    }
    Ok(())
}

/// Weights w_0… and the global scale of one frame.
fn frame_weights(
    rig: &Rig,
    spec: &WeightSpec,
    opts: &FrameOptions,
    scale_override: Option<f32>,
) -> Result<(Vec<f32>, f32)> {
    let names: Vec<&str> = rig.targets.iter().map(|t| t.name.as_str()).collect();
    let norm = if opts.normalize {
        Normalization::Rescale
    } else {
        Normalization::NeutralTakesRest
    };
    let w = resolve(&names, spec, norm)?;
    let g = match scale_override {
        Some(s) => s,
        None => {
            let gs: GlobalScale = opts.global_scale.parse()?;
            let suggested: Vec<f32> = rig.targets.iter().map(|t| t.global_scale).collect();
            global_scale(gs, &w, &suggested)
        }
    };
    Ok((w, g))
}

fn melanin_for(rig: &Rig, opts: &FrameOptions) -> Result<Option<Map>> {
    match &opts.melanin {
        Some(p) => {
            let m = read_map(p, Quantity::Melanin)?;
            if (m.width(), m.height()) != rig.size() {
                bail!(
                    "melanin '{}' is {}×{}; the rig's maps are {}×{}",
                    p.display(),
                    m.width(),
                    m.height(),
                    rig.size().0,
                    rig.size().1
                );
            }
            Ok(Some(m))
        }
        None => Ok(rig.melanin.clone()),
    }
}

fn is_exr(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

fn write_color(path: &Path, rgb: &[Map; 3]) -> Result<()> {
    if is_exr(path) {
        write_exr(
            path,
            &[("R", &rgb[0]), ("G", &rgb[1]), ("B", &rgb[2])],
            ExrPrecision::F32,
        )?;
    } else {
        write_png8_srgb(path, &[&rgb[0], &rgb[1], &rgb[2]])?;
    }
    Ok(())
}

fn write_hemoglobin(path: &Path, h: &Map) -> Result<()> {
    if is_exr(path) {
        write_exr(path, &[("blood", h)], ExrPrecision::F32)?;
    } else {
        let v = Map::from_vec(
            h.width(),
            h.height(),
            h.data().iter().map(|x| x / 0.32).collect(),
        )?;
        write_png16(path, &[&v])?;
    }
    Ok(())
}

fn no_melanin() -> anyhow::Error {
    anyhow::anyhow!("the rig has no melanin map for colour; pass --melanin FILE (or build the rig with --melanin)")
}

fn eval(a: EvalArgs) -> Result<()> {
    if a.out.is_none() && a.hemoglobin.is_none() && a.preview.is_none() {
        bail!("nothing to write: give --out (colour), --hemoglobin and/or --preview");
    }
    let (rig, lut, _) = rig_dir::load(&a.rig)?;
    let spec: WeightSpec = a.weights.parse()?;
    let (w, g) = frame_weights(&rig, &spec, &a.frame, None)?;
    let wants_colour = a.out.is_some() || a.preview.is_some();
    let mel = melanin_for(&rig, &a.frame)?;
    if wants_colour && mel.is_none() {
        return Err(no_melanin());
    }
    let (h, rgb) = match a.device {
        DeviceArg::Cpu => {
            let h = hemoglobin(&rig, &w, g)?;
            let rgb = match (&mel, wants_colour) {
                (Some(m), true) => Some(color(&h, m, &lut)?),
                _ => None,
            };
            (h, rgb)
        }
        DeviceArg::Gpu => {
            // Without melanin only the hemoglobin is wanted; colour with C_m = 0 is discarded.
            let m = mel.unwrap_or_else(|| Map::filled(rig.size().0, rig.size().1, 0.0));
            let (h, rgb) = derma_rig::gpu_eval::GpuRig::new(&rig, &m, &lut)?.render(&w, g)?;
            (h, wants_colour.then_some(rgb))
        }
    };
    if let Some(p) = &a.hemoglobin {
        write_hemoglobin(p, &h)?;
    }
    if let Some(rgb) = &rgb {
        if let Some(p) = &a.out {
            write_color(p, rgb)?;
        }
        if let Some(p) = &a.preview {
            let img = preview(rgb, &h)?;
            write_png8_srgb(p, &[&img[0], &img[1], &img[2]])?;
        }
    }
    println!(
        "weights: neutral={:.4}{} global scale {g:.4}",
        w[0],
        rig.targets
            .iter()
            .zip(&w[1..])
            .filter(|(_, x)| **x > 0.0)
            .map(|(t, x)| format!(", {}={x:.4}", t.name))
            .collect::<String>()
    );
    Ok(())
}

/// Top of the preview's hemoglobin scale (volume fraction): grey = 1 − H / PREVIEW_BLOOD_TOP,
/// dark = more blood, clipped (lips and moles saturate so the face's variation shows).
const PREVIEW_BLOOD_TOP: f32 = 0.03;

/// The template head rendered with `rgb` as base colour, and again with the hemoglobin map as
/// display grey (dark = more blood), side by side (linear RGB).
fn preview(rgb: &[Map; 3], h: &Map) -> Result<[Map; 3]> {
    use derma_skin::preview::render;
    use derma_skin::texture_set::RenderMaps;
    const PANEL: usize = 512;
    let mesh = derma_skin::template::head_mesh();
    let tangents = derma_skin::surface::mikktspace_tangents(&mesh);
    let (w, hh) = (h.width(), h.height());
    let flat = |v: f32| Map::filled(w, hh, v);
    let maps = |base: [Map; 3]| RenderMaps {
        base_color: base,
        // Skin-like specular (F0 2.8 %, Kelemen/Jimenez) and roughness, flat normals.
        roughness: flat(0.45),
        specular: flat(0.35),
        normal: [flat(0.0), flat(0.0), flat(1.0)],
        height_mm: flat(0.0),
        subsurface: None,
    };
    let shade = |m: &RenderMaps| {
        render(
            &mesh,
            &tangents,
            &derma_skin::preview::Textures {
                maps: m,
                wrap: false,
                uv_scale: glam::Vec2::ONE,
            },
            0.0,
            PANEL,
        )
    };
    let colour = shade(&maps(rgb.clone()));
    let grey = Map::from_vec(
        w,
        hh,
        h.data()
            .iter()
            .map(|v| derma_core::color::srgb_decode((1.0 - v / PREVIEW_BLOOD_TOP).clamp(0.0, 1.0)))
            .collect(),
    )?;
    let blood = shade(&maps([grey.clone(), grey.clone(), grey]));
    Ok([0, 1, 2].map(|k| {
        let mut out = Map::filled(2 * PANEL, PANEL, 0.0);
        for y in 0..PANEL {
            for x in 0..PANEL {
                out.set(x, y, colour[k].get(x, y));
                out.set(PANEL + x, y, blood[k].get(x, y));
            }
        }
        out
    }))
}

#[derive(serde::Serialize, serde::Deserialize, PartialEq)]
struct AnimationJson {
    /// SHA-256 over the rig.json, the curves file and the frame options.
    key: String,
    fps: f64,
    format: String,
    frames: Vec<FrameJson>,
}

#[derive(serde::Serialize, serde::Deserialize, PartialEq)]
struct FrameJson {
    index: usize,
    time: f64,
    weights: Vec<(String, f32)>,
    global_scale: f32,
    files: Vec<String>,
}

fn animate(a: AnimateArgs, quiet: bool) -> Result<()> {
    let t0 = Instant::now();
    check_inputs_outside(&a.out, &[&a.rig, &a.curves])?;
    let (rig, lut, _) = rig_dir::load(&a.rig)?;
    let curves = derma_rig::animation::Curves::read(&a.curves)?;
    let fps = a.fps.or(curves.fps).unwrap_or(24.0);
    if !(fps.is_finite() && fps > 0.0) {
        bail!("--fps {fps}: expected a positive rate");
    }
    for (n, _) in &curves.weights {
        if n != "neutral" && rig.target_index(n).is_none() {
            bail!(
                "curve '{n}' in '{}' names no target of the rig ({})",
                a.curves.display(),
                rig.targets
                    .iter()
                    .map(|t| t.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let mel = melanin_for(&rig, &a.frame)?.ok_or_else(no_melanin)?;
    let times = curves.frame_times(fps);
    let fmt = if a.format == FrameFormat::Png {
        "png"
    } else {
        "exr"
    };
    let mut frames = Vec::with_capacity(times.len());
    for (k, &t) in times.iter().enumerate() {
        let spec = curves.weights_at(t);
        let (w, g) = frame_weights(
            &rig,
            &spec,
            &a.frame,
            curves.global_scale.as_ref().map(|c| c.at(t)),
        )
        .with_context(|| format!("frame {k} (t = {t:.3} s)"))?;
        let mut files = vec![format!("color_{k:05}.{fmt}")];
        if a.hemoglobin {
            files.push(format!("hemoglobin_{k:05}.exr"));
        }
        let mut names = vec![("neutral".to_string(), w[0])];
        names.extend(
            rig.targets
                .iter()
                .zip(&w[1..])
                .map(|(t, x)| (t.name.clone(), *x)),
        );
        frames.push(FrameJson {
            index: k,
            time: t,
            weights: names,
            global_scale: g,
            files,
        });
    }
    let key = {
        let mut h = sha2::Sha256::new();
        h.update(std::fs::read(a.rig.join("rig.json"))?);
        h.update(std::fs::read(&a.curves)?);
        h.update(
            format!(
                "{fps} {fmt} {} {} {:?}",
                a.hemoglobin, a.frame.global_scale, a.frame.melanin
            )
            .as_bytes(),
        );
        format!("{:x}", h.finalize())
    };
    let json = AnimationJson {
        key: key.clone(),
        fps,
        format: fmt.into(),
        frames,
    };
    let jp = a.out.join("animation.json");
    if let Ok(old) = std::fs::read_to_string(&jp) {
        let same = serde_json::from_str::<AnimationJson>(&old).is_ok_and(|o| o.key == key);
        if !same && !a.force {
            bail!(
                "'{}' holds frames of a different animation (rig, curves or options changed); use --force to replace them, or another --out",
                a.out.display()
            );
        }
        if !same {
            for f in json.frames.iter().flat_map(|f| &f.files) {
                let _ = std::fs::remove_file(a.out.join(f));
            }
        }
    }
    derma_core::atomic::write_bytes(&jp, serde_json::to_string_pretty(&json)?.as_bytes())?;
    let mut plan = (a.format == FrameFormat::Png)
        .then(|| FramePlan::new(&rig, &mel, &lut))
        .transpose()?;
    let (fw, fh) = rig.size();
    let mut buf = vec![0u32; fw * fh];
    let bar = crate::optics::progress_bar(json.frames.len() as u64, quiet, "frames", "frames");
    let mut skipped = 0;
    for f in &json.frames {
        if f.files.iter().all(|n| a.out.join(n).exists()) {
            skipped += 1;
        } else {
            let w: Vec<f32> = f.weights.iter().map(|x| x.1).collect();
            let cp = a.out.join(&f.files[0]);
            match &mut plan {
                Some(p) => {
                    p.render(&rig, &w, f.global_scale, &mut buf)?;
                    let rgb = unpack_rgba8(&buf, fw, fh);
                    derma_core::image_io::write_png8(&cp, &[&rgb[0], &rgb[1], &rgb[2]])?;
                    if a.hemoglobin {
                        write_hemoglobin(
                            &a.out.join(&f.files[1]),
                            &hemoglobin(&rig, &w, f.global_scale)?,
                        )?;
                    }
                }
                None => {
                    let h = hemoglobin(&rig, &w, f.global_scale)?;
                    write_color(&cp, &color(&h, &mel, &lut)?)?;
                    if a.hemoglobin {
                        write_hemoglobin(&a.out.join(&f.files[1]), &h)?;
                    }
                }
            }
        }
        if let Some(b) = &bar {
            b.inc(1);
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if !quiet {
        eprintln!(
            "{} frames at {fps} fps ({} already there) in {:.2} s → {}",
            json.frames.len(),
            skipped,
            t0.elapsed().as_secs_f64(),
            a.out.display()
        );
    }
    Ok(())
}
