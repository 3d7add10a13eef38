//! `derma render`'s orchestration: load a texture set (and a mesh, a rig frame, an iris), build
//! the scene once, and write the views, turntables and contact sheets, each file atomically.

use crate::error::{ExportError, Result};
use derma_core::progress::{Job, Progress, Unit};
use derma_core::Map;
use derma_render::camera::View;
use derma_render::lighting::Setup;
use derma_render::material::SkinMaps;
use derma_render::scene::{Material, Scene};
use derma_rig::{GlobalScale, Normalization, WeightSpec};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A rig frame: the texture set's skin re-shaded with the frame's hemoglobin.
pub struct RigFrame {
    /// The rig directory (`derma rig build`).
    pub dir: PathBuf,
    /// Target weights.
    pub weights: WeightSpec,
    /// Global hemoglobin scale.
    pub global: GlobalScale,
}

/// What `derma render` draws and writes.
pub struct RenderJob {
    /// The texture set directory.
    pub textures: PathBuf,
    /// A user mesh; `None`: the head with its eyes, lashes, teeth and tongue.
    pub mesh: Option<PathBuf>,
    /// A fitted head directory (`derma head fit`); `None`: the built-in head.
    pub head: Option<PathBuf>,
    /// Lighting setups (one image each).
    pub setups: Vec<Setup>,
    /// Image size (pixels).
    pub size: (u32, u32),
    /// The camera.
    pub view: View,
    /// Also a turntable of this many frames per setup (APNG).
    pub turntable: Option<usize>,
    /// Also the contact sheet (views under every setup beside the maps).
    pub sheet: bool,
    /// Also linear radiance as EXR.
    pub exr: bool,
    /// Colour from a rig frame.
    pub rig: Option<RigFrame>,
    /// Face-unit weights posing the built-in head (e.g. mouthSmileLeft=1).
    pub face_units: Vec<(String, f32)>,
    /// An eye texture on the head's eye UVs (`derma photo iris`).
    pub iris: Option<PathBuf>,
    /// A teeth texture on the head's teeth UVs (`derma photo teeth`).
    pub teeth: Option<PathBuf>,
    /// Gaze yaw and pitch (degrees).
    pub gaze: (f32, f32),
    /// Lid closure in [0, 1] (a blink's peak; 0 open).
    pub blink: f32,
    /// Pupil diameter (mm) drawn through the eye texture's coordinates; `None`: the texture's
    /// own (4 mm).
    pub pupil_mm: Option<f32>,
    /// Draw the lacrimal lake along the lid margins.
    pub lake: bool,
    /// Where to draw: a GPU (the full renderer) or the CPU (no subsurface scattering, shadows,
    /// lake or refraction; [`derma_render::CpuRenderer`]).
    pub device: derma_core::gpu::Device,
    /// Output directory.
    pub out: PathBuf,
}

/// What was written and measured.
#[derive(Clone, Debug, Serialize)]
pub struct RenderReport {
    /// What drew: the GPU adapter, or the CPU renderer.
    pub adapter: String,
    /// Every file written.
    pub files: Vec<PathBuf>,
    /// Frames rendered.
    pub frames: usize,
    /// Mean wall time per frame including read-back (s).
    pub seconds_per_frame: f64,
}

/// The skin of `rig` (read from `dir`), checked to be the one of the texture set whose decoded
/// base colour is `base`: refused for a rig of bare maps (its colour is the LUT's, and would
/// replace the set's) or of another set.
pub fn skin_of<'a>(
    rig: &'a derma_rig::Rig,
    dir: &Path,
    base: &[Map; 3],
) -> Result<&'a derma_rig::skin_response::SkinResponse> {
    let bad = |detail: String| {
        ExportError::from(derma_core::CoreError::Format {
            path: dir.to_path_buf(),
            message: detail,
        })
    };
    let skin = rig.skin.as_ref().ok_or_else(|| {
        bad("built from bare hemoglobin and melanin maps, its colour is the skin-colour LUT's and would replace the set's base colour; build the rig from the texture set".into())
    })?;
    let (w, h) = (base[0].width(), base[0].height());
    if skin.size() != (w, h) {
        return Err(bad(format!(
            "its maps are {}×{}; the texture set is {w}×{h} (build the rig from this set)",
            skin.size().0,
            skin.size().1
        )));
    }
    let differ = (0..w * h)
        .filter(|&i| {
            (0..3).any(|c| derma_core::image_io::srgb8(base[c].data()[i]) != skin.base[i][c])
        })
        .count();
    if differ > 0 {
        return Err(bad(format!(
            "its base colour differs from the texture set's on {differ} texels: it was built from another set"
        )));
    }
    Ok(skin)
}

