//! The `derma eyes …` commands' work on files: training a model (from tracked data or the rig),
//! writing synthetic tracked sequences, animating the head (curves, GLB, rendered frames) and
//! the distance-field table with its images. The CLI only parses and prints.

use crate::animate::{self, Drive, Sample};
use crate::evaluate::{Evaluator, Frame};
use crate::glb;
use crate::model::{self, Components, Curve, EyeModel};
use crate::render::{self, Stage};
use crate::rigdata::Rig;
use crate::sdf::{self, material};
use crate::surface::Skin;
use crate::tracked::Tracked;
use crate::Result;
use derma_core::progress::{Progress, Unit};
use derma_core::Map;
use derma_head::Head;
use derma_render::frame::Steps;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Where training data comes from.
#[derive(Clone, Debug)]
pub enum Data {
    /// A tracked-data file (JSON or CSV).
    File(PathBuf),
    /// `n` sampled poses of the head's rig (the built-in head, or a fitted one).
    Rig {
        /// Poses.
        samples: usize,
        /// Seed.
        seed: u64,
        /// A fitted head directory (`derma head fit`); `None`: the built-in head.
        head: Option<PathBuf>,
    },
}

/// What `train` wrote and measured.
#[derive(Clone, Debug, Serialize)]
pub struct TrainReport {
    /// Frames trained on.
    pub frames: usize,
    /// Tracked vertices.
    pub vertices: usize,
    /// Components used.
    pub components: Components,
    /// Held-out error against the number of components (fig. 3.7).
    pub curve: Curve,
    /// Palpebral opening (mm) the baseline model gives in primary gaze and at 40° downgaze, per
    /// eye (Read et al. 2006: 9.7 ± 1.2 and 6.4 ± 1.1).
    pub aperture_mm: [[f32; 2]; 2],
    /// Files written.
    pub files: Vec<PathBuf>,
}

fn out_dir(dir: &Path) -> Result<()> {
    derma_core::atomic::ensure_writable_dir(dir)?;
    Ok(())
}

