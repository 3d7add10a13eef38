//! The integration tests of derma-rig as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-rig --test suite FILE::` runs one file's tests).

mod placed;
mod rig;
mod robust_files;
mod robust_sets;
