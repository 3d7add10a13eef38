//! The photo pipeline from files, as `derma photo …` runs it: each step reads its inputs, checks
//! that no output would overwrite one, and writes atomically (a temporary name, then a rename).
//! The built-in head stands in when no mesh is given.

use crate::bake::{bake, BakeOptions, BakeReport, SOURCE_INTERPOLATED, SOURCE_NONE};
use crate::camera::Camera;
use crate::chromophores::{fit_exposure, invert, ChromophoreReport};
use crate::correspondences::{self, exif_focal_px, Surface};
use crate::error::{PhotoError, Result};
use crate::iris::{iris_texture, IrisOptions, IrisReport};
use crate::photo::{Photo, RgbImage};
use crate::register::RegisterOptions;
use crate::resection::{resect, Resection, ResectionOptions};
use crate::synthetic;
use crate::teeth::{teeth_texture, TeethOptions, TeethReport};
use crate::unwrap::{unwrap, Stretch, UnwrapOptions};
use derma_core::atomic::{check_inputs_spared, ensure_writable_dir};
use derma_core::image_io::{write_exr, write_png8, ExrPrecision};
use derma_core::mesh::TriMesh;
use derma_core::progress::{Note, Progress, Unit};
use derma_core::report::{write_json, JsonFormat};
use derma_core::Map;
use derma_head::Head;
use derma_shading::skin_color_lut::SkinColorLut;
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A mesh to work on: a file or the built-in head's face (a disc, see
/// [`synthetic::face_disc`]) with its landmarks.
pub enum MeshSource {
    /// The built-in head's face disc.
    Builtin,
    /// A mesh file (OBJ, glTF, GLB), UVs optional.
    File(PathBuf),
}

impl MeshSource {
    /// Loads the mesh (without its UVs requirement).
    pub fn load(&self) -> Result<TriMesh> {
        match self {
            MeshSource::Builtin => synthetic::face_disc(Head::builtin()),
            MeshSource::File(p) => Ok(TriMesh::load_geometry(p)?),
        }
    }

    fn inputs(&self) -> Vec<&Path> {
        match self {
            MeshSource::Builtin => vec![],
            MeshSource::File(p) => vec![p.as_path()],
        }
    }
}

fn json_out(path: &Path, value: &impl Serialize) -> Result<()> {
    Ok(write_json(path, value, JsonFormat::REPORT)?)
}

/// `cameras.json`: each photo's camera and errors.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CamerasFile {
    /// One entry per photo.
    pub photos: Vec<CameraEntry>,
}

/// One photo of `cameras.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CameraEntry {
    /// The image file (relative to `cameras.json`'s folder when it lies below it).
    pub image: PathBuf,
    /// The camera.
    pub camera: Camera,
    /// RMS reprojection error of the inliers (pixels).
    pub rms_px: f64,
    /// Points flagged as outliers.
    pub outliers: Vec<String>,
    /// Every point's reprojection error under the camera.
    #[serde(default)]
    pub points: Vec<crate::resection::PointError>,
    /// Standard error of the focal length (pixels); absent where it was given.
    #[serde(default)]
    pub focal_se_px: Option<f64>,
    /// Standard error of the camera's distance to the mesh's origin (mesh units).
    #[serde(default)]
    pub distance_se: f64,
}

/// A standard error above this fraction of its value makes [`calibrate`] warn (authored: 5 %
/// of the focal length moves a face's outline by a few pixels in a typical portrait).
pub const ILL_DETERMINED: f64 = 0.05;

/// Options of [`calibrate`] beyond the resection's.
pub struct CalibrateInputs<'a> {
    /// The correspondence file (JSON or CSV).
    pub correspondences: &'a Path,
    /// The mesh the 3D points lie on.
    pub mesh: &'a MeshSource,
    /// Named landmarks of a file mesh (derma-head's JSON format), if any.
    pub landmarks: Option<&'a Path>,
    /// The mesh is in MediaPipe's 468-vertex topology.
    pub mediapipe_topology: bool,
    /// Take each photo's focal length from its EXIF when the file does not give one.
    pub exif: bool,
}

