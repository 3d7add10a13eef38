//! The main job end to end — surface → fields → features → bio maps → texture set → files —
//! behind a builder with documented defaults ([`SkinGenerator`]), and the result it produces
//! ([`TextureSet`]), which writes every file of [`crate::outputs`]. Orchestration only; the
//! physics lives in the modules it calls.
//!
//! ```no_run
//! # fn main() -> derma_skin::Result<()> {
//! use derma_skin::{SkinConfig, SkinGenerator};
//! let set = SkinGenerator::new(SkinConfig { size: 512, ..SkinConfig::default() }).threads(2).run()?;
//! set.write(std::path::Path::new("out"), &derma_core::progress::Silent)?;
//! # Ok(())
//! # }
//! ```

use crate::config::{SkinConfig, SurfaceKind};
use crate::feature_set::FeatureSet;
use crate::field::FieldSet;
use crate::outputs;
use crate::paint::BioMaps;
use crate::report::InputFiles;
use crate::surface::Surface;
use crate::texture_set::{HeightRange, RenderMaps};
use crate::{Result, SkinError};
use derma_core::gpu::Device;
use derma_core::head_mesh::MeshFrame;
use derma_core::mesh::TriMesh;
use derma_core::progress::{Job, Log, Note, Prefixed, Progress, Silent, Unit};
use derma_core::report::sha256_file;
use derma_core::Map;
use derma_shading::Appearance;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Which bio → render conversion the texture set uses.
#[derive(Clone, Default)]
pub enum AppearanceChoice {
    /// The built-in Monte Carlo match table (derma's default).
    #[default]
    Default,
    /// The analytic spectral Kubelka–Munk model.
    Analytic,
    /// A match table read by the caller.
    Table(Arc<derma_shading::TableAppearance>),
}

impl std::fmt::Debug for AppearanceChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            AppearanceChoice::Default => "Default",
            AppearanceChoice::Analytic => "Analytic",
            AppearanceChoice::Table(_) => "Table",
        })
    }
}

/// Bytes of memory per output texel at the pipeline's peak with the whole set in memory
/// ([`SkinGenerator::run`]): measured peak resident memory of `derma skin` on the built-in head
/// was 1.59 GB at 4096² and 5.51 GB at 8192² (issue 15), i.e. 78 bytes per added texel (bio
/// samples 48, the files' encodings of the render maps 20, UV raster 12, dilation sources 4,
/// less what is freed before the render maps exist); rounded up for a margin.
pub const BYTES_PER_TEXEL: f64 = 90.0;

/// [`BYTES_PER_TEXEL`] of the streamed main job ([`SkinGenerator::write_to`]): 0.84 GB at
/// 4096² and 2.22 GB at 8192² (issue 64), 27.5 bytes per added texel (UV raster 12, dilation
/// sources 4, heights 4, the preview's maps 11); rounded up for a margin.
pub const STREAMED_BYTES_PER_TEXEL: f64 = 36.0;

/// Memory the job takes whatever the size (the built-in head, its fields at 1024², the
/// features and their index): 0.27 GB measured by the same two runs, rounded up.
pub const FIXED_BYTES: f64 = 0.4e9;

/// Fails early when a `size`² texture set would not fit in memory whole.
pub fn check_memory(size: usize) -> Result<()> {
    check_need(size, BYTES_PER_TEXEL)
}

/// Fails early when the streamed main job of a `size`² set would not fit in memory.
pub fn check_memory_streamed(size: usize) -> Result<()> {
    check_need(size, STREAMED_BYTES_PER_TEXEL)
}

fn check_need(size: usize, per_texel: f64) -> Result<()> {
    match derma_core::memory::shortfall(FIXED_BYTES + per_texel * (size * size) as f64) {
        Some((need_gib, have_gib)) => Err(SkinError::TooLarge {
            width: size,
            height: size,
            need_gib,
            have_gib,
        }),
        None => Ok(()),
    }
}

/// Builds a skin texture set. Defaults: the given config, the built-in head (or the config's
/// surface), its default fields and regional biology, the Monte Carlo match table, [`Device::Auto`] for the
/// exemplar detail, all cores, no progress shown.
pub struct SkinGenerator<'a> {
    config: SkinConfig,
    config_path: Option<PathBuf>,
    mesh: Option<PathBuf>,
    head: Option<PathBuf>,
    fields: Option<PathBuf>,
    appearance: AppearanceChoice,
    device: Device,
    threads: Option<usize>,
    albedo: Option<PathBuf>,
    progress: &'a dyn Progress,
}

impl<'a> SkinGenerator<'a> {
    /// A generator for `config`.
    pub fn new(config: SkinConfig) -> Self {
        Self {
            config,
            config_path: None,
            mesh: None,
            head: None,
            fields: None,
            appearance: AppearanceChoice::Default,
            device: Device::Auto,
            threads: None,
            albedo: None,
            progress: &Silent,
        }
    }

