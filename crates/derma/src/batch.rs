//! `derma batch`: many identities from one spec (docs/batch.md): flags → derma-export's batch
//! runner for this process's shard, or its merge into the manifest.

use crate::progress::Bars;
use anyhow::{bail, Result};
use clap::Args;
use derma_batch::{self as batch, BatchSpec, RunOptions};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct BatchArgs {
    /// The batch spec (TOML: count, seed, size or sizes, presets or ita_deg, male, age_years, meshes or
    /// heads, config, appearance, glb, outputs; see docs/batch.md). Not with --merge.
    #[arg(required_unless_present = "merge", conflicts_with = "merge")]
    spec: Option<PathBuf>,
    /// Output directory: one directory per identity (000000, 000001, …), the spec, the manifest.
    #[arg(long, default_value = "batch")]
    out: PathBuf,
    #[command(flatten)]
    shard: crate::args::ShardArg,
    /// Check that every identity in --out is present and complete (each file against its
    /// hash), then write manifest.jsonl; fails naming what is missing.
    #[arg(long)]
    merge: bool,
    /// Worker threads per identity (default: all cores). Outputs are identical for any value.
    #[arg(long)]
    threads: Option<usize>,
    #[command(flatten)]
    device: crate::args::DeviceArg,
}

pub fn run(a: BatchArgs, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    if a.merge {
        let m = batch::merge(&a.out, bars)?;
        bars.finish();
        bars.say(format!(
            "wrote {}: {} identities, {} files checked against their hashes; {} unfinished \
             directories of killed runs removed",
            m.manifest.display(),
            m.identities,
            m.files,
            m.removed
        ));
        return Ok(());
    }
    let Some(spec_path) = &a.spec else {
        bail!("give a batch spec (TOML), or --merge");
    };
    let spec = BatchSpec::read(spec_path)?;
    let (shard, source) = a.shard.resolve()?;
    bars.say(format!(
        "shard {}/{} ({source}) of {} identities",
        shard.k, shard.n, spec.count
    ));
    let r = batch::run_shard(
        &a.out,
        &spec,
        shard,
        RunOptions {
            device: a.device.device,
            threads: a.threads,
        },
        bars,
    )?;
    bars.finish();
    bars.say(format!(
        "{} identities of this shard: {} made ({} unfinished directories of ended runs removed), \
         {} already complete, in {:.1} s",
        r.owned,
        r.made,
        r.resumed,
        r.skipped,
        t0.elapsed().as_secs_f64()
    ));
    Ok(())
}
