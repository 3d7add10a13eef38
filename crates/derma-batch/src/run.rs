//! One shard of a batch (docs/batch.md): every identity it owns that is not complete, painted by
//! the main job into this process's own unfinished directory and renamed into place when done.

use crate::error::{BatchError, Result};
use crate::layout::{hashes, io, prepare, remove_stale_partials, IDENTITY_FILE, PARTIAL, UNHASHED};
use crate::spec::{Appearance, BatchSpec, Identity};
use derma_core::progress::{Job, Note, Progress, Silent, Unit};
use derma_core::report::{write_json, JsonFormat};
use derma_core::shard::Shard;
use derma_skin::regional::Person;
use derma_skin::{AppearanceChoice, SkinConfig, SkinGenerator};
use std::path::Path;
use std::time::Instant;

/// How one shard's run went.
#[derive(Clone, Debug, Default)]
pub struct ShardReport {
    /// Identities this shard owns.
    pub owned: usize,
    /// Already complete from an earlier run, skipped.
    pub skipped: usize,
    /// Painted now.
    pub made: usize,
    /// Unfinished directories of ended runs on this host, removed (their identities made again).
    pub resumed: usize,
}

/// How the main job runs for each identity.
#[derive(Clone, Copy)]
pub struct RunOptions {
    /// Where `[detail]` synthesis and the preview run.
    pub device: derma_core::gpu::Device,
    /// Worker threads (None: all cores).
    pub threads: Option<usize>,
}

/// Paints every identity `shard` owns that is not complete in `out`, each into its own
/// `out/NNNNNN.partial.HOST.PID.N` then renamed to `out/NNNNNN`. An unfinished directory left by
/// a killed run on this host is removed and its identity made again, so a rerun of the same
/// command resumes; one left on another host is removed by [`super::merge()`].
pub fn run_shard(
    out: &Path,
    spec: &BatchSpec,
    shard: Shard,
    opts: RunOptions,
    progress: &dyn Progress,
) -> Result<ShardReport> {
    prepare(out, spec)?;
    // The config is read for each identity (its relative paths resolve against its own
    // directory); once here, so a bad one fails before any work.
    let generator_for = |id: &Identity, size: u32| -> Result<SkinGenerator<'_>> {
        let mut g = match &spec.config {
            Some(p) => SkinGenerator::from_config_file(Path::new(p))?,
            None => SkinGenerator::new(SkinConfig::default()),
        };
        let cfg = g.config_mut();
        cfg.size = size;
        cfg.seed = id.seed;
        cfg.person = Person {
            ita_deg: id.ita_deg,
            calibrate_melanin: true,
            sex: id.sex,
            age_years: id.age_years,
        };
        g = g
            .appearance(match spec.appearance {
                Appearance::Table => AppearanceChoice::Default,
                Appearance::Analytic => AppearanceChoice::Analytic,
            })
            .device(opts.device)
            .progress(&Silent);
        if let Some(m) = &id.mesh {
            g = g.mesh(m);
        }
        if let Some(h) = &id.head {
            g = g.head(h);
        }
        if let Some(n) = opts.threads {
            g = g.threads(n);
        }
        Ok(g)
    };
    generator_for(&spec.identity(0), spec.size.dirs()[0].0)?;
    let owned: Vec<usize> = (0..spec.count).filter(|&i| shard.owns(i)).collect();
    let mut report = ShardReport {
        owned: owned.len(),
        ..Default::default()
    };
    let job = Job::new(progress);
    job.stage("identities", owned.len() as u64, Unit::Steps);
    for &i in &owned {
        let mut id = spec.identity(i);
        let done = out.join(&id.dir);
        if done.join(IDENTITY_FILE).is_file() {
            report.skipped += 1;
            job.advance(1);
            continue;
        }
        report.resumed += remove_stale_partials(out, &id.dir)?;
        // This process's own unfinished directory: two workers on one identity (a replaced
        // pod still stopping, a requeued task) never write into the same one.
        let partial = out.join(format!(
            "{}{PARTIAL}{}",
            id.dir,
            derma_core::atomic::unique_tag()
        ));
        let started = Instant::now();
        for (size, sub) in spec.size.dirs() {
            let generator = generator_for(&id, size)?;
            let set = partial.join(&sub);
            derma_export::skin::run(&generator, &set, spec.glb, &Silent).map_err(|e| {
                derma_core::Invalid::new(
                    format!("identity {} ({}) at {size}²", i, id.dir),
                    "a painted texture set",
                    e,
                )
            })?;
            keep_outputs(&set, spec)?;
        }
        id.files = hashes(&partial)?;
        write_json(&partial.join(IDENTITY_FILE), &id, JsonFormat::DATA_PRETTY)?;
        if done.join(IDENTITY_FILE).is_file() {
            // Another worker finished it meanwhile: the same bytes; keep theirs.
            std::fs::remove_dir_all(&partial).map_err(|e| io(&partial, e))?;
            report.skipped += 1;
            job.advance(1);
            continue;
        }
        if done.exists() {
            // A directory under the final name without its record is not derma's: refuse to
            // guess rather than delete it.
            return Err(BatchError::from(derma_core::CoreError::Format {
                path: done,
                message: format!("exists without its {IDENTITY_FILE}; move it away and run again"),
            }));
        }
        std::fs::rename(&partial, &done).map_err(|e| io(&done, e))?;
        report.made += 1;
        job.note(Note::info(format!(
            "identity {} ({}, {:.0}°, {}, {} years) in {:.1} s",
            id.dir,
            id.preset.as_deref().unwrap_or("ITA"),
            id.ita_deg,
            id.sex.name(),
            id.age_years,
            started.elapsed().as_secs_f64()
        )));
        job.advance(1);
    }
    Ok(report)
}

/// Removes the set's files the spec's `outputs` leaves out (none when it names none).
fn keep_outputs(dir: &Path, spec: &BatchSpec) -> Result<()> {
    if spec.outputs.is_empty() {
        return Ok(());
    }
    for o in derma_skin::outputs::OUTPUTS.iter() {
        let p = dir.join(o.file);
        if o.file != UNHASHED && !spec.outputs.iter().any(|f| f == o.file) && p.exists() {
            std::fs::remove_file(&p).map_err(|e| io(&p, e))?;
        }
    }
    Ok(())
}
