//! Many faces from one spec (docs/batch.md): identity i's person (skin tone, sex, age), mesh and
//! seed drawn from the spec's distributions by i alone ([`spec`]), painted by the main job into
//! its own directory, sharded over a cluster job as precompute is (derma_core::shard) and
//! resumable ([`run`]), and merged into a manifest of one JSON line per identity ([`merge()`]);
//! [`layout`] names the directory's files.

pub mod layout;
pub mod merge;
pub mod run;
pub mod spec;

pub use layout::{prepare, IDENTITY_FILE, MANIFEST, SPEC_FILE};
pub use merge::{merge, Merged};
pub use run::{run_shard, RunOptions, ShardReport};
pub use spec::{dir_name, Appearance, BatchSpec, Identity, Sizes, STREAM};
