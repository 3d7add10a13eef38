//! `derma synth` as one library call (Shen et al.'s synthesis from files to files): exemplars
//! with registered channels and an optional region guide are read, grown and written, inputs spared.

use crate::error::{invalid, Result};
use crate::files::{load_exemplars, output_paths, write_outputs};
use crate::guide::Guide;
use crate::quality::Metrics;
use crate::synthesize::SynthOptions;
use crate::synthesizer::Synthesizer;
use derma_core::gpu::Device;
use derma_core::progress::{Progress, Timing};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What `derma synth` asks for.
#[derive(Clone, Debug)]
pub struct SynthJob {
    /// Exemplar images (PNG or EXR; grey → 1 channel, colour → 3).
    pub exemplars: Vec<PathBuf>,
    /// Per exemplar, further channels registered with it: (name, file); empty for none.
    pub channels: Vec<Vec<(String, PathBuf)>>,
    /// A grey map choosing the exemplar per output texel (two exemplars or more).
    pub guide: Option<PathBuf>,
    /// The main output (`.png` or `.exr`); registered channels go beside it as `stem_NAME.ext`.
    pub out: PathBuf,
    /// Size, passes, tolerance, seed, tiling.
    pub options: SynthOptions,
    /// Where the searches run.
    pub device: Device,
    /// Measure the result against the first exemplar ([`Metrics`]).
    pub metrics: bool,
}

/// What a [`SynthJob`] made.
pub struct SynthReport {
    /// Every file written, the main output first.
    pub outputs: Vec<PathBuf>,
    /// What ran the searches ("CPU (2 threads)", "GPU (…)").
    pub matcher: String,
    /// Wall-clock seconds of the synthesis (reading and writing excluded).
    pub seconds: f64,
    /// Seconds per stage.
    pub timings: Vec<Timing>,
    /// Each optimisation pass's windows and how many were searched (§3.3's self-adaptive skip).
    pub passes: Vec<crate::optimize::PassStats>,
    /// The metrics, when asked for.
    pub metrics: Option<Metrics>,
}

impl SynthReport {
    /// The metrics as one JSON object with the run's seconds and stage timings (keys sorted),
    /// when they were asked for.
    pub fn metrics_json(&self) -> Option<serde_json::Value> {
        let m = self.metrics.as_ref()?;
        let stages: serde_json::Map<String, serde_json::Value> = self
            .timings
            .iter()
            .map(|t| (t.stage.clone(), serde_json::json!(t.seconds)))
            .collect();
        Some(serde_json::json!({
            "seconds": self.seconds,
            "stages": stages,
            "windows_searched": self.passes.iter().map(|p| serde_json::json!({"side": p.w, "windows": p.windows, "searched": p.searched})).collect::<Vec<_>>(),
            "patch_swd": m.patch_swd,
            "patch_swd_half": m.patch_swd_half,
            "patch_swd_quarter": m.patch_swd_quarter,
            "contrast_ratio": m.contrast_ratio,
            "grain_ratio": m.grain_ratio,
            "verbatim_copy_ratio": m.verbatim_copy_ratio,
            "seam_energy": m.seam_energy,
        }))
    }
}

/// Creates the folders the outputs go in.
fn create_parents(outputs: &[PathBuf]) -> Result<()> {
    for o in outputs {
        if let Some(parent) = o.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(|e| {
                invalid(
                    format!("output folder '{}'", parent.display()),
                    format!("cannot create it ({e})"),
                )
            })?;
        }
    }
    Ok(())
}

/// Runs `job`: reads the exemplars (and guide), refuses outputs that would replace an input,
/// synthesises on the job's device with `progress`, writes every channel group.
pub fn run(job: &SynthJob, progress: &dyn Progress) -> Result<SynthReport> {
    let files = load_exemplars(&job.exemplars, &job.channels)?;
    let outputs = output_paths(&job.out, &files.groups)?;
    create_parents(&outputs)?;
    let mut inputs: Vec<&Path> = files.inputs.iter().map(PathBuf::as_path).collect();
    inputs.extend(job.guide.as_deref());
    derma_core::atomic::check_inputs_spared(&outputs, &inputs)?;
    let mut textures = files.textures.into_iter();
    let first = textures
        .next()
        .ok_or_else(|| invalid("exemplars", "none given; give at least one"))?;
    // The metrics compare with the first exemplar; keep a copy only when they are asked for.
    let exemplar = job.metrics.then(|| first.clone());
    let mut synth = Synthesizer::new(first)
        .options(job.options.clone())
        .device(job.device)
        .progress(progress);
    for t in textures {
        synth = synth.exemplar(t);
    }
    if let Some(g) = &job.guide {
        if job.exemplars.len() < 2 {
            return Err(invalid(
                "guide",
                "a guide chooses among exemplars: give at least two exemplars",
            ));
        }
        synth = synth.guide(Guide::read(g, job.exemplars.len())?);
    }
    let t = Instant::now();
    let out = synth.run()?;
    let seconds = t.elapsed().as_secs_f64();
    write_outputs(&outputs, &files.groups, &out.texture)?;
    let metrics = match &exemplar {
        Some(e) => Some(Metrics::measure(&out.texture, e, job.options.patch)?),
        None => None,
    };
    Ok(SynthReport {
        outputs,
        matcher: out.matcher,
        seconds,
        timings: out.timings,
        passes: out.passes,
        metrics,
    })
}