/// Resects every photo of a correspondence file and writes `out` (cameras.json).
pub fn calibrate(
    inp: &CalibrateInputs,
    opts: &ResectionOptions,
    out: &Path,
    progress: &dyn Progress,
) -> Result<Vec<Resection>> {
    let mut inputs = inp.mesh.inputs();
    inputs.push(inp.correspondences);
    inputs.extend(inp.landmarks);
    check_inputs_spared(&[out.to_path_buf()], &inputs)?;
    progress.stage("calibrate cameras", 0, Unit::Steps);
    let mesh = inp.mesh.load()?;
    let head = Head::builtin();
    let file_landmarks = match inp.landmarks {
        Some(p) => {
            let what = || format!("landmarks file '{}'", p.display());
            let text = std::fs::read_to_string(p).map_err(|e| {
                PhotoError::Invalid(derma_core::Invalid::new(what(), "a readable file", e))
            })?;
            Some(derma_head::Landmarks::from_json(&text, 1.0).map_err(|e| {
                PhotoError::Invalid(derma_core::Invalid::new(
                    what(),
                    "derma-head's landmark JSON",
                    e,
                ))
            })?)
        }
        None => None,
    };
    let landmarks = match (&inp.mesh, &file_landmarks) {
        (_, Some(l)) => Some(l),
        (MeshSource::Builtin, None) => Some(&head.landmarks),
        _ => None,
    };
    let surface = Surface {
        mesh: &mesh,
        landmarks,
        mediapipe_topology: inp.mediapipe_topology,
    };
    let size = |p: &Path| -> Result<(u32, u32)> {
        let img = RgbImage::read_linear(p)?;
        Ok((img.width as u32, img.height as u32))
    };
    let mut entries = correspondences::read(inp.correspondences, &surface, &size)?;
    if inp.exif {
        for e in &mut entries {
            if e.points.focal_px.is_none() {
                if let Ok(bytes) = std::fs::read(&e.image) {
                    e.points.focal_px = exif_focal_px(&bytes, e.points.width, e.points.height);
                }
            }
        }
    }
    let photos: Vec<_> = entries.iter().map(|e| e.points.clone()).collect();
    let res = resect(&photos, opts)?;
    for r in &res {
        let distance = DVec3::from(r.camera.translation).length();
        let mut weak = Vec::new();
        if let Some(se) = r
            .focal_se_px
            .filter(|se| *se > ILL_DETERMINED * r.camera.focal_px)
        {
            weak.push(format!(
                "focal length {:.0} ± {se:.0} px ({:.0} %)",
                r.camera.focal_px,
                100.0 * se / r.camera.focal_px
            ));
        }
        if r.distance_se > ILL_DETERMINED * distance {
            weak.push(format!(
                "distance {distance:.4} ± {:.4} ({:.0} %)",
                r.distance_se,
                100.0 * r.distance_se / distance
            ));
        }
        if !weak.is_empty() {
            progress.note(Note::warning(format!(
                "photo '{}': {} ill-determined by its {} points (one standard error); give the focal length (focal_px, EXIF), one shared camera, or more points spread in depth",
                r.photo,
                weak.join(" and "),
                r.points.iter().filter(|p| !p.outlier).count()
            )));
        }
    }
    let dir = out.parent().unwrap_or(Path::new("."));
    let file = CamerasFile {
        photos: entries
            .iter()
            .zip(&res)
            .map(|(e, r)| CameraEntry {
                image: relative(&e.image, dir),
                camera: r.camera,
                rms_px: r.rms_px,
                outliers: r
                    .points
                    .iter()
                    .filter(|p| p.outlier)
                    .map(|p| p.label.clone())
                    .collect(),
                points: r.points.clone(),
                focal_se_px: r.focal_se_px,
                distance_se: r.distance_se,
            })
            .collect(),
    };
    json_out(out, &file)?;
    Ok(res)
}

/// `p` relative to folder `dir` (with `..` where it lies beside or above it), so cameras.json
/// moves with its photos; absolute only where the two share no root.
fn relative(p: &Path, dir: &Path) -> PathBuf {
    let canon = |x: &Path| std::fs::canonicalize(x).unwrap_or_else(|_| x.to_path_buf());
    let (cp, cd) = (canon(p), canon(dir));
    let (a, b): (Vec<_>, Vec<_>) = (cp.components().collect(), cd.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return cp;
    }
    let mut out: PathBuf = b[common..].iter().map(|_| "..").collect();
    out.extend(&a[common..]);
    out
}