/// The frame's colour of the rig in `f` on the texture set whose decoded base colour is `base`.
fn rig_color(f: &RigFrame, base: &[Map; 3]) -> Result<[Map; 3]> {
    let (rig, lut, _) = derma_rig::rig_dir::load(&f.dir)?;
    skin_of(&rig, &f.dir, base)?;
    let (w, g) =
        derma_rig::weights::frame_weights(&rig, &f.weights, Normalization::default(), f.global)?;
    let melanin = rig.melanin.clone().ok_or_else(|| {
        ExportError::from(derma_core::CoreError::Format {
            path: f.dir.clone(),
            message: "the rig has no melanin map to colour with; build the rig with one".into(),
        })
    })?;
    let (_, rgb) = derma_rig::evaluate_frame(
        &rig,
        &lut,
        &w,
        g,
        Some(&melanin),
        derma_core::gpu::Device::Cpu,
    )?;
    Ok(rgb.expect("colour with melanin"))
}

fn write_rgb8(path: &Path, m: &[Map; 3]) -> Result<()> {
    Ok(derma_core::image_io::write_png8(
        path,
        &[&m[0], &m[1], &m[2]],
    )?)
}

/// Refuses face-unit names `head` lacks.
fn check_units(head: &derma_head::Head, units: &[(&str, f32)]) -> Result<()> {
    for (n, _) in units {
        if !head.face_units().iter().any(|u| u.name == *n) {
            return Err(derma_core::Invalid::new(
                "face unit",
                "one of the head's 52 (e.g. mouthSmileLeft, jawOpen, eyeBlinkLeft)",
                format!("'{n}'"),
            )
            .into());
        }
    }
    Ok(())
}

/// The user mesh at `path` through the head fitted to it in `dir`: read at the scale the fit
/// read it, refused when it is not the fitted mesh, posed by `units` carried onto it through
/// the fit's correspondence (one map for every unit), with the head's globes, lashes, teeth
/// and tongue in its openings.
fn fitted_mesh_scene(
    path: &Path,
    dir: &Path,
    skin_dir: &Path,
    units: &[(&str, f32)],
    skin: SkinMaps,
    eye: Option<[Map; 3]>,
    gaze: (f32, f32),
) -> Result<Scene> {
    let head = derma_head::fitted::open(dir)?;
    check_units(head, units)?;
    let mut mesh = derma_head::fitted::load_scan(
        dir,
        path,
        derma_core::head_mesh::HeadUnit::Auto,
        &Default::default(),
        &derma_core::Silent,
    )?;
    check_layout(skin_dir, &mesh.uv_layout(), path)?;
    let carry = derma_head::fit::onto::Carry::new(head, &mesh);
    crate::glb::check_share(carry.share(), path)?;
    if !units.is_empty() {
        let posed = head.posed_skin(units);
        let dense: Vec<glam::Vec3> = posed
            .positions
            .iter()
            .zip(&head.skin.positions)
            .map(|(a, b)| *a - *b)
            .collect();
        for (v, d) in carry.offsets(&dense) {
            mesh.positions[v as usize] += d;
        }
        mesh.compute_normals();
    }
    let lashes = skin.lash_color.map(glam::Vec3::from);
    Ok(Scene::mesh(&mesh, skin).with_parts(head, lashes, eye, gaze))
}