    /// A generator for the TOML config at `path` (paths inside it are relative to its
    /// directory; report.json records its hash).
    pub fn from_config_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| {
            SkinError::Core(derma_core::CoreError::Read {
                path: path.to_path_buf(),
                source,
            })
        })?;
        let config = SkinConfig::from_toml(&text, &path.display().to_string())?;
        Ok(Self {
            config_path: Some(path.to_path_buf()),
            ..Self::new(config)
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SkinConfig {
        &self.config
    }

    /// The configuration, to override keys (size, seed, surface…) after loading.
    pub fn config_mut(&mut self) -> &mut SkinConfig {
        &mut self.config
    }

    /// A mesh with UVs (OBJ, glTF, GLB) instead of the config's surface.
    pub fn mesh(mut self, path: impl Into<PathBuf>) -> Self {
        self.mesh = Some(path.into());
        self
    }

    /// A fitted head (`derma head fit`'s directory) instead of the built-in one: painted itself
    /// (its template skin, derma's UVs), or, with a mesh, the scan it was fitted to, whose
    /// landmarks and regions it gives.
    pub fn head(mut self, dir: impl Into<PathBuf>) -> Self {
        self.head = Some(dir.into());
        self
    }

    /// A directory of painted fields (NAME.png / NAME.exr), over the defaults.
    pub fn fields(mut self, dir: impl Into<PathBuf>) -> Self {
        self.fields = Some(dir.into());
        self
    }

    /// The bio → render conversion (default: the built-in match table).
    pub fn appearance(mut self, appearance: AppearanceChoice) -> Self {
        self.appearance = appearance;
        self
    }

    /// Where `[detail]`'s exemplar synthesis runs (default [`Device::Auto`]; identical results).
    pub fn device(mut self, device: Device) -> Self {
        self.device = device;
        self
    }

    /// Worker threads (default: all cores); outputs are identical for any number.
    pub fn threads(mut self, threads: usize) -> Self {
        self.threads = Some(threads);
        self
    }

    /// A photographed albedo of the mesh (its own UV layout) to compare the painted set with,
    /// region by region ([`crate::albedo_compare`]): the set's `albedo_comparison`.
    pub fn compare_albedo(mut self, path: impl Into<PathBuf>) -> Self {
        self.albedo = Some(path.into());
        self
    }

    /// Where progress and notes go (default nowhere).
    pub fn progress(mut self, progress: &'a dyn Progress) -> Self {
        self.progress = progress;
        self
    }

    /// The configuration's directory, against which its relative paths resolve.
    fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        match self.config_path.as_ref().and_then(|c| c.parent()) {
            Some(d) if !p.is_absolute() => d.join(p),
            _ => p.to_path_buf(),
        }
    }

    /// The mesh to use: `--mesh`, else the config's (with `surface.kind = "mesh"`).
    fn mesh_path(&self) -> Option<PathBuf> {
        self.mesh.clone().or_else(|| {
            (self.config.surface.kind == SurfaceKind::Mesh && !self.config.surface.mesh.is_empty())
                .then(|| self.resolve(&self.config.surface.mesh))
        })
    }

    /// Every file the set writes into `dir` (whatever the appearance, for the overwrite check).
    pub fn output_files(dir: &Path) -> Vec<PathBuf> {
        outputs::OUTPUTS.iter().map(|o| dir.join(o.file)).collect()
    }

    /// Checks before any work that the config is valid, the streamed job fits in memory
    /// ([`check_memory`] checks the whole set's need), `dir` can be written and no input would
    /// be overwritten.
    pub fn check_output(&self, dir: &Path) -> Result<()> {
        self.config.validate("the options")?;
        check_memory_streamed(self.config.size as usize)?;
        for (what, p) in [
            ("mesh", &self.mesh),
            ("fields", &self.fields),
            ("head", &self.head),
        ] {
            if let Some(p) = p {
                if !p.exists() {
                    return Err(SkinError::Input {
                        path: p.clone(),
                        detail: format!("the {what} does not exist"),
                    });
                }
            }
        }
        derma_core::atomic::check_writable_dest(dir).map_err(|e| SkinError::Input {
            path: dir.to_path_buf(),
            detail: format!("the output directory is not writable ({e})"),
        })?;
        let mesh = self.mesh_path();
        let lm = self.config.surface.landmarks.trim();
        let landmarks = (!lm.is_empty() && lm != "mediapipe").then(|| self.resolve(lm));
        let inputs: Vec<&Path> = [&mesh, &self.config_path, &self.fields, &landmarks]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        derma_core::atomic::check_inputs_spared(&Self::output_files(dir), &inputs)?;
        // A directory holding another's files is refused now, not after the painting.
        derma_core::atomic::check_owned(dir, &outputs::owned)?;
        Ok(())
    }

    /// Runs the main job in memory (in its own thread pool when [`Self::threads`] was given).
    pub fn run(&self) -> Result<TextureSet> {
        check_memory(self.config.size as usize)?;
        let pool = self.pool()?;
        let mut set = match &pool {
            Some(p) => p.install(|| self.generate()),
            None => self.generate(),
        }?;
        set.pool = pool;
        Ok(set)
    }

    /// The worker pool of [`Self::threads`], when given.
    fn pool(&self) -> Result<Option<Arc<rayon::ThreadPool>>> {
        let Some(n) = self.threads else {
            return Ok(None);
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| SkinError::Key {
                key: "threads".into(),
                detail: format!("cannot start {n} worker threads: {e}"),
            })?;
        Ok(Some(Arc::new(pool)))
    }

    fn generate(&self) -> Result<TextureSet> {
        let mut made = MadeAppearance::default();
        let pre = self.prepare(&mut made)?;
        let cfg = &pre.cfg;
        let measured = self.baseline_maps(cfg)?;
        let bio = self.paint(cfg, &pre, &measured)?;
        pre.job.stage("convert", 1, Unit::Steps);
        let mut render = crate::texture_set::convert(
            &bio,
            &pre.surface,
            pre.appearance,
            &cfg.material,
            pre.dilation.as_deref(),
        );
        render.lash_color = pre.lash_color();
        let outline = pre.outline(self);
        let mut set = TextureSet {
            surface: pre.surface,
            fields: pre.fields,
            features: pre.features,
            bio,
            render,
            mesh_scale: pre.read.mesh_scale,
            preview_mesh: pre.preview_mesh,
            appearance: outline.appearance,
            skin_surface: outline.skin_surface,
            config: self.config.clone(),
            inputs: outline.inputs,
            log: pre.job.finish(),
            started: pre.started,
            pool: None,
            device: self.device,
            albedo_comparison: None,
        };
        if let Some((photo, name)) = pre.albedo {
            set.albedo_comparison = Some(crate::albedo_compare::compare(
                set.painted(),
                &photo,
                &name,
            )?);
        }
        Ok(set)
    }

    /// Everything before painting: the options checked, the surface, the fields and the
    /// features placed.
    fn prepare<'m>(&'m self, made: &'m mut MadeAppearance) -> Result<Prepared<'m>> {
        let started = Instant::now();
        self.config.validate("the options")?;
        // A GPU chosen outright is opened now, so a build or machine without one is told so
        // before any work, as every other command does (auto falls back to the CPU later).
        if self.device == Device::Gpu {
            self.device.resolve()?;
        }
        let appearance = self.chosen_appearance(made);
        let plan = self.plan()?;
        let albedo = match &self.albedo {
            Some(p) => Some((derma_core::image_io::read_rgb(p)?, p.display().to_string())),
            None => None,
        };
        let job = Job::new(self.progress);
        self.note_table(&job);

        job.stage("surface and fields", 1, Unit::Steps);
        let read = self.read_surface(&plan, &job)?;
        let (cfg, melanin) = self.person_config(appearance, &plan, &read)?;
        self.note_inputs(&cfg, melanin, appearance, &plan, &read, &job);
        let (surfaces, fields) = self.surface_and_fields(&cfg, &plan, &read, &job)?;
        job.stage("scatter", 1, Unit::Steps);
        let features = crate::feature_set::place(&cfg, &fields, &surfaces.scatter, plan.size)?;
        let Surfaces {
            surface,
            dilation,
            preview_mesh,
            ..
        } = surfaces;
        Ok(Prepared {
            started,
            appearance,
            plan,
            albedo,
            job,
            read,
            cfg,
            surface,
            dilation,
            preview_mesh,
            fields,
            features,
        })
    }

    /// Runs the main job and writes its files into `dir`, band by band where nothing needs the
    /// whole set in memory (the streamed main job, `crate::stream`: the same files, with the
    /// same bits, in a fraction of the memory); whole where `[detail]` tiles or an albedo
    /// comparison do. Returns what was written and what the set was.
    pub fn write_to(&self, dir: &Path) -> Result<(SetSummary, Written)> {
        let pool = self.pool()?;
        let run = || {
            if self.config.detail.enabled() || self.albedo.is_some() {
                let set = self.generate()?;
                let written = set.write_files(dir, self.progress)?;
                return Ok((set.summary(), written));
            }
            self.stream_to(dir)
        };
        match &pool {
            Some(p) => p.install(run),
            None => run(),
        }
    }

    /// [`Self::write_to`]'s streamed path.
    fn stream_to(&self, dir: &Path) -> Result<(SetSummary, Written)> {
        derma_core::atomic::ensure_writable_dir(dir)?;
        let mut made = MadeAppearance::default();
        let pre = self.prepare(&mut made)?;
        let measured = self.baseline_maps(&pre.cfg)?;
        let painter = crate::paint::Painter::new(
            &pre.cfg,
            &pre.surface,
            &pre.fields,
            &pre.features,
            &measured,
        )?;
        let keep_sss =
            derma_core::gpu::BUILT && self.device != Device::Cpu && pre.preview_mesh.is_some();
        let out = crate::stream::write_bands(
            &crate::stream::Bands {
                painter: &painter,
                surface: &pre.surface,
                dilation: pre.dilation.as_deref(),
                appearance: pre.appearance,
                material: &pre.cfg.material,
                keep_subsurface: keep_sss,
            },
            dir,
            &pre.job,
        )?;
        drop(painter);
        let mut preview = out.preview;
        preview.lash_color = pre.lash_color();
        let outline = pre.outline(self);
        let Prepared {
            job,
            started,
            read,
            surface,
            preview_mesh,
            fields,
            features,
            ..
        } = pre;
        let log = job.finish();
        let view = SetView {
            surface: &surface,
            fields: &fields,
            features: &features,
            mesh_scale: read.mesh_scale.as_ref(),
            preview_mesh: preview_mesh.as_ref(),
            appearance: outline.appearance,
            skin_surface: outline.skin_surface,
            config: &self.config,
            inputs: &outline.inputs,
            log: &log,
            started,
            threads: rayon::current_num_threads(),
            device: self.device,
            albedo_comparison: None,
        };
        let maps = MapsWritten {
            files: out.files,
            height_range: out.height_range,
            statistics: &out.statistics,
            preview: &preview,
            reduced: &out.reduced,
        };
        let wjob = Job::new(self.progress);
        wjob.stage("write", 1, Unit::Steps);
        let written = view.write_rest(dir, maps, wjob)?;
        let summary = SetSummary {
            config: self.config.clone(),
            features,
            mesh_scale: read.mesh_scale,
            inputs: outline.inputs,
            albedo_comparison: None,
        };
        Ok((summary, written))
    }

    /// The bio → render conversion chosen, one made here held in `made`.
    fn chosen_appearance<'m>(&'m self, made: &'m mut MadeAppearance) -> &'m dyn Appearance {
        match &self.appearance {
            AppearanceChoice::Analytic => made
                .analytic
                .insert(derma_shading::SpectralKubelkaMunk::default()),
            AppearanceChoice::Default => made
                .builtin
                .insert(derma_shading::TableAppearance::builtin()),
            AppearanceChoice::Table(t) => t.as_ref(),
        }
    }

    /// The surface to paint and the head it needs, checked against each other; then the
    /// memory the texture set needs.
    fn plan(&self) -> Result<Plan> {
        let mesh_path = self.mesh_path();
        let kind = if mesh_path.is_some() {
            SurfaceKind::Mesh
        } else {
            self.config.surface.kind
        };
        let on_head = kind == SurfaceKind::Template;
        if self.head.is_some() && kind == SurfaceKind::Patch {
            return Err(SkinError::Key {
                key: "surface.kind".into(),
                detail: "a fitted head is painted as a head or through a mesh, not as a patch"
                    .into(),
            });
        }
        // The head (building the built-in one takes about a second): only where it is used.
        let head = if on_head || self.head.is_some() {
            Some(derma_head::fitted::or_builtin(self.head.as_deref())?)
        } else {
            None
        };
        let has_landmarks = !self.config.surface.landmarks.trim().is_empty() || self.head.is_some();
        let size = self.config.size as usize;
        check_memory_streamed(size)?;
        Ok(Plan {
            mesh_path,
            kind,
            on_head,
            head,
            has_landmarks,
            size,
        })
    }

    /// Warns where the caller's match table fits the light transport worse than is trusted.
    fn note_table(&self, job: &Job) {
        if let AppearanceChoice::Table(t) = &self.appearance {
            if t.subsurface_rms > derma_shading::table_appearance::TRUSTED_RMS {
                job.note(Note::warning(format!(
                    "the match table's subsurface fit reaches a relative RMS of {:.2} (trusted up to {}): its colours may be far from the light transport; fit it again with more iterations or nodes",
                    t.subsurface_rms,
                    derma_shading::table_appearance::TRUSTED_RMS
                )));
            }
        }
    }

    /// The surface's mesh as `plan` names it (none for a patch), and where its regions come
    /// from.
    fn read_surface(&self, plan: &Plan, job: &Job) -> Result<SurfaceMesh> {
        if plan.kind == SurfaceKind::Mesh && plan.mesh_path.is_none() {
            return Err(SkinError::Key {
                key: "surface.kind".into(),
                detail: "\"mesh\" needs surface.mesh or a mesh given to the generator".into(),
            });
        }
        let mut read = SurfaceMesh {
            mesh: None,
            mesh_scale: None,
            user_regions: None,
            template_layout: false,
        };
        read.mesh = match plan.kind {
            SurfaceKind::Template => Some(plan.head.expect("on the head").skin.clone()),
            SurfaceKind::Mesh => {
                let p = plan.mesh_path.clone().expect("checked");
                let user = self.read_user_mesh(&p, plan.head, plan.has_landmarks, job)?;
                (read.user_regions, read.template_layout) = (user.regions, user.template_layout);
                read.mesh_scale = Some(user.frame);
                Some(user.mesh)
            }
            SurfaceKind::Patch => None,
        };
        Ok(read)
    }

    /// The configuration calibrated to the person (with the regional gains where the surface
    /// has regions) and the mean baseline melanin it chose; landmarks without a mesh fail.
    fn person_config(
        &self,
        appearance: &dyn Appearance,
        plan: &Plan,
        read: &SurfaceMesh,
    ) -> Result<(SkinConfig, Option<f32>)> {
        let regional_gains = (plan.on_head || plan.has_landmarks || read.template_layout)
            && self.config.regional.enabled;
        let person = crate::calibration::apply_person(&self.config, appearance, regional_gains)?;
        if plan.has_landmarks
            && read.user_regions.is_none()
            && !(plan.on_head && self.head.is_some())
        {
            return Err(SkinError::Key {
                key: "surface.landmarks".into(),
                detail: "landmarks place the built-in head's fields on a user mesh; give the mesh (surface.mesh or the generator's mesh)".into(),
            });
        }
        Ok(person)
    }

    /// The inputs' notes, before any field is made (they depend only on the inputs), in a fixed
    /// order: the person's calibration, measured baselines, where a mesh's fields come from.
    fn note_inputs(
        &self,
        cfg: &SkinConfig,
        melanin: Option<f32>,
        appearance: &dyn Appearance,
        plan: &Plan,
        read: &SurfaceMesh,
        job: &Job,
    ) {
        if let Some(m) = melanin {
            job.note(Note::info(format!(
                "person: ITA {:.0}° → mean baseline melanin {m:.4} (cheeks and forehead, '{}' appearance); age {:.0} → wrinkle density ×{:.2}",
                cfg.person.ita_deg,
                appearance.name(),
                cfg.person.age_years,
                crate::regional::age_factor(cfg.person.age_years)
            )));
        }
        for (key, path) in [
            ("baseline.melanin_map", &cfg.baseline.melanin_map),
            ("baseline.blood_map", &cfg.baseline.blood_map),
        ] {
            if !path.trim().is_empty() {
                job.note(Note::info(format!(
                    "{key}: the baseline comes from '{}' (regional gains and the person's calibration do not apply to it)",
                    path.trim()
                )));
            }
        }
        if plan.kind != SurfaceKind::Template {
            if read.user_regions.is_some() && !read.template_layout {
                job.note(Note::info(
                    "default fields and regional biology placed on the mesh by its landmarks",
                ));
            } else if self.fields.is_none() && cfg.fields.is_empty() {
                job.note(Note::info("no fields given: uniform fields are used (moles, freckles, cysts and pores everywhere; no lips, hair or wrinkles); paint fields to place them"));
            }
        }
    }

    /// The surfaces and the fields: the default fields, then a fields directory, then config
    /// entries.
    fn surface_and_fields(
        &self,
        cfg: &SkinConfig,
        plan: &Plan,
        read: &SurfaceMesh,
        job: &Job,
    ) -> Result<(Surfaces, FieldSet)> {
        // The surface (tangent frames, UV rasters, gutter dilation) and the default fields do
        // not depend on each other: built side by side, so the single-threaded parts (MikkTSpace,
        // the dilation search) overlap the parallel ones.
        let (surfaces, mut fields) = rayon::join(
            || build_surfaces(cfg, read.mesh.as_ref(), plan.size),
            || default_fields(cfg, plan, read),
        );
        if read.mesh.is_some() {
            check_raster(&surfaces.surface, plan.mesh_path.as_deref(), job)?;
        }
        self.load_fields(cfg, &mut fields, job)?;
        Ok((surfaces, fields))
    }

    /// Reads the fields directory and the config's field entries over `fields`; notes the
    /// fields left uniform when some were given.
    fn load_fields(&self, cfg: &SkinConfig, fields: &mut FieldSet, job: &Job) -> Result<()> {
        if let Some(dir) = &self.fields {
            fields.load_dir(dir, &known_fields(cfg), job)?;
        }
        for (name, value) in &cfg.fields {
            let v = value.trim();
            let lower = v.to_ascii_lowercase();
            if lower.ends_with(".png") || lower.ends_with(".exr") {
                fields.load_file(name, &self.resolve(v), job)?;
            } else {
                fields.define(name, v)?;
            }
        }

        let uniform: Vec<&str> = fields
            .origins
            .iter()
            .filter(|(_, o)| *o == UNIFORM)
            .map(|(n, _)| n.as_str())
            .collect();
        if !uniform.is_empty() && (self.fields.is_some() || !cfg.fields.is_empty()) {
            job.note(Note::info(format!(
                "fields not given, uniform (this mesh has no built-in fields): {}",
                uniform.join(", ")
            )));
        }
        Ok(())
    }

    /// The bio maps: painted, with `[detail]`'s exemplar tiles, dilated into the gutter.
    fn paint(
        &self,
        cfg: &SkinConfig,
        pre: &Prepared,
        measured: &crate::paint::BaselineMaps,
    ) -> Result<BioMaps> {
        let (surface, fields, job) = (&pre.surface, &pre.fields, &pre.job);
        let mut bio = crate::paint::paint_with(cfg, surface, fields, &pre.features, measured, job)?;
        if cfg.detail.enabled() {
            self.apply_detail(cfg, surface, fields, &mut bio, job)?;
        }
        if let Some(src) = pre.dilation.as_deref() {
            bio.dilate(src);
        }
        Ok(bio)
    }
}