/// Trains a model and writes `model.json`, `components.csv` (fig. 3.7), `report.json` and, for
/// rig data, `tracked.json` into `dir`.
pub fn train(
    data: &Data,
    c: Components,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<TrainReport> {
    out_dir(dir)?;
    progress.stage("train the lid and skin model", 1, Unit::Steps);
    let mut files = Vec::new();
    let t = match data {
        Data::File(p) => Tracked::read(p)?,
        Data::Rig {
            samples,
            seed,
            head,
        } => {
            let rig = Rig::new(derma_head::fitted::or_builtin(head.as_deref())?)?;
            let t = rig.samples(*samples, *seed);
            let p = dir.join("tracked.json");
            t.write(&p)?;
            files.push(p);
            t
        }
    };
    let m = EyeModel::fit(&t, c)?;
    let curve = model::cross_validate(&t, Components { lids: 13, skin: 8 }, 5)?;
    let p = dir.join("model.json");
    m.write(&p)?;
    files.push(p);
    let mut csv = String::from("components,lid_error,skin_error\n");
    for (i, k) in curve.components.iter().enumerate() {
        let f = |v: &Vec<f64>| v.get(i).map_or(String::new(), |x| format!("{x:.6e}"));
        csv.push_str(&format!("{k},{},{}\n", f(&curve.lids), f(&curve.skin)));
    }
    let p = dir.join("components.csv");
    derma_core::atomic::write_bytes(&p, csv.as_bytes())?;
    files.push(p);
    let aperture_mm = [0, 1].map(|e| {
        [
            m.baseline_opening_mm(e, 0.0, 0.0),
            m.baseline_opening_mm(e, 0.0, -40.0),
        ]
    });
    // report.json lists itself among the files written.
    let p = dir.join("report.json");
    files.push(p.clone());
    let report = TrainReport {
        frames: t.frames.len(),
        vertices: t.vertex_count(),
        components: c,
        curve,
        aperture_mm,
        files,
    };
    derma_core::report::write_json(&p, &report, derma_core::report::JsonFormat::REPORT)?;
    progress.advance(1);
    Ok(report)
}

/// Writes a synthetic tracked sequence of the rig (JSON or CSV by extension).
pub fn synthetic(
    out: &Path,
    seconds: f32,
    fps: f32,
    seed: u64,
    head: Option<&Path>,
    progress: &dyn Progress,
) -> Result<usize> {
    if !(seconds > 0.0 && fps > 0.0) {
        return Err(derma_core::Invalid::new(
            "seconds and fps",
            "both positive",
            format!("a clip of {seconds} s at {fps} frames per second"),
        )
        .into());
    }
    progress.stage("synthesise tracked data", 1, Unit::Steps);
    let head = derma_head::fitted::or_builtin(head)?;
    let rig = Rig::new(head)?;
    let t = crate::synthetic::sequence(
        &rig,
        [head.eyes[0].centre, head.eyes[1].centre],
        seconds,
        fps,
        seed,
    );
    t.write(out)?;
    progress.advance(1);
    Ok(t.frames.len())
}

/// Where gaze targets come from.
#[derive(Clone, Debug)]
pub enum Targets {
    /// Idle-gaze statistics.
    Idle,
    /// A gaze-tracker CSV (time, h, v).
    Tracker(PathBuf),
    /// Salient points of an image the character looks at (horizontal field of view in °).
    Image(PathBuf, f32),
}

/// Options of `animate`.
#[derive(Clone, Debug)]
pub struct AnimateOptions {
    /// A trained model; `None` trains one on the rig.
    pub model: Option<PathBuf>,
    /// The drivers (fixations and blinks are filled from `targets`).
    pub drive: Drive,
    /// Gaze targets.
    pub targets: Targets,
    /// Rendered frame width (px); 0 for no renders.
    pub render: usize,
    /// Skin thickness cap over the globes (mm).
    pub thickness: f32,
    /// An eyeball texture on the head's eye UVs (`derma photo iris`: eye.exr linear, or eye.png
    /// sRGB); the default eye otherwise.
    pub iris: Option<PathBuf>,
    /// A fitted head directory (`derma head fit`); `None`: the built-in head.
    pub head: Option<PathBuf>,
    /// The user's own mesh the head was fitted to (with UVs; needs `head`): the animation moves
    /// its vertices (through the fit's B map) in place of the fitted head's skin.
    pub mesh: Option<PathBuf>,
}

/// Loads an eyeball texture as linear RGB maps (EXR as stored, other formats sRGB-decoded).
pub fn load_eye_texture(path: &Path) -> Result<[Map; 3]> {
    use derma_render::RenderError;
    derma_render::material::read_albedo(path)
        .map(|t| t.rgb)
        .map_err(|e| match e {
            RenderError::Core(e) => e.into(),
            RenderError::Invalid(e) => e.into(),
            e => derma_core::Invalid::new(
                format!("eye texture '{}'", path.display()),
                "a readable RGB image",
                e,
            )
            .into(),
        })
}

/// What `animate` wrote and measured.
#[derive(Clone, Debug, Serialize)]
pub struct AnimateReport {
    /// Frames.
    pub frames: usize,
    /// Blinks in the sequence.
    pub blinks: usize,
    /// Model vertices animated.
    pub vertices: usize,
    /// The GLB's morph-target fit.
    pub glb: glb::Report,
    /// Mean time (µs) of one model frame (all region vertices, one core).
    pub frame_us: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The model to animate: a file, or one trained on 300 rig poses.
pub fn load_or_train(p: &Option<PathBuf>, rig: &Rig) -> Result<EyeModel> {
    match p {
        Some(p) => EyeModel::read(p),
        None => EyeModel::fit(&rig.samples(300, 1), Components::default()),
    }
}

/// Animates the head: `curves.json`/`curves.csv`, `head.glb`, and with renders `sequence.png`
/// (animated PNG), `strip.png` and `frames/NNNN.png`.
pub fn animate(o: &AnimateOptions, dir: &Path, progress: &dyn Progress) -> Result<AnimateReport> {
    out_dir(dir)?;
    progress.stage("load or train the model", 1, Unit::Steps);
    let head = derma_head::fitted::or_builtin(o.head.as_deref())?;
    let rig = Rig::new(head)?;
    let m = load_or_train(&o.model, &rig)?;
    progress.advance(1);
    let ev = Evaluator::new(&m, &rig.region, head, o.thickness)?;
    let skin = match (&o.mesh, &o.head) {
        (None, _) => Skin::of_head(head),
        (Some(p), Some(dir)) => {
            let mesh = derma_head::fitted::load_scan(
                dir,
                p,
                derma_core::head_mesh::HeadUnit::Auto,
                &Default::default(),
                progress,
            )?;
            Skin::user(head, mesh, p)?
        }
        (Some(p), None) => {
            return Err(derma_core::Invalid::new(
                format!("the user's mesh '{}'", p.display()),
                "the head fitted to it (its fitted head directory, from 'derma head fit', through which a user's mesh is animated)",
                "no fitted head",
            )
            .into())
        }
    };
    let mut drive = o.drive.clone();
    match &o.targets {
        Targets::Idle => {}
        Targets::Tracker(p) => drive.fixations = Some(animate::read_tracker(p)?),
        Targets::Image(p, fov) => {
            let img = derma_core::image_io::read_rgb(p)?;
            let rgb: [Map; 3] = img.channels.try_into().map_err(|c: Vec<Map>| {
                derma_core::Invalid::new(
                    format!("look-at image '{}'", p.display()),
                    "an RGB image",
                    format!("{} channels", c.len()),
                )
            })?;
            drive.fixations = Some(animate::salient_fixations(
                &rgb,
                8,
                *fov,
                drive.seconds,
                drive.seed,
            ));
        }
    }
    let centres = [head.eyes[0].centre, head.eyes[1].centre];
    let samples = animate::timeline(&m, centres, head.eyes[0].radius + o.thickness, &drive);
    let blinks = drive
        .blinks
        .clone()
        .unwrap_or_else(|| crate::blink::schedule(drive.seconds, drive.activity, drive.seed))
        .len();
    let mut files = Vec::new();
    files.extend(write_curves(&samples, dir)?);
    // The model's cost per frame, on one core, over the first frames (at most 60).
    let mut f = Frame::default();
    let t0 = std::time::Instant::now();
    let timed = samples.len().min(60);
    for s in &samples[..timed] {
        ev.frame(&s.gaze, &mut f);
    }
    let frame_us = t0.elapsed().as_secs_f64() * 1e6 / timed.max(1) as f64;
    let mut frames = Vec::new();
    // Frames are evaluated as the GLB's fit and projection ask for them (in parallel, never all
    // held): memory stays bounded for any clip length.
    let evaluate = |i: usize| {
        let mut f = Frame::default();
        ev.frame(&samples[i].gaze, &mut f);
        f.positions
    };
    let baked = glb::Baked {
        times: samples.iter().map(|s| s.t).collect(),
        positions: &evaluate,
        rotations: samples
            .iter()
            .map(|s| s.gaze.eyes.map(|a| a.rotation()))
            .collect(),
    };
    progress.stage("evaluate frames and write the animated GLB", 1, Unit::Steps);
    let eye_texture = o.iris.as_deref().map(load_eye_texture).transpose()?;
    let p = dir.join("head.glb");
    let glb = glb::write(head, &rig.region, &skin, &baked, eye_texture.as_ref(), &p)?;
    files.push(p);
    progress.advance(1);
    if o.render > 0 {
        progress.stage("render frames", samples.len() as u64, Unit::Frames);
        let stage = Stage::new(head, &rig.region, &skin, eye_texture.clone());
        let fdir = dir.join("frames");
        std::fs::create_dir_all(&fdir).map_err(|source| derma_core::CoreError::Write {
            path: fdir.clone(),
            source,
        })?;
        let mut size = (0, 0);
        for (i, s) in samples.iter().enumerate() {
            ev.frame(&s.gaze, &mut f);
            let img = stage.render(&f, s.gaze.eyes.map(|a| a.rotation()), o.render);
            size = (img[0].width(), img[0].height());
            let p = fdir.join(format!("{i:04}.png"));
            derma_core::image_io::write_png8_srgb(&p, &[&img[0], &img[1], &img[2]])?;
            frames.push(render::srgb8(&img));
            progress.advance(1);
        }
        let p = dir.join("sequence.png");
        derma_core::image_io::write_apng(&p, &frames, size.0, size.1, drive.fps.round() as u16)?;
        files.push(p);
        files.push(fdir);
    }
    Ok(AnimateReport {
        frames: samples.len(),
        blinks,
        vertices: ev.optimised.len(),
        glb,
        frame_us,
        files,
    })
}

fn write_curves(samples: &[Sample], dir: &Path) -> Result<Vec<PathBuf>> {
    let p = dir.join("curves.json");
    derma_core::report::write_json(&p, &samples, derma_core::report::JsonFormat::DATA)?;
    let mut csv = String::from("time,left_h,left_v,right_h,right_v,left_upper,left_lower,right_upper,right_lower,blink_closure\n");
    for s in samples {
        let g = &s.gaze;
        csv.push_str(&format!(
            "{:.4},{:.3},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.4},{:.4}\n",
            s.t,
            g.eyes[0].h,
            g.eyes[0].v,
            g.eyes[1].h,
            g.eyes[1].v,
            g.lids[0][0],
            g.lids[0][1],
            g.lids[1][0],
            g.lids[1][1],
            s.closure
        ));
    }
    let q = dir.join("curves.csv");
    derma_core::atomic::write_bytes(&q, csv.as_bytes())?;
    Ok(vec![p, q])
}

/// Writes the distance-field table (`table.md`, `table.json`) and images (`mask.png`, fields
/// `exact.png`, `equiangular.png`, `backtracking.png`, `eye.png` / `lake.png` and the left eye's
/// `lake-closeup.png`: without the lake, with it, the field) at
/// `width` × `height` into `dir`; `runs` timed runs per method, plus the GPU rows when `device`
/// resolves to a GPU.
pub fn distance_fields(
    width: usize,
    height: usize,
    runs: usize,
    device: derma_core::Device,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<Vec<sdf::table::Row>> {
    out_dir(dir)?;
    if !(64..=8192).contains(&width) || !(64..=8192).contains(&height) {
        return Err(derma_core::Invalid::new(
            "size",
            "64 to 8192 pixels a side",
            format!("{width}×{height}"),
        )
        .into());
    }
    progress.stage("distance fields and the lake", 1, Unit::Steps);
    let head = Head::builtin();
    let scene = sdf::scene::head_close_up(head, width, height);
    let range = sdf::table::RANGE_MM;
    // Resolved in every build: `gpu` where the build has no GPU is an error, not a quiet CPU run.
    let device = device.resolve()?;
    #[cfg_attr(not(feature = "gpu"), allow(unused_mut))]
    let mut rows = sdf::table::measure(&scene.g, range, runs);
    #[cfg(feature = "gpu")]
    if device == derma_core::Device::Gpu {
        rows.extend(sdf::table::measure_gpu(&scene.g, range, runs.max(10))?);
    }
    #[cfg(not(feature = "gpu"))]
    let _ = device;
    derma_core::atomic::write_bytes(
        &dir.join("table.md"),
        sdf::table::markdown(&rows, width, height).as_bytes(),
    )?;
    derma_core::report::write_json(
        &dir.join("table.json"),
        &rows,
        derma_core::report::JsonFormat::REPORT,
    )?;
    let (w, h) = (width, height);
    let mask = Map::from_fn(w, h, |i| scene.g.mask[i] as f32 / 2.0);
    derma_core::image_io::write_png8(&dir.join("mask.png"), &[&mask])?;
    let show = |f: &sdf::Field| -> Map {
        // λ / Λ in grey on the globes (white at the skin, black at Λ and beyond), skin mid-grey.
        Map::from_fn(w, h, |i| match scene.g.mask[i] {
            material::EYE => (1.0 - f.distance[i] / range).clamp(0.0, 1.0),
            material::SKIN => 0.35,
            _ => 0.0,
        })
    };
    let exact = sdf::exact::field(&scene.g);
    derma_core::image_io::write_png8(&dir.join("exact.png"), &[&show(&exact)])?;
    let eq = sdf::samplers::field(
        &scene.g,
        sdf::samplers::Sampler::Equiangular { n: 64 },
        range,
    );
    derma_core::image_io::write_png8(&dir.join("equiangular.png"), &[&show(&eq)])?;
    let bt = sdf::samplers::field(&scene.g, sdf::table::DEFAULT, range);
    derma_core::image_io::write_png8(&dir.join("backtracking.png"), &[&show(&bt)])?;
    // One key light from the upper left (irradiance 1.6 π: a white matte surface facing it at
    // 1.6) over a grey ambient of 0.15.
    let mut light = derma_render::cpu::single_light(
        glam::Vec3::new(-0.4, 0.5, 0.75),
        glam::Vec3::splat(1.6 * std::f32::consts::PI),
    );
    (light.sky, light.ground) = (glam::Vec3::splat(0.15), glam::Vec3::splat(0.15));
    let plain = scene.frame.shade(&light, Steps::default());
    let lake = scene.frame.lake(&bt.distance, range);
    let lake = Steps {
        lake: Some(&lake),
        ..Steps::default()
    };
    let wet = scene.frame.shade(&light, lake);
    let to_maps = |img: &derma_render::Rendered| img.linear_maps();
    for (name, img) in [("eye.png", &plain), ("lake.png", &wet)] {
        let ch = to_maps(img);
        derma_core::image_io::write_png8_srgb(&dir.join(name), &[&ch[0], &ch[1], &ch[2]])?;
    }
    // A close-up of the left eye: without the lake, with it, and the field (λ / Λ).
    let cam = sdf::scene::Camera::close_up(head, width, height);
    let (c, _) = cam.project(head.eyes[0].centre);
    let (cw, ch) = (w * 9 / 40, h * 9 / 40);
    let (x0, y0) = (
        (c.x as usize).saturating_sub(cw / 2).min(w - cw),
        (c.y as usize).saturating_sub(ch / 2).min(h - ch),
    );
    let field = show(&bt);
    let panels: [[Map; 3]; 3] = [
        to_maps(&plain),
        to_maps(&wet),
        [field.clone(), field.clone(), field],
    ];
    // The three panels' crops side by side.
    let crop = [0, 1, 2].map(|k| {
        Map::from_fn(3 * cw, ch, |i| {
            let (x, y) = (i % (3 * cw), i / (3 * cw));
            panels[x / cw][k].get(x0 + x % cw, y0 + y)
        })
    });
    derma_core::image_io::write_png8_srgb(
        &dir.join("lake-closeup.png"),
        &[&crop[0], &crop[1], &crop[2]],
    )?;
    progress.advance(1);
    Ok(rows)
}
