//! `derma photo …`: faces from photographs (derma-photo, after Tarini et al. 2002) — calibrate
//! cameras from clicked points, unwrap a face mesh into one chart, bake its texture from the
//! photos, iris and teeth textures from single photos, and melanin/hemoglobin maps of a texture.

use crate::output::line;
use crate::photo_args::*;
use crate::progress::Bars;
use anyhow::Result;
use clap::Subcommand;
use derma_photo::bake::{BakeOptions, BakeReport};
use derma_photo::files::{self, CalibrateInputs, MeshSource, SyntheticOptions};
use derma_photo::iris::IrisOptions;
use derma_photo::resection::ResectionOptions;
use derma_photo::teeth::TeethOptions;
use derma_photo::unwrap::UnwrapOptions;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Subcommand)]
pub enum PhotoCommand {
    /// Cameras from clicked feature points: DLT, then Levenberg–Marquardt → cameras.json.
    Calibrate(CalibrateArgs),
    /// One flip-free, stretch-minimising UV chart for a disc-shaped face mesh → OBJ with UVs.
    Unwrap(UnwrapArgs),
    /// Resample the photos into the mesh's texture with their lighting taken out (spline
    /// blending) → albedo.png/.exr, shading_K.png.
    Bake(BakeArgs),
    /// Melanin and hemoglobin maps of a texture through the skin-colour LUT → EXR maps.
    Chromophores(ChromophoreArgs),
    /// An eyeball texture for the head's eye globes from one eye photo.
    Iris(IrisArgs),
    /// A teeth texture for the head's teeth from one smile photo.
    Teeth(TeethArgs),
    /// A synthetic photo set of the built-in head's face (known cameras), to try the pipeline.
    Synthetic(SyntheticArgs),
}

fn mesh_source(m: &Option<PathBuf>) -> MeshSource {
    match m {
        Some(p) => MeshSource::File(p.clone()),
        None => MeshSource::Builtin,
    }
}

pub fn run(cmd: PhotoCommand, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    match cmd {
        PhotoCommand::Calibrate(a) => calibrate(a, bars, t0),
        PhotoCommand::Unwrap(a) => unwrap(a, bars, t0),
        PhotoCommand::Bake(a) => bake(a, bars, t0),
        PhotoCommand::Chromophores(a) => chromophores(a, bars, t0),
        PhotoCommand::Iris(a) => iris(a, bars, t0),
        PhotoCommand::Teeth(a) => teeth(a, bars, t0),
        PhotoCommand::Synthetic(a) => synthetic(a, bars, t0),
    }
}

/// `derma photo calibrate`: the cameras, and per photo its fit.
fn calibrate(a: CalibrateArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let mesh = mesh_source(&a.mesh);
    let inp = CalibrateInputs {
        correspondences: &a.points,
        mesh: &mesh,
        landmarks: a.landmarks.as_deref(),
        mediapipe_topology: a.mediapipe_topology,
        exif: a.exif,
    };
    let opts = ResectionOptions {
        shared_intrinsics: !a.per_photo,
        refine_principal: a.refine_principal,
        refine_distortion: a.refine_distortion,
        focal_deviation: a.focal_deviation,
        ..Default::default()
    };
    let res = files::calibrate(&inp, &opts, &a.out, bars)?;
    for r in &res {
        let out: Vec<&str> = r
            .points
            .iter()
            .filter(|p| p.outlier)
            .map(|p| p.label.as_str())
            .collect();
        let se = r
            .focal_se_px
            .map_or(String::new(), |s| format!(" ± {s:.1}"));
        line(format!(
            "{}: {} points, RMS {:.2} px, f {:.1}{se} px (DLT {:.1}), distance ± {:.3}, outliers {:?}",
            r.photo,
            r.points.len(),
            r.rms_px,
            r.camera.focal_px,
            r.dlt_focal_px,
            r.distance_se,
            out
        ))?;
    }
    done(bars, "cameras", t0, &a.out);
    Ok(())
}

/// `derma photo unwrap`: the chart and its stretch.
fn unwrap(a: UnwrapArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let view = crate::args::optional_numbers(&a.view, "none", 3)
        .map_err(|e| anyhow::anyhow!("--view {e}"))?
        .map(|v| glam::Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32));
    let opts = UnwrapOptions {
        view,
        k: a.k,
        ..Default::default()
    };
    let (s, tutte, it, tris) = files::unwrap_file(&mesh_source(&a.mesh), &opts, &a.out, bars)?;
    line(format!(
        "{tris} triangles: L2 stretch {:.4} (Tutte start {:.3}), L∞ {:.2}, weighted L2 {:.4}, {} flipped, {it} iterations",
        s.l2, tutte.l2, s.linf, s.weighted_l2, s.flipped
    ))?;
    done(bars, "unwrapped", t0, &a.out);
    Ok(())
}

