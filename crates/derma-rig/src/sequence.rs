//! An animation rendered to an image sequence (Jimenez et al. 2010 §6: the rig evaluated per
//! frame from keyframed weights): colour frames (and hemoglobin maps) plus `animation.json`
//! listing every frame's weights. Resumable: rerunning keeps the frames already written, and a
//! directory holding another animation (rig, curves or options changed) is refused unless the
//! caller forces a restart.

use crate::animation::Curves;
use crate::basis::Rig;
use crate::error::{invalid, Result, RigError};
use crate::evaluate::{frame_color, hemoglobin, unpack_rgba8, FramePlan};
use crate::maps::{melanin_for, write_color, write_hemoglobin};
use crate::weights::{frame_weights, GlobalScale, Normalization};
use derma_core::progress::{Progress, Unit};
use serde::{Deserialize, Serialize};
use sha2::Digest;
use std::path::{Path, PathBuf};

/// Most frames of one sequence: 11.5 hours at 24 fps (a key time in milliseconds read as
/// seconds would otherwise ask for billions).
pub const MAX_FRAMES: usize = 1_000_000;

/// The format of the colour frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrameFormat {
    /// 8-bit sRGB PNG through the real-time path ([`FramePlan`]).
    #[default]
    Png,
    /// Linear float RGB EXR through the exact path.
    Exr,
}

impl FrameFormat {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            FrameFormat::Png => "png",
            FrameFormat::Exr => "exr",
        }
    }
}

/// How to render a sequence.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SequenceOptions {
    /// Frames per second (default: the curves' own, else 24).
    pub fps: Option<f64>,
    /// Colour frame format.
    pub format: FrameFormat,
    /// Also write `hemoglobin_NNNNN.exr` per frame.
    pub hemoglobin: bool,
    /// Replace the frames of a different animation already in the directory.
    pub force: bool,
    /// Weights that sum to more than one: an error, or rescaled.
    pub normalization: Normalization,
    /// Global scale when the curves have none (default [`GlobalScale::Auto`]).
    pub global_scale: GlobalScale,
    /// A melanin map to colour with instead of the rig's.
    pub melanin: Option<PathBuf>,
}

/// `animation.json`: the key of the inputs and every frame.
#[derive(Serialize, Deserialize, PartialEq)]
struct AnimationJson {
    /// SHA-256 over the rig.json, the curves file and the frame options.
    key: String,
    fps: f64,
    format: String,
    frames: Vec<FrameJson>,
}

#[derive(Serialize, Deserialize, PartialEq)]
struct FrameJson {
    index: usize,
    time: f64,
    weights: Vec<(String, f32)>,
    global_scale: f32,
    files: Vec<String>,
}

/// What [`render_sequence`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SequenceRun {
    /// Frames in the animation.
    pub frames: usize,
    /// Of those, frames already in the directory (kept).
    pub kept: usize,
    /// The frame rate used.
    pub fps: f64,
}