/// Unwraps a mesh into one chart and writes it as OBJ with UVs.
pub fn unwrap_file(
    mesh: &MeshSource,
    opts: &UnwrapOptions,
    out: &Path,
    progress: &dyn Progress,
) -> Result<(Stretch, Stretch, usize, usize)> {
    check_inputs_spared(&[out.to_path_buf()], &mesh.inputs())?;
    progress.stage("unwrap", 0, Unit::Steps);
    let m = mesh.load()?;
    let u = unwrap(&m, opts)?;
    u.mesh.write_obj(out)?;
    Ok((
        u.stretch,
        u.tutte_stretch,
        u.iterations,
        u.mesh.triangles.len(),
    ))
}

/// Reads `cameras.json`: each photo's image path (resolved against the file's folder), name
/// and camera.
pub fn read_cameras(cameras: &Path) -> Result<Vec<(PathBuf, String, Camera)>> {
    Ok(camera_list(read_cameras_file(cameras)?, cameras))
}

/// Each photo of a cameras file: its path (joined to the file's folder), name and camera.
fn camera_list(file: CamerasFile, cameras: &Path) -> Vec<(PathBuf, String, Camera)> {
    let dir = cameras.parent().unwrap_or(Path::new("."));
    file.photos
        .into_iter()
        .map(|e| (dir.join(&e.image), e.image.display().to_string(), e.camera))
        .collect()
}

/// The farthest a registration may move a camera when the cameras file's clicks left an RMS
/// reprojection error of `rms_px` (the largest of its photos'; one limit for all): twice that,
/// within 2–12 px; a file of cameras given without clicks (`rms_px` 0) keeps
/// [`RegisterOptions::default`]'s 12 px. Authored: resection from
/// 25–40 clicks leaves each camera within about half the clicks' RMS (issue 38's ground truth:
/// 0.6–1.4 px from 1.5 px clicks), so a correction of twice the RMS is beyond what the clicks
/// allow.
pub fn register_limit(rms_px: f64) -> f64 {
    if rms_px > 0.0 {
        (2.0 * rms_px).clamp(2.0, 12.0)
    } else {
        crate::register::RegisterOptions::default().max_shift_px
    }
}

/// `cameras.json` as written.
fn read_cameras_file(cameras: &Path) -> Result<CamerasFile> {
    let what = || format!("cameras file '{}'", cameras.display());
    let text = std::fs::read_to_string(cameras)
        .map_err(|e| PhotoError::Invalid(derma_core::Invalid::new(what(), "a readable file", e)))?;
    let file: CamerasFile = serde_json::from_str(&text).map_err(|e| {
        PhotoError::Invalid(derma_core::Invalid::new(
            what(),
            "the JSON that `derma photo calibrate` writes",
            e,
        ))
    })?;
    Ok(file)
}

/// Reads the photos of [`read_cameras`]' list, each checked against its camera's size.
pub fn read_photos(list: &[(PathBuf, String, Camera)]) -> Result<Vec<Photo>> {
    // Decoded in parallel, kept in the list's order (the first failure in that order reported).
    list.par_iter()
        .map(|(path, name, camera)| {
            let p = Photo {
                name: name.clone(),
                image: RgbImage::read_linear(path)?,
                camera: *camera,
            };
            p.check()?;
            Ok(p)
        })
        .collect()
}