/// `derma photo bake`: the texture, and per photo its gain and share, the fits and the cases.
fn bake(a: BakeArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let mut opts = BakeOptions {
        size: a.size,
        gain_compensation: !a.no_gain,
        multiband: !a.no_multiband,
        strict: a.strict,
        ..Default::default()
    };
    if a.keep_lighting {
        opts.delight = None;
    }
    if a.no_register {
        opts.register = None;
    }
    let r = files::bake_files(&a.mesh, &a.cameras, &opts, &a.out, bars)?;
    for p in &r.photos {
        line(format!(
            "{}: gain [{:.3}, {:.3}, {:.3}], {} vertices bound, best view for {:.1} %",
            p.name,
            p.gain[0],
            p.gain[1],
            p.gain[2],
            p.bound_vertices,
            100.0 * p.best_share
        ))?;
    }
    bake_fits(&r)?;
    line(format!(
        "triangles by case (common photo / all bound / unbound vertex): {:?}; {} vertices filled; {:.1} % of texels from photos",
        r.triangle_cases,
        r.unbound_vertices,
        100.0 * r.photo_coverage
    ))?;
    bars.say(format!(
        "baked {0}×{0} in {1:.2} s → {2}",
        a.size,
        t0.elapsed().as_secs_f64(),
        a.out.display()
    ));
    Ok(())
}

/// A bake's registration (the cameras' shifts) and lighting (the model, its candidates' scores
/// and its fit), where it made them.
fn bake_fits(r: &BakeReport) -> Result<()> {
    if !r.registration.is_empty() {
        let shifts: Vec<String> = r
            .registration
            .iter()
            .map(|g| match g.kept {
                true => format!("{:.2}", g.shift_px),
                false => "kept as calibrated".into(),
            })
            .collect();
        line(format!(
            "registration: cameras moved by [{}] px (RMS over the surface)",
            shifts.join(", ")
        ))?;
    }
    if let Some(l) = &r.lighting {
        let keys = l.key_direction.iter().filter(|d| d.is_some()).count();
        let scores: Vec<String> = l
            .candidates
            .iter()
            .map(|c| format!("{} {:.3}", c.model, c.held_out_misfit))
            .collect();
        let kept = if l.fallback.is_some() {
            ", not trusted: the lighting kept"
        } else {
            ""
        };
        line(format!(
            "lighting model: {}{kept} (held-out misfit of each: {})",
            l.model_name,
            scores.join("; ")
        ))?;
        line(format!(
            "lighting: a key light in {keys} of {} photos; relative misfit {:.3}; {:.1} % of samples weighted out (highlights, shadows); vignetting {:?}",
            l.key_direction.len(),
            l.rms_relative,
            100.0 * l.outlier_share,
            l.vignetting.iter().map(|v| (v * 1000.0).round() / 1000.0).collect::<Vec<_>>()
        ))?;
    }
    Ok(())
}

/// `derma photo chromophores`: the maps, and the inversion's fit.
fn chromophores(a: ChromophoreArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let exposure = crate::args::optional_numbers(&a.exposure, "auto", 1)
        .map_err(|e| anyhow::anyhow!("--exposure {e}"))?
        .map(|v| v[0]);
    let lut = derma_skin::measured::inversion_lut_of(a.config.as_deref())?;
    let r = files::chromophore_files(&a.texture, a.mask.as_deref(), &lut, exposure, &a.out, bars)?;
    line(format!(
        "exposure {:.3}; ΔE*ab median {:.2}, 95th percentile {:.2}; {:.2} % clamped to the gamut; {:.2} % flips; {} texels",
        r.exposure,
        r.median_delta_e,
        r.p95_delta_e,
        100.0 * r.clamped_share,
        100.0 * r.flips,
        r.texels
    ))?;
    done(bars, "chromophores", t0, &a.out);
    Ok(())
}

/// `derma photo iris`: the eye texture, and where the iris was found.
fn iris(a: IrisArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let opts = IrisOptions {
        start: a.start,
        size: a.size,
        seed: a.seed,
        ..Default::default()
    };
    let r = files::iris_files(&a.photo, &opts, &a.out, bars)?;
    line(format!(
        "iris at ({:.2}, {:.2}) r {:.2} px, pupil r {:.2} px; {:.0} % of samples kept; sector {:.1}°; {}",
        r.centre[0],
        r.centre[1],
        r.radius,
        r.pupil_radius,
        100.0 * r.kept_share,
        r.sector_deg,
        r.synthesis
    ))?;
    done(bars, "iris", t0, &a.out);
    Ok(())
}

/// `derma photo teeth`: the teeth texture, and the labels' shares.
fn teeth(a: TeethArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let opts = TeethOptions {
        size: a.size,
        ..Default::default()
    };
    let r = files::teeth_files(&a.photo, &opts, &a.out, bars)?;
    line(format!(
        "teeth {:.1} %, gums {:.1} %, voids {:.1} % (thresholds {:.3}, {:.3}); target {:?}",
        100.0 * r.shares[0],
        100.0 * r.shares[1],
        100.0 * r.shares[2],
        r.void_threshold,
        r.gum_threshold,
        r.target
    ))?;
    done(bars, "teeth", t0, &a.out);
    Ok(())
}

/// `derma photo synthetic`: a photo set with known cameras.
fn synthetic(a: SyntheticArgs, bars: &Bars, t0: Instant) -> Result<()> {
    let opts = SyntheticOptions {
        width: a.width,
        noise_px: a.noise,
        seed: a.seed,
    };
    files::synthetic_set(&opts, &a.out, bars)?;
    done(bars, "synthetic photo set", t0, &a.out);
    Ok(())
}

/// The closing note of a subcommand: what it made, how long it took, where it went.
fn done(bars: &Bars, what: &str, t0: Instant, out: &std::path::Path) {
    bars.say(format!(
        "{what} in {:.2} s → {}",
        t0.elapsed().as_secs_f64(),
        out.display()
    ));
}