/// Refuses to draw the set in `textures` on a mesh (`what`) whose UV layout is not the one
/// its manifest says it was painted on: its texels would land on the wrong skin. Sets without
/// a recorded layout (made before manifests had one, or by other tools) are not checked.
fn check_layout(textures: &Path, layout: &derma_core::mesh::UvLayout, what: &Path) -> Result<()> {
    let manifest = textures.join(derma_skin::outputs::MANIFEST);
    if !manifest.is_file() {
        return Ok(());
    }
    let m = derma_skin::manifest::read(&manifest)?;
    let painted: Option<derma_core::mesh::UvLayout> =
        serde_json::from_value(m["uv_layout"].clone()).ok();
    match painted {
        Some(p) if !p.matches(layout) => Err(derma_core::Invalid::new(
            format!("the set '{}'", textures.display()),
            format!(
                "a mesh with the UV layout it was painted on ({} triangles, UV area {:.4}; render it on the mesh it was painted on, or paint it again on this one)",
                p.triangles, p.signed_area
            ),
            format!(
                "'{}', which has another UV layout ({} triangles, UV area {:.4})",
                what.display(),
                layout.triangles,
                layout.signed_area
            ),
        )
        .into()),
        _ => Ok(()),
    }
}

/// The scene the job draws: the set on a user mesh (through its fitted head, or alone), or on
/// the built-in or fitted head, posed by the units and the eye model; every mesh checked
/// against the UV layout the set was painted on.
fn scene_of(
    job: &RenderJob,
    skin: &SkinMaps,
    eye: Option<[Map; 3]>,
    units: &[(&str, f32)],
    progress: &dyn Progress,
) -> Result<Scene> {
    let scene = match (&job.mesh, job.head.as_deref()) {
        (Some(p), Some(dir)) => {
            fitted_mesh_scene(p, dir, &job.textures, units, skin.clone(), eye, job.gaze)?
        }
        (Some(_), None) if !units.is_empty() => {
            return Err(derma_core::Invalid::new(
                "face units on a user mesh",
                "the head fitted to it, through which they pose it (derma head fit)",
                "no fitted head",
            )
            .into())
        }
        (Some(p), None) => {
            let mesh = crate::glb::load_mesh_mm(p, progress)?;
            check_layout(&job.textures, &mesh.uv_layout(), p)?;
            Scene::mesh(&mesh, skin.clone())
        }
        (None, dir) => {
            let head = derma_head::fitted::or_builtin(dir)?;
            let name = dir.map_or_else(|| "the built-in head".into(), |d| d.display().to_string());
            check_layout(
                &job.textures,
                derma_skin::builtin_head::template_layout(),
                Path::new(&name),
            )?;
            check_units(head, units)?;
            let pose = derma_eyes::still::EyePose {
                gaze: job.gaze,
                closure: job.blink,
            };
            if pose == derma_eyes::still::EyePose::REST {
                Scene::head(head, skin.clone(), units, eye, job.gaze)
            } else {
                // The lids and the skin around the eyes follow the gaze through the trained
                // eye-region model (thesis §3.9), the pose's units among its inputs.
                let mut posed = head.posed_skin(units);
                let lashes = derma_eyes::still::StillModel::new(head)?
                    .pose_skin(head, pose, units, &mut posed);
                let mut scene = Scene::posed_head(head, posed, skin.clone(), eye, job.gaze);
                for (name, mesh) in &lashes {
                    scene.replace_part_mesh(name, mesh);
                }
                scene
            }
        }
    };
    Ok(scene)
}

/// The face units posing the head: the job's own, plus (where the head can be posed: the
/// built-in or a fitted head) the rig frame's library expressions through their face units
/// ([`derma_rig::expression::face_units`]); a unit given both ways adds up to at most 1.
fn posing_units(job: &RenderJob) -> Vec<(&str, f32)> {
    let mut units: Vec<(&str, f32)> = job
        .face_units
        .iter()
        .map(|(n, w)| (n.as_str(), *w))
        .collect();
    let posable = job.mesh.is_none() || job.head.is_some();
    if let (Some(f), true) = (&job.rig, posable) {
        let e = f.weights.entries.iter().map(|(n, w)| (n.as_str(), *w));
        for (u, w) in derma_rig::expression::face_units(e) {
            derma_rig::expression::add_unit(&mut units, u, w);
        }
    }
    units
}