/// Bakes a texture from calibrated photos onto a UV-mapped mesh. De-lit (the default):
/// `albedo.png` (sRGB), `albedo.exr` (linear) and `shading_K.png` per photo K (the shading taken
/// out, in the photo's frame, scaled so that its 99th percentile is white); with the
/// lighting kept: `texture.png` and `texture.exr`. Both: `source.png` (which photo each texel
/// came from), `mask.png` (texels coloured from photos: the input of `derma photo chromophores
/// --mask`) and `bake.json`.
pub fn bake_files(
    mesh: &Path,
    cameras: &Path,
    opts: &BakeOptions,
    out_dir: &Path,
    progress: &dyn Progress,
) -> Result<BakeReport> {
    ensure_writable_dir(out_dir)?;
    let file = read_cameras_file(cameras)?;
    let rms = file.photos.iter().map(|e| e.rms_px).fold(0.0, f64::max);
    let list = camera_list(file, cameras);
    let colour = if opts.delight.is_some() {
        "albedo"
    } else {
        "texture"
    };
    let mut names: Vec<String> = vec![
        format!("{colour}.png"),
        format!("{colour}.exr"),
        "source.png".into(),
        "bake.json".into(),
        "mask.png".into(),
    ];
    if opts.delight.is_some() {
        names.extend((0..list.len()).map(|k| format!("shading_{k}.png")));
    }
    let outs: Vec<PathBuf> = names.iter().map(|n| out_dir.join(n)).collect();
    let mut inputs = vec![mesh, cameras];
    inputs.extend(list.iter().map(|(p, _, _)| p.as_path()));
    check_inputs_spared(&outs, &inputs)?;
    let photos = read_photos(&list)?;
    let m = TriMesh::load(mesh)?;
    let opts = BakeOptions {
        shading_images: opts.delight.is_some(),
        register: opts.register.map(|r| RegisterOptions {
            max_shift_px: r.max_shift_px.min(register_limit(rms)),
            ..r
        }),
        ..*opts
    };
    let b = bake(&m, &photos, &opts, progress)?;
    progress.stage("write", 0, Unit::Steps);
    // Every file written at once (each to a temporary name, renamed when complete).
    let n = photos.len().max(1);
    let (w, h) = (b.texture.width, b.texture.height);
    let grey = |path: &Path, f: &dyn Fn(u8) -> f32| -> Result<()> {
        let values = b.source.iter().map(|s| f(*s)).collect();
        Ok(write_png8(path, &[&Map::from_vec(w, h, values)?])?)
    };
    let mut jobs: Vec<Box<dyn Fn() -> Result<()> + Sync + '_>> = vec![
        Box::new(|| Ok(b.texture.write_linear(&outs[0])?)),
        Box::new(|| Ok(b.texture.write_linear(&outs[1])?)),
        Box::new(|| {
            grey(&outs[2], &|s| match s {
                SOURCE_NONE => 0.0,
                SOURCE_INTERPOLATED => 0.15,
                k => 0.3 + 0.7 * k as f32 / n as f32,
            })
        }),
        Box::new(|| json_out(&outs[3], &b.report)),
        Box::new(|| grey(&outs[4], &|s| ((s as usize) < photos.len()) as u8 as f32)),
    ];
    for (s, out) in b.shading.iter().zip(&outs[5..]) {
        jobs.push(Box::new(move || write_shading(s, out)));
    }
    jobs.par_iter().try_for_each(|job| job())?;
    drop(jobs);
    // Where the lighting was kept there is no shading to show: a shading image of an earlier
    // bake into this folder would contradict bake.json.
    for out in outs[5..].iter().skip(b.shading.len()) {
        if out.exists() {
            std::fs::remove_file(out).map_err(|e| {
                PhotoError::Invalid(derma_core::Invalid::new(
                    format!("stale '{}'", out.display()),
                    "removable",
                    e,
                ))
            })?;
        }
    }
    Ok(b.report)
}

/// Writes photo K's shading scaled so that the 99th percentile of its lit pixels is white.
fn write_shading(s: &RgbImage, out: &Path) -> Result<()> {
    let mut lum: Vec<f32> = s
        .data
        .iter()
        .map(|c| c.iter().sum::<f32>() / 3.0)
        .filter(|l| *l > 0.0)
        .collect();
    let top = if lum.is_empty() {
        1.0
    } else {
        let i = (lum.len() - 1) * 99 / 100;
        *lum.select_nth_unstable_by(i, f32::total_cmp).1
    };
    let scaled = RgbImage {
        width: s.width,
        height: s.height,
        data: s
            .data
            .iter()
            .map(|c| c.map(|v| v / top.max(1e-6)))
            .collect(),
    };
    Ok(scaled.write_linear(out)?)
}

/// Makes the iris texture of an eye photo; writes `eye.png` (sRGB), `eye.exr`, `iris_polar.png`
/// and `iris.json`.
pub fn iris_files(
    photo: &Path,
    opts: &IrisOptions,
    out_dir: &Path,
    progress: &dyn Progress,
) -> Result<IrisReport> {
    ensure_writable_dir(out_dir)?;
    let outs: Vec<PathBuf> = ["eye.png", "eye.exr", "iris_polar.png", "iris.json"]
        .iter()
        .map(|n| out_dir.join(n))
        .collect();
    check_inputs_spared(&outs, &[photo])?;
    progress.stage("iris", 0, Unit::Steps);
    let img = RgbImage::read_linear(photo)?;
    let t = iris_texture(&img, opts)?;
    t.texture.write_linear(&outs[0])?;
    t.texture.write_linear(&outs[1])?;
    t.polar.write_linear(&outs[2])?;
    json_out(&outs[3], &t.report)?;
    Ok(t.report)
}

