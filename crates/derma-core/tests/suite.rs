//! The integration tests of derma-core as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-core --test suite FILE::` runs one file's tests).

mod gltf_as_shipped;
#[cfg(feature = "gpu")]
mod gpu_limits;
mod robust_loaders;
mod robust_mesh_files;
mod shard;