/// Runs the job.
pub fn run(job: &RenderJob, progress: &dyn Progress) -> Result<RenderReport> {
    let t0 = Instant::now();
    derma_core::atomic::ensure_writable_dir(&job.out)?;
    if job.setups.is_empty() {
        return Err(derma_core::Invalid::new("lighting setups", "at least one", "none").into());
    }
    let mut skin = SkinMaps::from_dir(&job.textures)?;
    if let Some(f) = &job.rig {
        skin.base_color = rig_color(f, &skin.base_color)?;
    }
    let job_p = Job::new(progress);
    job_p.stage("scene", 1, Unit::Steps);
    let eye = job
        .iris
        .as_deref()
        .map(derma_eyes::files::load_eye_texture)
        .transpose()?;
    let units = posing_units(job);
    if !units.is_empty() {
        if let Some(wm) = derma_render::wrinkles::WrinkleMaps::from_dir(&job.textures)? {
            skin.normal = wm.blend(&skin.normal, units.iter().copied(), skin.wrap)?;
        }
    }
    let mut scene = scene_of(job, &skin, eye, &units, progress)?;
    if let Some(d) = job.pupil_mm {
        if scene.set_pupil(d) == 0 {
            return Err(derma_core::Invalid::new(
                format!("pupil diameter {d} mm"),
                "a scene with the head's globes",
                "a scene with none (a user mesh without its fitted head)",
            )
            .into());
        }
    }
    if let Some(p) = &job.teeth {
        if scene.texture_parts("teeth", &derma_render::material::read_albedo(p)?) == 0 {
            return Err(derma_core::Invalid::new(
                format!("teeth texture '{}'", p.display()),
                "a scene with the head's teeth",
                "a scene with none (a user mesh)",
            )
            .into());
        }
    }
    debug_assert!(matches!(scene.parts[0].material, Material::Skin(_)));
    let parts: Vec<String> = scene.parts.iter().map(|p| p.name.clone()).collect();
    let r = derma_render::renderer(&scene, job.device)?;
    r.set_lake(job.lake);
    let mut files = Vec::new();
    let mut frames = 0usize;
    let (w, h) = job.size;
    let total = job.setups.len() * (1 + job.turntable.unwrap_or(0))
        + if job.sheet { 3 * job.setups.len() } else { 0 };
    job_p.stage("render", total as u64, Unit::Steps);
    let tr = Instant::now();
    for s in &job.setups {
        let img = r.draw(&job.view, &s.lighting(), w, h)?;
        frames += 1;
        job_p.advance(1);
        let p = job.out.join(format!("{}.png", s.name()));
        write_rgb8(&p, &img.display_maps())?;
        files.push(p);
        if job.exr {
            let p = job.out.join(format!("{}.exr", s.name()));
            let m = img.linear_maps();
            derma_core::image_io::write_exr(
                &p,
                &[("R", &m[0]), ("G", &m[1]), ("B", &m[2])],
                derma_core::image_io::ExrPrecision::F16,
            )?;
            files.push(p);
        }
        if let Some(n) = job.turntable {
            let fr = derma_render::sheet::turntable(&*r, *s, n, w, h)?;
            frames += n;
            job_p.advance(n as u64);
            let p = job.out.join(format!("{}-turntable.png", s.name()));
            derma_core::image_io::write_apng(&p, &fr, w as usize, h as usize, 12)?;
            files.push(p);
        }
    }
    if job.sheet {
        let panel = w.min(h);
        let m = derma_render::sheet::contact_sheet(&*r, &skin, &job.setups, panel)?;
        frames += 3 * job.setups.len();
        job_p.advance(3 * job.setups.len() as u64);
        let p = job.out.join("sheet.png");
        write_rgb8(&p, &m)?;
        files.push(p);
    }
    let per = tr.elapsed().as_secs_f64() / frames.max(1) as f64;
    let report = RenderReport {
        adapter: r.name(),
        files: files.clone(),
        frames,
        seconds_per_frame: per,
    };
    let json = serde_json::json!({
        "adapter": report.adapter,
        "frames": frames,
        "seconds_per_frame": per,
        "total_seconds": t0.elapsed().as_secs_f64(),
        "size": [w, h],
        "lighting": job.setups.iter().map(|s| s.name()).collect::<Vec<_>>(),
        "view": {"yaw_deg": job.view.yaw_deg, "pitch_deg": job.view.pitch_deg, "zoom": job.view.zoom},
        "textures": job.textures,
        "mesh": job.mesh,
        "parts": parts,
        "files": files,
    });
    derma_core::report::write_json(
        &job.out.join("render.json"),
        &json,
        derma_core::report::JsonFormat::DATA_PRETTY,
    )?;
    job_p.finish();
    Ok(report)
}
