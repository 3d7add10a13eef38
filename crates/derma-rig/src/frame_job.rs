//! `derma rig eval` as one library call (Jimenez et al. 2010, eqs. 6–7 for one frame): a saved
//! rig and the frame's weights in; its colour, hemoglobin and preview files out.

use crate::error::{invalid, Result};
use crate::evaluate::evaluate_frame;
use crate::maps::{melanin_for, write_color, write_hemoglobin};
use crate::preview::write_preview;
use crate::rig_dir;
use crate::weights::{frame_weights, GlobalScale, Normalization, WeightSpec};
use derma_core::gpu::Device;
use derma_core::progress::Progress;
use std::path::PathBuf;

/// What `derma rig eval` asks for.
#[derive(Clone, Debug)]
pub struct FrameJob {
    /// The rig directory (from `derma rig build`).
    pub rig: PathBuf,
    /// Target weights; the neutral takes the rest.
    pub weights: WeightSpec,
    /// How weights that sum past 1 are handled.
    pub normalization: Normalization,
    /// The global scale of eq. 7.
    pub global_scale: GlobalScale,
    /// A melanin map for the colour (else the rig's own, or its LUT's default).
    pub melanin: Option<PathBuf>,
    /// Where to evaluate.
    pub device: Device,
    /// The colour map to write (`.png` 8-bit sRGB or `.exr` linear).
    pub color: Option<PathBuf>,
    /// The hemoglobin map to write (`.exr` or 16-bit `.png`).
    pub hemoglobin: Option<PathBuf>,
    /// A preview of the built-in head with the colour, beside the hemoglobin map.
    pub preview: Option<PathBuf>,
}

/// The weights a [`FrameJob`] evaluated.
pub struct FrameReport {
    /// The neutral's weight.
    pub neutral: f32,
    /// Each target's name and weight, in the rig's order.
    pub targets: Vec<(String, f32)>,
    /// The global scale applied.
    pub global_scale: f32,
}

/// Evaluates and writes the frame of `job`; `progress` sees the melanin map's preparation.
pub fn run(job: &FrameJob, progress: &dyn Progress) -> Result<FrameReport> {
    if job.color.is_none() && job.hemoglobin.is_none() && job.preview.is_none() {
        return Err(invalid(
            "frame",
            "nothing to write: give a colour map, a hemoglobin map and/or a preview",
        ));
    }
    let (rig, lut, _) = rig_dir::load(&job.rig)?;
    // The rig read, and before anything is written: no output may touch an input.
    let outputs: Vec<PathBuf> = [&job.color, &job.hemoglobin, &job.preview]
        .into_iter()
        .flatten()
        .cloned()
        .collect();
    let mut inputs: Vec<&std::path::Path> = vec![job.rig.as_path()];
    inputs.extend(job.melanin.as_deref());
    derma_core::atomic::check_inputs_spared(&outputs, &inputs)?;
    let (w, g) = frame_weights(&rig, &job.weights, job.normalization, job.global_scale)?;
    let wants_color = job.color.is_some() || job.preview.is_some();
    let melanin = wants_color
        .then(|| melanin_for(&rig, job.melanin.as_deref(), &lut.options, progress))
        .transpose()?;
    let (h, rgb) = evaluate_frame(&rig, &lut, &w, g, melanin.as_ref(), job.device)?;
    if let Some(p) = &job.hemoglobin {
        write_hemoglobin(p, &h, &lut.options)?;
    }
    if let Some(rgb) = &rgb {
        if let Some(p) = &job.color {
            write_color(p, rgb)?;
        }
        if let Some(p) = &job.preview {
            write_preview(p, rgb, &h)?;
        }
    }
    Ok(FrameReport {
        neutral: w[0],
        targets: rig
            .targets
            .iter()
            .zip(&w[1..])
            .map(|(t, &x)| (t.name.clone(), x))
            .collect(),
        global_scale: g,
    })
}