/// What the main job knows before it paints ([`SkinGenerator::prepare`]).
struct Prepared<'m> {
    started: Instant,
    appearance: &'m dyn Appearance,
    plan: Plan,
    albedo: Option<(derma_core::image_io::LoadedImage, String)>,
    job: Job<'m>,
    read: SurfaceMesh,
    /// The person's configuration (the options with the calibration and age applied).
    cfg: SkinConfig,
    surface: Surface,
    dilation: Option<Vec<u32>>,
    preview_mesh: Option<(TriMesh, Vec<[f32; 4]>)>,
    fields: FieldSet,
    features: FeatureSet,
}

/// The parts of a set [`Prepared::outline`] derives.
struct Outline {
    appearance: &'static str,
    skin_surface: crate::texture_set::SkinSurface,
    inputs: InputFiles,
}

impl Prepared<'_> {
    /// The built-in lash cards' colour, on the head.
    fn lash_color(&self) -> Option<[f32; 3]> {
        (self.plan.kind == SurfaceKind::Template)
            .then(|| self.cfg.hair.melanin(&self.cfg.person).color())
    }

    /// The appearance's name, the skin's surface and the files read.
    fn outline(&self, g: &SkinGenerator) -> Outline {
        Outline {
            appearance: self.appearance.name(),
            skin_surface: crate::texture_set::skin_surface(&self.cfg.material, self.appearance),
            inputs: InputFiles {
                config: g.config_path.clone(),
                mesh: self.plan.mesh_path.clone(),
                head: g.head.clone(),
                fields: g.fields.clone(),
                surface: self.plan.kind,
            },
        }
    }
}

