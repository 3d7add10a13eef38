//! The file jobs from Python: a photo bake onto a mesh (Tarini et al. 2002; docs/photo.md) and
//! an eye-region animation (docs/eyes.md), each writing its directory and returning its report.

use crate::errors::message;
use crate::progress::Callback;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Bakes calibrated photos (`derma photo calibrate`'s cameras.json) onto `mesh`'s UVs into
/// `out` (albedo.png/.exr de-lit, or texture.png/.exr with `delight=False`; source.png,
/// mask.png, bake.json). Returns the report as JSON text.
#[pyfunction]
#[pyo3(signature = (mesh, cameras, out, *, size=2048, delight=true, progress=None))]
pub fn photo_bake(
    py: Python<'_>,
    mesh: PathBuf,
    cameras: PathBuf,
    out: PathBuf,
    size: usize,
    delight: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let mut opts = derma_photo::bake::BakeOptions {
        size,
        ..Default::default()
    };
    if !delight {
        opts.delight = None;
        opts.register = None;
    }
    let callback = Callback::new(progress);
    let report = py.detach(|| {
        derma_photo::files::bake_files(&mesh, &cameras, &opts, &out, &callback)
            .map_err(|e| message(&e))
            .and_then(|r| serde_json::to_string(&r).map_err(|e| e.to_string()))
    });
    callback.finish()?;
    report.map_err(crate::errors::DermaError::new_err)
}

/// Animates the eye region of the built-in head (or a fitted one) into `out`: curves.json,
/// curves.csv, head.glb and, with `render` > 0 (frame width in px), the rendered frames.
/// Returns the report as JSON text.
#[pyfunction]
#[pyo3(signature = (out, *, seconds=4.0, fps=30.0, seed=1, activity="rest".to_string(),
    render=0, head=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn eyes_animate(
    py: Python<'_>,
    out: PathBuf,
    seconds: f32,
    fps: f32,
    seed: u64,
    activity: String,
    render: usize,
    head: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    use derma_eyes::animate::Drive;
    let activity = derma_eyes::blink::Activity::parse(&activity).ok_or_else(|| {
        crate::errors::invalid(
            "activity",
            format!("'{activity}': expected rest, conversation, reading or watching"),
        )
    })?;
    if !(seconds > 0.0 && fps > 0.0) {
        return Err(crate::errors::invalid(
            "seconds, fps",
            format!("{seconds} s at {fps} fps: expected positive numbers"),
        ));
    }
    let o = derma_eyes::files::AnimateOptions {
        model: None,
        drive: Drive {
            seconds,
            fps,
            activity,
            seed,
            ..Drive::default()
        },
        targets: derma_eyes::files::Targets::Idle,
        render,
        thickness: derma_eyes::sliding::THICKNESS,
        iris: None,
        head,
        mesh: None,
    };
    let callback = Callback::new(progress);
    let report = py.detach(|| {
        derma_eyes::files::animate(&o, &out, &callback)
            .map_err(|e| message(&e))
            .and_then(|r| serde_json::to_string(&r).map_err(|e| e.to_string()))
    });
    callback.finish()?;
    report.map_err(crate::errors::DermaError::new_err)
}