/// Makes the teeth texture of a smile photo for the built-in head's teeth; writes `teeth.png`
/// (sRGB with alpha), `teeth_equalised.png` and `teeth.json`.
pub fn teeth_files(
    photo: &Path,
    opts: &TeethOptions,
    out_dir: &Path,
    progress: &dyn Progress,
) -> Result<TeethReport> {
    ensure_writable_dir(out_dir)?;
    let outs: Vec<PathBuf> = ["teeth.png", "teeth_equalised.png", "teeth.json"]
        .iter()
        .map(|n| out_dir.join(n))
        .collect();
    check_inputs_spared(&outs, &[photo])?;
    progress.stage("teeth", 0, Unit::Steps);
    let img = RgbImage::read_linear(photo)?;
    let head = Head::builtin();
    let part = |n: &str| {
        head.part(n)
            .map(|p| &p.mesh)
            .ok_or_else(|| PhotoError::Mesh(format!("the built-in head has no {n}")))
    };
    let t = teeth_texture(&img, part("teeth_upper")?, part("teeth_lower")?, opts)?;
    let s = t.rgb.width;
    let ch = |c: usize| {
        Map::from_vec(
            s,
            s,
            t.rgb
                .data
                .iter()
                .map(|p| derma_core::color::srgb_encode(p[c].clamp(0.0, 1.0)))
                .collect(),
        )
    };
    let alpha = Map::from_vec(s, s, t.alpha.clone())?;
    write_png8(&outs[0], &[&ch(0)?, &ch(1)?, &ch(2)?, &alpha])?;
    t.equalised.write_linear(&outs[1])?;
    json_out(&outs[2], &t.report)?;
    Ok(t.report)
}

/// Turns a baked texture into melanin and hemoglobin maps; writes `melanin.exr`,
/// `hemoglobin.exr` (the channels `derma rig` and `derma skin` read), `residual.exr` (ΔE*ab), `confidence.exr`
/// and `chromophores.json`, inverting the colours in `lut` (the model the maps will be painted
/// with). `exposure`: `None` fits it. The mask selects the texels the fit and the report use;
/// every texel gets its maps.
pub fn chromophore_files(
    texture: &Path,
    mask: Option<&Path>,
    lut: &SkinColorLut,
    exposure: Option<f64>,
    out_dir: &Path,
    progress: &dyn Progress,
) -> Result<ChromophoreReport> {
    use derma_optics::bio::names;
    ensure_writable_dir(out_dir)?;
    let outs: Vec<PathBuf> = [
        "melanin.exr",
        "hemoglobin.exr",
        "residual.exr",
        "confidence.exr",
        "chromophores.json",
    ]
    .iter()
    .map(|n| out_dir.join(n))
    .collect();
    let mut inputs = vec![texture];
    inputs.extend(mask);
    check_inputs_spared(&outs, &inputs)?;
    progress.stage("invert the skin colour model", 0, Unit::Steps);
    // The texture and the mask are read at once.
    let (tex, grey) = rayon::join(
        || RgbImage::read_linear(texture),
        || mask.map(derma_core::image_io::read_grey).transpose(),
    );
    let tex = tex?;
    let m: Option<Vec<bool>> = match (mask, grey?) {
        (Some(p), Some(g)) => {
            let g = &g.channels[0];
            if (g.width(), g.height()) != (tex.width, tex.height) {
                return Err(PhotoError::Invalid(derma_core::Invalid::new(
                    format!("mask '{}'", p.display()),
                    format!("the texture's size ({}×{})", tex.width, tex.height),
                    format!("{}×{}", g.width(), g.height()),
                )));
            }
            Some(g.data().iter().map(|v| *v > 0.5).collect())
        }
        _ => None,
    };
    let e = match exposure {
        Some(e) => e,
        None => {
            let sel: Vec<[f32; 3]> = tex
                .data
                .iter()
                .enumerate()
                .filter(|(i, _)| m.as_ref().is_none_or(|m| m[*i]))
                .map(|(_, c)| *c)
                .collect();
            fit_exposure(lut, &sel)
        }
    };
    let c = invert(lut, &tex, m.as_deref(), e)?;
    write_exr(&outs[0], &[(names::MELANIN, &c.melanin)], ExrPrecision::F32)?;
    write_exr(
        &outs[1],
        &[(names::HEMOGLOBIN, &c.hemoglobin)],
        ExrPrecision::F32,
    )?;
    write_exr(&outs[2], &[("delta_e", &c.residual)], ExrPrecision::F32)?;
    write_exr(
        &outs[3],
        &[("confidence", &c.confidence)],
        ExrPrecision::F32,
    )?;
    json_out(&outs[4], &c.report)?;
    Ok(c.report)
}