/// Where an appearance made for one run lives ([`SkinGenerator::chosen_appearance`]).
#[derive(Default)]
struct MadeAppearance {
    analytic: Option<derma_shading::SpectralKubelkaMunk>,
    builtin: Option<derma_shading::TableAppearance>,
}

/// The surface a run paints, decided before any work ([`SkinGenerator::plan`]).
struct Plan {
    mesh_path: Option<PathBuf>,
    kind: SurfaceKind,
    /// Painted on the head itself (the built-in or a fitted one).
    on_head: bool,
    /// The head, where it is used.
    head: Option<&'static derma_head::Head>,
    /// Landmarks (or a fitted head) place the built-in head's fields.
    has_landmarks: bool,
    /// The texture's side.
    size: usize,
}

/// The surface's mesh as read ([`SkinGenerator::read_surface`]).
struct SurfaceMesh {
    /// None for a patch.
    mesh: Option<TriMesh>,
    /// The frame a user mesh was read in.
    mesh_scale: Option<MeshFrame>,
    /// Where a user mesh's fields and regional biology come from, if anywhere.
    user_regions: Option<derma_head::Regions>,
    /// The user mesh has the built-in head's UV layout.
    template_layout: bool,
}

/// The surface at the texture's size and at the scatter's resolution.
struct Surfaces {
    surface: Surface,
    /// The gutter's dilation sources (meshes only).
    dilation: Option<Vec<u32>>,
    scatter: Surface,
    /// The mesh and its tangents for the preview (none on a patch).
    preview_mesh: Option<(TriMesh, Vec<[f32; 4]>)>,
}