/// Renders the curves at `curves_path` with the rig in `rig_dir` into `out` (one stage of
/// frames).
pub fn render_sequence(
    rig_dir: &Path,
    curves_path: &Path,
    opts: &SequenceOptions,
    out: &Path,
    progress: &dyn Progress,
) -> Result<SequenceRun> {
    let (rig, lut, _) = crate::rig_dir::load(rig_dir)?;
    let curves = Curves::read(curves_path)?;
    let fps = opts.fps.or(curves.fps).unwrap_or(24.0);
    if !(fps.is_finite() && fps > 0.0) {
        return Err(invalid(
            "frame rate",
            format!("{fps}: expected a positive rate"),
        ));
    }
    let count = curves.frame_count(fps);
    if count > MAX_FRAMES {
        let (t0, t1) = curves.span();
        return Err(RigError::File {
            path: curves_path.to_path_buf(),
            detail: format!(
                "the keys span {t0} s to {t1} s: {count} frames at {fps} fps, more than {MAX_FRAMES} (are the times in seconds?)"
            ),
        });
    }
    for (n, _) in &curves.weights {
        if n != "neutral" && rig.target_index(n).is_none() {
            return Err(RigError::File {
                path: curves_path.to_path_buf(),
                detail: format!(
                    "curve '{n}' names no target of the rig ({})",
                    target_names(&rig)
                ),
            });
        }
    }
    let mel = melanin_for(&rig, opts.melanin.as_deref(), &lut.options, progress)?;
    let fmt = opts.format.extension();
    let mut frames = Vec::new();
    for (k, &t) in curves.frame_times(fps).iter().enumerate() {
        let global = curves
            .global_scale
            .as_ref()
            .map_or(opts.global_scale, |c| GlobalScale::Fixed(c.at(t)));
        let (w, g) = frame_weights(&rig, &curves.weights_at(t), opts.normalization, global)
            .map_err(|e| invalid(format!("frame {k} (t = {t:.3} s)"), e.to_string()))?;
        let mut files = vec![format!("color_{k:05}.{fmt}")];
        if opts.hemoglobin {
            files.push(format!("hemoglobin_{k:05}.exr"));
        }
        let mut weights = vec![("neutral".to_string(), w[0])];
        weights.extend(
            rig.targets
                .iter()
                .zip(&w[1..])
                .map(|(t, x)| (t.name.clone(), *x)),
        );
        frames.push(FrameJson {
            index: k,
            time: t,
            weights,
            global_scale: g,
            files,
        });
    }
    let json = AnimationJson {
        key: key(rig_dir, curves_path, fps, opts)?,
        fps,
        format: fmt.into(),
        frames,
    };
    start_or_resume(out, &json, opts.force)?;
    // The real-time path serves the LUT's colour; a rig with a set's skin composes exactly.
    let mut plan = (opts.format == FrameFormat::Png && rig.skin.is_none())
        .then(|| FramePlan::new(&rig, &mel, &lut))
        .transpose()?;
    let (fw, fh) = rig.size();
    let mut buf = vec![0u32; fw * fh];
    progress.stage("frames", json.frames.len() as u64, Unit::Frames);
    let mut kept = 0;
    for f in &json.frames {
        if f.files.iter().all(|n| out.join(n).exists()) {
            kept += 1;
        } else {
            let w: Vec<f32> = f.weights.iter().map(|x| x.1).collect();
            let color_path = out.join(&f.files[0]);
            let h = match &mut plan {
                Some(p) => {
                    p.render(&rig, &w, f.global_scale, &mut buf)?;
                    let rgb = unpack_rgba8(&buf, fw, fh);
                    derma_core::image_io::write_png8(&color_path, &[&rgb[0], &rgb[1], &rgb[2]])?;
                    opts.hemoglobin
                        .then(|| hemoglobin(&rig, &w, f.global_scale))
                        .transpose()?
                }
                None => {
                    let h = hemoglobin(&rig, &w, f.global_scale)?;
                    write_color(&color_path, &frame_color(&rig, &h, &mel, &lut)?)?;
                    Some(h)
                }
            };
            if let (true, Some(h)) = (opts.hemoglobin, h) {
                write_hemoglobin(&out.join(&f.files[1]), &h, &lut.options)?;
            }
        }
        progress.advance(1);
    }
    Ok(SequenceRun {
        frames: json.frames.len(),
        kept,
        fps,
    })
}

fn target_names(rig: &Rig) -> String {
    rig.targets
        .iter()
        .map(|t| t.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// SHA-256 over the rig's rig.json, the curves file and the options that change frames.
fn key(rig_dir: &Path, curves: &Path, fps: f64, opts: &SequenceOptions) -> Result<String> {
    let read = |p: PathBuf| {
        std::fs::read(&p).map_err(|e| RigError::File {
            path: p,
            detail: format!("cannot read: {e}"),
        })
    };
    let mut h = sha2::Sha256::new();
    h.update(read(rig_dir.join("rig.json"))?);
    h.update(read(curves.to_path_buf())?);
    let mut options = format!(
        "{fps} {} {} {} {:?}",
        opts.format.extension(),
        opts.hemoglobin,
        opts.global_scale,
        opts.melanin
    );
    if opts.normalization == Normalization::Rescale {
        options.push_str(" rescale");
    }
    h.update(options.as_bytes());
    Ok(derma_core::report::hex(&h.finalize()))
}

/// Writes `animation.json`, after checking that `out` holds no other animation (with `force`,
/// the other animation's frames are removed first).
fn start_or_resume(out: &Path, json: &AnimationJson, force: bool) -> Result<()> {
    derma_core::atomic::ensure_writable_dir(out)?;
    let jp = out.join("animation.json");
    if let Ok(old) = std::fs::read_to_string(&jp) {
        let same = serde_json::from_str::<AnimationJson>(&old).is_ok_and(|o| o.key == json.key);
        if !same && !force {
            return Err(RigError::File {
                path: out.to_path_buf(),
                detail: "holds frames of a different animation (rig, curves or options changed); force a restart or use another output directory".into(),
            });
        }
        if !same {
            for f in json.frames.iter().flat_map(|f| &f.files) {
                let _ = std::fs::remove_file(out.join(f));
            }
        }
    }
    derma_core::report::write_json(&jp, json, derma_core::report::JsonFormat::DATA_PRETTY)?;
    Ok(())
}
