//! `derma photo …`: faces from photographs (derma-photo, after Tarini et al. 2002) — calibrate
//! cameras from clicked points, unwrap a face mesh into one chart, bake its texture from the
//! photos, iris and teeth textures from single photos, and melanin/hemoglobin maps of a texture.

use crate::output::line;
use crate::progress::Bars;
use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use derma_photo::bake::BakeOptions;
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
    /// Resample the photos into the mesh's texture (gains, spline blending) → texture.png/.exr.
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

#[derive(Args)]
pub struct CalibrateArgs {
    /// Correspondences: JSON or CSV (format in derma-photo's correspondences module and README).
    #[arg(long)]
    points: PathBuf,
    /// The mesh the points lie on (OBJ/glTF/GLB, UVs not needed); default: the built-in face.
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// Named landmarks of --mesh (JSON {"name": [x, y, z]}), for points given by name.
    #[arg(long)]
    landmarks: Option<PathBuf>,
    /// --mesh is in MediaPipe's 468-vertex topology (vertex index = landmark id).
    #[arg(long)]
    mediapipe_topology: bool,
    /// Fix each photo's focal length from its EXIF (FocalLengthIn35mmFilm) when present.
    #[arg(long)]
    exif: bool,
    /// Intrinsics per photo instead of one shared camera.
    #[arg(long)]
    per_photo: bool,
    /// Also refine the principal point.
    #[arg(long)]
    refine_principal: bool,
    /// Also refine radial distortion k1, k2.
    #[arg(long)]
    refine_distortion: bool,
    /// Output cameras file.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct UnwrapArgs {
    /// Disc-topology mesh (one boundary loop); default: the built-in face.
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// Direction of view onto the face, X,Y,Z (Tarini et al. §3.1's V), or "none" for a
    /// view-independent layout.
    #[arg(long, default_value = "0,0,-1")]
    view: String,
    /// k of the view weight 1/(⟨N,V⟩ + k), 1.01–2: smaller gives the face more texture.
    #[arg(long, default_value_t = 1.2)]
    k: f32,
    /// Output OBJ with UVs.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct BakeArgs {
    /// UV-mapped mesh (from `derma photo unwrap`, or any single-chart UV layout).
    #[arg(long)]
    mesh: PathBuf,
    /// Cameras from `derma photo calibrate`.
    #[arg(long)]
    cameras: PathBuf,
    /// Texture size (texels).
    #[arg(long, default_value_t = 2048)]
    size: usize,
    /// No per-photo gain and white-balance compensation.
    #[arg(long)]
    no_gain: bool,
    /// No multiresolution spline: the weighted mean only.
    #[arg(long)]
    no_multiband: bool,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct ChromophoreArgs {
    /// Texture (PNG sRGB or linear EXR), e.g. a baked texture.png.
    #[arg(long)]
    texture: PathBuf,
    /// Grey mask: texels > 0.5 are the ones the exposure fit and the report use (e.g. the
    /// bake's mask.png: texels coloured from photos); every texel gets its maps.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Exposure the texture is divided by, or "auto" to fit it.
    #[arg(long, default_value = "auto")]
    exposure: String,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct IrisArgs {
    /// Photo of one open eye looking at the camera.
    #[arg(long)]
    photo: PathBuf,
    /// A rough centre X,Y (pixels) inside the pupil or iris; default: the darkest spot.
    #[arg(long)]
    start: Option<String>,
    /// Texture size (the globe's UV square).
    #[arg(long, default_value_t = 1024)]
    size: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct TeethArgs {
    /// Photo of the subject's teeth (a smile), cropped around the mouth.
    #[arg(long)]
    photo: PathBuf,
    /// Texture size.
    #[arg(long, default_value_t = 1024)]
    size: usize,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct SyntheticArgs {
    /// Photo width in pixels (height ¾ of it).
    #[arg(long, default_value_t = 1200)]
    width: u32,
    /// Landmark click noise (pixels).
    #[arg(long, default_value_t = 1.5)]
    noise: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

fn parse_vec(s: &str, n: usize, what: &str) -> Result<Vec<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("{what} '{s}': expected {n} comma-separated numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': expected {n} comma-separated finite numbers");
    }
    Ok(v)
}

pub fn run(cmd: PhotoCommand, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    match cmd {
        PhotoCommand::Calibrate(a) => {
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
                line(format!(
                    "{}: {} points, RMS {:.2} px, f {:.1} px (DLT {:.1}), outliers {:?}",
                    r.photo,
                    r.points.len(),
                    r.rms_px,
                    r.camera.focal_px,
                    r.dlt_focal_px,
                    out
                ))?;
            }
            bars.say(format!(
                "cameras in {:.2} s → {}",
                t0.elapsed().as_secs_f64(),
                a.out.display()
            ));
        }
        PhotoCommand::Unwrap(a) => {
            let view = if a.view.eq_ignore_ascii_case("none") {
                None
            } else {
                let v = parse_vec(&a.view, 3, "--view")?;
                Some(glam::Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
            };
            let opts = UnwrapOptions {
                view,
                k: a.k,
                ..Default::default()
            };
            let (s, tutte, it, tris) =
                files::unwrap_file(&mesh_source(&a.mesh), &opts, &a.out, bars)?;
            line(format!(
                "{tris} triangles: L2 stretch {:.4} (Tutte start {:.3}), L∞ {:.2}, weighted L2 {:.4}, {} flipped, {it} iterations",
                s.l2, tutte.l2, s.linf, s.weighted_l2, s.flipped
            ))?;
            bars.say(format!(
                "unwrapped in {:.2} s → {}",
                t0.elapsed().as_secs_f64(),
                a.out.display()
            ));
        }
        PhotoCommand::Bake(a) => {
            let opts = BakeOptions {
                size: a.size,
                gain_compensation: !a.no_gain,
                multiband: !a.no_multiband,
                ..Default::default()
            };
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
        }
        PhotoCommand::Chromophores(a) => {
            let exposure = if a.exposure.eq_ignore_ascii_case("auto") {
                None
            } else {
                Some(parse_vec(&a.exposure, 1, "--exposure")?[0])
            };
            let r =
                files::chromophore_files(&a.texture, a.mask.as_deref(), exposure, &a.out, bars)?;
            line(format!(
                "exposure {:.3}; ΔE*ab median {:.2}, 95th percentile {:.2}; {:.2} % clamped to the gamut; {} texels",
                r.exposure,
                r.median_delta_e,
                r.p95_delta_e,
                100.0 * r.clamped_share,
                r.texels
            ))?;
            bars.say(format!(
                "chromophores in {:.2} s → {}",
                t0.elapsed().as_secs_f64(),
                a.out.display()
            ));
        }
        PhotoCommand::Iris(a) => {
            let start = match &a.start {
                Some(s) => {
                    let v = parse_vec(s, 2, "--start")?;
                    Some([v[0], v[1]])
                }
                None => None,
            };
            let opts = IrisOptions {
                start,
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
            bars.say(format!(
                "iris in {:.2} s → {}",
                t0.elapsed().as_secs_f64(),
                a.out.display()
            ));
        }
        PhotoCommand::Teeth(a) => {
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
            bars.say(format!(
                "teeth in {:.2} s → {}",
                t0.elapsed().as_secs_f64(),
                a.out.display()
            ));
        }
        PhotoCommand::Synthetic(a) => {
            let opts = SyntheticOptions {
                width: a.width,
                noise_px: a.noise,
                seed: a.seed,
            };
            files::synthetic_set(&opts, &a.out, bars)?;
            bars.say(format!(
                "synthetic photo set in {:.2} s → {}",
                t0.elapsed().as_secs_f64(),
                a.out.display()
            ));
        }
    }
    Ok(())
}