/// The surfaces of `mesh` (its tangent frames, UV rasters and gutter dilation), or of a patch
/// where there is none.
fn build_surfaces(cfg: &SkinConfig, mesh: Option<&TriMesh>, size: usize) -> Surfaces {
    let sr = cfg.scatter_resolution as usize;
    match mesh {
        Some(m) => {
            let tangents = crate::surface::mikktspace_tangents(m);
            let ((surface, dilation), scatter) = rayon::join(
                || {
                    let s = Surface::mesh(m, &tangents, size, size);
                    let d = s.dilation();
                    (s, d)
                },
                || Surface::mesh(m, &tangents, sr, sr),
            );
            Surfaces {
                surface,
                dilation,
                scatter,
                preview_mesh: Some((m.clone(), tangents)),
            }
        }
        None => {
            let [w, h] = cfg.surface.patch_size_mm;
            Surfaces {
                surface: Surface::patch(size, size, [w, h], cfg.surface.tileable),
                dilation: None,
                scatter: Surface::patch(sr, sr, [w, h], cfg.surface.tileable),
                preview_mesh: None,
            }
        }
    }
}

/// The default fields: the built-in head's (on the head, or on a mesh with its regions), or
/// uniform ones.
fn default_fields(cfg: &SkinConfig, plan: &Plan, read: &SurfaceMesh) -> FieldSet {
    if plan.kind == SurfaceKind::Template {
        crate::builtin_head::fields_on(
            read.mesh.as_ref().expect("template mesh"),
            &plan.head.expect("on the head").regions,
            &cfg.person,
        )
    } else if let Some(regions) = &read.user_regions {
        crate::builtin_head::fields_on(read.mesh.as_ref().expect("a mesh"), regions, &cfg.person)
    } else {
        uniform_fields()
    }
}

impl SkinGenerator<'_> {
    /// `baseline.melanin_map` and `baseline.blood_map`, read and checked against the texture.
    fn baseline_maps(&self, cfg: &SkinConfig) -> Result<crate::paint::BaselineMaps> {
        use derma_optics::bio::names;
        let lut = derma_shading::skin_color_lut::LutOptions::default();
        let read = |key: &str, p: &str, chans: &[&str], png_top: f64| -> Result<Option<Map>> {
            if p.trim().is_empty() {
                return Ok(None);
            }
            let path = self.resolve(p.trim());
            let bad = |detail: String| SkinError::Config {
                origin: key.into(),
                detail: format!("'{}': {detail}", path.display()),
            };
            let map = if path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
            {
                let c = derma_core::image_io::read_exr_channels(&path)?;
                if c.len() == 1 {
                    c.into_iter().next().expect("one").1
                } else {
                    c.into_iter()
                        .find(|(n, _)| chans.iter().any(|w| n.eq_ignore_ascii_case(w)))
                        .map(|(_, m)| m)
                        .ok_or_else(|| bad(format!("none of the channels {chans:?}")))?
                }
            } else {
                let g = derma_core::image_io::read_grey(&path)?.channels.remove(0);
                let d: Vec<f32> = g.data().iter().map(|v| v * png_top as f32).collect();
                Map::from_vec(g.width(), g.height(), d)?
            };
            if map.data().iter().any(|v| !(0.0..=1.0).contains(v)) {
                return Err(bad("values must be volume fractions in [0, 1]".into()));
            }
            Ok(Some(map))
        };
        let b = &cfg.baseline;
        let melanin = read(
            "baseline.melanin_map",
            &b.melanin_map,
            &[names::MELANIN, "Y", "R"],
            lut.melanin_max,
        )?;
        let blood = read(
            "baseline.blood_map",
            &b.blood_map,
            &[names::HEMOGLOBIN, names::BLOOD, "Y", "R"],
            lut.blood_max,
        )?;
        let tissue = (melanin.is_some() || blood.is_some()).then(|| b.mean_tissue());
        Ok(crate::paint::BaselineMaps {
            melanin,
            blood,
            tissue,
        })
    }

    /// `[detail]`: the global exemplar's tile where no region claims the texel, each region's
    /// own tile by its mask (masks summing past 1 are normalised).
    fn apply_detail(
        &self,
        cfg: &SkinConfig,
        surface: &Surface,
        fields: &FieldSet,
        bio: &mut BioMaps,
        job: &Job,
    ) -> Result<()> {
        let d = &cfg.detail;
        let path = |p: &str| (!p.trim().is_empty()).then(|| self.resolve(p.trim()));
        let (h, a) = (path(&d.height), path(&d.albedo));
        let wrap = surface.period().is_some();
        let masks: Vec<(&Map, PathBuf)> = d
            .regions
            .iter()
            .map(|(name, p)| Ok((fields.scalar(name)?, self.resolve(p.trim()))))
            .collect::<Result<_>>()?;
        let (w, ht) = (bio.width, bio.height);
        let uv = |x: usize, y: usize| {
            (
                (x as f32 + 0.5) / w as f32,
                1.0 - (y as f32 + 0.5) / ht as f32,
            )
        };
        let claimed = |x: usize, y: usize| {
            let (u, v) = uv(x, y);
            masks
                .iter()
                .map(|(m, _)| m.sample_uv(u, v, wrap).clamp(0.0, 1.0))
                .sum::<f32>()
        };
        if h.is_some() || a.is_some() {
            job.stage("detail", 1, Unit::Steps);
            let tile = crate::detail::build(
                d,
                h.as_deref(),
                a.as_deref(),
                cfg.seed,
                self.device,
                &Prefixed::new(job, "detail"),
            )?;
            job.stage("detail / apply", 1, Unit::Steps);
            tile.apply_weighted(d, &mut bio.texels, w, &|x, y| {
                (1.0 - claimed(x, y)).max(0.0)
            });
        }
        for (k, (mask, p)) in masks.iter().enumerate() {
            job.stage("detail / region", 1, Unit::Steps);
            // Each region grows its own tile from its own seed.
            let seed = cfg.seed ^ (0x9e37_79b9_7f4a_7c15u64.wrapping_mul(k as u64 + 1));
            let tile = crate::detail::build(
                d,
                Some(p),
                None,
                seed,
                self.device,
                &Prefixed::new(job, "detail"),
            )?;
            tile.apply_weighted(d, &mut bio.texels, w, &|x, y| {
                let (u, v) = uv(x, y);
                mask.sample_uv(u, v, wrap).clamp(0.0, 1.0) / claimed(x, y).max(1.0)
            });
        }
        Ok(())
    }

    /// The user's mesh in derma's frame and where its regions come from: the fitted head it
    /// was given, its landmarks, or — a mesh with the template's UV layout (`--export-template`'s
    /// head.obj or head.glb, or a sculpt of it) — the built-in head's; none otherwise.
    fn read_user_mesh(
        &self,
        path: &Path,
        head: Option<&derma_head::Head>,
        has_landmarks: bool,
        job: &Job,
    ) -> Result<UserMesh> {
        let (mesh, frame) = load_mesh(path, &self.config.surface, self.head.as_deref(), job)?;
        let mut template_layout = false;
        let regions = match head {
            Some(head) if self.config.surface.landmarks.trim().is_empty() => Some(
                derma_head::Regions::new(head.landmarks.clone(), Vec::new(), Vec::new()),
            ),
            _ if has_landmarks => {
                let lm = self.landmarks(path, &frame)?;
                Some(derma_head::Regions::new(lm, Vec::new(), Vec::new()))
            }
            _ if mesh
                .uv_layout()
                .matches(crate::builtin_head::template_layout()) =>
            {
                template_layout = true;
                job.note(Note::info(format!(
                    "'{}' has the built-in head's UV layout: its default fields and regional biology apply",
                    path.display()
                )));
                Some(derma_head::Head::builtin().regions.clone())
            }
            _ => None,
        };
        Ok(UserMesh {
            mesh,
            frame,
            regions,
            template_layout,
        })
    }

    /// The user mesh's landmarks (`surface.landmarks`) in derma's frame: through the frame the
    /// mesh was read in (its unit and, with a fitted head, its axes).
    fn landmarks(&self, mesh: &Path, frame: &MeshFrame) -> Result<derma_head::Landmarks> {
        let v = self.config.surface.landmarks.trim();
        if v == "mediapipe" {
            let pts: Vec<glam::Vec3> =
                derma_core::mesh_file::file_positions(mesh, &frame.part_choice())?
                    .into_iter()
                    .map(|p| frame.point(p))
                    .collect();
            return derma_head::Landmarks::mediapipe(&pts).map_err(|e| SkinError::Mesh {
                path: mesh.display().to_string(),
                detail: e.to_string(),
            });
        }
        let path = self.resolve(v);
        let text = std::fs::read_to_string(&path).map_err(|e| SkinError::Input {
            path: path.clone(),
            detail: format!("cannot read the landmarks ({e})"),
        })?;
        derma_head::Landmarks::from_json_in(&text, &|p| frame.point(p)).map_err(|e| {
            SkinError::Input {
                path,
                detail: e.to_string(),
            }
        })
    }
}