/// Settings of [`synthetic_set`].
#[derive(Clone, Copy, Debug)]
pub struct SyntheticOptions {
    /// Photo width (height is ¾ of it).
    pub width: u32,
    /// Landmark noise (pixels, per axis).
    pub noise_px: f64,
    /// Seed of the freckles and the noise.
    pub seed: u64,
}

/// Writes a synthetic photo set of the built-in head's face: `face.obj` (no UVs),
/// `photoN.png` from five cameras (varied light, exposure, white balance, vignetting),
/// `points.json` (clicked feature points, 1.5 px noise), and `truth.json` (the true cameras).
pub fn synthetic_set(
    opts: &SyntheticOptions,
    out_dir: &Path,
    progress: &dyn Progress,
) -> Result<()> {
    ensure_writable_dir(out_dir)?;
    let head = Head::builtin();
    let lut = SkinColorLut::builtin();
    let views = synthetic::default_views();
    progress.stage("render synthetic photos", views.len() as u64, Unit::Steps);
    let mesh = synthetic::face_disc(head)?;
    let mut face = mesh.clone();
    face.uvs.clear();
    face.write_obj(&out_dir.join("face.obj"))?;
    let seed = opts.seed;
    let albedo = synthetic::truth_albedo(&lut, seed);
    let size = (opts.width, opts.width * 3 / 4);
    let (photos, points) = synthetic::photo_set(head, &mesh, &albedo, size, opts.noise_px, seed);
    let mut photos_json = Vec::new();
    let mut truth = Vec::new();
    for (photo, pts) in photos.iter().zip(&points) {
        photo.image.write_linear(&out_dir.join(&photo.name))?;
        photos_json.push(serde_json::json!({
            "image": photo.name,
            "width": size.0,
            "height": size.1,
            "points": pts.points.iter().map(|c| {
                if c.label.starts_with('v') {
                    serde_json::json!({"world": c.world.to_array(), "pixel": c.pixel.to_array()})
                } else {
                    serde_json::json!({"name": c.label, "pixel": c.pixel.to_array()})
                }
            }).collect::<Vec<_>>(),
        }));
        truth.push(serde_json::json!({"image": photo.name, "camera": photo.camera}));
        progress.advance(1);
    }
    json_out(
        &out_dir.join("points.json"),
        &serde_json::json!({"photos": photos_json}),
    )?;
    json_out(
        &out_dir.join("truth.json"),
        &serde_json::json!({"photos": truth}),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cameras_name_photos_relative_to_their_folder_even_beside_it() {
        let d = derma_test_support::scratch_dir("relative_paths");
        for sub in ["photos", "calib/out"] {
            std::fs::create_dir_all(d.join(sub)).unwrap();
        }
        std::fs::write(d.join("photos/a.png"), b"").unwrap();
        std::fs::write(d.join("calib/b.png"), b"").unwrap();
        assert_eq!(
            relative(&d.join("photos/a.png"), &d.join("calib/out")),
            Path::new("../../photos/a.png")
        );
        assert_eq!(
            relative(&d.join("calib/b.png"), &d.join("calib")),
            Path::new("b.png")
        );
        // What read_cameras does with it: joined to the folder, the same file.
        let back = d.join("calib/out").join("../../photos/a.png");
        assert_eq!(
            std::fs::canonicalize(back).unwrap(),
            std::fs::canonicalize(d.join("photos/a.png")).unwrap()
        );
    }
}
