//! derma-batch: many faces from one spec (docs/batch.md). Identity i's person (skin tone, sex,
//! age), mesh and seed drawn from the spec's distributions by i alone ([`spec`]), painted by the
//! main job with its GLB (derma-export's `skin`) into its own directory, sharded over a cluster
//! job as precompute is (derma_core::shard) and resumable ([`run`]), and merged into a manifest
//! of one JSON line per identity ([`merge()`]); [`layout`] names the directory's files. A job
//! runner over the main job, on its own floor above the exporter it calls.

#![warn(missing_docs)]

pub mod error;
pub mod layout;
pub mod merge;
pub mod run;
pub mod spec;

pub use error::{BatchError, Result};
pub use layout::{prepare, IDENTITY_FILE, MANIFEST, SPEC_FILE};
pub use merge::{merge, Merged};
pub use run::{run_shard, RunOptions, ShardReport};
pub use spec::{dir_name, Appearance, BatchSpec, Identity, Sizes, STREAM};