/// A user's mesh as [`SkinGenerator::read_user_mesh`] read it.
struct UserMesh {
    mesh: TriMesh,
    frame: MeshFrame,
    /// Where the built-in head's fields and regional biology come from, if anywhere.
    regions: Option<derma_head::Regions>,
    /// The mesh has the built-in head's UV layout.
    template_layout: bool,
}

/// The user's mesh in derma's frame (mm, +Y up, facing +Z) through derma-core's one head-mesh
/// loader: with a fitted head, in the frame its fit found (unit, axes, part); else by
/// `surface.unit` (its unit, the unit that makes it head-sized, or a nominal head's size) and
/// `surface.part`. The choice is noted.
fn load_mesh(
    path: &Path,
    surface: &crate::config::SurfaceConfig,
    head: Option<&Path>,
    progress: &dyn Progress,
) -> Result<(TriMesh, MeshFrame)> {
    use derma_core::head_mesh::HeadUnit;
    use derma_core::mesh_parts::PartChoice;
    let unit = HeadUnit::parse(&surface.unit).ok_or_else(|| SkinError::Key {
        key: "surface.unit".into(),
        detail: format!("'{}': expected auto, fit, mm, cm or m", surface.unit),
    })?;
    let part = match surface.part.trim() {
        "" => PartChoice::Auto,
        n => PartChoice::Named(n.to_string()),
    };
    Ok(derma_head::fitted::load_user_mesh(
        head, path, unit, &part, progress,
    )?)
}

/// Notes UV overlaps and charts outside [0, 1]; fails when no triangle covers a texel.
fn check_raster(s: &Surface, mesh: Option<&Path>, progress: &dyn Progress) -> Result<()> {
    let Some(ms) = s.mesh_surface() else {
        return Ok(());
    };
    if ms.raster.overlapping_triangles > 0 {
        progress.note(Note::warning(format!(
            "{} triangles overlap others in UV space; overlapping texels take the triangle nearest its interior, so the other surface goes unpainted",
            ms.raster.overlapping_triangles
        )));
    }
    if ms.raster.triangles_outside_unit_square > 0 {
        progress.note(Note::warning(format!(
            "{} triangles have UVs outside [0, 1]; only the part inside is painted",
            ms.raster.triangles_outside_unit_square
        )));
    }
    if ms.raster.coverage() == 0.0 {
        return Err(SkinError::Mesh {
            path: mesh.map_or_else(|| "mesh".into(), |p| p.display().to_string()),
            detail: "no triangle covers any texel (degenerate UVs?)".into(),
        });
    }
    Ok(())
}

/// The origin ([`FieldSet::origins`]) of a field left at its uniform default.
const UNIFORM: &str = "uniform";

/// Uniform defaults for surfaces without painted fields.
fn uniform_fields() -> FieldSet {
    let mut f = FieldSet::default();
    let one = |v: f32| Map::filled(4, 4, v);
    for name in ["moles", "freckles", "cysts", "pores", "face", "relief"] {
        f.scalars.insert(name.into(), one(1.0));
    }
    for name in ["lips", "scalp", "eyebrows", "wrinkles", "eyes"] {
        f.scalars.insert(name.into(), one(0.0));
    }
    f.vectors
        .insert("wrinkle_vectors".into(), [one(0.5), one(0.5), one(0.0)]);
    f.origins = f
        .scalars
        .keys()
        .chain(f.vectors.keys())
        .map(|n| (n.clone(), UNIFORM.to_string()))
        .collect();
    f
}

/// The field names a fields directory may hold: the built-in head's, those the configuration
/// reads and those its expressions use.
fn known_fields(cfg: &SkinConfig) -> std::collections::BTreeSet<String> {
    let mut known = crate::builtin_head::field_names();
    known.extend(cfg.field_names());
    for expr in cfg.fields.values() {
        known.extend(crate::field::expression_names(expr));
    }
    known
}

/// Everything the main job produced, in memory; [`TextureSet::write`] writes its files.
pub struct TextureSet {
    /// Texel → point on the surface.
    pub surface: Surface,
    /// The probability and vector fields used.
    pub fields: FieldSet,
    /// Every placed feature.
    pub features: FeatureSet,
    /// The painted bio parameters per texel.
    pub bio: BioMaps,
    /// The render maps.
    pub render: RenderMaps,
    /// The unit a user mesh was read in.
    pub mesh_scale: Option<MeshFrame>,
    /// Mesh and tangents for the preview (template, user mesh, or none for patches).
    pub preview_mesh: Option<(TriMesh, Vec<[f32; 4]>)>,
    /// Name of the appearance that made the colours.
    pub appearance: &'static str,
    /// The skin's roughness and F0 under lips, hair and cavities, and their source.
    pub skin_surface: crate::texture_set::SkinSurface,
    /// The configuration as given (before the person's calibration and age scaling, which
    /// `generate` derives again from it).
    pub config: SkinConfig,
    /// The files read.
    pub inputs: InputFiles,
    /// Stage timings and notes of the generation.
    pub log: Log,
    started: Instant,
    pool: Option<Arc<rayon::ThreadPool>>,
    device: Device,
    /// The set beside a photographed albedo ([`SkinGenerator::compare_albedo`]).
    pub albedo_comparison: Option<crate::albedo_compare::AlbedoComparison>,
}

/// What [`TextureSet::write`] wrote.
#[derive(Clone, Debug)]
pub struct Written {
    /// Every file, in manifest order.
    pub files: Vec<&'static str>,
    /// Range of height.png, mm.
    pub height_range: HeightRange,
    /// Timings and notes of the whole run, generation and writing.
    pub log: Log,
}

impl TextureSet {
    /// What [`crate::albedo_compare`] compares of the set.
    pub fn painted(&self) -> crate::albedo_compare::Painted<'_> {
        crate::albedo_compare::Painted {
            surface: &self.surface,
            fields: &self.fields,
            base_color: &self.render.base_color,
        }
    }

    /// The head the set was painted on or for: the fitted one it was given, or the built-in
    /// one (a fitted head was read once already, so this does not fail).
    pub fn head(&self) -> &'static derma_head::Head {
        self.view().head()
    }

    /// The UV layout the set was painted on: the template's on the head (fitted or not), the
    /// mesh's on a user mesh, none on a patch.
    pub fn uv_layout(&self) -> Option<derma_core::mesh::UvLayout> {
        self.view().uv_layout()
    }

    /// Worker threads the set was made with.
    pub fn threads(&self) -> usize {
        self.pool
            .as_ref()
            .map_or_else(rayon::current_num_threads, |p| p.current_num_threads())
    }

    /// What the caller of [`SkinGenerator::write_to`] gets of a set.
    pub fn summary(self) -> SetSummary {
        SetSummary {
            config: self.config,
            features: self.features,
            mesh_scale: self.mesh_scale,
            inputs: self.inputs,
            albedo_comparison: self.albedo_comparison,
        }
    }

    /// The set as its writing reads it.
    fn view(&self) -> SetView<'_> {
        SetView {
            surface: &self.surface,
            fields: &self.fields,
            features: &self.features,
            mesh_scale: self.mesh_scale.as_ref(),
            preview_mesh: self.preview_mesh.as_ref(),
            appearance: self.appearance,
            skin_surface: self.skin_surface,
            config: &self.config,
            inputs: &self.inputs,
            log: &self.log,
            started: self.started,
            threads: self.threads(),
            device: self.device,
            albedo_comparison: self.albedo_comparison.as_ref(),
        }
    }

    /// Writes every file of [`outputs::OUTPUTS`] into `dir` — the maps, features.json,
    /// preview.png, then manifest.json and report.json — each atomically. The preview's views
    /// are drawn by derma-render's GPU renderer where the set's device resolves to a GPU and it
    /// has a mesh, by its CPU renderer otherwise (a note says which).
    pub fn write(&self, dir: &Path, progress: &dyn Progress) -> Result<Written> {
        match &self.pool {
            Some(p) => p.install(|| self.write_files(dir, progress)),
            None => self.write_files(dir, progress),
        }
    }

    fn write_files(&self, dir: &Path, progress: &dyn Progress) -> Result<Written> {
        derma_core::atomic::ensure_writable_dir(dir)?;
        let job = Job::new(progress);
        job.stage("write", 1, Unit::Steps);
        let (files, height_range) = crate::texture_set::write_maps(dir, &self.bio, &self.render)?;
        let statistics = crate::report::Statistics::of_set(&self.surface, &self.bio, &self.render);
        let maps = MapsWritten {
            files,
            height_range,
            statistics: &statistics,
            preview: &self.render,
            reduced: &crate::preview::reduced_bio(&self.bio),
        };
        self.view().write_rest(dir, maps, job)
    }
}

/// What a run made besides its maps: what [`SkinGenerator::write_to`] returns with the files.
pub struct SetSummary {
    /// The configuration as given.
    pub config: SkinConfig,
    /// Every placed feature.
    pub features: FeatureSet,
    /// The unit a user mesh was read in.
    pub mesh_scale: Option<MeshFrame>,
    /// The files read.
    pub inputs: InputFiles,
    /// The set beside a photographed albedo ([`SkinGenerator::compare_albedo`]).
    pub albedo_comparison: Option<crate::albedo_compare::AlbedoComparison>,
}

/// The map files written, and what the rest of the set's files need of the maps.
struct MapsWritten<'a> {
    files: Vec<&'static str>,
    height_range: HeightRange,
    statistics: &'a crate::report::Statistics,
    /// The render maps the preview draws (whole; the wrinkle normals and, on the CPU, the
    /// subsurface maps may be left out).
    preview: &'a RenderMaps,
    /// The contact sheet's bio channels ([`crate::preview::reduced_bio`]).
    reduced: &'a [Map; 3],
}

/// A set as its writing reads it: a whole [`TextureSet`], or the streamed main job's state.
struct SetView<'a> {
    surface: &'a Surface,
    fields: &'a FieldSet,
    features: &'a FeatureSet,
    mesh_scale: Option<&'a MeshFrame>,
    preview_mesh: Option<&'a (TriMesh, Vec<[f32; 4]>)>,
    appearance: &'static str,
    skin_surface: crate::texture_set::SkinSurface,
    config: &'a SkinConfig,
    inputs: &'a InputFiles,
    log: &'a Log,
    started: Instant,
    threads: usize,
    device: Device,
    albedo_comparison: Option<&'a crate::albedo_compare::AlbedoComparison>,
}

impl SetView<'_> {
    /// The head the set was painted on or for.
    fn head(&self) -> &'static derma_head::Head {
        derma_head::fitted::or_builtin(self.inputs.head.as_deref())
            .unwrap_or(derma_head::Head::builtin())
    }

    /// The set's UV layout (see [`TextureSet::uv_layout`]).
    fn uv_layout(&self) -> Option<derma_core::mesh::UvLayout> {
        match self.inputs.surface {
            SurfaceKind::Patch => None,
            SurfaceKind::Template => Some(crate::builtin_head::template_layout().clone()),
            SurfaceKind::Mesh => self.preview_mesh.map(|(m, _)| m.uv_layout()),
        }
    }

    /// After the maps: lashes.png, wrinkle_masks.exr, features.json (in `job`'s current
    /// stage), preview.png, report.json and manifest.json.
    fn write_rest(&self, dir: &Path, mut maps: MapsWritten, job: Job) -> Result<Written> {
        let map_files = std::mem::take(&mut maps.files);
        let mut files = self.write_other_files(dir, map_files, maps.preview.lash_color)?;
        job.stage("preview", 1, Unit::Steps);
        self.write_preview(dir, &maps, &job)?;
        files.push(outputs::PREVIEW);
        let log = self.run_log(job);
        files.push(outputs::REPORT);
        let report = self.report(maps.height_range, maps.statistics, &log);
        derma_core::report::write_json(
            &dir.join(outputs::REPORT),
            &report,
            derma_core::report::JsonFormat::REPORT,
        )?;
        self.write_manifest(dir, &files, &report)?;
        files.insert(files.len() - 1, outputs::MANIFEST); // manifest order: before report.json
        Ok(Written {
            files,
            height_range: maps.height_range,
            log,
        })
    }

    /// manifest.json: every file of `files` in `dir` hashed (report.json aside), with the seed,
    /// the inputs as `report` gives them (each field file hashed), the options and the UV layout.
    fn write_manifest(&self, dir: &Path, files: &[&str], report: &serde_json::Value) -> Result<()> {
        let mut inputs = report["inputs"].clone();
        inputs["field_files"] = self
            .fields
            .origins
            .iter()
            .filter(|(_, o)| Path::new(o).is_file())
            .map(|(n, o)| (n.clone(), json!(sha256_file(Path::new(o)))))
            .collect::<serde_json::Map<_, _>>()
            .into();
        let made = crate::manifest::Made {
            size: self.config.size,
            seed: self.config.seed,
            surface: report["inputs"]["surface"].as_str().unwrap_or("-"),
            uv_layout: self.uv_layout(),
            inputs,
            options: json!({"config": self.config, "appearance": self.appearance}),
        };
        derma_core::report::write_json(
            &dir.join(outputs::MANIFEST),
            &crate::manifest::manifest(&made, dir, files)?,
            derma_core::report::JsonFormat::REPORT,
        )?;
        Ok(())
    }

    /// lashes.png (on the head), wrinkle_masks.exr (with landmarks) and features.json after
    /// the map `files`; returns every file in manifest order.
    fn write_other_files(
        &self,
        dir: &Path,
        mut files: Vec<&'static str>,
        lash_color: Option<[f32; 3]>,
    ) -> Result<Vec<&'static str>> {
        if let Some(hair) = lash_color {
            crate::texture_set::write_lashes(&dir.join(outputs::LASHES), hair)?;
            insert_after(&mut files, outputs::HAIR_COVERAGE, outputs::LASHES);
        }
        if crate::texture_set::write_wrinkle_masks(
            &dir.join(outputs::WRINKLE_MASKS),
            self.fields,
            self.surface.width,
            self.surface.height,
            self.surface.period().is_some(),
        )? {
            insert_after(&mut files, outputs::WRINKLE_NORMAL, outputs::WRINKLE_MASKS);
        } else {
            // No landmarks, no masks: a previous run's masks would not match this set.
            let stale = dir.join(outputs::WRINKLE_MASKS);
            if stale.is_file() {
                std::fs::remove_file(&stale).map_err(|e| crate::SkinError::Input {
                    path: stale.clone(),
                    detail: format!("cannot remove a previous run's masks ({e})"),
                })?;
            }
        }
        derma_core::report::write_json(
            &dir.join(outputs::FEATURES),
            &self.features.to_json(),
            derma_core::report::JsonFormat::DATA,
        )?;
        files.push(outputs::FEATURES);
        Ok(files)
    }

    /// preview.png: the contact sheet, its shaded views drawn by the GPU renderer where it
    /// runs, by the CPU previews otherwise.
    fn write_preview(&self, dir: &Path, maps: &MapsWritten, job: &Job) -> Result<()> {
        let template = self.inputs.surface == SurfaceKind::Template;
        let shaded = self.gpu_views(maps.preview, template, job);
        let lash_color = maps.preview.lash_color.map(glam::Vec3::from);
        let lashes = move |_: glam::Vec2| lash_color.unwrap_or_default();
        let props = if template {
            let mut props = derma_render::cpu::head_props(self.head());
            if lash_color.is_some() {
                derma_render::cpu::recolour_cards(&mut props, &lashes);
            }
            props
        } else {
            Vec::new()
        };
        let preview = crate::preview::contact_sheet(
            maps.preview,
            maps.reduced,
            self.surface,
            self.preview_mesh,
            &props,
            shaded,
        );
        derma_core::image_io::write_png8(
            &dir.join(outputs::PREVIEW),
            &[&preview[0], &preview[1], &preview[2]],
        )?;
        Ok(())
    }

    /// The preview's shaded views from derma-render's GPU renderer, where it runs; a note says
    /// which renderer draws them, and why.
    fn gpu_views(&self, maps: &RenderMaps, template: bool, job: &Job) -> Option<Vec<[Map; 3]>> {
        match crate::preview::gpu_views(
            maps,
            self.preview_mesh,
            template.then(|| self.head()),
            self.device,
        ) {
            Ok(Some((views, adapter))) => {
                job.note(Note::info(format!(
                    "preview rendered by derma-render on {adapter}"
                )));
                Some(views)
            }
            Ok(None) => {
                let why = if self.preview_mesh.is_none() {
                    "a flat patch"
                } else if self.device == Device::Cpu {
                    "the CPU device was chosen"
                } else if !derma_core::gpu::BUILT {
                    "a build without the gpu feature"
                } else {
                    "no hardware GPU; choosing the GPU device takes any adapter"
                };
                job.note(Note::info(format!(
                    "preview drawn by derma-render's CPU previews ({why})"
                )));
                None
            }
            Err(e) => {
                job.note(Note::warning(format!(
                    "preview drawn by the CPU previews: the GPU renderer failed ({e})"
                )));
                None
            }
        }
    }

    /// The whole run's log: the generation's, then the writing's, then the total time.
    fn run_log(&self, job: Job) -> Log {
        let mut log = self.log.clone();
        let written = job.finish();
        log.timings.extend(written.timings);
        log.notes.extend(written.notes);
        log.timings.push(derma_core::progress::Timing {
            stage: "total".into(),
            seconds: self.started.elapsed().as_secs_f64(),
        });
        log
    }

    /// report.json's content, with the range of height.png and the run's `log`.
    fn report(
        &self,
        height_range: HeightRange,
        statistics: &crate::report::Statistics,
        log: &Log,
    ) -> serde_json::Value {
        crate::report::report(&crate::report::Run {
            config: self.config,
            inputs: self.inputs,
            mesh_scale: self.mesh_scale.cloned(),
            threads: self.threads,
            appearance: self.appearance,
            skin_surface: self.skin_surface,
            surface: self.surface,
            statistics,
            field_origins: &self.fields.origins,
            counts: self.features.counts(),
            height_range,
            log,
            albedo_comparison: self.albedo_comparison,
        })
    }
}

/// Puts `file` into `files` just after `after` (at the end where `after` is missing).
fn insert_after(files: &mut Vec<&'static str>, after: &str, file: &'static str) {
    let at = files
        .iter()
        .position(|f| *f == after)
        .map_or(files.len(), |p| p + 1);
    files.insert(at, file);
}
